//! What the stochastic-actor rules (MASAC, a user's SAC variant) share: a
//! squashed Gaussian policy (Haarnoja et al. 2018), its reparameterised
//! samples, the soft critic step and the entropy-regularised actor step.
//!
//! Agent `i`'s actor head gives the mean `m` and log standard deviation `s`
//! (clamped to `[log_std_min, log_std_max]`) of a Gaussian squashed by tanh:
//!
//! ```text
//! u = m + exp(s) * eps,  eps ~ N(0, I),   a = tanh(u)
//! log pi(a | o) = sum_k [ -eps_k^2 / 2 - s_k - log(2 pi) / 2 - log(1 - tanh(u_k)^2) ]
//! ```
//!
//! A rule with such a policy declares `HEADS = 2` (means, then log-stds; the
//! steps refuse other heads with [`NnError::InvalidConfig`]) and usually
//! `CRITICS = 2` (the steps take the minimum over the critics), and passes
//! every agent's entropy temperature `alpha_i` to each step.

use std::sync::Mutex;

use burn::module::Module;
use burn::tensor::activation::softplus;
use burn::tensor::{Tensor, TensorData};
use fmsr_core::policy::{ActMode, PolicyOutput};

use super::{BatchTensors, Learner};
use crate::config::Teammates;
use crate::error::NnError;
use crate::explore::{gaussian, randomize};
use crate::group::to_vec1;

const HALF_LOG_TAU: f32 = 0.918_938_5; // log(2 pi) / 2

/// A tanh-squashed Gaussian policy head: the clamp of its log standard deviations.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SquashedGaussian {
    /// Lower bound of `s` (MASAC's default: -5).
    pub log_std_min: f32,
    /// Upper bound of `s` (MASAC's default: 2).
    pub log_std_max: f32,
}

/// Every agent's soft term `alpha_j log pi_j(a'_j | o'_j)` at `t + 1`, which
/// [`Learner::soft_critic_step`] subtracts from the critics' targets; made by
/// [`Learner::sampled_next_actions`].
#[derive(Debug, Clone)]
pub struct SoftTerm {
    /// Per group, `[A_g, n, 1]`.
    pub(super) groups: Vec<Tensor<3>>,
}

/// A reparameterised sample `a = tanh(m + exp(s) eps)` of every agent of a
/// group, `[A, n, d_max]` (zero in the padding), and `log pi(a)`, `[A, n, 1]`;
/// `head` is `[A, n, 2 d_max]` (means, then log-stds), `mask` `[A, 1, d_max]`.
fn sample(head: Tensor<3>, eps: Tensor<3>, mask: Tensor<3>, dist: SquashedGaussian) -> (Tensor<3>, Tensor<3>) {
    let dim = eps.dims()[2];
    let mean = head.clone().narrow(2, 0, dim);
    let log_std = head.narrow(2, dim, dim).clamp(dist.log_std_min, dist.log_std_max);
    let u = mean + log_std.clone().exp() * eps.clone();
    let a = u.clone().tanh() * mask.clone();
    // log(1 - tanh(u)^2) = 2 (log 2 - u - softplus(-2u)), stable for large |u|.
    let log_jac =
        (u.clone().neg().sub_scalar(-std::f32::consts::LN_2) - softplus(u.mul_scalar(-2.0), 1.0)).mul_scalar(2.0);
    let log_prob = (eps.square().mul_scalar(-0.5) - log_std).sub_scalar(HALF_LOG_TAU) - log_jac;
    (a, (log_prob * mask).sum_dim(2))
}

impl Learner {
    /// Refuses actors whose heads are not a squashed Gaussian's two blocks.
    fn check_gaussian_heads(&self) -> Result<(), NnError> {
        for (i, d) in (0..self.num_agents()).map(|i| (i, self.action_dim(i))) {
            let (g, k) = self.locate(i)?;
            let width = self.groups[g].actor_layout.head_cols.get(k).map_or(0, Vec::len);
            if width != 2 * d {
                return Err(NnError::InvalidConfig {
                    key: "UpdateRule::HEADS",
                    reason: format!(
                        "the squashed-Gaussian steps need 2 head blocks (means, log-stds); agent {i}'s actor has {width} outputs for {d} actions"
                    ),
                });
            }
        }
        Ok(())
    }

    /// Each group's temperatures `[A_g, 1, 1]`.
    fn temperature_tensors(&self, temperatures: &[f32]) -> Result<Vec<Tensor<3>>, NnError> {
        let na = self.num_agents();
        if temperatures.len() != na {
            return Err(NnError::Dimension { what: "temperatures".into(), expected: na, found: temperatures.len() });
        }
        let device = &self.device;
        Ok(self
            .groups
            .iter()
            .map(|g| {
                Tensor::from_data(TensorData::new(temperatures[g.agents.clone()].to_vec(), [g.len(), 1, 1]), device)
            })
            .collect())
    }

    /// Next actions `a'_j ~ pi_j(. | o'_j)` sampled from every agent's
    /// current actor, agent-major `[rows, joint_width]` (the next actions of
    /// [`Learner::soft_critic_step`]), and the soft term `alpha_j log pi_j(a'_j | o'_j)`
    /// with `alpha_j = temperatures[j]`. The noise comes from [`Learner::rng`].
    ///
    /// # Errors
    /// [`NnError::Dimension`] when `temperatures` is not one per agent,
    /// [`NnError::InvalidConfig`] for actors without two head blocks; backend errors.
    pub fn sampled_next_actions(
        &mut self,
        b: &BatchTensors,
        dist: SquashedGaussian,
        temperatures: &[f32],
    ) -> Result<(Tensor<2>, SoftTerm), NnError> {
        self.check_gaussian_heads()?;
        let alpha = self.temperature_tensors(temperatures)?;
        let eps = self.noise(b.n, gaussian);
        let next = self.per_group(|g, group| {
            let head = group.nets.actors.valid().forward(b.groups[g].x_next.clone());
            let (a, lp) = sample(head, eps[g].clone(), group.joint.mask.clone(), dist);
            Ok((group.joint.join(a), lp * alpha[g].clone()))
        })?;
        let (joint, soft): (Vec<Tensor<2>>, Vec<Tensor<3>>) = next.into_iter().unzip();
        let joint = joint
            .into_iter()
            .reduce(|a, b| a + b)
            .ok_or(NnError::Backend { what: "next actions", reason: "no group".into() })?;
        Ok((joint, SoftTerm { groups: soft }))
    }

    /// [`Learner::critic_step`] towards the soft target (eq. 7 with SAC's entropy term)
    ///
    /// ```text
    /// y_i = clip(r_i + gamma * (min_c Q'_{i,c}(x', g, a') - alpha_i log pi_i(a'_i | o'_i)), lo_i, hi_i)
    /// ```
    ///
    /// with `next_actions` and `soft` from [`Learner::sampled_next_actions`].
    /// Returns each agent's loss.
    ///
    /// # Errors
    /// Backend errors.
    pub fn soft_critic_step(
        &mut self,
        b: &BatchTensors,
        next_actions: Tensor<2>,
        soft: SoftTerm,
    ) -> Result<Vec<f32>, NnError> {
        let loss = self.net.critic_loss;
        self.critic_step_soft(b, next_actions, Some(soft.groups), &loss)
    }

    /// One optimiser step of every agent's actor on the entropy-regularised loss
    ///
    /// ```text
    /// L_i = mean (alpha_i log pi_i(a_i | o_i) - min_c Q_{i,c}(.., a_i, ..)),   a_i ~ pi_i(. | o_i)
    /// ```
    ///
    /// (reparameterised samples, noise from [`Learner::rng`]), where the
    /// critics see their rule's [`crate::CriticView`] with agent `i`'s own
    /// action replaced by `a_i`, the other agents' the sampled ones
    /// ([`Teammates::Replay`]) or `tanh` of their actors' current means.
    /// Worker averaging and information sharing of the actors happen here.
    /// Returns each agent's loss and its batch mean of `log pi_i(a_i | o_i)`,
    /// averaged over worker processes (what a temperature is tuned on).
    ///
    /// # Errors
    /// [`NnError::Dimension`] when `temperatures` is not one per agent,
    /// [`NnError::InvalidConfig`] for actors without two head blocks; backend errors.
    pub fn squashed_gaussian_actor_step(
        &mut self,
        b: &BatchTensors,
        dist: SquashedGaussian,
        temperatures: &[f32],
        teammates: Teammates,
    ) -> Result<(Vec<f32>, Vec<f32>), NnError> {
        self.check_gaussian_heads()?;
        let alpha = self.temperature_tensors(temperatures)?;
        let eps = self.noise(b.n, gaussian);
        let current;
        let b = match teammates {
            Teammates::Replay => b,
            Teammates::Current => {
                current = self.with_current_actions(b, |head, group| head.narrow(2, 0, group.max_action()).tanh())?;
                &current
            }
        };
        let mean_logp = Mutex::new(vec![0.0f32; self.num_agents()]);
        let losses = self.actor_step(|g, group, critics| {
            let head = group.nets.actors.forward(Tensor::from_inner(b.groups[g].x_now.clone()));
            let mask = Tensor::from_inner(group.joint.mask.clone());
            let (a, lp) = sample(head, Tensor::from_inner(eps[g].clone()), mask, dist);
            let input = group.critic_input_own(a, &b.og, &b.actions, &b.groups[g]);
            let q = critics
                .nets
                .iter()
                .map(|c| c.forward(input.clone()))
                .reduce(Tensor::min_pair)
                .ok_or(NnError::Backend { what: "critic", reason: "no critic".into() })?;
            let m = to_vec1(lp.clone().mean_dim(1).reshape([group.len()]), "log pi")?;
            if let Ok(mut v) = mean_logp.lock() {
                v[group.agents.clone()].copy_from_slice(&m);
            }
            Ok((lp * Tensor::from_inner(alpha[g].clone()) - q).mean_dim(1).reshape([group.len()]))
        })?;
        let mut mean_logp =
            mean_logp.into_inner().map_err(|_| NnError::Backend { what: "log pi", reason: "poisoned".into() })?;
        // Every worker tunes the same temperatures (the mean over all batches).
        self.comm.all_reduce_mean(&mut mean_logp);
        Ok((losses, mean_logp))
    }

    /// Actions of the squashed Gaussian policies for `n` rows of raw actor
    /// inputs per agent: `tanh(m)` in [`ActMode::Evaluate`]; a sample (noise
    /// from [`Learner::rng`]) with its `log pi` in [`ActMode::Explore`], then a
    /// uniformly random action with probability `random_eps`.
    ///
    /// # Errors
    /// [`NnError::Dimension`] / [`NnError::NotFinite`] for inputs that do not fit,
    /// [`NnError::InvalidConfig`] for actors without two head blocks; backend errors.
    pub fn squashed_gaussian_act(
        &mut self,
        inputs: &[Vec<f32>],
        n: usize,
        mode: ActMode,
        dist: SquashedGaussian,
        random_eps: f64,
    ) -> Result<PolicyOutput, NnError> {
        self.check_gaussian_heads()?;
        let heads = self.heads(inputs, n)?;
        let (lo, hi) = (dist.log_std_min, dist.log_std_max);
        let mut actions = Vec::with_capacity(heads.len());
        let mut log_probs = Vec::with_capacity(heads.len());
        for (i, h) in heads.iter().enumerate() {
            let d = self.action_dim(i);
            let mut a = Vec::with_capacity(n * d);
            let mut lps = Vec::with_capacity(n);
            for row in h.chunks_exact(2 * d) {
                let (mean, log_std) = row.split_at(d);
                let mut lp = 0.0f32;
                for (m, s) in mean.iter().zip(log_std) {
                    let s = s.clamp(lo, hi);
                    let eps = if mode == ActMode::Explore { gaussian(&mut self.rng) } else { 0.0 };
                    let u = m + s.exp() * eps;
                    lp += -0.5 * eps * eps - s - HALF_LOG_TAU - (1.0 - u.tanh().powi(2) + 1e-6).ln();
                    a.push(u.tanh());
                }
                lps.push(lp);
            }
            actions.push(a);
            log_probs.push(lps);
        }
        if mode == ActMode::Explore && random_eps > 0.0 {
            randomize(&mut actions, n, random_eps as f32, &mut self.rng);
        }
        Ok(PolicyOutput {
            actions,
            log_probs: if mode == ActMode::Explore { log_probs } else { Vec::new() },
            values: Vec::new(),
        })
    }
}
