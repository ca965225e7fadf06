//! Training a run directory ([`crate::artefacts::RunDir`]): a new run or its
//! continuation, on one process or as one of several MPI workers, and the
//! progress line of each epoch.

use std::path::Path;

use fmsr_core::persist::write_atomic;
use fmsr_core::prelude::*;
use fmsr_core::trainer::{RescuePoint, Restart};

use crate::artefacts::RunDir;
use crate::experiment::{ExperimentConfig, ExperimentError};
use crate::provenance::Provenance;
#[cfg(feature = "tensorboard")]
use crate::tensorboard::EventWriter;

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
    on_epoch: impl FnMut(&EpochStats),
) -> Result<Trainer<E, fmsr_nn::AnyLearner>, ExperimentError> {
    let start = if resume { Start::Resume } else { Start::New };
    train_from(config, envs, dir, start, comm, on_epoch)
}

/// How a run directory's training starts.
#[derive(Debug, Clone, Copy)]
pub enum Start<'a> {
    /// A new run (refused where a checkpoint exists).
    New,
    /// The run's last checkpoint, with its replay log: exactly as if never stopped.
    Resume,
    /// A run whose checkpoint was lost, from a rescue point
    /// ([`fmsr_core::trainer::RescuePoint`]), with `refill` exploring episodes
    /// collected into the empty replay buffer first. Refused where a
    /// checkpoint exists. The restart is appended to `restarts.jsonl`.
    Rescue {
        /// The rescue point.
        point: &'a RescuePoint,
        /// Episodes collected before the next update.
        refill: usize,
    },
}

/// As [`train_worker`], starting as `start` says.
pub fn train_from<E: Env + Send>(
    config: &ExperimentConfig,
    envs: Vec<E>,
    dir: &RunDir,
    start: Start<'_>,
    comm: std::sync::Arc<dyn Communicator>,
    mut on_epoch: impl FnMut(&EpochStats),
) -> Result<Trainer<E, fmsr_nn::AnyLearner>, ExperimentError> {
    let resume = !matches!(start, Start::New);
    let writes = comm.rank() == 0;
    // Built first: a config that only the env or the learner can check fails
    // before the run directory exists.
    let mut trainer = config.build_worker_trainer(envs, comm)?;
    // One writer per run directory: rank 0 (the process that writes its
    // shared files) holds the lock for the whole run, from before it reads
    // the checkpoint.
    let _lock = if writes { Some(dir.lock()?) } else { None };
    match start {
        Start::Resume => trainer.load_checkpoint(&dir.checkpoint())?,
        Start::New | Start::Rescue { .. } if dir.checkpoint().exists() => {
            return Err(ExperimentError::Cli {
                arg: "--out",
                reason: format!(
                    "{} already holds a run with a checkpoint: pass --resume or choose another --out",
                    dir.root().display()
                ),
            });
        }
        Start::New => {}
        Start::Rescue { point, refill } => {
            let restart = trainer.restore_rescue(point, refill)?;
            if writes {
                record_restart(dir, &restart)?;
            }
            // The restarted run has a checkpoint at once (with the refilled
            // replay), even when no epoch is left to train: it is a run again.
            trainer.save_checkpoint(&dir.checkpoint())?;
        }
    }
    // TensorBoard events beside metrics.csv, in builds with the `tensorboard` feature.
    #[cfg(feature = "tensorboard")]
    let mut events = None;
    if writes {
        if !resume || !dir.provenance().exists() {
            let provenance = Provenance::of_this_process(Path::new("."));
            let json = serde_json::to_vec_pretty(&provenance)
                .map_err(|e| ExperimentError::Encode { what: "provenance.json", reason: e.to_string() })?;
            write_atomic(&dir.provenance(), &json)?;
        }
        write_atomic(&dir.config(), config.to_toml()?.as_bytes())?;
        dir.write_metrics(trainer.history(), config.env.goal_distance)?;
        #[cfg(feature = "tensorboard")]
        {
            events = Some(EventWriter::create(dir.root())?);
        }
    }
    trainer.train(|t, stats| {
        t.save_checkpoint(&dir.checkpoint())?;
        if writes {
            dir.write_metrics(t.history(), config.env.goal_distance)?;
        }
        #[cfg(feature = "tensorboard")]
        if let Some(events) = &mut events {
            events.write_epoch(stats, t.env().spec())?;
        }
        on_epoch(stats);
        Ok(())
    })?;
    Ok(trainer)
}

/// The rescue point of the run in `dir` (its last checkpoint), its learner
/// state thinned to `level` ([`fmsr_nn::rescue_state`]); see
/// [`fmsr_core::trainer::RescuePoint`] for the format.
///
/// # Errors
/// The checkpoint's errors ([`RescuePoint::from_checkpoint`]), a learner
/// state that is not of this build.
pub fn rescue_point(dir: &RunDir, level: fmsr_nn::RescueLevel) -> Result<RescuePoint, ExperimentError> {
    let mut point = RescuePoint::from_checkpoint(&dir.checkpoint(), level.key())?;
    point.algorithm = fmsr_nn::rescue_state(&point.algorithm, level)?;
    Ok(point)
}

/// Appends a restart from a rescue point to the run's `restarts.jsonl`, with
/// the provenance of the binary that restarted it.
fn record_restart(dir: &RunDir, restart: &Restart) -> Result<(), ExperimentError> {
    let path = dir.root().join("restarts.jsonl");
    let mut text = match std::fs::read_to_string(&path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => String::new(),
        Err(source) => return Err(ExperimentError::Io { path, source }),
    };
    let line = serde_json::json!({
        "restart": restart,
        "lost": match restart.buffer_episodes {
            Some(held) => format!(
                "the replay buffer ({held} episodes of the {} stored over the run); the rescue point kept `{}`",
                restart.lost_episodes, restart.keeps
            ),
            None => format!(
                "the replay buffer (not counted; {} episodes stored over the run); the rescue point kept `{}`",
                restart.lost_episodes, restart.keeps
            ),
        },
        "binary": Provenance::of_this_process(Path::new(".")),
    });
    text.push_str(&line.to_string());
    text.push('\n');
    write_atomic(&path, text.as_bytes())?;
    Ok(())
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
