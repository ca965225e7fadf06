//! The collector: runs episodes of an [`Env`] with a [`Policy`], records the
//! stability features `phi(s_t, a_t)`, and turns them into occupancy estimates
//! (eq. 1) and each agent's shadow reward (eqs. 7, 11-15).
//!
//! It is generic over the environment, the [`OccupancyEstimator`] and the
//! [`ShadowReward`] utility, so a user's own estimator or utility trains
//! exactly like the paper's [`DiscountedOccupancy`] and [`LogUtility`]:
//!
//! ```
//! use fmsr_core::prelude::*;
//! use fmsr_core::collector::Collector;
//! # use fmsr_core::spec::{AgentSpec, StepOutcome};
//! # #[derive(Debug)] struct Line { spec: EnvSpec, x: f32 }
//! # impl Env for Line {
//! #     type Error = std::io::Error;
//! #     fn spec(&self) -> &EnvSpec { &self.spec }
//! #     fn reset(&mut self, _seed: u64) -> Result<Observation, Self::Error> { self.x = 0.0; Ok(self.obs()) }
//! #     fn step(&mut self, a: &JointAction) -> Result<StepOutcome, Self::Error> {
//! #         self.x += 0.1 * a.0[0];
//! #         let info = StepInfo { features: vec![f32::from(self.x > 0.0)], ..StepInfo::default() };
//! #         Ok(StepOutcome { observation: self.obs(), reward: -self.x.abs(), terminated: false, truncated: false, info })
//! #     }
//! #     fn goal_distance(&self, a: &[f32], d: &[f32]) -> f32 { (a[0] - d[0]).abs() }
//! #     fn goal_reward(&self, a: &[f32], d: &[f32]) -> f32 { -self.goal_distance(a, d) }
//! # }
//! # impl Line { fn obs(&self) -> Observation { Observation { global: vec![self.x], locals: vec![vec![self.x]],
//! #     achieved_goal: vec![self.x], desired_goal: vec![1.0] } } }
//! # let spec = EnvSpec { agents: vec![AgentSpec { name: "a".into(), action_slots: vec![0], local_obs_dim: 1 }],
//! #     action_dim: 1, obs_dim: 1, goal_dim: 1, episode_len: 4, features: vec!["right".into()], reward_range: (-1.0, 0.0) };
//! # let env = Line { spec: spec.clone(), x: 0.0 };
//! /// Always pushes right.
//! struct Right;
//! impl Policy for Right {
//!     type Error = std::convert::Infallible;
//!     fn num_agents(&self) -> usize { 1 }
//!     fn act(&mut self, _: &[Vec<f32>], n: usize, _: ActMode) -> Result<PolicyOutput, Self::Error> {
//!         Ok(PolicyOutput::actions(vec![vec![1.0; n]]))
//!     }
//! }
//! let layout = ObservationLayout::new(spec.clone(), vec![vec![]])?;
//! let occupancy = DiscountedOccupancy::new(1, 0.5, Averaging::Ema { beta: 1.0 })?;
//! let assignment = RewardAssignment::all_features(&spec).resolve(&spec)?;
//! let rewards = AgentRewards::new(assignment, LogUtility::default(), 0.1)?;
//! let mut collector = Collector::new(env, layout, occupancy, rewards)?;
//! let episode = collector.rollout(&mut Right, 7, ActMode::Explore, &mut |_, _| {})?;
//! let returns = collector.observe(&episode)?;
//! // The feature is on at every step: lambda = (1 - 0.5) (1 + 0.5 + 0.25 + 0.125).
//! assert!((collector.occupancy().estimate()[0] - 0.9375).abs() < 1e-9);
//! assert_eq!(returns.len(), 1);
//! # Ok::<(), CoreError>(())
//! ```

use crate::agent::ObservationLayout;
use crate::algorithm::RewardModel;
use crate::env::Env;
use crate::error::CoreError;
use crate::occupancy::{DiscountedOccupancy, OccupancyEstimator};
use crate::policy::{ActMode, Policy};
use crate::replay::Episode;
use crate::shadow::{AgentRewards, LogUtility, ShadowReward};
use crate::spec::{JointAction, StepOutcome};

fn env_err<E: std::error::Error + Send + Sync + 'static>(e: E) -> CoreError {
    CoreError::Env(Box::new(e))
}

/// Runs episodes and keeps the occupancy estimate; see the [module docs](self).
#[derive(Debug)]
pub struct Collector<E, O = DiscountedOccupancy, S = LogUtility> {
    env: E,
    layout: ObservationLayout,
    occupancy: O,
    rewards: AgentRewards<S>,
    env_steps: u64,
}

impl<E: Env, O: OccupancyEstimator, S: ShadowReward> Collector<E, O, S> {
    /// A collector of `env` whose policies see actor inputs laid out by
    /// `layout`, estimating occupancy with `occupancy` and rewarding agents with `rewards`.
    ///
    /// # Errors
    /// [`CoreError`] when the layout, estimator or reward computation do not fit `env`'s spec.
    pub fn new(env: E, layout: ObservationLayout, occupancy: O, rewards: AgentRewards<S>) -> Result<Self, CoreError> {
        let spec = env.spec();
        spec.validate()?;
        if layout.spec() != spec {
            return Err(CoreError::InvalidConfig {
                key: "layout".into(),
                reason: "the observation layout was built for another environment spec".into(),
            });
        }
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
        Ok(Self { env, layout, occupancy, rewards, env_steps: 0 })
    }

    /// Runs one episode from `seed`, acting with `policy` in `mode`, and calls
    /// `on_step(env, outcome)` after every step (e.g. to read contacts).
    ///
    /// # Errors
    /// Errors of the environment or the policy, and observations or features
    /// of the wrong shape.
    pub fn rollout<P: Policy>(
        &mut self,
        policy: &mut P,
        seed: u64,
        mode: ActMode,
        on_step: &mut dyn FnMut(&E, &StepOutcome),
    ) -> Result<Episode, CoreError> {
        let spec = self.env.spec().clone();
        if policy.num_agents() != spec.agents.len() {
            return Err(CoreError::Dimension {
                what: "policy agents",
                expected: spec.agents.len(),
                found: policy.num_agents(),
            });
        }
        let mut obs = self.env.reset(seed).map_err(env_err)?;
        obs.validate(&spec)?;
        let mut prev = JointAction::zeros(spec.action_dim);
        let mut episode = Episode::with_capacity(spec.episode_len);
        for _ in 0..spec.episode_len {
            let inputs = self.layout.actor_inputs(&obs, &prev);
            let out = policy.act(&inputs, 1, mode).map_err(|e| CoreError::Algorithm(Box::new(e)))?;
            let joint = JointAction::from_agents(&spec.agents, &out.actions)?;
            let outcome = self.env.step(&joint).map_err(env_err)?;
            outcome.observation.validate(&spec)?;
            if outcome.info.features.len() != spec.features.len() {
                return Err(CoreError::Dimension {
                    what: "step features",
                    expected: spec.features.len(),
                    found: outcome.info.features.len(),
                });
            }
            on_step(&self.env, &outcome);
            if !out.log_probs.is_empty() {
                episode.log_probs.push(out.log_probs.iter().map(|l| l.first().copied().unwrap_or(0.0)).collect());
            }
            episode.observations.push(obs);
            episode.actions.push(joint.clone());
            episode.infos.push(outcome.info);
            obs = outcome.observation;
            prev = joint;
        }
        episode.observations.push(obs);
        self.env_steps += spec.episode_len as u64;
        Ok(episode)
    }

    /// Records a finished training episode: its features update the occupancy
    /// estimate (eq. 1). Returns each agent's undiscounted return (task and
    /// shadow rewards, eq. 7) under the updated estimate.
    ///
    /// # Errors
    /// Features outside `[0, 1]` or of the wrong length.
    pub fn observe(&mut self, episode: &Episode) -> Result<Vec<f64>, CoreError> {
        self.occupancy.observe_episode(&episode.features())?;
        let mut returns = vec![0.0f64; self.rewards.num_agents()];
        let mut step = vec![0.0f32; returns.len()];
        for (t, info) in episode.infos.iter().enumerate() {
            let o = &episode.observations[t + 1];
            let task = self.env.goal_reward(&o.achieved_goal, &o.desired_goal);
            self.agent_rewards(task, &info.features, &mut step);
            returns.iter_mut().zip(&step).for_each(|(r, v)| *r += f64::from(*v));
        }
        Ok(returns)
    }

    /// The environment.
    #[must_use]
    pub fn env(&self) -> &E {
        &self.env
    }

    /// The environment, mutably.
    pub fn env_mut(&mut self) -> &mut E {
        &mut self.env
    }

    /// How actor inputs are assembled.
    #[must_use]
    pub fn layout(&self) -> &ObservationLayout {
        &self.layout
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

    /// Environment steps run so far.
    #[must_use]
    pub fn env_steps(&self) -> u64 {
        self.env_steps
    }

    /// Restores the estimator and step counter of a checkpoint.
    pub(crate) fn restore(&mut self, occupancy: O, env_steps: u64) {
        self.occupancy = occupancy;
        self.env_steps = env_steps;
    }
}

impl<E: Env, O: OccupancyEstimator, S: ShadowReward> RewardModel for Collector<E, O, S> {
    fn goal_reward(&self, achieved: &[f32], desired: &[f32]) -> f32 {
        self.env.goal_reward(achieved, desired)
    }

    fn agent_rewards(&self, task: f32, phi: &[f32], out: &mut [f32]) {
        self.rewards.compute(task, phi, self.occupancy.estimate(), out);
    }

    fn reward_bounds(&self) -> Vec<(f64, f64)> {
        self.rewards.step_bounds(self.env.spec().reward_range)
    }
}
