//! The utility `F(lambda)` of an occupancy and the per-step shadow reward that
//! follows from it (eqs. 2, 11-12; docs/design.md 3.4).

use serde::{Deserialize, Serialize};

use crate::error::CoreError;

/// A utility `F(lambda)` of an occupancy, and the per-step shadow reward that follows from it.
pub trait ShadowReward {
    /// The utility `F(lambda)`.
    fn utility(&self, lambda: f64) -> f64;

    /// The per-step shadow reward for a step whose feature value is `phi`, when
    /// the current occupancy estimate of the feature is `lambda`.
    fn step_reward(&self, phi: f64, lambda: f64) -> f64;

    /// Smallest and largest value [`ShadowReward::step_reward`] can take for
    /// `phi` in `[0, 1]` and `lambda` in `[0, 1]` (used to bound Q targets).
    fn step_reward_range(&self) -> (f64, f64);
}

/// Which per-step reward [`LogUtility`] gives.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum ShadowMode {
    /// `z = phi * F'(lambda)`: the policy gradient of the utility (default).
    #[default]
    Gradient,
    /// `z = F(lambda)` at every step: eq. (2)'s term read as a per-step reward.
    Value,
}

/// `F(lambda) = log(lambda + offset)` (eqs. 11-12 with the sign of docs/design.md 3.4).
///
/// ```
/// use fmsr_core::shadow::{LogUtility, ShadowMode, ShadowReward};
/// let f = LogUtility::default(); // offset 0.1, gradient mode
/// assert!((f.step_reward(1.0, 0.0) - 10.0).abs() < 1e-12);  // 1 / (0 + 0.1)
/// assert!((f.step_reward(1.0, 1.0) - 1.0 / 1.1).abs() < 1e-12);
/// assert_eq!(f.step_reward(0.0, 0.5), 0.0);
/// let v = LogUtility { mode: ShadowMode::Value, ..LogUtility::default() };
/// assert!((v.step_reward(0.0, 0.9) - 0.0).abs() < 1e-12); // log(1.0)
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LogUtility {
    /// The offset inside the logarithm (the paper's 0.1), positive.
    pub offset: f64,
    /// Gradient (default) or value mode.
    pub mode: ShadowMode,
}

impl Default for LogUtility {
    fn default() -> Self {
        Self { offset: 0.1, mode: ShadowMode::Gradient }
    }
}

impl LogUtility {
    /// Checks that the offset is positive and finite.
    pub fn validate(&self) -> Result<(), CoreError> {
        if !(self.offset.is_finite() && self.offset > 0.0) {
            return Err(CoreError::InvalidConfig {
                key: "shadow.offset".into(),
                reason: format!("{} must be positive", self.offset),
            });
        }
        Ok(())
    }
}

impl ShadowReward for LogUtility {
    fn utility(&self, lambda: f64) -> f64 {
        (lambda + self.offset).ln()
    }

    fn step_reward(&self, phi: f64, lambda: f64) -> f64 {
        match self.mode {
            ShadowMode::Gradient => phi / (lambda.max(0.0) + self.offset),
            ShadowMode::Value => self.utility(lambda.max(0.0)),
        }
    }

    fn step_reward_range(&self) -> (f64, f64) {
        match self.mode {
            ShadowMode::Gradient => (0.0, 1.0 / self.offset),
            ShadowMode::Value => (self.utility(0.0), self.utility(1.0)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn log_utility_at_lambda_zero_and_one() {
        let f = LogUtility::default();
        assert!((f.utility(0.0) - 0.1f64.ln()).abs() < 1e-12);
        assert!((f.utility(1.0) - 1.1f64.ln()).abs() < 1e-12);
        assert!((f.step_reward(1.0, 0.0) - 10.0).abs() < 1e-12);
        assert!((f.step_reward(1.0, 1.0) - 1.0 / 1.1).abs() < 1e-12);
        assert!((f.step_reward(0.5, 1.0) - 0.5 / 1.1).abs() < 1e-12);
        let v = LogUtility { mode: ShadowMode::Value, ..LogUtility::default() };
        assert!((v.step_reward(0.0, 0.0) - 0.1f64.ln()).abs() < 1e-12);
        assert!((v.step_reward(1.0, 1.0) - 1.1f64.ln()).abs() < 1e-12);
        assert!(LogUtility { offset: 0.0, ..LogUtility::default() }.validate().is_err());
    }
}
