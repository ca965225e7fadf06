//! # fmsr-envs
//!
//! Environments implementing [`fmsr_core::Env`]:
//!
//! - [`team_reach::TeamReach`]: a small, fast multi-agent goal-conditioned test
//!   environment (no physics engine) used by tests and examples.
//! - [`shadow_hand::ShadowHand`]: the Shadow Hand block and egg rotation tasks with
//!   92 touch sensors, on rapier3d (default; the model is fetched with pip on first use)
//!   or, with the cargo feature `mujoco`, on MuJoCo 3.17 (`ShadowHandConfig::init_mujoco`).
//!   The task code is shared; only the physics ([`shadow_hand::HandPhysics`]) differs.
//!   The agents are a partition of the 20 actuators ([`shadow_hand::HandAgent`]).
//! - [`shadow_hand::render`]: a headless CPU renderer of the hand, the object and
//!   the goal from gymnasium-robotics' camera, for either engine's episodes.
//!
//! ## Features
//!
//! - `rapier` (default): the rapier3d backend, pure Rust.
//! - `mujoco`: the MuJoCo backend (run `scripts/setup_mujoco.sh` first).
//!
//! Without either, the hand's task, configs, model and renderer build but no
//! physics: [`shadow_hand::ShadowHandConfig::init_engine`] names the missing
//! feature in its error.
#![warn(missing_docs)]

pub mod error;
pub mod shadow_hand;
pub mod team_reach;

pub use error::EnvError;

/// The items most users need.
pub mod prelude {
    pub use crate::error::EnvError;
    #[cfg(feature = "rapier")]
    pub use crate::shadow_hand::RapierHand;
    pub use crate::shadow_hand::{
        GoalDistance, HandAgent, HandObject, HandPhysics, RapierSettings, ShadowHand, ShadowHandConfig, TouchObs,
        fetch_hand_assets,
    };
    pub use crate::team_reach::{TeamReach, TeamReachConfig};
}
