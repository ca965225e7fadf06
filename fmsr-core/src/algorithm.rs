//! The algorithm seam: a learner that owns its storage, its update schedule,
//! its target networks and its save/restore.
//!
//! The training loop ([`crate::trainer`]) only knows this trait: it collects
//! episodes with the algorithm's [`Policy`], hands each one to
//! [`Algorithm::store`] (a HER replay buffer for off-policy algorithms, a
//! rollout buffer for on-policy ones), then calls [`Algorithm::update`] once per
//! cycle with the [`RewardModel`] that turns task rewards and features into each
//! agent's reward `r_i` (eq. 7) under the current occupancy estimate. How many
//! gradient steps a cycle runs, when targets move and when information sharing
//! mixes (see [`crate::sharing`]) is the algorithm's business.

use serde::{Deserialize, Serialize};

use crate::policy::Policy;
use crate::replay::Episode;

/// Each agent's reward for a transition, as the shadow rewards define it
/// ([`crate::shadow`]):
/// `r_i = w_i * r_task(g_achieved, g) + alpha * sum_{k in S_i} z_k(phi_k, lambda_k)` (eq. 7).
///
/// Off-policy algorithms call it while sampling, so relabelled goals (HER) and
/// the newest occupancy estimate enter every batch.
pub trait RewardModel {
    /// The task reward of reaching `achieved` when `desired` was the goal.
    fn goal_reward(&self, achieved: &[f32], desired: &[f32]) -> f32;

    /// Writes every agent's reward for a step with task reward `task` and
    /// features `phi` into `out` (one value per agent).
    fn agent_rewards(&self, task: f32, phi: &[f32], out: &mut [f32]);

    /// Each agent's per-step reward bounds `(lo, hi)` (used to clip Q targets
    /// to `[lo, hi] / (1 - gamma)`).
    fn reward_bounds(&self) -> Vec<(f64, f64)>;
}

/// What one [`Algorithm::update`] call did, averaged over its gradient steps.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct UpdateStats {
    /// Gradient steps taken (0 when the algorithm was not ready to learn).
    pub updates: u64,
    /// Mean critic loss of each agent.
    pub critic_loss: Vec<f64>,
    /// Mean actor loss of each agent (over the steps that updated actors).
    pub actor_loss: Vec<f64>,
    /// Each agent's mean `|task part|` of the rewards in the sampled batches,
    /// HER's relabelled goals included (empty when the algorithm does not
    /// say): the task reward as the critics learn it.
    #[serde(default)]
    pub batch_task_reward_abs: Vec<f64>,
    /// Each agent's mean `|shadow part|` of the same rewards (the agent's
    /// reward for the step less its reward with a zero task reward).
    #[serde(default)]
    pub batch_shadow_reward_abs: Vec<f64>,
    /// Each agent's mean `Q_i(x, g, a)` of its (first) online critic over the
    /// sampled batches (empty when the algorithm does not say).
    #[serde(default)]
    pub q_mean: Vec<f64>,
}

/// A multi-agent learning algorithm: a [`Policy`] that also learns.
///
/// Implemented by `fmsr-nn`'s MADDPG, MATD3 and MASAC, or by your own: the
/// `fmsr` crate's `examples/custom_algorithm.rs` implements independent DDPG
/// in one file against this trait alone.
pub trait Algorithm: Policy {
    /// Stores one collected episode in the algorithm's own storage.
    fn store(&mut self, episode: &Episode) -> Result<(), Self::Error>;

    /// The updates of one training cycle, with rewards from `rewards`.
    fn update(&mut self, rewards: &dyn RewardModel) -> Result<UpdateStats, Self::Error>;

    /// The algorithm's whole state (networks, optimisers, normalisers, RNG and,
    /// with `include_storage`, its replay or rollout storage) as bytes.
    fn save_state(&self, include_storage: bool) -> Result<Vec<u8>, Self::Error>;

    /// Restores a state written by [`Algorithm::save_state`]; a state of another
    /// shape or algorithm is an error, never a panic. Storage absent from the
    /// bytes is left as it is.
    fn load_state(&mut self, bytes: &[u8]) -> Result<(), Self::Error>;

    /// Restores the algorithm's part of a rescue point
    /// ([`crate::trainer::RescuePoint`]): a state written by
    /// [`Algorithm::save_state`] without storage, which the algorithm's own
    /// tools may have thinned (fmsr-nn's `rescue_state` drops target networks
    /// and optimiser moments, which this restores as the online networks and
    /// fresh moments). By default, [`Algorithm::load_state`]: an algorithm
    /// that does not thin its states reads its rescue points as whole states.
    fn load_rescue_state(&mut self, bytes: &[u8]) -> Result<(), Self::Error> {
        self.load_state(bytes)
    }

    /// How many of the most recently stored episodes the storage can still
    /// sample from (a replay buffer's capacity in episodes; 0 for storage that is
    /// emptied by every update). The trainer's replay log keeps that many on disk.
    fn storage_capacity(&self) -> usize;

    /// Puts the storage in the state it had after `total` episodes were
    /// [stored](Algorithm::store), given the last `min(total, storage_capacity())`
    /// of them in store order (read back from the replay log). Unlike `store`,
    /// this learns nothing from them (normalisers were restored with the state).
    fn restore_storage(&mut self, total: u64, episodes: &[Episode]) -> Result<(), Self::Error>;
}
