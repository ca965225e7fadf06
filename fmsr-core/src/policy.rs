//! The policy seam: one object acts for all agents from their local inputs.
//!
//! A policy is the acting half of an [`crate::Algorithm`]. The collector hands
//! it a batch of actor inputs (one matrix per agent, laid out by
//! [`crate::agent::ObservationLayout`]) and a mode; the policy returns every
//! agent's action and whatever its algorithm needs later (log-probabilities of
//! a stochastic policy, value estimates of an on-policy learner).
//! Exploration belongs to the policy: in [`ActMode::Explore`] a DDPG policy adds
//! Gaussian noise and random actions, a SAC policy samples from its
//! distribution; in [`ActMode::Evaluate`] both act deterministically.

use serde::{Deserialize, Serialize};

/// How a policy acts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum ActMode {
    /// Training rollouts: the algorithm's own exploration.
    Explore,
    /// Evaluation: the deterministic (or mean) action.
    #[default]
    Evaluate,
}

/// What a policy returns for `n` rows of inputs.
///
/// `actions[i]` holds `n` rows of agent `i`'s action (row major, each value in
/// `[-1, 1]`). `log_probs` and `values` are empty unless the algorithm records
/// them; when present they hold one value per row for every agent.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct PolicyOutput {
    /// Each agent's actions, `n x action_dim(i)`.
    pub actions: Vec<Vec<f32>>,
    /// Each agent's `log pi_i(a_i | o_i)`, `n` values, or empty.
    pub log_probs: Vec<Vec<f32>>,
    /// Each agent's value estimate, `n` values, or empty.
    pub values: Vec<Vec<f32>>,
}

impl PolicyOutput {
    /// An output that carries actions only.
    ///
    /// ```
    /// use fmsr_core::policy::PolicyOutput;
    /// let out = PolicyOutput::actions(vec![vec![0.5], vec![-0.5, 0.0]]);
    /// assert!(out.log_probs.is_empty() && out.values.is_empty());
    /// ```
    #[must_use]
    pub fn actions(actions: Vec<Vec<f32>>) -> Self {
        Self { actions, log_probs: Vec::new(), values: Vec::new() }
    }
}

/// Acts for all agents of an environment (PettingZoo's parallel API: every
/// agent acts at every step).
pub trait Policy {
    /// The error of this policy.
    type Error: std::error::Error + Send + Sync + 'static;

    /// Number of agents.
    fn num_agents(&self) -> usize;

    /// Actions of every agent for `n` rows of actor inputs: `inputs[i]` holds
    /// `n` rows of agent `i`'s actor input, row major.
    fn act(&mut self, inputs: &[Vec<f32>], n: usize, mode: ActMode) -> Result<PolicyOutput, Self::Error>;
}

/// A policy whose acting half can be saved and restored on its own, without
/// what only learning needs (critics, targets, optimisers, replay): what a
/// trained policy file (`fmsr export`) carries.
///
/// A separate ability, not part of [`crate::Algorithm`], so an algorithm of
/// your own need not offer it.
pub trait PolicyState: Policy {
    /// The acting state (for the learners of `fmsr-nn`: every agent's actor
    /// and its input normaliser) as bytes.
    fn save_policy(&self) -> Result<Vec<u8>, Self::Error>;

    /// Restores a state written by [`PolicyState::save_policy`]; after it the
    /// policy acts as the saved one did in [`ActMode::Evaluate`]. A state of
    /// another shape or algorithm, or corrupted bytes, is an error and changes
    /// nothing.
    fn load_policy(&mut self, bytes: &[u8]) -> Result<(), Self::Error>;
}
