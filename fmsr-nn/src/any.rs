//! One of the learners, chosen at run time (the `algorithm` key of an experiment).

use fmsr_core::algorithm::{Algorithm, RewardModel, UpdateStats};
use fmsr_core::policy::{ActMode, Policy, PolicyOutput, PolicyState};
use fmsr_core::replay::Episode;
use serde::{Deserialize, Serialize};

use crate::error::NnError;
use crate::{Maddpg, Masac, Matd3};

/// The algorithms of this crate, by name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum AlgorithmKind {
    /// [`Maddpg`] (default).
    #[default]
    Maddpg,
    /// [`Matd3`].
    Matd3,
    /// [`Masac`].
    Masac,
}

impl AlgorithmKind {
    /// All three.
    pub const ALL: [AlgorithmKind; 3] = [AlgorithmKind::Maddpg, AlgorithmKind::Matd3, AlgorithmKind::Masac];

    /// The config key of the algorithm's own section, e.g. `"matd3"`.
    ///
    /// ```
    /// use fmsr_nn::AlgorithmKind;
    /// assert_eq!(AlgorithmKind::Masac.key(), "masac");
    /// ```
    #[must_use]
    pub fn key(self) -> &'static str {
        match self {
            AlgorithmKind::Maddpg => "maddpg",
            AlgorithmKind::Matd3 => "matd3",
            AlgorithmKind::Masac => "masac",
        }
    }
}

/// One of [`Maddpg`], [`Matd3`], [`Masac`], behind the same traits.
#[derive(Debug)]
pub enum AnyLearner {
    /// MADDPG.
    Maddpg(Maddpg),
    /// MATD3.
    Matd3(Matd3),
    /// MASAC.
    Masac(Masac),
}

macro_rules! each {
    ($self:expr, $l:ident => $e:expr) => {
        match $self {
            AnyLearner::Maddpg($l) => $e,
            AnyLearner::Matd3($l) => $e,
            AnyLearner::Masac($l) => $e,
        }
    };
}

impl AnyLearner {
    /// Which algorithm this is.
    #[must_use]
    pub fn kind(&self) -> AlgorithmKind {
        match self {
            AnyLearner::Maddpg(_) => AlgorithmKind::Maddpg,
            AnyLearner::Matd3(_) => AlgorithmKind::Matd3,
            AnyLearner::Masac(_) => AlgorithmKind::Masac,
        }
    }

    /// Agent `agent`'s actor trunk, flattened (what information sharing mixes).
    ///
    /// # Errors
    /// [`NnError::UnknownAgent`].
    pub fn actor_trunk(&self, agent: usize) -> Result<Vec<f32>, NnError> {
        each!(self, l => l.actor_trunk(agent))
    }

    /// All parameters of agent `agent`'s online actor and (first) critic, flattened.
    ///
    /// # Errors
    /// [`NnError::UnknownAgent`], backend errors.
    pub fn params(&self, agent: usize) -> Result<(Vec<f32>, Vec<f32>), NnError> {
        each!(self, l => l.params(agent))
    }
}

impl Policy for AnyLearner {
    type Error = NnError;

    fn num_agents(&self) -> usize {
        each!(self, l => l.num_agents())
    }

    fn act(&mut self, inputs: &[Vec<f32>], n: usize, mode: ActMode) -> Result<PolicyOutput, NnError> {
        each!(self, l => l.act(inputs, n, mode))
    }
}

impl Algorithm for AnyLearner {
    fn store(&mut self, episode: &Episode) -> Result<(), NnError> {
        each!(self, l => l.store(episode))
    }

    fn update(&mut self, rewards: &dyn RewardModel) -> Result<UpdateStats, NnError> {
        each!(self, l => l.update(rewards))
    }

    fn save_state(&self, include_storage: bool) -> Result<Vec<u8>, NnError> {
        each!(self, l => l.save_state(include_storage))
    }

    fn load_state(&mut self, bytes: &[u8]) -> Result<(), NnError> {
        each!(self, l => l.load_state(bytes))
    }

    fn load_rescue_state(&mut self, bytes: &[u8]) -> Result<(), NnError> {
        each!(self, l => l.load_rescue_state(bytes))
    }

    fn storage_capacity(&self) -> usize {
        each!(self, l => l.storage_capacity())
    }

    fn restore_storage(&mut self, total: u64, episodes: &[Episode]) -> Result<(), NnError> {
        each!(self, l => l.restore_storage(total, episodes))
    }
}

impl PolicyState for AnyLearner {
    fn save_policy(&self) -> Result<Vec<u8>, NnError> {
        each!(self, l => l.save_policy())
    }

    fn load_policy(&mut self, bytes: &[u8]) -> Result<(), NnError> {
        each!(self, l => l.load_policy(bytes))
    }
}
