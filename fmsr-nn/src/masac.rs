//! MASAC: soft actor-critic (Haarnoja et al. 2018) per agent, with HER, shadow
//! rewards and information sharing exactly as MADDPG.
//!
//! Agent `i`'s actor head gives the mean `m` and log standard deviation `s`
//! (clamped to `[log_std_min, log_std_max]`) of a Gaussian squashed by tanh:
//!
//! ```text
//! u = m + exp(s) * eps,  eps ~ N(0, I),   a = tanh(u)
//! log pi(a | o) = sum_k [ -eps_k^2 / 2 - s_k - log(2 pi) / 2 - log(1 - tanh(u_k)^2) ]
//! y_i  = clip(r_i + gamma * (min(Q'_i1, Q'_i2)(x', g, a') - alpha_i log pi_i(a'_i | o'_i)), lo_i, hi_i)
//! L_Q  = mean (Q_i1 - y_i)^2 + mean (Q_i2 - y_i)^2
//! L_pi = mean (alpha_i log pi_i(a_i | o_i) - min(Q_i1, Q_i2)(x, g, a_1..a_i..a_N))
//! L_alpha = -mean log alpha_i (log pi_i(a_i | o_i) + H_i),   H_i = target_entropy_per_dim * dim(A_i)
//! ```
//!
//! `a'` are sampled from the current actors; the critics' targets move once
//! per cycle. Evaluation acts with `tanh(m)`.

use std::sync::Mutex;

use burn::module::Module;
use burn::tensor::activation::softplus;
use burn::tensor::{Tensor, TensorData};
use fmsr_core::policy::{ActMode, PolicyOutput};
use serde::{Deserialize, Serialize};

use crate::config::{MasacConfig, Teammates};
use crate::error::NnError;
use crate::explore::{gaussian, randomize};
use crate::group::to_vec1;
use crate::learner::{BatchTensors, Learner, LearnerParts};
use crate::off_policy::{OffPolicy, StepLosses, UpdateRule};
use crate::state::RuleState;

const HALF_LOG_TAU: f32 = 0.918_938_5; // log(2 pi) / 2

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

/// A reparameterised sample `a = tanh(m + exp(s) eps)` of every agent,
/// `[A, n, d_max]` (zero in the padding), and `log pi(a)`, `[A, n, 1]`; `head`
/// is `[A, n, 2 d_max]` (means, then log-stds), `mask` `[A, 1, d_max]`.
fn sample(head: Tensor<3>, eps: Tensor<3>, mask: Tensor<3>, bounds: (f32, f32)) -> (Tensor<3>, Tensor<3>) {
    let dim = eps.dims()[2];
    let mean = head.clone().narrow(2, 0, dim);
    let log_std = head.narrow(2, dim, dim).clamp(bounds.0, bounds.1);
    let u = mean + log_std.clone().exp() * eps.clone();
    let a = u.clone().tanh() * mask.clone();
    // log(1 - tanh(u)^2) = 2 (log 2 - u - softplus(-2u)), stable for large |u|.
    let log_jac =
        (u.clone().neg().sub_scalar(-std::f32::consts::LN_2) - softplus(u.mul_scalar(-2.0), 1.0)).mul_scalar(2.0);
    let log_prob = (eps.square().mul_scalar(-0.5) - log_std).sub_scalar(HALF_LOG_TAU) - log_jac;
    (a, (log_prob * mask).sum_dim(2))
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
    fn bounds(&self) -> (f32, f32) {
        (self.config.log_std_min as f32, self.config.log_std_max as f32)
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
        let heads = l.heads(inputs, n)?;
        let (lo, hi) = self.bounds();
        let mut actions = Vec::with_capacity(heads.len());
        let mut log_probs = Vec::with_capacity(heads.len());
        for (i, h) in heads.iter().enumerate() {
            let d = l.action_dim(i);
            let mut a = Vec::with_capacity(n * d);
            let mut lps = Vec::with_capacity(n);
            for row in h.chunks_exact(2 * d) {
                let (mean, log_std) = row.split_at(d);
                let mut lp = 0.0f32;
                for (m, s) in mean.iter().zip(log_std) {
                    let s = s.clamp(lo, hi);
                    let eps = if mode == ActMode::Explore { gaussian(&mut l.rng) } else { 0.0 };
                    let u = m + s.exp() * eps;
                    lp += -0.5 * eps * eps - s - HALF_LOG_TAU - (1.0 - u.tanh().powi(2) + 1e-6).ln();
                    a.push(u.tanh());
                }
                lps.push(lp);
            }
            actions.push(a);
            log_probs.push(lps);
        }
        if mode == ActMode::Explore && self.config.random_eps > 0.0 {
            randomize(&mut actions, n, self.config.random_eps as f32, &mut l.rng);
        }
        Ok(PolicyOutput {
            actions,
            log_probs: if mode == ActMode::Explore { log_probs } else { Vec::new() },
            values: Vec::new(),
        })
    }

    /// One step of every agent's critics, actor and temperature.
    fn step(&mut self, l: &mut Learner, b: &BatchTensors) -> Result<StepLosses, NnError> {
        let (n, na, bounds) = (b.n, l.num_agents(), self.bounds());
        let device = l.device.clone();
        let alphas: Vec<f32> = self.state.log_alpha.iter().map(|v| v.exp() as f32).collect();
        let alpha: Vec<Tensor<3>> = l
            .groups
            .iter()
            .map(|g| Tensor::from_data(TensorData::new(alphas[g.agents.clone()].to_vec(), [g.len(), 1, 1]), &device))
            .collect();
        // Next actions from the current actors, with their log-probabilities.
        let eps_next = l.noise(n, gaussian);
        let next = l.per_group(|g, group| {
            let head = group.nets.actors.valid().forward(b.groups[g].x_next.clone());
            let (a, lp) = sample(head, eps_next[g].clone(), group.joint.mask.clone(), bounds);
            Ok((group.joint.join(a), lp * alpha[g].clone()))
        })?;
        let (joint, soft): (Vec<Tensor<2>>, Vec<Tensor<3>>) = next.into_iter().unzip();
        let joint = joint
            .into_iter()
            .reduce(|a, b| a + b)
            .ok_or(NnError::Backend { what: "next actions", reason: "no group".into() })?;
        let critic = l.critic_step_soft(b, joint, Some(soft))?;
        // Actor step on fresh samples; the batch means of log pi feed the temperature.
        let eps = l.noise(n, gaussian);
        let current;
        let b = match self.config.teammates {
            Teammates::Replay => b,
            Teammates::Current => {
                current = l.with_current_actions(b, |head, group| head.narrow(2, 0, group.max_action()).tanh())?;
                &current
            }
        };
        let mean_logp = Mutex::new(vec![0.0f32; na]);
        let actor = l.actor_step(|g, group, critics| {
            let head = group.nets.actors.forward(Tensor::from_inner(b.groups[g].x_now.clone()));
            let mask = Tensor::from_inner(group.joint.mask.clone());
            let (a, lp) = sample(head, Tensor::from_inner(eps[g].clone()), mask, bounds);
            let input = group.critic_input_own(a, &b.og, &b.actions, &b.groups[g]);
            let q = critics.nets[0].forward(input.clone()).min_pair(critics.nets[1].forward(input));
            let m = to_vec1(lp.clone().mean_dim(1).reshape([group.len()]), "log pi")?;
            if let Ok(mut v) = mean_logp.lock() {
                v[group.agents.clone()].copy_from_slice(&m);
            }
            Ok((lp * Tensor::from_inner(alpha[g].clone()) - q).mean_dim(1).reshape([group.len()]))
        })?;
        let mut mean_logp =
            mean_logp.into_inner().map_err(|_| NnError::Backend { what: "log pi", reason: "poisoned".into() })?;
        // Every worker tunes the same temperatures (the mean over all batches).
        l.comm.all_reduce_mean(&mut mean_logp);
        let dims: Vec<usize> = (0..na).map(|i| l.action_dim(i)).collect();
        let c = &l.net;
        self.update_temperatures(&mean_logp, &dims, (c.adam_beta1, c.adam_beta2, c.adam_epsilon));
        Ok(StepLosses { critic, actor: Some(actor) })
    }

    fn targets(&self) -> (f64, bool) {
        (self.config.polyak, false)
    }

    /// Version 1: postcard of [`MasacState`] (as learner states of formats 5 and 6 held it).
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

    /// Format 4 kept the log temperatures, then each agent's Adam state `(t, m, v)`.
    fn state_from_values(&self, values: &[f64], agents: usize) -> Result<Option<RuleState>, NnError> {
        if values.len() != 4 * agents {
            return Err(NnError::StateMismatch {
                what: "temperature state".into(),
                expected: (4 * agents).to_string(),
                found: values.len().to_string(),
            });
        }
        let (log_alpha, adam) = values.split_at(agents);
        let alpha_adam = adam.chunks_exact(3).map(|c| ScalarAdam { t: c[0] as u64, m: c[1], v: c[2] }).collect();
        RuleState::encode(1, &MasacState { log_alpha: log_alpha.to_vec(), alpha_adam }).map(Some)
    }
}
