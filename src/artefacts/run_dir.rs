//! Run directories: configuration, per-epoch logs, checkpoint and evaluation
//! of one training run, written so that a kill loses at most the current epoch.
//!
//! ```text
//! runs/<name>/config.toml      the resolved experiment
//! runs/<name>/provenance.json  the commit and build that started it
//! runs/<name>/checkpoint.bin   written atomically after every epoch
//! runs/<name>/checkpoint.replay/  the replay log: one segment of new episodes per checkpoint
//! runs/<name>/metrics.jsonl    one fmsr_core::trainer::EpochStats per line
//! runs/<name>/metrics.csv      the same, flat
//! runs/<name>/events.out.tfevents.*  the same for TensorBoard (one file per process)
//! runs/<name>/eval.json        written by `fmsr eval`
//! runs/<name>/eval-<engine>.json  `fmsr eval --engine` on the other engine
//! runs/<name>/eval[-<engine>]-validation.json  `fmsr eval --set validation`
//! runs/<name>/.lock            held by the one `fmsr train` writing the run
//! ```

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use fmsr_core::persist::write_atomic;
use fmsr_core::prelude::*;

use crate::error::ExperimentError;
use crate::experiment::{Engine, EpisodeSet, ExperimentConfig};
use crate::provenance::Provenance;
use fmsr_envs::shadow_hand::GoalDistance;

/// The writer lock of a run directory ([`RunDir::lock`]), released on drop.
#[derive(Debug)]
pub struct RunLock {
    _file: std::fs::File,
}

/// The files of one run.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RunDir {
    root: PathBuf,
}

impl RunDir {
    /// The run kept in `root`.
    #[must_use]
    pub fn new(root: impl Into<PathBuf>) -> Self {
        Self { root: root.into() }
    }

    /// The directory.
    #[must_use]
    pub fn root(&self) -> &Path {
        &self.root
    }

    /// `config.toml`.
    #[must_use]
    pub fn config(&self) -> PathBuf {
        self.root.join("config.toml")
    }

    /// `checkpoint.bin`.
    #[must_use]
    pub fn checkpoint(&self) -> PathBuf {
        self.root.join("checkpoint.bin")
    }

    /// `provenance.json`: the commit and build that started the run.
    #[must_use]
    pub fn provenance(&self) -> PathBuf {
        self.root.join("provenance.json")
    }

    /// Reads `provenance.json` (`None` for runs that predate it).
    ///
    /// # Errors
    /// [`ExperimentError::Io`] or [`ExperimentError::Parse`] for a file that exists but cannot be read.
    pub fn load_provenance(&self) -> Result<Option<Provenance>, ExperimentError> {
        let path = self.provenance();
        if !path.exists() {
            return Ok(None);
        }
        let text =
            std::fs::read_to_string(&path).map_err(|source| ExperimentError::Io { path: path.clone(), source })?;
        serde_json::from_str(&text)
            .map(Some)
            .map_err(|e| ExperimentError::parse_source(path, "not a run's provenance", e))
    }

    /// `metrics.jsonl`.
    #[must_use]
    pub fn metrics_jsonl(&self) -> PathBuf {
        self.root.join("metrics.jsonl")
    }

    /// `metrics.csv`.
    #[must_use]
    pub fn metrics_csv(&self) -> PathBuf {
        self.root.join("metrics.csv")
    }

    /// Where an evaluation on `engine` of a run trained on `trained_on` goes:
    /// `eval.json` on the training engine, else `eval-<engine>.json`.
    #[must_use]
    pub fn eval_json_on(&self, engine: Engine, trained_on: Engine) -> PathBuf {
        if engine == trained_on { self.eval_json() } else { self.root.join(format!("eval-{}.json", engine.key())) }
    }

    /// Where an evaluation on the episodes of `set` goes: the test set's at
    /// [`RunDir::eval_json_on`], the validation episodes' beside it with
    /// `-validation` (`eval-validation.json`, `eval-mujoco-validation.json`).
    #[must_use]
    pub fn eval_json_for(&self, engine: Engine, trained_on: Engine, set: EpisodeSet) -> PathBuf {
        let test = self.eval_json_on(engine, trained_on);
        match set {
            EpisodeSet::Test => test,
            EpisodeSet::Validation => test.with_file_name(format!(
                "{}-validation.json",
                test.file_stem().and_then(|s| s.to_str()).unwrap_or("eval")
            )),
        }
    }

    /// `eval.json`.
    #[must_use]
    pub fn eval_json(&self) -> PathBuf {
        self.root.join("eval.json")
    }

    /// `.lock`: the file `fmsr train` holds an exclusive lock on.
    #[must_use]
    pub fn lock_file(&self) -> PathBuf {
        self.root.join(".lock")
    }

    /// Takes the run's writer lock, creating the directory: an exclusive OS
    /// lock on [`RunDir::lock_file`], held until the [`RunLock`] is dropped or
    /// the process ends (a crash or `kill -9` releases it too), with this
    /// process's id, host and start time written into the file for whoever
    /// finds it held. Readers (`eval`, `export`, `render`) take no lock: every
    /// file they read is replaced atomically.
    ///
    /// # Errors
    /// [`ExperimentError::RunLocked`] naming the holder when another process
    /// holds it; [`ExperimentError::Io`] when the file cannot be made.
    pub fn lock(&self) -> Result<RunLock, ExperimentError> {
        use std::io::{Seek, Write};
        let io = |path: &Path| {
            let path = path.to_path_buf();
            move |source| ExperimentError::Io { path: path.clone(), source }
        };
        std::fs::create_dir_all(&self.root).map_err(io(&self.root))?;
        let path = self.lock_file();
        let mut file = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(&path)
            .map_err(io(&path))?;
        match file.try_lock() {
            Ok(()) => {}
            Err(std::fs::TryLockError::WouldBlock) => {
                let holder = std::fs::read_to_string(&path).unwrap_or_default().trim().to_owned();
                let holder = if holder.is_empty() { "a process that has not named itself yet".into() } else { holder };
                return Err(ExperimentError::RunLocked { dir: self.root.clone(), holder });
            }
            Err(std::fs::TryLockError::Error(source)) => return Err(ExperimentError::Io { path, source }),
        }
        let host = std::fs::read_to_string("/proc/sys/kernel/hostname").unwrap_or_default();
        let since = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs());
        let me = format!("pid {} on {} since {since} (Unix time)", std::process::id(), host.trim());
        file.set_len(0).and_then(|()| file.rewind()).and_then(|()| file.write_all(me.as_bytes())).map_err(io(&path))?;
        Ok(RunLock { _file: file })
    }

    /// Reads the run's configuration.
    pub fn load_config(&self) -> Result<ExperimentConfig, ExperimentError> {
        ExperimentConfig::load_saved(&self.config())
    }

    /// Reads the per-epoch statistics.
    pub fn load_metrics(&self) -> Result<Vec<EpochStats>, ExperimentError> {
        let path = self.metrics_jsonl();
        let text =
            std::fs::read_to_string(&path).map_err(|source| ExperimentError::Io { path: path.clone(), source })?;
        text.lines()
            .filter(|l| !l.trim().is_empty())
            .enumerate()
            .map(|(i, l)| {
                serde_json::from_str(l).map_err(|e| ExperimentError::parse_source(&path, format!("line {}", i + 1), e))
            })
            .collect()
    }

    /// Writes the per-epoch statistics (JSON lines and CSV), atomically. The
    /// CSV names the goal distance `distance` of every epoch's success (the
    /// run's `env.goal_distance`).
    pub fn write_metrics(&self, history: &[EpochStats], distance: GoalDistance) -> Result<(), CoreError> {
        let mut jsonl = String::new();
        for s in history {
            let line = serde_json::to_string(s)
                .map_err(|e| CoreError::Corrupt { path: self.metrics_jsonl(), reason: e.to_string() })?;
            jsonl.push_str(&line);
            jsonl.push('\n');
        }
        write_atomic(&self.metrics_jsonl(), jsonl.as_bytes())?;
        let mut csv = String::from(
            "epoch,goal_distance,success_rate,held_success_rate,train_success_rate,drop_rate,env_steps,updates,env_steps_per_sec,updates_per_sec,seconds",
        );
        let (k, n) = history.first().map_or((0, 0), |s| (s.occupancy.len(), s.returns.len()));
        for i in 0..k {
            let _ = write!(csv, ",occupancy_{i},eval_feature_rate_{i}");
        }
        for i in 0..n {
            let _ = write!(
                csv,
                ",return_{i},critic_loss_{i},actor_loss_{i},task_reward_abs_{i},shadow_reward_abs_{i},\
                 batch_task_reward_abs_{i},batch_shadow_reward_abs_{i},q_mean_{i}"
            );
        }
        csv.push('\n');
        // A value the epoch did not record (metrics of older runs) is an empty cell.
        let opt = |v: Option<&f64>| v.map_or_else(String::new, f64::to_string);
        for s in history {
            let _ = write!(
                csv,
                "{},{},{},{},{},{},{},{},{:.1},{:.2},{:.2}",
                s.epoch,
                distance.key(),
                s.success_rate,
                opt(s.held_success_rate.as_ref()),
                s.train_success_rate,
                s.drop_rate,
                s.env_steps,
                s.updates,
                s.env_steps_per_sec,
                s.updates_per_sec,
                s.seconds
            );
            for i in 0..k {
                let _ = write!(csv, ",{},{}", s.occupancy[i], s.eval_feature_rates.get(i).copied().unwrap_or(0.0));
            }
            for i in 0..n {
                let _ = write!(
                    csv,
                    ",{},{},{},{},{},{},{},{}",
                    s.returns[i],
                    s.critic_loss.get(i).copied().unwrap_or(0.0),
                    s.actor_loss.get(i).copied().unwrap_or(0.0),
                    s.task_reward_abs.get(i).copied().unwrap_or(0.0),
                    s.shadow_reward_abs.get(i).copied().unwrap_or(0.0),
                    opt(s.batch_task_reward_abs.get(i)),
                    opt(s.batch_shadow_reward_abs.get(i)),
                    opt(s.q_mean.get(i))
                );
            }
            csv.push('\n');
        }
        write_atomic(&self.metrics_csv(), csv.as_bytes())?;
        Ok(())
    }
}
