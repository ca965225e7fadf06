//! The update steps: every group's forward and backward pass, gradients
//! averaged over worker processes and mixed over the graph (gradient mode),
//! each group's optimiser step, parameters mixed (parameter mode); polyak targets.

use burn::module::Module;
use burn::optim::GradientsParams;
use burn::tensor::{Device, Tensor};
use fmsr_core::sharing::{NetworkKind, SharedParameters};
use fmsr_graph::MixingMatrix;

use crate::config::TdLoss;
use crate::error::NnError;
use crate::group::Group;
use crate::mixing::{all_reduce, mix_gradients, mix_stacks};
use crate::net::Critics;

use super::{BatchTensors, Learner};

/// Every agent's information-sharing view: the groups' stacks of one kind.
struct Shared<'a> {
    groups: &'a mut [Group],
}

impl SharedParameters for Shared<'_> {
    type Error = NnError;

    fn consensus_step(&mut self, kind: NetworkKind, mixing: &MixingMatrix) -> Result<(), NnError> {
        let copies = self.groups.first().map_or(0, |g| g.nets.copies(kind));
        for c in 0..copies {
            let stacks = self.groups.iter_mut().map(|g| g.nets.stack_mut(kind, c)).collect();
            mix_stacks(stacks, mixing)?;
        }
        Ok(())
    }
}

/// Every group's gradients of one kind, as gradient-mode sharing sees them.
struct SharedGrads<'a> {
    grads: &'a mut [GradientsParams],
    ids: Vec<Vec<(burn::module::ParamId, burn::module::ParamId)>>,
    agents: usize,
    device: Device,
}

impl SharedParameters for SharedGrads<'_> {
    type Error = NnError;

    fn consensus_step(&mut self, _: NetworkKind, mixing: &MixingMatrix) -> Result<(), NnError> {
        mix_gradients(self.grads, &self.ids, self.agents, mixing, &self.device)
    }
}

impl Learner {
    /// One optimiser step of every agent's critics towards the clipped TD target (eq. 7)
    ///
    /// ```text
    /// y_i = clip(r_i + gamma * min_c Q'_{i,c}(x', g, a'), lo_i, hi_i)
    /// L_i = sum_c mean l(Q_{i,c}(x, g, a) - y_i)
    /// ```
    ///
    /// with `l` the loss of `networks.critic_loss` ([`crate::CriticLoss`]:
    /// squared, or Huber), where `a'` is `next_actions` (`[rows, joint_width]`, agent-major, as
    /// [`Learner::target_actions`] gives) and each critic sees its rule's
    /// [`crate::CriticView`] of these. Worker averaging and information
    /// sharing of the critics happen here. Returns each agent's loss.
    ///
    /// # Errors
    /// Backend errors.
    pub fn critic_step(&mut self, b: &BatchTensors, next_actions: Tensor<2>) -> Result<Vec<f32>, NnError> {
        let loss = self.net.critic_loss;
        self.critic_step_soft(b, next_actions, None, &loss)
    }

    /// [`Learner::critic_step`] (or, with `soft`, [`Learner::soft_critic_step`])
    /// with the rule's own loss on the TD error instead of `networks.critic_loss`:
    ///
    /// ```text
    /// L_i = sum_c mean loss(Q_{i,c}(x, g, a) - y_i)
    /// ```
    ///
    /// # Errors
    /// Backend errors.
    pub fn critic_step_with(
        &mut self,
        b: &BatchTensors,
        next_actions: Tensor<2>,
        soft: Option<crate::SoftTerm>,
        loss: &dyn TdLoss,
    ) -> Result<Vec<f32>, NnError> {
        self.critic_step_soft(b, next_actions, soft.map(|s| s.groups), loss)
    }

    /// [`Learner::critic_step`] with an optional soft term (eq. 7)
    ///
    /// ```text
    /// y_i = clip(r_i + gamma * (min_c Q'_{i,c}(x', g, a') - soft_i), lo_i, hi_i)
    /// L_i = sum_c mean (Q_{i,c}(x, g, a) - y_i)^2
    /// ```
    ///
    /// for every group's agents at once, where `a'` is `next_actions`
    /// (`[n, action_dim]`, agent-major) and `soft[g]` an optional `[A_g, n, 1]`
    /// term (MASAC's `alpha_i log pi_i`). Returns the agents' losses.
    pub(crate) fn critic_step_soft(
        &mut self,
        b: &BatchTensors,
        next_actions: Tensor<2>,
        soft: Option<Vec<Tensor<3>>>,
        critic_loss: &dyn TdLoss,
    ) -> Result<Vec<f32>, NnError> {
        let next_global = Tensor::cat(vec![b.og_next.clone(), next_actions.clone()], 1).unsqueeze_dim::<3>(0);
        let next_joint = next_actions.unsqueeze_dim::<3>(0);
        let joint = b.actions.clone().unsqueeze_dim::<3>(0);
        let global = Tensor::cat(vec![b.og.clone(), b.actions.clone()], 1).unsqueeze_dim::<3>(0);
        let gamma = self.gamma as f32;
        // Each group's batch-mean Q of its first critic, for the epoch's statistics.
        let q_means = std::sync::Mutex::new(Vec::with_capacity(self.groups.len()));
        let losses = self.step_groups(NetworkKind::Critics, |g, group| {
            let (gb, na) = (&b.groups[g], group.len());
            let next_input = group.critic_input(&next_global, &gb.x_next, &next_joint);
            let input = Tensor::from_inner(group.critic_input(&global, &gb.x_now, &joint));
            let mut q_next = group.nets.critic_targets.nets.iter().map(|c| c.forward(next_input.clone()));
            let first = q_next.next().ok_or(NnError::Backend { what: "critic target", reason: "no critic".into() })?;
            let mut q_next = q_next.fold(first, Tensor::min_pair);
            if let Some(soft) = &soft {
                q_next = q_next - soft[g].clone();
            }
            let shape = [na, b.n, 1];
            let y = (gb.rewards.clone() + q_next.mul_scalar(gamma))
                .max_pair(gb.lo.clone().expand(shape))
                .min_pair(gb.hi.clone().expand(shape));
            let y = Tensor::from_inner(y);
            let mut loss: Option<Tensor<3>> = None;
            for c in &group.nets.critics.nets {
                let q = c.forward(input.clone());
                if loss.is_none() {
                    // A shared critic's Q is one row for all agents: each agent's is that.
                    let mean = q.clone().inner().mean_dim(1).expand([na, 1, 1]).reshape([na]);
                    let mean: Tensor<1> = Tensor::from_inner(mean);
                    q_means.lock().unwrap_or_else(std::sync::PoisonError::into_inner).push((g, mean));
                }
                let l = critic_loss.loss(q - y.clone()).mean_dim(1);
                loss = Some(match loss {
                    Some(acc) => acc + l,
                    None => l,
                });
            }
            Ok(loss.ok_or(NnError::Backend { what: "critic loss", reason: "no critic".into() })?.reshape([na]))
        })?;
        let mut q_means = q_means.into_inner().unwrap_or_else(std::sync::PoisonError::into_inner);
        q_means.sort_by_key(|(g, _)| *g);
        let mut q = Vec::with_capacity(losses.len());
        for (_, mean) in q_means {
            q.extend(crate::group::to_vec1(mean, "critic mean Q")?);
        }
        let d = &mut self.diagnostics;
        d.q_sum.resize(q.len(), 0.0);
        d.q_sum.iter_mut().zip(&q).for_each(|(a, v)| *a += f64::from(*v));
        d.q_steps += 1;
        Ok(losses)
    }

    /// One optimiser step of every agent's actor on the losses `[A_g]` that
    /// `loss(g, group, critics)` returns for each group, where `critics` are
    /// the group's online critics without parameter gradients.
    pub(crate) fn actor_step<F>(&mut self, loss: F) -> Result<Vec<f32>, NnError>
    where
        F: Fn(usize, &Group, &Critics) -> Result<Tensor<1>, NnError> + Sync,
    {
        let losses = self.step_groups(NetworkKind::Actors, |g, group| {
            let critics = group.nets.critics.clone().no_grad();
            loss(g, group, &critics)
        })?;
        for group in &mut self.groups {
            group.act_cache = None;
        }
        Ok(losses)
    }

    /// Every group's losses of `kind`, their gradients and optimiser steps,
    /// then parameter-mode sharing. Without other workers and without
    /// gradient sharing nothing crosses groups before the step, so each
    /// group steps in its own worker right after its backward pass; otherwise
    /// the gradients are first averaged over workers and mixed over the graph.
    fn step_groups<F>(&mut self, kind: NetworkKind, loss: F) -> Result<Vec<f32>, NnError>
    where
        F: Fn(usize, &Group) -> Result<Tensor<1>, NnError> + Sync,
    {
        let fused = self.comm.workers() <= 1 && !self.sharing.mixes_gradients(kind);
        let lr = match kind {
            NetworkKind::Actors => self.net.lr_actor,
            NetworkKind::Critics => self.net.lr_critic,
        };
        let results = self.per_group(|g, group| {
            let l = loss(g, group)?;
            group.nets.step(kind, l, lr, fused)
        })?;
        let (losses, grads): (Vec<Vec<f32>>, Vec<Option<GradientsParams>>) = results.into_iter().unzip();
        if !fused {
            self.reduce_mix_optimize(kind, lr, grads.into_iter().flatten().collect())?;
        }
        self.sharing.mix_parameters(kind, &mut Shared { groups: &mut self.groups })?;
        Ok(losses.concat())
    }

    /// Worker averaging and gradient-mode sharing, then every group's optimiser step.
    fn reduce_mix_optimize(
        &mut self,
        kind: NetworkKind,
        lr: f64,
        mut grads: Vec<GradientsParams>,
    ) -> Result<(), NnError> {
        if self.comm.workers() > 1 {
            for (group, g) in self.groups.iter().zip(grads.iter_mut()) {
                all_reduce(g, &group.nets.ids(kind), self.comm.as_ref())?;
            }
        }
        if self.sharing.mixes_gradients(kind) {
            let ids = self.groups.iter().map(|g| g.nets.trunk_ids(kind)).collect();
            let (agents, device) = (self.num_agents(), self.device.clone());
            self.sharing.mix_gradients(kind, &mut SharedGrads { grads: &mut grads, ids, agents, device })?;
        }
        for (group, g) in self.groups.iter_mut().zip(grads) {
            group.nets.optimize(kind, lr, g);
        }
        Ok(())
    }

    /// The agent-major joint action `[n, action_dim]` of `f(g, group)`, each
    /// group's agents' actions `[A_g, n, d_max]` (masked by the group).
    pub(crate) fn joint_of(
        &mut self,
        f: impl Fn(usize, &Group) -> Result<Tensor<3>, NnError> + Sync,
    ) -> Result<Tensor<2>, NnError> {
        let parts = self.per_group(|g, group| Ok(group.joint.join(f(g, group)? * group.joint.mask.clone())))?;
        let mut parts = parts.into_iter();
        let first = parts.next().ok_or(NnError::Backend { what: "joint action", reason: "no group".into() })?;
        Ok(parts.fold(first, |acc, p| acc + p))
    }

    /// `b` with the sampled joint actions replaced by every agent's current
    /// action `squash(heads)` (no gradient): the teammates' actions of
    /// [`crate::Teammates::Current`].
    pub(crate) fn with_current_actions(
        &mut self,
        b: &BatchTensors,
        squash: impl Fn(Tensor<3>, &Group) -> Tensor<3> + Sync,
    ) -> Result<BatchTensors, NnError> {
        let actions =
            self.joint_of(|g, group| Ok(squash(group.nets.actors.valid().forward(b.groups[g].x_now.clone()), group)))?;
        Ok(BatchTensors { actions, ..b.clone() })
    }

    /// Targets move towards the online networks (eq. 9).
    pub(crate) fn soft_update_targets(&mut self, polyak: f64, actors: bool) {
        let p = polyak as f32;
        for group in &mut self.groups {
            let nets = &mut group.nets;
            if actors {
                nets.actor_targets.soft_update(&nets.actors, p);
            }
            for (t, o) in nets.critic_targets.nets.iter_mut().zip(&nets.critics.nets) {
                t.soft_update(o, p);
            }
        }
    }
}
