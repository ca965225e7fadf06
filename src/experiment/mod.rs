//! Experiments as data: one TOML file fixes the task, the method (one of the
//! paper's four configurations), the engine, the trainer, the networks,
//! information sharing and the evaluation, and a run directory keeps its
//! configuration, logs, checkpoint and evaluation.
//!
//! ```toml
//! name = "block_dense_fmsr_is_quick"
//! method = "dense_fmsr_is"      # dense_fmsr_is | dense_fmsr | dense | sparse
//! stack = "fmsr"                # fmsr | paper (gym's goal distance, HER baselines' target clip and normalisers)
//! algorithm = "maddpg"          # maddpg | matd3 | masac | one registered by your crate
//! engine = "rapier"             # rapier | mujoco
//! device = "cpu"
//!
//! [env]                         # fmsr_envs::shadow_hand::ShadowHandConfig
//! object = "block"
//!
//! [trainer]                     # fmsr_core::trainer::TrainerConfig (seed, budget, gamma, shadow)
//! seed = 0
//! epochs = 3
//!
//! [replay]                      # fmsr_core::replay::ReplayConfig (buffer, batch, batches per cycle, HER)
//! batch_size = 256
//!
//! [networks]                    # fmsr_nn::NetworkConfig (sizes, Adam, normalisers, threads)
//! hidden = 64
//!
//! [maddpg]                      # the chosen algorithm's own section (fmsr_nn::MaddpgConfig, ...)
//! polyak = 0.95
//! ```
//!
//! # One owner per setting
//!
//! `method` is the paper's preset: it decides the task reward (`env.reward`),
//! whether shadow rewards are on (`trainer.shadow.enabled`) and whether agents
//! share information (`sharing.enabled`). Setting one of those keys to a value
//! that contradicts the method is an error naming both keys; so is a section
//! that the method or the algorithm does not use (`[sharing]` without
//! information sharing, `[trainer.shadow]` without shadow rewards, `[matd3]`
//! under `algorithm = "maddpg"`). The discount is `trainer.gamma`, used by the
//! occupancy estimate and the critics alike. `stack = "paper"` owns
//! `env.goal_distance`, `networks.target_clip` and `networks.normalizer_stats`
//! the same way ([`Stack`]).
//!
//! `algorithm` names an entry of the [registry](crate::algorithms): the
//! three of this crate, and any rule a user's crate registered; its section
//! is read against that rule's settings.
//!
//! A run's `config.toml` is the resolved experiment: besides what its file
//! said, it names every setting of the chosen algorithm's section with the
//! value the run used, so changing a default in a later release never changes
//! a saved run that is resumed or evaluated.

use std::collections::BTreeMap;
use std::path::Path;

use serde::{Deserialize, Serialize};

use fmsr_core::method::Method;
use fmsr_core::prelude::*;
use fmsr_core::replay::ReplayConfig;
use fmsr_core::sharing::SharingConfig;
use fmsr_envs::shadow_hand::ShadowHandConfig;

pub use crate::error::ExperimentError;
use fmsr_graph::Graph;
use fmsr_nn::{ConfiguredRule, CriticTying, Device, DeviceSpec, NetworkConfig, Teammates};

use crate::algorithms::{self, AlgorithmSettings};
pub use crate::stack::Stack;
use crate::tasks::{self, SHADOW_HAND, ShadowHandSettings, ShadowHandTask, TaskSettings};

/// The timestep of the Shadow Hand model (s); one env step is `substeps` of them.
pub const MODEL_TIMESTEP: f64 = 0.002;

/// Which physics engine runs the Shadow Hand (its home is `fmsr_envs::shadow_hand::engine`).
pub use fmsr_envs::shadow_hand::Engine;

/// The communication graph of the agents, by agent name.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct GraphConfig {
    /// Undirected edges between agent names; `None` is the paper's finger ring
    /// thumb-index-middle-ring-little-thumb with the wrist on its own.
    pub edges: Option<Vec<(String, String)>>,
    /// What each actor observes besides the goal and its neighbours' previous
    /// actions: `"local"` (default, the paper's MAGCLA: its own joints and
    /// touch sensors and the object) or `"global"` (the critics' global
    /// observation; an ablation, no longer MAGCLA).
    #[serde(default)]
    pub actor_observation: ActorView,
}

impl GraphConfig {
    /// The graph over `spec`'s agents (node `i` = agent `i`).
    pub fn build(&self, spec: &EnvSpec) -> Result<Graph, ExperimentError> {
        let names: Vec<String> = spec.agents.iter().map(|a| a.name.clone()).collect();
        let edges = match &self.edges {
            None => {
                let g = Graph::shadow_hand();
                if g.nodes() != names.len() {
                    return Err(ExperimentError::config(
                        "graph.edges",
                        format!("the default graph has 6 nodes, the environment {} agents", names.len()),
                    ));
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

/// Which episodes an evaluation plays: the fixed test set, reported, or the
/// validation episodes, on which an epoch, a snapshot or a seed is chosen.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EpisodeSet {
    /// The fixed test set (paper: 100 episodes), the same for every policy.
    #[default]
    Test,
    /// Held-out episodes whose seeds are disjoint from the test set's.
    Validation,
}

impl EpisodeSet {
    /// `test` or `validation`.
    #[must_use]
    pub fn key(self) -> &'static str {
        match self {
            Self::Test => "test",
            Self::Validation => "validation",
        }
    }
}

impl EvalConfig {
    /// The seeds of the fixed test set: `splitmix64(seed + i)`.
    #[must_use]
    pub fn seeds(&self) -> Vec<u64> {
        self.seeds_of(EpisodeSet::Test, self.episodes)
    }

    /// The first `n` seeds of `set`. The test set's are `splitmix64(seed + i)`,
    /// the validation episodes' `splitmix64(seed + 2^63 + i)`: `splitmix64` is
    /// a bijection of `u64` and the two sets of inputs do not meet for `n`
    /// below `2^63`, so no validation episode is ever a test episode.
    ///
    /// ```
    /// use fmsr::experiment::{EpisodeSet, EvalConfig};
    /// let eval = EvalConfig::default();
    /// let test = eval.seeds_of(EpisodeSet::Test, 1000);
    /// let validation = eval.seeds_of(EpisodeSet::Validation, 1000);
    /// assert_eq!(test[..100], eval.seeds()[..]);
    /// assert!(validation.iter().all(|s| !test.contains(s)));
    /// ```
    #[must_use]
    pub fn seeds_of(&self, set: EpisodeSet, n: usize) -> Vec<u64> {
        let base = match set {
            EpisodeSet::Test => self.seed,
            EpisodeSet::Validation => self.seed.wrapping_add(1 << 63),
        };
        (0..n as u64).map(|i| fmsr_core::seeding::splitmix64(base.wrapping_add(i))).collect()
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
    /// Whose code the settings the paper leaves open follow
    /// ([`Stack`]): `"fmsr"` (default) or `"paper"` (gym's goal distance,
    /// HER baselines' target clip and normaliser statistics).
    #[serde(default)]
    pub stack: Stack,
    /// The task by its name ([`crate::tasks`]; default `"shadow_hand"`, the
    /// paper's, whose settings are `engine` and `[env]`). A registered
    /// task's settings are its `[<task>]` section
    /// ([`ExperimentConfig::task_settings`]).
    #[serde(default = "default_task", skip_serializing_if = "is_shadow_hand")]
    pub task: String,
    /// The registered task's settings, read once through the registry;
    /// `None` for the Shadow Hand.
    #[serde(skip)]
    task_settings: Option<TaskSettings>,
    /// The learning algorithm by its registered name
    /// ([`crate::algorithms`]; default `"maddpg"`, the paper's).
    #[serde(default = "default_algorithm")]
    pub algorithm: String,
    /// The physics engine.
    #[serde(default)]
    pub engine: Engine,
    /// The burn device the networks live on: `"cpu"` (burn's `flex`, default),
    /// or with the `wgpu` / `vulkan` / `cuda` features a GPU such as `"wgpu:0"`,
    /// `"vulkan:0"`, `"cuda:0"` or `"wgpu:cpu"`, parsed when the config is
    /// read (a name that does not parse is refused there, naming the key) and
    /// checked against this build and machine ([`device_of`]).
    #[serde(default = "default_device")]
    pub device: DeviceSpec,
    /// The Shadow Hand task (object, thresholds, features).
    #[serde(default)]
    pub env: ShadowHandConfig,
    /// The training loop, the discount and the shadow rewards.
    #[serde(default)]
    pub trainer: TrainerConfig,
    /// Replay storage and gradient steps per cycle (every algorithm here is off-policy).
    #[serde(default)]
    pub replay: ReplayConfig,
    /// Networks, optimisers and normalisers. They are initialised from
    /// `trainer.seed + networks.seed`.
    #[serde(default = "NetworkConfig::new")]
    pub networks: NetworkConfig,
    /// The algorithms' settings by name, each read once through the
    /// registry; the chosen algorithm's are the `[<algorithm>]` of the
    /// file ([`ExperimentConfig::algorithm_settings`]).
    #[serde(skip)]
    algorithm_settings: BTreeMap<String, AlgorithmSettings>,
    /// Information sharing settings (mode, target, mixing weights); only with a
    /// method that shares.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sharing: Option<SharingConfig>,
    /// The agents' graph (neighbours observed by actors, and mixed by IS).
    #[serde(default)]
    pub graph: GraphConfig,
    /// The test set.
    #[serde(default)]
    pub eval: EvalConfig,
}

fn default_device() -> DeviceSpec {
    DeviceSpec::Flex
}

fn default_task() -> String {
    SHADOW_HAND.into()
}

#[allow(clippy::ptr_arg)] // serde's `skip_serializing_if` passes `&String`
fn is_shadow_hand(task: &String) -> bool {
    task == SHADOW_HAND
}

fn default_algorithm() -> String {
    "maddpg".into()
}

/// Sections read through burn's `Config` derive, which neither rejects unknown
/// keys nor fills in defaults when deserialising: (key, default as TOML).
fn burn_sections() -> Result<Vec<(&'static str, toml::Table)>, toml::ser::Error> {
    Ok(vec![("networks", toml::Table::try_from(NetworkConfig::new())?)])
}

/// `table[a][b]...` if present.
fn lookup<'a>(table: &'a toml::Table, path: &[&str]) -> Option<&'a toml::Value> {
    let (first, rest) = path.split_first()?;
    let v = table.get(*first)?;
    if rest.is_empty() { Some(v) } else { lookup(v.as_table()?, rest) }
}

/// Rejects keys and sections that contradict `method` or `algorithm` (see the module docs).
fn check_owners(table: &toml::Table) -> Result<(), ExperimentError> {
    let text = |path: &[&str]| lookup(table, path).and_then(toml::Value::as_str).map(str::to_owned);
    let Some(method) = text(&["method"]).and_then(|m| Method::deserialize(toml::Value::String(m)).ok()) else {
        return Ok(()); // a missing or unknown method is reported by the parser
    };
    let conflict = |key: &str, reason: String| Err(ExperimentError::config(key, reason));
    let reward = if method.reward() == RewardType::Sparse { "sparse" } else { "dense" };
    if let Some(r) = text(&["env", "reward"])
        && r != reward
    {
        return conflict(
            "env.reward",
            format!("`{r}` contradicts `method = \"{}\"`, which sets it to `{reward}`", key_of(method)),
        );
    }
    let flag = |path: &[&str]| lookup(table, path).and_then(toml::Value::as_bool);
    for (path, on, what) in [
        (&["trainer", "shadow", "enabled"][..], method.shadow(), "shadow rewards"),
        (&["sharing", "enabled"][..], method.sharing(), "information sharing"),
    ] {
        if let Some(v) = flag(path)
            && v != on
        {
            return conflict(
                &path.join("."),
                format!(
                    "`{v}` contradicts `method = \"{}\"`, which turns {what} {}",
                    key_of(method),
                    if on { "on" } else { "off" }
                ),
            );
        }
    }
    if !method.sharing() && table.contains_key("sharing") {
        return conflict(
            "sharing",
            format!("`method = \"{}\"` does not share information; remove the section", key_of(method)),
        );
    }
    if !method.shadow() && lookup(table, &["trainer", "shadow"]).is_some() {
        return conflict(
            "trainer.shadow",
            format!("`method = \"{}\"` uses no shadow rewards; remove the section", key_of(method)),
        );
    }
    let stack = text(&["stack"]).and_then(|s| Stack::deserialize(toml::Value::String(s)).ok());
    if stack == Some(Stack::Paper) {
        for owned in Stack::OWNED {
            let path: Vec<&str> = owned.key.split('.').collect();
            if let Some(v) = text(&path)
                && v != owned.paper
            {
                return conflict(
                    owned.key,
                    format!("`{v}` contradicts `stack = \"paper\"`, which sets it to `{}`", owned.paper),
                );
            }
        }
    }
    let algorithm = text(&["algorithm"]).unwrap_or_else(|| "maddpg".into());
    for name in algorithms::names() {
        if name != algorithm && table.contains_key(name) {
            return conflict(name, format!("`algorithm = \"{algorithm}\"` does not read `[{name}]`"));
        }
    }
    // An unknown task is reported by its lookup, listing the tasks.
    let task = text(&["task"]).unwrap_or_else(|| SHADOW_HAND.into());
    let names = tasks::names();
    if names.contains(&task.as_str())
        && let Some(name) = names.into_iter().find(|&n| n != task && table.contains_key(n))
    {
        return conflict(name, format!("`task = \"{task}\"` does not read `[{name}]`"));
    }
    Ok(())
}

fn key_of(method: Method) -> String {
    toml::Value::try_from(method).ok().and_then(|v| v.as_str().map(str::to_owned)).unwrap_or_default()
}

/// The parsed device of `device`: `"cpu"`/`"flex"`, and with the `wgpu` or
/// `vulkan` features `"wgpu"`, `"wgpu:N"`, `"wgpu:cpu"`, `"vulkan:N"`
/// ([`fmsr_nn::device`]).
///
/// # Errors
/// [`ExperimentError::Config`] for a device this build or this machine does
/// not have, listing those it has.
pub fn parse_device(device: &str) -> Result<Device, ExperimentError> {
    let invalid =
        |e: fmsr_nn::NnError| ExperimentError::config_source("device", format!("`{device}` is not a device"), e);
    device_of(device.parse::<DeviceSpec>().map_err(invalid)?)
}

/// The burn device of `device`, checking that this build has its backend
/// and this machine its adapter.
///
/// # Errors
/// [`ExperimentError::Config`] for key `device`, listing the devices there are.
pub fn device_of(device: DeviceSpec) -> Result<Device, ExperimentError> {
    device.device().map_err(|e| ExperimentError::config_source("device", format!("`{device}` cannot be used here"), e))
}

impl ExperimentConfig {
    /// Parses a TOML experiment, rejecting unknown keys, wrong types, impossible
    /// values and settings that contradict their owner with a message that
    /// names the key.
    ///
    /// # Errors
    /// [`ExperimentError::Parse`] or [`ExperimentError::Config`].
    pub fn from_toml(text: &str, path: &Path) -> Result<Self, ExperimentError> {
        let parse_err = |message: String| ExperimentError::parse(path, message);
        let mut value: toml::Table =
            toml::from_str(text).map_err(|e| ExperimentError::parse_source(path, "not a TOML experiment", e))?;
        if value.contains_key("ddpg") {
            return Err(parse_err(
                "`[ddpg]` was split: network sizes, learning rates, normalisers and threads are in `[networks]`, \
                 polyak and exploration in `[maddpg]`, batch settings in `[replay]`"
                    .into(),
            ));
        }
        check_owners(&value)?;
        let algorithm = match value.get("algorithm") {
            None => default_algorithm(),
            Some(toml::Value::String(name)) => name.clone(),
            Some(_) => {
                return Err(parse_err("`algorithm` must be a string, the name of a registered algorithm".into()));
            }
        };
        let (_, task_settings) = tasks::take_section(&mut value, &algorithm)?;
        let section = match value.remove(&algorithm) {
            None => None,
            Some(toml::Value::Table(section)) => Some(section),
            Some(_) => return Err(parse_err(format!("`{algorithm}` must be a table"))),
        };
        let settings = AlgorithmSettings::resolve(&algorithm, section.as_ref())?;
        for (key, defaults) in
            burn_sections().map_err(|e| ExperimentError::parse_source(path, "writing the defaults of `networks`", e))?
        {
            let Some(section) = value.get_mut(key) else { continue };
            let table = section.as_table().ok_or_else(|| parse_err(format!("`{key}` must be a table")))?;
            let mut merged = defaults;
            for (k, v) in table {
                if !merged.contains_key(k) {
                    let mut names: Vec<_> = merged.keys().cloned().collect();
                    names.sort();
                    return Err(parse_err(format!("unknown key `{key}.{k}`, expected one of {}", names.join(", "))));
                }
                merged.insert(k.clone(), v.clone());
            }
            *section = toml::Value::Table(merged);
        }
        let mut config = ExperimentConfig::deserialize(toml::Value::Table(value))
            .map_err(|e| ExperimentError::parse_source(path, "not an experiment", e))?;
        config.algorithm_settings.insert(algorithm, settings);
        config.task_settings = task_settings;
        if let Some(d) = config.stack.goal_distance() {
            config.env.goal_distance = d;
        }
        if let Some(c) = config.stack.target_clip() {
            config.networks.target_clip = c;
        }
        if let Some(n) = config.stack.normalizer_stats() {
            config.networks.normalizer_stats = n;
        }
        config.validate()?;
        Ok(config.with_sections_written())
    }

    /// Parses the resolved experiment of a saved run or policy file, which
    /// names every setting: a Shadow Hand experiment that does not name
    /// `env.goal_distance` is refused (the default of a user's file, read
    /// with [`Self::from_toml`], has changed before, and would change what
    /// its records mean).
    ///
    /// # Errors
    /// As [`Self::from_toml`].
    pub fn from_saved_toml(text: &str, path: &Path) -> Result<Self, ExperimentError> {
        let value: toml::Table =
            toml::from_str(text).map_err(|e| ExperimentError::parse_source(path, "not a TOML experiment", e))?;
        if value.get("task").and_then(toml::Value::as_str).is_some_and(|t| t != SHADOW_HAND) {
            return Self::from_toml(text, path);
        }
        if lookup(&value, &["env", "goal_distance"]).is_none() {
            return Err(ExperimentError::config(
                "env.goal_distance",
                format!(
                    "{} names no goal distance; a saved experiment names every setting (write the one it \
                     trained under, \"yaw\" for the records before the full-angle task)",
                    path.display()
                ),
            ));
        }
        Self::from_toml(text, path)
    }

    /// Reads and parses the resolved experiment of a saved run (`config.toml`),
    /// as [`Self::from_saved_toml`].
    pub fn load_saved(path: &Path) -> Result<Self, ExperimentError> {
        let text = std::fs::read_to_string(path).map_err(|source| ExperimentError::Io { path: path.into(), source })?;
        Self::from_saved_toml(&text, path)
    }

    /// Reads and parses a TOML experiment file.
    pub fn load(path: &Path) -> Result<Self, ExperimentError> {
        let text = std::fs::read_to_string(path).map_err(|source| ExperimentError::Io { path: path.into(), source })?;
        Self::from_toml(&text, path)
    }

    /// The configuration as TOML, without the keys the method owns (so it reads back as the same config).
    ///
    /// # Errors
    /// [`ExperimentError::Encode`] if a value cannot be written as TOML.
    pub fn to_toml(&self) -> Result<String, ExperimentError> {
        let err = |e: toml::ser::Error| ExperimentError::Encode { what: "config.toml", reason: e.to_string() };
        let mut table = toml::Table::try_from(self.clone().with_sections_written()).map_err(err)?;
        table.insert(self.algorithm.clone(), toml::Value::Table(self.algorithm_settings()?.to_table()?));
        if let Some(settings) = &self.task_settings {
            table.remove("env");
            table.remove("engine");
            table.insert(self.task.clone(), toml::Value::Table(settings.to_table()?));
        }
        if let Some(toml::Value::Table(env)) = table.get_mut("env") {
            env.remove("reward");
        }
        if let Some(toml::Value::Table(trainer)) = table.get_mut("trainer") {
            if self.method.shadow() {
                if let Some(toml::Value::Table(shadow)) = trainer.get_mut("shadow") {
                    shadow.remove("enabled");
                }
            } else {
                trainer.remove("shadow");
            }
        }
        if let Some(toml::Value::Table(sharing)) = table.get_mut("sharing") {
            sharing.remove("enabled");
        }
        toml::to_string_pretty(&table).map_err(err)
    }

    /// Checks the values that do not need the environment.
    pub fn validate(&self) -> Result<(), ExperimentError> {
        self.trainer.validate()?;
        self.replay.validate()?;
        self.networks.validate()?;
        self.algorithm_settings()?;
        device_of(self.device)?;
        if self.networks.critic == CriticTying::Shared && self.method.shadow() {
            return Err(ExperimentError::config(
                "networks.critic",
                format!(
                    "\"shared\" gives every agent one critic, but {} gives each finger its own shadow reward; \
                     use \"shared_trunk\" (a head per agent)",
                    self.method.label()
                ),
            ));
        }
        // The defaults below are the Shadow Hand's: another task with as many
        // agents would take them silently.
        if !self.is_shadow_hand() && self.graph.edges.is_none() {
            return Err(ExperimentError::config(
                "graph.edges",
                format!("the default is the Shadow Hand's finger ring; the task `{}` names its own edges", self.task),
            ));
        }
        if !self.is_shadow_hand() && self.method.shadow() && self.trainer.shadow.assignment.is_none() {
            return Err(ExperimentError::config(
                "trainer.shadow.assignment",
                format!(
                    "the default is the paper's assignment to the Shadow Hand's fingers (eqs. 13-15); the task `{}` \
                     names its own",
                    self.task
                ),
            ));
        }
        if self.name.trim().is_empty() || self.name.contains(['/', '\\']) {
            return Err(ExperimentError::config("name", "must be a non-empty file name"));
        }
        if !(self.eval.threshold.is_finite() && self.eval.threshold > 0.0) {
            return Err(ExperimentError::config("eval.threshold", "must be positive"));
        }
        if self.eval.episodes == 0 {
            return Err(ExperimentError::config("eval.episodes", "must be at least 1"));
        }
        Ok(())
    }

    /// The configuration's name in tables and figures: its [`RunKey`] in
    /// words (e.g. `Dense+FMSR+IS, alpha 0.03, trained on MuJoCo`).
    #[must_use]
    pub fn label(&self) -> String {
        self.key().to_string()
    }

    /// Whether the task is the Shadow Hand (`task = "shadow_hand"`, the default).
    #[must_use]
    pub fn is_shadow_hand(&self) -> bool {
        self.task == SHADOW_HAND
    }

    /// The task's settings, as its registry entry builds environments of
    /// them: a task of your own crate's `[<task>]` section, read once as the
    /// task's own type when the config was loaded; the Shadow Hand's
    /// `engine` and `env` as they are now, with the method's task reward
    /// ([`ExperimentConfig::env_config`]).
    ///
    /// # Errors
    /// [`ExperimentError::Config`] for key `task` when the Shadow Hand's
    /// entry is not fmsr's own.
    pub fn task_settings(&self) -> Result<TaskSettings, ExperimentError> {
        match &self.task_settings {
            Some(settings) => Ok(settings.clone()),
            None => {
                TaskSettings::new::<ShadowHandTask>(ShadowHandSettings { engine: self.engine, env: self.env_config() })
            }
        }
    }

    /// Which teammates' actions the chosen algorithm's actor loss takes.
    ///
    /// # Errors
    /// [`ExperimentError::Config`] for an algorithm that is not registered.
    pub fn teammates(&self) -> Result<Teammates, ExperimentError> {
        Ok(self.algorithm_settings()?.teammates())
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
        SharingConfig { enabled: self.method.sharing(), ..self.sharing.clone().unwrap_or_default() }
    }

    /// The config with the chosen algorithm's section written out (its
    /// defaults where the file left it out), so that a run's `config.toml`
    /// records every setting its algorithm learned with and a later change of
    /// a default cannot change a run that is resumed or evaluated.
    #[must_use]
    pub fn with_algorithm_section(mut self) -> Self {
        if let Ok(settings) = self.algorithm_settings() {
            self.algorithm_settings.insert(self.algorithm.clone(), settings);
        }
        self
    }

    /// The config with the `[sharing]` section written out (its defaults where
    /// the file left it out) when the method shares, for the reason of
    /// [`ExperimentConfig::with_algorithm_section`].
    ///
    /// ```
    /// use fmsr::experiment::ExperimentConfig;
    /// let text = "name = \"x\"\nmethod = \"dense_fmsr_is\"\n";
    /// let config = ExperimentConfig::from_toml(text, "x.toml".as_ref()).unwrap();
    /// assert!(config.sharing.is_some() && config.to_toml().unwrap().contains("[sharing]"));
    /// ```
    #[must_use]
    pub fn with_sharing_section(mut self) -> Self {
        if self.method.sharing() && self.sharing.is_none() {
            self.sharing = Some(self.sharing_config());
        }
        self
    }

    /// Both optional sections written out: what a loaded config and a run's
    /// `config.toml` hold.
    fn with_sections_written(self) -> Self {
        self.with_algorithm_section().with_sharing_section()
    }

    /// The chosen algorithm's settings, as read with the config (the
    /// rule's defaults when `algorithm` was changed to one the file has no
    /// section of).
    ///
    /// ```
    /// use fmsr::experiment::ExperimentConfig;
    /// use fmsr::nn::Matd3Rule;
    /// let text = "name = \"x\"\nmethod = \"dense\"\nalgorithm = \"matd3\"\n[matd3]\npolicy_delay = 3\n";
    /// let config = ExperimentConfig::from_toml(text, "x.toml".as_ref())?;
    /// let settings = config.algorithm_settings()?;
    /// assert_eq!(settings.get::<Matd3Rule>()?.policy_delay, 3);
    /// assert_eq!(settings.to_table()?["policy_delay"].as_integer(), Some(3));
    /// # Ok::<(), fmsr::error::ExperimentError>(())
    /// ```
    ///
    /// # Errors
    /// [`ExperimentError::Config`] for an algorithm that is not registered.
    pub fn algorithm_settings(&self) -> Result<AlgorithmSettings, ExperimentError> {
        match self.algorithm_settings.get(&self.algorithm) {
            Some(settings) => Ok(settings.clone()),
            None => AlgorithmSettings::resolve(&self.algorithm, None),
        }
    }

    /// Rule `R`'s settings in this config (its section, defaults where the
    /// config left them out), e.g. `config.algorithm_config::<MaddpgRule>()`.
    ///
    /// ```
    /// use fmsr::experiment::ExperimentConfig;
    /// use fmsr::nn::Matd3Rule;
    /// let text = "name = \"x\"\nmethod = \"dense\"\nalgorithm = \"matd3\"\n[matd3]\npolicy_delay = 3\n";
    /// let config = ExperimentConfig::from_toml(text, "x.toml".as_ref())?;
    /// assert_eq!(config.algorithm_config::<Matd3Rule>()?.policy_delay, 3);
    /// # Ok::<(), fmsr::error::ExperimentError>(())
    /// ```
    ///
    /// # Errors
    /// [`ExperimentError::Config`] naming the section when its settings are not `R`'s.
    pub fn algorithm_config<R: ConfiguredRule>(&self) -> Result<R::Config, ExperimentError> {
        match self.algorithm_settings.get(R::NAME) {
            Some(settings) => settings.get::<R>().cloned(),
            None => Ok(R::default_config()),
        }
    }

    /// The config with algorithm `R` and these settings.
    ///
    /// ```
    /// use fmsr::experiment::ExperimentConfig;
    /// use fmsr::nn::{Matd3Config, Matd3Rule};
    /// let config = ExperimentConfig::from_toml("name = \"x\"\nmethod = \"dense\"\n", "x.toml".as_ref())?;
    /// let config = config.with_algorithm::<Matd3Rule>(&Matd3Config::new().with_policy_delay(3))?;
    /// assert_eq!((config.algorithm.as_str(), config.label().as_str()), ("matd3", "Dense, MATD3"));
    /// assert!(config.to_toml()?.contains("policy_delay = 3"));
    /// # Ok::<(), fmsr::error::ExperimentError>(())
    /// ```
    ///
    /// # Errors
    /// [`ExperimentError::Config`] when `R` is not registered
    /// ([`algorithms::register`]) or its settings are impossible.
    pub fn with_algorithm<R: ConfiguredRule>(mut self, config: &R::Config) -> Result<Self, ExperimentError> {
        let section = toml::Table::try_from(config)
            .map_err(|e| ExperimentError::config_source(R::NAME, "the settings cannot be written as TOML", e))?;
        let settings = AlgorithmSettings::resolve(R::NAME, Some(&section))?;
        settings.get::<R>()?;
        self.algorithm = R::NAME.into();
        self.algorithm_settings.insert(self.algorithm.clone(), settings);
        Ok(self)
    }
}

mod key;
#[cfg(test)]
mod label_tests;

pub use key::{Distinction, RunKey};
