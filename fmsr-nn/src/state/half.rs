//! Half-precision learner states, for the smallest rescue points
//! ([`super::RescueLevel::Half`]): a learner state thinned as `online`, whose
//! online networks are stored as IEEE 754 binary16 (`f16`) values and read
//! back as the `f32` nearest to each, about half the bytes of `online`.
//!
//! ```text
//! magic "FMSRNNHF" | version 1 (u32, LE) | CRC-32C (u64, LE) | body (postcard)
//! body: state  (a learner state of format 7 whose agents' actor and critic flats are empty)
//!     | lens   (each emptied flat's length: agent by agent, the actor, then each critic)
//!     | values (those flats in that order, 2 bytes each, little-endian f16)
//! ```
//!
//! Rounding to `f16` moves each parameter by at most 2^-11 of itself (about
//! 5e-4) for magnitudes in `[6.1e-5, 65504]`; smaller ones keep an absolute
//! error below 3e-8 (subnormals), larger ones would overflow and are refused.

use burn::tensor::f16;
use fmsr_core::persist;
use serde::{Deserialize, Serialize};

use super::{Framing, LearnerState, decode, encode};
use crate::error::NnError;

const HALF: Framing = Framing { format: persist::Format::new(b"FMSRNNHF", 1), what: "half-precision learner state" };

#[derive(Serialize, Deserialize)]
struct HalfState {
    state: LearnerState,
    lens: Vec<u64>,
    values: Vec<u8>,
}

/// Whether `bytes` are framed as a half-precision learner state.
pub(super) fn is_half(bytes: &[u8]) -> bool {
    bytes.starts_with(HALF.format.magic)
}

/// `state` (thinned as `online`) with its online networks as `f16`.
///
/// # Errors
/// [`NnError::InvalidConfig`] for a parameter beyond `f16`'s range.
pub(super) fn pack(mut state: LearnerState) -> Result<Vec<u8>, NnError> {
    let (mut lens, mut values) = (Vec::new(), Vec::new());
    for (i, agent) in state.learner.agents.iter_mut().enumerate() {
        for flat in std::iter::once(&mut agent.actor).chain(agent.critics.iter_mut()) {
            lens.push(flat.len() as u64);
            for &v in flat.iter() {
                let h = f16::from_f32(v);
                if h.is_infinite() != v.is_infinite() {
                    return Err(NnError::InvalidConfig {
                        key: "rescue --keep half",
                        reason: format!("agent {i} has a parameter {v} beyond f16's range; keep `online`"),
                    });
                }
                values.extend_from_slice(&h.to_bits().to_le_bytes());
            }
            flat.clear();
        }
    }
    encode(&HALF, &HalfState { state, lens, values })
}

/// The learner state of [`pack`]'s bytes, its networks as `f32` again.
///
/// # Errors
/// [`NnError::CorruptState`] for bytes that are not one, or whose lengths do not add up.
pub(super) fn unpack(bytes: &[u8]) -> Result<LearnerState, NnError> {
    let HalfState { mut state, lens, values } = decode(&HALF, bytes)?;
    let corrupt = |reason: String| NnError::CorruptState { offset: persist::HEADER_LEN, reason };
    let flats = state.learner.agents.iter().map(|a| 1 + a.critics.len()).sum::<usize>();
    let total = lens.iter().try_fold(0u64, |s, &l| s.checked_add(l));
    if lens.len() != flats || total.and_then(|t| t.checked_mul(2)) != Some(values.len() as u64) {
        return Err(corrupt(format!(
            "{}: {} flats of {} values in {} bytes, for {flats} networks",
            HALF.what,
            lens.len(),
            total.map_or_else(|| "too many".into(), |t| t.to_string()),
            values.len()
        )));
    }
    let mut halves = values.chunks_exact(2).map(|b| f16::from_bits(u16::from_le_bytes([b[0], b[1]])).to_f32());
    let mut lens = lens.into_iter();
    for agent in &mut state.learner.agents {
        for flat in std::iter::once(&mut agent.actor).chain(agent.critics.iter_mut()) {
            let len = lens.next().unwrap_or(0) as usize;
            *flat = halves.by_ref().take(len).collect();
        }
    }
    Ok(state)
}
