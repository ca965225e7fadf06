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
//! averaged over recent episodes ([`shadow::DiscountedOccupancy`]).
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
//! doubly stochastic mixing matrix `M` (crate `fmsr-graph`). Algorithm 1 mixes
//! between the critic and the actor updates instead; docs/design.md 3.7 says why
//! the two orders differ only at the ends of a run of updates.
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
//! - [`Collector`]: runs episodes (in lockstep on several environments).
//! - [`shadow`]: the shadow rewards of the method (FMSR): any
//!   [`OccupancyEstimator`] (eq. 1), any utility [`ShadowReward`] (eqs. 2,
//!   11-12), the finger-specific assignment (eqs. 13-15), held together by
//!   [`shadow::ShadowRewards`], which gives the learners their rewards (eq. 7).
//! - [`sharing`]: information sharing (IS), its settings and the
//!   algorithm-independent consensus step (eq. 8), [`sharing::InformationSharing`].
//! - [`method::Method`]: the paper's four configurations.
//! - [`replay::ReplayBuffer`]: joint transitions with HER "future" relabelling.
//! - [`trainer::Trainer`]: collect -> store -> update (and share) -> evaluate -> checkpoint.
#![warn(missing_docs)]

pub mod agent;
pub mod algorithm;
pub mod collector;
pub mod env;
pub mod error;
pub mod interval;
pub mod method;
pub mod metrics;
pub mod persist;
pub mod policy;
pub mod replay;
pub mod replay_log;
pub mod seeding;
pub mod shadow;
pub mod sharing;
pub mod spec;
#[cfg(feature = "testing")]
pub mod testing;
pub mod trainer;

pub use algorithm::{Algorithm, RewardModel};
pub use collector::Collector;
pub use env::{AnyEnv, ContactReadout, Env};
pub use error::CoreError;
pub use policy::{ActMode, Policy, PolicyState};
/// The rand this crate's API takes (the replay buffer's sampling RNG, the
/// seeded streams of [`seeding`]), so that an algorithm of one's own names
/// it at the same version.
pub use rand;
pub use shadow::{OccupancyEstimator, ShadowReward};

/// The items most users need.
pub mod prelude {
    pub use crate::agent::{ActorView, Batch, Communicator, ObservationLayout, SingleProcess};
    pub use crate::algorithm::{Algorithm, RewardModel, UpdateStats};
    pub use crate::collector::Collector;
    pub use crate::env::{AnyEnv, ContactPoint, ContactReadout, Env, ObjectContacts};
    pub use crate::error::CoreError;
    pub use crate::method::Method;
    pub use crate::metrics::{
        EpisodeOutcome, EpisodeSummary, FailureCounts, FailureRow, FailureType, GraspQuality, GraspTrace, MeanStd,
        StabilityRow,
    };
    pub use crate::policy::{ActMode, Policy, PolicyOutput, PolicyState};
    pub use crate::replay::{Episode, HerConfig, ReplayBuffer, ReplayConfig};
    pub use crate::shadow::{
        AgentReward, AgentRewards, Averaging, DiscountedOccupancy, LogUtility, OccupancyEstimator, RewardAssignment,
        ShadowConfig, ShadowMode, ShadowReward, ShadowRewards,
    };
    pub use crate::sharing::{
        InformationSharing, MixingChoice, NetworkKind, ShareMode, ShareTarget, SharedParameters, Sharing, SharingConfig,
    };
    pub use crate::spec::{AgentSpec, EnvSpec, JointAction, Observation, RewardType, StepInfo, StepOutcome};
    pub use crate::trainer::{EpochStats, EvalSummary, Trainer, TrainerConfig};
}
