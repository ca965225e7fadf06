//! The multi-agent DDPG learner implementing [`fmsr_core::Agent`].

use burn::tensor::{Device, Tensor};
use fmsr_core::agent::{
    Agent, Batch, Communicator, LearnStats, ObservationLayout, ShareMode, ShareTarget, Sharing, SingleProcess,
};
use fmsr_graph::Mixer;

use crate::config::DdpgConfig;
use crate::error::{NnError, check_values};
use crate::net::{Actor, Critic, FlatAdam, NetShape, flat_grads, matrix, to_vec};
use crate::normalizer::Normalizer;

/// Everything one agent learns: actor and critic, their targets, their Adam
/// states and the actor's input normaliser.
#[derive(Debug, Clone)]
pub(crate) struct AgentNets {
    pub(crate) actor_shape: NetShape,
    pub(crate) actor: Vec<f32>,
    pub(crate) actor_target: Vec<f32>,
    pub(crate) actor_adam: FlatAdam,
    pub(crate) critic: Vec<f32>,
    pub(crate) critic_target: Vec<f32>,
    pub(crate) critic_adam: FlatAdam,
    pub(crate) actor_norm: Normalizer,
}

/// Multi-agent DDPG (MADDPG / MAGCLA) with HER-baselines losses, running
/// input normalisers, target networks and information sharing; see the crate
/// docs for the equations.
///
/// Parameters live in flat `f32` vectors (the master copy that Adam, polyak
/// averaging, consensus and [`fmsr_core::agent::SaveState`] work on); burn
/// modules are built from them on the device for each forward/backward pass.
/// Gradients are taken on `device.autodiff()` only; acting and the target
/// networks run on the plain device.
#[derive(Debug)]
pub struct DdpgLearner {
    pub(crate) layout: ObservationLayout,
    pub(crate) config: DdpgConfig,
    sharing: Option<Sharing>,
    mixer: Option<Mixer>,
    comm: Box<dyn Communicator>,
    device: Device,
    ad_device: Device,
    pub(crate) critic_shape: NetShape,
    pub(crate) agents: Vec<AgentNets>,
    pub(crate) critic_norm: Normalizer,
    /// Agent-major order of the joint action: `perm[k]` is the joint slot of column `k`.
    perm: Vec<usize>,
    /// Start of each agent's block in the agent-major joint action.
    offsets: Vec<usize>,
    act_cache: Option<Vec<Actor>>,
    target_cache: Option<(Vec<Actor>, Vec<Critic>)>,
    /// One single-thread rayon pool per worker thread (empty when `threads == 1`).
    pools: Vec<rayon::ThreadPool>,
}

/// One agent's loss and flat gradient.
type LossGrad = (f32, Vec<f32>);

impl DdpgLearner {
    /// A learner on burn's `flex` CPU device, averaging nothing across workers
    /// ([`SingleProcess`]).
    ///
    /// # Errors
    /// [`NnError::InvalidConfig`] for an impossible config, [`NnError::Sharing`]
    /// when the mixing matrix does not have one node per agent.
    pub fn new(layout: ObservationLayout, config: DdpgConfig, sharing: Option<Sharing>) -> Result<Self, NnError> {
        Self::with_parts(layout, config, sharing, Box::new(SingleProcess), Device::flex())
    }

    /// A learner on burn's `flex` CPU device that averages gradients and
    /// normaliser statistics over workers with `comm`.
    ///
    /// # Errors
    /// As [`DdpgLearner::new`].
    pub fn with_communicator(
        layout: ObservationLayout,
        config: DdpgConfig,
        sharing: Option<Sharing>,
        comm: Box<dyn Communicator>,
    ) -> Result<Self, NnError> {
        Self::with_parts(layout, config, sharing, comm, Device::flex())
    }

    /// A learner on `device` (any burn device; its autodiff twin is used for
    /// gradients) that averages gradients and normaliser statistics with `comm`.
    ///
    /// # Errors
    /// As [`DdpgLearner::new`].
    pub fn with_parts(
        layout: ObservationLayout,
        config: DdpgConfig,
        sharing: Option<Sharing>,
        comm: Box<dyn Communicator>,
        device: Device,
    ) -> Result<Self, NnError> {
        config.validate()?;
        let spec = layout.spec();
        let n = spec.num_agents();
        if n == 0 {
            return Err(NnError::InvalidConfig { key: "agents", reason: "the layout has no agents".into() });
        }
        if let Some(s) = &sharing
            && s.mixing.n() != n
        {
            return Err(NnError::Sharing {
                reason: format!("the mixing matrix has {} nodes but the learner has {n} agents", s.mixing.n()),
            });
        }
        for (i, a) in spec.agents.iter().enumerate() {
            if layout.actor_input_dim(i) == 0 || a.action_dim() == 0 {
                return Err(NnError::InvalidConfig {
                    key: "agents",
                    reason: format!(
                        "agent {i} ({}) has actor input dim {} and action dim {}; both must be positive",
                        a.name,
                        layout.actor_input_dim(i),
                        a.action_dim()
                    ),
                });
            }
        }
        let device = device.inner();
        let ad_device = device.clone().autodiff();
        let critic_shape = NetShape::mlp(layout.critic_input_dim(), config.hidden, config.layers, 1);
        let og_dim = spec.obs_dim + spec.goal_dim;
        let agents = (0..n)
            .map(|i| {
                let actor_shape =
                    NetShape::mlp(layout.actor_input_dim(i), config.hidden, config.layers, spec.agents[i].action_dim());
                let actor = actor_shape.init(config.seed, 2 * i as u64);
                let critic = critic_shape.init(config.seed, 2 * i as u64 + 1);
                AgentNets {
                    actor_target: actor.clone(),
                    actor_adam: FlatAdam::new(actor.len()),
                    critic_target: critic.clone(),
                    critic_adam: FlatAdam::new(critic.len()),
                    actor_norm: Normalizer::new(layout.actor_input_dim(i), config.norm_eps, config.clip_obs),
                    actor_shape,
                    actor,
                    critic,
                }
            })
            .collect();
        let mut perm = Vec::with_capacity(spec.action_dim);
        let mut offsets = Vec::with_capacity(n);
        for a in &spec.agents {
            offsets.push(perm.len());
            perm.extend_from_slice(&a.action_slots);
        }
        let workers = config.threads.min(n);
        let pools = if workers > 1 {
            (0..workers)
                .map(|k| {
                    rayon::ThreadPoolBuilder::new()
                        .num_threads(1)
                        .thread_name(move |_| format!("fmsr-nn-agent-worker-{k}"))
                        .build()
                        .map_err(|e| NnError::InvalidConfig {
                            key: "threads",
                            reason: format!("cannot start worker {k}: {e}"),
                        })
                })
                .collect::<Result<Vec<_>, _>>()?
        } else {
            Vec::new()
        };
        Ok(Self {
            pools,
            critic_norm: Normalizer::new(og_dim, config.norm_eps, config.clip_obs),
            mixer: sharing.as_ref().map(|s| Mixer::new(&s.mixing)),
            layout,
            config,
            sharing,
            comm,
            device,
            ad_device,
            critic_shape,
            agents,
            perm,
            offsets,
            act_cache: None,
            target_cache: None,
        })
    }

    /// The configuration.
    #[must_use]
    pub fn config(&self) -> &DdpgConfig {
        &self.config
    }

    /// The observation layout.
    #[must_use]
    pub fn layout(&self) -> &ObservationLayout {
        &self.layout
    }

    /// The information-sharing setting, if any.
    #[must_use]
    pub fn sharing(&self) -> Option<&Sharing> {
        self.sharing.as_ref()
    }

    /// The layer sizes of agent `agent`'s actor.
    ///
    /// # Errors
    /// [`NnError::UnknownAgent`].
    pub fn actor_shape(&self, agent: usize) -> Result<&NetShape, NnError> {
        Ok(&self.agent(agent)?.actor_shape)
    }

    /// The layer sizes of every critic.
    #[must_use]
    pub fn critic_shape(&self) -> &NetShape {
        &self.critic_shape
    }

    /// All flat parameters of agent `agent`'s online actor.
    ///
    /// # Errors
    /// [`NnError::UnknownAgent`].
    pub fn actor_params(&self, agent: usize) -> Result<&[f32], NnError> {
        Ok(&self.agent(agent)?.actor)
    }

    /// All flat parameters of agent `agent`'s online critic.
    ///
    /// # Errors
    /// [`NnError::UnknownAgent`].
    pub fn critic_params(&self, agent: usize) -> Result<&[f32], NnError> {
        Ok(&self.agent(agent)?.critic)
    }

    /// The hidden -> hidden layers of agent `agent`'s online critic, flattened
    /// (what information sharing mixes with target `Critics` or `Both`).
    ///
    /// # Errors
    /// [`NnError::UnknownAgent`].
    pub fn critic_trunk(&self, agent: usize) -> Result<Vec<f32>, NnError> {
        Ok(self.agent(agent)?.critic[self.critic_shape.trunk()].to_vec())
    }

    /// The actor-input normaliser of agent `agent`.
    ///
    /// # Errors
    /// [`NnError::UnknownAgent`].
    pub fn actor_normalizer(&self, agent: usize) -> Result<&Normalizer, NnError> {
        Ok(&self.agent(agent)?.actor_norm)
    }

    /// The normaliser of the critics' `[global obs, goal]` input.
    #[must_use]
    pub fn critic_normalizer(&self) -> &Normalizer {
        &self.critic_norm
    }

    /// `Q_i(x, goal, a)` of the online critic of agent `agent` for `n` rows of
    /// raw global observations, goals and joint actions (in the environment's
    /// slot order).
    ///
    /// # Errors
    /// [`NnError::UnknownAgent`], [`NnError::Dimension`] / [`NnError::NotFinite`] for bad inputs.
    pub fn q_values(
        &self,
        agent: usize,
        obs: &[f32],
        goals: &[f32],
        actions: &[f32],
        n: usize,
    ) -> Result<Vec<f32>, NnError> {
        let nets = self.agent(agent)?;
        let spec = self.layout.spec();
        check_values(|| "q_values obs".into(), obs, n * spec.obs_dim)?;
        check_values(|| "q_values goals".into(), goals, n * spec.goal_dim)?;
        check_values(|| "q_values actions".into(), actions, n * spec.action_dim)?;
        if n == 0 {
            return Ok(Vec::new());
        }
        let mut og = self.obs_goal(obs, goals, n);
        self.critic_norm.normalize(&mut og);
        let input = self.critic_input(&og, &self.permute_actions(actions, n), n);
        let critic = Critic::from_flat(&self.critic_shape, &nets.critic, &self.device, false)?;
        to_vec(critic.forward(matrix(input, n, self.critic_shape.layers[0].0, &self.device)), "q values")
    }

    pub(crate) fn agent(&self, agent: usize) -> Result<&AgentNets, NnError> {
        self.agents.get(agent).ok_or(NnError::UnknownAgent { agent, agents: self.agents.len() })
    }

    pub(crate) fn invalidate(&mut self) {
        self.act_cache = None;
        self.target_cache = None;
    }

    /// Rows of `[obs, goal]`.
    fn obs_goal(&self, obs: &[f32], goals: &[f32], n: usize) -> Vec<f32> {
        let (od, gd) = (self.layout.spec().obs_dim, self.layout.spec().goal_dim);
        let mut out = Vec::with_capacity(n * (od + gd));
        for r in 0..n {
            out.extend_from_slice(&obs[r * od..(r + 1) * od]);
            out.extend_from_slice(&goals[r * gd..(r + 1) * gd]);
        }
        out
    }

    /// Joint actions in agent-major column order.
    fn permute_actions(&self, actions: &[f32], n: usize) -> Vec<f32> {
        let ad = self.perm.len();
        let mut out = Vec::with_capacity(n * ad);
        for row in actions.chunks_exact(ad).take(n) {
            out.extend(self.perm.iter().map(|&s| row[s]));
        }
        out
    }

    /// Rows of `[og, actions]` (actions agent-major).
    fn critic_input(&self, og: &[f32], actions: &[f32], n: usize) -> Vec<f32> {
        let ogd = self.critic_norm.dim();
        let ad = self.perm.len();
        let mut out = Vec::with_capacity(n * (ogd + ad));
        for r in 0..n {
            out.extend_from_slice(&og[r * ogd..(r + 1) * ogd]);
            out.extend_from_slice(&actions[r * ad..(r + 1) * ad]);
        }
        out
    }

    fn check_batch(&self, b: &Batch) -> Result<(), NnError> {
        let spec = self.layout.spec();
        let n = b.size;
        let na = self.agents.len();
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
        if b.q_bounds.len() != na {
            return Err(NnError::Dimension {
                what: "batch.q_bounds (agents)".into(),
                expected: na,
                found: b.q_bounds.len(),
            });
        }
        for (i, &(lo, hi)) in b.q_bounds.iter().enumerate() {
            if lo.is_nan() || hi.is_nan() || lo > hi {
                return Err(NnError::InvalidConfig {
                    key: "batch.q_bounds",
                    reason: format!("agent {i} has bounds ({lo}, {hi}); need lo <= hi"),
                });
            }
        }
        Ok(())
    }

    fn ensure_targets(&mut self) -> Result<(), NnError> {
        if self.target_cache.is_none() {
            let mut actors = Vec::with_capacity(self.agents.len());
            let mut critics = Vec::with_capacity(self.agents.len());
            for a in &self.agents {
                actors.push(Actor::from_flat(&a.actor_shape, &a.actor_target, &self.device, false)?);
                critics.push(Critic::from_flat(&self.critic_shape, &a.critic_target, &self.device, false)?);
            }
            self.target_cache = Some((actors, critics));
        }
        Ok(())
    }

    fn mix(&mut self, what: &'static str, critic: bool, grads: Option<&mut [Vec<f32>]>) -> Result<(), NnError> {
        let Some(mixer) = self.mixer.as_mut() else { return Ok(()) };
        let critic_trunk = self.critic_shape.trunk();
        let mut slices: Vec<&mut [f32]> = match grads {
            Some(gs) => gs
                .iter_mut()
                .zip(&self.agents)
                .map(|(g, a)| if critic { &mut g[critic_trunk.clone()] } else { &mut g[a.actor_shape.trunk()] })
                .collect(),
            None => self
                .agents
                .iter_mut()
                .map(|a| {
                    if critic {
                        &mut a.critic[critic_trunk.clone()]
                    } else {
                        let r = a.actor_shape.trunk();
                        &mut a.actor[r]
                    }
                })
                .collect(),
        };
        if slices.first().is_none_or(|s| s.is_empty()) {
            return Ok(());
        }
        mixer.mix_slices(&mut slices).map_err(|source| NnError::Mixing { what, source })
    }

    /// One optimiser step of every agent's critic (`critic`) or actor from its
    /// gradient: averaged over workers by the communicator, mixed over the graph
    /// in gradient mode, Adam, then mixed in parameter mode (eq. 8).
    fn apply_gradients(&mut self, critic: bool, mut grads: Vec<Vec<f32>>) -> Result<(), NnError> {
        for g in &mut grads {
            self.comm.all_reduce_mean(g);
        }
        let (grad_what, param_what) = if critic {
            ("critic trunk gradients", "critic trunk parameters")
        } else {
            ("actor trunk gradients", "actor trunk parameters")
        };
        if self.shares(ShareMode::Gradients, critic) {
            self.mix(grad_what, critic, Some(&mut grads))?;
        }
        let c = &self.config;
        let (lr, b1, b2, eps) =
            (if critic { c.lr_critic } else { c.lr_actor }, c.adam_beta1, c.adam_beta2, c.adam_epsilon);
        for (a, g) in self.agents.iter_mut().zip(&grads) {
            let (adam, params) =
                if critic { (&mut a.critic_adam, &mut a.critic) } else { (&mut a.actor_adam, &mut a.actor) };
            adam.step(params, g, lr, b1, b2, eps);
        }
        if self.shares(ShareMode::Parameters, critic) {
            self.mix(param_what, critic, None)?;
        }
        Ok(())
    }

    fn shares(&self, mode: ShareMode, critic: bool) -> bool {
        self.sharing.as_ref().is_some_and(|s| {
            s.mode == mode
                && match s.target {
                    ShareTarget::Actors => !critic,
                    ShareTarget::Critics => critic,
                    ShareTarget::Both => true,
                }
        })
    }

    fn learn_inner(&mut self, b: &Batch) -> Result<LearnStats, NnError> {
        self.check_batch(b)?;
        let n = b.size;
        let na = self.agents.len();
        let cfg = self.config.clone();

        // Normalisers follow the data they learn on.
        let mut og = self.obs_goal(&b.obs, &b.goals, n);
        let mut og_next = self.obs_goal(&b.next_obs, &b.goals, n);
        self.critic_norm.update(&og, self.comm.as_ref());
        for (a, x) in self.agents.iter_mut().zip(&b.actor_inputs) {
            a.actor_norm.update(x, self.comm.as_ref());
        }
        self.critic_norm.normalize(&mut og);
        self.critic_norm.normalize(&mut og_next);
        let norm_inputs = |xs: &[Vec<f32>]| -> Vec<Vec<f32>> {
            xs.iter()
                .zip(&self.agents)
                .map(|(x, a)| {
                    let mut x = x.clone();
                    a.actor_norm.normalize(&mut x);
                    x
                })
                .collect()
        };
        let x_now = norm_inputs(&b.actor_inputs);
        let x_next = norm_inputs(&b.next_actor_inputs);
        let actions = self.permute_actions(&b.actions, n);

        // Target actions a'_j = mu'_j(next input j), agent-major.
        self.ensure_targets()?;
        let Some((t_actors, t_critics)) = self.target_cache.as_ref() else {
            return Err(NnError::Backend { what: "target networks", reason: "not built".into() });
        };
        let ad = self.perm.len();
        let mut next_actions = vec![0.0f32; n * ad];
        for (j, actor) in t_actors.iter().enumerate() {
            let dim = self.agents[j].actor_shape.layers[0].0;
            let aj = self.layout.spec().agents[j].action_dim();
            let out = to_vec(actor.forward(matrix(x_next[j].clone(), n, dim, &self.device)), "target actions")?;
            let off = self.offsets[j];
            for r in 0..n {
                next_actions[r * ad + off..r * ad + off + aj].copy_from_slice(&out[r * aj..(r + 1) * aj]);
            }
        }
        let next_input = self.critic_input(&og_next, &next_actions, n);
        let now_input = self.critic_input(&og, &actions, n);
        let cin = self.critic_shape.layers[0].0;

        // Critic phase: y_i = clip(r_i + gamma Q'_i(x', g, a'), bounds); L = mean((Q_i - y_i)^2).
        let critic_results = {
            let (device, ad_device, shape) = (&self.device, &self.ad_device, &self.critic_shape);
            let agents = &self.agents;
            par_map(&self.pools, na, |i| -> Result<LossGrad, NnError> {
                let q_next = to_vec(t_critics[i].forward(matrix(next_input.clone(), n, cin, device)), "target q")?;
                let (lo, hi) = b.q_bounds[i];
                let y: Vec<f32> =
                    b.rewards[i].iter().zip(&q_next).map(|(&r, &q)| (r + cfg.gamma as f32 * q).clamp(lo, hi)).collect();
                let critic = Critic::from_flat(shape, &agents[i].critic, ad_device, true)?;
                let q = critic.forward(matrix(now_input.clone(), n, cin, ad_device));
                let diff = q - matrix(y, n, 1, ad_device);
                let loss = (diff.clone() * diff).mean();
                let value = scalar(&loss)?;
                let grads = loss.backward();
                let mut g = Vec::with_capacity(shape.num_params());
                flat_grads(&critic.layers(), &grads, &mut g)?;
                Ok((value, g))
            })?
        };
        let (critic_loss, critic_grads): (Vec<f32>, Vec<Vec<f32>>) = critic_results.into_iter().unzip();
        self.apply_gradients(true, critic_grads)?;

        // Actor phase: L = -mean(Q_i(x, g, a with agent i's block = mu_i)) + action_l2 * mean(mu_i^2).
        let ogd = self.critic_norm.dim();
        let actor_results = {
            let (ad_device, shape) = (&self.ad_device, &self.critic_shape);
            let (agents, offsets, layout) = (&self.agents, &self.offsets, &self.layout);
            par_map(&self.pools, na, |i| -> Result<LossGrad, NnError> {
                let nets = &agents[i];
                let dim = nets.actor_shape.layers[0].0;
                let ai = layout.spec().agents[i].action_dim();
                let off = offsets[i];
                let left_w = ogd + off;
                let right_w = ad - off - ai;
                let mut left = Vec::with_capacity(n * left_w);
                let mut right = Vec::with_capacity(n * right_w);
                for r in 0..n {
                    left.extend_from_slice(&og[r * ogd..(r + 1) * ogd]);
                    left.extend_from_slice(&actions[r * ad..r * ad + off]);
                    right.extend_from_slice(&actions[r * ad + off + ai..(r + 1) * ad]);
                }
                let actor = Actor::from_flat(&nets.actor_shape, &nets.actor, ad_device, true)?;
                let critic = Critic::from_flat(shape, &nets.critic, ad_device, false)?;
                let mu = actor.forward(matrix(x_now[i].clone(), n, dim, ad_device));
                let mut parts = Vec::with_capacity(3);
                if left_w > 0 {
                    parts.push(matrix(left, n, left_w, ad_device));
                }
                parts.push(mu.clone());
                if right_w > 0 {
                    parts.push(matrix(right, n, right_w, ad_device));
                }
                let q = critic.forward(Tensor::cat(parts, 1));
                let loss = q.mean().neg() + (mu.clone() * mu).mean().mul_scalar(cfg.action_l2 as f32);
                let value = scalar(&loss)?;
                let grads = loss.backward();
                let mut g = Vec::with_capacity(nets.actor_shape.num_params());
                flat_grads(&actor.layers(), &grads, &mut g)?;
                Ok((value, g))
            })?
        };
        let (actor_loss, actor_grads): (Vec<f32>, Vec<Vec<f32>>) = actor_results.into_iter().unzip();
        self.apply_gradients(false, actor_grads)?;
        self.act_cache = None;
        Ok(LearnStats { critic_loss, actor_loss })
    }
}

/// The value of a one-element tensor.
fn scalar(t: &Tensor<1>) -> Result<f32, NnError> {
    let v = t
        .clone()
        .inner()
        .into_data()
        .try_into_vec::<f32>()
        .map_err(|e| NnError::Backend { what: "loss", reason: format!("{e:?}") })?;
    v.first().copied().ok_or(NnError::Backend { what: "loss", reason: "empty tensor".into() })
}

/// `f(0), ..., f(n - 1)`: with no pools in order on the calling thread (burn's
/// kernels then use rayon's global pool), otherwise round robin over the
/// single-thread `pools`, one scoped OS thread driving each, so the agents run
/// in parallel and each agent's kernels run on one core (no oversubscription).
fn par_map<T: Send>(
    pools: &[rayon::ThreadPool],
    n: usize,
    f: impl Fn(usize) -> Result<T, NnError> + Sync,
) -> Result<Vec<T>, NnError> {
    let t = pools.len().min(n);
    if t <= 1 {
        return (0..n).map(f).collect();
    }
    let f = &f;
    let mut slots: Vec<Option<Result<T, NnError>>> = (0..n).map(|_| None).collect();
    std::thread::scope(|s| {
        let handles: Vec<_> = pools[..t]
            .iter()
            .enumerate()
            .map(|(k, pool)| s.spawn(move || pool.install(|| (k..n).step_by(t).map(|i| (i, f(i))).collect::<Vec<_>>())))
            .collect();
        for h in handles {
            match h.join() {
                Ok(done) => {
                    for (i, r) in done {
                        slots[i] = Some(r);
                    }
                }
                Err(_) => return,
            }
        }
    });
    slots
        .into_iter()
        .map(|s| s.unwrap_or(Err(NnError::Backend { what: "agent update", reason: "a worker thread panicked".into() })))
        .collect()
}

impl Agent for DdpgLearner {
    type Error = NnError;

    fn num_agents(&self) -> usize {
        self.agents.len()
    }

    fn act(&mut self, inputs: &[Vec<f32>], n: usize) -> Result<Vec<Vec<f32>>, NnError> {
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
            let actors = self
                .agents
                .iter()
                .map(|a| Actor::from_flat(&a.actor_shape, &a.actor, &self.device, false))
                .collect::<Result<Vec<_>, _>>()?;
            self.act_cache = Some(actors);
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

    fn learn(&mut self, batch: &Batch) -> Result<LearnStats, NnError> {
        self.learn_inner(batch)
    }

    fn update_targets(&mut self) -> Result<(), NnError> {
        let p = self.config.polyak as f32;
        for a in &mut self.agents {
            for (t, &o) in a.actor_target.iter_mut().zip(&a.actor) {
                *t = p * *t + (1.0 - p) * o;
            }
            for (t, &o) in a.critic_target.iter_mut().zip(&a.critic) {
                *t = p * *t + (1.0 - p) * o;
            }
        }
        self.target_cache = None;
        Ok(())
    }

    fn consensus_params(&self, agent: usize) -> Result<Vec<f32>, NnError> {
        let a = self.agent(agent)?;
        Ok(a.actor[a.actor_shape.trunk()].to_vec())
    }

    fn set_consensus_params(&mut self, agent: usize, params: &[f32]) -> Result<(), NnError> {
        let na = self.agents.len();
        let a = self.agents.get_mut(agent).ok_or(NnError::UnknownAgent { agent, agents: na })?;
        let range = a.actor_shape.trunk();
        check_values(|| format!("consensus parameters of agent {agent}"), params, range.len())?;
        a.actor[range].copy_from_slice(params);
        self.act_cache = None;
        Ok(())
    }
}
