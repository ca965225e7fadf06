//! Configuration of the method: shadow rewards, information sharing and the
//! paper's four configurations as data.

use fmsr_graph::{Graph, Lazy, MaxDegree, MetropolisHastings, MixingMatrix, MixingRule, UserMatrix};
use serde::{Deserialize, Serialize};

use crate::agent::{ShareMode, ShareTarget, Sharing};
use crate::error::CoreError;
use crate::occupancy::{Averaging, DiscountedOccupancy};
use crate::shadow::{AgentRewards, LogUtility, RewardAssignment};
use crate::spec::{EnvSpec, RewardType};

/// Shadow rewards (FMSR): weight, utility, occupancy averaging and the finger-specific assignment.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ShadowConfig {
    /// Whether agents receive shadow rewards at all (off: task reward only).
    pub enabled: bool,
    /// Weight `alpha` of the shadow rewards (eq. 2; default 0.1).
    pub alpha: f64,
    /// The utility `F` and the per-step reward mode.
    pub utility: LogUtility,
    /// How the occupancy is averaged over recent episodes.
    pub occupancy: Averaging,
    /// Which features each agent receives; `None` is the paper's eqs. 13-15.
    pub assignment: Option<RewardAssignment>,
    /// The largest ratio, for any agent, of its mean per-step shadow reward
    /// `|alpha sum_k z_k|` to its mean per-step task reward `|w_i r|` over the
    /// first cycle's episodes (default 1.0: shadow rewards must not outweigh the
    /// task). Training stops with an error naming both values when an agent's
    /// ratio is larger; `inf` disables the check. Every epoch logs the ratios
    /// (`EpochStats::shadow_scale`).
    pub max_scale: f64,
}

impl Default for ShadowConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            alpha: 0.1,
            utility: LogUtility::default(),
            occupancy: Averaging::default(),
            assignment: None,
            max_scale: 1.0,
        }
    }
}

impl ShadowConfig {
    /// The per-agent reward computation for `spec` (task only when disabled).
    pub fn agent_rewards(&self, spec: &EnvSpec) -> Result<AgentRewards, CoreError> {
        self.utility.validate()?;
        let assignment = if self.enabled {
            self.assignment.clone().unwrap_or_else(RewardAssignment::paper)
        } else {
            RewardAssignment::task_only(spec)
        };
        AgentRewards::new(assignment.resolve(spec)?, self.utility, self.alpha)
    }

    /// The occupancy estimator of `spec`'s features with discount `gamma`.
    pub fn occupancy(&self, spec: &EnvSpec, gamma: f64) -> Result<DiscountedOccupancy, CoreError> {
        DiscountedOccupancy::new(spec.features.len(), gamma, self.occupancy)
    }
}

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

/// The paper's four configurations (section IV.C).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Method {
    /// Dense task reward, finger-specific shadow rewards, information sharing.
    DenseFmsrIs,
    /// Dense task reward and shadow rewards, no information sharing.
    DenseFmsr,
    /// Dense task reward only.
    Dense,
    /// Sparse task reward only.
    Sparse,
}

impl Method {
    /// All four, in the paper's order.
    pub const ALL: [Method; 4] = [Method::DenseFmsrIs, Method::DenseFmsr, Method::Dense, Method::Sparse];

    /// The task reward of the configuration.
    #[must_use]
    pub fn reward(self) -> RewardType {
        match self {
            Method::Sparse => RewardType::Sparse,
            _ => RewardType::Dense,
        }
    }

    /// Whether shadow rewards are on.
    #[must_use]
    pub fn shadow(self) -> bool {
        matches!(self, Method::DenseFmsrIs | Method::DenseFmsr)
    }

    /// Whether information sharing is on.
    #[must_use]
    pub fn sharing(self) -> bool {
        matches!(self, Method::DenseFmsrIs)
    }

    /// The name used in the paper's tables, e.g. `Dense+FMSR+IS`.
    ///
    /// ```
    /// use fmsr_core::config::Method;
    /// assert_eq!(Method::DenseFmsrIs.label(), "Dense+FMSR+IS");
    /// assert!(Method::DenseFmsr.shadow() && !Method::DenseFmsr.sharing());
    /// ```
    #[must_use]
    pub fn label(self) -> &'static str {
        match self {
            Method::DenseFmsrIs => "Dense+FMSR+IS",
            Method::DenseFmsr => "Dense+FMSR",
            Method::Dense => "Dense",
            Method::Sparse => "Sparse",
        }
    }
}
