//! # fmsr-envs
//!
//! Environments implementing [`fmsr_core::Env`]:
//!
//! - [`team_reach::TeamReach`]: a small, fast multi-agent goal-conditioned test
//!   environment (no physics engine) used by tests and examples.
//! - [`shadow_hand::ShadowHand`]: the Shadow Hand block and egg rotation tasks with
//!   92 touch sensors, on rapier3d (default; the model is fetched with pip on first use).
#![warn(missing_docs)]

pub mod error;
pub mod shadow_hand;
pub mod team_reach;

pub use error::EnvError;

/// The items most users need.
pub mod prelude {
    pub use crate::error::EnvError;
    pub use crate::shadow_hand::{
        HandAgent, HandObject, HandPhysics, RapierHand, RapierSettings, ShadowHand, ShadowHandConfig, TouchObs,
        fetch_hand_assets,
    };
    pub use crate::team_reach::{TeamReach, TeamReachConfig};
}
