//! The learners' saved state: one serde structure in the framing of
//! [`fmsr_core::persist`] (postcard behind a magic number, version and checksum), so a truncated or corrupted
//! file is an error, never a panic. `f32`/`f64` values are stored bit for bit,
//! so a restored learner continues exactly as the saved one would have.
//!
//! Networks are stored per agent as flat parameter vectors (the
//! [`crate::NetShape`] layout), optimiser states as burn's burnpack records of
//! the stacked modules, which are keyed by parameter ids; the learners derive
//! their ids from the network kind, so a learner built again from the same
//! config reads its own records back.

use std::ops::RangeInclusive;

use burn::optim::ModuleOptimizer;
use burn::tensor::Bytes;
use fmsr_core::persist::{self, FormatError};
use fmsr_core::replay::ReplayBuffer;
use rand_chacha::ChaCha8Rng;
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

use crate::error::{NnError, check_values};
use crate::group::Group;
use crate::learner::Learner;
use crate::net::Critics;
use crate::normalizer::Normalizer;

mod half;

/// An update rule's own state as a learner state holds it: a version of the
/// rule's choosing and the postcard bytes of a serde value.
///
/// ```
/// use fmsr_nn::RuleState;
/// let s = RuleState::encode(2, &vec![0.5f64, 1.0])?;
/// assert_eq!(s.decode::<Vec<f64>>("demo", 1..=2)?, vec![0.5, 1.0]);
/// assert!(s.decode::<Vec<f64>>("demo", 3..=3).is_err(), "a version this reader does not know");
/// # Ok::<(), fmsr_nn::NnError>(())
/// ```
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct RuleState {
    /// The layout's version, checked by the rule that reads it.
    pub version: u32,
    /// postcard bytes of the value.
    pub bytes: Vec<u8>,
}

impl RuleState {
    /// `value` as version `version`.
    ///
    /// # Errors
    /// [`NnError::Backend`] when the value does not encode.
    pub fn encode<T: Serialize>(version: u32, value: &T) -> Result<Self, NnError> {
        let bytes = postcard::to_allocvec(value)
            .map_err(|e| NnError::Backend { what: "update rule state", reason: e.to_string() })?;
        Ok(Self { version, bytes })
    }

    /// The value, when its version is one of `versions`; `rule` names the rule in errors.
    ///
    /// # Errors
    /// [`NnError::StateMismatch`] for another version, [`NnError::CorruptState`] for bytes that do not decode.
    pub fn decode<T: DeserializeOwned>(&self, rule: &str, versions: RangeInclusive<u32>) -> Result<T, NnError> {
        if !versions.contains(&self.version) {
            return Err(NnError::StateMismatch {
                what: format!("{rule} state version"),
                expected: format!("{} to {}", versions.start(), versions.end()),
                found: self.version.to_string(),
            });
        }
        postcard::from_bytes(&self.bytes)
            .map_err(|e| NnError::CorruptState { offset: 0, reason: format!("{rule} state: {e}") })
    }
}

const MAGIC: &[u8; 8] = b"FMSRNNST";

/// The version of [`LearnerState`]'s layout: 7, the update rule's own state
/// an optional versioned record ([`RuleState`]: absent for a rule without
/// state), the agents' networks stacked in groups, each group with one
/// optimiser record per kind. States of other versions are refused with
/// [`NnError::CorruptState`] naming the version this build reads.
const STATE_FORMAT: u32 = 7;

/// How a state is framed: [`fmsr_core::persist`]'s header (magic, version,
/// checksum) with the kind of state named in errors.
struct Framing {
    format: persist::Format,
    what: &'static str,
}

/// The whole learner ([`LearnerState`]).
const LEARNER: Framing = Framing { format: persist::Format::new(MAGIC, STATE_FORMAT), what: "learner state" };

/// A learner state: its body and the update rule's own state.
fn decode_learner(bytes: &[u8]) -> Result<(LearnerBody, Option<RuleState>), NnError> {
    if half::is_half(bytes) {
        let state = half::unpack(bytes)?;
        return Ok((state.learner, state.rule));
    }
    match persist::decode::<LearnerState>(&LEARNER.format, bytes) {
        Ok(state) => Ok((state.learner, state.rule)),
        Err(FormatError::Version { found, .. }) => Err(NnError::CorruptState {
            offset: 8,
            reason: format!("learner state of format {found}; this build reads format {STATE_FORMAT}"),
        }),
        Err(_) => decode::<LearnerState>(&LEARNER, bytes).map(|state| (state.learner, state.rule)),
    }
}

/// The acting half ([`PolicyState`]): version 2.
const POLICY: Framing = Framing { format: persist::Format::new(b"FMSRNNPO", 2), what: "policy state" };

/// The header of [`fmsr_core::persist`], then the postcard body.
fn encode<T: Serialize>(framing: &Framing, value: &T) -> Result<Vec<u8>, NnError> {
    persist::encode(&framing.format, value).map_err(|e| NnError::Backend { what: framing.what, reason: e.to_string() })
}

/// The inverse of [`encode`]; the error names the byte where reading failed.
fn decode<T: DeserializeOwned>(framing: &Framing, bytes: &[u8]) -> Result<T, NnError> {
    persist::decode(&framing.format, bytes).map_err(|e| {
        let offset = match e {
            FormatError::Magic { .. } | FormatError::Encode(_) => 0,
            FormatError::Version { .. } => 8,
            FormatError::Checksum => 12,
            FormatError::Body(_) => persist::HEADER_LEN,
        };
        NnError::CorruptState { offset, reason: format!("{}: {e}", framing.what) }
    })
}

impl Learner {
    /// The learner's state; `rule` carries the update rule's own.
    pub(crate) fn save(
        &self,
        algorithm: &str,
        include_storage: bool,
        rule: Option<RuleState>,
    ) -> Result<Vec<u8>, NnError> {
        let mut agents = Vec::with_capacity(self.num_agents());
        let (mut actor_optim, mut critic_optim) = (Vec::new(), Vec::new());
        for group in &self.groups {
            let nets = &group.nets;
            let critic_flats = |cs: &Critics| -> Result<Vec<Vec<Vec<f32>>>, NnError> {
                cs.nets.iter().map(|c| c.to_flats(&group.critic_layout)).collect()
            };
            let actors = nets.actors.to_flats(&group.actor_layout)?;
            let targets = nets.actor_targets.to_flats(&group.actor_layout)?;
            let (critics, critic_targets) = (critic_flats(&nets.critics)?, critic_flats(&nets.critic_targets)?);
            for (k, i) in group.agents.clone().enumerate() {
                agents.push(AgentState {
                    actor: actors[k].clone(),
                    actor_target: targets[k].clone(),
                    critics: critics.iter().map(|c| c[k].clone()).collect(),
                    critic_targets: critic_targets.iter().map(|c| c[k].clone()).collect(),
                    actor_norm: self.actor_norms[i].clone(),
                });
            }
            actor_optim.push(optim_bytes(&nets.actor_optim)?);
            critic_optim.push(optim_bytes(&nets.critic_optim)?);
        }
        let learner = LearnerBody {
            algorithm: algorithm.to_owned(),
            agents,
            group_sizes: self.groups.iter().map(|g| g.len() as u64).collect(),
            actor_optim,
            critic_optim,
            critic_norm: self.critic_norm.clone(),
            rng: self.rng.clone(),
            steps: self.steps,
            replay: include_storage.then(|| self.replay.clone()),
        };
        encode(&LEARNER, &LearnerState { learner, rule })
    }

    /// Restores a state written by [`Learner::save`]. `rule` turns the saved
    /// rule state into the rule's and checks it
    /// before anything of this learner changes; its result is returned. With
    /// `thinned`, a state of [`crate::rescue_state`]: absent targets are
    /// restored as the online networks, absent optimiser moments as fresh ones.
    pub(crate) fn load<S>(
        &mut self,
        algorithm: &str,
        bytes: &[u8],
        thinned: bool,
        rule: impl FnOnce(Option<RuleState>) -> Result<S, NnError>,
    ) -> Result<S, NnError> {
        let (mut state, saved) = decode_learner(bytes)?;
        if thinned {
            state.fill_thinned();
        }
        let mismatch =
            |what: &str, expected: String, found: String| NnError::StateMismatch { what: what.into(), expected, found };
        if state.algorithm != algorithm {
            return Err(mismatch("algorithm", algorithm.into(), state.algorithm));
        }
        if state.agents.len() != self.num_agents() {
            return Err(mismatch("agents", self.num_agents().to_string(), state.agents.len().to_string()));
        }
        let sizes: Vec<u64> = self.groups.iter().map(|g| g.len() as u64).collect();
        if state.group_sizes != sizes
            || state.actor_optim.len() != sizes.len()
            || state.critic_optim.len() != sizes.len()
        {
            return Err(mismatch(
                "agent groups (networks.stacking; shared critics need one group)",
                format!("{sizes:?}"),
                format!("{:?}", state.group_sizes),
            ));
        }
        for (i, s) in state.agents.iter().enumerate() {
            self.check_agent_state(i, s)?;
        }
        for group in &self.groups {
            check_critic_sharing(group, &state.agents[group.agents.clone()])?;
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
        crate::device::check_load_device()?;
        let load = |o: &ModuleOptimizer, bytes: &[u8], what: &str| {
            o.clone()
                .from_bytes(Bytes::from_bytes_vec(bytes.to_vec()))
                .map_err(|e| NnError::CorruptState { offset: 0, reason: format!("{what} optimizer: {e:?}") })
        };
        let rule = rule(saved)?;
        let mut optims = Vec::with_capacity(self.groups.len());
        for (g, group) in self.groups.iter().enumerate() {
            // A thinned state without moments keeps this learner's fresh optimisers.
            let fresh = |o: &ModuleOptimizer, bytes: &[u8], what: &str| {
                if thinned && bytes.is_empty() { Ok(o.clone()) } else { load(o, bytes, what) }
            };
            optims.push((
                fresh(&group.nets.actor_optim, &state.actor_optim[g], "actor")?,
                fresh(&group.nets.critic_optim, &state.critic_optim[g], "critic")?,
            ));
        }
        for (group, (actor, critic)) in self.groups.iter_mut().zip(optims) {
            restore_group(group, &state.agents[group.agents.clone()]);
            group.nets.actor_optim = actor;
            group.nets.critic_optim = critic;
        }
        self.actor_norms = state.agents.into_iter().map(|a| a.actor_norm).collect();
        self.critic_norm = state.critic_norm;
        self.rng = state.rng;
        self.steps = state.steps;
        if let Some(replay) = state.replay {
            self.replay = replay;
        }
        Ok(rule)
    }

    /// Checks agent `i`'s saved networks and normaliser against this learner's shapes.
    fn check_agent_state(&self, i: usize, s: &AgentState) -> Result<(), NnError> {
        let (g, k) = self.locate(i)?;
        let group = &self.groups[g];
        let check = |what: String, flat: &[f32], expected: usize| check_values(|| what.clone(), flat, expected);
        self.check_actor_state(i, &s.actor, &s.actor_norm)?;
        let actor_len = group.actor_layout.shapes[k].num_params();
        check(format!("agent {i} target actor"), &s.actor_target, actor_len)
            .map_err(|e| state_mismatch(i, "actor", e))?;
        let critics = group.nets.critics.nets.len();
        if s.critics.len() != critics || s.critic_targets.len() != critics {
            return Err(NnError::StateMismatch {
                what: format!("agent {i} critics"),
                expected: critics.to_string(),
                found: s.critics.len().to_string(),
            });
        }
        let critic_len = group.critic_layout.shapes[k].num_params();
        for (c, t) in s.critics.iter().zip(&s.critic_targets) {
            check(format!("agent {i} critic"), c, critic_len)
                .and_then(|()| check(format!("agent {i} target critic"), t, critic_len))
                .map_err(|e| state_mismatch(i, "critic", e))?;
        }
        Ok(())
    }
}

/// Checks that saved critics fit the group's [`crate::CriticTying`]. The
/// state stores every agent's whole critic, so sharing shows in the values:
/// a layer held once is equal, bit for bit, across the agents, while the
/// critics of agents that do not share start from draws of their own, and
/// their input layers (which no information sharing mixes) never meet.
fn check_critic_sharing(group: &Group, agents: &[AgentState]) -> Result<(), NnError> {
    let layout = &group.critic_layout;
    if agents.len() < 2 {
        return Ok(());
    }
    let end = |k: usize| layout.shapes[0].offset(k);
    let equal = |flats: Vec<&Vec<f32>>, end: usize| flats.iter().all(|f| f.get(..end) == flats[0].get(..end));
    let found = |shared: bool| if shared { "critics shared by the agents" } else { "a critic per agent" };
    for c in 0..agents[0].critics.len() {
        let online: Vec<&Vec<f32>> = agents.iter().map(|a| &a.critics[c]).collect();
        let target: Vec<&Vec<f32>> = agents.iter().map(|a| &a.critic_targets[c]).collect();
        let ok = if layout.shared > 0 {
            equal(online, end(layout.shared)) && equal(target, end(layout.shared))
        } else {
            !equal(online, end(1))
        };
        if !ok {
            return Err(NnError::StateMismatch {
                what: "critics (networks.critic)".into(),
                expected: found(layout.shared > 0).into(),
                found: found(layout.shared == 0).into(),
            });
        }
    }
    Ok(())
}

/// Rebuilds a group's networks from its agents' checked states, with the same ids.
fn restore_group(group: &mut Group, agents: &[AgentState]) {
    let column = |f: &dyn Fn(&AgentState) -> Vec<f32>| agents.iter().map(f).collect::<Vec<_>>();
    let nets = &mut group.nets;
    nets.actors = nets.actors.with_flats(&group.actor_layout, &column(&|a| a.actor.clone()));
    nets.actor_targets = nets.actor_targets.with_flats(&group.actor_layout, &column(&|a| a.actor_target.clone()));
    for c in 0..nets.critics.nets.len() {
        let online = column(&|a| a.critics[c].clone());
        let target = column(&|a| a.critic_targets[c].clone());
        nets.critics.nets[c] = nets.critics.nets[c].with_flats(&group.critic_layout, &online);
        nets.critic_targets.nets[c] = nets.critic_targets.nets[c].with_flats(&group.critic_layout, &target);
    }
    group.act_cache = None;
}

/// One agent's networks in its own [`crate::NetShape`] layout (whatever the
/// stacking), so states do not depend on how the learner batches its agents.
#[derive(Serialize, Deserialize)]
struct AgentState {
    actor: Vec<f32>,
    actor_target: Vec<f32>,
    critics: Vec<Vec<f32>>,
    critic_targets: Vec<Vec<f32>>,
    actor_norm: Normalizer,
}

/// A learner state of format 7: its body, then the rule's own state.
#[derive(Serialize, Deserialize)]
struct LearnerState {
    learner: LearnerBody,
    rule: Option<RuleState>,
}

/// Everything of a learner state but the update rule's own state.
#[derive(Serialize, Deserialize)]
struct LearnerBody {
    algorithm: String,
    agents: Vec<AgentState>,
    /// The number of agents of each group ([`crate::Stacking`]).
    group_sizes: Vec<u64>,
    /// burn's record of each group's actor Adam (moments of the stacked parameters).
    actor_optim: Vec<Vec<u8>>,
    /// The same for the critics.
    critic_optim: Vec<Vec<u8>>,
    critic_norm: Normalizer,
    rng: ChaCha8Rng,
    steps: u64,
    replay: Option<ReplayBuffer>,
}

/// What a rescue point keeps of a learner's state ([`rescue_state`]).
///
/// A rescue point is what survives the loss of a run's machine: small enough
/// to commit at every record, a learner state without the replay buffer.
/// Sizes for the paper's networks (six agents, 3 x 256, MADDPG), measured on
/// a lite run's checkpoint: the whole state 31.1 MB; the online networks
/// about 7.8 MB, each further part about as much again.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum RescueLevel {
    /// The online actors and critics, normalisers, RNG, counters and the
    /// update rule's state; the targets restored as the online networks
    /// (polyak 0.95 keeps them a few cycles behind), Adam's moments restored
    /// fresh (about a quarter of the whole state). The default, by
    /// measurement: lite egg runs restarted from it after 20 of 40 epochs
    /// ended within the interval of the same runs uninterrupted (two seeds
    /// pooled, test success 76 % against 74 %, the difference's interval
    /// [-10, +6] points; `docs/design.md`, "Rescue points").
    #[default]
    Online,
    /// As `Online`, the online networks stored at half precision (`f16`,
    /// each parameter within about 5e-4 of itself; about half of `Online`).
    Half,
    /// As `Online`, with the target networks (about half).
    Targets,
    /// Everything but the replay buffer: bit for bit what a checkpoint holds.
    Full,
}

impl RescueLevel {
    /// The name in configs and records.
    #[must_use]
    pub fn key(self) -> &'static str {
        match self {
            Self::Online => "online",
            Self::Half => "half",
            Self::Targets => "targets",
            Self::Full => "full",
        }
    }

    /// What a restart from this level loses beside the replay buffer, in words.
    #[must_use]
    pub fn loses(self) -> &'static str {
        match self {
            Self::Online => "the replay buffer, the target networks (restored as the online ones) and Adam's moments",
            Self::Half => {
                "the replay buffer, the target networks (restored as the online ones), Adam's moments and the networks' precision below f16"
            }
            Self::Targets => "the replay buffer and Adam's moments",
            Self::Full => "the replay buffer",
        }
    }
}

/// A learner state ([`fmsr_core::Algorithm::save_state`], as a checkpoint
/// holds it) thinned to `level` for a rescue point: never the replay buffer;
/// below [`RescueLevel::Full`] the targets and optimiser moments are left
/// empty, which [`fmsr_core::Algorithm::load_rescue_state`] restores as the
/// online networks and fresh moments (and which a whole-state reader refuses).
/// The result is a learner state of this build's format; at
/// [`RescueLevel::Half`], one whose networks are `f16` (the module `half`).
///
/// # Errors
/// [`NnError::CorruptState`] when `learner_state` is not a learner state of
/// this build; [`NnError::InvalidConfig`] at `Half` for a parameter beyond `f16`'s range.
pub fn rescue_state(learner_state: &[u8], level: RescueLevel) -> Result<Vec<u8>, NnError> {
    let (mut body, rule) = decode_learner(learner_state)?;
    body.replay = None;
    if level != RescueLevel::Full {
        body.actor_optim.iter_mut().chain(&mut body.critic_optim).for_each(Vec::clear);
    }
    if matches!(level, RescueLevel::Online | RescueLevel::Half) {
        for a in &mut body.agents {
            a.actor_target.clear();
            a.critic_targets.iter_mut().for_each(Vec::clear);
        }
    }
    let state = LearnerState { learner: body, rule };
    if level == RescueLevel::Half { half::pack(state) } else { encode(&LEARNER, &state) }
}

impl LearnerBody {
    /// Fills what [`rescue_state`] left empty: targets as the online networks.
    /// (Empty optimiser records are kept empty: [`Learner::load`] keeps its
    /// fresh optimisers for them.)
    fn fill_thinned(&mut self) {
        for a in &mut self.agents {
            if a.actor_target.is_empty() {
                a.actor_target.clone_from(&a.actor);
            }
            for (t, c) in a.critic_targets.iter_mut().zip(&a.critics) {
                if t.is_empty() {
                    t.clone_from(c);
                }
            }
        }
    }
}

fn optim_bytes(o: &ModuleOptimizer) -> Result<Vec<u8>, NnError> {
    o.into_bytes()
        .map(|b| b.to_vec())
        .map_err(|e| NnError::Backend { what: "optimizer state", reason: format!("{e:?}") })
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

/// The acting half of a learner: each agent's actor, in its own
/// [`crate::NetShape`] layout, and its input normaliser. No critics, targets,
/// optimiser state, RNG or replay: what a trained policy file carries, and
/// independent of the stacking and the device it was trained with.
#[derive(Serialize, Deserialize)]
struct PolicyState {
    algorithm: String,
    actors: Vec<ActorState>,
}

#[derive(Serialize, Deserialize)]
struct ActorState {
    actor: Vec<f32>,
    actor_norm: Normalizer,
}

/// The policy state ([`fmsr_core::policy::PolicyState::save_policy`]) held in
/// a whole learner state (`Algorithm::save_state`, as a checkpoint stores it):
/// every agent's actor and input normaliser, without building a learner, so a
/// run trained with any stacking or device exports on any machine.
///
/// # Errors
/// [`NnError::CorruptState`] when `learner_state` is not a learner state of this build.
pub fn policy_from_learner_state(learner_state: &[u8]) -> Result<Vec<u8>, NnError> {
    let (state, _) = decode_learner(learner_state)?;
    let actors = state.agents.into_iter().map(|a| ActorState { actor: a.actor, actor_norm: a.actor_norm }).collect();
    encode(&POLICY, &PolicyState { algorithm: state.algorithm, actors })
}

/// The precision of a policy state's actors (its normalisers are always kept whole).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PolicyPrecision {
    /// `f32`, as trained: bit for bit the learner's actors.
    #[default]
    Full,
    /// `f16` (each parameter within about 5e-4 of itself; about half the
    /// bytes): for shipping, where the policy's evaluations hold.
    Half,
}

impl PolicyPrecision {
    /// The name in commands and records.
    #[must_use]
    pub fn key(self) -> &'static str {
        match self {
            Self::Full => "full",
            Self::Half => "half",
        }
    }

    /// The precision of a policy state's bytes, by their framing (no check of
    /// the rest: reading them does that).
    #[must_use]
    pub fn of(policy: &[u8]) -> Self {
        if half::is_half_policy(policy) { Self::Half } else { Self::Full }
    }
}

/// A policy state (of either precision) at `precision`. From `Half` to
/// `Full` the values are the `f32` nearest each `f16`, not the trained ones.
///
/// # Errors
/// [`NnError::CorruptState`] when `policy` is not a policy state;
/// [`NnError::InvalidConfig`] at `Half` for a parameter beyond `f16`'s range.
pub fn policy_at_precision(policy: &[u8], precision: PolicyPrecision) -> Result<Vec<u8>, NnError> {
    let state = decode_policy(policy)?;
    match precision {
        PolicyPrecision::Full => encode(&POLICY, &state),
        PolicyPrecision::Half => half::pack_policy(state),
    }
}

/// A policy state of either precision, its actors as `f32`.
fn decode_policy(bytes: &[u8]) -> Result<PolicyState, NnError> {
    if half::is_half_policy(bytes) { half::unpack_policy(bytes) } else { decode(&POLICY, bytes) }
}

impl Learner {
    /// The acting state alone: every agent's actor and input normaliser.
    pub(crate) fn save_policy(&self, algorithm: &str) -> Result<Vec<u8>, NnError> {
        let mut actors = Vec::with_capacity(self.num_agents());
        for group in &self.groups {
            let flats = group.nets.actors.to_flats(&group.actor_layout)?;
            for (flat, i) in flats.into_iter().zip(group.agents.clone()) {
                actors.push(ActorState { actor: flat, actor_norm: self.actor_norms[i].clone() });
            }
        }
        encode(&POLICY, &PolicyState { algorithm: algorithm.to_owned(), actors })
    }

    /// Restores a state written by [`Learner::save_policy`] (or
    /// [`policy_from_learner_state`], at either [`PolicyPrecision`]): the actors (their targets set equal)
    /// and their normalisers; critics, optimisers, RNG and replay stay as
    /// they are. Everything is checked before anything changes.
    pub(crate) fn load_policy(&mut self, algorithm: &str, bytes: &[u8]) -> Result<(), NnError> {
        let state = decode_policy(bytes)?;
        if state.algorithm != algorithm {
            return Err(NnError::StateMismatch {
                what: "algorithm".into(),
                expected: algorithm.into(),
                found: state.algorithm,
            });
        }
        if state.actors.len() != self.num_agents() {
            return Err(NnError::StateMismatch {
                what: "agents".into(),
                expected: self.num_agents().to_string(),
                found: state.actors.len().to_string(),
            });
        }
        for (i, a) in state.actors.iter().enumerate() {
            self.check_actor_state(i, &a.actor, &a.actor_norm)?;
        }
        for group in &mut self.groups {
            let flats: Vec<Vec<f32>> = state.actors[group.agents.clone()].iter().map(|a| a.actor.clone()).collect();
            let nets = &mut group.nets;
            nets.actors = nets.actors.with_flats(&group.actor_layout, &flats);
            nets.actor_targets = nets.actor_targets.with_flats(&group.actor_layout, &flats);
            group.act_cache = None;
        }
        self.actor_norms = state.actors.into_iter().map(|a| a.actor_norm).collect();
        Ok(())
    }

    /// Checks agent `i`'s saved actor and normaliser against this learner's
    /// shapes (of a whole state and of a policy state alike).
    fn check_actor_state(&self, i: usize, actor: &[f32], norm: &Normalizer) -> Result<(), NnError> {
        let (g, k) = self.locate(i)?;
        let expected = self.groups[g].actor_layout.shapes[k].num_params();
        check_values(|| format!("agent {i} actor"), actor, expected).map_err(|e| state_mismatch(i, "actor", e))?;
        if norm.dim() != self.actor_norms[i].dim() {
            return Err(NnError::StateMismatch {
                what: format!("agent {i} actor normaliser"),
                expected: self.actor_norms[i].dim().to_string(),
                found: norm.dim().to_string(),
            });
        }
        Ok(())
    }
}
