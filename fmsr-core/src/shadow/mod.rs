//! Shadow rewards (paper eqs. 2, 7, 11-15; docs/design.md 3.4-3.5).
//!
//! A shadow reward turns a concave utility `F_k(lambda_k)` of the occupancy of a
//! stability feature into a per-step reward. We *maximise*
//! `F_k(lambda) = log(lambda_k + 0.1)` (the paper writes `-log`, which would push
//! the occupancy down; docs/design.md 3.4). Two modes:
//!
//! - [`ShadowMode::Gradient`] (default): the general-utility policy gradient. By
//!   the chain rule `grad F(lambda) = sum_{s,a} dF/dlambda * grad lambda(s, a)`, so
//!   the per-step reward is `z_k(s, a) = F'(lambda_k) * phi_k(s, a) = phi_k(s, a) / (lambda_k + 0.1)`.
//! - [`ShadowMode::Value`]: adds `F_k(lambda_k)` itself at every step, eq. (2)'s
//!   term read as a per-step reward (with this module's sign, not eqs. 11-12's);
//!   kept for ablation.
//!
//! Agent `i` learns from `r_i = w_task * r_task + alpha * sum_{k in S_i} z_k` in its
//! critic target (eq. 7), where `S_i` is its finger-specific set of features
//! ([`RewardAssignment`], eqs. 13-15).

//!
//! The pieces, each in its file, and the one struct that holds them:
//!
//! - [`occupancy`]: the estimate `lambda` of the discounted occupancy of each
//!   feature (eq. 1), [`OccupancyEstimator`] with the paper's [`DiscountedOccupancy`].
//! - [`ShadowReward`], [`LogUtility`]: the utility `F` and the per-step reward `z` (eqs. 2, 11-12).
//! - [`RewardAssignment`], [`AgentRewards`]: which features each agent is
//!   rewarded for (eqs. 13-15) and its reward `r_i` (eq. 7).
//! - [`ShadowRewards`]: the estimator and the agents' rewards together, as the
//!   trainer holds them: it observes every collected episode and gives the
//!   learners their rewards ([`ShadowRewards::reward_model`]).
//! - [`ShadowConfig`]: `[trainer.shadow]` of a run's config.

mod assignment;
mod config;
mod model;
pub mod occupancy;
mod utility;

pub use self::assignment::{AgentReward, AgentRewards, ResolvedAssignment, RewardAssignment};
pub use self::config::ShadowConfig;
pub use self::model::{RewardSums, ShadowRewards, TrainingRewards};
pub use self::occupancy::{Averaging, DiscountedOccupancy, OccupancyEstimator, episode_occupancy};
pub use self::utility::{LogUtility, ShadowMode, ShadowReward};
