//! The paper's four configurations as data (section IV.C).

use serde::{Deserialize, Serialize};

use crate::spec::RewardType;

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
    /// use fmsr_core::method::Method;
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
