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

use crate::experiment::{Engine, EpisodeSet, ExperimentConfig, ExperimentError};
use crate::provenance::Provenance;
use crate::tensorboard::EventWriter;

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
        serde_json::from_str(&text).map(Some).map_err(|e| ExperimentError::Parse { path, message: e.to_string() })
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
        ExperimentConfig::load(&self.config())
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
                serde_json::from_str(l)
                    .map_err(|e| ExperimentError::Parse { path: path.clone(), message: format!("line {}: {e}", i + 1) })
            })
            .collect()
    }

    /// Writes the per-epoch statistics (JSON lines and CSV), atomically.
    pub fn write_metrics(&self, history: &[EpochStats]) -> Result<(), CoreError> {
        let mut jsonl = String::new();
        for s in history {
            let line = serde_json::to_string(s)
                .map_err(|e| CoreError::Corrupt { path: self.metrics_jsonl(), reason: e.to_string() })?;
            jsonl.push_str(&line);
            jsonl.push('\n');
        }
        write_atomic(&self.metrics_jsonl(), jsonl.as_bytes())?;
        let mut csv = String::from(
            "epoch,success_rate,train_success_rate,drop_rate,env_steps,updates,env_steps_per_sec,updates_per_sec,seconds",
        );
        let (k, n) = history.first().map_or((0, 0), |s| (s.occupancy.len(), s.returns.len()));
        for i in 0..k {
            let _ = write!(csv, ",occupancy_{i},eval_feature_rate_{i}");
        }
        for i in 0..n {
            let _ = write!(csv, ",return_{i},critic_loss_{i},actor_loss_{i},task_reward_abs_{i},shadow_reward_abs_{i}");
        }
        csv.push('\n');
        for s in history {
            let _ = write!(
                csv,
                "{},{},{},{},{},{},{:.1},{:.2},{:.2}",
                s.epoch,
                s.success_rate,
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
                    ",{},{},{},{},{}",
                    s.returns[i],
                    s.critic_loss.get(i).copied().unwrap_or(0.0),
                    s.actor_loss.get(i).copied().unwrap_or(0.0),
                    s.task_reward_abs.get(i).copied().unwrap_or(0.0),
                    s.shadow_reward_abs.get(i).copied().unwrap_or(0.0)
                );
            }
            csv.push('\n');
        }
        write_atomic(&self.metrics_csv(), csv.as_bytes())?;
        Ok(())
    }
}

/// Trains `config` on `envs` (`config.trainer.num_envs()` copies of the task) in `dir`: a new run (refusing to overwrite one that
/// has a checkpoint) or, with `resume`, the continuation of the run in `dir`.
/// After every epoch the checkpoint and the logs are written and `on_epoch` is
/// called.
pub fn train<E: Env + Send>(
    config: &ExperimentConfig,
    envs: Vec<E>,
    dir: &RunDir,
    resume: bool,
    on_epoch: impl FnMut(&EpochStats),
) -> Result<Trainer<E, fmsr_nn::AnyLearner>, ExperimentError> {
    train_worker(config, envs, dir, resume, std::sync::Arc::new(SingleProcess), on_epoch)
}

/// As [`train`], as one of `comm.workers()` worker processes of one run
/// (every worker calls it): worker 0 writes the configuration, the logs and
/// every worker's checkpoint files; the others only train.
pub fn train_worker<E: Env + Send>(
    config: &ExperimentConfig,
    envs: Vec<E>,
    dir: &RunDir,
    resume: bool,
    comm: std::sync::Arc<dyn Communicator>,
    mut on_epoch: impl FnMut(&EpochStats),
) -> Result<Trainer<E, fmsr_nn::AnyLearner>, ExperimentError> {
    let writes = comm.rank() == 0;
    // Built first: a config that only the env or the learner can check fails
    // before the run directory exists.
    let mut trainer = config.build_worker_trainer(envs, comm)?;
    // One writer per run directory: rank 0 (the process that writes its
    // shared files) holds the lock for the whole run, from before it reads
    // the checkpoint.
    let _lock = if writes { Some(dir.lock()?) } else { None };
    if resume {
        trainer.load_checkpoint(&dir.checkpoint())?;
    } else if dir.checkpoint().exists() {
        return Err(ExperimentError::Config {
            key: "out".into(),
            reason: format!("{} already holds a run: pass --resume or choose another --out", dir.root().display()),
        });
    }
    let mut events = None;
    if writes {
        if !resume {
            let provenance = Provenance::of_this_process(Path::new("."));
            let json = serde_json::to_vec_pretty(&provenance)
                .map_err(|e| ExperimentError::Config { key: "provenance".into(), reason: e.to_string() })?;
            write_atomic(&dir.provenance(), &json)?;
        }
        write_atomic(&dir.config(), config.to_toml()?.as_bytes())?;
        dir.write_metrics(trainer.history())?;
        events = Some(EventWriter::create(dir.root())?);
    }
    trainer.train(|t, stats| {
        t.save_checkpoint(&dir.checkpoint())?;
        if writes {
            dir.write_metrics(t.history())?;
        }
        if let Some(events) = &mut events {
            events.write_epoch(stats, t.env().spec())?;
        }
        on_epoch(stats);
        Ok(())
    })?;
    Ok(trainer)
}

/// Whether this process was started by an MPI launcher (`mpirun`, `srun`) as
/// one of several ranks: Open MPI's, PMI's or Slurm's rank count is set and
/// above 1.
#[must_use]
pub fn launched_with_several_ranks() -> bool {
    ["OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_SIZE", "SLURM_NTASKS"]
        .iter()
        .filter_map(|k| std::env::var(k).ok())
        .filter_map(|v| v.parse::<usize>().ok())
        .any(|n| n > 1)
}

/// One line of progress per epoch, for logs (`fmsr train` writes it to stderr
/// when stderr is not a terminal): the epoch of `total`, env steps, training
/// success (at the training threshold, exploring) and evaluation success (the
/// epoch's deterministic episodes), each with its 95 % Wilson interval over
/// the epoch's `episodes` (training, evaluation), env steps/s, updates/s, the
/// epoch's seconds and the time left at the mean pace of `seconds_so_far` over
/// `epochs_timed` epochs of this process (here 5 epochs left at 104 s each).
///
/// ```
/// # use fmsr::core::trainer::EpochStats;
/// let s = EpochStats { epoch: 2, env_steps: 33_000, train_success_rate: 0.05, success_rate: 0.1,
///     env_steps_per_sec: 254.0, updates_per_sec: 21.3, seconds: 104.0, ..Default::default() };
/// assert_eq!(fmsr::run::epoch_line(&s, (100, 10), 8, 312.0, 3),
///     "epoch 3/8 | 33000 env steps | train 0.05 [0.02, 0.11] | eval 0.10 [0.02, 0.40] | 254 env steps/s | 21.3 updates/s | 104 s | ETA 8 min 40 s");
/// ```
#[must_use]
pub fn epoch_line(
    s: &EpochStats,
    episodes: (usize, usize),
    total: usize,
    seconds_so_far: f64,
    epochs_timed: usize,
) -> String {
    let done = s.epoch + 1;
    let left = total.saturating_sub(done) as f64 * seconds_so_far / epochs_timed.max(1) as f64;
    let left = left.round() as u64;
    let eta = if left >= 60 { format!("{} min {} s", left / 60, left % 60) } else { format!("{left} s") };
    let rate = |p: f64, n: usize| {
        let k = (p * n as f64).round() as usize;
        fmsr_core::interval::Interval::wilson(k, n)
            .map_or_else(|| format!("{p:.2}"), |i| format!("{p:.2} [{:.2}, {:.2}]", i.lower, i.upper))
    };
    format!(
        "epoch {done}/{total} | {} env steps | train {} | eval {} | {:.0} env steps/s | {:.1} updates/s | {:.0} s | ETA {eta}",
        s.env_steps,
        rate(s.train_success_rate, episodes.0),
        rate(s.success_rate, episodes.1),
        s.env_steps_per_sec,
        s.updates_per_sec,
        s.seconds
    )
}
