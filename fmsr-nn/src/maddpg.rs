//! MADDPG with HER-baselines losses (paper section III, eqs. 5-7, 9).
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
//! once: `theta' <- polyak theta' + (1 - polyak) theta` (eq. 9).

use burn::tensor::Tensor;
use burn::tensor::activation::tanh;
use fmsr_core::agent::Batch;
use fmsr_core::algorithm::{Algorithm, RewardModel, UpdateStats};
use fmsr_core::policy::{ActMode, Policy, PolicyOutput, PolicyState};
use fmsr_core::replay::Episode;

use crate::config::{MaddpgConfig, Teammates};
use crate::error::NnError;
use crate::explore;
use crate::learner::{BatchTensors, Learner, LearnerParts};

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
#[derive(Debug)]
pub struct Maddpg {
    learner: Learner,
    config: MaddpgConfig,
}

impl Maddpg {
    /// MADDPG from the shared parts and its own config.
    ///
    /// # Errors
    /// [`NnError::InvalidConfig`] / [`NnError::Sharing`] naming the first impossible setting.
    pub fn new(parts: LearnerParts, config: MaddpgConfig) -> Result<Self, NnError> {
        config.validate()?;
        Ok(Self { learner: Learner::new(parts, 1, 1)?, config })
    }

    /// The algorithm's config.
    #[must_use]
    pub fn config(&self) -> &MaddpgConfig {
        &self.config
    }

    /// One gradient step of every critic and actor; `None` while the replay is empty.
    ///
    /// # Errors
    /// Backend and shape errors.
    pub fn step(&mut self, rewards: &dyn RewardModel) -> Result<Option<StepLosses>, NnError> {
        let Some(b) = self.learner.sample(rewards)? else { return Ok(None) };
        let (critic, actor) = self.step_on(&b)?;
        Ok(Some(StepLosses { critic, actor: Some(actor) }))
    }

    fn step_on(&mut self, b: &BatchTensors) -> Result<(Vec<f32>, Vec<f32>), NnError> {
        let l = &mut self.learner;
        let next = target_actions(l, b)?;
        let critic = l.critic_step(b, next, None)?;
        let actor = actor_step(l, b, self.config.action_l2, self.config.teammates)?;
        l.steps += 1;
        Ok((critic, actor))
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
        self.step_on(&b)
    }

    /// Moves the target networks towards the online networks (eq. 9); the
    /// update cycle does this once per cycle.
    pub fn update_targets(&mut self) {
        self.learner.soft_update_targets(self.config.polyak, true);
    }

    /// Agent `agent`'s actor trunk, flattened (what information sharing mixes).
    ///
    /// # Errors
    /// [`NnError::UnknownAgent`].
    pub fn actor_trunk(&self, agent: usize) -> Result<Vec<f32>, NnError> {
        self.learner.actor_trunk(agent)
    }

    /// Replaces agent `agent`'s actor trunk.
    ///
    /// # Errors
    /// [`NnError::UnknownAgent`], [`NnError::Dimension`].
    pub fn set_actor_trunk(&mut self, agent: usize, trunk: &[f32]) -> Result<(), NnError> {
        self.learner.set_actor_trunk(agent, trunk)
    }

    /// All parameters of agent `agent`'s online actor and critic, flattened.
    ///
    /// # Errors
    /// [`NnError::UnknownAgent`], backend errors.
    pub fn params(&self, agent: usize) -> Result<(Vec<f32>, Vec<f32>), NnError> {
        self.learner.params(agent)
    }

    /// `Q_i(x, g, a)` of agent `agent`'s online critic for `n` rows of raw
    /// observations, goals and joint actions (in the environment's slot order).
    ///
    /// # Errors
    /// [`NnError::UnknownAgent`], [`NnError::Dimension`] / [`NnError::NotFinite`].
    pub fn q_values(
        &self,
        agent: usize,
        obs: &[f32],
        goals: &[f32],
        actions: &[f32],
        n: usize,
    ) -> Result<Vec<f32>, NnError> {
        self.learner.q_values(agent, obs, goals, actions, n)
    }

    /// Agent `agent`'s critic trunk, flattened.
    ///
    /// # Errors
    /// [`NnError::UnknownAgent`].
    pub fn critic_trunk(&self, agent: usize) -> Result<Vec<f32>, NnError> {
        self.learner.critic_trunk(agent)
    }

    /// Transitions stored in the replay buffer.
    #[must_use]
    pub fn replay_len(&self) -> usize {
        self.learner.replay.transitions()
    }
}

/// `tanh(mu'_j(o'_j))` of every agent's target actor, agent-major `[n, action_dim]`.
pub(crate) fn target_actions(l: &mut Learner, b: &BatchTensors) -> Result<Tensor<2>, NnError> {
    l.joint_of(|g, group| Ok(tanh(group.nets.actor_targets.forward(b.groups[g].x_next.clone()))))
}

/// The deterministic policy-gradient step of MADDPG and MATD3 (eq. 5 with
/// HER's action penalty), on each agent's first critic, a group's agents at once:
///
/// ```text
/// L_i = -mean Q_i1(x, g, a_1..mu_i(o_i)..a_N) + action_l2 * mean mu_i(o_i)^2
/// ```
pub(crate) fn actor_step(
    l: &mut Learner,
    b: &BatchTensors,
    action_l2: f64,
    teammates: Teammates,
) -> Result<Vec<f32>, NnError> {
    let current;
    let b = match teammates {
        Teammates::Replay => b,
        Teammates::Current => {
            current = l.with_current_actions(b, |head, _| tanh(head))?;
            &current
        }
    };
    l.actor_step(|g, group, critics| {
        let (joint, na) = (&group.joint, group.len());
        let mu = tanh(group.nets.actors.forward(Tensor::from_inner(b.groups[g].x_now.clone())))
            * Tensor::from_inner(joint.mask.clone());
        let q = critics.nets[0].forward(joint.with_own(mu.clone(), &b.og, &b.actions));
        let penalty = mu.square().sum_dim(2).mean_dim(1).reshape([na]) * Tensor::from_inner(joint.inv_dim.clone());
        Ok(q.mean_dim(1).reshape([na]).neg() + penalty.mul_scalar(action_l2 as f32))
    })
}

/// `tanh` of the heads, with exploration in [`ActMode::Explore`].
pub(crate) fn deterministic_act(
    l: &mut Learner,
    inputs: &[Vec<f32>],
    n: usize,
    mode: ActMode,
    noise: (f64, f64),
) -> Result<PolicyOutput, NnError> {
    let mut actions = l.heads(inputs, n)?;
    actions.iter_mut().flatten().for_each(|v| *v = v.tanh());
    if mode == ActMode::Explore {
        explore::perturb(&mut actions, n, noise.0 as f32, noise.1 as f32, &mut l.rng);
    }
    Ok(PolicyOutput::actions(actions))
}

/// Each agent's losses of one gradient step.
#[derive(Debug, Clone, PartialEq)]
pub struct StepLosses {
    /// Critic (TD) loss of each agent.
    pub critic: Vec<f32>,
    /// Actor loss of each agent, when the step updated the actors.
    pub actor: Option<Vec<f32>>,
}

/// Runs `batches` steps and averages their losses.
pub(crate) fn run_cycle(
    batches: usize,
    agents: usize,
    mut step: impl FnMut() -> Result<Option<StepLosses>, NnError>,
) -> Result<UpdateStats, NnError> {
    let mut stats = UpdateStats { updates: 0, critic_loss: vec![0.0; agents], actor_loss: vec![0.0; agents] };
    let mut actor_steps = 0usize;
    for _ in 0..batches {
        let Some(StepLosses { critic, actor }) = step()? else { break };
        stats.updates += 1;
        stats.critic_loss.iter_mut().zip(&critic).for_each(|(a, v)| *a += f64::from(*v));
        if let Some(actor) = actor {
            actor_steps += 1;
            stats.actor_loss.iter_mut().zip(&actor).for_each(|(a, v)| *a += f64::from(*v));
        }
    }
    let n = stats.updates.max(1) as f64;
    stats.critic_loss.iter_mut().for_each(|v| *v /= n);
    stats.actor_loss.iter_mut().for_each(|v| *v /= actor_steps.max(1) as f64);
    Ok(stats)
}

impl Policy for Maddpg {
    type Error = NnError;

    fn num_agents(&self) -> usize {
        self.learner.num_agents()
    }

    fn act(&mut self, inputs: &[Vec<f32>], n: usize, mode: ActMode) -> Result<PolicyOutput, NnError> {
        deterministic_act(&mut self.learner, inputs, n, mode, (self.config.noise_eps, self.config.random_eps))
    }
}

impl Algorithm for Maddpg {
    fn store(&mut self, episode: &Episode) -> Result<(), NnError> {
        self.learner.store(episode)
    }

    fn update(&mut self, rewards: &dyn RewardModel) -> Result<UpdateStats, NnError> {
        let batches = self.learner.replay_config.batches;
        let agents = self.learner.num_agents();
        let stats = run_cycle(batches, agents, || self.step(rewards))?;
        if stats.updates > 0 {
            self.learner.soft_update_targets(self.config.polyak, true);
        }
        Ok(stats)
    }

    fn save_state(&self, include_storage: bool) -> Result<Vec<u8>, NnError> {
        self.learner.save("maddpg", include_storage, Vec::new())
    }

    fn load_state(&mut self, bytes: &[u8]) -> Result<(), NnError> {
        self.learner.load("maddpg", bytes).map(|_| ())
    }

    fn storage_capacity(&self) -> usize {
        self.learner.storage_capacity()
    }

    fn restore_storage(&mut self, total: u64, episodes: &[Episode]) -> Result<(), NnError> {
        self.learner.restore_storage(total, episodes)
    }
}

impl PolicyState for Maddpg {
    fn save_policy(&self) -> Result<Vec<u8>, NnError> {
        self.learner.save_policy("maddpg")
    }

    fn load_policy(&mut self, bytes: &[u8]) -> Result<(), NnError> {
        self.learner.load_policy("maddpg", bytes)
    }
}
