//! The learner ([`Learner`]): what MADDPG, MATD3 and MASAC share.
//!
//! By job: `replay.rs` holds the HER replay buffer, its sampling and the
//! batches it uploads; `steps.rs` the critic and actor steps, worker averaging,
//! information sharing and polyak targets; `deterministic.rs` what the
//! deterministic-actor rules share (target actions, the policy-gradient step,
//! acting with exploration); `stochastic.rs` what the squashed-Gaussian rules
//! share (sampled next actions, the soft critic step, the entropy-regularised
//! actor step, acting); `probes.rs` the views into the networks that
//! tests and tools read; this file the networks, the normalisers and acting.
//! The algorithms drive it through [`crate::off_policy`].

pub(crate) mod deterministic;
mod probes;
mod replay;
mod steps;
mod stochastic;

use burn::optim::AdamConfig;
use burn::optim::grad_clipping::GradientClippingConfig;
use burn::tensor::{Device, Tensor, TensorData};
use fmsr_core::agent::{Communicator, ObservationLayout};
use fmsr_core::replay::{ReplayBuffer, ReplayConfig};
use fmsr_core::sharing::{InformationSharing, NetworkKind, Sharing};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::config::{CriticTying, CriticView, NetworkConfig, Stacking};
use crate::error::{NnError, check_values};
use crate::group::{Group, GroupSpec};
use crate::normalizer::Normalizer;
use crate::workers::{par_each, worker_pools};

pub use self::replay::BatchTensors;
pub use self::replay::{check_replay_fits, physical_memory_bytes};
pub use self::stochastic::{SoftTerm, SquashedGaussian};

/// What MADDPG, MATD3 and MASAC share: the agents' networks in stacked
/// groups ([`crate::Stacking`]) that live on the device
/// across updates; input normalisers; the HER replay buffer and its sampling;
/// the critic and actor steps with worker averaging and information sharing;
/// polyak targets. Its state is saved and restored through the algorithm
/// ([`fmsr_core::algorithm::Algorithm::save_state`]).
///
/// A step of the critics or actors runs every group's forward and backward
/// pass (on worker threads when there are several groups), averages
/// gradients over worker processes, mixes them over the graph in gradient
/// mode, steps each group's optimiser and mixes parameters in parameter mode.
/// With one group (GPUs) the kernels a joint update launches do not depend on
/// the number of agents.
///
/// Rollouts act on a host copy of the actors (burn's `flex` device), made
/// once after each update phase, so an environment step never waits for a
/// round trip to an accelerator.
///
/// An update rule ([`crate::UpdateRule`]) sees it through its public methods:
/// the agents and their action widths, the step index, the RNG and device, and the steps
/// ([`Learner::target_actions`], [`Learner::critic_step`],
/// [`Learner::deterministic_actor_step`], [`Learner::deterministic_act`];
/// [`Learner::sampled_next_actions`], [`Learner::soft_critic_step`],
/// [`Learner::squashed_gaussian_actor_step`], [`Learner::squashed_gaussian_act`]),
/// each of which applies information sharing and worker averaging itself.
pub struct Learner {
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
    /// What the update cycle's batches held, for the epoch's statistics.
    pub(crate) diagnostics: Diagnostics,
    pools: Vec<rayon::ThreadPool>,
}

/// Sums over an update cycle's sampled batches: each agent's reward parts
/// and its critic's mean Q (not saved: a cycle starts and ends in one call).
#[derive(Debug, Clone, Default)]
pub(crate) struct Diagnostics {
    /// Sum over sampled rows of each agent's `|task part|`.
    pub(crate) task_abs: Vec<f64>,
    /// Sum over sampled rows of each agent's `|shadow part|`.
    pub(crate) shadow_abs: Vec<f64>,
    /// Rows sampled.
    pub(crate) rows: u64,
    /// Sum over critic steps of each agent's batch-mean Q.
    pub(crate) q_sum: Vec<f64>,
    /// Critic steps.
    pub(crate) q_steps: u64,
}

impl Diagnostics {
    /// The means, into `stats`, and a fresh start.
    pub(crate) fn take_into(&mut self, stats: &mut fmsr_core::algorithm::UpdateStats) {
        let rows = self.rows.max(1) as f64;
        let q_steps = self.q_steps.max(1) as f64;
        stats.batch_task_reward_abs = self.task_abs.iter().map(|v| v / rows).collect();
        stats.batch_shadow_reward_abs = self.shadow_abs.iter().map(|v| v / rows).collect();
        stats.q_mean = self.q_sum.iter().map(|v| v / q_steps).collect();
        *self = Self::default();
    }
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
        Stacking::Auto => *device == Device::flex() && net.critic == CriticTying::PerAgent,
    };
    if per_agent { (0..agents).map(|i| i..i + 1).collect() } else { std::iter::once(0..agents).collect() }
}

impl Learner {
    /// A learner with `critics` critics per agent and actor heads of
    /// `head_mult * action_dim(i)` outputs.
    pub(crate) fn new(
        parts: LearnerParts,
        critics: usize,
        head_mult: usize,
        view: CriticView,
    ) -> Result<Self, NnError> {
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
        if net.critic != CriticTying::PerAgent && sharing.shares(NetworkKind::Critics) {
            return Err(NnError::Sharing {
                reason: format!(
                    "networks.critic = {:?} already shares the critics' trunk; information sharing can mix only the actors",
                    net.critic
                ),
            });
        }
        if view != CriticView::Global && net.critic != CriticTying::PerAgent {
            return Err(NnError::InvalidConfig {
                key: "networks.critic",
                reason: format!(
                    "{:?} shares critics that see the global input; a critic of view {view:?} needs one per agent",
                    net.critic
                ),
            });
        }
        let device = device.inner();
        let na = spec.num_agents();
        let inputs: Vec<usize> = (0..na).map(|i| layout.actor_input_dim(i)).collect();
        let actions: Vec<usize> = spec.agents.iter().map(|a| a.action_dim()).collect();
        let critic_sets: Option<Vec<Vec<usize>>> = match view {
            CriticView::Global => None,
            CriticView::Own => Some((0..na).map(|i| vec![i]).collect()),
            CriticView::Neighbours => Some(
                (0..na).map(|i| std::iter::once(i).chain(layout.neighbours(i).iter().copied()).collect()).collect(),
            ),
        };
        let critic_inputs: Vec<usize> = match &critic_sets {
            None => vec![layout.critic_input_dim(); na],
            Some(sets) => (0..na).map(|i| inputs[i] + sets[i].iter().map(|&j| actions[j]).sum::<usize>()).collect(),
        };
        let group_spec = GroupSpec {
            inputs: &inputs,
            actions: &actions,
            critic_inputs: &critic_inputs,
            critic_sets: critic_sets.as_deref(),
            hidden: net.hidden,
            layers: net.layers,
            seed: net.seed,
            critics,
            critic_shared: net.critic.shared_layers(net.layers),
            head_mult,
            same_trunks: (sharing.shares(NetworkKind::Actors), sharing.shares(NetworkKind::Critics)),
            adam: AdamConfig::new()
                .with_beta_1(net.adam_beta1 as f32)
                .with_beta_2(net.adam_beta2 as f32)
                .with_epsilon(net.adam_epsilon as f32)
                .with_grad_clipping(
                    (net.grad_clip_value > 0.0).then_some(GradientClippingConfig::Value(net.grad_clip_value as f32)),
                ),
            grad_clip_norm: net.grad_clip_norm,
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
            diagnostics: Diagnostics::default(),
            pools,
        })
    }

    /// Number of agents.
    #[must_use]
    pub fn num_agents(&self) -> usize {
        self.actor_norms.len()
    }

    /// Agent `i`'s action dimension (`i < num_agents()`).
    #[must_use]
    pub fn action_dim(&self, i: usize) -> usize {
        self.layout.spec().agents[i].action_dim()
    }

    /// The joint action's width (every agent's actions, agent-major).
    #[must_use]
    pub fn joint_width(&self) -> usize {
        self.perm.len()
    }

    /// Gradient steps taken before the one in progress (the learner counts them).
    #[must_use]
    pub fn step_index(&self) -> u64 {
        self.steps
    }

    /// The learner's random stream (exploration, sampling, a rule's own draws),
    /// saved with the state.
    pub fn rng(&mut self) -> &mut ChaCha8Rng {
        &mut self.rng
    }

    /// The plain device the targets and batches live on.
    #[must_use]
    pub fn device(&self) -> &Device {
        &self.device
    }

    /// The discount.
    #[must_use]
    pub fn gamma(&self) -> f64 {
        self.gamma
    }

    /// The networks' and optimisers' settings (Adam's betas for a rule's own
    /// optimiser, as MASAC's temperatures use them).
    #[must_use]
    pub fn networks(&self) -> &NetworkConfig {
        &self.net
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

#[cfg(test)]
mod tests {
    use fmsr_core::agent::ObservationLayout;
    use fmsr_core::replay::ReplayConfig;
    use fmsr_core::spec::{AgentSpec, EnvSpec};

    use super::{Learner, LearnerParts};
    use crate::config::{CriticView, NetworkConfig, Stacking};

    // Guards `networks.threads`: the groups' updates run on that many worker
    // threads, at most one per group. The determinism tests compare thread
    // counts and pass alike whether or not the setting is applied.
    #[test]
    fn the_groups_update_on_networks_threads() {
        let agent = |i: usize| AgentSpec { name: format!("a{i}"), action_slots: vec![i], local_obs_dim: 2 };
        let spec = EnvSpec {
            agents: (0..3).map(agent).collect(),
            action_dim: 3,
            obs_dim: 4,
            goal_dim: 1,
            episode_len: 5,
            features: vec![],
            reward_range: (-1.0, 0.0),
        };
        let layout = ObservationLayout::new(spec, vec![vec![]; 3]).unwrap();
        let workers = |stacking: Stacking, threads: usize| {
            let net = NetworkConfig::new().with_hidden(8).with_layers(2).with_stacking(stacking).with_threads(threads);
            let replay = ReplayConfig { buffer_size: 100, ..ReplayConfig::default() };
            let learner =
                Learner::new(LearnerParts::new(layout.clone(), net, replay, 0.9), 1, 1, CriticView::Global).unwrap();
            (learner.groups.len(), learner.pools.len())
        };
        assert_eq!(workers(Stacking::PerAgent, 1), (3, 0), "one thread: on the calling thread");
        assert_eq!(workers(Stacking::PerAgent, 2), (3, 2));
        assert_eq!(workers(Stacking::PerAgent, 8), (3, 3), "at most one thread per group");
        assert_eq!(workers(Stacking::All, 2), (1, 0), "one group: one thread");
    }

    struct Task;

    impl fmsr_core::RewardModel for Task {
        fn goal_reward(&self, a: &[f32], d: &[f32]) -> f32 {
            -(a[0] - d[0]).abs()
        }
        fn agent_rewards(&self, task: f32, _: &[f32], out: &mut [f32]) {
            out.fill(task);
        }
        fn reward_bounds(&self) -> Vec<(f64, f64)> {
            vec![(-1.0, 0.0); 2]
        }
    }

    // Guards `networks.normalizer_stats`: HER baselines' rule adds T
    // relabelled rows of each episode when it is stored and nothing when a
    // batch is sampled; the default adds every sampled batch and nothing at
    // storing.
    #[test]
    fn the_normalisers_learn_from_what_the_setting_says() {
        use crate::config::NormalizerStats;
        use fmsr_core::replay::Episode;
        use fmsr_core::spec::{JointAction, Observation, StepInfo};
        const T: usize = 5;
        let agent = |i: usize| AgentSpec { name: format!("a{i}"), action_slots: vec![i], local_obs_dim: 2 };
        let spec = EnvSpec {
            agents: (0..2).map(agent).collect(),
            action_dim: 2,
            obs_dim: 3,
            goal_dim: 1,
            episode_len: T,
            features: vec![],
            reward_range: (-1.0, 0.0),
        };
        let layout = ObservationLayout::new(spec, vec![vec![]; 2]).unwrap();
        let episode = Episode {
            observations: (0..=T)
                .map(|t| Observation {
                    global: vec![t as f32, 1.0, 2.0],
                    locals: vec![vec![t as f32, 0.5]; 2],
                    achieved_goal: vec![t as f32],
                    desired_goal: vec![9.0],
                })
                .collect(),
            actions: (0..T).map(|_| JointAction(vec![0.1, -0.1])).collect(),
            infos: vec![StepInfo::default(); T],
            log_probs: Vec::new(),
        };
        let counts = |stats: NormalizerStats| {
            let net = NetworkConfig::new().with_hidden(8).with_layers(2).with_normalizer_stats(stats);
            let replay = ReplayConfig { buffer_size: 100, batch_size: 16, ..ReplayConfig::default() };
            let mut learner =
                Learner::new(LearnerParts::new(layout.clone(), net, replay, 0.9), 1, 1, CriticView::Global).unwrap();
            learner.store(&episode).unwrap();
            let stored = (learner.critic_norm.count(), learner.actor_norms[1].count());
            learner.sample(&Task).unwrap().unwrap();
            (stored, (learner.critic_norm.count(), learner.actor_norms[1].count()))
        };
        assert_eq!(counts(NormalizerStats::StoredEpisodes), ((5.0, 5.0), (5.0, 5.0)));
        assert_eq!(counts(NormalizerStats::SampledBatches), ((0.0, 0.0), (16.0, 16.0)));
    }
}
