//! # fmsr
//!
//! Finger-specific Multi-agent Shadow Reward (FMSR) with Information Sharing
//! (IS) for dexterous in-hand manipulation, in Rust: the facade over the
//! workspace's crates and the `fmsr` command.
//!
//! | crate | what |
//! |---|---|
//! | [`graph`] (`fmsr-graph`) | graphs, doubly stochastic mixing matrices, consensus steps (eq. 8) |
//! | [`core`] (`fmsr-core`) | `Env`, `Policy`, `Algorithm`, `OccupancyEstimator`, `ShadowReward` traits, collector, occupancy (eq. 1), shadow rewards (eqs. 7, 11-15), HER replay, trainer |
//! | [`nn`] (`fmsr-nn`) | burn actor/critic modules and the learners MADDPG, MATD3, MASAC |
//! | [`envs`] (`fmsr-envs`) | the rapier3d Shadow Hand tasks and the `TeamReach` test env |
//!
//! ```
//! use fmsr::prelude::*;
//!
//! // The paper's default information-sharing topology and its mixing matrix.
//! let graph = Graph::shadow_hand();
//! let sharing = SharingConfig::default().build(&graph).unwrap().unwrap();
//! assert_eq!(sharing.mixing.n(), 6);
//! ```
//!
//! ## Your own algorithm
//!
//! The trainer knows algorithms only through two traits of `fmsr-core`:
//! [`core::Policy`] (act for all agents) and [`core::Algorithm`] (store
//! episodes, update with the trainer's [`core::RewardModel`], save and
//! restore). fmsr-nn's one off-policy learner, [`nn::OffPolicy`], implements
//! both over an update rule, [`nn::UpdateRule`], which is public:
//! `examples/custom_algorithm.rs` writes independent DDPG (each critic sees
//! only its own agent's observation and action, `CriticView::Own`), which
//! this crate does not ship, as one rule in one short file, and gets HER,
//! information sharing, worker averaging, resume and policy export from the
//! crate. Its settings are a config section ([`nn::ConfiguredRule`]), and
//! one call, [`algorithms::register`], lets experiment files name it
//! (`algorithm = "iddpg"`) and fmsr's own command, [`cli::main`], train,
//! resume, export, evaluate and report it; `tests/custom_algorithm.rs`
//! checks that it learns TeamReach, resumes exactly, and runs through the
//! command by name. A stochastic policy's rule steps through the learner's
//! squashed-Gaussian steps ([`nn::SquashedGaussian`]), as the crate's MASAC
//! does: `examples/downstream/src/sac.rs`, a crate outside this workspace,
//! writes SAC with a fixed temperature that way, registers it and runs it
//! through [`cli::run`].
//!
//! ## Your own task
//!
//! A task is an [`core::Env`] of your crate with its settings
//! ([`tasks::Task`]). One call, [`tasks::register`], lets experiment files
//! choose it (`task = "herd"`, its settings in `[herd]`) and fmsr's command
//! train, resume, export and evaluate it with any registered algorithm,
//! the shadow rewards of its features and information sharing over its
//! agents; [`task_eval`] measures what every task has. The Shadow Hand is
//! the task `"shadow_hand"` ([`tasks::ShadowHandTask`]), the default, in the
//! registry from the start and trained through it as yours is.
//! `examples/downstream` registers its `Herd` that way and runs it through
//! [`cli::run`].
//!
//! ## Features
//!
//! `cli` (default) brings the `fmsr` command, [`report`], [`render`] and
//! [`tensorboard`] with their crates (clap, indicatif, plotters and a font,
//! gif, png, prost); a library user's crate that trains, evaluates and saves
//! runs from its own code depends on `fmsr` with `default-features = false`
//! and builds none of them. `report`, `render` and `tensorboard` each alone;
//! `mujoco`, the GPU backends and `mpi` as the guide says.
#![cfg_attr(docsrs, feature(doc_cfg))]
#![warn(missing_docs)]

pub mod algorithms;
pub mod allocator;
pub mod artefacts;
#[cfg(feature = "cli")]
pub mod cli;
pub mod error;
pub mod evaluate;
pub mod experiment;
mod factory;
#[cfg(any(feature = "report", feature = "render"))]
mod font;
#[cfg(feature = "mpi")]
pub mod mpi;
pub mod provenance;
#[cfg(feature = "render")]
pub mod render;
#[cfg(feature = "report")]
pub mod report;
pub mod run;
pub mod stack;
pub mod task_eval;
pub mod tasks;
#[cfg(feature = "tensorboard")]
pub mod tensorboard;

pub use fmsr_core as core;
pub use fmsr_envs as envs;
pub use fmsr_graph as graph;
pub use fmsr_nn as nn;

/// Everything most users need, from every crate of the workspace.
pub mod prelude {
    pub use fmsr_core::prelude::*;
    pub use fmsr_envs::prelude::*;
    pub use fmsr_graph::prelude::*;
    pub use fmsr_nn::prelude::*;
}
