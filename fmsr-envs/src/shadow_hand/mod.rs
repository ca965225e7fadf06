//! The Shadow Hand block and egg rotation tasks (rotation about Z only) with
//! 92 touch sensors, with gymnasium-robotics' semantics (docs/design.md 4).
//!
//! The task ([`ShadowHand`]) is written against the small [`HandPhysics`] trait;
//! [`RapierHand`] is the pure-Rust backend (the default), and a MuJoCo backend
//! only has to implement the trait.
//!
//! - **Reset**: the model's initial state, the object (upright in the model)
//!   rotated about Z by `U(-pi, pi)` and moved by `N(0, 0.005)` per axis, then
//!   `settle_steps` (10) steps at zero action; as gym's `_reset_sim`, the reset
//!   is drawn again while the object's centre ends at or below 0.04 m
//!   (`is_on_palm`). The goal is the object's position after settling and a
//!   rotation about Z by `U(-pi, pi)`: an upright object turned about Z.
//! - **Action**: `a` in `[-1, 1]^20` maps to `ctrl = mid + a * half_range` of each
//!   actuator's `ctrlrange`; one step is `substeps` (20) physics steps of 0.002 s.
//! - **Goals** are 7-dim (object position, quaternion `[w, x, y, z]` with `w >= 0`,
//!   or as the engine reports it under `"gym"`);
//!   the goal distance ([`GoalDistance`], `goal_distance`) is by default the full
//!   angle between the achieved and desired orientations, as gym's
//!   `manipulate.py` measures it (a tilted object is far from an upright goal)
//!   with `q` and `-q` one orientation; `"gym"` is gym's formula exactly, over
//!   `[0, 2 pi]` with the engine's quaternion sign kept (the paper's stack);
//!   `"yaw"` the difference of the rotations about Z alone (older records). Dense reward `-distance`, sparse `0` on
//!   success and `-1` otherwise; success when `distance < success_threshold`
//!   (0.1 in training, 0.4 in testing).
//! - **Observation**: gymnasium's 153 values (24 hand qpos, 24 hand qvel, 6 object
//!   qvel, 7 object pose, 92 touch) are the global view. The local view of each
//!   agent is its own joints' positions and velocities, its own touch sensors,
//!   and the object pose (7) and velocity (6).
//! - **Features**: `safe_region` (object centre within `safe_radius` of the palm
//!   centre) and `contacts` (at least `min_active_touch` = 11 of the 92 touch
//!   sensors active: the paper's "greater than tau = 10").
//! - **Drop**: the object centre below `drop_height` or farther than
//!   `drop_distance` from the palm centre. Episodes are never terminated early
//!   (gymnasium's semantics); the flag is in [`StepInfo::dropped`].

pub mod assets;
mod engine;
pub mod model;
#[cfg(feature = "mujoco")]
pub mod mujoco;
pub mod physics;
#[cfg(feature = "rapier")]
pub mod rapier;
/// The rapier backend's settings; the backend itself needs the feature `rapier`.
#[cfg(not(feature = "rapier"))]
pub mod rapier {
    mod settings;
    pub use self::settings::RapierSettings;
}
pub mod render;
pub mod rotation;

use std::f64::consts::PI;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use fmsr_core::spec::{AgentSpec, EnvSpec, JointAction, Observation, RewardType, StepInfo, StepOutcome};
use fmsr_core::{ContactReadout, Env, env::ObjectContacts};

pub use self::assets::{HandAssets, fetch_hand_assets};
pub use self::engine::{Engine, EnginePhysics};
pub use self::model::HandObject;
use self::model::{ACTUATORS, AGENTS, HAND_JOINTS, NUM_TOUCH, PREFIX};
#[cfg(feature = "mujoco")]
pub use self::mujoco::{MujocoHand, MujocoHandModel, MujocoSettings, load_mujoco_model};
pub use self::physics::HandPhysics;
pub use self::rapier::RapierSettings;
#[cfg(feature = "rapier")]
pub use self::rapier::{RapierHand, RapierHandModel};
pub use self::rotation::GoalDistance;
use crate::error::EnvError;

/// How touch readings enter the observations.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum TouchObs {
    /// `1` when the reading is positive, else `0` (gymnasium's `boolean`).
    #[default]
    Boolean,
    /// The normal force in N (gymnasium's `sensordata`).
    Continuous,
    /// `ln(1 + force)` (gymnasium's `log`).
    Log,
}

/// Settings of [`ShadowHand`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ShadowHandConfig {
    /// Block (default) or egg.
    pub object: HandObject,
    /// Steps per episode (default 100).
    pub episode_len: usize,
    /// Model timesteps (0.002 s) per env step (default 20, i.e. 0.04 s; gymnasium's
    /// `n_substeps`). The rapier backend covers them with steps of `rapier.timestep`.
    pub substeps: usize,
    /// Steps at zero action after placing the object (default 10).
    pub settle_steps: usize,
    /// Standard deviation of the initial position noise per axis (m, default 0.005).
    pub position_noise: f64,
    /// Dense (default) or sparse task reward.
    pub reward: RewardType,
    /// Success threshold on the goal distance (rad; 0.1 in training (default), 0.4 in testing).
    pub success_threshold: f32,
    /// How the goal distance is measured: `"full"` (default, the full angle
    /// between the orientations, `q` and `-q` one orientation), `"gym"`
    /// (gymnasium-robotics' `2 arccos(w)` over `[0, 2 pi]`, the engine's
    /// quaternion sign kept in observations and goals: the paper's stack) or
    /// `"yaw"` (rotation about Z alone, the oldest records). A saved run or
    /// policy that names none was made under `"yaw"` and is read so.
    pub goal_distance: GoalDistance,
    /// `rho`: the `safe_region` radius around the palm centre, the centroid of the
    /// 8 palm touch sites (m, default 0.08; the paper gives no value). At rest at
    /// mid controls the block's centre is 4.5 cm and the egg's 6.4 cm from it.
    pub safe_radius: f64,
    /// The `contacts` feature is on with at least this many active touch
    /// sensors (default 11: the paper's "greater than tau = 10", eq. 12; the
    /// oldest records used 10, which their configs name).
    pub min_active_touch: usize,
    /// Touch readings above this force (N) count as active (default 0: any contact).
    pub touch_threshold: f64,
    /// How touch readings enter the observations (default boolean).
    pub touch_obs: TouchObs,
    /// The object is dropped below this height (m, default 0.1; it rests near 0.17).
    pub drop_height: f64,
    /// ... or farther than this from the palm centre (m, default 0.15).
    pub drop_distance: f64,
    /// Where the model is cached (default: `$FMSR_ASSETS_DIR`, else `$XDG_CACHE_HOME/fmsr` or
    /// `~/.cache/fmsr`; see [`assets::default_assets_dir`]).
    pub assets_dir: Option<PathBuf>,
    /// Solver settings of the rapier backend.
    pub rapier: RapierSettings,
    /// The agents and the actuators each one owns; `None` is the paper's six
    /// agents (docs/design.md 3.1). Every actuator must be owned exactly once. An
    /// agent observes the joints and touch sensors of every finger (or the
    /// wrist/palm) it owns an actuator of.
    pub agents: Option<Vec<HandAgent>>,
}

/// One agent of a custom partition of the hand's actuators.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HandAgent {
    /// The agent's name (used by reward assignments and graphs).
    pub name: String,
    /// The actuators it owns, by joint name without prefix (`"WRJ1"`, `"THJ0"`, ...).
    pub actuators: Vec<String>,
}

impl HandAgent {
    /// The paper's partition: wrist, index, middle, ring, little, thumb.
    ///
    /// ```
    /// use fmsr_envs::shadow_hand::HandAgent;
    /// let agents = HandAgent::paper();
    /// assert_eq!(agents[0].actuators, vec!["WRJ1", "WRJ0"]);
    /// assert_eq!(agents.iter().map(|a| a.actuators.len()).sum::<usize>(), 20);
    /// ```
    #[must_use]
    pub fn paper() -> Vec<HandAgent> {
        AGENTS
            .iter()
            .map(|part| HandAgent {
                name: part.name.into(),
                actuators: ACTUATORS.iter().filter(|a| a.starts_with(part.joint_prefix)).map(|a| (*a).into()).collect(),
            })
            .collect()
    }
}

impl Default for ShadowHandConfig {
    fn default() -> Self {
        Self {
            object: HandObject::Block,
            episode_len: 100,
            substeps: 20,
            settle_steps: 10,
            position_noise: 0.005,
            reward: RewardType::Dense,
            success_threshold: 0.1,
            goal_distance: GoalDistance::Full,
            safe_radius: 0.08,
            min_active_touch: 11,
            touch_threshold: 0.0,
            touch_obs: TouchObs::Boolean,
            drop_height: 0.1,
            drop_distance: 0.15,
            assets_dir: None,
            rapier: RapierSettings::default(),
            agents: None,
        }
    }
}

/// Models loaded once per process and then shared, by assets folder and object.
#[cfg_attr(not(any(feature = "rapier", feature = "mujoco")), allow(dead_code))]
pub(crate) struct ModelCache<M>(Mutex<Vec<(CacheKey, Arc<M>)>>);

/// Where a model was loaded from.
type CacheKey = (PathBuf, HandObject);

#[cfg_attr(not(any(feature = "rapier", feature = "mujoco")), allow(dead_code))]
impl<M> ModelCache<M> {
    /// An empty cache.
    pub(crate) const fn new() -> Self {
        Self(Mutex::new(Vec::new()))
    }

    /// The cached model of `object` from `assets`, or the one `load` makes.
    pub(crate) fn get_or_load(
        &self,
        assets: &HandAssets,
        object: HandObject,
        load: impl FnOnce() -> Result<M, EnvError>,
    ) -> Result<Arc<M>, EnvError> {
        let key = (assets.root.clone(), object);
        let mut models = self.0.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        if let Some((_, m)) = models.iter().find(|(k, _)| *k == key) {
            return Ok(Arc::clone(m));
        }
        let model = Arc::new(load()?);
        models.push((key, Arc::clone(&model)));
        Ok(model)
    }
}

#[cfg(feature = "rapier")]
static MODELS: ModelCache<RapierHandModel> = ModelCache::new();

/// Loads (once per process, then shared) the rapier model of `object` from `assets`.
#[cfg(feature = "rapier")]
pub fn load_rapier_model(assets: &HandAssets, object: HandObject) -> Result<Arc<RapierHandModel>, EnvError> {
    MODELS.get_or_load(assets, object, || RapierHandModel::load(assets, object))
}

impl ShadowHandConfig {
    /// The block task with the test success threshold 0.4.
    #[must_use]
    pub fn test_block() -> Self {
        Self { success_threshold: 0.4, ..Self::default() }
    }

    /// Builds the rapier environment, fetching the model into the cache on first use.
    ///
    /// ```no_run
    /// use fmsr_envs::shadow_hand::ShadowHandConfig;
    /// use fmsr_core::Env;
    /// let mut env = ShadowHandConfig::default().init().unwrap();
    /// let obs = env.reset(0).unwrap();
    /// assert_eq!(obs.global.len(), 153);
    /// assert_eq!(env.spec().agents.len(), 6);
    /// ```
    #[cfg(feature = "rapier")]
    pub fn init(self) -> Result<ShadowHand<RapierHand>, EnvError> {
        let physics = self.rapier_physics()?;
        self.init_with(physics)
    }

    /// The rapier physics of this config's object and settings, fetching the
    /// model into the cache on first use.
    ///
    /// # Errors
    /// An invalid config, a model that cannot be fetched or loaded.
    #[cfg(feature = "rapier")]
    pub fn rapier_physics(&self) -> Result<RapierHand, EnvError> {
        self.check()?;
        let assets = fetch_hand_assets(self.assets_dir.as_deref())?;
        let model = load_rapier_model(&assets, self.object)?;
        RapierHand::new(model, self.rapier)
    }

    /// Builds the task on any physics backend.
    pub fn init_with<P: HandPhysics>(self, physics: P) -> Result<ShadowHand<P>, EnvError> {
        self.check()?;
        ShadowHand::new(self, physics)
    }

    fn check(&self) -> Result<(), EnvError> {
        let bad = |key: &'static str, reason: String| Err(EnvError::InvalidConfig { key, reason });
        if self.episode_len == 0 {
            return bad("episode_len", "must be at least 1".into());
        }
        if self.substeps == 0 {
            return bad("substeps", "must be at least 1".into());
        }
        let positive = |key: &'static str, v: f64| {
            if v.is_finite() && v > 0.0 { Ok(()) } else { bad(key, format!("{v} must be positive and finite")) }
        };
        positive("success_threshold", f64::from(self.success_threshold))?;
        positive("safe_radius", self.safe_radius)?;
        positive("drop_distance", self.drop_distance)?;
        if !(self.position_noise.is_finite() && self.position_noise >= 0.0) {
            return bad("position_noise", format!("{} must be >= 0", self.position_noise));
        }
        if !self.drop_height.is_finite() {
            return bad("drop_height", format!("{} must be finite", self.drop_height));
        }
        if !(self.touch_threshold.is_finite() && self.touch_threshold >= 0.0) {
            return bad("touch_threshold", format!("{} must be finite and >= 0", self.touch_threshold));
        }
        if self.min_active_touch > NUM_TOUCH {
            return bad("min_active_touch", format!("at most {NUM_TOUCH}"));
        }
        Ok(())
    }
}

/// The joint-action slots of each agent of `partition`, checking that every
/// actuator is owned exactly once and that names are known and unique.
fn partition_slots(partition: &[HandAgent]) -> Result<Vec<Vec<usize>>, EnvError> {
    let bad = |reason: String| EnvError::InvalidConfig { key: "env.agents", reason };
    if partition.is_empty() {
        return Err(bad("at least one agent is needed".into()));
    }
    let mut owner: Vec<Option<&str>> = vec![None; ACTUATORS.len()];
    let mut all = Vec::with_capacity(partition.len());
    for (i, agent) in partition.iter().enumerate() {
        if partition[..i].iter().any(|a| a.name == agent.name) {
            return Err(bad(format!("agent name `{}` is used twice", agent.name)));
        }
        if agent.actuators.is_empty() {
            return Err(bad(format!("agent `{}` owns no actuator", agent.name)));
        }
        let mut slots = Vec::with_capacity(agent.actuators.len());
        for name in &agent.actuators {
            let slot = ACTUATORS.iter().position(|a| a == name).ok_or_else(|| {
                bad(format!("agent `{}`: unknown actuator `{name}` (known: {})", agent.name, ACTUATORS.join(", ")))
            })?;
            if let Some(other) = owner[slot] {
                return Err(bad(format!("actuator `{name}` is owned by both `{other}` and `{}`", agent.name)));
            }
            owner[slot] = Some(&agent.name);
            slots.push(slot);
        }
        all.push(slots);
    }
    if let Some(slot) = owner.iter().position(Option::is_none) {
        return Err(bad(format!("actuator `{}` is owned by no agent", ACTUATORS[slot])));
    }
    Ok(all)
}

/// The object is on the palm after a reset when its centre is higher (m; gym's `is_on_palm`).
const ON_PALM_HEIGHT: f64 = 0.04;

/// Resets drawn for one seed before giving up (gym retries without a bound).
const MAX_RESET_ATTEMPTS: usize = 100;

/// Which joints, actuators and touch sensors an agent owns.
#[derive(Debug, Clone)]
struct AgentIndex {
    joints: Vec<usize>,
    touch: Vec<usize>,
}

/// Rotation about Z by `angle` as `[w, x, y, z]`.
fn quat_z(angle: f64) -> [f64; 4] {
    [(angle / 2.0).cos(), 0.0, 0.0, (angle / 2.0).sin()]
}

/// A standard normal draw for the object's initial position: Box-Muller on
/// two uniform draws. Written out on purpose, where fmsr-nn draws its normals
/// from `rand_distr`: the episodes a seed gives (the fixed test set and the
/// validation episodes) are this stream, and every evaluation on record, the
/// long runs' snapshots among them, was made on them. `rand_distr`'s ziggurat
/// consumes the stream differently and would change every episode, the goals
/// included; move it only together with a new test set, and evaluate again
/// what is on record.
fn normal(rng: &mut ChaCha8Rng) -> f64 {
    let u1: f64 = rng.random_range(f64::EPSILON..1.0);
    let u2: f64 = rng.random();
    (-2.0 * u1.ln()).sqrt() * (2.0 * PI * u2).cos()
}

/// The Shadow Hand rotation task; see the [module docs](self). `P` is its
/// physics: by default the engine chosen at run time
/// ([`ShadowHandConfig::init_engine`]), or one backend's own type.
#[derive(Debug)]
pub struct ShadowHand<P: HandPhysics = EnginePhysics> {
    config: ShadowHandConfig,
    spec: EnvSpec,
    physics: P,
    agents: Vec<AgentIndex>,
    goal: [f32; 7],
    steps: Option<usize>,
    qpos: Vec<f64>,
    qvel: Vec<f64>,
}

impl<P: HandPhysics> ShadowHand<P> {
    fn new(config: ShadowHandConfig, physics: P) -> Result<Self, EnvError> {
        if physics.ctrl_range().len() != ACTUATORS.len() || physics.touch_names().len() != NUM_TOUCH {
            return Err(EnvError::Model(format!(
                "the physics has {} actuators and {} touch sensors, expected {} and {NUM_TOUCH}",
                physics.ctrl_range().len(),
                physics.touch_names().len(),
                ACTUATORS.len()
            )));
        }
        let touch_prefix = format!("{PREFIX}TS_");
        let partition = config.agents.clone().unwrap_or_else(HandAgent::paper);
        let slots_of = partition_slots(&partition)?;
        let mut agents = Vec::new();
        let mut specs = Vec::new();
        let mut touch_seen = [false; NUM_TOUCH];
        for (agent, slots) in partition.iter().zip(slots_of) {
            // The fingers (or the wrist) this agent moves, and what it observes of them.
            let parts: Vec<_> =
                AGENTS.iter().filter(|p| slots.iter().any(|&s| ACTUATORS[s].starts_with(p.joint_prefix))).collect();
            let joints: Vec<usize> = (0..HAND_JOINTS.len())
                .filter(|&i| parts.iter().any(|p| HAND_JOINTS[i].starts_with(p.joint_prefix)))
                .collect();
            let touch: Vec<usize> = physics
                .touch_names()
                .iter()
                .enumerate()
                .filter(|(_, n)| {
                    let stem = n.strip_prefix(&touch_prefix).unwrap_or(n);
                    parts.iter().any(|p| p.touch_prefixes.iter().any(|t| stem.starts_with(t)))
                })
                .map(|(i, _)| i)
                .collect();
            for &t in &touch {
                touch_seen[t] = true;
            }
            specs.push(AgentSpec {
                name: agent.name.clone(),
                action_slots: slots,
                local_obs_dim: 2 * joints.len() + touch.len() + 13,
            });
            agents.push(AgentIndex { joints, touch });
        }
        let touch_owned = touch_seen.iter().filter(|&&t| t).count();
        if touch_owned != NUM_TOUCH {
            return Err(EnvError::Model(format!("{touch_owned} of {NUM_TOUCH} touch sensors belong to an agent")));
        }
        let spec = EnvSpec {
            agents: specs,
            action_dim: ACTUATORS.len(),
            obs_dim: 2 * HAND_JOINTS.len() + 6 + 7 + NUM_TOUCH,
            goal_dim: 7,
            episode_len: config.episode_len,
            features: vec!["safe_region".into(), "contacts".into()],
            reward_range: match config.reward {
                RewardType::Dense => (-std::f32::consts::PI, 0.0),
                RewardType::Sparse => (-1.0, 0.0),
            },
        };
        spec.validate()?;
        Ok(Self {
            config,
            spec,
            physics,
            agents,
            goal: [0.0; 7],
            steps: None,
            qpos: vec![0.0; HAND_JOINTS.len()],
            qvel: vec![0.0; HAND_JOINTS.len()],
        })
    }

    /// The settings.
    #[must_use]
    pub fn config(&self) -> &ShadowHandConfig {
        &self.config
    }

    /// The physics backend.
    #[must_use]
    pub fn physics(&self) -> &P {
        &self.physics
    }

    /// The physics backend, mutably (for tests and tools; the task does not see changes made here).
    pub fn physics_mut(&mut self) -> &mut P {
        &mut self.physics
    }

    /// Number of active touch sensors after the last step.
    #[must_use]
    pub fn active_touch_count(&self) -> usize {
        self.physics.touch().iter().filter(|&&t| t > self.config.touch_threshold).count()
    }

    /// The current goal distance between the object and the goal (rad), by `goal_distance`.
    #[must_use]
    pub fn angle_error(&self) -> f32 {
        self.goal_distance(&self.achieved_goal(), &self.goal)
    }

    /// What a rendered frame of the current state shows ([`render::HandScene::render`]).
    #[must_use]
    pub fn view(&self) -> render::HandView {
        let mut qpos = vec![0.0; HAND_JOINTS.len()];
        self.physics.hand_qpos(&mut qpos);
        let (object_position, object_quaternion) = self.physics.object_pose();
        let g = self.goal.map(f64::from);
        render::HandView {
            qpos,
            object_position,
            object_quaternion,
            goal_position: [g[0], g[1], g[2]],
            goal_quaternion: [g[3], g[4], g[5], g[6]],
            touch_active: self.physics.touch().iter().map(|&t| t > self.config.touch_threshold).collect(),
        }
    }

    /// Distance of the object centre from the palm centre (m).
    #[must_use]
    pub fn palm_distance(&self) -> f64 {
        let (p, _) = self.physics.object_pose();
        let c = self.physics.palm_center();
        ((p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2) + (p[2] - c[2]).powi(2)).sqrt()
    }

    /// Maps an action in `[-1, 1]^20` to actuator controls.
    #[must_use]
    pub fn action_to_ctrl(&self, action: &[f32]) -> Vec<f64> {
        self.physics
            .ctrl_range()
            .iter()
            .zip(action)
            .map(|(r, &a)| {
                let (mid, half) = ((r[0] + r[1]) / 2.0, (r[1] - r[0]) / 2.0);
                mid + f64::from(a.clamp(-1.0, 1.0)) * half
            })
            .collect()
    }

    /// The object's pose as the achieved goal: the engine's quaternion with
    /// `w >= 0`, or as the engine reports it where the distance tells the
    /// two signs apart ([`GoalDistance::keeps_sign`], gym's).
    fn achieved_goal(&self) -> [f32; 7] {
        let (p, mut q) = self.physics.object_pose();
        if q[0] < 0.0 && !self.config.goal_distance.keeps_sign() {
            q.iter_mut().for_each(|v| *v = -*v);
        }
        [p[0], p[1], p[2], q[0], q[1], q[2], q[3]].map(|v| v as f32)
    }

    fn touch_value(&self, t: f64) -> f32 {
        match self.config.touch_obs {
            TouchObs::Boolean => f32::from(u8::from(t > self.config.touch_threshold)),
            TouchObs::Continuous => t as f32,
            TouchObs::Log => t.ln_1p() as f32,
        }
    }

    fn observation(&mut self) -> Result<Observation, EnvError> {
        self.physics.hand_qpos(&mut self.qpos);
        self.physics.hand_qvel(&mut self.qvel);
        let object_qvel = self.physics.object_qvel();
        let achieved = self.achieved_goal();
        let touch: Vec<f32> = self.physics.touch().iter().map(|&t| self.touch_value(t)).collect();
        let mut global = Vec::with_capacity(self.spec.obs_dim);
        global.extend(self.qpos.iter().map(|&v| v as f32));
        global.extend(self.qvel.iter().map(|&v| v as f32));
        global.extend(object_qvel.iter().map(|&v| v as f32));
        global.extend_from_slice(&achieved);
        global.extend_from_slice(&touch);
        if let Some(i) = global.iter().position(|v| !v.is_finite()) {
            return Err(EnvError::Diverged(format!("observation entry {i} is {}", global[i])));
        }
        let locals = self
            .agents
            .iter()
            .map(|a| {
                let mut local = Vec::with_capacity(2 * a.joints.len() + a.touch.len() + 13);
                local.extend(a.joints.iter().map(|&j| self.qpos[j] as f32));
                local.extend(a.joints.iter().map(|&j| self.qvel[j] as f32));
                local.extend(a.touch.iter().map(|&t| touch[t]));
                local.extend_from_slice(&achieved);
                local.extend(object_qvel.iter().map(|&v| v as f32));
                local
            })
            .collect();
        Ok(Observation { global, locals, achieved_goal: achieved.to_vec(), desired_goal: self.goal.to_vec() })
    }
}

impl<P: HandPhysics> Env for ShadowHand<P> {
    type Error = EnvError;

    fn spec(&self) -> &EnvSpec {
        &self.spec
    }

    fn reset(&mut self, seed: u64) -> Result<Observation, EnvError> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut attempts = 0;
        loop {
            self.physics.reset();
            let (p0, _) = self.physics.object_pose();
            let angle = rng.random_range(-PI..PI);
            let noise = self.config.position_noise;
            let pos =
                [p0[0] + noise * normal(&mut rng), p0[1] + noise * normal(&mut rng), p0[2] + noise * normal(&mut rng)];
            self.physics.set_object_pose(pos, quat_z(angle));
            let mid = self.action_to_ctrl(&[0.0; 20]);
            self.physics.set_ctrl(&mid);
            for _ in 0..self.config.settle_steps {
                self.physics.step(self.config.substeps);
            }
            attempts += 1;
            // gym's `is_on_palm`: the object's centre above 0.04 m after settling.
            if self.physics.object_pose().0[2] > ON_PALM_HEIGHT {
                break;
            }
            if attempts >= MAX_RESET_ATTEMPTS {
                return Err(EnvError::Reset { seed, attempts });
            }
        }
        let goal_angle = rng.random_range(-PI..PI);
        let (p, _) = self.physics.object_pose();
        let q = quat_z(goal_angle);
        let q = if q[0] < 0.0 { q.map(|v| -v) } else { q };
        self.goal = [p[0], p[1], p[2], q[0], q[1], q[2], q[3]].map(|v| v as f32);
        self.steps = Some(0);
        self.observation()
    }

    fn step(&mut self, action: &JointAction) -> Result<StepOutcome, EnvError> {
        action.validate(&self.spec)?;
        let steps = self.steps.ok_or(EnvError::NotReset)? + 1;
        let ctrl = self.action_to_ctrl(action.as_slice());
        self.physics.set_ctrl(&ctrl);
        self.physics.step(self.config.substeps);
        self.steps = Some(steps);
        let observation = self.observation()?;
        let c = &self.config;
        let distance = self.goal_distance(&observation.achieved_goal, &observation.desired_goal);
        let palm_distance = self.palm_distance();
        let (p, _) = self.physics.object_pose();
        let info = StepInfo {
            is_success: distance < c.success_threshold,
            features: vec![
                f32::from(u8::from(palm_distance < c.safe_radius)),
                f32::from(u8::from(self.active_touch_count() >= c.min_active_touch)),
            ],
            dropped: p[2] < c.drop_height || palm_distance > c.drop_distance,
        };
        Ok(StepOutcome {
            observation,
            reward: c.reward.reward(distance, c.success_threshold),
            terminated: false,
            truncated: steps >= c.episode_len,
            info,
        })
    }

    fn goal_distance(&self, achieved: &[f32], desired: &[f32]) -> f32 {
        if achieved.len() < 7 || desired.len() < 7 {
            return f32::NAN;
        }
        self.config.goal_distance.between(&achieved[3..7], &desired[3..7])
    }

    fn goal_reward(&self, achieved: &[f32], desired: &[f32]) -> f32 {
        self.config.reward.reward(self.goal_distance(achieved, desired), self.config.success_threshold)
    }
}

impl<P: HandPhysics> ContactReadout for ShadowHand<P> {
    fn object_contacts(&self) -> ObjectContacts {
        let mut contacts = self.physics.object_contacts();
        contacts.active_touch_sensors = self.active_touch_count();
        contacts
    }

    fn object_orientation(&self) -> Option<[f64; 4]> {
        Some(self.physics.object_pose().1)
    }
}

/// Steps each env with its action, in parallel over rayon's thread pool.
pub fn step_batch<P: HandPhysics + Send>(
    envs: &mut [ShadowHand<P>],
    actions: &[JointAction],
) -> Vec<Result<StepOutcome, EnvError>> {
    envs.par_iter_mut().zip(actions.par_iter()).map(|(env, a)| env.step(a)).collect()
}

/// Resets each env with its seed, in parallel.
pub fn reset_batch<P: HandPhysics + Send>(
    envs: &mut [ShadowHand<P>],
    seeds: &[u64],
) -> Vec<Result<Observation, EnvError>> {
    envs.par_iter_mut().zip(seeds.par_iter()).map(|(env, &s)| env.reset(s)).collect()
}

#[allow(dead_code)]
fn _assert_send() {
    fn send<T: Send>() {}
    send::<ShadowHand<EnginePhysics>>();
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn yaw_distance_wraps() {
        let a = quat_z(3.0).map(|v| v as f32);
        let b = quat_z(-3.0).map(|v| v as f32);
        assert!((rotation::yaw_error(&a, &b) - (std::f32::consts::TAU - 6.0)).abs() < 1e-4);
        assert!((rotation::yaw(&quat_z(0.7).map(|v| v as f32)) - 0.7).abs() < 1e-5);
    }
}
