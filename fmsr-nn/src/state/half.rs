//! Half-precision states: the smallest rescue points
//! ([`super::RescueLevel::Half`]) and the smallest policy files
//! ([`super::PolicyPrecision::Half`]). Their networks are stored as IEEE 754
//! binary16 (`f16`) values and read back as the `f32` nearest to each, about
//! half the bytes of the `f32` state.
//!
//! ```text
//! magic "FMSRNNHF" | version 1 (u32, LE) | CRC-32C (u64, LE) | body (postcard)
//! body: state  (a learner state of format 7 whose agents' actor and critic flats are empty)
//!     | lens   (each emptied flat's length: agent by agent, the actor, then each critic)
//!     | values (those flats in that order, 2 bytes each, little-endian f16)
//!
//! magic "FMSRNNPH" | version 1 (u32, LE) | CRC-32C (u64, LE) | body (postcard)
//! body: state  (a policy state whose actors' flats are empty; normalisers kept as they are)
//!     | lens   (each actor's length, agent by agent)
//!     | values (those flats in that order, 2 bytes each, little-endian f16)
//! ```
//!
//! Rounding to `f16` moves each parameter by at most 2^-11 of itself (about
//! 5e-4) for magnitudes in `[6.1e-5, 65504]`; smaller ones keep an absolute
//! error below 3e-8 (subnormals), larger ones would overflow and are refused.

use burn::tensor::f16;
use fmsr_core::persist;
use serde::{Deserialize, Serialize};

use super::{Framing, LearnerState, PolicyState, decode, encode};
use crate::error::NnError;

const HALF: Framing = Framing { format: persist::Format::new(b"FMSRNNHF", 1), what: "half-precision learner state" };

const HALF_POLICY: Framing =
    Framing { format: persist::Format::new(b"FMSRNNPH", 1), what: "half-precision policy state" };

/// A state whose networks' flats were emptied into `lens` and `values`.
#[derive(Serialize, Deserialize)]
struct Halved<S> {
    state: S,
    lens: Vec<u64>,
    values: Vec<u8>,
}

/// Whether `bytes` are framed as a half-precision learner state.
pub(super) fn is_half(bytes: &[u8]) -> bool {
    bytes.starts_with(HALF.format.magic)
}

/// Empties `flats` into `f16` values, each flat's length in `lens`.
///
/// # Errors
/// [`NnError::InvalidConfig`] under `key` for a parameter beyond `f16`'s
/// range, naming the flat's agent and `keep`, what to keep instead.
fn halve<'a>(
    flats: impl Iterator<Item = (usize, &'a mut Vec<f32>)>,
    key: &'static str,
    keep: &str,
) -> Result<(Vec<u64>, Vec<u8>), NnError> {
    let (mut lens, mut values) = (Vec::new(), Vec::new());
    for (i, flat) in flats {
        lens.push(flat.len() as u64);
        values.reserve(2 * flat.len());
        for &v in flat.iter() {
            let h = f16::from_f32(v);
            if h.is_infinite() != v.is_infinite() {
                return Err(NnError::InvalidConfig {
                    key,
                    reason: format!("agent {i} has a parameter {v} beyond f16's range; keep {keep}"),
                });
            }
            values.extend_from_slice(&h.to_bits().to_le_bytes());
        }
        flat.clear();
    }
    Ok((lens, values))
}

/// Fills `flats` (`count` of them) from [`halve`]'s `lens` and `values`.
///
/// # Errors
/// [`NnError::CorruptState`] when the lengths do not add up to the values or
/// do not match the flats.
fn unhalve<'a>(
    flats: impl Iterator<Item = &'a mut Vec<f32>>,
    count: usize,
    lens: Vec<u64>,
    values: &[u8],
    what: &str,
) -> Result<(), NnError> {
    let total = lens.iter().try_fold(0u64, |s, &l| s.checked_add(l));
    if lens.len() != count || total.and_then(|t| t.checked_mul(2)) != Some(values.len() as u64) {
        return Err(NnError::CorruptState {
            offset: persist::HEADER_LEN,
            reason: format!(
                "{what}: {} flats of {} values in {} bytes, for {count} networks",
                lens.len(),
                total.map_or_else(|| "too many".into(), |t| t.to_string()),
                values.len()
            ),
        });
    }
    let mut halves = values.chunks_exact(2).map(|b| f16::from_bits(u16::from_le_bytes([b[0], b[1]])).to_f32());
    for (flat, len) in flats.zip(lens) {
        *flat = halves.by_ref().take(len as usize).collect();
    }
    Ok(())
}

/// `state` (thinned as `online`) with its online networks as `f16`.
///
/// # Errors
/// [`NnError::InvalidConfig`] for a parameter beyond `f16`'s range.
pub(super) fn pack(mut state: LearnerState) -> Result<Vec<u8>, NnError> {
    let flats =
        state.learner.agents.iter_mut().enumerate().flat_map(|(i, agent)| {
            std::iter::once(&mut agent.actor).chain(agent.critics.iter_mut()).map(move |f| (i, f))
        });
    let (lens, values) = halve(flats, "rescue --keep half", "`online`")?;
    encode(&HALF, &Halved { state, lens, values })
}

/// The learner state of [`pack`]'s bytes, its networks as `f32` again.
///
/// # Errors
/// [`NnError::CorruptState`] for bytes that are not one, or whose lengths do not add up.
pub(super) fn unpack(bytes: &[u8]) -> Result<LearnerState, NnError> {
    let Halved { mut state, lens, values } = decode::<Halved<LearnerState>>(&HALF, bytes)?;
    let count = state.learner.agents.iter().map(|a| 1 + a.critics.len()).sum::<usize>();
    let flats = state
        .learner
        .agents
        .iter_mut()
        .flat_map(|agent| std::iter::once(&mut agent.actor).chain(agent.critics.iter_mut()));
    unhalve(flats, count, lens, &values, HALF.what)?;
    Ok(state)
}

/// Whether `bytes` are framed as a half-precision policy state.
pub(super) fn is_half_policy(bytes: &[u8]) -> bool {
    bytes.starts_with(HALF_POLICY.format.magic)
}

/// `state` with its actors as `f16` (the normalisers as they are).
///
/// # Errors
/// [`NnError::InvalidConfig`] for a parameter beyond `f16`'s range.
pub(super) fn pack_policy(mut state: PolicyState) -> Result<Vec<u8>, NnError> {
    let flats = state.actors.iter_mut().enumerate().map(|(i, a)| (i, &mut a.actor));
    let (lens, values) = halve(flats, "export --precision half", "the full precision")?;
    encode(&HALF_POLICY, &Halved { state, lens, values })
}

/// The policy state of [`pack_policy`]'s bytes, its actors as `f32` again.
///
/// # Errors
/// [`NnError::CorruptState`] for bytes that are not one, or whose lengths do not add up.
pub(super) fn unpack_policy(bytes: &[u8]) -> Result<PolicyState, NnError> {
    let Halved { mut state, lens, values } = decode::<Halved<PolicyState>>(&HALF_POLICY, bytes)?;
    let count = state.actors.len();
    unhalve(state.actors.iter_mut().map(|a| &mut a.actor), count, lens, &values, HALF_POLICY.what)?;
    Ok(state)
}
