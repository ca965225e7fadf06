//! [`SaveState`] for [`DdpgLearner`]: a small self-checking binary format.
//!
//! Layout (little endian): the magic `b"FMSRNN\0\x01"`, a `u64` length and a
//! JSON header (format version, agent count, network shapes, normaliser
//! dims), then for every agent its online actor, target actor, actor Adam
//! (`t`, `m`, `v`), online critic, target critic, critic Adam and actor
//! normaliser (`sum`, `sumsq`, `count`), then the critic normaliser, each
//! vector as a `u64` length and its values; last a `u64` FNV-1a hash of
//! everything before it. `f32`/`f64` values are stored bit for bit, so a
//! restored learner continues exactly as the saved one would have.
//!
//! Hyperparameters are not part of the state: the learner keeps its own
//! config (a checkpoint is resumed with the run's config).

use fmsr_core::agent::SaveState;
use serde::{Deserialize, Serialize};

use crate::error::NnError;
use crate::learner::DdpgLearner;
use crate::net::{FlatAdam, NetShape};

const MAGIC: &[u8; 8] = b"FMSRNN\0\x01";
const FORMAT: u32 = 1;

#[derive(Debug, Serialize, Deserialize, PartialEq)]
struct Header {
    format: u32,
    agents: usize,
    actor_shapes: Vec<NetShape>,
    critic_shape: NetShape,
    actor_norm_dims: Vec<usize>,
    critic_norm_dim: usize,
}

fn fnv1a(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

struct Writer(Vec<u8>);

impl Writer {
    fn u64(&mut self, v: u64) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn f32s(&mut self, v: &[f32]) {
        self.u64(v.len() as u64);
        for x in v {
            self.0.extend_from_slice(&x.to_le_bytes());
        }
    }
    fn f64s(&mut self, v: &[f64]) {
        self.u64(v.len() as u64);
        for x in v {
            self.0.extend_from_slice(&x.to_le_bytes());
        }
    }
}

struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn take(&mut self, n: usize) -> Result<&[u8], NnError> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.bytes.len()).ok_or_else(|| NnError::CorruptState {
            offset: self.at,
            reason: format!("truncated: need {n} more bytes, {} left", self.bytes.len() - self.at),
        })?;
        let s = &self.bytes[self.at..end];
        self.at = end;
        Ok(s)
    }
    fn u64(&mut self) -> Result<u64, NnError> {
        let mut b = [0u8; 8];
        b.copy_from_slice(self.take(8)?);
        Ok(u64::from_le_bytes(b))
    }
    fn len(&mut self, what: &str, expected: usize) -> Result<usize, NnError> {
        let found = self.u64()?;
        if found != expected as u64 {
            return Err(NnError::StateMismatch {
                what: format!("length of {what}"),
                expected: expected.to_string(),
                found: found.to_string(),
            });
        }
        Ok(expected)
    }
    fn f32s(&mut self, what: &str, expected: usize) -> Result<Vec<f32>, NnError> {
        let n = self.len(what, expected)?;
        let raw = self.take(n.saturating_mul(4))?;
        Ok(raw.chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect())
    }
    fn f64s(&mut self, what: &str, expected: usize) -> Result<Vec<f64>, NnError> {
        let n = self.len(what, expected)?;
        let raw = self.take(n.saturating_mul(8))?;
        Ok(raw.chunks_exact(8).map(|c| f64::from_le_bytes([c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]])).collect())
    }
}

impl DdpgLearner {
    fn header(&self) -> Header {
        Header {
            format: FORMAT,
            agents: self.agents.len(),
            actor_shapes: self.agents.iter().map(|a| a.actor_shape.clone()).collect(),
            critic_shape: self.critic_shape.clone(),
            actor_norm_dims: self.agents.iter().map(|a| a.actor_norm.dim()).collect(),
            critic_norm_dim: self.critic_norm.dim(),
        }
    }
}

fn write_adam(w: &mut Writer, a: &FlatAdam) {
    w.u64(a.t);
    w.f32s(&a.m);
    w.f32s(&a.v);
}

fn read_adam(r: &mut Reader<'_>, what: &str, n: usize) -> Result<FlatAdam, NnError> {
    let t = r.u64()?;
    let m = r.f32s(&format!("{what} Adam m"), n)?;
    let v = r.f32s(&format!("{what} Adam v"), n)?;
    Ok(FlatAdam { t, m, v })
}

fn mismatch(what: &str, expected: impl std::fmt::Debug, found: impl std::fmt::Debug) -> NnError {
    NnError::StateMismatch { what: what.to_owned(), expected: format!("{expected:?}"), found: format!("{found:?}") }
}

impl SaveState for DdpgLearner {
    fn save_state(&self) -> Result<Vec<u8>, NnError> {
        let header = serde_json::to_vec(&self.header())
            .map_err(|e| NnError::Backend { what: "state header", reason: e.to_string() })?;
        let mut w = Writer(Vec::new());
        w.0.extend_from_slice(MAGIC);
        w.u64(header.len() as u64);
        w.0.extend_from_slice(&header);
        for a in &self.agents {
            w.f32s(&a.actor);
            w.f32s(&a.actor_target);
            write_adam(&mut w, &a.actor_adam);
            w.f32s(&a.critic);
            w.f32s(&a.critic_target);
            write_adam(&mut w, &a.critic_adam);
            let (s, q, c) = a.actor_norm.stats();
            w.f64s(s);
            w.f64s(q);
            w.f64s(&[c]);
        }
        let (s, q, c) = self.critic_norm.stats();
        w.f64s(s);
        w.f64s(q);
        w.f64s(&[c]);
        let hash = fnv1a(&w.0);
        w.u64(hash);
        Ok(w.0)
    }

    fn load_state(&mut self, bytes: &[u8]) -> Result<(), NnError> {
        if bytes.len() < MAGIC.len() + 16 {
            return Err(NnError::CorruptState { offset: 0, reason: format!("only {} bytes", bytes.len()) });
        }
        if &bytes[..MAGIC.len()] != MAGIC {
            return Err(NnError::CorruptState { offset: 0, reason: "not an fmsr-nn learner state (bad magic)".into() });
        }
        let body_len = bytes.len() - 8;
        let mut stored = [0u8; 8];
        stored.copy_from_slice(&bytes[body_len..]);
        if u64::from_le_bytes(stored) != fnv1a(&bytes[..body_len]) {
            return Err(NnError::CorruptState { offset: body_len, reason: "checksum mismatch".into() });
        }
        let mut r = Reader { bytes: &bytes[..body_len], at: MAGIC.len() };
        let header_len = usize::try_from(r.u64()?).unwrap_or(usize::MAX);
        let header_at = r.at;
        let header: Header = serde_json::from_slice(r.take(header_len)?)
            .map_err(|e| NnError::CorruptState { offset: header_at, reason: format!("header: {e}") })?;
        let mine = self.header();
        if header.format != FORMAT {
            return Err(mismatch("format version", FORMAT, header.format));
        }
        if header.agents != mine.agents {
            return Err(mismatch("number of agents", mine.agents, header.agents));
        }
        for (i, (m, h)) in mine.actor_shapes.iter().zip(&header.actor_shapes).enumerate() {
            if m != h {
                return Err(mismatch(&format!("actor {i} layers"), &m.layers, &h.layers));
            }
        }
        if header.critic_shape != mine.critic_shape {
            return Err(mismatch("critic layers", &mine.critic_shape.layers, &header.critic_shape.layers));
        }
        if header.actor_norm_dims != mine.actor_norm_dims || header.critic_norm_dim != mine.critic_norm_dim {
            return Err(mismatch(
                "normaliser dims",
                (&mine.actor_norm_dims, mine.critic_norm_dim),
                (&header.actor_norm_dims, header.critic_norm_dim),
            ));
        }
        // Read everything before touching the learner, so a failure leaves it unchanged.
        let mut agents = self.agents.clone();
        for (i, a) in agents.iter_mut().enumerate() {
            let (na, nc, nd) = (a.actor.len(), a.critic.len(), a.actor_norm.dim());
            a.actor = r.f32s(&format!("actor {i}"), na)?;
            a.actor_target = r.f32s(&format!("target actor {i}"), na)?;
            a.actor_adam = read_adam(&mut r, &format!("actor {i}"), na)?;
            a.critic = r.f32s(&format!("critic {i}"), nc)?;
            a.critic_target = r.f32s(&format!("target critic {i}"), nc)?;
            a.critic_adam = read_adam(&mut r, &format!("critic {i}"), nc)?;
            let s = r.f64s(&format!("actor {i} normaliser sum"), nd)?;
            let q = r.f64s(&format!("actor {i} normaliser sumsq"), nd)?;
            let c = r.f64s(&format!("actor {i} normaliser count"), 1)?;
            a.actor_norm.set_stats(s, q, c[0]);
        }
        let nd = self.critic_norm.dim();
        let s = r.f64s("critic normaliser sum", nd)?;
        let q = r.f64s("critic normaliser sumsq", nd)?;
        let c = r.f64s("critic normaliser count", 1)?;
        if r.at != body_len {
            return Err(NnError::CorruptState { offset: r.at, reason: format!("{} trailing bytes", body_len - r.at) });
        }
        self.critic_norm.set_stats(s, q, c[0]);
        self.agents = agents;
        self.invalidate();
        Ok(())
    }
}
