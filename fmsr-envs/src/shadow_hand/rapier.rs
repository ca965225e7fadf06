//! The rapier3d backend of the Shadow Hand: `rapier3d-mjcf` loads the model,
//! and this module fixes what it leaves out (docs/design.md 4):
//!
//! - **includes** inside `<worldbody>`/`<asset>` are inlined first ([`super::model::inline_includes`]);
//! - **contact filtering** follows MuJoCo's `(contype1 & conaffinity2) || (contype2 & conaffinity1)`:
//!   the distinct `(contype, conaffinity)` classes of the model's geoms get one
//!   collision-group bit each, and each class's filter holds the classes it collides
//!   with under MuJoCo's rule. A symmetric relation over at most 32 classes is encoded
//!   exactly by rapier's AND test, so no physics hook runs for them (contact recycling stays on);
//! - the **J1/J0 coupling**: the loader couples the two joints of the `T_xxJ1c`
//!   tendon as co-actuated (`q_k = (c_k / c_0) q_0`), which gives the distal joint
//!   the wrong sign. That tendon is a length constraint, so the coupling is
//!   `c_0 q_0 + c_k q_k = 0`, i.e. `q_k = -(c_0 / c_k) q_0`; we rewrite every
//!   coupling whose tendon has coefficients of opposite sign that way. Its range
//!   (`|c_0 q_0 + c_k q_k| <= 0.001`, i.e. +-0.14 rad of the distal joint) is the
//!   tendon's **slack** ([`RapierSettings::tendon_slack`]): the coupling holds
//!   only at the ends of the range;
//! - the **target** body is a ghost: it gets no collider and is fixed;
//! - the **object's** mass and inertia are set explicitly to MuJoCo's (box: from
//!   its density 567; egg: the solid ellipsoid of density 1000, collided as the
//!   convex hull of 1106 points on the ellipsoid, in place of the loader's 12-vertex hull), and its free-joint damping 0.01 becomes
//!   rapier body damping `0.01 / m` (linear) and `0.01 / I` (angular);
//! - **touch sensors**: each `robot0:TS_*` site box on its body reads the summed
//!   normal force (impulse / dt) of the object's contact points inside it, averaged
//!   over the substeps of one [`HandPhysics::step`].
//!
//! - the 19 **`<contact><pair>`**s of `shared.xml` (finger-finger and finger-thumb,
//!   which MuJoCo collides regardless of `contype`): their colliders share one more
//!   group bit, and a physics hook on those colliders drops the pairs that only that
//!   bit admitted and are not listed.
//!
//! - **touch sensors read every contact** of their body inside their box, finger
//!   on finger included, as MuJoCo's do ([`RapierSettings::touch_every_contact`]);
//! - **torsional friction** of the object's `condim="4"` contacts
//!   ([`RapierSettings::torsional_friction`]), which rapier's solver lacks: an
//!   angular impulse after each step, bounded by the friction coefficient times
//!   the normal impulse.
//!
//! Not modelled: the pairs' `condim="1"` (they keep friction), the other tendon
//! limits (the J1+J0 sums of `T_xxJ1u/d`, which the joint ranges never reach), MuJoCo's
//! soft-contact `solref`/`solimp` and geom `margin`.

use std::collections::HashMap;
use std::path::Path;
use std::sync::Arc;

use rapier3d::dynamics::{Multibody, MultibodyDofCoupling};
use rapier3d::math::{Pose, Real, Rotation, Vector};
use rapier3d::prelude::*;
use rapier3d_mjcf::{MjcfLoaderOptions, MjcfMultibodyOptions, MjcfRobot, MjcfRobotHandles};
use serde::{Deserialize, Serialize};

use fmsr_core::env::{ContactPoint, ObjectContacts};

use super::assets::HandAssets;
use super::model::{
    ACTUATORS, HAND_JOINTS, HandObject, NUM_TOUCH, PREFIX, TouchSensorSite, fixed_tendon_ranges, inline_includes,
    touch_sensor_sites,
};
use super::physics::HandPhysics;
use crate::error::EnvError;

/// Solver settings of the rapier backend (the speed/fidelity trade-off).
///
/// The task always advances the model's time (`substeps` x 0.002 s = 0.04 s per
/// env step); `timestep` is the length of one rapier step within it, so
/// `timestep = 0.008` covers an env step with 5 rapier steps. Each rapier step
/// (and each of its `solver_iterations`) rebuilds the multibody mass matrix, which
/// dominates the cost, while `pgs_iterations` add solver passes without that
/// rebuild. Measured against MuJoCo 3.17 on the block (settings table in
/// `tests/shadow_hand_settings.rs` and the closing note of issue 4):
///
/// | timestep | solver it. | PGS it. | rest z (m) | tracking (rad) | active touch | env steps/s |
/// |---|---|---|---|---|---|---|
/// | MuJoCo 0.002 x 20 | - | - | 0.1661 | 0.057 | 5.15 | 1563 |
/// | 0.002 | 4 | 1 | 0.1661 | 0.085 | 3.23 | 56 |
/// | 0.002 | 2 | 1 | 0.1661 | 0.074 | 3.32 | 101 |
/// | 0.002 | 1 | 1 | 0.1664 | 0.069 | 3.25 | 182 |
/// | 0.004 | 1 | 4 | 0.1663 | 0.073 | 3.38 | 339 |
/// | 0.008 | 2 | 1 | 0.1662 | 0.066 | 3.42 | 391 |
/// | **0.008** (default) | **1** | **4** | 0.1660 | 0.058 | 3.88 | 649 |
/// | 0.0133 | 1 | 4 | 0.1663 | 0.046 | 4.38 | 1052 |
/// | 0.02 | 1 | 4 | 0.1665 | 0.038 | 4.94 | 1563 |
///
/// (tracking: mean `|q - ctrl|` of the 20 actuated joints after 1 s at `a = +-0.5`;
/// active touch: mean active sensors per step over 20 episodes of random actions,
/// none of which dropped the block in any row; steps/s with random actions on one
/// core of a 2-core machine shared with other builds, load average 4-5, so only
/// the ratios between rows mean much.) The default is the setting closest to
/// MuJoCo's rest height and tracking error, at ~6x the speed of `fine()`.
/// (The active-touch column predates [`RapierSettings::touch_every_contact`]:
/// the sensors then read only the object's contacts. With every contact, as
/// MuJoCo counts them, random actions give 5.20 active sensors a step against
/// MuJoCo's 4.86; `examples/engine_parity.rs` measures both fidelity settings
/// against MuJoCo, and `docs/results.md` holds its table.)
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RapierSettings {
    /// Physics timestep (s); MuJoCo's model uses 0.002.
    pub timestep: f64,
    /// `IntegrationParameters::num_solver_iterations` (rapier's substeps).
    pub solver_iterations: usize,
    /// `IntegrationParameters::num_internal_pgs_iterations`.
    pub pgs_iterations: usize,
    /// `IntegrationParameters::num_internal_stabilization_iterations`.
    pub stabilization_iterations: usize,
    /// Distance below which contacts are predicted (m).
    pub prediction_distance: f64,
    /// Reuse contacts of pairs that barely moved (`IntegrationParameters::contact_recycling`).
    pub contact_recycling: bool,
    /// Touch sensors read every contact of their body inside their box, as
    /// MuJoCo's do (finger on finger included), not only the object's contacts.
    pub touch_every_contact: bool,
    /// Torsional friction of `condim >= 4` contacts (the object's `condim="4"`):
    /// after each step, the spin of the object about each contact normal
    /// relative to the touching body is opposed by an angular impulse of at most
    /// `mu_torsion` x the contact's normal impulse (MuJoCo's second friction
    /// coefficient, 0.005 m here), never more than stops that spin.
    pub torsional_friction: bool,
    /// The J1/J0 tendon's slack: the coupled distal joint moves freely while the
    /// tendon length `c_0 q_0 + c_k q_k` is inside its range (+-0.001 m, about
    /// +-0.14 rad of J0), and the coupling engages at the ends of the range, as
    /// MuJoCo's tendon limit does. Off: the coupling is an equality at length 0.
    pub tendon_slack: bool,
}

impl Default for RapierSettings {
    fn default() -> Self {
        Self {
            timestep: 0.008,
            solver_iterations: 1,
            pgs_iterations: 4,
            stabilization_iterations: 1,
            prediction_distance: 0.002,
            contact_recycling: true,
            touch_every_contact: true,
            torsional_friction: true,
            tendon_slack: true,
        }
    }
}

impl RapierSettings {
    /// MuJoCo's own step (0.002 s) with 2 solver iterations: about 6x slower than
    /// the default, for comparisons.
    #[must_use]
    pub fn fine() -> Self {
        Self { timestep: 0.002, solver_iterations: 2, pgs_iterations: 1, ..Self::default() }
    }

    /// The default solver without the fidelity settings: touch sensors read
    /// only the object's contacts, contacts have no torsional friction and the
    /// J1/J0 coupling has no slack (how every run before issue 11's fidelity work
    /// was simulated), for comparisons.
    ///
    /// ```
    /// use fmsr_envs::shadow_hand::RapierSettings;
    /// let before = RapierSettings::without_fidelity();
    /// assert!(!before.touch_every_contact && !before.torsional_friction && !before.tendon_slack);
    /// assert_eq!(before.timestep, RapierSettings::default().timestep);
    /// ```
    #[must_use]
    pub fn without_fidelity() -> Self {
        Self { touch_every_contact: false, torsional_friction: false, tendon_slack: false, ..Self::default() }
    }
}

/// One touch sensor: a box on a body.
#[derive(Debug, Clone)]
struct TouchSite {
    /// Rapier body index in `MjcfRobot::bodies`.
    body: usize,
    /// The site's pose in the body frame.
    pose: Pose,
    half: Vector,
}

/// A J1/J0 coupling `q2 = coeff q1 + offset` whose tendon allows slack: the
/// offset may lie anywhere in `band` (the tendon's length range over `c2`).
#[derive(Debug, Clone, Copy)]
struct TendonSlack {
    /// `MjcfRobot::joints` index of the coupling's first joint.
    joint1: usize,
    /// `MjcfRobot::joints` index of its second joint.
    joint2: usize,
    band: [Real; 2],
}

/// A slack coupling in the world: the multibody coupling it installs when it
/// engages, and its band.
#[derive(Debug, Clone, Copy)]
struct SlackCoupling {
    joint1: MultibodyJointHandle,
    coupling: MultibodyDofCoupling,
    band: [Real; 2],
}

/// The model loaded from disk once; shared by every env built from it.
#[derive(Debug)]
pub struct RapierHandModel {
    robot: MjcfRobot,
    object: HandObject,
    /// `MjcfRobot::joints` index of each of [`HAND_JOINTS`].
    joints: Vec<usize>,
    ctrl_range: Vec<[f64; 2]>,
    touch_names: Vec<String>,
    touch_sites: Vec<TouchSite>,
    object_body: usize,
    object_pos0: Vector,
    palm_body: usize,
    palm_center_local: Vector,
    /// Collision groups per (body index, collider index in body).
    groups: HashMap<(usize, usize), InteractionGroups>,
    /// The `<contact><pair>` geoms, as (body index, collider index in body).
    pairs: Vec<((usize, usize), (usize, usize))>,
    /// `(condim, torsional friction coefficient)` per (body index, collider index in body).
    torsion: HashMap<(usize, usize), (u32, f64)>,
    /// The couplings whose tendon has a length range.
    slack: Vec<TendonSlack>,
    gravity: Vector,
    /// The model's `<option timestep>` (0.002 s).
    model_timestep: f64,
}

fn name_of(s: &str) -> String {
    format!("{PREFIX}{s}")
}

impl RapierHandModel {
    /// Loads the scene of `object` from the fetched assets and applies our fixes.
    pub fn load(assets: &HandAssets, object: HandObject) -> Result<Self, EnvError> {
        let scene = assets.scene(object.file_stem());
        let xml = inline_includes(&scene)?;
        let base = assets.hand_dir();
        Self::from_xml(&xml, &base, object)
    }

    fn from_xml(xml: &str, base: &Path, object: HandObject) -> Result<Self, EnvError> {
        let options = MjcfLoaderOptions::default();
        let (mut robot, model) =
            MjcfRobot::from_str(xml, options, base).map_err(|e| EnvError::Model(format!("rapier3d-mjcf: {e:#}")))?;
        let missing = |what: &str, name: &str| EnvError::Model(format!("no {what} named {name}"));

        // Hand joints in MuJoCo's qpos order.
        let joints = HAND_JOINTS
            .iter()
            .map(|j| robot.joint_name_to_idx.get(&name_of(j)).copied().ok_or_else(|| missing("joint", &name_of(j))))
            .collect::<Result<Vec<_>, _>>()?;

        // Actuators: the 20 position servos.
        if robot.actuators.len() != ACTUATORS.len() {
            return Err(EnvError::Model(format!("{} actuators, expected {}", robot.actuators.len(), ACTUATORS.len())));
        }
        let mut ctrl_range = Vec::with_capacity(ACTUATORS.len());
        for (binding, expected) in robot.actuators.iter().zip(ACTUATORS) {
            let a = &binding.actuator;
            if a.name.as_deref() != Some(&format!("{PREFIX}A_{expected}")) || binding.joint_index.is_none() {
                return Err(EnvError::Model(format!("actuator {:?} is not A_{expected} on a joint", a.name)));
            }
            let range = a.ctrl_range.ok_or_else(|| EnvError::Model(format!("{:?} has no ctrlrange", a.name)))?;
            ctrl_range.push([range[0], range[1]]);
        }

        // J1/J0 coupling sign, and its slack (see the module docs).
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

        // Geoms by name, from the parsed model.
        let mut geom_classes = HashMap::new();
        let mut geom_torsion = HashMap::new();
        for entry in &model.bodies {
            for g in &entry.body.geoms {
                if let Some(n) = &g.name {
                    geom_classes.insert(n.clone(), (g.contype, g.conaffinity));
                    geom_torsion.insert(n.clone(), (g.condim, g.friction[1]));
                }
            }
        }

        // Touch sensors: their site boxes on the rapier bodies.
        let mut touch_names = Vec::new();
        let mut touch_sites = Vec::new();
        for TouchSensorSite { name, body, site } in touch_sensor_sites(&model)? {
            let body_name = model.bodies[body].body.name.clone().unwrap_or_default();
            let body = *robot.body_name_to_idx.get(&body_name).ok_or_else(|| missing("body", &body_name))?;
            let t = site.pose.translation;
            let q = site.pose.rotation;
            touch_sites.push(TouchSite {
                body,
                pose: Pose::from_parts(
                    Vector::new(t.x as Real, t.y as Real, t.z as Real),
                    Rotation::from_xyzw(q.x as Real, q.y as Real, q.z as Real, q.w as Real).normalize(),
                ),
                half: Vector::new(site.size[0] as Real, site.size[1] as Real, site.size[2] as Real),
            });
            touch_names.push(name);
        }

        // Contact classes (see the module docs).
        let mut classes: Vec<(u32, u32)> = Vec::new();
        let mut collider_class = HashMap::new();
        for (geom, &(body, col)) in &robot.geom_name_to_collider {
            let Some(&(ct, ca)) = geom_classes.get(geom) else { continue };
            let k = classes.iter().position(|&c| c == (ct, ca)).unwrap_or_else(|| {
                classes.push((ct, ca));
                classes.len() - 1
            });
            collider_class.insert((body, col), k);
        }
        // The ground we add is MuJoCo's default plane geom: contype = conaffinity = 1.
        let ground_class = classes.iter().position(|&c| c == (1, 1)).unwrap_or_else(|| {
            classes.push((1, 1));
            classes.len() - 1
        });
        if classes.len() > 31 {
            return Err(EnvError::Model(format!("{} contact classes, at most 31 supported", classes.len())));
        }
        let collide = |a: (u32, u32), b: (u32, u32)| (a.0 & b.1) != 0 || (b.0 & a.1) != 0;
        let class_groups: Vec<InteractionGroups> = classes
            .iter()
            .map(|&a| {
                let member = 1u32 << classes.iter().position(|&c| c == a).unwrap_or(0);
                let filter = classes
                    .iter()
                    .enumerate()
                    .filter(|&(_, &b)| collide(a, b))
                    .fold(0u32, |acc, (j, _)| acc | (1 << j));
                InteractionGroups::new(Group::from(member), Group::from(filter), InteractionTestMode::And)
            })
            .collect();
        let mut groups: HashMap<(usize, usize), InteractionGroups> =
            collider_class.into_iter().map(|(key, k)| (key, class_groups[k])).collect();
        groups.insert((usize::MAX, 0), class_groups[ground_class]);
        let pairs = robot
            .contact_pairs
            .iter()
            .filter_map(|p| {
                let a = robot.geom_name_to_collider.get(&p.geom1)?;
                let b = robot.geom_name_to_collider.get(&p.geom2)?;
                Some((*a, *b))
            })
            .collect::<Vec<_>>();
        let torsion = robot
            .geom_name_to_collider
            .iter()
            .filter_map(|(geom, key)| geom_torsion.get(geom).map(|t| (*key, *t)))
            .collect();
        if pairs.len() != robot.contact_pairs.len() {
            return Err(EnvError::Model("a <contact><pair> names a geom without a collider".into()));
        }

        // Target: a ghost.
        let target = *robot.body_name_to_idx.get("target").ok_or_else(|| missing("body", "target"))?;
        robot.bodies[target].colliders.clear();
        let target_pose = *robot.bodies[target].body.position();
        robot.bodies[target].body = RigidBodyBuilder::fixed().pose(target_pose).build();

        // Object: MuJoCo's mass, inertia and damping.
        let object_body = *robot.body_name_to_idx.get("object").ok_or_else(|| missing("body", "object"))?;
        let (mass, inertia) = match object {
            // Box of side 0.05 m and density 567 kg/m^3.
            HandObject::Block => {
                let m = 567.0 * 0.05f64.powi(3);
                (m, [m * (0.05f64.powi(2) * 2.0) / 12.0; 3])
            }
            // Solid ellipsoid of semi-axes (0.03, 0.03, 0.04), density 1000 kg/m^3.
            HandObject::Egg => {
                let (a, b, c) = (0.03f64, 0.03f64, 0.04f64);
                let m = 1000.0 * 4.0 / 3.0 * std::f64::consts::PI * a * b * c;
                (m, [m * (b * b + c * c) / 5.0, m * (a * a + c * c) / 5.0, m * (a * a + b * b) / 5.0])
            }
        };
        let obj = &mut robot.bodies[object_body];
        for c in &mut obj.colliders {
            c.set_density(0.0);
        }
        if object == HandObject::Egg {
            // The loader's ellipsoid is the hull of a 12-vertex icosphere (it rests 7 mm
            // low); use the hull of a 24 x 48 latitude-longitude sampling instead.
            let shape = SharedShape::convex_hull(&ellipsoid_points([0.03, 0.03, 0.04], 24, 48))
                .ok_or_else(|| EnvError::Model("convex hull of the egg failed".into()))?;
            if let Some(c) = obj.colliders.first_mut() {
                c.set_shape(shape);
            }
        }
        obj.body.set_additional_mass_properties(
            MassProperties::new(
                Vector::ZERO,
                mass as Real,
                Vector::new(inertia[0] as Real, inertia[1] as Real, inertia[2] as Real),
            ),
            false,
        );
        obj.body.set_linear_damping((0.01 / mass) as Real);
        let mean_inertia = (inertia[0] + inertia[1] + inertia[2]) / 3.0;
        obj.body.set_angular_damping((0.01 / mean_inertia) as Real);
        let object_pos0 = obj.body.translation();

        // Palm centre: the centroid of the palm's touch sites, in the palm frame.
        let palm_body = *robot.body_name_to_idx.get(&name_of("palm")).ok_or_else(|| missing("body", "palm"))?;
        let palm_sites: Vec<&TouchSite> = touch_sites.iter().filter(|s| s.body == palm_body).collect();
        let palm_center_local = if palm_sites.is_empty() {
            Vector::ZERO
        } else {
            palm_sites.iter().map(|s| s.pose.translation).sum::<Vector>() / palm_sites.len() as Real
        };

        let gravity = robot.gravity;
        let model_timestep = model.option.timestep;
        Ok(Self {
            robot,
            object,
            joints,
            ctrl_range,
            touch_names,
            touch_sites,
            object_body,
            object_pos0,
            palm_body,
            palm_center_local,
            groups,
            pairs,
            torsion,
            slack,
            gravity,
            model_timestep,
        })
    }

    /// Which object the scene holds.
    #[must_use]
    pub fn object(&self) -> HandObject {
        self.object
    }

    /// Number of hand joints found (24).
    #[must_use]
    pub fn num_hand_joints(&self) -> usize {
        self.joints.len()
    }

    /// The object's initial position in the model.
    #[must_use]
    pub fn object_initial_position(&self) -> [f64; 3] {
        let p = self.object_pos0;
        [f64::from(p.x), f64::from(p.y), f64::from(p.z)]
    }
}

/// The rapier3d Shadow Hand scene; see the [module docs](self).
pub struct RapierHand {
    model: Arc<RapierHandModel>,
    settings: RapierSettings,
    world: PhysicsWorld,
    handles: MjcfRobotHandles<Option<MultibodyJointHandle>>,
    /// Rapier body handle per `MjcfRobot::bodies` index (`None` for the world).
    body_handles: Vec<Option<RigidBodyHandle>>,
    /// Sensors on each body.
    sensors_of_body: HashMap<RigidBodyHandle, Vec<usize>>,
    object: RigidBodyHandle,
    object_collider: ColliderHandle,
    palm: RigidBodyHandle,
    /// (multibody joint handle, free axis) of each hand joint.
    joint_dofs: Vec<(MultibodyJointHandle, usize)>,
    hooks: PairHooks,
    /// `(condim, torsional friction coefficient)` of each collider of the model.
    torsion: HashMap<ColliderHandle, (u32, f64)>,
    /// The slack couplings, taken out of the multibody ([`RapierSettings::tendon_slack`]).
    slack: Vec<SlackCoupling>,
    ctrl: Vec<Real>,
    touch_sum: Vec<f64>,
    touch: Vec<f64>,
}

impl std::fmt::Debug for RapierHand {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RapierHand").field("object", &self.model.object).field("settings", &self.settings).finish()
    }
}

impl RapierHand {
    /// Builds the scene from a loaded model.
    pub fn new(model: Arc<RapierHandModel>, settings: RapierSettings) -> Result<Self, EnvError> {
        if !(settings.timestep.is_finite() && settings.timestep > 0.0) || settings.solver_iterations == 0 {
            return Err(EnvError::InvalidConfig {
                key: "rapier",
                reason: "timestep must be positive and solver_iterations at least 1".into(),
            });
        }
        let mut hand = Self::build(model, settings);
        hand.reset();
        Ok(hand)
    }

    fn build(model: Arc<RapierHandModel>, settings: RapierSettings) -> Self {
        let mut world = PhysicsWorld::new();
        world.gravity = model.gravity;
        let p = &mut world.integration_parameters;
        p.dt = settings.timestep as Real;
        p.num_solver_iterations = settings.solver_iterations;
        p.num_internal_pgs_iterations = settings.pgs_iterations;
        p.num_internal_stabilization_iterations = settings.stabilization_iterations;
        p.normalized_prediction_distance = settings.prediction_distance as Real;
        p.contact_recycling = settings.contact_recycling;
        // Contacts are read from the manifolds (touch sensors, read-out).
        p.contact_clustering = false;
        let handles = model.robot.clone().insert_using_multibody_joints(
            &mut world.bodies,
            &mut world.colliders,
            &mut world.multibody_joints,
            &mut world.impulse_joints,
            MjcfMultibodyOptions::default(),
        );
        let body_handles: Vec<Option<RigidBodyHandle>> =
            handles.bodies.iter().map(|b| b.as_ref().map(|b| b.body)).collect();
        for (bi, b) in handles.bodies.iter().enumerate() {
            let Some(b) = b else { continue };
            for (ci, c) in b.colliders.iter().enumerate() {
                if let (Some(g), Some(col)) = (model.groups.get(&(bi, ci)), world.colliders.get_mut(c.handle)) {
                    col.set_collision_groups(*g);
                }
            }
        }
        // `<contact><pair>`: the pair's colliders share PAIR_BIT, and the hook keeps,
        // among the pairs that bit lets through, only the listed ones.
        let mut hooks = PairHooks::default();
        let collider_of =
            |(b, c): (usize, usize)| handles.bodies[b].as_ref().and_then(|b| b.colliders.get(c)).map(|c| c.handle);
        for &(a, b) in &model.pairs {
            let (Some(a), Some(b)) = (collider_of(a), collider_of(b)) else { continue };
            hooks.pairs.insert((a, b));
            hooks.pairs.insert((b, a));
            for h in [a, b] {
                if let Some(col) = world.colliders.get_mut(h) {
                    let g = col.collision_groups();
                    col.set_collision_groups(InteractionGroups::new(
                        g.memberships | PAIR_BIT,
                        g.filter | PAIR_BIT,
                        InteractionTestMode::And,
                    ));
                    col.set_active_hooks(col.active_hooks() | ActiveHooks::FILTER_CONTACT_PAIRS);
                }
            }
        }
        // Ground plane at z = 0 (the scene's floor, which the loader skips).
        let ground = world.bodies.insert(RigidBodyBuilder::fixed());
        let ground_groups = model.groups[&(usize::MAX, 0)];
        world.colliders.insert_with_parent(
            ColliderBuilder::cuboid(5.0, 5.0, 0.5)
                .translation(Vector::new(1.0, 1.0, -0.5))
                .collision_groups(ground_groups),
            ground,
            &mut world.bodies,
        );
        let mut sensors_of_body: HashMap<RigidBodyHandle, Vec<usize>> = HashMap::new();
        for (i, s) in model.touch_sites.iter().enumerate() {
            if let Some(h) = body_handles[s.body] {
                sensors_of_body.entry(h).or_default().push(i);
            }
        }
        let object = body_handles[model.object_body].expect("object body is inserted");
        let object_collider = handles.bodies[model.object_body]
            .as_ref()
            .and_then(|b| b.colliders.first())
            .map(|c| c.handle)
            .expect("object has a collider");
        let palm = body_handles[model.palm_body].expect("palm body is inserted");
        let joint_dofs = model
            .joints
            .iter()
            .map(|&j| {
                let h = handles.joints[j].joint.expect("hand joints are multibody joints");
                let (mb, link) = world.multibody_joints.get(h).expect("joint exists");
                let locked = mb.link(link).expect("link exists").joint().data.locked_axes.bits();
                let axis = (0..6).find(|a| locked & (1 << a) == 0).unwrap_or(3);
                (h, axis)
            })
            .collect();
        let n_act = model.ctrl_range.len();
        let torsion = model.torsion.iter().filter_map(|(&key, &t)| collider_of(key).map(|h| (h, t))).collect();
        let slack =
            if settings.tendon_slack { take_slack_couplings(&mut world, &handles, &model.slack) } else { Vec::new() };
        Self {
            settings,
            world,
            handles,
            body_handles,
            sensors_of_body,
            object,
            object_collider,
            palm,
            joint_dofs,
            hooks,
            torsion,
            slack,
            ctrl: vec![0.0; n_act],
            touch_sum: vec![0.0; NUM_TOUCH],
            touch: vec![0.0; NUM_TOUCH],
            model,
        }
    }

    /// The settings in use.
    #[must_use]
    pub fn settings(&self) -> RapierSettings {
        self.settings
    }

    /// The rapier world (read-only), e.g. for rendering or inspection.
    #[must_use]
    pub fn world(&self) -> &PhysicsWorld {
        &self.world
    }

    /// Calls `f(point, normal into the object, normal impulse, other body)` for
    /// every active contact point of the object.
    fn for_each_object_contact(&self, mut f: impl FnMut(Vector, Vector, Real, Option<RigidBodyHandle>)) {
        let colliders = &self.world.colliders;
        for pair in self.world.narrow_phase.contact_pairs_with(self.object_collider) {
            let object_is_1 = pair.collider1 == self.object_collider;
            let other =
                colliders.get(if object_is_1 { pair.collider2 } else { pair.collider1 }).and_then(|c| c.parent());
            for_each_point(colliders, pair, |n1, p, impulse| f(p, if object_is_1 { -n1 } else { n1 }, impulse, other));
        }
    }

    /// Calls `f(point, normal impulse, body1, body2)` for every active contact
    /// point of the scene.
    fn for_each_contact(&self, mut f: impl FnMut(Vector, Real, Option<RigidBodyHandle>, Option<RigidBodyHandle>)) {
        let colliders = &self.world.colliders;
        for pair in self.world.narrow_phase.contact_pairs() {
            let parent = |h| colliders.get(h).and_then(|c: &Collider| c.parent());
            let (b1, b2) = (parent(pair.collider1), parent(pair.collider2));
            for_each_point(colliders, pair, |_, p, impulse| f(p, impulse, b1, b2));
        }
    }

    /// Adds the normal forces of this step's contacts to the touch sensors whose
    /// box holds them: every contact of the sensor's body
    /// ([`RapierSettings::touch_every_contact`], MuJoCo's rule), or only the object's.
    fn accumulate_touch(&mut self) {
        let dt = self.world.integration_parameters.dt;
        let mut hits: Vec<(usize, f64)> = Vec::new();
        let bodies = &self.world.bodies;
        let mut read = |p: Vector, impulse: Real, body: RigidBodyHandle| {
            let (Some(sensors), Some(rb)) = (self.sensors_of_body.get(&body), bodies.get(body)) else { return };
            let local_body = rb.position().inverse_transform_point(p);
            for &i in sensors {
                let s = &self.model.touch_sites[i];
                let q = s.pose.inverse_transform_point(local_body).abs();
                if q.x <= s.half.x && q.y <= s.half.y && q.z <= s.half.z {
                    hits.push((i, f64::from(impulse / dt)));
                }
            }
        };
        if self.settings.touch_every_contact {
            self.for_each_contact(|p, impulse, b1, b2| {
                for body in [b1, b2].into_iter().flatten() {
                    read(p, impulse, body);
                }
            });
        } else {
            self.for_each_object_contact(|p, _n, impulse, other| {
                if let Some(other) = other {
                    read(p, impulse, other);
                }
            });
        }
        for (i, f) in hits {
            self.touch_sum[i] += f;
        }
    }

    /// [`RapierSettings::torsional_friction`]: opposes the object's spin about
    /// each contact normal, relative to the touching body, by an angular impulse
    /// bounded by `mu_torsion` x the manifold's normal impulse (MuJoCo's
    /// `condim = 4` friction cone in its torsional direction).
    fn apply_torsional_friction(&mut self) {
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

    /// [`RapierSettings::tendon_slack`]: before each rapier step, installs the
    /// coupling of each slack tendon at the end of its band that the coupled
    /// joints would cross within the step, and takes it out otherwise.
    fn engage_tendon_limits(&mut self) {
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

    fn joint_coord(&self, k: usize) -> (f64, f64) {
        let (h, axis) = self.joint_dofs[k];
        let Some((mb, link_id)) = self.world.multibody_joints.get(h) else { return (0.0, 0.0) };
        let Some(link) = mb.link(link_id) else { return (0.0, 0.0) };
        let q = link.joint().coords()[axis];
        let v = mb.joint_velocity(link);
        let qd = if v.is_empty() { 0.0 } else { v[0] };
        (f64::from(q), f64::from(qd))
    }
}

/// Calls `f(normal, point, normal impulse)` for every point of `pair` with a
/// positive normal impulse: the manifold's normal outward from collider 1 and the
/// midpoint of the two surfaces' points, in the world frame.
fn for_each_point(colliders: &ColliderSet, pair: &ContactPair, mut f: impl FnMut(Vector, Vector, Real)) {
    let PairContacts::Rigid(rigid) = &pair.contacts else { return };
    let (Some(c1), Some(c2)) = (colliders.get(pair.collider1), colliders.get(pair.collider2)) else { return };
    for m in &rigid.manifolds {
        // `local_n1`: the contact normal, outward from collider 1, in its frame.
        let n1 = c1.position().rotation * m.local_n1;
        for pt in m.points.iter().filter(|pt| pt.data.impulse > 0.0) {
            let p1 = c1.position().transform_point(pt.local_p1);
            let p2 = c2.position().transform_point(pt.local_p2);
            f(n1, (p1 + p2) * 0.5, pt.data.impulse);
        }
    }
}

/// Takes the couplings of `slack` out of the world's multibodies (they are
/// installed again, step by step, by [`RapierHand::engage_tendon_limits`]).
fn take_slack_couplings(
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

/// Points on the ellipsoid of semi-axes `r`: the poles and `lat - 1` rings of `lon` points.
fn ellipsoid_points(r: [f64; 3], lat: usize, lon: usize) -> Vec<Vector> {
    let mut pts = vec![Vector::new(0.0, 0.0, r[2] as Real), Vector::new(0.0, 0.0, -r[2] as Real)];
    for i in 1..lat {
        let theta = std::f64::consts::PI * i as f64 / lat as f64;
        for j in 0..lon {
            let phi = std::f64::consts::TAU * j as f64 / lon as f64;
            pts.push(Vector::new(
                (r[0] * theta.sin() * phi.cos()) as Real,
                (r[1] * theta.sin() * phi.sin()) as Real,
                (r[2] * theta.cos()) as Real,
            ));
        }
    }
    pts
}

/// The collision-group bit shared by the colliders of `<contact><pair>` elements.
const PAIR_BIT: Group = Group::GROUP_32;

/// Keeps the explicit `<contact><pair>`s among the pairs [`PAIR_BIT`] admits.
#[derive(Debug, Default, Clone)]
struct PairHooks {
    pairs: std::collections::HashSet<(ColliderHandle, ColliderHandle)>,
}

impl PhysicsHooks for PairHooks {
    fn filter_contact_pair(&self, context: &PairFilterContext) -> Option<SolverFlags> {
        if self.pairs.contains(&(context.collider1, context.collider2)) {
            return Some(SolverFlags::default());
        }
        let strip = |h: ColliderHandle| {
            context.colliders.get(h).map(|c| {
                let g = c.collision_groups();
                InteractionGroups::new(g.memberships - PAIR_BIT, g.filter - PAIR_BIT, InteractionTestMode::And)
            })
        };
        match (strip(context.collider1), strip(context.collider2)) {
            (Some(a), Some(b)) if a.test(b) => Some(SolverFlags::default()),
            _ => None,
        }
    }
}

fn quat_wxyz(q: Rotation) -> [f64; 4] {
    [f64::from(q.w), f64::from(q.x), f64::from(q.y), f64::from(q.z)]
}

fn arr(v: Vector) -> [f64; 3] {
    [f64::from(v.x), f64::from(v.y), f64::from(v.z)]
}

impl HandPhysics for RapierHand {
    fn timestep(&self) -> f64 {
        self.model.model_timestep
    }

    fn ctrl_range(&self) -> &[[f64; 2]] {
        &self.model.ctrl_range
    }

    fn touch_names(&self) -> &[String] {
        &self.model.touch_names
    }

    fn reset(&mut self) {
        // Rebuilding the world from the loaded model is cheap next to an episode
        // and drops every warm-start cache, so episodes depend only on their seed.
        *self = Self::build(Arc::clone(&self.model), self.settings);
        self.set_ctrl(&vec![0.0; self.ctrl.len()]);
    }

    fn set_object_pose(&mut self, position: [f64; 3], q: [f64; 4]) {
        if let Some(rb) = self.world.bodies.get_mut(self.object) {
            let rot = Rotation::from_xyzw(q[1] as Real, q[2] as Real, q[3] as Real, q[0] as Real).normalize();
            let pos = Vector::new(position[0] as Real, position[1] as Real, position[2] as Real);
            rb.set_position(Pose::from_parts(pos, rot), true);
            rb.set_linvel(Vector::ZERO, true);
            rb.set_angvel(Vector::ZERO, true);
        }
    }

    fn set_ctrl(&mut self, ctrl: &[f64]) {
        for ((c, &u), r) in self.ctrl.iter_mut().zip(ctrl).zip(&self.model.ctrl_range) {
            *c = u.clamp(r[0], r[1]) as Real;
        }
        self.handles.apply_controls_multibody(&mut self.world.bodies, &mut self.world.multibody_joints, &self.ctrl);
    }

    fn step(&mut self, substeps: usize) {
        self.touch_sum.iter_mut().for_each(|t| *t = 0.0);
        let duration = substeps as f64 * self.model.model_timestep;
        let steps = ((duration / self.settings.timestep).round() as usize).max(1);
        for _ in 0..steps {
            self.engage_tendon_limits();
            self.world.step_with_events(&self.hooks, &());
            self.accumulate_touch();
            if self.settings.torsional_friction {
                self.apply_torsional_friction();
            }
        }
        let n = steps as f64;
        for (t, s) in self.touch.iter_mut().zip(&self.touch_sum) {
            *t = s / n;
        }
    }

    fn hand_qpos(&self, out: &mut [f64]) {
        for (k, o) in out.iter_mut().enumerate().take(self.joint_dofs.len()) {
            *o = self.joint_coord(k).0;
        }
    }

    fn hand_qvel(&self, out: &mut [f64]) {
        for (k, o) in out.iter_mut().enumerate().take(self.joint_dofs.len()) {
            *o = self.joint_coord(k).1;
        }
    }

    fn object_pose(&self) -> ([f64; 3], [f64; 4]) {
        let rb = &self.world.bodies[self.object];
        (arr(rb.translation()), quat_wxyz(*rb.rotation()))
    }

    fn object_qvel(&self) -> [f64; 6] {
        let rb = &self.world.bodies[self.object];
        let lin = arr(rb.linvel());
        let ang_local = arr(rb.rotation().inverse() * rb.angvel());
        [lin[0], lin[1], lin[2], ang_local[0], ang_local[1], ang_local[2]]
    }

    fn touch(&self) -> &[f64] {
        &self.touch
    }

    fn palm_center(&self) -> [f64; 3] {
        arr(self.world.bodies[self.palm].position().transform_point(self.model.palm_center_local))
    }

    fn object_contacts(&self) -> ObjectContacts {
        let dt = self.world.integration_parameters.dt;
        let mut points = Vec::new();
        self.for_each_object_contact(|p, n, impulse, other| {
            if other.is_some_and(|o| self.is_hand_body(o)) {
                points.push(ContactPoint { position: arr(p), normal: arr(n), normal_force: f64::from(impulse / dt) });
            }
        });
        let rb = &self.world.bodies[self.object];
        ObjectContacts {
            points,
            center_of_mass: arr(rb.center_of_mass()),
            active_touch_sensors: self.touch.iter().filter(|&&t| t > 0.0).count(),
        }
    }
}

impl RapierHand {
    /// Sets the object's linear and angular velocity (world frame; for tests and tools).
    pub fn set_object_velocity(&mut self, linear: [f64; 3], angular: [f64; 3]) {
        let v = |a: [f64; 3]| Vector::new(a[0] as Real, a[1] as Real, a[2] as Real);
        let rb = &mut self.world.bodies[self.object];
        rb.set_linvel(v(linear), true);
        rb.set_angvel(v(angular), true);
    }

    /// Whether `h` is one of the model's bodies other than the object (i.e. the hand).
    fn is_hand_body(&self, h: RigidBodyHandle) -> bool {
        h != self.object && self.body_handles.contains(&Some(h))
    }
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
