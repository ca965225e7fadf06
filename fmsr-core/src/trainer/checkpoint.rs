//! The checkpoint of a run: its format (the trainer's part, the algorithm's
//! bytes, each worker's file) and its layout on disk (worker 0's file commits a
//! checkpoint; the other workers' files and every worker's replay log beside it).

use std::path::{Path, PathBuf};

use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

use super::{EpochStats, Trainer, TrainerConfig, TrainerState, algo_err};
use crate::algorithm::Algorithm;
use crate::env::Env;
use crate::error::CoreError;
use crate::persist;
use crate::replay_log::ReplayLog;
use crate::shadow::OccupancyEstimator;
use crate::shadow::ShadowReward;

/// Version 4 (CRC-32C; 3 began the [`persist`] framing with the replay in
/// the replay log).
const FORMAT: persist::Format = persist::Format::new(b"FMSRCKPT", 4);

/// A checkpoint file: the trainer's part as JSON (the configuration's tagged
/// enums need a self-describing format), the algorithm's as its own bytes.
#[derive(Serialize, Deserialize)]
struct CheckpointFile {
    meta: String,
    algorithm: Vec<u8>,
}

#[derive(Serialize, Deserialize)]
pub(super) struct CheckpointMeta<O> {
    pub(super) config: TrainerConfig,
    pub(super) state: TrainerState,
    pub(super) occupancy: O,
    pub(super) env_steps: u64,
    /// Worker processes of the run, and which one this file belongs to.
    pub(super) workers: usize,
    pub(super) rank: usize,
}

/// A checkpoint file's two parts: the trainer's (JSON) and the algorithm's bytes.
pub(super) fn read_checkpoint_parts(path: &Path) -> Result<(String, Vec<u8>), CoreError> {
    let corrupt = |reason: String| CoreError::Corrupt { path: path.into(), reason };
    let bytes = std::fs::read(path).map_err(|source| CoreError::Io { path: path.into(), source })?;
    let file: CheckpointFile = persist::decode(&FORMAT, &bytes).map_err(|e| corrupt(e.to_string()))?;
    Ok((file.meta, file.algorithm))
}

/// What a checkpoint holds for a reader that does not train: how far the run
/// got and the algorithm's state (e.g. to take its policy out, `fmsr export`).
#[derive(Debug, Clone, PartialEq)]
pub struct CheckpointContents {
    /// Epochs trained when the checkpoint was written.
    pub epoch: usize,
    /// Env steps collected by then (this worker's).
    pub env_steps: u64,
    /// The algorithm's state ([`Algorithm::save_state`] without storage).
    pub algorithm: Vec<u8>,
    /// The per-epoch statistics up to the checkpoint, as the trainer kept
    /// them: `metrics.jsonl` is written after the checkpoint, so a reader of a
    /// run that trains can find it one epoch behind; this never is.
    pub history: Vec<EpochStats>,
}

/// Reads worker 0's checkpoint file written by [`Trainer::save_checkpoint`]
/// without building a trainer (any occupancy estimator, any configuration).
///
/// # Errors
/// [`CoreError::Io`]; [`CoreError::Corrupt`] for a file that is not a
/// checkpoint of this build, truncated or corrupted.
pub fn read_checkpoint_contents(path: &Path) -> Result<CheckpointContents, CoreError> {
    #[derive(Deserialize)]
    struct Progress {
        epoch: usize,
        #[serde(default)]
        history: Vec<EpochStats>,
    }
    #[derive(Deserialize)]
    struct Meta {
        state: Progress,
        env_steps: u64,
    }
    let corrupt = |reason: String| CoreError::Corrupt { path: path.into(), reason };
    let bytes = std::fs::read(path).map_err(|source| CoreError::Io { path: path.into(), source })?;
    let file: CheckpointFile = persist::decode(&FORMAT, &bytes).map_err(|e| corrupt(e.to_string()))?;
    let meta: Meta = serde_json::from_str(&file.meta).map_err(|e| corrupt(e.to_string()))?;
    Ok(CheckpointContents {
        epoch: meta.state.epoch,
        env_steps: meta.env_steps,
        algorithm: file.algorithm,
        history: meta.state.history,
    })
}

/// What one worker contributes to a checkpoint: its checkpoint file and its
/// new replay segment (name and bytes).
#[derive(Serialize, Deserialize)]
struct WorkerFiles {
    checkpoint: Vec<u8>,
    segment: Option<(String, Vec<u8>)>,
}

/// A worker's files, versioned with the checkpoint.
const WORKER_FORMAT: persist::Format = persist::Format { magic: b"FMSRWRKR", ..FORMAT };

/// The checkpoint file of worker `rank` at `epoch`: `path` itself for worker 0
/// (the file whose rename commits a checkpoint), else
/// `<stem>.worker<rank>.e<epoch>.<ext>` beside it.
fn worker_path(path: &Path, rank: usize, epoch: usize) -> PathBuf {
    if rank == 0 {
        return path.to_path_buf();
    }
    let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let ext = path.extension().map(|e| e.to_string_lossy().into_owned()).unwrap_or_default();
    path.with_file_name(format!("{stem}.worker{rank}.e{epoch:06}.{ext}"))
}

/// The replay log folder of worker `rank`: [`ReplayLog::dir`] for worker 0,
/// else `<stem>.worker<rank>.replay`.
fn worker_replay_dir(path: &Path, rank: usize) -> PathBuf {
    if rank == 0 {
        return ReplayLog::dir(path);
    }
    let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    path.with_file_name(format!("{stem}.worker{rank}.replay"))
}

/// Deletes the checkpoint files of workers `1..workers` from other epochs than `epoch`.
fn remove_stale_worker_files(path: &Path, workers: usize, epoch: usize) -> Result<(), CoreError> {
    let dir = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let current: Vec<PathBuf> = (1..workers).map(|r| worker_path(path, r, epoch)).collect();
    let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let prefix = format!("{stem}.worker");
    let entries = std::fs::read_dir(dir).map_err(|source| CoreError::Io { path: dir.into(), source })?;
    for entry in entries.flatten() {
        let p = entry.path();
        let name = entry.file_name().to_string_lossy().into_owned();
        let stale = name.starts_with(&prefix) && p.extension() == path.extension() && !current.contains(&p);
        if stale && p.is_file() {
            std::fs::remove_file(&p).map_err(|source| CoreError::Io { path: p.clone(), source })?;
        }
    }
    Ok(())
}

impl<E, A, O, S> Trainer<E, A, O, S>
where
    E: Env + Send,
    A: Algorithm,
    O: OccupancyEstimator + Serialize + DeserializeOwned,
    S: ShadowReward,
{
    /// Writes a checkpoint of everything training needs to continue: the
    /// algorithm's state (networks, optimisers, normalisers, RNG), the trainer's
    /// RNG, counters and history, and the occupancy estimate, to `path`; and the
    /// episodes stored since the previous checkpoint to the replay log beside it
    /// ([`ReplayLog::dir`]). Resuming continues exactly as an uninterrupted run.
    /// Every file is written atomically, in an order that leaves a loadable
    /// checkpoint whenever the process is killed (see [`crate::replay_log`]).
    ///
    /// With several workers every worker calls this; worker 0 gathers and
    /// writes every worker's files (`<stem>.worker<r>.e<epoch>.<ext>` and
    /// `<stem>.worker<r>.replay/` beside `path`), its own last.
    ///
    /// # Errors
    /// I/O errors, and errors of the algorithm's `save_state`.
    pub fn save_checkpoint(&mut self, path: &Path) -> Result<(), CoreError> {
        let files = WorkerFiles {
            segment: self.log.take_segment(self.state.stored_episodes)?,
            checkpoint: self.checkpoint_bytes(path)?,
        };
        let all = if self.comm.workers() <= 1 {
            vec![files]
        } else {
            let corrupt = |e: persist::FormatError| CoreError::Corrupt { path: path.into(), reason: e.to_string() };
            let bytes = persist::encode(&WORKER_FORMAT, &files).map_err(corrupt)?;
            let Some(gathered) = self.comm.gather_bytes(bytes) else { return Ok(()) };
            gathered.iter().map(|b| persist::decode(&WORKER_FORMAT, b).map_err(corrupt)).collect::<Result<_, _>>()?
        };
        self.write_checkpoint_files(path, all)
    }

    /// This worker's checkpoint file.
    fn checkpoint_bytes(&self, path: &Path) -> Result<Vec<u8>, CoreError> {
        let meta = CheckpointMeta {
            config: self.config.clone(),
            state: self.state.clone(),
            occupancy: self.shadow.occupancy(),
            env_steps: self.collector.env_steps(),
            workers: self.comm.workers(),
            rank: self.comm.rank(),
        };
        let corrupt = |reason: String| CoreError::Corrupt { path: path.into(), reason };
        let meta = serde_json::to_string(&meta).map_err(|e| corrupt(e.to_string()))?;
        let algorithm = self.algorithm.save_state(false).map_err(algo_err)?;
        persist::encode(&FORMAT, &CheckpointFile { meta, algorithm }).map_err(|e| corrupt(e.to_string()))
    }

    /// Writes every worker's segment, then the other workers' checkpoints, then
    /// worker 0's (the commit), then prunes what the new checkpoint no longer needs.
    fn write_checkpoint_files(&self, path: &Path, all: Vec<WorkerFiles>) -> Result<(), CoreError> {
        let epoch = self.state.epoch;
        for (rank, files) in all.iter().enumerate() {
            if let Some((name, bytes)) = &files.segment {
                persist::write_atomic(&worker_replay_dir(path, rank).join(name), bytes)?;
            }
        }
        for (rank, files) in all.iter().enumerate().skip(1).chain(all.iter().enumerate().take(1)) {
            persist::write_atomic(&worker_path(path, rank, epoch), &files.checkpoint)?;
        }
        for rank in 0..all.len() {
            ReplayLog::prune(&worker_replay_dir(path, rank), self.window_start())?;
        }
        if all.len() > 1 { remove_stale_worker_files(path, all.len(), epoch) } else { Ok(()) }
    }

    /// Restores a checkpoint written by [`Trainer::save_checkpoint`], with the
    /// algorithm's storage read back from the replay log. The checkpoint must
    /// come from the same configuration, except `epochs`, which may be raised to
    /// train longer, and `envs` and `threads`, and from as many workers; each
    /// worker reads its own files. A corrupted, truncated or mismatched file is
    /// an error naming the problem.
    ///
    /// # Errors
    /// [`CoreError::Io`], [`CoreError::Corrupt`] (also for a damaged or missing
    /// replay log), [`CoreError::InvalidConfig`] (another configuration, or
    /// another number of workers) or the algorithm's error (another shape).
    pub fn load_checkpoint(&mut self, path: &Path) -> Result<(), CoreError> {
        let (rank, workers) = (self.comm.rank(), self.comm.workers());
        let (main, algorithm) = self.read_checkpoint(path)?;
        if main.workers != workers {
            return Err(CoreError::InvalidConfig {
                key: "checkpoint".into(),
                reason: format!(
                    "{} was written by a run of {} worker process(es), this one has {workers}: resume with as many \
                     (`mpirun -np {}`), or start a new run",
                    path.display(),
                    main.workers,
                    main.workers
                ),
            });
        }
        let own = worker_path(path, rank, main.state.epoch);
        let (meta, algorithm) = if rank == 0 { (main, algorithm) } else { self.read_checkpoint(&own)? };
        if meta.rank != rank {
            return Err(CoreError::Corrupt { path: own, reason: format!("holds worker {}'s state", meta.rank) });
        }
        self.apply_checkpoint(meta, &algorithm)?;
        let (from, to) = (self.window_start(), self.state.stored_episodes);
        let episodes = ReplayLog::read(&worker_replay_dir(path, rank), from, to)?;
        // After a restart from a rescue point the storage was refilled from
        // empty at the replay floor: it holds what a fresh one would after
        // `to - floor` episodes.
        self.algorithm.restore_storage(to - self.state.replay_floor, &episodes).map_err(algo_err)
    }

    /// As [`Trainer::load_checkpoint`] but leaves the algorithm's storage as it
    /// is and reads no replay log, and only worker 0's file: enough to evaluate
    /// the policy (of a run of any number of workers), not to train on.
    ///
    /// # Errors
    /// As [`Trainer::load_checkpoint`].
    pub fn load_checkpoint_without_storage(&mut self, path: &Path) -> Result<(), CoreError> {
        let (meta, algorithm) = self.read_checkpoint(path)?;
        self.apply_checkpoint(meta, &algorithm)
    }

    /// A checkpoint file's trainer part (checked against this trainer's
    /// configuration) and algorithm bytes.
    fn read_checkpoint(&self, path: &Path) -> Result<(CheckpointMeta<O>, Vec<u8>), CoreError> {
        let corrupt = |reason: String| CoreError::Corrupt { path: path.into(), reason };
        let (meta, algorithm) = read_checkpoint_parts(path)?;
        let meta: CheckpointMeta<O> = serde_json::from_str(&meta).map_err(|e| corrupt(e.to_string()))?;
        self.check_meta(&meta, path)?;
        Ok((meta, algorithm))
    }

    /// Checks a checkpoint's (or rescue point's) trainer part against this
    /// trainer: the same configuration but `epochs`, `threads` and `envs`, the
    /// same features.
    pub(super) fn check_meta(&self, meta: &CheckpointMeta<O>, path: &Path) -> Result<(), CoreError> {
        let corrupt = |reason: String| CoreError::Corrupt { path: path.into(), reason };
        let mut expected = self.config.clone();
        expected.epochs = meta.config.epochs;
        // Threads do not change the history; envs only batch the remaining
        // rollouts differently (and `fmsr eval` runs on one environment).
        expected.threads = meta.config.threads;
        expected.envs = meta.config.envs;
        if meta.config != expected {
            return Err(CoreError::InvalidConfig {
                key: "checkpoint".into(),
                reason: format!("{} was written with a different configuration", path.display()),
            });
        }
        if meta.occupancy.estimate().len() != self.env().spec().features.len() {
            return Err(corrupt("occupancy has a different number of features".into()));
        }
        Ok(())
    }

    fn apply_checkpoint(&mut self, meta: CheckpointMeta<O>, algorithm: &[u8]) -> Result<(), CoreError> {
        self.algorithm.load_state(algorithm).map_err(algo_err)?;
        self.shadow.restore(meta.occupancy);
        self.collector.restore(meta.env_steps);
        self.log = ReplayLog::default();
        self.state = meta.state;
        Ok(())
    }

    /// The store index of the oldest episode the algorithm's storage still holds.
    fn window_start(&self) -> u64 {
        let window = self.state.stored_episodes.saturating_sub(self.algorithm.storage_capacity() as u64);
        window.max(self.state.replay_floor)
    }
}
