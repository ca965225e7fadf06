//! What MADDPG, MATD3 and MASAC share: the agents' networks in stacked
//! groups ([`crate::group`], [`crate::Stacking`]) that live on the device
//! across updates; input normalisers; the HER replay buffer and its sampling;
//! the critic and actor steps with worker averaging and information sharing;
//! polyak targets. Save/restore is in [`crate::state`].
//!
//! A step of the critics or actors runs every group's forward and backward
//! pass (on worker threads when there are several groups), averages
//! gradients over worker processes, mixes them over the graph in gradient
//! mode, steps each group's optimiser and mixes parameters in parameter mode.
//! With one group (GPUs) the kernels a joint update launches do not depend on
//! the number of agents.
//!
//! Rollouts act on a host copy of the actors (burn's `flex` device), made
//! once after each update phase, so an environment step never waits for a
//! round trip to an accelerator.

use burn::module::Module;
use burn::optim::{AdamConfig, GradientsParams};
use burn::tensor::{Device, Tensor, TensorData};
use fmsr_core::RewardModel;
use fmsr_core::agent::{Batch, Communicator, ObservationLayout, Sharing};
use fmsr_core::replay::{Episode, ReplayBuffer, ReplayConfig};
use fmsr_core::sharing::{InformationSharing, NetworkGroup, SharedParameters};
use fmsr_graph::MixingMatrix;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::config::{CriticSharing, NetworkConfig, Stacking};
use crate::error::{NnError, check_values};
use crate::group::{Group, GroupBatch, GroupSpec, to_vec1};
use crate::mixing::{all_reduce, mix_gradients, mix_stacks};
use crate::net::Critics;
use crate::normalizer::Normalizer;
use crate::workers::{par_each, worker_pools};

/// A sampled batch on the device: normalised inputs, joint actions in
/// agent-major column order, and each group's share.
#[derive(Clone)]
pub(crate) struct BatchTensors {
    pub(crate) n: usize,
    /// `[x, g]` normalised, `n x (obs + goal)`.
    pub(crate) og: Tensor<2>,
    /// `[x', g]` normalised.
    pub(crate) og_next: Tensor<2>,
    /// `a_1 .. a_N` agent-major, `n x action_dim`.
    pub(crate) actions: Tensor<2>,
    /// Each group's inputs, rewards and bounds.
    pub(crate) groups: Vec<GroupBatch>,
}

/// The shared machinery; see the [module docs](self).
pub(crate) struct Learner {
    pub(crate) layout: ObservationLayout,
    pub(crate) net: NetworkConfig,
    pub(crate) replay_config: ReplayConfig,
    pub(crate) gamma: f64,
    pub(crate) sharing: InformationSharing,
    pub(crate) comm: Box<dyn Communicator>,
    /// The plain device (targets, batches); its autodiff twin holds the online networks.
    pub(crate) device: Device,
    pub(crate) groups: Vec<Group>,
    pub(crate) actor_norms: Vec<Normalizer>,
    pub(crate) critic_norm: Normalizer,
    /// Agent-major order of the joint action: `perm[k]` is the joint slot of column `k`.
    perm: Vec<usize>,
    pub(crate) replay: ReplayBuffer,
    pub(crate) rng: ChaCha8Rng,
    /// Gradient steps taken.
    pub(crate) steps: u64,
    pools: Vec<rayon::ThreadPool>,
}

impl std::fmt::Debug for Learner {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Learner")
            .field("agents", &self.num_agents())
            .field("groups", &self.groups.len())
            .field("net", &self.net)
            .field("replay", &self.replay.episodes())
            .field("steps", &self.steps)
            .finish_non_exhaustive()
    }
}

/// What a learner is built from, besides its algorithm's own config.
#[derive(Debug)]
pub struct LearnerParts {
    /// How actor inputs are laid out (and the environment's spec).
    pub layout: ObservationLayout,
    /// Networks and optimisers.
    pub networks: NetworkConfig,
    /// Replay storage and the number of gradient steps per cycle.
    pub replay: ReplayConfig,
    /// The discount (the trainer's `gamma`).
    pub gamma: f64,
    /// Information sharing (`None`: off).
    pub sharing: Option<Sharing>,
    /// Averaging across worker processes.
    pub comm: Box<dyn Communicator>,
    /// The device the networks live on (its autodiff twin takes gradients).
    pub device: Device,
}

impl LearnerParts {
    /// Parts on burn's `flex` CPU device, in one process.
    #[must_use]
    pub fn new(layout: ObservationLayout, networks: NetworkConfig, replay: ReplayConfig, gamma: f64) -> Self {
        Self {
            layout,
            networks,
            replay,
            gamma,
            sharing: None,
            comm: Box::new(fmsr_core::agent::SingleProcess),
            device: Device::flex(),
        }
    }

    /// With information sharing.
    #[must_use]
    pub fn with_sharing(mut self, sharing: Option<Sharing>) -> Self {
        self.sharing = sharing;
        self
    }

    /// With a communicator between worker processes: gradients (as HER
    /// baselines' MPI Adam), normaliser statistics and MASAC's temperature
    /// gradients are averaged over the workers, so their networks stay identical.
    #[must_use]
    pub fn with_communicator(mut self, comm: Box<dyn Communicator>) -> Self {
        self.comm = comm;
        self
    }

    /// On another device (see [`crate::device`]).
    #[must_use]
    pub fn with_device(mut self, device: Device) -> Self {
        self.device = device;
        self
    }
}

/// Checks what the networks need of the parts: a discount in `[0, 1)`, agents
/// with positive input and action widths, a mixing matrix over all of them.
fn check_parts(layout: &ObservationLayout, gamma: f64, sharing: Option<&Sharing>) -> Result<(), NnError> {
    if !(0.0..1.0).contains(&gamma) {
        return Err(NnError::InvalidConfig { key: "gamma", reason: format!("{gamma} is not in [0, 1)") });
    }
    let spec = layout.spec();
    let n = spec.num_agents();
    if n == 0 {
        return Err(NnError::InvalidConfig { key: "agents", reason: "the layout has no agents".into() });
    }
    if let Some(s) = sharing
        && s.mixing.n() != n
    {
        return Err(NnError::Sharing {
            reason: format!("the mixing matrix has {} nodes but the learner has {n} agents", s.mixing.n()),
        });
    }
    match spec.agents.iter().enumerate().find(|(i, a)| layout.actor_input_dim(*i) == 0 || a.action_dim() == 0) {
        Some((i, a)) => Err(NnError::InvalidConfig {
            key: "agents",
            reason: format!(
                "agent {i} ({}) has actor input dim {} and action dim {}; both must be positive",
                a.name,
                layout.actor_input_dim(i),
                a.action_dim()
            ),
        }),
        None => Ok(()),
    }
}

/// The agent ranges of the groups `net.stacking` asks for on `device`
/// (one group when the agents share critics).
fn group_ranges(net: &NetworkConfig, agents: usize, device: &Device) -> Vec<std::ops::Range<usize>> {
    let per_agent = match net.stacking {
        Stacking::PerAgent => true,
        Stacking::All => false,
        Stacking::Auto => *device == Device::flex() && net.critic == CriticSharing::PerAgent,
    };
    if per_agent { (0..agents).map(|i| i..i + 1).collect() } else { std::iter::once(0..agents).collect() }
}

/// Every agent's information-sharing view: the groups' stacks of one kind.
struct Shared<'a> {
    groups: &'a mut [Group],
}

impl SharedParameters for Shared<'_> {
    type Error = NnError;

    fn consensus_step(&mut self, kind: NetworkGroup, mixing: &MixingMatrix) -> Result<(), NnError> {
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

    fn consensus_step(&mut self, _: NetworkGroup, mixing: &MixingMatrix) -> Result<(), NnError> {
        mix_gradients(self.grads, &self.ids, self.agents, mixing, &self.device)
    }
}

impl Learner {
    /// A learner with `critics` critics per agent and actor heads of
    /// `head_mult * action_dim(i)` outputs.
    pub(crate) fn new(parts: LearnerParts, critics: usize, head_mult: usize) -> Result<Self, NnError> {
        let LearnerParts { layout, networks: net, replay: replay_config, gamma, sharing, comm, device } = parts;
        net.validate()?;
        replay_config.validate().map_err(|e| NnError::InvalidConfig { key: "replay", reason: e.to_string() })?;
        replay_config.worker_batch(comm.workers()).map_err(|_| NnError::InvalidConfig {
            key: "replay.batch_size",
            reason: format!(
                "{} is the total over all worker processes and must split evenly over {}",
                replay_config.batch_size,
                comm.workers()
            ),
        })?;
        check_parts(&layout, gamma, sharing.as_ref())?;
        let spec = layout.spec().clone();
        let sharing = InformationSharing::new(sharing);
        if net.critic != CriticSharing::PerAgent && sharing.shares(NetworkGroup::Critics) {
            return Err(NnError::Sharing {
                reason: format!(
                    "networks.critic = {:?} already shares the critics' trunk; information sharing can mix only the actors",
                    net.critic
                ),
            });
        }
        let device = device.inner();
        let na = spec.num_agents();
        let inputs: Vec<usize> = (0..na).map(|i| layout.actor_input_dim(i)).collect();
        let actions: Vec<usize> = spec.agents.iter().map(|a| a.action_dim()).collect();
        let group_spec = GroupSpec {
            inputs: &inputs,
            actions: &actions,
            critic_input: layout.critic_input_dim(),
            hidden: net.hidden,
            layers: net.layers,
            seed: net.seed,
            critics,
            critic_shared: net.critic.shared_layers(net.layers),
            head_mult,
            same_trunks: (sharing.shares(NetworkGroup::Actors), sharing.shares(NetworkGroup::Critics)),
            adam: AdamConfig::new()
                .with_beta_1(net.adam_beta1 as f32)
                .with_beta_2(net.adam_beta2 as f32)
                .with_epsilon(net.adam_epsilon as f32),
        };
        let groups: Vec<Group> = group_ranges(&net, na, &device)
            .into_iter()
            .enumerate()
            .map(|(g, r)| Group::new(g, r, &group_spec, spec.action_dim, &device))
            .collect();
        let perm = spec.agents.iter().flat_map(|a| a.action_slots.iter().copied()).collect();
        let pools = worker_pools(net.threads.min(groups.len()))?;
        let replay = ReplayBuffer::new(&spec, replay_config.buffer_size)
            .map_err(|e| NnError::InvalidConfig { key: "replay.buffer_size", reason: e.to_string() })?;
        check_replay_fits(&replay, replay_config.buffer_size, physical_memory_bytes())?;
        // Networks start identical on every worker; exploration and sampling
        // draw from a stream of the worker's own.
        let mut rng = ChaCha8Rng::seed_from_u64(net.seed);
        rng.set_stream(0xF115 + comm.rank() as u64);
        Ok(Self {
            critic_norm: Normalizer::new(spec.obs_dim + spec.goal_dim, net.norm_eps, net.clip_obs),
            actor_norms: inputs.iter().map(|&d| Normalizer::new(d, net.norm_eps, net.clip_obs)).collect(),
            layout,
            net,
            replay_config,
            gamma,
            sharing,
            comm,
            device,
            groups,
            perm,
            replay,
            rng,
            steps: 0,
            pools,
        })
    }

    /// Number of agents.
    pub(crate) fn num_agents(&self) -> usize {
        self.actor_norms.len()
    }

    /// Agent `i`'s action dimension.
    pub(crate) fn action_dim(&self, i: usize) -> usize {
        self.layout.spec().agents[i].action_dim()
    }

    /// The group of agent `agent` and the agent's index in it.
    pub(crate) fn locate(&self, agent: usize) -> Result<(usize, usize), NnError> {
        self.groups
            .iter()
            .position(|g| g.agents.contains(&agent))
            .map(|g| (g, agent - self.groups[g].agents.start))
            .ok_or(NnError::UnknownAgent { agent, agents: self.num_agents() })
    }

    /// `f(g, group_g)` for every group, on the worker threads.
    pub(crate) fn per_group<T: Send>(
        &mut self,
        f: impl Fn(usize, &mut Group) -> Result<T, NnError> + Sync,
    ) -> Result<Vec<T>, NnError> {
        par_each(&self.pools, &mut self.groups, f)
    }

    /// Group `g`'s agents' normalised actor inputs, zero-padded to `[A_g, n, in_max]`, as host data.
    fn padded_inputs(&self, g: usize, xs: &[Vec<f32>], n: usize) -> Vec<f32> {
        let group = &self.groups[g];
        let width = group.input_width();
        let mut out = vec![0.0; group.len() * n * width];
        for (k, i) in group.agents.clone().enumerate() {
            let mut x = xs[i].clone();
            self.actor_norms[i].normalize(&mut x);
            let d = self.actor_norms[i].dim();
            for (r, row) in x.chunks_exact(d).take(n).enumerate() {
                out[(k * n + r) * width..][..d].copy_from_slice(row);
            }
        }
        out
    }

    /// The actors' head outputs (pre-activation) for `n` rows of raw actor
    /// inputs, each agent's in its own column order, computed on the host copy.
    pub(crate) fn heads(&mut self, inputs: &[Vec<f32>], n: usize) -> Result<Vec<Vec<f32>>, NnError> {
        let na = self.num_agents();
        if inputs.len() != na {
            return Err(NnError::Dimension { what: "actor inputs (agents)".into(), expected: na, found: inputs.len() });
        }
        for (i, x) in inputs.iter().enumerate() {
            check_values(|| format!("actor input of agent {i}"), x, n * self.layout.actor_input_dim(i))?;
        }
        if n == 0 {
            return Ok(vec![Vec::new(); na]);
        }
        let host = Device::flex();
        let mut out = Vec::with_capacity(na);
        for g in 0..self.groups.len() {
            let x = self.padded_inputs(g, inputs, n);
            let group = &mut self.groups[g];
            if group.act_cache.is_none() {
                group.act_cache = Some(group.nets.actors.copy_to(&host));
            }
            let actors =
                group.act_cache.as_ref().ok_or(NnError::Backend { what: "actors", reason: "no host copy".into() })?;
            let x = Tensor::<3>::from_data(TensorData::new(x, [group.len(), n, group.input_width()]), &host);
            let y = actors.forward(x);
            let w = y.dims()[2];
            let y = y
                .into_data()
                .try_into_vec::<f32>()
                .map_err(|e| NnError::Backend { what: "actions", reason: format!("{e:?}") })?;
            for (k, cols) in group.actor_layout.head_cols.iter().enumerate() {
                out.push(
                    (0..n).flat_map(|r| cols.iter().map(|&c| y[(k * n + r) * w + c]).collect::<Vec<_>>()).collect(),
                );
            }
        }
        Ok(out)
    }

    /// Stores an episode in the replay buffer.
    pub(crate) fn store(&mut self, episode: &Episode) -> Result<(), NnError> {
        self.replay.store(episode).map_err(|e| NnError::Replay { reason: e.to_string() })
    }

    /// The replay buffer's capacity in episodes.
    pub(crate) fn storage_capacity(&self) -> usize {
        self.replay.capacity_episodes()
    }

    /// [`fmsr_core::Algorithm::restore_storage`] for the replay buffer.
    pub(crate) fn restore_storage(&mut self, total: u64, episodes: &[Episode]) -> Result<(), NnError> {
        self.replay.restore_log(total, episodes).map_err(|e| NnError::Replay { reason: e.to_string() })
    }

    /// Samples a batch with HER, updates the normalisers with it (as HER
    /// baselines do) and puts it on the device. `None` while the buffer is empty.
    pub(crate) fn sample(&mut self, rewards: &dyn RewardModel) -> Result<Option<BatchTensors>, NnError> {
        if self.replay.episodes() == 0 {
            return Ok(None);
        }
        let b = self
            .replay
            .sample(
                // This worker's share; `new` checked that it divides evenly.
                self.replay_config.batch_size / self.comm.workers(),
                &self.replay_config.her,
                &self.layout,
                &mut self.rng,
                &|a, d| rewards.goal_reward(a, d),
                &|task, phi, out| rewards.agent_rewards(task, phi, out),
            )
            .map_err(|e| NnError::Replay { reason: e.to_string() })?;
        let bounds = rewards.reward_bounds();
        if bounds.len() != self.num_agents() {
            return Err(NnError::Dimension {
                what: "reward bounds (agents)".into(),
                expected: self.num_agents(),
                found: bounds.len(),
            });
        }
        let scale = 1.0 / (1.0 - self.gamma);
        let bounds = bounds.iter().map(|&(lo, hi)| ((lo * scale) as f32, (hi * scale) as f32)).collect();
        self.tensors(&b, bounds).map(Some)
    }

    fn check_batch(&self, b: &Batch, bounds: &[(f32, f32)]) -> Result<(), NnError> {
        let spec = self.layout.spec();
        let (n, na) = (b.size, self.num_agents());
        if n == 0 {
            return Err(NnError::Dimension { what: "batch.size (must be positive)".into(), expected: 1, found: 0 });
        }
        check_values(|| "batch.obs".into(), &b.obs, n * spec.obs_dim)?;
        check_values(|| "batch.next_obs".into(), &b.next_obs, n * spec.obs_dim)?;
        check_values(|| "batch.goals".into(), &b.goals, n * spec.goal_dim)?;
        check_values(|| "batch.actions".into(), &b.actions, n * spec.action_dim)?;
        for (what, v) in [("batch.actor_inputs", &b.actor_inputs), ("batch.next_actor_inputs", &b.next_actor_inputs)] {
            if v.len() != na {
                return Err(NnError::Dimension { what: format!("{what} (agents)"), expected: na, found: v.len() });
            }
            for (i, x) in v.iter().enumerate() {
                check_values(|| format!("{what}[{i}]"), x, n * self.layout.actor_input_dim(i))?;
            }
        }
        if b.rewards.len() != na {
            return Err(NnError::Dimension {
                what: "batch.rewards (agents)".into(),
                expected: na,
                found: b.rewards.len(),
            });
        }
        for (i, r) in b.rewards.iter().enumerate() {
            check_values(|| format!("batch.rewards[{i}]"), r, n)?;
        }
        if bounds.len() != na {
            return Err(NnError::Dimension {
                what: "Q-target bounds (agents)".into(),
                expected: na,
                found: bounds.len(),
            });
        }
        if let Some((i, (lo, hi))) =
            bounds.iter().enumerate().find(|(_, (lo, hi))| lo.is_nan() || hi.is_nan() || lo > hi)
        {
            return Err(NnError::InvalidConfig {
                key: "q_bounds",
                reason: format!("agent {i} has bounds ({lo}, {hi}); need lo <= hi"),
            });
        }
        Ok(())
    }

    /// Checks and normalises a host batch and uploads it.
    pub(crate) fn tensors(&mut self, b: &Batch, bounds: Vec<(f32, f32)>) -> Result<BatchTensors, NnError> {
        self.check_batch(b, &bounds)?;
        let n = b.size;
        let spec = self.layout.spec();
        let (od, gd) = (spec.obs_dim, spec.goal_dim);
        let obs_goal = |obs: &[f32]| {
            let mut out = Vec::with_capacity(n * (od + gd));
            for r in 0..n {
                out.extend_from_slice(&obs[r * od..(r + 1) * od]);
                out.extend_from_slice(&b.goals[r * gd..(r + 1) * gd]);
            }
            out
        };
        let (mut og, mut og_next) = (obs_goal(&b.obs), obs_goal(&b.next_obs));
        self.critic_norm.update(&og, self.comm.as_ref());
        for (norm, x) in self.actor_norms.iter_mut().zip(&b.actor_inputs) {
            norm.update(x, self.comm.as_ref());
        }
        self.critic_norm.normalize(&mut og);
        self.critic_norm.normalize(&mut og_next);
        let ad = self.perm.len();
        let mut actions = Vec::with_capacity(n * ad);
        for row in b.actions.chunks_exact(ad).take(n) {
            actions.extend(self.perm.iter().map(|&s| row[s]));
        }
        let groups = (0..self.groups.len()).map(|g| self.group_batch(g, b, &bounds)).collect();
        let dev = &self.device;
        Ok(BatchTensors {
            n,
            og: matrix(og, n, od + gd, dev),
            og_next: matrix(og_next, n, od + gd, dev),
            actions: matrix(actions, n, ad, dev),
            groups,
        })
    }

    /// Group `g`'s share of a checked host batch.
    fn group_batch(&self, g: usize, b: &Batch, bounds: &[(f32, f32)]) -> GroupBatch {
        let (n, dev) = (b.size, &self.device);
        let group = &self.groups[g];
        let (a, width, r) = (group.len(), group.input_width(), group.agents.clone());
        let stack = |v: Vec<f32>, cols: usize| Tensor::<3>::from_data(TensorData::new(v, [a, n, cols]), dev);
        let per_agent = |f: fn(&(f32, f32)) -> f32| {
            Tensor::<3>::from_data(
                TensorData::new(bounds[r.clone()].iter().map(f).collect::<Vec<f32>>(), [a, 1, 1]),
                dev,
            )
        };
        GroupBatch {
            x_now: stack(self.padded_inputs(g, &b.actor_inputs, n), width),
            x_next: stack(self.padded_inputs(g, &b.next_actor_inputs, n), width),
            rewards: stack(b.rewards[r.clone()].concat(), 1),
            lo: per_agent(|b| b.0),
            hi: per_agent(|b| b.1),
        }
    }

    /// One optimiser step of every agent's critics towards the clipped TD target (eq. 7)
    ///
    /// ```text
    /// y_i = clip(r_i + gamma * (min_c Q'_{i,c}(x', g, a') - soft_i), lo_i, hi_i)
    /// L_i = sum_c mean (Q_{i,c}(x, g, a) - y_i)^2
    /// ```
    ///
    /// for every group's agents at once, where `a'` is `next_actions`
    /// (`[n, action_dim]`, agent-major) and `soft[g]` an optional `[A_g, n, 1]`
    /// term (MASAC's `alpha_i log pi_i`). Returns the agents' losses.
    pub(crate) fn critic_step(
        &mut self,
        b: &BatchTensors,
        next_actions: Tensor<2>,
        soft: Option<Vec<Tensor<3>>>,
    ) -> Result<Vec<f32>, NnError> {
        let next_input = Tensor::cat(vec![b.og_next.clone(), next_actions], 1).unsqueeze_dim::<3>(0);
        let input = Tensor::from_inner(Tensor::cat(vec![b.og.clone(), b.actions.clone()], 1).unsqueeze_dim::<3>(0));
        let gamma = self.gamma as f32;
        self.step_groups(NetworkGroup::Critics, |g, group| {
            let (gb, na) = (&b.groups[g], group.len());
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
                let l = (c.forward(input.clone()) - y.clone()).square().mean_dim(1);
                loss = Some(match loss {
                    Some(acc) => acc + l,
                    None => l,
                });
            }
            Ok(loss.ok_or(NnError::Backend { what: "critic loss", reason: "no critic".into() })?.reshape([na]))
        })
    }

    /// One optimiser step of every agent's actor on the losses `[A_g]` that
    /// `loss(g, group, critics)` returns for each group, where `critics` are
    /// the group's online critics without parameter gradients.
    pub(crate) fn actor_step<F>(&mut self, loss: F) -> Result<Vec<f32>, NnError>
    where
        F: Fn(usize, &Group, &Critics) -> Result<Tensor<1>, NnError> + Sync,
    {
        let losses = self.step_groups(NetworkGroup::Actors, |g, group| {
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
    fn step_groups<F>(&mut self, kind: NetworkGroup, loss: F) -> Result<Vec<f32>, NnError>
    where
        F: Fn(usize, &Group) -> Result<Tensor<1>, NnError> + Sync,
    {
        let fused = self.comm.workers() <= 1 && !self.sharing.mixes_gradients(kind);
        let lr = match kind {
            NetworkGroup::Actors => self.net.lr_actor,
            NetworkGroup::Critics => self.net.lr_critic,
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
        kind: NetworkGroup,
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

    /// Agent `agent`'s actor trunk, flattened (what sharing mixes), for inspection.
    pub(crate) fn actor_trunk(&self, agent: usize) -> Result<Vec<f32>, NnError> {
        let (g, k) = self.locate(agent)?;
        let group = &self.groups[g];
        let flats = group.nets.actors.to_flats(&group.actor_layout)?;
        Ok(flats[k][group.actor_layout.shapes[k].trunk()].to_vec())
    }

    /// Replaces agent `agent`'s actor trunk.
    pub(crate) fn set_actor_trunk(&mut self, agent: usize, trunk: &[f32]) -> Result<(), NnError> {
        let (g, k) = self.locate(agent)?;
        let group = &mut self.groups[g];
        let range = group.actor_layout.shapes[k].trunk();
        check_values(|| format!("actor trunk of agent {agent}"), trunk, range.len())?;
        let mut flats = group.nets.actors.to_flats(&group.actor_layout)?;
        flats[k][range].copy_from_slice(trunk);
        group.nets.actors = group.nets.actors.with_flats(&group.actor_layout, &flats);
        group.act_cache = None;
        Ok(())
    }

    /// All parameters of agent `agent`'s online actor and first critic.
    pub(crate) fn params(&self, agent: usize) -> Result<(Vec<f32>, Vec<f32>), NnError> {
        let (g, k) = self.locate(agent)?;
        let group = &self.groups[g];
        let mut actors = group.nets.actors.to_flats(&group.actor_layout)?;
        let mut critics = group.nets.critics.nets[0].to_flats(&group.critic_layout)?;
        Ok((actors.swap_remove(k), critics.swap_remove(k)))
    }

    /// `Q_i(x, g, a)` of agent `agent`'s first online critic for raw rows.
    pub(crate) fn q_values(
        &self,
        agent: usize,
        obs: &[f32],
        goals: &[f32],
        actions: &[f32],
        n: usize,
    ) -> Result<Vec<f32>, NnError> {
        let (g, k) = self.locate(agent)?;
        let spec = self.layout.spec();
        check_values(|| "q_values obs".into(), obs, n * spec.obs_dim)?;
        check_values(|| "q_values goals".into(), goals, n * spec.goal_dim)?;
        check_values(|| "q_values actions".into(), actions, n * spec.action_dim)?;
        if n == 0 {
            return Ok(Vec::new());
        }
        let (od, gd, ad) = (spec.obs_dim, spec.goal_dim, self.perm.len());
        let mut og = Vec::with_capacity(n * (od + gd));
        for r in 0..n {
            og.extend_from_slice(&obs[r * od..(r + 1) * od]);
            og.extend_from_slice(&goals[r * gd..(r + 1) * gd]);
        }
        self.critic_norm.normalize(&mut og);
        let mut input = Vec::with_capacity(n * (od + gd + ad));
        for r in 0..n {
            input.extend_from_slice(&og[r * (od + gd)..(r + 1) * (od + gd)]);
            input.extend(self.perm.iter().map(|&s| actions[r * ad + s]));
        }
        let x = matrix(input, n, od + gd + ad, &self.device).unsqueeze_dim::<3>(0);
        let q = self.groups[g].nets.critics.nets[0].valid().forward(x);
        // One row for all agents when they share the whole critic.
        let row = if q.dims()[0] == 1 { 0 } else { k };
        let q = q.narrow(0, row, 1).reshape([n]);
        to_vec1(q, "q values")
    }

    /// Agent `i`'s first critic's trunk, flattened.
    pub(crate) fn critic_trunk(&self, agent: usize) -> Result<Vec<f32>, NnError> {
        let (g, k) = self.locate(agent)?;
        let group = &self.groups[g];
        let flats = group.nets.critics.nets[0].to_flats(&group.critic_layout)?;
        Ok(flats[k][group.critic_layout.shapes[k].trunk()].to_vec())
    }

    /// Each group's normal noise `[A_g, n, d_max]` (zero in the padding),
    /// drawn agent by agent, row by row from the learner's stream.
    pub(crate) fn noise(&mut self, n: usize, sample: impl Fn(&mut ChaCha8Rng) -> f32) -> Vec<Tensor<3>> {
        let mut out = Vec::with_capacity(self.groups.len());
        for g in 0..self.groups.len() {
            let (agents, dmax) = (self.groups[g].agents.clone(), self.groups[g].max_action());
            let mut v = vec![0.0; agents.len() * n * dmax];
            for (k, i) in agents.clone().enumerate() {
                for r in 0..n {
                    for c in 0..self.action_dim(i) {
                        v[(k * n + r) * dmax + c] = sample(&mut self.rng);
                    }
                }
            }
            out.push(Tensor::from_data(TensorData::new(v, [agents.len(), n, dmax]), &self.device));
        }
        out
    }
}

/// A row-major `rows x cols` matrix as a tensor on `device`.
pub(crate) fn matrix(values: Vec<f32>, rows: usize, cols: usize, device: &Device) -> Tensor<2> {
    Tensor::<2>::from_data(TensorData::new(values, [rows, cols]), device)
}

/// The machine's physical memory (`MemTotal` of `/proc/meminfo`); `None`
/// where it cannot be read (not Linux).
#[must_use]
pub fn physical_memory_bytes() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemTotal:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// Refuses a replay buffer that could never fit: the buffer allocates as
/// episodes arrive, so without this a `replay.buffer_size` beyond the
/// machine's `memory` would only fail hours into training.
///
/// # Errors
/// [`NnError::InvalidConfig`] naming `replay.buffer_size`, with the bytes it
/// would take at full size and the memory there is.
pub fn check_replay_fits(replay: &ReplayBuffer, buffer_size: usize, memory: Option<u64>) -> Result<(), NnError> {
    let need = replay.bytes_at_capacity();
    match memory {
        Some(memory) if need > memory => Err(NnError::InvalidConfig {
            key: "replay.buffer_size",
            reason: format!(
                "{buffer_size} transitions would take {:.1} GB at full size ({} episodes), more than this machine's \
                 {:.1} GB of memory: lower it",
                need as f64 / 1e9,
                replay.capacity_episodes(),
                memory as f64 / 1e9
            ),
        }),
        _ => Ok(()),
    }
}
