//! # fmsr-core
//!
//! The traits and the learning machinery of **FMSR + IS** (Finger-specific
//! Multi-agent Shadow Reward with Information Sharing) that know nothing of
//! neural-network or physics libraries.
//!
//! ## The method
//!
//! `N` agents (one per finger plus the wrist) act on one environment; agent `i`
//! owns some slots of the joint action ([`spec::AgentSpec`]). Each agent learns a
//! deterministic actor `mu_i` and a critic `Q_i` that sees the global observation,
//! the goal and all actions (MAGCLA / MADDPG), from one shared replay buffer with
//! hindsight relabelling ([`replay`]).
//!
//! **Occupancy** (eq. 1). For a stability feature `phi_k(s, a)` in `[0, 1]` (object in
//! the safe region, at least 10 active touch sensors), the discounted occupancy of
//! one episode is
//!
//! ```text
//! lambda_k = (1 - gamma) * sum_{t=0}^{T-1} gamma^t * phi_k(s_t, a_t),
//! ```
//!
//! averaged over recent episodes ([`occupancy::DiscountedOccupancy`]).
//!
//! **Shadow reward** (eqs. 2, 7, 11-12). A concave utility `F_k(lambda) = log(lambda_k + 0.1)`
//! is maximised through the per-step reward `z_k = phi_k / (lambda_k + 0.1)`, its
//! policy gradient ([`shadow::LogUtility`]). Agent `i`'s critic target is
//!
//! ```text
//! y_i = w_i * r_task + alpha * sum_{k in S_i} z_k + gamma * Q_i'(x', a')    (eq. 7)
//! ```
//!
//! with the finger-specific sets `S_i` of eqs. 13-15 ([`shadow::RewardAssignment`]).
//!
//! **Information sharing** (eq. 8): after each actor update, the agents' shared-shape
//! parameters are mixed over a graph, `theta_i <- sum_j M_ij theta_j`, with a symmetric
//! doubly stochastic mixing matrix `M` (crate `fmsr-graph`).
//!
//! ## Example
//!
//! ```
//! use fmsr_core::prelude::*;
//!
//! // Occupancy of a feature that is on for the first 2 of 4 steps, gamma = 0.5.
//! let mut occ = DiscountedOccupancy::new(1, 0.5, Averaging::Ema { beta: 0.1 }).unwrap();
//! occ.observe_episode(&[vec![1.0], vec![1.0], vec![0.0], vec![0.0]]).unwrap();
//! assert!((occ.estimate()[0] - 0.75).abs() < 1e-12);
//! // The gradient-mode shadow reward of a step where the feature is on.
//! let z = LogUtility::default().step_reward(1.0, occ.estimate()[0]);
//! assert!((z - 1.0 / 0.85).abs() < 1e-12);
//! ```
//!
//! ## Contents
//!
//! - [`Env`], [`ContactReadout`]: environments and their optional contact read-out.
//! - [`Policy`] (acting for all agents, with its own exploration) and
//!   [`Algorithm`] (a policy that owns its storage, update schedule, targets and
//!   save/restore); [`agent::ObservationLayout`] assembles actor inputs.
//! - [`Collector`]: runs episodes, estimates occupancy with any
//!   [`OccupancyEstimator`] and rewards agents with any [`ShadowReward`].
//! - [`sharing::InformationSharing`]: the algorithm-independent consensus step (eq. 8).
//! - [`replay::ReplayBuffer`]: joint transitions with HER "future" relabelling.
//! - [`trainer::Trainer`]: collect -> store -> update (and share) -> evaluate -> checkpoint.
#![warn(missing_docs)]

pub mod agent;
pub mod algorithm;
pub mod collector;
pub mod config;
pub mod env;
pub mod error;
pub mod interval;
pub mod metrics;
pub mod occupancy;
pub mod persist;
pub mod policy;
pub mod replay;
pub mod replay_log;
pub mod seeding;
pub mod shadow;
pub mod sharing;
pub mod spec;
pub mod trainer;

pub use algorithm::{Algorithm, RewardModel};
pub use collector::Collector;
pub use env::{ContactReadout, Env};
pub use error::CoreError;
pub use occupancy::OccupancyEstimator;
pub use policy::{ActMode, Policy, PolicyState};
pub use shadow::ShadowReward;

/// The items most users need.
pub mod prelude {
    pub use crate::agent::{
        ActorView, Batch, Communicator, ObservationLayout, ShareMode, ShareTarget, Sharing, SingleProcess,
    };
    pub use crate::algorithm::{Algorithm, RewardModel, UpdateStats};
    pub use crate::collector::Collector;
    pub use crate::config::{Method, MixingChoice, ShadowConfig, SharingConfig};
    pub use crate::env::{ContactPoint, ContactReadout, Env, ObjectContacts};
    pub use crate::error::CoreError;
    pub use crate::metrics::{
        EpisodeOutcome, EpisodeSummary, FailureCounts, FailureRow, FailureType, GraspQuality, GraspTrace, MeanStd,
        StabilityRow,
    };
    pub use crate::occupancy::{Averaging, DiscountedOccupancy, OccupancyEstimator};
    pub use crate::policy::{ActMode, Policy, PolicyOutput, PolicyState};
    pub use crate::replay::{Episode, HerConfig, ReplayBuffer, ReplayConfig};
    pub use crate::shadow::{AgentReward, AgentRewards, LogUtility, RewardAssignment, ShadowMode, ShadowReward};
    pub use crate::sharing::{InformationSharing, NetworkGroup, SharedParameters};
    pub use crate::spec::{AgentSpec, EnvSpec, JointAction, Observation, RewardType, StepInfo, StepOutcome};
    pub use crate::trainer::{EpochStats, EvalSummary, Trainer, TrainerConfig};
}
