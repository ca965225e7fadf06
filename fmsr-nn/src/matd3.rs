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

use fmsr_core::policy::{ActMode, PolicyOutput};

use crate::config::Matd3Config;
use crate::error::NnError;
use crate::explore::gaussian;
use crate::learner::{BatchTensors, Learner, LearnerParts, matrix};
use crate::off_policy::{OffPolicy, StepLosses, UpdateRule};

/// Multi-agent TD3; see the [module docs](self).
pub type Matd3 = OffPolicy<Matd3Rule>;

/// MATD3's update rule: its config is all it adds to the shared learner.
#[derive(Debug, Clone, PartialEq)]
pub struct Matd3Rule {
    config: Matd3Config,
}

impl Matd3Rule {
    /// The rule with these settings (checked when a learner is built).
    #[must_use]
    pub fn new(config: Matd3Config) -> Self {
        Self { config }
    }
}

impl Matd3 {
    /// MATD3 from the shared parts and its own config.
    ///
    /// # Errors
    /// [`NnError::InvalidConfig`] / [`NnError::Sharing`] naming the first impossible setting.
    pub fn new(parts: LearnerParts, config: Matd3Config) -> Result<Self, NnError> {
        Self::with_rule(parts, Matd3Rule::new(config))
    }

    /// The algorithm's config.
    #[must_use]
    pub fn config(&self) -> &Matd3Config {
        &self.rule.config
    }
}

impl UpdateRule for Matd3Rule {
    const NAME: &'static str = "matd3";
    const CRITICS: usize = 2;

    fn validate(&self) -> Result<(), NnError> {
        self.config.validate()
    }

    fn act(&mut self, l: &mut Learner, inputs: &[Vec<f32>], n: usize, mode: ActMode) -> Result<PolicyOutput, NnError> {
        l.deterministic_act(inputs, n, mode, self.config.noise_eps, self.config.random_eps)
    }

    /// One critic step, and an actor step every `policy_delay` of them.
    fn step(&mut self, l: &mut Learner, b: &BatchTensors) -> Result<StepLosses, NnError> {
        let (sigma, clip) = (self.config.target_noise as f32, self.config.target_noise_clip as f32);
        let width = l.joint_width();
        let noise: Vec<f32> = (0..b.n * width).map(|_| (sigma * gaussian(&mut l.rng)).clamp(-clip, clip)).collect();
        let smoothed = l.target_actions(b)? + matrix(noise, b.n, width, &l.device);
        let critic = l.critic_step(b, smoothed.clamp(-1.0, 1.0))?;
        // This is critic step `step_index() + 1` (counted from one).
        let actor = if (l.step_index() + 1).is_multiple_of(self.config.policy_delay as u64) {
            Some(l.deterministic_actor_step(b, self.config.action_l2, self.config.teammates)?)
        } else {
            None
        };
        Ok(StepLosses { critic, actor })
    }

    fn targets(&self) -> (f64, bool) {
        (self.config.polyak, true)
    }
}
