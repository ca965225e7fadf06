//! Torsional friction of the object's `condim="4"` contacts
//! ([`RapierSettings::torsional_friction`](super::RapierSettings::torsional_friction)),
//! which rapier's solver lacks: after each step, an angular impulse about each
//! contact normal against the object's spin relative to the touching body,
//! bounded by the torsional coefficient times the normal impulse.

use std::collections::HashMap;

use rapier3d::math::{Real, Vector};
use rapier3d::prelude::*;
use rapier3d_mjcf::MjcfRobot;
use rapier3d_mjcf::mjcf_rs::Model;

use super::RapierHand;

/// `(condim, torsional friction coefficient)` of each collider of a named geom,
/// by (body index, collider index in body).
pub(super) fn coefficients(robot: &MjcfRobot, model: &Model) -> HashMap<(usize, usize), (u32, f64)> {
    let mut geom_torsion = HashMap::new();
    for entry in &model.bodies {
        for g in &entry.body.geoms {
            if let Some(n) = &g.name {
                geom_torsion.insert(n.clone(), (g.condim, g.friction[1]));
            }
        }
    }
    robot.geom_name_to_collider.iter().filter_map(|(geom, key)| geom_torsion.get(geom).map(|t| (*key, *t))).collect()
}

impl RapierHand {
    /// [`RapierSettings::torsional_friction`](super::RapierSettings::torsional_friction): opposes the object's spin about
    /// each contact normal, relative to the touching body, by an angular impulse
    /// bounded by `mu_torsion` x the manifold's normal impulse (MuJoCo's
    /// `condim = 4` friction cone in its torsional direction).
    pub(super) fn apply_torsional_friction(&mut self) {
        let object_torsion = self.torsion.get(&self.object_collider).copied().unwrap_or((3, 0.0));
        let mut manifolds: Vec<(Vector, Real, Vector)> = Vec::new();
        let (colliders, bodies) = (&self.world.colliders, &self.world.bodies);
        for pair in self.world.narrow_phase.contact_pairs_with(self.object_collider) {
            let PairContacts::Rigid(rigid) = &pair.contacts else { continue };
            let other = if pair.collider1 == self.object_collider { pair.collider2 } else { pair.collider1 };
            let (condim, mu) = self.torsion.get(&other).copied().unwrap_or((3, 0.0));
            let mu = mu.max(object_torsion.1) as Real;
            if condim.max(object_torsion.0) < 4 || mu <= 0.0 {
                continue;
            }
            let (Some(c1), Some(c_other)) = (colliders.get(pair.collider1), colliders.get(other)) else { continue };
            let w_other = c_other.parent().and_then(|b| bodies.get(b)).map_or(Vector::ZERO, |b| b.angvel());
            for m in &rigid.manifolds {
                let normal_impulse: Real = m.points.iter().map(|p| p.data.impulse.max(0.0)).sum();
                if let Some(n) = torsion_axis(c1.position().rotation * m.local_n1)
                    && normal_impulse > 0.0
                {
                    manifolds.push((n, mu * normal_impulse, w_other));
                }
            }
        }
        let object = &mut self.world.bodies[self.object];
        for (n, limit, w_other) in manifolds {
            let spin = (object.angvel() - w_other).dot(n);
            let per_unit = n.dot(object.mass_properties().effective_world_inv_inertia * n);
            object.apply_torque_impulse(-n * torsional_impulse(spin, per_unit, limit), true);
        }
    }
}

/// The unit axis of torsional friction for a manifold normal, `None` when the
/// manifold carries no normal (a zero vector, which rapier can report).
fn torsion_axis(normal: Vector) -> Option<Vector> {
    let n = normal.normalize_or_zero();
    (n != Vector::ZERO).then_some(n)
}

/// The torsional friction impulse (about the contact normal, against the spin)
/// for a relative `spin` (rad/s) when a unit impulse changes the spin by
/// `per_unit`: what stops the spin, at most `limit` (`mu_torsion` x the normal
/// impulse); zero when the body cannot turn about the normal.
fn torsional_impulse(spin: Real, per_unit: Real, limit: Real) -> Real {
    if per_unit > 0.0 && limit > 0.0 { (spin / per_unit).clamp(-limit, limit) } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    // Regression (e08af39): a manifold without a normal made the torsion axis
    // NaN (normalising a zero vector), and the object's velocity with it.
    #[test]
    fn a_manifold_without_a_normal_has_no_torsion_axis() {
        assert_eq!(torsion_axis(Vector::ZERO), None);
        let n = torsion_axis(Vector::new(0.0, 3.0, 4.0)).unwrap();
        assert!((n.length() - 1.0).abs() < 1e-6 && n.is_finite());
    }

    proptest! {
        // Guards the torsional friction impulse: bounded by the friction limit,
        // against the spin, and never reversing it.
        #[test]
        fn the_torsional_impulse_is_bounded_and_never_reverses_the_spin(
            spin in -50.0f32..50.0, per_unit in 0.0f32..1e5, limit in 0.0f32..1e-3,
        ) {
            let j = torsional_impulse(spin, per_unit, limit);
            prop_assert!(j.abs() <= limit);
            prop_assert!(j * spin >= 0.0);
            let after = spin - j * per_unit;
            prop_assert!(after * spin >= -1e-4 * spin.abs().max(1.0));
        }
    }
}
