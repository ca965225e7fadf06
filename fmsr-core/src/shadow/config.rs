//! The shadow rewards as configured (`[trainer.shadow]`).

use serde::{Deserialize, Serialize};

use super::assignment::{AgentRewards, RewardAssignment};
use super::occupancy::{Averaging, DiscountedOccupancy};
use super::utility::LogUtility;
use crate::error::CoreError;
use crate::spec::EnvSpec;

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
    /// The largest ratio, for any agent, of its mean shadow reward
    /// `|alpha sum_k z_k|` to its mean task reward `|w_i r|` in the first
    /// cycle's sampled batches, as the critics see them (HER's relabelled
    /// goals included; in its episodes for an algorithm that does not report
    /// its batches). Default 1.0: shadow rewards must not outweigh the task.
    /// Training stops with an error naming both values when an agent's ratio
    /// is larger; `inf` disables the check. Every epoch logs both means per
    /// agent, in the batches (`EpochStats::batch_task_reward_abs`,
    /// `EpochStats::batch_shadow_reward_abs`) and in the episodes
    /// (`EpochStats::task_reward_abs`, `EpochStats::shadow_reward_abs`).
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
    /// Checks the settings that do not need the environment, naming each by
    /// its key in an experiment file (`trainer.shadow.*`).
    ///
    /// ```
    /// use fmsr_core::shadow::ShadowConfig;
    /// let err = ShadowConfig { alpha: -0.1, ..ShadowConfig::default() }.validate().unwrap_err();
    /// assert!(err.to_string().contains("trainer.shadow.alpha"));
    /// ```
    ///
    /// # Errors
    /// [`CoreError::InvalidConfig`] for a negative or non-finite `alpha`, a
    /// utility offset that is not positive, an averaging window of no episode
    /// or a `beta` outside `(0, 1]`, a `max_scale` that is not positive.
    pub fn validate(&self) -> Result<(), CoreError> {
        let bad = |key: &str, reason: String| Err(CoreError::InvalidConfig { key: key.into(), reason });
        if !(self.alpha.is_finite() && self.alpha >= 0.0) {
            return bad("trainer.shadow.alpha", format!("{} must be finite and nonnegative", self.alpha));
        }
        let offset = self.utility.offset;
        if !(offset.is_finite() && offset > 0.0) {
            return bad("trainer.shadow.utility.offset", format!("{offset} must be finite and positive"));
        }
        match self.occupancy {
            Averaging::Ema { beta } if !(beta > 0.0 && beta <= 1.0) => {
                return bad("trainer.shadow.occupancy.beta", format!("{beta} is not in (0, 1]"));
            }
            Averaging::Window { episodes: 0 } => {
                return bad("trainer.shadow.occupancy.episodes", "must be at least 1".into());
            }
            _ => {}
        }
        if self.max_scale.is_nan() || self.max_scale <= 0.0 {
            return bad("trainer.shadow.max_scale", format!("{} must be positive (inf: no check)", self.max_scale));
        }
        Ok(())
    }

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
