//! The data types shared by environments and learners: agent and environment
//! specifications, joint actions, observations and step outcomes.

use serde::{Deserialize, Serialize};

use crate::error::{CoreError, check_vector};

/// One agent of a multi-agent environment (one finger, or the wrist).
///
/// The agent owns `action_slots` of the joint action (docs/design.md 3.1: the
/// partition is data, not code) and receives a local observation of
/// `local_obs_dim` values (its own joints and touch sensors and the object).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AgentSpec {
    /// Name of the agent, e.g. `"thumb"`.
    pub name: String,
    /// Indices into the joint action owned by this agent, in order.
    pub action_slots: Vec<usize>,
    /// Length of the agent's local observation.
    pub local_obs_dim: usize,
}

impl AgentSpec {
    /// Number of action components this agent controls.
    ///
    /// ```
    /// use fmsr_core::spec::AgentSpec;
    /// let thumb = AgentSpec { name: "thumb".into(), action_slots: vec![15, 16, 17, 18, 19], local_obs_dim: 30 };
    /// assert_eq!(thumb.action_dim(), 5);
    /// ```
    #[must_use]
    pub fn action_dim(&self) -> usize {
        self.action_slots.len()
    }
}

/// The task reward of a goal-conditioned environment (docs/design.md 3.6).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum RewardType {
    /// `-d(achieved, desired)`: the negative goal distance (paper eq. 10).
    #[default]
    Dense,
    /// `0` on success, `-1` otherwise (the Gym convention).
    Sparse,
}

impl RewardType {
    /// The task reward for a goal distance `distance` and success threshold `threshold`.
    ///
    /// ```
    /// use fmsr_core::spec::RewardType;
    /// assert_eq!(RewardType::Dense.reward(0.5, 0.1), -0.5);
    /// assert_eq!(RewardType::Sparse.reward(0.5, 0.1), -1.0);
    /// assert_eq!(RewardType::Sparse.reward(0.05, 0.1), 0.0);
    /// ```
    #[must_use]
    pub fn reward(self, distance: f32, threshold: f32) -> f32 {
        match self {
            RewardType::Dense => -distance,
            RewardType::Sparse => {
                if distance < threshold {
                    0.0
                } else {
                    -1.0
                }
            }
        }
    }
}

/// Everything a learner needs to know about an environment.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EnvSpec {
    /// The agents, in a fixed order (the node order of the consensus graph).
    pub agents: Vec<AgentSpec>,
    /// Length of the joint action; every slot is owned by exactly one agent.
    pub action_dim: usize,
    /// Length of the global observation (what the critics see).
    pub obs_dim: usize,
    /// Length of achieved and desired goals.
    pub goal_dim: usize,
    /// Steps per episode, `T`.
    pub episode_len: usize,
    /// Names of the stability features `phi_k(s, a)` in `[0, 1]`, in the order of
    /// [`StepInfo::features`].
    pub features: Vec<String>,
    /// Smallest and largest task reward of one step (used to bound Q targets).
    pub reward_range: (f32, f32),
}

impl EnvSpec {
    /// Checks the spec: the agents partition the joint action exactly once, and
    /// names are unique.
    ///
    /// ```
    /// use fmsr_core::spec::{AgentSpec, EnvSpec};
    /// let agent = |name: &str, slots: Vec<usize>| AgentSpec { name: name.into(), action_slots: slots, local_obs_dim: 2 };
    /// let mut spec = EnvSpec {
    ///     agents: vec![agent("a", vec![0]), agent("b", vec![1, 2])],
    ///     action_dim: 3, obs_dim: 4, goal_dim: 2, episode_len: 10,
    ///     features: vec!["safe_region".into()], reward_range: (-1.0, 0.0),
    /// };
    /// assert!(spec.validate().is_ok());
    /// spec.agents[1].action_slots = vec![0, 2];
    /// assert!(spec.validate().is_err());
    /// ```
    pub fn validate(&self) -> Result<(), CoreError> {
        validate_partition(&self.agents, self.action_dim)?;
        for agent in &self.agents {
            let count = self.agents.iter().filter(|a| a.name == agent.name).count();
            if count != 1 {
                return Err(CoreError::AgentCount {
                    name: agent.name.clone(),
                    count,
                    what: "the environment's agents",
                });
            }
        }
        if self.episode_len == 0 {
            return Err(CoreError::InvalidConfig { key: "episode_len".into(), reason: "must be at least 1".into() });
        }
        Ok(())
    }

    /// Number of agents.
    #[must_use]
    pub fn num_agents(&self) -> usize {
        self.agents.len()
    }

    /// Index of the agent called `name`.
    pub fn agent_index(&self, name: &str) -> Result<usize, CoreError> {
        self.agents.iter().position(|a| a.name == name).ok_or_else(|| CoreError::UnknownAgent {
            name: name.to_owned(),
            known: self.agents.iter().map(|a| a.name.as_str()).collect::<Vec<_>>().join(", "),
        })
    }

    /// Index of the feature called `name`.
    pub fn feature_index(&self, name: &str) -> Result<usize, CoreError> {
        self.features
            .iter()
            .position(|f| f == name)
            .ok_or_else(|| CoreError::UnknownFeature { name: name.to_owned(), known: self.features.join(", ") })
    }
}

/// Checks that `agents` own each of the `action_dim` slots of the joint action exactly once.
pub fn validate_partition(agents: &[AgentSpec], action_dim: usize) -> Result<(), CoreError> {
    let mut owners = vec![0usize; action_dim];
    for agent in agents {
        for &slot in &agent.action_slots {
            if slot >= action_dim {
                return Err(CoreError::ActionPartition { slot, owners: 0, action_dim });
            }
            owners[slot] += 1;
        }
    }
    match owners.iter().position(|&n| n != 1) {
        Some(slot) => Err(CoreError::ActionPartition { slot, owners: owners[slot], action_dim }),
        None => Ok(()),
    }
}

/// The actions of all agents, as one vector in the environment's actuator order.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct JointAction(pub Vec<f32>);

impl JointAction {
    /// All-zero joint action of length `dim` (the mid-range of every actuator).
    #[must_use]
    pub fn zeros(dim: usize) -> Self {
        JointAction(vec![0.0; dim])
    }

    /// Assembles a joint action from per-agent actions, placing each agent's
    /// values into the slots it owns.
    ///
    /// ```
    /// use fmsr_core::spec::{AgentSpec, JointAction};
    /// let agents = vec![
    ///     AgentSpec { name: "a".into(), action_slots: vec![2], local_obs_dim: 1 },
    ///     AgentSpec { name: "b".into(), action_slots: vec![0, 1], local_obs_dim: 1 },
    /// ];
    /// let joint = JointAction::from_agents(&agents, &[vec![0.5], vec![-1.0, 1.0]]).unwrap();
    /// assert_eq!(joint.0, vec![-1.0, 1.0, 0.5]);
    /// assert_eq!(joint.agent(&agents[1]), vec![-1.0, 1.0]);
    /// ```
    pub fn from_agents(agents: &[AgentSpec], actions: &[Vec<f32>]) -> Result<Self, CoreError> {
        if actions.len() != agents.len() {
            return Err(CoreError::Dimension {
                what: "per-agent actions",
                expected: agents.len(),
                found: actions.len(),
            });
        }
        let dim = agents.iter().map(AgentSpec::action_dim).sum();
        let mut joint = vec![0.0; dim];
        for (agent, action) in agents.iter().zip(actions) {
            check_vector("agent action", action, agent.action_dim())?;
            for (&slot, &value) in agent.action_slots.iter().zip(action) {
                if slot >= dim {
                    return Err(CoreError::ActionPartition { slot, owners: 0, action_dim: dim });
                }
                joint[slot] = value;
            }
        }
        Ok(JointAction(joint))
    }

    /// The values of the slots owned by `agent`.
    #[must_use]
    pub fn agent(&self, agent: &AgentSpec) -> Vec<f32> {
        agent.action_slots.iter().map(|&s| self.0[s]).collect()
    }

    /// Checks the length against `spec` and that every value is finite.
    pub fn validate(&self, spec: &EnvSpec) -> Result<(), CoreError> {
        check_vector("joint action", &self.0, spec.action_dim)
    }

    /// The values as a slice.
    #[must_use]
    pub fn as_slice(&self) -> &[f32] {
        &self.0
    }
}

/// What the environment shows after a reset or a step.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Observation {
    /// The global observation (critics' view), `EnvSpec::obs_dim` values.
    pub global: Vec<f32>,
    /// One local observation per agent (actors' view, without goal and
    /// neighbours' actions, which the learner appends).
    pub locals: Vec<Vec<f32>>,
    /// The goal the object currently achieves.
    pub achieved_goal: Vec<f32>,
    /// The goal of the episode.
    pub desired_goal: Vec<f32>,
}

impl Observation {
    /// Checks every part against `spec`.
    pub fn validate(&self, spec: &EnvSpec) -> Result<(), CoreError> {
        check_vector("global observation", &self.global, spec.obs_dim)?;
        if self.locals.len() != spec.agents.len() {
            return Err(CoreError::Dimension {
                what: "local observations",
                expected: spec.agents.len(),
                found: self.locals.len(),
            });
        }
        for (local, agent) in self.locals.iter().zip(&spec.agents) {
            check_vector("local observation", local, agent.local_obs_dim)?;
        }
        check_vector("achieved goal", &self.achieved_goal, spec.goal_dim)?;
        check_vector("desired goal", &self.desired_goal, spec.goal_dim)
    }
}

/// Extra facts about one step.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct StepInfo {
    /// Whether the goal is reached at the environment's success threshold.
    pub is_success: bool,
    /// The stability features `phi_k(s_t, a_t)` in `[0, 1]`, in the order of
    /// [`EnvSpec::features`].
    pub features: Vec<f32>,
    /// Whether the object has left the hand (a `drop` failure, docs/design.md 3.9).
    pub dropped: bool,
}

/// The result of [`crate::Env::step`] (Gymnasium/PettingZoo parallel semantics).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StepOutcome {
    /// The observation after the step.
    pub observation: Observation,
    /// The task reward of the step (shared by all agents).
    pub reward: f32,
    /// The episode ended in a terminal state.
    pub terminated: bool,
    /// The episode was cut by the time limit.
    pub truncated: bool,
    /// Success, features and failure flags.
    pub info: StepInfo,
}
