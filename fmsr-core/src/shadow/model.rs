//! The shadow rewards as the trainer holds them: an occupancy estimate that
//! observes every collected episode (eq. 1) and the agents' rewards computed
//! from it (eq. 7).

use super::assignment::AgentRewards;
use super::occupancy::{DiscountedOccupancy, OccupancyEstimator};
use super::utility::{LogUtility, ShadowReward};
use crate::algorithm::RewardModel;
use crate::env::Env;
use crate::error::CoreError;
use crate::replay::Episode;
use crate::spec::EnvSpec;

/// Per-agent sums of one episode's rewards ([`ShadowRewards::reward_sums`]).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RewardSums {
    /// Undiscounted returns (task and shadow rewards, eq. 7).
    pub returns: Vec<f64>,
    /// Sums of `|w_i r|`, the task parts.
    pub task_abs: Vec<f64>,
    /// Sums of `|alpha sum_k z_k|`, the shadow parts.
    pub shadow_abs: Vec<f64>,
}

/// The occupancy estimator `O` and the agents' rewards under utility `S`,
/// checked against one environment spec.
///
/// ```
/// use fmsr_core::shadow::{Averaging, DiscountedOccupancy, ResolvedAssignment, ShadowRewards};
/// use fmsr_core::shadow::{AgentRewards, LogUtility};
/// # use fmsr_core::spec::{AgentSpec, EnvSpec};
/// # let spec = EnvSpec { agents: vec![AgentSpec { name: "a".into(), action_slots: vec![0], local_obs_dim: 1 }],
/// #     action_dim: 1, obs_dim: 1, goal_dim: 1, episode_len: 2, features: vec!["f".into()], reward_range: (-1.0, 0.0) };
/// let occupancy = DiscountedOccupancy::new(1, 0.5, Averaging::Window { episodes: 1 }).unwrap();
/// let rewards = AgentRewards::new(
///     ResolvedAssignment { task_weights: vec![1.0], features: vec![vec![0]] },
///     LogUtility::default(),
///     0.1,
/// )
/// .unwrap();
/// let mut shadow = ShadowRewards::new(&spec, occupancy, rewards).unwrap();
/// shadow.observe_episode(&[vec![1.0], vec![0.0]]).unwrap();
/// assert!((shadow.estimate()[0] - 0.5).abs() < 1e-12); // (1 - 0.5) * 1
/// ```
#[derive(Debug, Clone)]
pub struct ShadowRewards<O = DiscountedOccupancy, S = LogUtility> {
    occupancy: O,
    rewards: AgentRewards<S>,
    reward_range: (f32, f32),
}

impl<O: OccupancyEstimator, S: ShadowReward> ShadowRewards<O, S> {
    /// The shadow rewards of an environment with spec `spec`.
    ///
    /// # Errors
    /// [`CoreError::Dimension`] when the estimator does not estimate one value
    /// per feature of `spec` or the rewards are not for its agents.
    pub fn new(spec: &EnvSpec, occupancy: O, rewards: AgentRewards<S>) -> Result<Self, CoreError> {
        if occupancy.estimate().len() != spec.features.len() {
            return Err(CoreError::Dimension {
                what: "occupancy features",
                expected: spec.features.len(),
                found: occupancy.estimate().len(),
            });
        }
        if rewards.num_agents() != spec.agents.len() {
            return Err(CoreError::Dimension {
                what: "reward assignment agents",
                expected: spec.agents.len(),
                found: rewards.num_agents(),
            });
        }
        Ok(Self { occupancy, rewards, reward_range: spec.reward_range })
    }

    /// Updates the occupancy estimate (eq. 1) with one episode's features
    /// `features[t][k] = phi_k(s_t, a_t)`.
    ///
    /// # Errors
    /// The estimator's error for features of the wrong shape or outside `[0, 1]`.
    pub fn observe_episode(&mut self, features: &[Vec<f32>]) -> Result<(), CoreError> {
        self.occupancy.observe_episode(features)
    }

    /// The current estimate `lambda`, one value per feature.
    #[must_use]
    pub fn estimate(&self) -> &[f64] {
        self.occupancy.estimate()
    }

    /// The occupancy estimator.
    #[must_use]
    pub fn occupancy(&self) -> &O {
        &self.occupancy
    }

    /// The per-agent reward computation.
    #[must_use]
    pub fn rewards(&self) -> &AgentRewards<S> {
        &self.rewards
    }

    /// Each agent's sums over `episode` of `env` under the current estimate:
    /// its undiscounted return and the magnitudes of its task and shadow parts.
    #[must_use]
    pub fn reward_sums<E: Env>(&self, env: &E, episode: &Episode) -> RewardSums {
        let n = self.rewards.num_agents();
        let mut sums = RewardSums { returns: vec![0.0; n], task_abs: vec![0.0; n], shadow_abs: vec![0.0; n] };
        for (t, info) in episode.infos.iter().enumerate() {
            let o = &episode.observations[t + 1];
            let task = env.goal_reward(&o.achieved_goal, &o.desired_goal);
            for (i, (task_part, shadow_part)) in self.rewards.parts(task, &info.features, self.estimate()).enumerate() {
                sums.returns[i] += f64::from((task_part + shadow_part) as f32);
                sums.task_abs[i] += task_part.abs();
                sums.shadow_abs[i] += shadow_part.abs();
            }
        }
        sums
    }

    /// What the learners of `env` learn from: its task reward, recomputed for
    /// relabelled goals, and these shadow rewards.
    pub fn reward_model<'a, E: Env>(&'a self, env: &'a E) -> TrainingRewards<'a, E, O, S> {
        TrainingRewards { env, shadow: self }
    }

    /// Restores the estimator of a checkpoint.
    pub(crate) fn restore(&mut self, occupancy: O) {
        self.occupancy = occupancy;
    }
}

/// The [`RewardModel`] of training: an environment's goal reward and the
/// shadow rewards ([`ShadowRewards::reward_model`]).
#[derive(Debug)]
pub struct TrainingRewards<'a, E, O, S> {
    env: &'a E,
    shadow: &'a ShadowRewards<O, S>,
}

impl<E: Env, O: OccupancyEstimator, S: ShadowReward> RewardModel for TrainingRewards<'_, E, O, S> {
    fn goal_reward(&self, achieved: &[f32], desired: &[f32]) -> f32 {
        self.env.goal_reward(achieved, desired)
    }

    fn agent_rewards(&self, task: f32, phi: &[f32], out: &mut [f32]) {
        self.shadow.rewards.compute(task, phi, self.shadow.estimate(), out);
    }

    fn reward_bounds(&self) -> Vec<(f64, f64)> {
        self.shadow.rewards.step_bounds(self.shadow.reward_range)
    }
}
