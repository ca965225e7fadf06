//! The J1/J0 coupling: `rapier3d-mjcf` couples the two joints of the
//! `T_xxJ1c` tendon as co-actuated (`q_k = (c_k / c_0) q_0`), which gives the
//! distal joint the wrong sign. That tendon is a length constraint, so the
//! coupling is `c_0 q_0 + c_k q_k = 0`, i.e. `q_k = -(c_0 / c_k) q_0`; every
//! coupling whose tendon has coefficients of opposite sign is rewritten that
//! way. Its range (`|c_0 q_0 + c_k q_k| <= 0.001`, about +-0.14 rad of the
//! distal joint) is the tendon's **slack**
//! ([`RapierSettings::tendon_slack`](super::RapierSettings::tendon_slack)): the
//! coupling holds only at the ends of the range.

use rapier3d::dynamics::{Multibody, MultibodyDofCoupling};
use rapier3d::math::Real;
use rapier3d::prelude::*;
use rapier3d_mjcf::mjcf_rs::Model;
use rapier3d_mjcf::{MjcfRobot, MjcfRobotHandles};

use super::super::model::fixed_tendon_ranges;
use super::RapierHand;
use crate::error::EnvError;

/// A J1/J0 coupling `q2 = coeff q1 + offset` whose tendon allows slack: the
/// offset may lie anywhere in `band` (the tendon's length range over `c2`).
#[derive(Debug, Clone, Copy)]
pub(super) struct TendonSlack {
    /// `MjcfRobot::joints` index of the coupling's first joint.
    joint1: usize,
    /// `MjcfRobot::joints` index of its second joint.
    joint2: usize,
    band: [Real; 2],
}

/// A slack coupling in the world: the multibody coupling it installs when it
/// engages, and its band.
#[derive(Debug, Clone, Copy)]
pub(super) struct SlackCoupling {
    joint1: MultibodyJointHandle,
    coupling: MultibodyDofCoupling,
    band: [Real; 2],
}

/// Rewrites the sign of every J1/J0 coupling of `robot` whose tendon (in
/// `xml`, parsed as `model`) is a length constraint, and returns the slack of
/// those whose tendon has a length range.
pub(super) fn fix_couplings(robot: &mut MjcfRobot, model: &Model, xml: &str) -> Result<Vec<TendonSlack>, EnvError> {
    let tendon_ranges = fixed_tendon_ranges(xml)?;
    let mut slack = Vec::new();
    for c in &mut robot.joint_couplings {
        let (Some(n1), Some(n2)) = (robot.joints[c.joint1].name.as_deref(), robot.joints[c.joint2].name.as_deref())
        else {
            continue;
        };
        let tendon = model
            .tendons
            .iter()
            .find(|t| t.joints.iter().any(|tj| tj.joint == n1) && t.joints.iter().any(|tj| tj.joint == n2));
        if let Some(t) = tendon {
            let coef = |n: &str| t.joints.iter().find(|tj| tj.joint == n).map_or(0.0, |tj| tj.coef);
            let (c1, c2) = (coef(n1), coef(n2));
            if c1 * c2 < 0.0 {
                c.coeff = (-(c1 / c2)) as Real;
                // Length `c1 q1 + c2 q2 = c2 (q2 - coeff q1) = c2 offset`.
                if let Some([lo, hi]) = t.name.as_ref().and_then(|n| tendon_ranges.get(n)) {
                    let (a, b) = ((lo / c2) as Real, (hi / c2) as Real);
                    slack.push(TendonSlack { joint1: c.joint1, joint2: c.joint2, band: [a.min(b), a.max(b)] });
                }
            }
        }
    }
    Ok(slack)
}

/// Takes the couplings of `slack` out of the world's multibodies (they are
/// installed again, step by step, by [`RapierHand::engage_tendon_limits`]).
pub(super) fn take_slack_couplings(
    world: &mut PhysicsWorld,
    handles: &MjcfRobotHandles<Option<MultibodyJointHandle>>,
    slack: &[TendonSlack],
) -> Vec<SlackCoupling> {
    let mut out = Vec::new();
    for s in slack {
        let (Some(h1), Some(h2)) = (handles.joints[s.joint1].joint, handles.joints[s.joint2].joint) else { continue };
        let Some(link2) = world.multibody_joints.get(h2).map(|(_, l)| l) else { continue };
        let Some((mb, link1)) = world.multibody_joints.get_mut(h1) else { continue };
        let Some(i) = mb.couplings().iter().position(|c| c.link1 == link1 && c.link2 == link2) else { continue };
        if let Some(coupling) = mb.remove_dof_coupling(i) {
            out.push(SlackCoupling { joint1: h1, coupling, band: s.band });
        }
    }
    out
}

/// `(q2 - coeff q1, its rate)` of a coupling's two joints.
fn coupling_offset(mb: &Multibody, c: &MultibodyDofCoupling) -> Option<(Real, Real)> {
    let (l1, l2) = (mb.link(c.link1)?, mb.link(c.link2)?);
    let (v1, v2) = (mb.joint_velocity(l1), mb.joint_velocity(l2));
    let q = l2.joint().coords()[c.axis2] - c.coeff * l1.joint().coords()[c.axis1];
    let rate = v2.get(c.dof2).copied()? - c.coeff * v1.get(c.dof1).copied()?;
    Some((q, rate))
}

/// How far past an end of its band a slack coupling's offset may be predicted
/// before the coupling engages (rad). Without it, a coupling held exactly at
/// its end would never be released.
const SLACK_TOLERANCE: Real = 1e-3;

/// The end of `band` at which a slack coupling engages, when its offset is
/// predicted to lie beyond it (by more than [`SLACK_TOLERANCE`]) after the next
/// step; `None` while the offset stays inside, where the joints move freely.
fn tendon_limit(predicted: Real, band: [Real; 2]) -> Option<Real> {
    if predicted > band[1] + SLACK_TOLERANCE {
        Some(band[1])
    } else if predicted < band[0] - SLACK_TOLERANCE {
        Some(band[0])
    } else {
        None
    }
}

impl RapierHand {
    /// [`RapierSettings::tendon_slack`](super::RapierSettings::tendon_slack): before each rapier step, installs the
    /// coupling of each slack tendon at the end of its band that the coupled
    /// joints would cross within the step, and takes it out otherwise.
    pub(super) fn engage_tendon_limits(&mut self) {
        let dt = self.world.integration_parameters.dt;
        for s in &self.slack {
            let Some((mb, _)) = self.world.multibody_joints.get_mut(s.joint1) else { continue };
            let c = s.coupling;
            mb.retain_dof_couplings(|k| (k.link1, k.dof1, k.link2, k.dof2) != (c.link1, c.dof1, c.link2, c.dof2));
            let Some((offset, rate)) = coupling_offset(mb, &c) else { continue };
            if let Some(end) = tendon_limit(offset + rate * dt, s.band) {
                mb.add_dof_coupling(MultibodyDofCoupling { offset: end, ..c });
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    proptest! {
        // Guards the tendon slack rule: a coupling engages only when its offset
        // leaves the band, and then at the end it crossed.
        #[test]
        fn a_slack_coupling_engages_only_outside_its_band_at_the_end_it_crossed(
            lo in -1.0f32..0.0, width in 0.0f32..1.0, predicted in -3.0f32..3.0,
        ) {
            let band = [lo, lo + width];
            match tendon_limit(predicted, band) {
                None => prop_assert!(predicted >= band[0] - SLACK_TOLERANCE && predicted <= band[1] + SLACK_TOLERANCE),
                Some(end) if predicted > band[1] => prop_assert_eq!(end, band[1]),
                Some(end) => { prop_assert!(predicted < band[0]); prop_assert_eq!(end, band[0]); }
            }
        }
    }
}
