//! Loading the model once per process: `rapier3d-mjcf` reads the MJCF (its
//! includes inlined first, [`inline_includes`]) and each concern of [`super`]
//! takes what it needs from it; the target becomes a ghost and the object gets
//! MuJoCo's mass, inertia and damping.

use std::collections::HashMap;
use std::path::Path;

use rapier3d::math::{Real, Vector};
use rapier3d::prelude::*;
use rapier3d_mjcf::{MjcfLoaderOptions, MjcfRobot};

use super::super::assets::HandAssets;
use super::super::model::{ACTUATORS, HAND_JOINTS, HandObject, PREFIX, inline_includes};
use super::contacts::{self, ColliderKey};
use super::missing;
use super::tendon::{self, TendonSlack};
use super::torsion;
use super::touch::{self, TouchSite};
use crate::error::EnvError;

/// The model loaded from disk once; shared by every env built from it.
#[derive(Debug)]
pub struct RapierHandModel {
    pub(super) robot: MjcfRobot,
    pub(super) object: HandObject,
    /// `MjcfRobot::joints` index of each of [`HAND_JOINTS`].
    pub(super) joints: Vec<usize>,
    pub(super) ctrl_range: Vec<[f64; 2]>,
    pub(super) touch_names: Vec<String>,
    pub(super) touch_sites: Vec<TouchSite>,
    pub(super) object_body: usize,
    pub(super) object_pos0: Vector,
    pub(super) palm_body: usize,
    pub(super) palm_center_local: Vector,
    /// Collision groups per (body index, collider index in body).
    pub(super) groups: HashMap<ColliderKey, InteractionGroups>,
    /// The `<contact><pair>` geoms, as (body index, collider index in body).
    pub(super) pairs: Vec<(ColliderKey, ColliderKey)>,
    /// `(condim, torsional friction coefficient)` per (body index, collider index in body).
    pub(super) torsion: HashMap<ColliderKey, (u32, f64)>,
    /// The couplings whose tendon has a length range.
    pub(super) slack: Vec<TendonSlack>,
    pub(super) gravity: Vector,
    /// The model's `<option timestep>` (0.002 s).
    pub(super) model_timestep: f64,
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
        let joints = hand_joints(&robot)?;
        let ctrl_range = actuator_ranges(&robot)?;
        let slack = tendon::fix_couplings(&mut robot, &model, xml)?;
        let (touch_names, touch_sites) = touch::touch_sites(&robot, &model)?;
        let groups = contacts::collision_groups(&robot, &model)?;
        let pairs = contacts::contact_pairs(&robot)?;
        let torsion = torsion::coefficients(&robot, &model);
        make_target_a_ghost(&mut robot)?;
        let (object_body, object_pos0) = set_object_mass(&mut robot, object)?;
        let (palm_body, palm_center_local) = palm_center(&robot, &touch_sites)?;
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

/// The `MjcfRobot::joints` index of each of [`HAND_JOINTS`], in MuJoCo's qpos order.
fn hand_joints(robot: &MjcfRobot) -> Result<Vec<usize>, EnvError> {
    HAND_JOINTS
        .iter()
        .map(|j| robot.joint_name_to_idx.get(&name_of(j)).copied().ok_or_else(|| missing("joint", &name_of(j))))
        .collect()
}

/// The control range of each of the 20 position servos, checked against [`ACTUATORS`].
fn actuator_ranges(robot: &MjcfRobot) -> Result<Vec<[f64; 2]>, EnvError> {
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
    Ok(ctrl_range)
}

/// The target body: a ghost, fixed and without colliders.
fn make_target_a_ghost(robot: &mut MjcfRobot) -> Result<(), EnvError> {
    let target = *robot.body_name_to_idx.get("target").ok_or_else(|| missing("body", "target"))?;
    robot.bodies[target].colliders.clear();
    let target_pose = *robot.bodies[target].body.position();
    robot.bodies[target].body = RigidBodyBuilder::fixed().pose(target_pose).build();
    Ok(())
}

/// The object gets MuJoCo's mass, inertia and damping (the egg also a finer
/// hull); returns its body index and initial position.
fn set_object_mass(robot: &mut MjcfRobot, object: HandObject) -> Result<(usize, Vector), EnvError> {
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
    Ok((object_body, object_pos0))
}

/// The palm's body index and its centre, the centroid of the palm's touch
/// sites, in the palm frame.
fn palm_center(robot: &MjcfRobot, touch_sites: &[TouchSite]) -> Result<(usize, Vector), EnvError> {
    let palm_body = *robot.body_name_to_idx.get(&name_of("palm")).ok_or_else(|| missing("body", "palm"))?;
    let palm_sites: Vec<&TouchSite> = touch_sites.iter().filter(|s| s.body == palm_body).collect();
    let palm_center_local = if palm_sites.is_empty() {
        Vector::ZERO
    } else {
        palm_sites.iter().map(|s| s.pose.translation).sum::<Vector>() / palm_sites.len() as Real
    };
    Ok((palm_body, palm_center_local))
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
