//! MADDPG with HER-baselines losses (paper section III, eqs. 5, 7, 9).
//!
//! Per agent `i`, on one shared HER batch (experience synchronisation):
//!
//! ```text
//! a'_j = tanh(mu'_j(o'_j))                                          every agent j
//! y_i  = clip(r_i + gamma * Q'_i(x', g, a'_1..a'_N), lo_i, hi_i)    (eq. 7, clip_return)
//! L_Q  = mean (Q_i(x, g, a_1..a_N) - y_i)^2
//! L_mu = -mean Q_i(x, g, a_1..mu_i(o_i)..a_N) + action_l2 * mean mu_i(o_i)^2   (eq. 5)
//! ```
//!
//! `batches` such steps per cycle (critics, then actors, with information
//! sharing at the two hooks of [`fmsr_core::sharing`]), then the targets move
//! once: `theta' <- polyak theta' + (1 - polyak) theta` (eq. 9). The cycle and
//! everything but the two losses are the shared [`OffPolicy`] learner's.

use fmsr_core::agent::Batch;
use fmsr_core::policy::{ActMode, PolicyOutput};

use crate::config::MaddpgConfig;
use crate::error::NnError;
use crate::learner::{BatchTensors, Learner, LearnerParts};
use crate::off_policy::{OffPolicy, StepLosses, UpdateRule};

/// Multi-agent DDPG; see the [module docs](self).
///
/// ```
/// use fmsr_core::prelude::*;
/// use fmsr_nn::prelude::*;
/// let agent = |n: &str, s: Vec<usize>| AgentSpec { name: n.into(), action_slots: s, local_obs_dim: 3 };
/// let spec = EnvSpec { agents: vec![agent("a", vec![0]), agent("b", vec![1, 2])], action_dim: 3, obs_dim: 4,
///     goal_dim: 2, episode_len: 10, features: vec![], reward_range: (-1.0, 0.0) };
/// let layout = ObservationLayout::new(spec, vec![vec![1], vec![0]])?;
/// let parts = LearnerParts::new(layout, NetworkConfig::new().with_hidden(16).with_layers(2), ReplayConfig::default(), 0.9);
/// let mut maddpg = Maddpg::new(parts, MaddpgConfig::new())?;
/// let out = maddpg.act(&[vec![0.1; 7], vec![0.2; 6]], 1, ActMode::Evaluate)?;
/// assert_eq!((out.actions[0].len(), out.actions[1].len()), (1, 2));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub type Maddpg = OffPolicy<MaddpgRule>;

/// MADDPG's update rule: its config is all it adds to the shared learner.
#[derive(Debug, Clone, PartialEq)]
pub struct MaddpgRule {
    config: MaddpgConfig,
}

impl MaddpgRule {
    /// The rule with these settings (checked when a learner is built).
    #[must_use]
    pub fn new(config: MaddpgConfig) -> Self {
        Self { config }
    }
}

impl Maddpg {
    /// MADDPG from the shared parts and its own config.
    ///
    /// # Errors
    /// [`NnError::InvalidConfig`] / [`NnError::Sharing`] naming the first impossible setting.
    pub fn new(parts: LearnerParts, config: MaddpgConfig) -> Result<Self, NnError> {
        Self::with_rule(parts, MaddpgRule::new(config))
    }

    /// The algorithm's config.
    #[must_use]
    pub fn config(&self) -> &MaddpgConfig {
        &self.rule.config
    }

    /// One gradient step on a given batch (the normalisers are updated from
    /// it), with each agent's Q targets clipped to `q_bounds[i]`. Returns the
    /// critic and actor losses of every agent.
    ///
    /// # Errors
    /// [`NnError::Dimension`] / [`NnError::NotFinite`] for a batch that does not
    /// fit the layout, backend errors.
    pub fn learn_batch(&mut self, batch: &Batch, q_bounds: &[(f32, f32)]) -> Result<(Vec<f32>, Vec<f32>), NnError> {
        let b = self.learner.tensors(batch, q_bounds.to_vec())?;
        let StepLosses { critic, actor } = self.rule_step(&b)?;
        Ok((critic, actor.unwrap_or_default()))
    }
}

impl UpdateRule for MaddpgRule {
    const NAME: &'static str = "maddpg";

    fn validate(&self) -> Result<(), NnError> {
        self.config.validate()
    }

    fn act(&mut self, l: &mut Learner, inputs: &[Vec<f32>], n: usize, mode: ActMode) -> Result<PolicyOutput, NnError> {
        l.deterministic_act(inputs, n, mode, self.config.noise_eps, self.config.random_eps)
    }

    fn step(&mut self, l: &mut Learner, b: &BatchTensors) -> Result<StepLosses, NnError> {
        let next = l.target_actions(b)?;
        let critic = l.critic_step(b, next)?;
        let actor = l.deterministic_actor_step(b, self.config.action_l2, self.config.teammates)?;
        Ok(StepLosses { critic, actor: Some(actor) })
    }

    fn targets(&self) -> (f64, bool) {
        (self.config.polyak, true)
    }
}
