//! The MuJoCo backend of the Shadow Hand (feature `mujoco`): MuJoCo 3.17 itself,
//! through `mujoco-rs` 7.0.0, on the same cached gymnasium-robotics MJCF as the
//! rapier backend (docs/design.md 4). Only the physics differs; the task is
//! [`super::ShadowHand`].
//!
//! MuJoCo loads the scene file as it is (includes, meshes, contact pairs,
//! tendons, `solref`/`solimp`), so nothing of the rapier backend's fixes is
//! needed. What the task reads maps onto MuJoCo's data as gymnasium-robotics
//! reads it:
//!
//! - hand `qpos`/`qvel`: the 24 `robot0:` joints at their `jnt_qposadr`/`jnt_dofadr`;
//! - object pose and velocity: the `object:joint` free joint's `qpos` (7) and `qvel` (6);
//! - touch: the 92 `robot0:TS_*` touch sensors' `sensordata`, as MuJoCo computes it
//!   in the last substep of a step (gymnasium reads `sensordata` after
//!   `mj_step(nstep=20)`). [`MujocoSettings::mean_touch`] averages over the
//!   substeps instead, as the rapier backend does;
//! - contacts: `mjData.contact` of the object with the hand's bodies, with the
//!   normal force from `mj_contactForce`.
//!
//! Build and run set-up: `scripts/setup_mujoco.sh` (see the crate README/`.ci/run`).

use std::sync::Arc;

use mujoco_rs::prelude::*;
use serde::{Deserialize, Serialize};

use fmsr_core::env::{ContactPoint, ObjectContacts};

use super::assets::{HandAssets, fetch_hand_assets};
use super::model::{ACTUATORS, HAND_JOINTS, HandObject, NUM_TOUCH, PREFIX};
use super::physics::HandPhysics;
use super::{ModelCache, ShadowHand, ShadowHandConfig};
use crate::error::EnvError;

/// Settings of the MuJoCo backend.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(default, deny_unknown_fields)]
pub struct MujocoSettings {
    /// Average the touch readings over the substeps of a step (like the rapier
    /// backend) instead of gymnasium's reading of the last substep (default `false`).
    pub mean_touch: bool,
}

/// The model loaded once per (assets, object) and shared by every env built from it.
#[derive(Debug)]
pub struct MujocoHandModel {
    model: Arc<MjModel>,
    object: HandObject,
    /// `qpos` address of each of [`HAND_JOINTS`].
    qpos_adr: Vec<usize>,
    /// `qvel` address of each of [`HAND_JOINTS`].
    dof_adr: Vec<usize>,
    object_qpos_adr: usize,
    object_dof_adr: usize,
    object_body: usize,
    ctrl_range: Vec<[f64; 2]>,
    touch_names: Vec<String>,
    /// `sensordata` address of each touch sensor.
    touch_adr: Vec<usize>,
    /// Sites of the palm's touch sensors (their centroid is the palm centre).
    palm_sites: Vec<usize>,
    /// Whether each body is part of the hand (name starts with `robot0:`).
    hand_body: Vec<bool>,
}

fn model_err(what: impl std::fmt::Display) -> EnvError {
    EnvError::Model(format!("MuJoCo: {what}"))
}

impl MujocoHandModel {
    /// Loads the scene of `object` (`hand/manipulate_<object>_touch_sensors.xml`) with MuJoCo.
    pub fn load(assets: &HandAssets, object: HandObject) -> Result<Self, EnvError> {
        let scene = assets.scene(object.file_stem());
        let model = MjModel::from_xml(&scene).map_err(|e| model_err(format!("loading {}: {e}", scene.display())))?;
        Self::from_model(model, object)
    }

    fn from_model(model: MjModel, object: HandObject) -> Result<Self, EnvError> {
        let id = |kind: MjtObjBase, name: &str| {
            model.name_to_id(kind, name).ok_or_else(|| model_err(format!("no {kind:?} named {name}")))
        };
        let jnt_qposadr = model.jnt_qposadr();
        let jnt_dofadr = model.jnt_dofadr();
        let mut qpos_adr = Vec::with_capacity(HAND_JOINTS.len());
        let mut dof_adr = Vec::with_capacity(HAND_JOINTS.len());
        for j in HAND_JOINTS {
            let k = id(MjtObjBase::mjOBJ_JOINT, &format!("{PREFIX}{j}"))?;
            qpos_adr.push(jnt_qposadr[k] as usize);
            dof_adr.push(jnt_dofadr[k] as usize);
        }
        let object_joint = id(MjtObjBase::mjOBJ_JOINT, "object:joint")?;
        let object_qpos_adr = jnt_qposadr[object_joint] as usize;
        let object_dof_adr = jnt_dofadr[object_joint] as usize;
        let object_body = id(MjtObjBase::mjOBJ_BODY, "object")?;

        let nu = model.ffi().nu as usize;
        if nu != ACTUATORS.len() {
            return Err(model_err(format!("{nu} actuators, expected {}", ACTUATORS.len())));
        }
        for (i, a) in ACTUATORS.iter().enumerate() {
            let name = model.id_to_name(MjtObjBase::mjOBJ_ACTUATOR, i).unwrap_or("");
            if name != format!("{PREFIX}A_{a}") {
                return Err(model_err(format!("actuator {i} is {name:?}, expected {PREFIX}A_{a}")));
            }
        }
        let ctrl_range: Vec<[f64; 2]> = model.actuator_ctrlrange().to_vec();

        let touch_prefix = format!("{PREFIX}TS_");
        let palm = id(MjtObjBase::mjOBJ_BODY, &format!("{PREFIX}palm"))?;
        let site_body = model.site_bodyid();
        let (mut touch_names, mut touch_adr, mut palm_sites) = (Vec::new(), Vec::new(), Vec::new());
        for (s, ((ty, adr), site)) in
            model.sensor_type().iter().zip(model.sensor_adr()).zip(model.sensor_objid()).enumerate()
        {
            if *ty != MjtSensor::mjSENS_TOUCH {
                continue;
            }
            let Some(name) = model.id_to_name(MjtObjBase::mjOBJ_SENSOR, s).filter(|n| n.starts_with(&touch_prefix))
            else {
                continue;
            };
            touch_names.push(name.to_owned());
            touch_adr.push(*adr as usize);
            if site_body[*site as usize] as usize == palm {
                palm_sites.push(*site as usize);
            }
        }
        if touch_names.len() != NUM_TOUCH {
            return Err(model_err(format!("{} touch sensors, expected {NUM_TOUCH}", touch_names.len())));
        }
        let nbody = model.ffi().nbody as usize;
        let hand_body = (0..nbody)
            .map(|b| model.id_to_name(MjtObjBase::mjOBJ_BODY, b).is_some_and(|n| n.starts_with(PREFIX)))
            .collect();
        Ok(Self {
            model: Arc::new(model),
            object,
            qpos_adr,
            dof_adr,
            object_qpos_adr,
            object_dof_adr,
            object_body,
            ctrl_range,
            touch_names,
            touch_adr,
            palm_sites,
            hand_body,
        })
    }

    /// Which object the scene holds.
    #[must_use]
    pub fn object(&self) -> HandObject {
        self.object
    }

    /// The MuJoCo model.
    #[must_use]
    pub fn mj_model(&self) -> &Arc<MjModel> {
        &self.model
    }
}

static MODELS: ModelCache<MujocoHandModel> = ModelCache::new();

/// Loads (once per process, then shared) the MuJoCo model of `object` from `assets`.
pub fn load_mujoco_model(assets: &HandAssets, object: HandObject) -> Result<Arc<MujocoHandModel>, EnvError> {
    MODELS.get_or_load(assets, object, || MujocoHandModel::load(assets, object))
}

/// The MuJoCo Shadow Hand scene; see the [module docs](self).
pub struct MujocoHand {
    model: Arc<MujocoHandModel>,
    settings: MujocoSettings,
    data: MjData<Arc<MjModel>>,
    touch: Vec<f64>,
}

impl std::fmt::Debug for MujocoHand {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MujocoHand").field("object", &self.model.object).field("settings", &self.settings).finish()
    }
}

impl MujocoHand {
    /// Builds the scene from a loaded model, in its initial state.
    pub fn new(model: Arc<MujocoHandModel>, settings: MujocoSettings) -> Result<Self, EnvError> {
        let data = MjData::new(Arc::clone(&model.model));
        let mut hand = Self { model, settings, data, touch: vec![0.0; NUM_TOUCH] };
        hand.reset();
        Ok(hand)
    }

    /// The settings in use.
    #[must_use]
    pub fn settings(&self) -> MujocoSettings {
        self.settings
    }

    /// The MuJoCo data (read-only), e.g. for inspection or comparison with gymnasium.
    #[must_use]
    pub fn data(&self) -> &MjData<Arc<MjModel>> {
        &self.data
    }

    /// The whole `qpos` (38 values: hand, object and target free joints).
    #[must_use]
    pub fn qpos(&self) -> &[f64] {
        self.data.qpos()
    }

    fn read_touch(&self, out: &mut [f64], add: bool) {
        let sensordata = self.data.sensordata();
        for (o, &a) in out.iter_mut().zip(&self.model.touch_adr) {
            if add {
                *o += sensordata[a];
            } else {
                *o = sensordata[a];
            }
        }
    }
}

impl HandPhysics for MujocoHand {
    fn timestep(&self) -> f64 {
        self.data.model().opt().timestep
    }

    fn ctrl_range(&self) -> &[[f64; 2]] {
        &self.model.ctrl_range
    }

    fn touch_names(&self) -> &[String] {
        &self.model.touch_names
    }

    fn reset(&mut self) {
        // mj_resetData: qpos0, zero velocities, controls, warm start and time.
        self.data.reset();
        self.data.forward();
        self.touch.iter_mut().for_each(|t| *t = 0.0);
    }

    fn set_object_pose(&mut self, position: [f64; 3], q: [f64; 4]) {
        let (a, d) = (self.model.object_qpos_adr, self.model.object_dof_adr);
        let qpos = self.data.qpos_mut();
        qpos[a..a + 3].copy_from_slice(&position);
        qpos[a + 3..a + 7].copy_from_slice(&q);
        self.data.qvel_mut()[d..d + 6].iter_mut().for_each(|v| *v = 0.0);
        self.data.forward();
    }

    fn set_ctrl(&mut self, ctrl: &[f64]) {
        for ((c, &u), r) in self.data.ctrl_mut().iter_mut().zip(ctrl).zip(&self.model.ctrl_range) {
            *c = u.clamp(r[0], r[1]);
        }
    }

    fn step(&mut self, substeps: usize) {
        let mut touch = std::mem::take(&mut self.touch);
        touch.iter_mut().for_each(|t| *t = 0.0);
        for _ in 0..substeps {
            self.data.step();
            if self.settings.mean_touch {
                self.read_touch(&mut touch, true);
            }
        }
        if self.settings.mean_touch {
            let n = substeps.max(1) as f64;
            touch.iter_mut().for_each(|t| *t /= n);
        } else {
            self.read_touch(&mut touch, false);
        }
        self.touch = touch;
    }

    fn hand_qpos(&self, out: &mut [f64]) {
        let qpos = self.data.qpos();
        for (o, &a) in out.iter_mut().zip(&self.model.qpos_adr) {
            *o = qpos[a];
        }
    }

    fn hand_qvel(&self, out: &mut [f64]) {
        let qvel = self.data.qvel();
        for (o, &a) in out.iter_mut().zip(&self.model.dof_adr) {
            *o = qvel[a];
        }
    }

    fn object_pose(&self) -> ([f64; 3], [f64; 4]) {
        let a = self.model.object_qpos_adr;
        let q = &self.data.qpos()[a..a + 7];
        ([q[0], q[1], q[2]], [q[3], q[4], q[5], q[6]])
    }

    fn object_qvel(&self) -> [f64; 6] {
        let d = self.model.object_dof_adr;
        let mut v = [0.0; 6];
        v.copy_from_slice(&self.data.qvel()[d..d + 6]);
        v
    }

    fn touch(&self) -> &[f64] {
        &self.touch
    }

    fn palm_center(&self) -> [f64; 3] {
        let xpos = self.data.site_xpos();
        let sites = &self.model.palm_sites;
        let mut c = [0.0; 3];
        for &s in sites {
            for k in 0..3 {
                c[k] += xpos[s][k];
            }
        }
        c.map(|v| v / sites.len().max(1) as f64)
    }

    fn object_contacts(&self) -> ObjectContacts {
        let m = &self.model;
        let geom_body = self.data.model().geom_bodyid();
        let mut points = Vec::new();
        for (i, c) in self.data.contact().iter().enumerate() {
            if c.efc_address < 0 || c.exclude != 0 {
                continue;
            }
            let (b1, b2) = (geom_body[c.geom[0] as usize] as usize, geom_body[c.geom[1] as usize] as usize);
            // The frame's first row is the normal, from geom 1 to geom 2.
            let n = [c.frame[0], c.frame[1], c.frame[2]];
            let normal = if b2 == m.object_body && m.hand_body[b1] {
                n
            } else if b1 == m.object_body && m.hand_body[b2] {
                n.map(|v| -v)
            } else {
                continue;
            };
            let force = self.data.contact_force(i)[0];
            if force > 0.0 {
                points.push(ContactPoint { position: c.pos, normal, normal_force: force });
            }
        }
        ObjectContacts {
            points,
            center_of_mass: self.data.xipos()[m.object_body],
            active_touch_sensors: self.touch.iter().filter(|&&t| t > 0.0).count(),
        }
    }
}

impl ShadowHandConfig {
    /// Builds the environment on MuJoCo (feature `mujoco`), fetching the model into
    /// the cache on first use. The task is the same as [`ShadowHandConfig::init`]'s.
    ///
    /// ```no_run
    /// use fmsr_envs::shadow_hand::{MujocoSettings, ShadowHandConfig};
    /// use fmsr_core::Env;
    /// let mut env = ShadowHandConfig::default().init_mujoco(MujocoSettings::default()).unwrap();
    /// assert_eq!(env.reset(0).unwrap().global.len(), 153);
    /// ```
    pub fn init_mujoco(self, settings: MujocoSettings) -> Result<ShadowHand<MujocoHand>, EnvError> {
        let physics = self.mujoco_physics(settings)?;
        self.init_with(physics)
    }

    /// The MuJoCo physics of this config's object, fetching the model into the
    /// cache on first use.
    ///
    /// # Errors
    /// A model that cannot be fetched or loaded.
    pub fn mujoco_physics(&self, settings: MujocoSettings) -> Result<MujocoHand, EnvError> {
        let assets = fetch_hand_assets(self.assets_dir.as_deref())?;
        let model = load_mujoco_model(&assets, self.object)?;
        MujocoHand::new(model, settings)
    }
}

#[allow(dead_code)]
fn _assert_send() {
    fn send<T: Send>() {}
    send::<ShadowHand<MujocoHand>>();
}
