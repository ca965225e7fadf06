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
