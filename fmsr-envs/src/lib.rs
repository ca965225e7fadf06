//! # fmsr-envs
//!
//! Environments implementing [`fmsr_core::Env`]:
//!
//! - [`team_reach::TeamReach`]: a small, fast multi-agent goal-conditioned test
//!   environment (no physics engine) used by tests and examples.
//! - The Shadow Hand block and egg rotation tasks on rapier3d (default).
#![warn(missing_docs)]

pub mod error;
pub mod shadow_hand;
pub mod team_reach;

pub use error::EnvError;

/// The items most users need.
pub mod prelude {
    pub use crate::error::EnvError;
    pub use crate::shadow_hand::{
        HandObject, HandPhysics, RapierHand, RapierSettings, ShadowHand, ShadowHandConfig, TouchObs, fetch_hand_assets,
    };
    pub use crate::team_reach::{TeamReach, TeamReachConfig};
}
