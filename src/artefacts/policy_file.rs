//! Trained policy files (`fmsr export`): a run's policy alone, a few MB, that
//! `fmsr eval`, `fmsr render` and `fmsr report` read wherever they read a run
//! directory.
//!
//! A policy file holds every agent's actor and input normaliser
//! ([`fmsr_core::policy::PolicyState`]), the experiment (env, engine, agents,
//! topology: the run's `config.toml`), where it came from
//! ([`Provenance`]: commit, build, command), its learning curve
//! (`metrics.jsonl`) and its evaluations (`eval.json`, `eval-<engine>.json`).
//! No critics, optimiser state, RNG or replay: it acts, it does not train on.
//!
//! ```text
//! magic "FMSRPLCY" | format version (u32, LE) | CRC-32C of the body (u64, LE) | body (postcard)
//! body: config (TOML) | provenance (JSON) | metrics (JSON lines) | evaluations (JSON each)
//!       | epochs | env steps | policy state (fmsr-nn's framing of its own)
//! ```
//!
//! The framing is [`fmsr_core::persist`]'s, so a file of another format
//! version, a truncated or a corrupted one is an error naming what is wrong
//! before any byte of it is used.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use fmsr_core::persist::write_atomic;
use fmsr_core::persist::{self, FormatError};
use fmsr_core::prelude::*;
use fmsr_core::trainer::read_checkpoint_contents;

use super::eval_file::{EvalReport, read_eval};
use super::render_target::RenderTarget;
use super::run_dir::RunDir;
use crate::error::ExperimentError;
use crate::experiment::{Engine, EpisodeSet, ExperimentConfig};
use crate::provenance::Provenance;
use fmsr_envs::shadow_hand::GoalDistance;
use fmsr_nn::PolicyPrecision;

/// The policy file format this build writes and reads: 2 (CRC-32C).
pub const POLICY_FILE_VERSION: u32 = 2;

/// The framing of a policy file.
const FORMAT: persist::Format = persist::Format::new(b"FMSRPLCY", POLICY_FILE_VERSION);

/// The name of a policy file inside a directory: `fmsr eval DIR` reads
/// `DIR/policy.fmsr` when `DIR` holds no run.
pub const POLICY_FILE_NAME: &str = "policy.fmsr";

/// The body as stored: the self-describing parts as text (the configuration's
/// tagged enums and the metrics' optional fields need TOML and JSON).
#[derive(Serialize, Deserialize)]
struct Body {
    config: String,
    provenance: String,
    metrics: Vec<String>,
    evals: Vec<String>,
    epochs: u64,
    env_steps: u64,
    policy: Vec<u8>,
}

/// A trained policy with its experiment, provenance, learning curve and evaluations.
#[derive(Debug, Clone, PartialEq)]
pub struct PolicyFile {
    /// The experiment the policy was trained in.
    pub config: ExperimentConfig,
    /// The commit and build that trained it.
    pub provenance: Provenance,
    /// The run's per-epoch statistics.
    pub metrics: Vec<EpochStats>,
    /// The run's evaluations: on its own engine first, then on the others.
    pub evals: Vec<EvalReport>,
    /// Epochs trained.
    pub epochs: usize,
    /// Env steps collected (one worker's).
    pub env_steps: u64,
    /// The policy state ([`fmsr_core::policy::PolicyState::save_policy`]).
    pub policy: Vec<u8>,
}

impl PolicyFile {
    /// The policy of the run in `dir`, from its last checkpoint, with its
    /// configuration, provenance, metrics and evaluations.
    ///
    /// # Errors
    /// The errors of reading the run's files; [`ExperimentError::NotARun`] when
    /// the run has no checkpoint.
    pub fn from_run(dir: &RunDir) -> Result<Self, ExperimentError> {
        if !dir.checkpoint().exists() {
            return Err(ExperimentError::NotARun {
                path: dir.root().to_path_buf(),
                reason: "holds no trained run (no checkpoint.bin)".into(),
            });
        }
        let config = dir.load_config()?;
        let contents = read_checkpoint_contents(&dir.checkpoint())?;
        let policy = fmsr_nn::policy_from_learner_state(&contents.algorithm)?;
        // The checkpoint's own history: metrics.jsonl may lag it by an epoch
        // while the run trains.
        let metrics = if contents.history.len() == contents.epoch {
            contents.history
        } else {
            let mut metrics = dir.load_metrics()?;
            metrics.truncate(contents.epoch);
            metrics
        };
        let mut evals = Vec::new();
        for set in [EpisodeSet::Test, EpisodeSet::Validation] {
            for engine in [config.engine, other_engine(config.engine)] {
                if let Some(e) = read_eval(&dir.eval_json_for(engine, config.engine, set))? {
                    evals.push(e);
                }
            }
        }
        Ok(Self {
            provenance: dir.load_provenance()?.unwrap_or_default(),
            config,
            metrics,
            evals,
            epochs: contents.epoch,
            env_steps: contents.env_steps,
            policy,
        })
    }

    /// The test-set evaluation on `engine` the file carries, if any.
    #[must_use]
    pub fn eval_on(&self, engine: Engine) -> Option<&EvalReport> {
        self.eval_for(engine.key(), EpisodeSet::Test)
    }

    /// The evaluation on the engine named `engine` and the episodes of `set`
    /// the file carries, if any.
    #[must_use]
    pub fn eval_for(&self, engine: &str, set: EpisodeSet) -> Option<&EvalReport> {
        self.eval_under(engine, set, self.config.env.goal_distance)
    }

    /// The precision of the actors ([`PolicyFile::at_precision`]).
    #[must_use]
    pub fn precision(&self) -> PolicyPrecision {
        PolicyPrecision::of(&self.policy)
    }

    /// This policy with its actors at `precision`. The evaluations it carries
    /// stay, each saying the precision it was measured at, until `fmsr eval
    /// --record` replaces them: `fmsr eval` of the file compares a new
    /// evaluation with them, episode by episode.
    ///
    /// # Errors
    /// The errors of [`fmsr_nn::policy_at_precision`]: a corrupt policy state,
    /// or a parameter beyond `f16`'s range.
    pub fn at_precision(&self, precision: PolicyPrecision) -> Result<Self, ExperimentError> {
        if self.precision() == precision {
            return Ok(self.clone());
        }
        Ok(Self { policy: fmsr_nn::policy_at_precision(&self.policy, precision)?, ..self.clone() })
    }

    /// The evaluation the file carries for `engine` and `set` under `distance`.
    #[must_use]
    pub fn eval_under(&self, engine: &str, set: EpisodeSet, distance: GoalDistance) -> Option<&EvalReport> {
        self.evals.iter().find(|e| e.engine == engine && e.set == set && e.goal_distance == distance)
    }

    /// Carries `eval` from now on, in place of the evaluation of the same
    /// engine, episode set and goal distance (test sets first, the training
    /// engine first, the training distance first).
    pub fn record_eval(&mut self, eval: EvalReport) {
        self.evals.retain(|e| !(e.engine == eval.engine && e.set == eval.set && e.goal_distance == eval.goal_distance));
        self.evals.push(eval);
        let own = self.config.engine.key();
        let distance = self.config.env.goal_distance;
        self.evals.sort_by_key(|e| (e.set != EpisodeSet::Test, e.engine != own, e.goal_distance != distance));
    }

    /// The file's bytes.
    ///
    /// # Errors
    /// [`ExperimentError::Encode`] when a part cannot be encoded.
    pub fn to_bytes(&self) -> Result<Vec<u8>, ExperimentError> {
        let body = Body {
            config: self.config.to_toml()?,
            provenance: to_json(&self.provenance)?,
            metrics: self.metrics.iter().map(to_json).collect::<Result<_, _>>()?,
            evals: self.evals.iter().map(to_json).collect::<Result<_, _>>()?,
            epochs: self.epochs as u64,
            env_steps: self.env_steps,
            policy: self.policy.clone(),
        };
        persist::encode(&FORMAT, &body)
            .map_err(|e| ExperimentError::Encode { what: "the policy file", reason: e.to_string() })
    }

    /// Reads a file's bytes; `path` names it in errors.
    ///
    /// # Errors
    /// [`ExperimentError::Parse`] naming what is wrong: not a policy file,
    /// another format version, a checksum mismatch, or a part that does not
    /// parse (the configuration is checked as `fmsr train` checks it).
    pub fn from_bytes(bytes: &[u8], path: &Path) -> Result<Self, ExperimentError> {
        let body: Body = persist::decode(&FORMAT, bytes).map_err(|e| match e {
            FormatError::Magic { .. } => ExperimentError::parse(path, "not an fmsr policy file (bad magic)"),
            other => ExperimentError::parse_source(path, "policy file", other),
        })?;
        let json = |what: &str, e: Box<dyn std::error::Error + Send + Sync>| {
            ExperimentError::parse_source(path, format!("policy file's {what}"), e)
        };
        let config = ExperimentConfig::from_saved_toml(&body.config, path)?;
        let provenance = serde_json::from_str(&body.provenance).map_err(|e| json("provenance", e.into()))?;
        let metrics = body
            .metrics
            .iter()
            .map(|m| serde_json::from_str(m).map_err(|e| json("metrics", e.into())))
            .collect::<Result<_, _>>()?;
        let evals = body
            .evals
            .iter()
            .map(|m| serde_json::from_str(m).map_err(|e| json("evaluation", e.into())))
            .collect::<Result<_, _>>()?;
        let epochs = usize::try_from(body.epochs).map_err(|e| json("epochs", e.into()))?;
        Ok(Self { config, provenance, metrics, evals, epochs, env_steps: body.env_steps, policy: body.policy })
    }

    /// Reads a policy file.
    ///
    /// # Errors
    /// [`ExperimentError::Io`], or as [`PolicyFile::from_bytes`].
    pub fn read(path: &Path) -> Result<Self, ExperimentError> {
        let bytes = std::fs::read(path).map_err(|source| ExperimentError::Io { path: path.into(), source })?;
        Self::from_bytes(&bytes, path)
    }

    /// Writes the file atomically (a crash leaves the old file or the new one).
    ///
    /// # Errors
    /// As [`PolicyFile::to_bytes`], and I/O errors.
    pub fn write(&self, path: &Path) -> Result<(), ExperimentError> {
        Ok(write_atomic(path, &self.to_bytes()?)?)
    }
}

/// The policy files in `dir` (`dir/*.fmsr` and `dir/*/policy.fmsr`, sorted)
/// trained in the configuration of `config`: the same task, engine and
/// configuration label (method, agents). Files that cannot be read are
/// skipped with a warning (`log::warn!`); a missing `dir` has none.
#[must_use]
pub fn matching_policies(dir: &Path, config: &ExperimentConfig) -> Vec<PathBuf> {
    let Ok(entries) = std::fs::read_dir(dir) else { return Vec::new() };
    let mut paths: Vec<PathBuf> = entries
        .flatten()
        .map(|e| e.path())
        .map(|p| if p.is_dir() { p.join(POLICY_FILE_NAME) } else { p })
        .filter(|p| p.is_file() && p.extension().is_some_and(|e| e == "fmsr"))
        .collect();
    paths.sort();
    paths.retain(|p| match PolicyFile::read(p) {
        Ok(f) => {
            f.config.env.object == config.env.object
                && f.config.engine == config.engine
                && f.config.key() == config.key()
        }
        Err(e) => {
            log::warn!("skipping {}: {e}", p.display());
            false
        }
    });
    paths
}

/// The engine that is not `engine`.
fn other_engine(engine: Engine) -> Engine {
    match engine {
        Engine::Rapier => Engine::Mujoco,
        Engine::Mujoco => Engine::Rapier,
    }
}

/// One part of the body as JSON text.
fn to_json<T: Serialize>(value: &T) -> Result<String, ExperimentError> {
    serde_json::to_string(value).map_err(|e| ExperimentError::Encode { what: "the policy file", reason: e.to_string() })
}

/// What `fmsr eval`, `render` and `report` read: a run directory or a policy file.
#[derive(Debug, Clone)]
pub enum Source {
    /// A run directory (its last checkpoint acts).
    Run(RunDir),
    /// A policy file.
    Policy {
        /// Where it was read from.
        path: PathBuf,
        /// Its contents.
        file: Box<PolicyFile>,
    },
}

impl Source {
    /// `path` as a run directory (it holds `config.toml`), a directory that
    /// holds `policy.fmsr`, or a policy file.
    ///
    /// # Errors
    /// [`ExperimentError::NotARun`] for a directory that holds neither;
    /// the errors of [`PolicyFile::read`].
    pub fn open(path: &Path) -> Result<Self, ExperimentError> {
        if path.is_dir() {
            let run = RunDir::new(path);
            if run.config().exists() {
                return Ok(Self::Run(run));
            }
            let file = path.join(POLICY_FILE_NAME);
            if !file.exists() {
                return Err(ExperimentError::NotARun {
                    path: path.to_path_buf(),
                    reason: format!("holds neither a run (config.toml) nor a policy file ({POLICY_FILE_NAME})"),
                });
            }
            return Ok(Self::Policy { file: Box::new(PolicyFile::read(&file)?), path: file });
        }
        Ok(Self::Policy { file: Box::new(PolicyFile::read(path)?), path: path.to_path_buf() })
    }

    /// The experiment. A policy file's acts on the CPU (`device = "cpu"`):
    /// the policy does not depend on the device or stacking it trained with.
    ///
    /// # Errors
    /// The errors of reading a run's `config.toml`.
    pub fn config(&self) -> Result<ExperimentConfig, ExperimentError> {
        match self {
            Self::Run(dir) => dir.load_config(),
            Self::Policy { file, .. } => {
                let mut config = file.config.clone();
                config.device = fmsr_nn::DeviceSpec::Flex;
                Ok(config)
            }
        }
    }

    /// The directory the source lives in: the run directory, or the policy
    /// file's folder (where `fmsr render` draws by default).
    #[must_use]
    pub fn home(&self) -> &Path {
        match self {
            Self::Run(dir) => dir.root(),
            Self::Policy { path, .. } => path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new(".")),
        }
    }

    /// Where `fmsr render` draws test episode `episode` on `engine` (default:
    /// the engine it trained on) unless told otherwise:
    /// `HOME/render/episode-K-ENGINE.gif`, [`Source::home`].
    ///
    /// # Errors
    /// The errors of reading a run's `config.toml`, when `engine` is `None`.
    pub fn render_target(&self, episode: usize, engine: Option<Engine>) -> Result<RenderTarget, ExperimentError> {
        let engine = match engine {
            Some(e) => e,
            None => self.config()?.engine,
        };
        Ok(RenderTarget::default_for(&RunDir::new(self.home()), episode, engine))
    }

    /// The precision of the actors that act: a run's are `full`; a policy
    /// file's as exported.
    #[must_use]
    pub fn precision(&self) -> PolicyPrecision {
        match self {
            Self::Run(_) => PolicyPrecision::Full,
            Self::Policy { file, .. } => file.precision(),
        }
    }

    /// The path as given.
    #[must_use]
    pub fn path(&self) -> &Path {
        match self {
            Self::Run(dir) => dir.root(),
            Self::Policy { path, .. } => path,
        }
    }

    /// Puts the policy into `trainer` (built from [`Source::config`]); returns
    /// the epochs it was trained for.
    ///
    /// # Errors
    /// The errors of reading the checkpoint, or of a policy that does not fit.
    pub fn load_into<E: Env + Send>(
        &self,
        trainer: &mut Trainer<E, fmsr_nn::AnyLearner>,
    ) -> Result<usize, ExperimentError> {
        match self {
            Self::Run(dir) => {
                trainer.load_checkpoint_without_storage(&dir.checkpoint())?;
                Ok(trainer.epoch())
            }
            Self::Policy { file, .. } => {
                trainer.algorithm_mut().load_policy(&file.policy)?;
                Ok(file.epochs)
            }
        }
    }
}
