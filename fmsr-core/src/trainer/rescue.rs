//! Rescue points ([`RescuePoint`]): their file format, writing and reading,
//! and restarting a run from one.

use std::path::Path;

use rand::RngExt;
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

use super::checkpoint::CheckpointMeta;
use super::{Trainer, algo_err};
use crate::algorithm::Algorithm;
use crate::env::Env;
use crate::error::CoreError;
use crate::persist;
use crate::policy::ActMode;
use crate::shadow::{OccupancyEstimator, ShadowReward};

/// The rescue point format (version 1, CRC-32C).
const FORMAT: persist::Format = persist::Format::new(b"FMSRRESC", 1);

#[derive(Serialize, Deserialize)]
struct RescueFile {
    meta: String,
    algorithm: Vec<u8>,
    keeps: String,
}

/// A rescue point: a run's training state without its replay buffer, small
/// enough to keep in a repository, from which a run whose machine (its
/// checkpoint and replay log with it) was lost goes on.
///
/// ```text
/// magic "FMSRRESC" | format version (u32, LE) | CRC-32C of the body (u64, LE) | body (postcard)
/// body: meta (JSON: the trainer's configuration, loop state with its RNG, counters
///       and history, the occupancy estimate, env steps, workers)
///     | algorithm (its state without storage, possibly thinned by its own tools)
///     | keeps (what the algorithm's part keeps, in the algorithm's words)
/// ```
///
/// Version 1. The trainer's part is a checkpoint's ([`Trainer::save_checkpoint`]),
/// whole; the algorithm's is [`Algorithm::save_state`] without storage, which
/// the algorithm may thin (fmsr-nn's `rescue_state`: `online` keeps the online
/// networks, normalisers, RNG and counters, restores the targets as the
/// online networks and Adam's moments fresh). A file of another version, a
/// truncated or a corrupted one is refused with [`CoreError::Corrupt`] naming
/// what is wrong before any of it is used.
///
/// Restarting ([`Trainer::restore_rescue`]) loses the replay buffer:
/// the run records the episodes it lost as its replay floor (a later
/// checkpoint's replay log starts there), collects `refill` exploring
/// episodes into the empty buffer before its next update, and goes on; the
/// restart is in the run's history ([`Restart`]).
#[derive(Debug, Clone, PartialEq)]
pub struct RescuePoint {
    /// The trainer's part, as a checkpoint holds it (JSON).
    meta: String,
    /// The algorithm's state without storage, as [`RescuePoint::keeps`] says.
    pub algorithm: Vec<u8>,
    /// What the algorithm's part keeps (fmsr-nn: `online`, `targets`, `full`).
    pub keeps: String,
    /// Epochs trained.
    pub epoch: usize,
    /// Env steps collected.
    pub env_steps: u64,
    /// Episodes stored into the replay buffer over the run (all lost at a restart).
    pub stored_episodes: u64,
}

/// What a restart from a rescue point did, as the run's records keep it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Restart {
    /// Epochs trained when the rescue point was taken (the restart's first epoch).
    pub epoch: usize,
    /// What the rescue point kept of the algorithm's state.
    pub keeps: String,
    /// The run's replay floor after the restart: every episode stored before
    /// it (store indices below this, counted from the run's start) is gone.
    /// Not the buffer's content: that is [`Restart::buffer_episodes`].
    pub lost_episodes: u64,
    /// Episodes the replay buffer held when the rescue point was taken, all
    /// lost: those stored since the run's start or its previous restart, at
    /// most the buffer's capacity ([`Algorithm::storage_capacity`]). `None`
    /// in records of older binaries, which did not count it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub buffer_episodes: Option<u64>,
    /// Exploring episodes collected into the empty buffer before the next update.
    pub refill_episodes: usize,
}

#[derive(Deserialize)]
struct Progress {
    epoch: usize,
    stored_episodes: u64,
}

#[derive(Deserialize)]
struct MetaView {
    state: Progress,
    env_steps: u64,
    workers: usize,
}

impl RescuePoint {
    /// The rescue point of the checkpoint at `path` (worker 0's file of a
    /// one-process run), its algorithm's part as the checkpoint holds it
    /// (`keeps` names what that part keeps); thin it with the algorithm's
    /// tools and say so in `keeps`.
    ///
    /// # Errors
    /// [`CoreError::Io`]; [`CoreError::Corrupt`] for a file that is not a
    /// checkpoint of this build; [`CoreError::InvalidConfig`] for a run of
    /// several worker processes (their other workers' states are not in it).
    pub fn from_checkpoint(path: &Path, keeps: &str) -> Result<Self, CoreError> {
        let (meta, algorithm) = super::checkpoint::read_checkpoint_parts(path)?;
        Self::new(meta, algorithm, keeps.into(), path)
    }

    fn new(meta: String, algorithm: Vec<u8>, keeps: String, path: &Path) -> Result<Self, CoreError> {
        let view: MetaView =
            serde_json::from_str(&meta).map_err(|e| CoreError::Corrupt { path: path.into(), reason: e.to_string() })?;
        if view.workers != 1 {
            return Err(CoreError::InvalidConfig {
                key: "rescue point".into(),
                reason: format!(
                    "{} is of a run of {} worker processes; rescue points are of one-process runs",
                    path.display(),
                    view.workers
                ),
            });
        }
        Ok(Self {
            meta,
            algorithm,
            keeps,
            epoch: view.state.epoch,
            env_steps: view.env_steps,
            stored_episodes: view.state.stored_episodes,
        })
    }

    /// The file's bytes.
    ///
    /// # Errors
    /// [`CoreError::Corrupt`] when the body cannot be encoded.
    pub fn to_bytes(&self) -> Result<Vec<u8>, CoreError> {
        let file = RescueFile { meta: self.meta.clone(), algorithm: self.algorithm.clone(), keeps: self.keeps.clone() };
        persist::encode(&FORMAT, &file)
            .map_err(|e| CoreError::Corrupt { path: "rescue point".into(), reason: e.to_string() })
    }

    /// Writes the rescue point to `path`, atomically.
    ///
    /// # Errors
    /// I/O errors.
    pub fn write(&self, path: &Path) -> Result<(), CoreError> {
        persist::write_atomic(path, &self.to_bytes()?)
    }

    /// Reads a rescue point; `path` names it in errors.
    ///
    /// # Errors
    /// [`CoreError::Corrupt`] for another format or version, a truncated or a
    /// corrupted file; [`CoreError::InvalidConfig`] as [`Self::from_checkpoint`].
    pub fn from_bytes(bytes: &[u8], path: &Path) -> Result<Self, CoreError> {
        let file: RescueFile = persist::decode(&FORMAT, bytes)
            .map_err(|e| CoreError::Corrupt { path: path.into(), reason: format!("rescue point: {e}") })?;
        Self::new(file.meta, file.algorithm, file.keeps, path)
    }

    /// Reads the rescue point at `path`.
    ///
    /// # Errors
    /// [`CoreError::Io`], and as [`Self::from_bytes`].
    pub fn read(path: &Path) -> Result<Self, CoreError> {
        let bytes = std::fs::read(path).map_err(|source| CoreError::Io { path: path.into(), source })?;
        Self::from_bytes(&bytes, path)
    }
}

impl<E, A, O, S> Trainer<E, A, O, S>
where
    E: Env + Send,
    A: Algorithm,
    O: OccupancyEstimator + Serialize + DeserializeOwned,
    S: ShadowReward,
{
    /// Restarts this (new, one-process) trainer from `rescue`: the loop's
    /// state, the occupancy estimate and the algorithm's state
    /// ([`Algorithm::load_rescue_state`]), with an empty replay buffer; then
    /// `refill` exploring episodes collected and stored (their features
    /// observed by the occupancy estimate, as any collected episode's)
    /// before the next update. The configuration must be the run's, except
    /// `epochs`, `envs` and `threads`, as for a checkpoint.
    ///
    /// # Errors
    /// [`CoreError::InvalidConfig`] (another configuration, several
    /// workers), [`CoreError::Corrupt`], the algorithm's and the environment's errors.
    pub fn restore_rescue(&mut self, rescue: &RescuePoint, refill: usize) -> Result<Restart, CoreError> {
        if self.comm.workers() != 1 {
            return Err(CoreError::InvalidConfig {
                key: "rescue point".into(),
                reason: "a rescue point restarts a one-process run".into(),
            });
        }
        let path = Path::new("rescue point");
        let meta: CheckpointMeta<O> = serde_json::from_str(&rescue.meta)
            .map_err(|e| CoreError::Corrupt { path: path.into(), reason: e.to_string() })?;
        self.check_meta(&meta, path)?;
        self.algorithm.load_rescue_state(&rescue.algorithm).map_err(algo_err)?;
        self.shadow.restore(meta.occupancy);
        self.collector.restore(meta.env_steps);
        self.log = crate::replay_log::ReplayLog::default();
        self.state = meta.state;
        let held = (self.state.stored_episodes.saturating_sub(self.state.replay_floor))
            .min(self.algorithm.storage_capacity() as u64);
        self.state.replay_floor = self.state.stored_episodes;
        let seeds: Vec<u64> = (0..refill).map(|_| self.state.rng.random::<u64>()).collect();
        let episodes = self.collector.rollouts(&mut self.algorithm, &seeds, ActMode::Explore)?;
        for episode in &episodes {
            self.algorithm.store(episode).map_err(algo_err)?;
        }
        self.observe_every_worker(&episodes)?;
        for episode in episodes {
            self.log.push(episode, self.algorithm.storage_capacity());
            self.state.stored_episodes += 1;
        }
        let restart = Restart {
            epoch: self.state.epoch,
            keeps: rescue.keeps.clone(),
            lost_episodes: self.state.replay_floor,
            buffer_episodes: Some(held),
            refill_episodes: refill,
        };
        self.state.restarts.push(restart.clone());
        Ok(restart)
    }
}
