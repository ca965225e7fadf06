//! The environment trait and the optional abilities an environment may have.

use serde::{Deserialize, Serialize};

use crate::spec::{EnvSpec, JointAction, Observation, StepOutcome};

/// A multi-agent, goal-conditioned environment.
///
/// `reset` and `step` follow the Gymnasium/PettingZoo parallel API. An
/// environment is deterministic given the seed of `reset`. It also computes the
/// task reward for any pair of achieved and desired goals, so that hindsight
/// replay can relabel stored transitions, and reports the stability features
/// `phi(s_t, a_t)` of each step in [`crate::spec::StepInfo::features`].
///
/// Implementations: the Shadow Hand environments and the small `TeamReach`
/// test environment of `fmsr-envs`, or your own.
pub trait Env {
    /// The error of this environment.
    type Error: std::error::Error + Send + Sync + 'static;

    /// The agents, dimensions, episode length and features.
    fn spec(&self) -> &EnvSpec;

    /// Starts a new episode, seeded by `seed`.
    fn reset(&mut self, seed: u64) -> Result<Observation, Self::Error>;

    /// Applies one joint action (each value in `[-1, 1]`).
    fn step(&mut self, action: &JointAction) -> Result<StepOutcome, Self::Error>;

    /// Distance between an achieved and a desired goal (radians for the
    /// rotation tasks). Success at threshold `d` means `goal_distance < d`.
    fn goal_distance(&self, achieved: &[f32], desired: &[f32]) -> f32;

    /// The task reward for reaching `achieved` when `desired` is the goal: the
    /// reward [`Env::step`] would give, recomputed for hindsight relabelling.
    fn goal_reward(&self, achieved: &[f32], desired: &[f32]) -> f32;
}

/// One contact point between the hand and the object, in world coordinates.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ContactPoint {
    /// Position of the contact (m).
    pub position: [f64; 3],
    /// Unit contact normal, pointing into the object.
    pub normal: [f64; 3],
    /// Normal force magnitude (N).
    pub normal_force: f64,
}

/// The contacts on the manipulated object at the current step.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct ObjectContacts {
    /// The contact points between the hand and the object.
    pub points: Vec<ContactPoint>,
    /// The object's centre of mass in world coordinates (m).
    pub center_of_mass: [f64; 3],
    /// Number of active touch sensors.
    pub active_touch_sensors: usize,
}

/// The optional ability to read out the object's contacts, for the grasp
/// stability metrics (paper section IV.C).
pub trait ContactReadout {
    /// The contacts of the last step.
    fn object_contacts(&self) -> ObjectContacts;

    /// The object's orientation after the last step, `[w, x, y, z]`, as the
    /// engine reports it (its sign kept, whatever the task observes), for the
    /// evaluation's records; `None` (the default) for an env without one.
    fn object_orientation(&self) -> Option<[f64; 4]> {
        None
    }
}

/// The error of an [`AnyEnv`]: its environment's own, boxed.
#[derive(Debug, thiserror::Error)]
#[error(transparent)]
pub struct AnyEnvError(pub Box<dyn std::error::Error + Send + Sync + 'static>);

/// Any [`Env`] behind one type: what a program chooses at run time (a task
/// found by name in a config) trains and evaluates as [`AnyEnv`], with its
/// errors boxed in [`AnyEnvError`]. Every call goes to the environment it holds.
///
/// ```
/// use fmsr_core::env::{AnyEnv, Env};
/// # use fmsr_core::spec::*;
/// # #[derive(Debug)] struct Still { spec: EnvSpec }
/// # impl Env for Still {
/// #     type Error = std::io::Error;
/// #     fn spec(&self) -> &EnvSpec { &self.spec }
/// #     fn reset(&mut self, _: u64) -> Result<Observation, Self::Error> { Ok(obs()) }
/// #     fn step(&mut self, _: &JointAction) -> Result<StepOutcome, Self::Error> {
/// #         Ok(StepOutcome { observation: obs(), reward: -1.0, terminated: false, truncated: false,
/// #             info: StepInfo { features: vec![0.0], ..StepInfo::default() } })
/// #     }
/// #     fn goal_distance(&self, a: &[f32], d: &[f32]) -> f32 { (a[0] - d[0]).abs() }
/// #     fn goal_reward(&self, a: &[f32], d: &[f32]) -> f32 { -self.goal_distance(a, d) }
/// # }
/// # fn obs() -> Observation { Observation { global: vec![0.0], locals: vec![vec![0.0]], achieved_goal: vec![0.0], desired_goal: vec![2.0] } }
/// # let spec = EnvSpec { agents: vec![AgentSpec { name: "a".into(), action_slots: vec![0], local_obs_dim: 1 }],
/// #     action_dim: 1, obs_dim: 1, goal_dim: 1, episode_len: 3, features: vec!["f".into()], reward_range: (-2.0, 0.0) };
/// let mut env = AnyEnv::new(Still { spec });
/// assert_eq!(env.goal_distance(&[0.0], &[2.0]), 2.0);
/// assert_eq!(env.reset(7)?.desired_goal, [2.0]);
/// assert!(env.downcast_ref::<Still>().is_some() && env.downcast_ref::<AnyEnv>().is_none());
/// # Ok::<(), fmsr_core::env::AnyEnvError>(())
/// ```
pub struct AnyEnv {
    inner: Box<dyn ErasedEnv>,
}

impl AnyEnv {
    /// `env` behind [`AnyEnv`].
    pub fn new<E: Env + Send + 'static>(env: E) -> Self {
        Self { inner: Box::new(env) }
    }

    /// The environment it holds, if it is an `E`: what code that knows the
    /// task reads of its state (a task's evaluation measures, say).
    #[must_use]
    pub fn downcast_ref<E: Env + 'static>(&self) -> Option<&E> {
        self.inner.as_any().downcast_ref::<E>()
    }
}

impl std::fmt::Debug for AnyEnv {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("AnyEnv").field("spec", self.inner.spec()).finish_non_exhaustive()
    }
}

/// [`Env`] with its error boxed, so that it can be a trait object.
trait ErasedEnv: Send {
    fn spec(&self) -> &EnvSpec;
    fn reset(&mut self, seed: u64) -> Result<Observation, AnyEnvError>;
    fn step(&mut self, action: &JointAction) -> Result<StepOutcome, AnyEnvError>;
    fn goal_distance(&self, achieved: &[f32], desired: &[f32]) -> f32;
    fn goal_reward(&self, achieved: &[f32], desired: &[f32]) -> f32;
    fn as_any(&self) -> &dyn std::any::Any;
}

impl<E: Env + Send + 'static> ErasedEnv for E {
    fn spec(&self) -> &EnvSpec {
        Env::spec(self)
    }

    fn reset(&mut self, seed: u64) -> Result<Observation, AnyEnvError> {
        Env::reset(self, seed).map_err(|e| AnyEnvError(Box::new(e)))
    }

    fn step(&mut self, action: &JointAction) -> Result<StepOutcome, AnyEnvError> {
        Env::step(self, action).map_err(|e| AnyEnvError(Box::new(e)))
    }

    fn goal_distance(&self, achieved: &[f32], desired: &[f32]) -> f32 {
        Env::goal_distance(self, achieved, desired)
    }

    fn goal_reward(&self, achieved: &[f32], desired: &[f32]) -> f32 {
        Env::goal_reward(self, achieved, desired)
    }

    fn as_any(&self) -> &dyn std::any::Any {
        self
    }
}

impl Env for AnyEnv {
    type Error = AnyEnvError;

    fn spec(&self) -> &EnvSpec {
        self.inner.spec()
    }

    fn reset(&mut self, seed: u64) -> Result<Observation, AnyEnvError> {
        self.inner.reset(seed)
    }

    fn step(&mut self, action: &JointAction) -> Result<StepOutcome, AnyEnvError> {
        self.inner.step(action)
    }

    fn goal_distance(&self, achieved: &[f32], desired: &[f32]) -> f32 {
        self.inner.goal_distance(achieved, desired)
    }

    fn goal_reward(&self, achieved: &[f32], desired: &[f32]) -> f32 {
        self.inner.goal_reward(achieved, desired)
    }
}
