//! The rapier3d backend of the Shadow Hand: `rapier3d-mjcf` loads the model,
//! and this module fixes what it leaves out (docs/design.md 4), one concern a file:
//!
//! - `load.rs`: **includes** inside `<worldbody>`/`<asset>` are inlined first
//!   ([`super::model::inline_includes`]); the **target** body is a ghost (no
//!   collider, fixed); the **object's** mass and inertia are MuJoCo's (box: from
//!   its density 567; egg: the solid ellipsoid of density 1000, collided as the
//!   convex hull of 1106 points on the ellipsoid, in place of the loader's
//!   12-vertex hull), and its free-joint damping 0.01 becomes rapier body
//!   damping `0.01 / m` (linear) and `0.01 / I` (angular);
//! - `contacts.rs`: **contact filtering** follows MuJoCo's
//!   `(contype1 & conaffinity2) || (contype2 & conaffinity1)` with one
//!   collision-group bit per class, and the 19 **`<contact><pair>`**s of
//!   `shared.xml` collide through one more bit and a physics hook;
//! - `tendon.rs`: the **J1/J0 coupling** gets the sign of a length constraint,
//!   and the tendon's **slack** ([`RapierSettings::tendon_slack`]);
//! - `touch.rs`: **touch sensors** read the summed normal force of the contacts
//!   inside their site box, averaged over the substeps of one
//!   [`HandPhysics::step`], every contact of their body as MuJoCo's do
//!   ([`RapierSettings::touch_every_contact`]);
//! - `torsion.rs`: **torsional friction** of the object's `condim="4"` contacts
//!   ([`RapierSettings::torsional_friction`]), which rapier's solver lacks;
//! - `settings.rs`: the solver settings, speed against fidelity.
//!
//! Not modelled: the pairs' `condim="1"` (they keep friction), the other tendon
//! limits (the J1+J0 sums of `T_xxJ1u/d`, which the joint ranges never reach), MuJoCo's
//! soft-contact `solref`/`solimp` and geom `margin`.

mod contacts;
mod load;
mod settings;
mod tendon;
mod torsion;
mod touch;

use std::collections::HashMap;
use std::sync::Arc;

use rapier3d::math::{Pose, Real, Rotation, Vector};
use rapier3d::prelude::*;
use rapier3d_mjcf::{MjcfMultibodyOptions, MjcfRobotHandles};

use fmsr_core::env::{ContactPoint, ObjectContacts};

pub use self::load::RapierHandModel;
pub use self::settings::RapierSettings;
use self::tendon::SlackCoupling;
use super::model::NUM_TOUCH;
use super::physics::HandPhysics;
use crate::error::EnvError;

/// The error of a name the model lacks (loading the model, finding its touch sites).
fn missing(what: &str, name: &str) -> EnvError {
    EnvError::Model(format!("no {what} named {name}"))
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
    hooks: contacts::PairHooks,
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
        contacts::apply_groups(&mut world, &handles, &model.groups);
        let collider_of =
            |(b, c): (usize, usize)| handles.bodies[b].as_ref().and_then(|b| b.colliders.get(c)).map(|c| c.handle);
        let hooks = contacts::install_pairs(&mut world, &model.pairs, collider_of);
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
        let slack = if settings.tendon_slack {
            tendon::take_slack_couplings(&mut world, &handles, &model.slack)
        } else {
            Vec::new()
        };
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
            contacts::for_each_point(colliders, pair, |n1, p, impulse| {
                f(p, if object_is_1 { -n1 } else { n1 }, impulse, other)
            });
        }
    }

    /// Calls `f(point, normal impulse, body1, body2)` for every active contact
    /// point of the scene.
    fn for_each_contact(&self, mut f: impl FnMut(Vector, Real, Option<RigidBodyHandle>, Option<RigidBodyHandle>)) {
        let colliders = &self.world.colliders;
        for pair in self.world.narrow_phase.contact_pairs() {
            let parent = |h| colliders.get(h).and_then(|c: &Collider| c.parent());
            let (b1, b2) = (parent(pair.collider1), parent(pair.collider2));
            contacts::for_each_point(colliders, pair, |_, p, impulse| f(p, impulse, b1, b2));
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
