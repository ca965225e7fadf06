//! Finger-specific reward assignment (eqs. 13-15) and each agent's reward `r_i`
//! (eq. 7; docs/design.md 3.5).

use serde::{Deserialize, Serialize};

use super::utility::{LogUtility, ShadowReward};
use crate::error::CoreError;
use crate::spec::EnvSpec;

/// The reward one agent learns from: the task reward with a weight and a set of
/// shadow-reward features.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AgentReward {
    /// The agent's name, as in [`EnvSpec::agents`].
    pub agent: String,
    /// Weight of the shared task reward (default 1).
    #[serde(default = "one")]
    pub task_weight: f64,
    /// Names of the features whose shadow rewards this agent receives.
    #[serde(default)]
    pub shadow: Vec<String>,
}

fn one() -> f64 {
    1.0
}

/// Finger-specific reward assignment as data (paper eqs. 13-15, docs/design.md 3.5).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RewardAssignment {
    /// One entry per agent.
    pub agents: Vec<AgentReward>,
}

impl RewardAssignment {
    /// The paper's assignment for the Shadow Hand: wrist {task, safe_region,
    /// contacts} (eq. 13); thumb and little {task, safe_region} (eq. 14); index,
    /// middle and ring {task, contacts} (eq. 15).
    ///
    /// ```
    /// use fmsr_core::shadow::RewardAssignment;
    /// let a = RewardAssignment::paper();
    /// assert_eq!(a.agents[0].shadow, vec!["safe_region", "contacts"]);
    /// ```
    #[must_use]
    pub fn paper() -> Self {
        let entry = |agent: &str, shadow: &[&str]| AgentReward {
            agent: agent.into(),
            task_weight: 1.0,
            shadow: shadow.iter().map(|s| (*s).to_owned()).collect(),
        };
        Self {
            agents: vec![
                entry("wrist", &["safe_region", "contacts"]),
                entry("index", &["contacts"]),
                entry("middle", &["contacts"]),
                entry("ring", &["contacts"]),
                entry("little", &["safe_region"]),
                entry("thumb", &["safe_region"]),
            ],
        }
    }

    /// Every agent of `spec` learns from the task reward alone (the Dense and
    /// Sparse configurations).
    #[must_use]
    pub fn task_only(spec: &EnvSpec) -> Self {
        Self {
            agents: spec
                .agents
                .iter()
                .map(|a| AgentReward { agent: a.name.clone(), task_weight: 1.0, shadow: Vec::new() })
                .collect(),
        }
    }

    /// Every agent of `spec` receives the shadow rewards of all of its features.
    #[must_use]
    pub fn all_features(spec: &EnvSpec) -> Self {
        Self {
            agents: spec
                .agents
                .iter()
                .map(|a| AgentReward { agent: a.name.clone(), task_weight: 1.0, shadow: spec.features.clone() })
                .collect(),
        }
    }

    /// Resolves names against `spec`: each agent must appear exactly once and
    /// every feature must exist.
    pub fn resolve(&self, spec: &EnvSpec) -> Result<ResolvedAssignment, CoreError> {
        for entry in &self.agents {
            spec.agent_index(&entry.agent)?;
            if !entry.task_weight.is_finite() {
                return Err(CoreError::InvalidConfig {
                    key: format!("assignment.{}.task_weight", entry.agent),
                    reason: "must be finite".into(),
                });
            }
        }
        let mut task_weights = Vec::with_capacity(spec.agents.len());
        let mut features = Vec::with_capacity(spec.agents.len());
        for agent in &spec.agents {
            let entries: Vec<_> = self.agents.iter().filter(|e| e.agent == agent.name).collect();
            if entries.len() != 1 {
                return Err(CoreError::AgentCount {
                    name: agent.name.clone(),
                    count: entries.len(),
                    what: "the reward assignment",
                });
            }
            task_weights.push(entries[0].task_weight);
            let mut ks = entries[0].shadow.iter().map(|f| spec.feature_index(f)).collect::<Result<Vec<_>, _>>()?;
            ks.sort_unstable();
            ks.dedup();
            features.push(ks);
        }
        Ok(ResolvedAssignment { task_weights, features })
    }
}

/// A [`RewardAssignment`] resolved to indices, in the environment's agent order.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ResolvedAssignment {
    /// Task-reward weight of each agent.
    pub task_weights: Vec<f64>,
    /// Feature indices of each agent.
    pub features: Vec<Vec<usize>>,
}

/// Computes each agent's reward `r_i = w_i * r_task + alpha * sum_{k in S_i} z_k(phi_k, lambda_k)` (eq. 7).
///
/// ```
/// use fmsr_core::shadow::{AgentRewards, LogUtility, ResolvedAssignment};
/// let assignment = ResolvedAssignment { task_weights: vec![1.0, 1.0], features: vec![vec![0], vec![]] };
/// let rewards = AgentRewards::new(assignment, LogUtility::default(), 0.5).unwrap();
/// let mut out = [0.0f32; 2];
/// // task reward -1, feature on, occupancy 0.4: agent 0 gets -1 + 0.5 * 1 / 0.5 = 0
/// rewards.compute(-1.0, &[1.0], &[0.4], &mut out);
/// assert!((out[0] - 0.0).abs() < 1e-6);
/// assert_eq!(out[1], -1.0);
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AgentRewards<S = LogUtility> {
    assignment: ResolvedAssignment,
    shadow: S,
    alpha: f64,
}

impl<S: ShadowReward> AgentRewards<S> {
    /// Builds the reward computation; `alpha` is the shadow-reward weight (eq. 2), finite and nonnegative.
    pub fn new(assignment: ResolvedAssignment, shadow: S, alpha: f64) -> Result<Self, CoreError> {
        if !(alpha.is_finite() && alpha >= 0.0) {
            return Err(CoreError::InvalidConfig {
                key: "shadow.alpha".into(),
                reason: format!("{alpha} must be finite and nonnegative"),
            });
        }
        Ok(Self { assignment, shadow, alpha })
    }

    /// Number of agents.
    #[must_use]
    pub fn num_agents(&self) -> usize {
        self.assignment.task_weights.len()
    }

    /// The resolved assignment.
    #[must_use]
    pub fn assignment(&self) -> &ResolvedAssignment {
        &self.assignment
    }

    /// Writes each agent's reward for a step with task reward `task`, features
    /// `phi` and occupancy estimate `lambda` into `out` (one value per agent).
    pub fn compute(&self, task: f32, phi: &[f32], lambda: &[f64], out: &mut [f32]) {
        for (o, (task_part, shadow_part)) in out.iter_mut().zip(self.parts(task, phi, lambda)) {
            *o = (task_part + shadow_part) as f32;
        }
    }

    /// Each agent's reward for a step split into its task part `w_i r` and its
    /// shadow part `alpha sum_{k in S_i} z_k` (eq. 7); [`AgentRewards::compute`] adds them.
    pub fn parts<'a>(&'a self, task: f32, phi: &'a [f32], lambda: &'a [f64]) -> impl Iterator<Item = (f64, f64)> + 'a {
        self.assignment.task_weights.iter().zip(&self.assignment.features).map(move |(w, ks)| {
            let shadow: f64 = ks.iter().map(|&k| self.shadow.step_reward(f64::from(phi[k]), lambda[k])).sum();
            (w * f64::from(task), self.alpha * shadow)
        })
    }

    /// Bounds `(lo, hi)` of each agent's per-step reward, given the task reward's range.
    #[must_use]
    pub fn step_bounds(&self, task_range: (f32, f32)) -> Vec<(f64, f64)> {
        let (zlo, zhi) = self.shadow.step_reward_range();
        self.assignment
            .task_weights
            .iter()
            .zip(&self.assignment.features)
            .map(|(&w, ks)| {
                let (a, b) = (w * f64::from(task_range.0), w * f64::from(task_range.1));
                let n = ks.len() as f64;
                (a.min(b) + self.alpha * n * zlo.min(0.0), a.max(b) + self.alpha * n * zhi.max(0.0))
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spec::AgentSpec;

    fn hand_spec() -> EnvSpec {
        let names = ["wrist", "index", "middle", "ring", "little", "thumb"];
        let dims = [2, 3, 3, 3, 4, 5];
        let mut next = 0;
        let agents = names
            .iter()
            .zip(dims)
            .map(|(n, d)| {
                let slots = (next..next + d).collect();
                next += d;
                AgentSpec { name: (*n).into(), action_slots: slots, local_obs_dim: 1 }
            })
            .collect();
        EnvSpec {
            agents,
            action_dim: 20,
            obs_dim: 153,
            goal_dim: 7,
            episode_len: 100,
            features: vec!["safe_region".into(), "contacts".into()],
            reward_range: (-std::f32::consts::PI, 0.0),
        }
    }

    #[test]
    fn paper_assignment_resolves_on_the_hand() {
        let spec = hand_spec();
        let r = RewardAssignment::paper().resolve(&spec).unwrap();
        assert_eq!(r.features, vec![vec![0, 1], vec![1], vec![1], vec![1], vec![0], vec![0]]);
        let rewards = AgentRewards::new(r, LogUtility::default(), 1.0).unwrap();
        let mut out = [0.0f32; 6];
        // task -0.5, safe_region on, contacts off, lambda = (0.4, 0.9)
        rewards.compute(-0.5, &[1.0, 0.0], &[0.4, 0.9], &mut out);
        let safe = (1.0 / 0.5) as f32 - 0.5;
        assert_eq!(out, [safe, -0.5, -0.5, -0.5, safe, safe]);
        let bounds = rewards.step_bounds(spec.reward_range);
        assert!((bounds[0].1 - 20.0).abs() < 1e-9);
        assert!((bounds[1].0 + std::f64::consts::PI).abs() < 1e-6);
    }

    #[test]
    fn assignment_errors_name_the_problem() {
        let spec = hand_spec();
        let mut a = RewardAssignment::paper();
        a.agents[1].shadow.push("grip".into());
        assert!(matches!(a.resolve(&spec), Err(CoreError::UnknownFeature { name, .. }) if name == "grip"));
        let mut a = RewardAssignment::paper();
        a.agents.pop();
        assert!(matches!(a.resolve(&spec), Err(CoreError::AgentCount { name, count: 0, .. }) if name == "thumb"));
        let mut a = RewardAssignment::paper();
        a.agents[0].agent = "pinky".into();
        assert!(matches!(a.resolve(&spec), Err(CoreError::UnknownAgent { name, .. }) if name == "pinky"));
        assert!(
            AgentRewards::new(RewardAssignment::task_only(&spec).resolve(&spec).unwrap(), LogUtility::default(), -1.0)
                .is_err()
        );
    }

    #[test]
    fn task_only_ignores_features() {
        let spec = hand_spec();
        let rewards =
            AgentRewards::new(RewardAssignment::task_only(&spec).resolve(&spec).unwrap(), LogUtility::default(), 1.0)
                .unwrap();
        let mut out = [0.0f32; 6];
        rewards.compute(-1.0, &[1.0, 1.0], &[0.0, 0.0], &mut out);
        assert_eq!(out, [-1.0; 6]);
    }
}
