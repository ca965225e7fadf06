//! Experiments as data: one TOML file fixes the task, the method (one of the
//! paper's four configurations), the engine, the trainer, the networks,
//! information sharing and the evaluation, and a run directory keeps its
//! configuration, logs, checkpoint and evaluation.
//!
//! ```toml
//! name = "block_dense_fmsr_is_quick"
//! method = "dense_fmsr_is"      # dense_fmsr_is | dense_fmsr | dense | sparse
//! engine = "rapier"             # rapier | mujoco
//!
//! [env]                         # fmsr_envs::shadow_hand::ShadowHandConfig
//! object = "block"
//!
//! [trainer]                     # fmsr_core::trainer::TrainerConfig
//! seed = 0
//! epochs = 3
//!
//! [ddpg]                        # fmsr_nn::DdpgConfig
//! hidden = 64
//! ```

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use fmsr_core::config::{Method, SharingConfig};
use fmsr_core::prelude::*;
use fmsr_envs::shadow_hand::ShadowHandConfig;
use fmsr_graph::Graph;
use fmsr_nn::{DdpgConfig, DdpgLearner};

/// The timestep of the Shadow Hand model (s); one env step is `substeps` of them.
pub const MODEL_TIMESTEP: f64 = 0.002;

/// Which physics engine runs the Shadow Hand.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Engine {
    /// rapier3d, pure Rust (default).
    #[default]
    Rapier,
    /// MuJoCo 3.17 (cargo feature `mujoco`).
    Mujoco,
}

/// The communication graph of the agents, by agent name.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct GraphConfig {
    /// Undirected edges between agent names; `None` is the paper's finger ring
    /// thumb-index-middle-ring-little-thumb with the wrist on its own.
    pub edges: Option<Vec<(String, String)>>,
}

impl GraphConfig {
    /// The graph over `spec`'s agents (node `i` = agent `i`).
    pub fn build(&self, spec: &EnvSpec) -> Result<Graph, ExperimentError> {
        let names: Vec<String> = spec.agents.iter().map(|a| a.name.clone()).collect();
        let edges = match &self.edges {
            None => {
                let g = Graph::shadow_hand();
                if g.nodes() != names.len() {
                    return Err(ExperimentError::Config {
                        key: "graph.edges".into(),
                        reason: format!("the default graph has 6 nodes, the environment {} agents", names.len()),
                    });
                }
                g.edges().to_vec()
            }
            Some(edges) => edges
                .iter()
                .map(|(a, b)| Ok((spec.agent_index(a)?, spec.agent_index(b)?)))
                .collect::<Result<Vec<_>, CoreError>>()
                .map_err(|source| ExperimentError::Invalid { key: "graph.edges", source })?,
        };
        Graph::from_edges(names.len(), &edges)
            .and_then(|g| g.with_names(names))
            .map_err(|e| ExperimentError::Invalid { key: "graph.edges", source: e.into() })
    }
}

/// The fixed test set and the measures of `fmsr eval`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EvalConfig {
    /// Test episodes (paper: 100), the same seeds for every policy.
    pub episodes: usize,
    /// Seed of the test set.
    pub seed: u64,
    /// Success threshold at test time (paper: 0.4 rad).
    pub threshold: f32,
}

impl Default for EvalConfig {
    fn default() -> Self {
        Self { episodes: 100, seed: 20_240_601, threshold: 0.4 }
    }
}

impl EvalConfig {
    /// The seeds of the fixed test set.
    #[must_use]
    pub fn seeds(&self) -> Vec<u64> {
        (0..self.episodes as u64).map(|i| fmsr_core::trainer::splitmix64(self.seed.wrapping_add(i))).collect()
    }
}

/// How a run keeps its state.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RunConfig {
    /// Store the replay buffer in checkpoints, so a resumed run is identical
    /// to an uninterrupted one (large for long runs).
    pub checkpoint_replay: bool,
}

impl Default for RunConfig {
    fn default() -> Self {
        Self { checkpoint_replay: true }
    }
}

/// One experiment; see the [module docs](self).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExperimentConfig {
    /// Name of the run (the default output directory is `runs/<name>`).
    pub name: String,
    /// One of the paper's four configurations. It decides the task reward,
    /// whether shadow rewards are on and whether agents share information.
    pub method: Method,
    /// The physics engine.
    #[serde(default)]
    pub engine: Engine,
    /// The Shadow Hand task (object, thresholds, features).
    #[serde(default)]
    pub env: ShadowHandConfig,
    /// The training loop and the shadow rewards.
    #[serde(default)]
    pub trainer: TrainerConfig,
    /// The networks and DDPG hyperparameters. The networks are initialised
    /// from `trainer.seed + ddpg.seed`; `gamma` is the trainer's.
    #[serde(default = "DdpgConfig::new")]
    pub ddpg: DdpgConfig,
    /// Information sharing settings (mode, target, mixing weights).
    #[serde(default)]
    pub sharing: SharingConfig,
    /// The agents' graph (neighbours observed by actors, and mixed by IS).
    #[serde(default)]
    pub graph: GraphConfig,
    /// The test set.
    #[serde(default)]
    pub eval: EvalConfig,
    /// Checkpointing.
    #[serde(default)]
    pub run: RunConfig,
}

/// Errors of experiments and runs.
#[derive(Debug, thiserror::Error)]
pub enum ExperimentError {
    /// A configuration value is wrong.
    #[error("config: `{key}`: {reason}")]
    Config {
        /// The key.
        key: String,
        /// What is wrong.
        reason: String,
    },
    /// The TOML could not be parsed (unknown key, wrong type, syntax).
    #[error("{path}: {message}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// The parser's message, which names the key and line.
        message: String,
    },
    /// The engine is not compiled in.
    #[error("engine `mujoco` needs the cargo feature `mujoco` (see README: MuJoCo)")]
    EngineUnavailable,
    /// Reading or writing a run file failed.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// A value that only the environment can check (agents, features, graph,
    /// mixing matrix) is wrong.
    #[error("config: `{key}`: {source}")]
    Invalid {
        /// The key.
        key: &'static str,
        /// What is wrong.
        #[source]
        source: CoreError,
    },
    /// A core error (trainer, checkpoint, graph).
    #[error(transparent)]
    Core(#[from] CoreError),
    /// An environment error.
    #[error(transparent)]
    Env(#[from] fmsr_envs::EnvError),
    /// A learner error.
    #[error(transparent)]
    Nn(#[from] fmsr_nn::NnError),
}

impl ExperimentConfig {
    /// Parses a TOML experiment, rejecting unknown keys, wrong types and
    /// impossible values with a message that names the key.
    pub fn from_toml(text: &str, path: &Path) -> Result<Self, ExperimentError> {
        let parse_err = |message: String| ExperimentError::Parse { path: path.to_path_buf(), message };
        let mut value: toml::Table = toml::from_str(text).map_err(|e| parse_err(e.to_string()))?;
        // burn's Config derive neither ignores nor defaults keys when deserialising:
        // check [ddpg] against its fields and fill in the defaults.
        if let Some(ddpg) = value.get_mut("ddpg") {
            let mut merged = toml::Table::try_from(DdpgConfig::new()).map_err(|e| parse_err(e.to_string()))?;
            let table = ddpg.as_table().ok_or_else(|| parse_err("`ddpg` must be a table".into()))?;
            for (k, v) in table {
                if !merged.contains_key(k) {
                    let mut names: Vec<_> = merged.keys().cloned().collect();
                    names.sort();
                    return Err(parse_err(format!("unknown key `ddpg.{k}`, expected one of {}", names.join(", "))));
                }
                merged.insert(k.clone(), v.clone());
            }
            *ddpg = toml::Value::Table(merged);
        }
        let config = ExperimentConfig::deserialize(toml::Value::Table(value)).map_err(|e| parse_err(e.to_string()))?;
        config.validate()?;
        Ok(config)
    }

    /// Reads and parses a TOML experiment file.
    pub fn load(path: &Path) -> Result<Self, ExperimentError> {
        let text = std::fs::read_to_string(path).map_err(|source| ExperimentError::Io { path: path.into(), source })?;
        Self::from_toml(&text, path)
    }

    /// The configuration as TOML.
    pub fn to_toml(&self) -> Result<String, ExperimentError> {
        toml::to_string_pretty(self).map_err(|e| ExperimentError::Config { key: "(all)".into(), reason: e.to_string() })
    }

    /// Checks the values that do not need the environment.
    pub fn validate(&self) -> Result<(), ExperimentError> {
        self.trainer.validate()?;
        self.ddpg.validate()?;
        if self.name.trim().is_empty() || self.name.contains(['/', '\\']) {
            return Err(ExperimentError::Config { key: "name".into(), reason: "must be a non-empty file name".into() });
        }
        if !(self.eval.threshold.is_finite() && self.eval.threshold > 0.0) {
            return Err(ExperimentError::Config { key: "eval.threshold".into(), reason: "must be positive".into() });
        }
        if self.eval.episodes == 0 {
            return Err(ExperimentError::Config { key: "eval.episodes".into(), reason: "must be at least 1".into() });
        }
        Ok(())
    }

    /// The environment config with the method's task reward.
    #[must_use]
    pub fn env_config(&self) -> ShadowHandConfig {
        ShadowHandConfig { reward: self.method.reward(), ..self.env.clone() }
    }

    /// The trainer config with shadow rewards switched by the method.
    #[must_use]
    pub fn trainer_config(&self) -> TrainerConfig {
        let mut t = self.trainer.clone();
        t.shadow.enabled = self.method.shadow();
        t
    }

    /// The sharing config switched by the method.
    #[must_use]
    pub fn sharing_config(&self) -> SharingConfig {
        SharingConfig { enabled: self.method.sharing(), ..self.sharing.clone() }
    }

    /// Builds the learner and the trainer on `env`, checking everything that
    /// needs the environment (agents, features, graph, mixing matrix).
    pub fn build_trainer<E: Env>(&self, env: E) -> Result<Trainer<E, DdpgLearner>, ExperimentError> {
        let spec = env.spec().clone();
        let graph = self.graph.build(&spec)?;
        let layout = ObservationLayout::from_graph(spec.clone(), &graph)
            .map_err(|source| ExperimentError::Invalid { key: "graph.edges", source })?;
        let trainer_config = self.trainer_config();
        trainer_config
            .shadow
            .agent_rewards(&spec)
            .map_err(|source| ExperimentError::Invalid { key: "trainer.shadow.assignment", source })?;
        let sharing = self
            .sharing_config()
            .build(&graph)
            .map_err(|source| ExperimentError::Invalid { key: "sharing.mixing", source })?;
        let ddpg = self
            .ddpg
            .clone()
            .with_gamma(trainer_config.gamma_for(spec.episode_len))
            .with_seed(trainer_config.seed.wrapping_add(self.ddpg.seed));
        let learner = DdpgLearner::new(layout.clone(), ddpg, sharing)?;
        Ok(Trainer::new(trainer_config, env, learner, layout)?)
    }
}
