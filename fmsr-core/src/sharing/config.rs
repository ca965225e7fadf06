//! Information sharing as configured (`[sharing]`): the mixing rule and what is mixed.

use fmsr_graph::{Graph, Lazy, MaxDegree, MetropolisHastings, MixingMatrix, MixingRule, UserMatrix};
use serde::{Deserialize, Serialize};

use super::{ShareMode, ShareTarget, Sharing};
use crate::error::CoreError;

/// The mixing weights of information sharing.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case", tag = "rule", deny_unknown_fields)]
pub enum MixingChoice {
    /// Metropolis-Hastings weights (default).
    #[default]
    MetropolisHastings,
    /// Max-degree weights.
    MaxDegree,
    /// `(1 - alpha) I + alpha M_MH`.
    LazyMetropolisHastings {
        /// Laziness, in `(0, 1]`.
        alpha: f64,
    },
    /// `(1 - alpha) I + alpha M_maxdeg`.
    LazyMaxDegree {
        /// Laziness, in `(0, 1]`.
        alpha: f64,
    },
    /// A user-given matrix, validated against the graph.
    Matrix {
        /// The rows of `M`.
        rows: Vec<Vec<f64>>,
    },
}

impl MixingChoice {
    /// The validated mixing matrix on `graph`.
    pub fn matrix(&self, graph: &Graph) -> Result<MixingMatrix, CoreError> {
        let m = match self {
            MixingChoice::MetropolisHastings => MetropolisHastings.mixing_matrix(graph)?,
            MixingChoice::MaxDegree => MaxDegree.mixing_matrix(graph)?,
            MixingChoice::LazyMetropolisHastings { alpha } => {
                Lazy::new(MetropolisHastings, *alpha)?.mixing_matrix(graph)?
            }
            MixingChoice::LazyMaxDegree { alpha } => Lazy::new(MaxDegree, *alpha)?.mixing_matrix(graph)?,
            MixingChoice::Matrix { rows } => UserMatrix { rows: rows.clone() }.mixing_matrix(graph)?,
        };
        m.validate(graph)?;
        Ok(m)
    }
}

/// Information sharing (IS, eq. 8).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SharingConfig {
    /// Whether agents share information.
    pub enabled: bool,
    /// Mix parameters (default) or gradients.
    pub mode: ShareMode,
    /// Mix actors (default), critics or both.
    pub target: ShareTarget,
    /// The mixing weights.
    pub mixing: MixingChoice,
}

impl Default for SharingConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            mode: ShareMode::Parameters,
            target: ShareTarget::Actors,
            mixing: MixingChoice::default(),
        }
    }
}

impl SharingConfig {
    /// What the learner applies on `graph`: `None` when disabled.
    pub fn build(&self, graph: &Graph) -> Result<Option<Sharing>, CoreError> {
        if !self.enabled {
            return Ok(None);
        }
        Ok(Some(Sharing { mixing: self.mixing.matrix(graph)?, mode: self.mode, target: self.target }))
    }
}
