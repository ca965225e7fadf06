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

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;
    use crate::shadow::{Averaging, ResolvedAssignment};
    use crate::spec::{AgentSpec, JointAction, Observation, StepInfo, StepOutcome};

    /// A goal reward only: `-|achieved - desired|` on one coordinate.
    #[derive(Debug)]
    struct Goal(EnvSpec);

    impl Env for Goal {
        type Error = std::io::Error;
        fn spec(&self) -> &EnvSpec {
            &self.0
        }
        fn reset(&mut self, _: u64) -> Result<Observation, Self::Error> {
            Err(std::io::Error::other("not stepped in these tests"))
        }
        fn step(&mut self, _: &JointAction) -> Result<StepOutcome, Self::Error> {
            Err(std::io::Error::other("not stepped in these tests"))
        }
        fn goal_distance(&self, a: &[f32], d: &[f32]) -> f32 {
            (a[0] - d[0]).abs()
        }
        fn goal_reward(&self, a: &[f32], d: &[f32]) -> f32 {
            -self.goal_distance(a, d)
        }
    }

    fn spec(agents: usize, features: usize) -> EnvSpec {
        EnvSpec {
            agents: (0..agents)
                .map(|i| AgentSpec { name: format!("a{i}"), action_slots: vec![i], local_obs_dim: 1 })
                .collect(),
            action_dim: agents,
            obs_dim: 1,
            goal_dim: 1,
            episode_len: 4,
            features: (0..features).map(|k| format!("f{k}")).collect(),
            reward_range: (-2.0, 0.0),
        }
    }

    fn shadow(spec: &EnvSpec, features: Vec<Vec<usize>>, alpha: f64) -> ShadowRewards {
        let n = spec.agents.len();
        let assignment = ResolvedAssignment { task_weights: vec![1.0; n], features };
        let rewards = AgentRewards::new(assignment, LogUtility::default(), alpha).unwrap();
        let occupancy = DiscountedOccupancy::new(spec.features.len(), 0.9, Averaging::Window { episodes: 3 }).unwrap();
        ShadowRewards::new(spec, occupancy, rewards).unwrap()
    }

    fn episode(goals: &[(f32, f32)], phis: &[Vec<f32>]) -> Episode {
        let mut e = Episode::with_capacity(phis.len());
        let obs = |(a, d): (f32, f32)| Observation {
            global: vec![0.0],
            locals: vec![],
            achieved_goal: vec![a],
            desired_goal: vec![d],
        };
        e.observations.push(obs((0.0, 0.0)));
        for (g, phi) in goals.iter().zip(phis) {
            e.observations.push(obs(*g));
            e.infos.push(StepInfo { features: phi.clone(), ..StepInfo::default() });
            e.actions.push(JointAction(vec![]));
        }
        e
    }

    // Guards that the trainer's statistics and the learners' targets see one
    // reward (eq. 7): an episode's returns from `reward_sums` are the sums of
    // what the learners' RewardModel gives for its steps, under one estimate.
    proptest! {
        #[test]
        fn reward_sums_add_up_the_learners_rewards(
            steps in prop::collection::vec((-1.0f32..1.0, -1.0f32..1.0, 0.0f32..=1.0, 0.0f32..=1.0), 1..8),
            alpha in 0.0f64..1.0,
        ) {
            let spec = spec(3, 2);
            let mut shadow = shadow(&spec, vec![vec![0], vec![1], vec![0, 1]], alpha);
            let goals: Vec<(f32, f32)> = steps.iter().map(|s| (s.0, s.1)).collect();
            let phis: Vec<Vec<f32>> = steps.iter().map(|s| vec![s.2, s.3]).collect();
            shadow.observe_episode(&phis).unwrap();
            let env = Goal(spec);
            let sums = shadow.reward_sums(&env, &episode(&goals, &phis));
            let model = shadow.reward_model(&env);
            let mut expected = [0.0f64; 3];
            for ((a, d), phi) in goals.iter().zip(&phis) {
                let mut out = [0.0f32; 3];
                model.agent_rewards(model.goal_reward(&[*a], &[*d]), phi, &mut out);
                for (e, o) in expected.iter_mut().zip(out) {
                    *e += f64::from(o);
                }
            }
            for (got, want) in sums.returns.iter().zip(expected) {
                prop_assert!((got - want).abs() <= 1e-9 * (1.0 + want.abs()), "{got} != {want}");
            }
            for (i, (lo, hi)) in model.reward_bounds().into_iter().enumerate() {
                let per_step = sums.returns[i] / steps.len() as f64;
                prop_assert!(lo <= per_step + 1e-9 && per_step <= hi + 1e-9, "agent {i}: {per_step} outside [{lo}, {hi}]");
            }
        }
    }

    #[test]
    fn shadow_rewards_of_another_spec_are_refused() {
        let spec = spec(2, 1);
        let rewards = |n: usize| {
            AgentRewards::new(
                ResolvedAssignment { task_weights: vec![1.0; n], features: vec![vec![]; n] },
                LogUtility::default(),
                0.1,
            )
            .unwrap()
        };
        let occupancy = |k: usize| DiscountedOccupancy::new(k, 0.9, Averaging::default()).unwrap();
        assert!(matches!(
            ShadowRewards::new(&spec, occupancy(2), rewards(2)),
            Err(CoreError::Dimension { what: "occupancy features", expected: 1, found: 2 })
        ));
        assert!(matches!(
            ShadowRewards::new(&spec, occupancy(1), rewards(3)),
            Err(CoreError::Dimension { what: "reward assignment agents", expected: 2, found: 3 })
        ));
        assert!(ShadowRewards::new(&spec, occupancy(1), rewards(2)).is_ok());
    }
}
