//! burn actor/critic networks and the multi-agent DDPG learner of fmsr
//! (paper section III, Algorithm 1; DESIGN.md sections 3 and 6).
//!
//! [`DdpgLearner`] implements [`fmsr_core::Agent`] and
//! [`fmsr_core::agent::SaveState`]: one actor and one critic per agent, the
//! critics seeing the global observation, the goal and every agent's action
//! (MADDPG / MAGCLA), the actors seeing their own actor input (local
//! observation, goal, neighbours' previous actions; see
//! [`fmsr_core::agent::ObservationLayout`]).
//!
//! # The networks
//!
//! - Actor of agent `i`: `actor_input_dim(i) -> hidden` (own input layer),
//!   `layers - 1` layers `hidden -> hidden` (the *trunk*, the same shape for
//!   every agent), `hidden -> action_dim(i)` (own head); ReLU between layers,
//!   `tanh` on the output.
//! - Critic of agent `i`: `[x, g, a_1..a_N] -> hidden x layers -> 1`, ReLU
//!   between layers. Its trunk is its hidden -> hidden layers.
//! - Inputs are normalised by running mean/std normalisers ([`Normalizer`]),
//!   one per actor input and one for the critics' `[x, g]` part:
//!   `clip((v - mean) / max(std, eps), -clip_obs, clip_obs)`, updated from the
//!   batches the learner learns on and saved with the model.
//! - Weights are Glorot-uniform and biases zero (TensorFlow's default, as in
//!   HER baselines), drawn from a ChaCha8 stream per network seeded by
//!   [`DdpgConfig::seed`], so learners are reproducible independently of burn's
//!   global RNG.
//!
//! # The updates (HER-baselines DDPG, per agent `i`, one shared batch)
//!
//! Critic target and loss (paper eq. 7; the shadow reward is already part of
//! `r_i`, there is no terminal masking since episodes end by the time limit):
//!
//! ```text
//! a'_j = mu'_j(o'_j)                                      for every agent j
//! y_i  = clip(r_i + gamma * Q'_i(x', g, a'_1, ..., a'_N), q_lo_i, q_hi_i)
//! L_Q  = mean over the batch of (Q_i(x, g, a_1, ..., a_N) - y_i)^2
//! ```
//!
//! Actor loss (the deterministic policy gradient of eq. 5, with HER's action
//! penalty), with agent `i`'s action replaced by its current policy:
//!
//! ```text
//! L_mu = -mean Q_i(x, g, a_1, ..., mu_i(o_i), ..., a_N) + action_l2 * mean(mu_i(o_i)^2)
//! ```
//!
//! Each gradient is averaged over workers ([`fmsr_core::agent::Communicator`],
//! as HER's MPI Adam) and applied by Adam on the flat parameter vector:
//!
//! ```text
//! t += 1;  lr_t = lr * sqrt(1 - beta2^t) / (1 - beta1^t)
//! m = beta1 m + (1 - beta1) grad;  v = beta2 v + (1 - beta2) grad^2
//! theta -= lr_t * m / (sqrt(v) + eps)
//! ```
//!
//! Target networks ([`fmsr_core::Agent::update_targets`], eq. 9 with HER's
//! convention): `theta' <- polyak * theta' + (1 - polyak) * theta`.
//!
//! Every `learn` call runs, for all agents, the critic updates, then the actor
//! updates (which use the updated critics), then information sharing. The
//! agents' gradient computations run on [`DdpgConfig::threads`] OS threads;
//! each agent's computation is independent of the others and of the thread
//! that runs it, so results are bit-identical for any thread count.
//!
//! # Why a flat Adam rather than burn's `AdamConfig`
//!
//! The learner keeps every network as one flat `f32` vector and builds burn
//! [`Actor`] / [`Critic`] modules (`#[derive(Module)]`, burn `Linear` layers)
//! from it for each pass; gradients are read back with `Tensor::grad` into
//! the same flat layout. Everything that acts on parameters across agents or
//! workers then works on plain slices: the `Communicator`'s all-reduce of each
//! flattened gradient (HER baselines' MPI Adam does exactly this), gradient
//! and parameter mixing over the trunk ranges, polyak averaging, and
//! bit-exact checkpoints of parameters and Adam moments ([`FlatAdam`]), with
//! no dependence on burn's parameter ids or record formats.
//!
//! # Information sharing (paper eq. 8, DESIGN.md 3.7)
//!
//! With a [`fmsr_core::agent::Sharing`] of mixing matrix `M`:
//!
//! - mode `Parameters` (default): after the actor updates,
//!   `theta_i <- sum_j M[i][j] theta_j` over the actors' trunks (target
//!   `Actors` or `Both`); with target `Critics` or `Both` the critics' trunks
//!   are mixed the same way right after the critic updates;
//! - mode `Gradients`: the trunk gradients are mixed the same way before the
//!   optimiser step.
//!
//! [`fmsr_core::Agent::consensus_params`] exposes the actor trunk of an agent.
//!
//! # Backends
//!
//! burn 0.22 chooses the backend by the device: [`DdpgLearner::new`] uses
//! `Device::flex()` (pure-Rust CPU), [`DdpgLearner::with_parts`] takes any
//! device; gradients are taken on its `.autodiff()` twin only, acting and the
//! target networks run on the plain device. The cargo feature `ndarray` passes
//! through burn's (deprecated) ndarray backend.
//!
//! # Example
//!
//! ```
//! use fmsr_core::Agent;
//! use fmsr_core::agent::{Batch, ObservationLayout};
//! use fmsr_core::spec::{AgentSpec, EnvSpec};
//! use fmsr_nn::prelude::*;
//!
//! let agent = |n: &str, s: Vec<usize>| AgentSpec { name: n.into(), action_slots: s, local_obs_dim: 3 };
//! let spec = EnvSpec { agents: vec![agent("a", vec![0]), agent("b", vec![1, 2])], action_dim: 3, obs_dim: 4,
//!     goal_dim: 2, episode_len: 10, features: vec![], reward_range: (-1.0, 0.0) };
//! let layout = ObservationLayout::new(spec, vec![vec![1], vec![0]])?;
//! let config = DdpgConfig::new().with_hidden(16).with_layers(2).with_seed(1);
//! let mut learner = DdpgLearner::new(layout.clone(), config, None)?;
//!
//! // One observation: actor inputs of agent a (3 + 2 + 2) and b (3 + 2 + 1).
//! let actions = learner.act(&[vec![0.1; 7], vec![0.2; 6]], 1)?;
//! assert_eq!((actions[0].len(), actions[1].len()), (1, 2));
//! assert!(actions.iter().flatten().all(|a| a.abs() <= 1.0));
//!
//! let n = 8;
//! let batch = Batch { size: n, obs: vec![0.5; n * 4], next_obs: vec![0.4; n * 4], goals: vec![0.0; n * 2],
//!     actions: vec![0.1; n * 3], actor_inputs: vec![vec![0.3; n * 7], vec![0.3; n * 6]],
//!     next_actor_inputs: vec![vec![0.2; n * 7], vec![0.2; n * 6]], task_rewards: vec![-1.0; n],
//!     features: vec![], rewards: vec![vec![-1.0; n]; 2], q_bounds: vec![(-100.0, 0.0); 2] };
//! let stats = learner.learn(&batch)?;
//! assert_eq!(stats.critic_loss.len(), 2);
//! learner.update_targets()?;
//! assert_eq!(learner.consensus_params(0)?.len(), 16 * 16 + 16);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

#![warn(missing_docs)]

mod config;
mod error;
mod learner;
mod net;
mod normalizer;
mod state;

/// burn's device type, re-exported for [`DdpgLearner::with_parts`] (e.g. `Device::flex()`).
pub use burn::tensor::Device;
pub use config::DdpgConfig;
pub use error::NnError;
pub use learner::DdpgLearner;
pub use net::{Actor, Critic, FlatAdam, NetShape};
pub use normalizer::Normalizer;

/// Everything needed for typical use: `use fmsr_nn::prelude::*;`.
pub mod prelude {
    pub use crate::{Actor, Critic, DdpgConfig, DdpgLearner, Device, FlatAdam, NetShape, NnError, Normalizer};
    pub use fmsr_core::agent::{Agent, SaveState};
}
