//! What every learner shares: what an actor observes ([`ActorView`]) and how
//! its inputs are laid out ([`ObservationLayout`]), the batch of joint
//! transitions every agent learns from ([`Batch`]), and the communicator
//! between worker processes ([`Communicator`], [`SingleProcess`]).
//! Information sharing has its own module, [`crate::sharing`].

use serde::{Deserialize, Serialize};

use crate::error::CoreError;
use crate::spec::{EnvSpec, JointAction, Observation};

/// What an actor observes of the environment.
///
/// MAGCLA (the paper's design, the default) gives each actor its own part of
/// the state; `Global` gives every actor the critics' global observation, an
/// ablation that is no longer MAGCLA: it tells how much the
/// six-agent method loses by its actors' local view.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum ActorView {
    /// The agent's local observation (own joints and touch sensors, the object).
    #[default]
    Local,
    /// The global observation, as the critics see it.
    Global,
}

/// How an actor's input is assembled (docs/design.md 3.2): its observation
/// ([`ActorView`]: local by default), the goal, and its graph neighbours'
/// previous actions, in that order.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ObservationLayout {
    spec: EnvSpec,
    neighbours: Vec<Vec<usize>>,
    #[serde(default)]
    view: ActorView,
}

impl ObservationLayout {
    /// A layout for `spec` where agent `i` observes the previous actions of
    /// `neighbours[i]`.
    ///
    /// ```
    /// use fmsr_core::agent::ObservationLayout;
    /// use fmsr_core::spec::{AgentSpec, EnvSpec, JointAction, Observation};
    /// let agent = |n: &str, s: Vec<usize>, d| AgentSpec { name: n.into(), action_slots: s, local_obs_dim: d };
    /// let spec = EnvSpec { agents: vec![agent("a", vec![0], 1), agent("b", vec![1, 2], 2)],
    ///     action_dim: 3, obs_dim: 3, goal_dim: 1, episode_len: 5, features: vec![], reward_range: (-1.0, 0.0) };
    /// let layout = ObservationLayout::new(spec, vec![vec![1], vec![0]]).unwrap();
    /// assert_eq!(layout.actor_input_dim(0), 1 + 1 + 2);
    /// let mut input = Vec::new();
    /// layout.push_actor_input(0, &[7.0], &[1.0, 2.0, 3.0], &[9.0], &[0.1, 0.2, 0.3], &mut input);
    /// assert_eq!(input, vec![7.0, 9.0, 0.2, 0.3]);
    /// ```
    pub fn new(spec: EnvSpec, neighbours: Vec<Vec<usize>>) -> Result<Self, CoreError> {
        spec.validate()?;
        if neighbours.len() != spec.agents.len() {
            return Err(CoreError::Dimension {
                what: "observation graph nodes",
                expected: spec.agents.len(),
                found: neighbours.len(),
            });
        }
        for (i, ns) in neighbours.iter().enumerate() {
            if let Some(&j) = ns.iter().find(|&&j| j >= spec.agents.len() || j == i) {
                return Err(CoreError::InvalidConfig {
                    key: "observation_graph".into(),
                    reason: format!("agent {i} lists {j} as a neighbour"),
                });
            }
        }
        Ok(Self { spec, neighbours, view: ActorView::Local })
    }

    /// The same layout with actors observing `view`.
    ///
    /// ```
    /// use fmsr_core::agent::{ActorView, ObservationLayout};
    /// use fmsr_core::spec::{AgentSpec, EnvSpec};
    /// let agent = |n: &str, s: Vec<usize>, d| AgentSpec { name: n.into(), action_slots: s, local_obs_dim: d };
    /// let spec = EnvSpec { agents: vec![agent("a", vec![0], 1), agent("b", vec![1, 2], 2)],
    ///     action_dim: 3, obs_dim: 3, goal_dim: 1, episode_len: 5, features: vec![], reward_range: (-1.0, 0.0) };
    /// let layout = ObservationLayout::new(spec, vec![vec![1], vec![0]]).unwrap().with_view(ActorView::Global);
    /// assert_eq!(layout.actor_input_dim(0), 3 + 1 + 2);
    /// let mut input = Vec::new();
    /// layout.push_actor_input(0, &[7.0], &[1.0, 2.0, 3.0], &[9.0], &[0.1, 0.2, 0.3], &mut input);
    /// assert_eq!(input, vec![1.0, 2.0, 3.0, 9.0, 0.2, 0.3]);
    /// ```
    #[must_use]
    pub fn with_view(mut self, view: ActorView) -> Self {
        self.view = view;
        self
    }

    /// A layout whose neighbours are those of `graph` (node `i` = agent `i`).
    pub fn from_graph(spec: EnvSpec, graph: &fmsr_graph::Graph) -> Result<Self, CoreError> {
        if graph.nodes() != spec.agents.len() {
            return Err(CoreError::Dimension {
                what: "observation graph nodes",
                expected: spec.agents.len(),
                found: graph.nodes(),
            });
        }
        let neighbours =
            (0..graph.nodes()).map(|i| graph.neighbors(i).map(<[usize]>::to_vec)).collect::<Result<Vec<_>, _>>()?;
        Self::new(spec, neighbours)
    }

    /// The environment's spec.
    #[must_use]
    pub fn spec(&self) -> &EnvSpec {
        &self.spec
    }

    /// The neighbours whose actions agent `agent` observes.
    #[must_use]
    pub fn neighbours(&self, agent: usize) -> &[usize] {
        &self.neighbours[agent]
    }

    /// Length of agent `agent`'s actor input.
    #[must_use]
    pub fn actor_input_dim(&self, agent: usize) -> usize {
        let observed = match self.view {
            ActorView::Local => self.spec.agents[agent].local_obs_dim,
            ActorView::Global => self.spec.obs_dim,
        };
        observed
            + self.spec.goal_dim
            + self.neighbours[agent].iter().map(|&j| self.spec.agents[j].action_dim()).sum::<usize>()
    }

    /// Length of every critic's input: global observation, goal and joint action.
    #[must_use]
    pub fn critic_input_dim(&self) -> usize {
        self.spec.obs_dim + self.spec.goal_dim + self.spec.action_dim
    }

    /// Appends agent `agent`'s actor input to `out`: its observation (`local`,
    /// its own part of the step's observation, or `global`, the whole of it,
    /// by the layout's [`ActorView`]), `goal`, then the neighbours' slots of
    /// `prev_action` (the joint action of the previous step).
    pub fn push_actor_input(
        &self,
        agent: usize,
        local: &[f32],
        global: &[f32],
        goal: &[f32],
        prev_action: &[f32],
        out: &mut Vec<f32>,
    ) {
        out.extend_from_slice(match self.view {
            ActorView::Local => local,
            ActorView::Global => global,
        });
        out.extend_from_slice(goal);
        for &j in &self.neighbours[agent] {
            out.extend(self.spec.agents[j].action_slots.iter().map(|&s| prev_action[s]));
        }
    }

    /// The actor inputs of all agents for one observation (one row each).
    #[must_use]
    pub fn actor_inputs(&self, obs: &Observation, prev_action: &JointAction) -> Vec<Vec<f32>> {
        (0..self.spec.agents.len())
            .map(|i| {
                let mut v = Vec::with_capacity(self.actor_input_dim(i));
                self.push_actor_input(i, &obs.locals[i], &obs.global, &obs.desired_goal, &prev_action.0, &mut v);
                v
            })
            .collect()
    }
}

/// A batch of joint transitions with hindsight-relabelled goals, shared by all
/// agents' updates (docs/design.md 3.8). Matrices are row major, one row per sample.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct Batch {
    /// Number of samples.
    pub size: usize,
    /// Global observations `x_t`, `size x obs_dim`.
    pub obs: Vec<f32>,
    /// Global observations `x_{t+1}`.
    pub next_obs: Vec<f32>,
    /// (Relabelled) goals, `size x goal_dim`.
    pub goals: Vec<f32>,
    /// Joint actions `a_t`, `size x action_dim`.
    pub actions: Vec<f32>,
    /// Actor inputs at `t`, per agent `size x actor_input_dim(i)`.
    pub actor_inputs: Vec<Vec<f32>>,
    /// Actor inputs at `t + 1`, per agent.
    pub next_actor_inputs: Vec<Vec<f32>>,
    /// The task reward of each sample for its (relabelled) goal.
    pub task_rewards: Vec<f32>,
    /// The features `phi(s_t, a_t)`, `size x K`.
    pub features: Vec<f32>,
    /// Each agent's reward (task and shadow, eq. 7), per agent `size`.
    pub rewards: Vec<Vec<f32>>,
}

/// The collective operations between worker processes that training uses
/// (the paper trains with 4 MPI workers; HER baselines with up to 19): every
/// worker calls each operation in the same order. The single-process
/// implementation [`SingleProcess`] is the identity, so running on several
/// processes changes no algorithm code; the `fmsr` crate's feature `mpi` has
/// one over MPI.
pub trait Communicator: Send + Sync + std::fmt::Debug {
    /// Number of workers.
    fn workers(&self) -> usize;

    /// This worker's index, `0 .. workers()`; worker 0 writes the run's files.
    fn rank(&self) -> usize;

    /// Replaces `values` by their mean over all workers.
    fn all_reduce_mean(&self, values: &mut [f32]);

    /// Every worker's `local`, concatenated in rank order; every worker passes
    /// the same number of values.
    fn all_gather(&self, local: &[f32]) -> Vec<f32>;

    /// Worker 0 gets every worker's bytes in rank order (its own first); the
    /// others get `None`. Lengths may differ.
    fn gather_bytes(&self, local: Vec<u8>) -> Option<Vec<Vec<u8>>>;
}

/// A shared communicator (the trainer and the algorithm hold the same one).
impl<C: Communicator + ?Sized> Communicator for std::sync::Arc<C> {
    fn workers(&self) -> usize {
        (**self).workers()
    }

    fn rank(&self) -> usize {
        (**self).rank()
    }

    fn all_reduce_mean(&self, values: &mut [f32]) {
        (**self).all_reduce_mean(values);
    }

    fn all_gather(&self, local: &[f32]) -> Vec<f32> {
        (**self).all_gather(local)
    }

    fn gather_bytes(&self, local: Vec<u8>) -> Option<Vec<Vec<u8>>> {
        (**self).gather_bytes(local)
    }
}

/// The single-process [`Communicator`]: one worker, every operation the identity.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct SingleProcess;

impl Communicator for SingleProcess {
    fn workers(&self) -> usize {
        1
    }

    fn rank(&self) -> usize {
        0
    }

    fn all_reduce_mean(&self, _values: &mut [f32]) {}

    fn all_gather(&self, local: &[f32]) -> Vec<f32> {
        local.to_vec()
    }

    fn gather_bytes(&self, local: Vec<u8>) -> Option<Vec<Vec<u8>>> {
        Some(vec![local])
    }
}
