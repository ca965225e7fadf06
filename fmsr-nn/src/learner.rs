//! What MADDPG, MATD3 and MASAC share: per agent an actor, one or two critics,
//! their targets and optimisers as burn modules that live on the device across
//! updates; input normalisers; the HER replay buffer and its sampling; the
//! critic and actor steps with worker averaging and information sharing; polyak
//! targets; and save/restore.

use burn::module::Module;
use burn::nn::Linear;
use burn::optim::{AdamConfig, GradientsParams, ModuleOptimizer};
use burn::tensor::{Device, Tensor, TensorData};
use fmsr_core::RewardModel;
use fmsr_core::agent::{Batch, Communicator, ObservationLayout, Sharing};
use fmsr_core::replay::{Episode, ReplayBuffer, ReplayConfig};
use fmsr_core::sharing::{InformationSharing, NetworkGroup};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::config::NetworkConfig;
use crate::error::{NnError, check_values};
use crate::mixing::{GradHolder, ParamHolder, all_reduce, group_trunk_ids};
use crate::net::{Actor, Critic, Critics, NetShape};
use crate::normalizer::Normalizer;
use crate::workers::{par_agents, worker_pools};

/// Everything one agent learns with.
#[derive(Clone)]
pub(crate) struct AgentNets {
    /// Online actor, on the autodiff device.
    pub(crate) actor: Actor,
    /// Target actor, on the plain device.
    pub(crate) actor_target: Actor,
    /// Online critics, on the autodiff device.
    pub(crate) critics: Critics,
    /// Target critics, on the plain device.
    pub(crate) critic_targets: Critics,
    pub(crate) actor_optim: ModuleOptimizer,
    pub(crate) critic_optim: ModuleOptimizer,
    pub(crate) actor_norm: Normalizer,
}

impl AgentNets {
    /// The gradients of `loss` with respect to the networks of `group`.
    fn gradients(&self, group: NetworkGroup, loss: Tensor<1>) -> GradientsParams {
        match group {
            NetworkGroup::Actors => GradientsParams::from_grads(loss.backward(), &self.actor),
            NetworkGroup::Critics => GradientsParams::from_grads(loss.backward(), &self.critics),
        }
    }

    /// One Adam step of the networks of `group`.
    fn optimize(&mut self, group: NetworkGroup, lr: f64, grads: GradientsParams) {
        match group {
            NetworkGroup::Actors => self.actor = self.actor_optim.step(lr, self.actor.clone(), grads),
            NetworkGroup::Critics => self.critics = self.critic_optim.step(lr, self.critics.clone(), grads),
        }
    }
}

/// A sampled batch on the device: normalised inputs, joint actions in
/// agent-major column order, rewards and Q-target bounds.
#[derive(Clone)]
pub(crate) struct BatchTensors {
    pub(crate) n: usize,
    /// `[x, g]` normalised, `n x (obs + goal)`.
    pub(crate) og: Tensor<2>,
    /// `[x', g]` normalised.
    pub(crate) og_next: Tensor<2>,
    /// `a_1 .. a_N` agent-major, `n x action_dim`.
    pub(crate) actions: Tensor<2>,
    /// Each agent's normalised actor input at `t`.
    pub(crate) x_now: Vec<Tensor<2>>,
    /// Each agent's normalised actor input at `t + 1`.
    pub(crate) x_next: Vec<Tensor<2>>,
    /// Each agent's reward, `n x 1`.
    pub(crate) rewards: Vec<Tensor<2>>,
    /// Each agent's Q-target bounds `[lo, hi] / (1 - gamma)` (`clip_return`).
    pub(crate) bounds: Vec<(f32, f32)>,
}

/// Where each agent's block lies in the agent-major joint action.
#[derive(Debug, Clone)]
pub(crate) struct JointLayout {
    offsets: Vec<usize>,
    dims: Vec<usize>,
    width: usize,
}

impl JointLayout {
    /// The critic input `[x, g, a]` on the autodiff device with agent `i`'s
    /// block of the sampled joint action replaced by `mu` (`n x action_dim(i)`).
    pub(crate) fn with(&self, i: usize, mu: Tensor<2>, b: &BatchTensors) -> Tensor<2> {
        let (off, ai, ad) = (self.offsets[i], self.dims[i], self.width);
        let mut parts = vec![Tensor::from_inner(b.og.clone())];
        if off > 0 {
            parts.push(Tensor::from_inner(b.actions.clone().narrow(1, 0, off)));
        }
        parts.push(mu);
        if off + ai < ad {
            parts.push(Tensor::from_inner(b.actions.clone().narrow(1, off + ai, ad - off - ai)));
        }
        Tensor::cat(parts, 1)
    }
}

/// The shared machinery; see the [module docs](self).
pub(crate) struct Learner {
    pub(crate) layout: ObservationLayout,
    pub(crate) net: NetworkConfig,
    pub(crate) replay_config: ReplayConfig,
    pub(crate) gamma: f64,
    pub(crate) sharing: InformationSharing,
    pub(crate) comm: Box<dyn Communicator>,
    pub(crate) device: Device,
    pub(crate) agents: Vec<AgentNets>,
    pub(crate) critic_norm: Normalizer,
    /// Start of each agent's block in the agent-major joint action.
    pub(crate) offsets: Vec<usize>,
    /// Agent-major order of the joint action: `perm[k]` is the joint slot of column `k`.
    perm: Vec<usize>,
    pub(crate) replay: ReplayBuffer,
    pub(crate) rng: ChaCha8Rng,
    /// Gradient steps taken.
    pub(crate) steps: u64,
    pub(crate) act_cache: Option<Vec<Actor>>,
    pools: Vec<rayon::ThreadPool>,
}

impl std::fmt::Debug for Learner {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Learner")
            .field("agents", &self.agents.len())
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

    /// On another device.
    #[must_use]
    pub fn with_device(mut self, device: Device) -> Self {
        self.device = device;
        self
    }
}

/// Parameter ids: agent `i`'s network `k` starts at `(i + 1) << 24 | k << 16`.
fn id_base(agent: usize, net: u64) -> u64 {
    ((agent as u64 + 1) << 24) | (net << 16)
}

/// Initial flat parameters of every agent's network of `shape`; with `same_trunk`
/// every agent starts from agent 0's trunk, so mixing begins at consensus.
fn initial(shapes: &[NetShape], seed: u64, stream: impl Fn(usize) -> u64, same_trunk: bool) -> Vec<Vec<f32>> {
    let mut flats: Vec<Vec<f32>> = shapes.iter().enumerate().map(|(i, s)| s.init(seed, stream(i))).collect();
    if same_trunk && let Some(first) = flats.first().cloned() {
        let r0 = shapes[0].trunk();
        for (flat, shape) in flats.iter_mut().zip(shapes).skip(1) {
            let r = shape.trunk();
            if r.len() == r0.len() {
                flat[r].copy_from_slice(&first[r0.clone()]);
            }
        }
    }
    flats
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

/// Every agent's networks and optimisers: online networks on the autodiff
/// twin of `device`, targets on `device`; trunks that sharing mixes start equal.
fn build_agents(
    layout: &ObservationLayout,
    net: &NetworkConfig,
    sharing: &InformationSharing,
    device: &Device,
    critics: usize,
    head_mult: usize,
) -> Vec<AgentNets> {
    let spec = layout.spec();
    let n = spec.num_agents();
    let ad_device = device.clone().autodiff();
    let actor_shapes: Vec<NetShape> = (0..n)
        .map(|i| {
            NetShape::mlp(layout.actor_input_dim(i), net.hidden, net.layers, head_mult * spec.agents[i].action_dim())
        })
        .collect();
    let critic_shapes = vec![NetShape::mlp(layout.critic_input_dim(), net.hidden, net.layers, 1); n];
    // ChaCha8 streams: 8i for agent i's actor, 8i + 1 + 2c for its critic c.
    let actor_flats = initial(&actor_shapes, net.seed, |i| 8 * i as u64, sharing.shares(NetworkGroup::Actors));
    let critic_flats: Vec<Vec<Vec<f32>>> = (0..critics)
        .map(|c| {
            let stream = |i: usize| 8 * i as u64 + 1 + 2 * c as u64;
            initial(&critic_shapes, net.seed, stream, sharing.shares(NetworkGroup::Critics))
        })
        .collect();
    let adam = AdamConfig::new()
        .with_beta_1(net.adam_beta1 as f32)
        .with_beta_2(net.adam_beta2 as f32)
        .with_epsilon(net.adam_epsilon as f32);
    (0..n)
        .map(|i| {
            let critics_on = |dev: &Device, kind: u64| Critics {
                nets: (0..critics)
                    .map(|c| {
                        Critic::from_flat(&critic_shapes[i], &critic_flats[c][i], dev, id_base(i, kind + 2 * c as u64))
                    })
                    .collect(),
            };
            AgentNets {
                actor: Actor::from_flat(&actor_shapes[i], &actor_flats[i], &ad_device, id_base(i, 0)),
                actor_target: Actor::from_flat(&actor_shapes[i], &actor_flats[i], device, id_base(i, 1)),
                critics: critics_on(&ad_device, 2),
                critic_targets: critics_on(device, 3),
                actor_optim: adam.init(),
                critic_optim: adam.init(),
                actor_norm: Normalizer::new(layout.actor_input_dim(i), net.norm_eps, net.clip_obs),
            }
        })
        .collect()
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
        let device = device.inner();
        let agents = build_agents(&layout, &net, &sharing, &device, critics, head_mult);
        let mut perm = Vec::with_capacity(spec.action_dim);
        let mut offsets = Vec::with_capacity(agents.len());
        for a in &spec.agents {
            offsets.push(perm.len());
            perm.extend_from_slice(&a.action_slots);
        }
        let pools = worker_pools(net.threads.min(agents.len()))?;
        let replay = ReplayBuffer::new(&spec, replay_config.buffer_size)
            .map_err(|e| NnError::InvalidConfig { key: "replay.buffer_size", reason: e.to_string() })?;
        // Networks start identical on every worker; exploration and sampling
        // draw from a stream of the worker's own.
        let mut rng = ChaCha8Rng::seed_from_u64(net.seed);
        rng.set_stream(0xF115 + comm.rank() as u64);
        Ok(Self {
            critic_norm: Normalizer::new(spec.obs_dim + spec.goal_dim, net.norm_eps, net.clip_obs),
            layout,
            net,
            replay_config,
            gamma,
            sharing,
            comm,
            device,
            agents,
            offsets,
            perm,
            replay,
            rng,
            steps: 0,
            act_cache: None,
            pools,
        })
    }

    /// Agent `agent`'s networks.
    fn agent(&self, agent: usize) -> Result<&AgentNets, NnError> {
        self.agents.get(agent).ok_or(NnError::UnknownAgent { agent, agents: self.agents.len() })
    }

    /// Number of agents.
    pub(crate) fn num_agents(&self) -> usize {
        self.agents.len()
    }

    /// Agent `i`'s action dimension.
    pub(crate) fn action_dim(&self, i: usize) -> usize {
        self.layout.spec().agents[i].action_dim()
    }

    /// The actors' head outputs (pre-activation) for `n` rows of raw actor inputs.
    pub(crate) fn heads(&mut self, inputs: &[Vec<f32>], n: usize) -> Result<Vec<Vec<f32>>, NnError> {
        let na = self.agents.len();
        if inputs.len() != na {
            return Err(NnError::Dimension { what: "actor inputs (agents)".into(), expected: na, found: inputs.len() });
        }
        for (i, x) in inputs.iter().enumerate() {
            check_values(|| format!("actor input of agent {i}"), x, n * self.layout.actor_input_dim(i))?;
        }
        if n == 0 {
            return Ok(vec![Vec::new(); na]);
        }
        if self.act_cache.is_none() {
            self.act_cache = Some(self.agents.iter().map(|a| a.actor.valid()).collect());
        }
        let Some(actors) = self.act_cache.as_ref() else {
            return Err(NnError::Backend { what: "actors", reason: "not built".into() });
        };
        actors
            .iter()
            .zip(&self.agents)
            .zip(inputs)
            .map(|((actor, a), x)| {
                let mut x = x.clone();
                a.actor_norm.normalize(&mut x);
                to_vec(actor.forward(matrix(x, n, a.actor_norm.dim(), &self.device)), "actions")
            })
            .collect()
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
        if bounds.len() != self.agents.len() {
            return Err(NnError::Dimension {
                what: "reward bounds (agents)".into(),
                expected: self.agents.len(),
                found: bounds.len(),
            });
        }
        let scale = 1.0 / (1.0 - self.gamma);
        let bounds = bounds.iter().map(|&(lo, hi)| ((lo * scale) as f32, (hi * scale) as f32)).collect();
        self.tensors(&b, bounds).map(Some)
    }

    fn check_batch(&self, b: &Batch, bounds: &[(f32, f32)]) -> Result<(), NnError> {
        let spec = self.layout.spec();
        let (n, na) = (b.size, self.agents.len());
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
        for (a, x) in self.agents.iter_mut().zip(&b.actor_inputs) {
            a.actor_norm.update(x, self.comm.as_ref());
        }
        self.critic_norm.normalize(&mut og);
        self.critic_norm.normalize(&mut og_next);
        let ogd = od + gd;
        let dev = &self.device;
        let inputs = |xs: &[Vec<f32>]| -> Vec<Tensor<2>> {
            xs.iter()
                .zip(&self.agents)
                .map(|(x, a)| {
                    let mut x = x.clone();
                    a.actor_norm.normalize(&mut x);
                    matrix(x, n, a.actor_norm.dim(), dev)
                })
                .collect()
        };
        let ad = self.perm.len();
        let mut actions = Vec::with_capacity(n * ad);
        for row in b.actions.chunks_exact(ad).take(n) {
            actions.extend(self.perm.iter().map(|&s| row[s]));
        }
        Ok(BatchTensors {
            n,
            og: matrix(og, n, ogd, dev),
            og_next: matrix(og_next, n, ogd, dev),
            actions: matrix(actions, n, ad, dev),
            x_now: inputs(&b.actor_inputs),
            x_next: inputs(&b.next_actor_inputs),
            rewards: b.rewards.iter().map(|r| matrix(r.clone(), n, 1, dev)).collect(),
            bounds,
        })
    }

    /// `f(i, agent_i)` for every agent, on the worker threads.
    pub(crate) fn per_agent<T: Send>(
        &mut self,
        f: impl Fn(usize, &AgentNets) -> Result<T, NnError> + Sync,
    ) -> Result<Vec<T>, NnError> {
        par_agents(&self.pools, &mut self.agents, |i, a| f(i, a))
    }

    /// One optimiser step of every agent's critics towards the clipped TD target (eq. 7)
    ///
    /// ```text
    /// y_i = clip(r_i + gamma * (min_c Q'_{i,c}(x', g, a') - soft_i), lo_i, hi_i)
    /// L_i = sum_c mean (Q_{i,c}(x, g, a) - y_i)^2
    /// ```
    ///
    /// where `a'` is `next_actions` (agent-major) and `soft_i` an optional
    /// per-sample term (MASAC's `alpha_i log pi_i`). Returns the losses.
    pub(crate) fn critic_step(
        &mut self,
        b: &BatchTensors,
        next_actions: Tensor<2>,
        soft: Option<Vec<Tensor<2>>>,
    ) -> Result<Vec<f32>, NnError> {
        let next_input = Tensor::cat(vec![b.og_next.clone(), next_actions], 1);
        let input = Tensor::from_inner(Tensor::cat(vec![b.og.clone(), b.actions.clone()], 1));
        let gamma = self.gamma as f32;
        self.step_group(NetworkGroup::Critics, |i, a| {
            let mut q_next = a.critic_targets.nets.iter().map(|c| c.forward(next_input.clone()));
            let first = q_next.next().ok_or(NnError::Backend { what: "critic target", reason: "no critic".into() })?;
            let mut q_next = q_next.fold(first, Tensor::min_pair);
            if let Some(soft) = &soft {
                q_next = q_next - soft[i].clone();
            }
            let (lo, hi) = b.bounds[i];
            let y = Tensor::from_inner((b.rewards[i].clone() + q_next.mul_scalar(gamma)).clamp(lo, hi));
            let mut loss: Option<Tensor<1>> = None;
            for c in &a.critics.nets {
                let l = (c.forward(input.clone()) - y.clone()).square().mean();
                loss = Some(match loss {
                    Some(acc) => acc + l,
                    None => l,
                });
            }
            loss.ok_or(NnError::Backend { what: "critic loss", reason: "no critic".into() })
        })
    }

    /// One optimiser step of every agent's actor on `loss(i, actor, critics, b)`,
    /// where `critics` are agent `i`'s online critics without parameter gradients.
    pub(crate) fn actor_step<F>(&mut self, b: &BatchTensors, loss: F) -> Result<Vec<f32>, NnError>
    where
        F: Fn(usize, &Actor, &Critics, &BatchTensors) -> Result<Tensor<1>, NnError> + Sync,
    {
        let losses =
            self.step_group(NetworkGroup::Actors, |i, a| loss(i, &a.actor, &a.critics.clone().no_grad(), b))?;
        self.act_cache = None;
        Ok(losses)
    }

    /// Every agent's loss of `group`, its gradient and its optimiser step, then
    /// parameter-mode sharing. Without other workers and without gradient
    /// sharing nothing crosses agents before the step, so each agent's step
    /// runs in its own worker right after its backward pass; otherwise the
    /// gradients are first averaged over workers and mixed over the graph.
    fn step_group<F>(&mut self, group: NetworkGroup, loss: F) -> Result<Vec<f32>, NnError>
    where
        F: Fn(usize, &AgentNets) -> Result<Tensor<1>, NnError> + Sync,
    {
        let fused = self.comm.workers() <= 1 && !self.sharing.mixes_gradients(group);
        let lr = match group {
            NetworkGroup::Actors => self.net.lr_actor,
            NetworkGroup::Critics => self.net.lr_critic,
        };
        let results = par_agents(&self.pools, &mut self.agents, |i, a| {
            let l = loss(i, a)?;
            let value = scalar(&l)?;
            let grads = a.gradients(group, l);
            if fused {
                a.optimize(group, lr, grads);
                Ok((value, None))
            } else {
                Ok((value, Some(grads)))
            }
        })?;
        let (losses, grads): (Vec<f32>, Vec<Option<GradientsParams>>) = results.into_iter().unzip();
        if !fused {
            self.reduce_mix_optimize(group, lr, grads.into_iter().flatten().collect())?;
        }
        let mut holder = ParamHolder { agents: &mut self.agents };
        self.sharing.mix_parameters(group, &mut holder)?;
        Ok(losses)
    }

    /// `b` with the sampled joint actions replaced by every agent's current
    /// action `squash(head_j(o_j), j)` (no gradient): the teammates' actions of
    /// [`crate::Teammates::Current`].
    pub(crate) fn with_current_actions(
        &mut self,
        b: &BatchTensors,
        squash: impl Fn(Tensor<2>, usize) -> Tensor<2> + Sync,
    ) -> Result<BatchTensors, NnError> {
        let actions = self.per_agent(|j, a| Ok(squash(a.actor.valid().forward(b.x_now[j].clone()), j)))?;
        Ok(BatchTensors { actions: Tensor::cat(actions, 1), ..b.clone() })
    }

    /// Where each agent's block lies in the agent-major joint action.
    pub(crate) fn joint(&self) -> JointLayout {
        JointLayout {
            offsets: self.offsets.clone(),
            dims: (0..self.agents.len()).map(|i| self.action_dim(i)).collect(),
            width: self.perm.len(),
        }
    }

    /// Worker averaging and gradient-mode sharing, then every agent's optimiser step.
    fn reduce_mix_optimize(
        &mut self,
        group: NetworkGroup,
        lr: f64,
        mut grads: Vec<GradientsParams>,
    ) -> Result<(), NnError> {
        if self.comm.workers() > 1 {
            for (a, g) in self.agents.iter().zip(grads.iter_mut()) {
                let layers = match group {
                    NetworkGroup::Actors => a.actor.layers(),
                    NetworkGroup::Critics => a.critics.nets.iter().flat_map(Critic::layers).collect(),
                };
                all_reduce(g, &layers, self.comm.as_ref())?;
            }
        }
        if self.sharing.mixes_gradients(group) {
            let ids: Vec<_> = self.agents.iter().map(|a| group_trunk_ids(a, group)).collect();
            let mut holder = GradHolder { grads: &mut grads, ids: &ids };
            self.sharing.mix_gradients(group, &mut holder)?;
        }
        for (a, g) in self.agents.iter_mut().zip(grads) {
            a.optimize(group, lr, g);
        }
        Ok(())
    }

    /// Targets move towards the online networks (eq. 9).
    pub(crate) fn soft_update_targets(&mut self, polyak: f64, actors: bool) {
        let p = polyak as f32;
        for a in &mut self.agents {
            if actors {
                a.actor_target.soft_update(&a.actor, p);
            }
            for (t, o) in a.critic_targets.nets.iter_mut().zip(&a.critics.nets) {
                t.soft_update(o, p);
            }
        }
    }

    /// Agent `i`'s actor trunk, flattened (what sharing mixes), for inspection.
    pub(crate) fn actor_trunk(&self, agent: usize) -> Result<Vec<f32>, NnError> {
        let a = self.agent(agent)?;
        let mut out = Vec::new();
        crate::net::flatten(&a.actor.trunk.iter().collect::<Vec<_>>(), &mut out)?;
        Ok(out)
    }

    /// Replaces agent `agent`'s actor trunk.
    pub(crate) fn set_actor_trunk(&mut self, agent: usize, trunk: &[f32]) -> Result<(), NnError> {
        let na = self.agents.len();
        let a = self.agents.get_mut(agent).ok_or(NnError::UnknownAgent { agent, agents: na })?;
        let shape = a.actor.shape();
        let range = shape.trunk();
        check_values(|| format!("actor trunk of agent {agent}"), trunk, range.len())?;
        let mut flat = a.actor.to_flat()?;
        flat[range].copy_from_slice(trunk);
        a.actor = a.actor.with_flat(&flat);
        self.act_cache = None;
        Ok(())
    }

    /// All parameters of agent `agent`'s online actor and first critic.
    pub(crate) fn params(&self, agent: usize) -> Result<(Vec<f32>, Vec<f32>), NnError> {
        let a = self.agent(agent)?;
        Ok((a.actor.to_flat()?, a.critics.nets[0].to_flat()?))
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
        let a = self.agent(agent)?;
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
        let critic = a.critics.nets[0].valid();
        to_vec(critic.forward(matrix(input, n, od + gd + ad, &self.device)), "q values")
    }

    /// Agent `i`'s first critic's trunk, flattened.
    pub(crate) fn critic_trunk(&self, agent: usize) -> Result<Vec<f32>, NnError> {
        let a = self.agent(agent)?;
        let mut out = Vec::new();
        let c = &a.critics.nets[0];
        let trunk: Vec<&Linear> = c.hidden.iter().skip(1).collect();
        crate::net::flatten(&trunk, &mut out)?;
        Ok(out)
    }
}

/// The value of a one-element tensor.
pub(crate) fn scalar(t: &Tensor<1>) -> Result<f32, NnError> {
    let v = t
        .clone()
        .inner()
        .into_data()
        .try_into_vec::<f32>()
        .map_err(|e| NnError::Backend { what: "loss", reason: format!("{e:?}") })?;
    v.first().copied().ok_or(NnError::Backend { what: "loss", reason: "empty tensor".into() })
}

/// Reads a 2-d tensor back as a row-major vector.
pub(crate) fn to_vec(t: Tensor<2>, what: &'static str) -> Result<Vec<f32>, NnError> {
    t.inner().into_data().try_into_vec::<f32>().map_err(|e| NnError::Backend { what, reason: format!("{e:?}") })
}

/// A row-major `rows x cols` matrix as a tensor on `device`.
pub(crate) fn matrix(values: Vec<f32>, rows: usize, cols: usize, device: &Device) -> Tensor<2> {
    Tensor::<2>::from_data(TensorData::new(values, [rows, cols]), device)
}
