//! MASAC: soft actor-critic (Haarnoja et al. 2018) per agent, with HER, shadow
//! rewards and information sharing exactly as MADDPG.
//!
//! Agent `i`'s actor is a tanh-squashed Gaussian ([`crate::SquashedGaussian`]:
//! `a = tanh(m + exp(s) eps)`); the rule is written against the learner's
//! public view alone (its stochastic steps), as a user's SAC variant would be:
//!
//! ```text
//! y_i  = clip(r_i + gamma * (min(Q'_i1, Q'_i2)(x', g, a') - alpha_i log pi_i(a'_i | o'_i)), lo_i, hi_i)
//! L_Q  = mean (Q_i1 - y_i)^2 + mean (Q_i2 - y_i)^2
//! L_pi = mean (alpha_i log pi_i(a_i | o_i) - min(Q_i1, Q_i2)(x, g, a_1..a_i..a_N))
//! L_alpha = -mean log alpha_i (log pi_i(a_i | o_i) + H_i),   H_i = target_entropy_per_dim * dim(A_i)
//! ```
//!
//! `a'` are sampled from the current actors; the critics' targets move once
//! per cycle. Evaluation acts with `tanh(m)`.

use fmsr_core::policy::{ActMode, PolicyOutput};
use serde::{Deserialize, Serialize};

use crate::config::MasacConfig;
use crate::error::NnError;
use crate::learner::{BatchTensors, Learner, LearnerParts, SquashedGaussian};
use crate::off_policy::{OffPolicy, StepLosses, UpdateRule};
use crate::state::RuleState;

/// Adam on one scalar (the log temperature), as the networks' Adam.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
struct ScalarAdam {
    t: u64,
    m: f64,
    v: f64,
}

impl ScalarAdam {
    fn step(&mut self, x: &mut f64, grad: f64, lr: f64, (b1, b2, eps): (f64, f64, f64)) {
        self.t += 1;
        self.m = b1 * self.m + (1.0 - b1) * grad;
        self.v = b2 * self.v + (1.0 - b2) * grad * grad;
        let t = self.t.min(i32::MAX as u64) as i32;
        let (mh, vh) = (self.m / (1.0 - b1.powi(t)), self.v / (1.0 - b2.powi(t)));
        *x -= lr * mh / (vh.sqrt() + eps);
    }
}

/// Multi-agent SAC; see the [module docs](self).
pub type Masac = OffPolicy<MasacRule>;

/// MASAC's update rule: its config and its own state.
#[derive(Debug, Clone, PartialEq)]
pub struct MasacRule {
    config: MasacConfig,
    state: MasacState,
}

impl MasacRule {
    /// The rule with these settings (checked when a learner is built).
    #[must_use]
    pub fn new(config: MasacConfig) -> Self {
        Self { config, state: MasacState::default() }
    }
}

/// What MASAC learns beside the networks: every agent's log entropy
/// temperature and the Adam state that tunes it (saved with the learner).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub(crate) struct MasacState {
    log_alpha: Vec<f64>,
    alpha_adam: Vec<ScalarAdam>,
}

impl Masac {
    /// MASAC from the shared parts and its own config.
    ///
    /// # Errors
    /// [`NnError::InvalidConfig`] / [`NnError::Sharing`] naming the first impossible setting.
    pub fn new(parts: LearnerParts, config: MasacConfig) -> Result<Self, NnError> {
        Self::with_rule(parts, MasacRule::new(config))
    }

    /// The algorithm's config.
    #[must_use]
    pub fn config(&self) -> &MasacConfig {
        &self.rule.config
    }

    /// Each agent's entropy temperature `alpha_i`.
    #[must_use]
    pub fn temperatures(&self) -> Vec<f64> {
        self.rule.state.log_alpha.iter().map(|l| l.exp()).collect()
    }
}

impl MasacRule {
    fn dist(&self) -> SquashedGaussian {
        SquashedGaussian { log_std_min: self.config.log_std_min as f32, log_std_max: self.config.log_std_max as f32 }
    }

    fn temperatures_f32(&self) -> Vec<f32> {
        self.state.log_alpha.iter().map(|v| v.exp() as f32).collect()
    }

    /// One Adam step of every agent's log temperature towards its target entropy.
    fn update_temperatures(&mut self, mean_logp: &[f32], dims: &[usize], betas: (f64, f64, f64)) {
        let s = &mut self.state;
        for (((la, adam), &lp), &d) in s.log_alpha.iter_mut().zip(&mut s.alpha_adam).zip(mean_logp).zip(dims) {
            let target = self.config.target_entropy_per_dim * d as f64;
            let grad = -(f64::from(lp) + target);
            adam.step(la, grad, self.config.lr_temperature, betas);
        }
    }
}

impl UpdateRule for MasacRule {
    const NAME: &'static str = "masac";
    const CRITICS: usize = 2;
    const HEADS: usize = 2;

    fn validate(&self) -> Result<(), NnError> {
        self.config.validate()
    }

    fn init(&mut self, agents: usize) {
        self.state = MasacState {
            log_alpha: vec![self.config.initial_temperature.ln(); agents],
            alpha_adam: vec![ScalarAdam::default(); agents],
        };
    }

    fn act(&mut self, l: &mut Learner, inputs: &[Vec<f32>], n: usize, mode: ActMode) -> Result<PolicyOutput, NnError> {
        l.squashed_gaussian_act(inputs, n, mode, self.dist(), self.config.random_eps)
    }

    /// One step of every agent's critics, actor and temperature.
    fn step(&mut self, l: &mut Learner, b: &BatchTensors) -> Result<StepLosses, NnError> {
        let (dist, alphas) = (self.dist(), self.temperatures_f32());
        // Next actions from the current actors, with their log-probabilities.
        let (next, soft) = l.sampled_next_actions(b, dist, &alphas)?;
        let critic = l.soft_critic_step(b, next, soft)?;
        // Actor step on fresh samples; the batch means of log pi feed the temperature.
        let (actor, mean_logp) = l.squashed_gaussian_actor_step(b, dist, &alphas, self.config.teammates)?;
        let dims: Vec<usize> = (0..l.num_agents()).map(|i| l.action_dim(i)).collect();
        let c = l.networks();
        self.update_temperatures(&mean_logp, &dims, (c.adam_beta1, c.adam_beta2, c.adam_epsilon));
        Ok(StepLosses { critic, actor: Some(actor) })
    }

    fn targets(&self) -> (f64, bool) {
        (self.config.polyak, false)
    }

    /// Version 1: postcard of `MasacState` (the temperatures' state, as learner states of formats 5 and 6 held it).
    fn state(&self) -> Result<Option<RuleState>, NnError> {
        RuleState::encode(1, &self.state).map(Some)
    }

    fn restore(&mut self, state: Option<&RuleState>, agents: usize) -> Result<(), NnError> {
        let state: MasacState = match state {
            Some(s) => s.decode(Self::NAME, 1..=1)?,
            None => MasacState::default(),
        };
        let (a, b) = (state.log_alpha.len(), state.alpha_adam.len());
        if a != agents || b != agents {
            return Err(NnError::StateMismatch {
                what: "temperature state (log temperatures, Adam states)".into(),
                expected: format!("{agents}, {agents}"),
                found: format!("{a}, {b}"),
            });
        }
        self.state = state;
        Ok(())
    }
}
