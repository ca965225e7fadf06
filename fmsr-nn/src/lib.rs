//! burn networks and the multi-agent learners of fmsr: MADDPG, MATD3 and
//! MASAC, each with hindsight replay, finger-specific shadow rewards and
//! information sharing (paper section III, Algorithm 1).
//!
//! Every learner is one generic off-policy learner, [`OffPolicy<R>`], over an
//! update rule ([`UpdateRule`], public: a user's algorithm is one) that holds only what makes the algorithm itself (its config,
//! its losses and targets, what its critics see, its own state): [`Maddpg`] is
//! `OffPolicy<MaddpgRule>`, [`Matd3`] `OffPolicy<Matd3Rule>`, [`Masac`]
//! `OffPolicy<MasacRule>` ([`off_policy`]). A rule steps through the
//! learner's public view ([`Learner`]): the deterministic steps of MADDPG and
//! MATD3, and the squashed-Gaussian ones ([`SquashedGaussian`]) that MASAC is
//! written on and a user's SAC variant can be. `OffPolicy` implements
//! [`fmsr_core::Algorithm`], [`fmsr_core::Policy`] and
//! [`fmsr_core::PolicyState`] once: it owns the HER replay buffer, the update
//! schedule (`replay.batches` gradient steps per cycle), the target networks
//! and save/restore. They share one machinery:
//!
//! - per agent an actor (own input layer -> trunk of equal shape -> own head)
//!   and one or two critics that see the global observation, the goal and
//!   every agent's action (MADDPG / MAGCLA); the networks of a group of agents
//!   are one [`StackedMlp`] whose layers are `[agents, in, out]` tensors, one
//!   batched matmul per layer ([`Stacking`]: every agent in one group on a
//!   GPU, one group per agent on worker threads on the CPU), built once with
//!   [`StackedMlpConfig::init`], living on the device across updates and
//!   optimised by burn's Adam with its state on the device;
//! - running input normalisers (HER baselines), updated from each batch;
//! - critic targets clipped to the reward bounds over `1 - gamma` (`clip_return`;
//!   [`TargetClip`]: or HER baselines' `[-1 / (1 - gamma), 0]`);
//! - information sharing (eq. 8) through [`fmsr_core::sharing::InformationSharing`]:
//!   `theta_i <- sum_j M[i][j] theta_j` over the trunks, on parameters after
//!   the optimiser step (default) or on gradients before it, one matmul of `M`
//!   with each stacked trunk tensor on the device;
//! - polyak targets `theta' <- polyak theta' + (1 - polyak) theta` (eq. 9), on the device;
//! - gradients averaged over worker processes by a
//!   [`fmsr_core::agent::Communicator`] (identity in one process).
//!
//! | algorithm | critics | actor | exploration | module |
//! |---|---|---|---|---|
//! | [`Maddpg`] | one | deterministic, `tanh` | Gaussian noise + random actions | [`maddpg`] |
//! | [`Matd3`] | twin, min target | deterministic, delayed | as MADDPG, smoothed targets | [`matd3`] |
//! | [`Masac`] | twin, min target | tanh-Gaussian | sampling; temperature tuned | [`masac`] |
//!
//! The groups' computations run on [`NetworkConfig::threads`] OS threads;
//! each group's computation depends only on its own state, so results are
//! bit-identical for any thread count. With one group the kernels of a joint
//! update do not depend on the number of agents. Rollouts act on a host copy
//! of the actors (burn's `flex`), refreshed after each update phase, so an
//! environment step never waits for the device.
//!
//! # Backends
//!
//! burn 0.22 chooses the backend by the device: [`LearnerParts::new`] uses
//! `Device::flex()` (pure-Rust CPU); [`LearnerParts::with_device`] takes any
//! burn device compiled in, such as the GPUs of the `wgpu` and `vulkan`
//! features, named by the strings of [`DeviceSpec`] ([`device`]). Gradients
//! are taken on the device's `.autodiff()` twin; the target networks run on
//! the plain device, acting on a `flex` copy of the actors.
//!
//! # Example
//!
//! ```
//! use fmsr_core::prelude::*;
//! use fmsr_nn::prelude::*;
//!
//! let agent = |n: &str, s: Vec<usize>| AgentSpec { name: n.into(), action_slots: s, local_obs_dim: 3 };
//! let spec = EnvSpec { agents: vec![agent("a", vec![0]), agent("b", vec![1, 2])], action_dim: 3, obs_dim: 4,
//!     goal_dim: 2, episode_len: 10, features: vec![], reward_range: (-1.0, 0.0) };
//! let layout = ObservationLayout::new(spec, vec![vec![1], vec![0]])?;
//! let parts = LearnerParts::new(layout, NetworkConfig::new().with_hidden(16).with_layers(2), ReplayConfig::default(), 0.9);
//! let mut sac = Masac::new(parts, MasacConfig::new())?;
//! let out = sac.act(&[vec![0.1; 7], vec![0.2; 6]], 1, ActMode::Explore)?;
//! assert!(out.actions.iter().flatten().all(|a| a.abs() <= 1.0));
//! assert_eq!(out.log_probs.len(), 2);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

#![warn(missing_docs)]

mod any;
mod clip;
mod config;
pub mod device;
mod error;
mod explore;
mod group;
mod learner;
pub mod maddpg;
pub mod masac;
pub mod matd3;
mod mixing;
mod net;
mod normalizer;
pub mod off_policy;
mod state;
mod workers;

pub use any::{AnyLearner, ConfiguredRule};
/// The burn this crate is built on, so that a rule of one's own names its
/// tensors and modules at the same version (`fmsr_nn::burn::tensor::Tensor`).
pub use burn;
/// burn's device type, re-exported for [`LearnerParts::with_device`] (e.g. `Device::flex()`).
pub use burn::tensor::Device;
pub use config::{
    CriticLoss, CriticTying, CriticView, MaddpgConfig, MasacConfig, Matd3Config, NetworkConfig, NormalizerStats,
    Stacking, TargetClip, TdLoss, Teammates,
};
pub use device::{Adapter, DeviceSpec};
/// The former name of [`CriticTying`].
#[deprecated(note = "renamed CriticTying: \"sharing\" means information sharing (eq. 8)")]
pub type CriticSharing = CriticTying;
pub use error::NnError;
pub use learner::{BatchTensors, Learner, LearnerParts, SoftTerm, SquashedGaussian};
pub use maddpg::{Maddpg, MaddpgRule};
pub use masac::{Masac, MasacRule};
pub use matd3::{Matd3, Matd3Rule};
pub use net::{Critics, NetShape, StackLayout, StackedLinear, StackedMlp, StackedMlpConfig};
pub use normalizer::Normalizer;
pub use off_policy::{OffPolicy, StepLosses, UpdateRule};
pub use state::{
    PolicyPrecision, RescueLevel, RuleState, policy_at_precision, policy_from_learner_state, rescue_state,
};

/// Everything needed for typical use: `use fmsr_nn::prelude::*;`.
pub mod prelude {
    pub use crate::{
        AnyLearner, ConfiguredRule, Device, DeviceSpec, LearnerParts, Maddpg, MaddpgConfig, Masac, MasacConfig, Matd3,
        Matd3Config, NetShape, NetworkConfig, NnError, Normalizer, PolicyPrecision, StackedMlp, StackedMlpConfig,
        Stacking, policy_at_precision, policy_from_learner_state,
    };
    pub use fmsr_core::algorithm::Algorithm;
    pub use fmsr_core::policy::{ActMode, Policy, PolicyState};
}
