//! MATD3: TD3 (Fujimoto et al. 2018) per agent, with HER, shadow rewards and
//! information sharing exactly as MADDPG.
//!
//! ```text
//! a'_j = clip(tanh(mu'_j(o'_j)) + clip(eps, -c, c), -1, 1),  eps ~ N(0, sigma^2)   (target smoothing)
//! y_i  = clip(r_i + gamma * min(Q'_i1, Q'_i2)(x', g, a'), lo_i, hi_i)              (twin critics)
//! L_Q  = mean (Q_i1 - y_i)^2 + mean (Q_i2 - y_i)^2
//! ```
//!
//! The actors (with their information sharing) update on `Q_i1` once every
//! `policy_delay` critic steps; targets move once per cycle.

use fmsr_core::algorithm::{Algorithm, RewardModel, UpdateStats};
use fmsr_core::policy::{ActMode, Policy, PolicyOutput, PolicyState};
use fmsr_core::replay::Episode;

use crate::config::Matd3Config;
use crate::error::NnError;
use crate::explore::gaussian;
use crate::learner::{Learner, LearnerParts, matrix};
use crate::maddpg::{StepLosses, actor_step, deterministic_act, run_cycle, target_actions};

/// Multi-agent TD3; see the [module docs](self).
#[derive(Debug)]
pub struct Matd3 {
    learner: Learner,
    config: Matd3Config,
}

impl Matd3 {
    /// MATD3 from the shared parts and its own config.
    ///
    /// # Errors
    /// [`NnError::InvalidConfig`] / [`NnError::Sharing`] naming the first impossible setting.
    pub fn new(parts: LearnerParts, config: Matd3Config) -> Result<Self, NnError> {
        config.validate()?;
        Ok(Self { learner: Learner::new(parts, 2, 1)?, config })
    }

    /// The algorithm's config.
    #[must_use]
    pub fn config(&self) -> &Matd3Config {
        &self.config
    }

    /// One critic step, and an actor step every `policy_delay` of them;
    /// `None` while the replay is empty.
    ///
    /// # Errors
    /// Backend and shape errors.
    pub fn step(&mut self, rewards: &dyn RewardModel) -> Result<Option<StepLosses>, NnError> {
        let Some(b) = self.learner.sample(rewards)? else { return Ok(None) };
        let (sigma, clip) = (self.config.target_noise as f32, self.config.target_noise_clip as f32);
        let l = &mut self.learner;
        let width: usize = (0..l.num_agents()).map(|i| l.action_dim(i)).sum();
        let noise: Vec<f32> = (0..b.n * width).map(|_| (sigma * gaussian(&mut l.rng)).clamp(-clip, clip)).collect();
        let smoothed = target_actions(l, &b)? + matrix(noise, b.n, width, &l.device);
        let critic = l.critic_step(&b, smoothed.clamp(-1.0, 1.0), None)?;
        l.steps += 1;
        let actor = if l.steps.is_multiple_of(self.config.policy_delay as u64) {
            Some(actor_step(l, &b, self.config.action_l2, self.config.teammates)?)
        } else {
            None
        };
        Ok(Some(StepLosses { critic, actor }))
    }

    /// Agent `agent`'s actor trunk, flattened.
    ///
    /// # Errors
    /// [`NnError::UnknownAgent`].
    pub fn actor_trunk(&self, agent: usize) -> Result<Vec<f32>, NnError> {
        self.learner.actor_trunk(agent)
    }
}

impl Policy for Matd3 {
    type Error = NnError;

    fn num_agents(&self) -> usize {
        self.learner.num_agents()
    }

    fn act(&mut self, inputs: &[Vec<f32>], n: usize, mode: ActMode) -> Result<PolicyOutput, NnError> {
        deterministic_act(&mut self.learner, inputs, n, mode, (self.config.noise_eps, self.config.random_eps))
    }
}

impl Algorithm for Matd3 {
    fn store(&mut self, episode: &Episode) -> Result<(), NnError> {
        self.learner.store(episode)
    }

    fn update(&mut self, rewards: &dyn RewardModel) -> Result<UpdateStats, NnError> {
        let (batches, agents) = (self.learner.replay_config.batches, self.learner.num_agents());
        let stats = run_cycle(batches, agents, || self.step(rewards))?;
        if stats.updates > 0 {
            self.learner.soft_update_targets(self.config.polyak, true);
        }
        Ok(stats)
    }

    fn save_state(&self, include_storage: bool) -> Result<Vec<u8>, NnError> {
        self.learner.save("matd3", include_storage, Vec::new())
    }

    fn load_state(&mut self, bytes: &[u8]) -> Result<(), NnError> {
        self.learner.load("matd3", bytes).map(|_| ())
    }

    fn storage_capacity(&self) -> usize {
        self.learner.storage_capacity()
    }

    fn restore_storage(&mut self, total: u64, episodes: &[Episode]) -> Result<(), NnError> {
        self.learner.restore_storage(total, episodes)
    }
}

impl PolicyState for Matd3 {
    fn save_policy(&self) -> Result<Vec<u8>, NnError> {
        self.learner.save_policy("matd3")
    }

    fn load_policy(&mut self, bytes: &[u8]) -> Result<(), NnError> {
        self.learner.load_policy("matd3", bytes)
    }
}
