//! The learners' saved state: one serde structure in the framing of
//! [`fmsr_core::persist`] (postcard behind a magic number, version and checksum), so a truncated or corrupted
//! file is an error, never a panic. `f32`/`f64` values are stored bit for bit,
//! so a restored learner continues exactly as the saved one would have.
//!
//! Networks are stored as flat parameter vectors (the [`crate::NetShape`]
//! layout), optimiser states as burn's burnpack records, which are keyed by
//! parameter ids; the learners derive their ids from (agent, network), so a
//! learner built again from the same config reads its own records back.

use burn::optim::ModuleOptimizer;
use burn::tensor::Bytes;
use fmsr_core::persist::{self, FormatError};
use fmsr_core::replay::ReplayBuffer;
use rand_chacha::ChaCha8Rng;
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

use crate::error::{NnError, check_values};
use crate::learner::{AgentNets, Learner};
use crate::net::{Critic, Critics};
use crate::normalizer::Normalizer;

const MAGIC: &[u8; 8] = b"FMSRNNST";

/// The version of [`LearnerState`]'s layout.
const STATE_FORMAT: u32 = 3;

/// The header of [`fmsr_core::persist`], then the postcard body.
pub(crate) fn encode<T: Serialize>(value: &T) -> Result<Vec<u8>, NnError> {
    persist::encode(MAGIC, STATE_FORMAT, value).map_err(|e| NnError::Backend { what: "state", reason: e.to_string() })
}

/// The inverse of [`encode`].
pub(crate) fn decode<T: DeserializeOwned>(bytes: &[u8]) -> Result<T, NnError> {
    persist::decode(MAGIC, STATE_FORMAT, bytes).map_err(|e| {
        let offset = match e {
            FormatError::Magic { .. } | FormatError::Encode(_) => 0,
            FormatError::Version { .. } => 8,
            FormatError::Checksum => 12,
            FormatError::Body(_) => persist::HEADER_LEN,
        };
        NnError::CorruptState { offset, reason: format!("learner state: {e}") }
    })
}

impl Learner {
    /// The learner's state; `extra` carries the algorithm's own.
    pub(crate) fn save(&self, algorithm: &str, include_storage: bool, extra: Vec<f64>) -> Result<Vec<u8>, NnError> {
        let agents = self
            .agents
            .iter()
            .map(|a| {
                Ok(AgentState {
                    actor: a.actor.to_flat()?,
                    actor_target: a.actor_target.to_flat()?,
                    critics: a.critics.nets.iter().map(Critic::to_flat).collect::<Result<_, _>>()?,
                    critic_targets: a.critic_targets.nets.iter().map(Critic::to_flat).collect::<Result<_, _>>()?,
                    actor_optim: optim_bytes(&a.actor_optim)?,
                    critic_optim: optim_bytes(&a.critic_optim)?,
                    actor_norm: a.actor_norm.clone(),
                })
            })
            .collect::<Result<Vec<_>, NnError>>()?;
        let state = LearnerState {
            algorithm: algorithm.to_owned(),
            agents,
            critic_norm: self.critic_norm.clone(),
            rng: self.rng.clone(),
            steps: self.steps,
            replay: include_storage.then(|| self.replay.clone()),
            extra,
        };
        crate::state::encode(&state)
    }

    /// Restores a state written by [`Learner::save`]; returns its `extra`.
    pub(crate) fn load(&mut self, algorithm: &str, bytes: &[u8]) -> Result<Vec<f64>, NnError> {
        let state: LearnerState = crate::state::decode(bytes)?;
        let mismatch =
            |what: &str, expected: String, found: String| NnError::StateMismatch { what: what.into(), expected, found };
        if state.algorithm != algorithm {
            return Err(mismatch("algorithm", algorithm.into(), state.algorithm));
        }
        if state.agents.len() != self.agents.len() {
            return Err(mismatch("agents", self.agents.len().to_string(), state.agents.len().to_string()));
        }
        let mut restored = Vec::with_capacity(self.agents.len());
        for (i, (a, s)) in self.agents.iter().zip(state.agents).enumerate() {
            restored.push(restore_agent(i, a, s)?);
        }
        if let Some(replay) = &state.replay {
            if !replay.is_compatible(self.layout.spec()) {
                return Err(mismatch("replay buffer", "this environment's spec".into(), "another spec".into()));
            }
            replay.check_consistency().map_err(|e| NnError::CorruptState { offset: 0, reason: e.to_string() })?;
        }
        if state.critic_norm.dim() != self.critic_norm.dim() {
            return Err(mismatch(
                "critic normaliser",
                self.critic_norm.dim().to_string(),
                state.critic_norm.dim().to_string(),
            ));
        }
        self.agents = restored;
        self.critic_norm = state.critic_norm;
        self.rng = state.rng;
        self.steps = state.steps;
        if let Some(replay) = state.replay {
            self.replay = replay;
        }
        self.act_cache = None;
        Ok(state.extra)
    }
}

#[derive(Serialize, Deserialize)]
struct AgentState {
    actor: Vec<f32>,
    actor_target: Vec<f32>,
    critics: Vec<Vec<f32>>,
    critic_targets: Vec<Vec<f32>>,
    actor_optim: Vec<u8>,
    critic_optim: Vec<u8>,
    actor_norm: Normalizer,
}

#[derive(Serialize, Deserialize)]
struct LearnerState {
    algorithm: String,
    agents: Vec<AgentState>,
    critic_norm: Normalizer,
    rng: ChaCha8Rng,
    steps: u64,
    replay: Option<ReplayBuffer>,
    extra: Vec<f64>,
}

fn optim_bytes(o: &ModuleOptimizer) -> Result<Vec<u8>, NnError> {
    o.into_bytes()
        .map(|b| b.to_vec())
        .map_err(|e| NnError::Backend { what: "optimizer state", reason: format!("{e:?}") })
}

fn restore_agent(i: usize, a: &AgentNets, s: AgentState) -> Result<AgentNets, NnError> {
    let check = |what: String, flat: &[f32], expected: usize| check_values(|| what.clone(), flat, expected);
    let actor_len = a.actor.shape().num_params();
    check(format!("agent {i} actor"), &s.actor, actor_len)
        .and_then(|()| check(format!("agent {i} target actor"), &s.actor_target, actor_len))
        .map_err(|e| state_mismatch(i, "actor", e))?;
    if s.critics.len() != a.critics.nets.len() || s.critic_targets.len() != a.critics.nets.len() {
        return Err(NnError::StateMismatch {
            what: format!("agent {i} critics"),
            expected: a.critics.nets.len().to_string(),
            found: s.critics.len().to_string(),
        });
    }
    let critic_len = a.critics.nets[0].shape().num_params();
    for (c, t) in s.critics.iter().zip(&s.critic_targets) {
        check(format!("agent {i} critic"), c, critic_len)
            .and_then(|()| check(format!("agent {i} target critic"), t, critic_len))
            .map_err(|e| state_mismatch(i, "critic", e))?;
    }
    if s.actor_norm.dim() != a.actor_norm.dim() {
        return Err(NnError::StateMismatch {
            what: format!("agent {i} actor normaliser"),
            expected: a.actor_norm.dim().to_string(),
            found: s.actor_norm.dim().to_string(),
        });
    }
    let load = |o: &ModuleOptimizer, bytes: Vec<u8>| {
        o.clone()
            .from_bytes(Bytes::from_bytes_vec(bytes))
            .map_err(|e| NnError::CorruptState { offset: 0, reason: format!("agent {i} optimizer: {e:?}") })
    };
    Ok(AgentNets {
        actor: a.actor.with_flat(&s.actor),
        actor_target: a.actor_target.with_flat(&s.actor_target),
        critics: Critics { nets: a.critics.nets.iter().zip(&s.critics).map(|(c, f)| c.with_flat(f)).collect() },
        critic_targets: Critics {
            nets: a.critic_targets.nets.iter().zip(&s.critic_targets).map(|(c, f)| c.with_flat(f)).collect(),
        },
        actor_optim: load(&a.actor_optim, s.actor_optim)?,
        critic_optim: load(&a.critic_optim, s.critic_optim)?,
        actor_norm: s.actor_norm,
    })
}

fn state_mismatch(i: usize, what: &str, e: NnError) -> NnError {
    match e {
        NnError::Dimension { expected, found, .. } => NnError::StateMismatch {
            what: format!("agent {i} {what} parameters"),
            expected: expected.to_string(),
            found: found.to_string(),
        },
        other => other,
    }
}
