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
use std::sync::Arc;

use serde::{Deserialize, Serialize};

use fmsr_core::method::Method;
use fmsr_core::prelude::*;
use fmsr_core::replay::ReplayConfig;
use fmsr_core::shadow::ShadowConfig;
use fmsr_core::sharing::{ShareMode, ShareTarget, SharingConfig};
use fmsr_envs::shadow_hand::{GoalDistance, ShadowHandConfig};

pub use crate::error::ExperimentError;
use fmsr_graph::Graph;
use fmsr_nn::{ConfiguredRule, CriticTying, Device, DeviceSpec, NetworkConfig, NormalizerStats, TargetClip, Teammates};

use crate::algorithms;
pub use crate::stack::Stack;

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
    /// The learning algorithm by its registered name
    /// ([`crate::algorithms`]; default `"maddpg"`, the paper's).
    #[serde(default = "default_algorithm")]
    pub algorithm: String,
    /// The physics engine.
    #[serde(default)]
    pub engine: Engine,
    /// The burn device the networks live on: `"cpu"` (burn's `flex`, default),
    /// or with the `wgpu` / `vulkan` / `cuda` features a GPU such as `"wgpu:0"`,
    /// `"vulkan:0"`, `"cuda:0"` or `"wgpu:cpu"` ([`parse_device`]).
    #[serde(default = "default_device")]
    pub device: String,
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
    /// The algorithms' own sections by name, each with every setting
    /// written out; the chosen algorithm's is the `[<algorithm>]` of the
    /// file ([`ExperimentConfig::algorithm_config`]).
    #[serde(skip)]
    algorithm_sections: BTreeMap<String, toml::Table>,
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

fn default_device() -> String {
    "cpu".into()
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
    let conflict = |key: &str, reason: String| Err(ExperimentError::Config { key: key.into(), reason });
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
    let invalid = |e: fmsr_nn::NnError| ExperimentError::Config { key: "device".into(), reason: e.to_string() };
    device.parse::<DeviceSpec>().and_then(|d| d.device()).map_err(invalid)
}

impl ExperimentConfig {
    /// Parses a TOML experiment, rejecting unknown keys, wrong types, impossible
    /// values and settings that contradict their owner with a message that
    /// names the key.
    ///
    /// # Errors
    /// [`ExperimentError::Parse`] or [`ExperimentError::Config`].
    pub fn from_toml(text: &str, path: &Path) -> Result<Self, ExperimentError> {
        let parse_err = |message: String| ExperimentError::Parse { path: path.to_path_buf(), message };
        let mut value: toml::Table = toml::from_str(text).map_err(|e| parse_err(e.to_string()))?;
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
        let section = match value.remove(&algorithm) {
            None => None,
            Some(toml::Value::Table(section)) => Some(section),
            Some(_) => return Err(parse_err(format!("`{algorithm}` must be a table"))),
        };
        let settings = algorithms::find(&algorithm)?.resolve(section.as_ref()).map_err(parse_err)?;
        for (key, defaults) in burn_sections().map_err(|e| parse_err(e.to_string()))? {
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
        let mut config =
            ExperimentConfig::deserialize(toml::Value::Table(value)).map_err(|e| parse_err(e.to_string()))?;
        config.algorithm_sections.insert(algorithm, settings);
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

    /// Parses the resolved experiment of a saved run or policy file. A saved
    /// experiment names every setting of `[env]`; one that does not name
    /// `env.goal_distance` is older than the full-angle task, when the only
    /// distance was the yaw error, and is read with `goal_distance = "yaw"`,
    /// so that resuming or evaluating it reproduces its records. A user's
    /// experiment file is read with [`Self::from_toml`], where the default is
    /// the full angle.
    ///
    /// # Errors
    /// As [`Self::from_toml`].
    pub fn from_saved_toml(text: &str, path: &Path) -> Result<Self, ExperimentError> {
        let parse_err = |message: String| ExperimentError::Parse { path: path.to_path_buf(), message };
        let mut value: toml::Table = toml::from_str(text).map_err(|e| parse_err(e.to_string()))?;
        let env = value.entry("env").or_insert_with(|| toml::Value::Table(toml::Table::new()));
        let env = env.as_table_mut().ok_or_else(|| parse_err("`env` must be a table".into()))?;
        if !env.contains_key("goal_distance") {
            env.insert("goal_distance".into(), toml::Value::String(GoalDistance::Yaw.key().into()));
        }
        let text = toml::to_string(&value).map_err(|e| parse_err(e.to_string()))?;
        Self::from_toml(&text, path)
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
        let (_, settings) = self.algorithm_entry()?;
        table.insert(self.algorithm.clone(), toml::Value::Table(settings));
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
        let (entry, settings) = self.algorithm_entry()?;
        entry.validate(&settings)?;
        parse_device(&self.device)?;
        if self.networks.critic == CriticTying::Shared && self.method.shadow() {
            return Err(ExperimentError::Config {
                key: "networks.critic".into(),
                reason: format!(
                    "\"shared\" gives every agent one critic, but {} gives each finger its own shadow reward; \
                     use \"shared_trunk\" (a head per agent)",
                    self.method.label()
                ),
            });
        }
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

    /// The configuration's name in tables and figures: the method's label (e.g.
    /// `Dense+FMSR+IS`), followed by the number of agents when the hand is not
    /// split into the paper's six (e.g. `Sparse, 1 agent`), and by
    /// `current teammates` when the actors' loss takes the teammates' current
    /// policies ([`Teammates::Current`]), `global actors`
    /// ([`ActorView::Global`]) and `shared critic (trunk)`
    /// ([`CriticTying`]); by the shadow rewards' `alpha` where it is not the
    /// default 0.1 (e.g. `alpha 0.03`), and by information sharing's mode and
    /// target where they are not the paper's parameters and actors (`IS on
    /// gradients`, `IS on critics`, `IS on actors and critics`), so that an
    /// ablation is never pooled with the method's runs; by `yaw distance` for
    /// the task of the oldest records (success by the rotation
    /// about Z alone, [`GoalDistance::Yaw`]), so that they are never pooled
    /// with runs of the paper's task; by `paper stack` under
    /// [`Stack::Paper`], and otherwise by `gym distance`, `HER target clip`
    /// and `HER normaliser statistics` for each of its settings alone; and by the algorithm and the training
    /// engine when they are not the paper's (MADDPG, rapier here), e.g. `Dense, MATD3, trained
    /// on MuJoCo`, so that a report never pools runs of two algorithms or two
    /// engines as seeds of one configuration.
    #[must_use]
    pub fn label(&self) -> String {
        let mut label = match &self.env.agents {
            Some(agents) if agents.len() != fmsr_envs::shadow_hand::HandAgent::paper().len() => {
                let n = agents.len();
                format!("{}, {n} agent{}", self.method.label(), if n == 1 { "" } else { "s" })
            }
            _ => self.method.label().into(),
        };
        // An algorithm this process has not registered (a saved run's,
        // read where its crate is absent) is labelled by its name.
        let algorithm = self.algorithm_entry().ok();
        let teammates = algorithm.as_ref().and_then(|(entry, settings)| entry.teammates(settings).ok());
        if teammates == Some(Teammates::Current) {
            label.push_str(", current teammates");
        }
        if self.graph.actor_observation == ActorView::Global {
            label.push_str(", global actors");
        }
        match (self.stack, self.env.goal_distance) {
            (_, GoalDistance::Yaw) => label.push_str(", yaw distance"),
            (Stack::Fmsr, GoalDistance::Gym) => label.push_str(", gym distance"),
            _ => {}
        }
        if self.stack == Stack::Fmsr && self.networks.target_clip == TargetClip::HerBaselines {
            label.push_str(", HER target clip");
        }
        if self.stack == Stack::Fmsr && self.networks.normalizer_stats == NormalizerStats::StoredEpisodes {
            label.push_str(", HER normaliser statistics");
        }
        if self.stack == Stack::Paper {
            label.push_str(", paper stack");
        }
        let shadow = &self.trainer.shadow;
        if self.method.shadow() && shadow.alpha != ShadowConfig::default().alpha {
            label.push_str(&format!(", alpha {}", shadow.alpha));
        }
        if self.method.sharing() {
            let (mode, target) = self
                .sharing
                .as_ref()
                .map_or_else(|| (ShareMode::default(), ShareTarget::default()), |s| (s.mode, s.target));
            if mode == ShareMode::Gradients {
                label.push_str(", IS on gradients");
            }
            match target {
                ShareTarget::Actors => {}
                ShareTarget::Critics => label.push_str(", IS on critics"),
                ShareTarget::Both => label.push_str(", IS on actors and critics"),
            }
        }
        match self.networks.critic {
            CriticTying::PerAgent => {}
            CriticTying::SharedTrunk => label.push_str(", shared critic trunk"),
            CriticTying::Shared => label.push_str(", shared critic"),
        }
        match algorithm {
            Some((entry, _)) => {
                if let Some(name) = entry.label() {
                    label.push_str(&format!(", {name}"));
                }
            }
            None => label.push_str(&format!(", {}", self.algorithm.to_uppercase())),
        }
        if self.engine == Engine::Mujoco {
            label.push_str(", trained on MuJoCo");
        }
        label
    }

    /// Which teammates' actions the chosen algorithm's actor loss takes.
    ///
    /// # Errors
    /// [`ExperimentError::Config`] for an algorithm that is not registered.
    pub fn teammates(&self) -> Result<Teammates, ExperimentError> {
        let (entry, settings) = self.algorithm_entry()?;
        entry.teammates(&settings)
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
        if let Ok((_, settings)) = self.algorithm_entry() {
            self.algorithm_sections.insert(self.algorithm.clone(), settings);
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

    /// The registry's entry of the chosen algorithm and its settings, each
    /// written out (defaults where the config left them out).
    pub(crate) fn algorithm_entry(&self) -> Result<(Arc<dyn algorithms::Entry>, toml::Table), ExperimentError> {
        let entry = algorithms::find(&self.algorithm)?;
        let settings = entry
            .resolve(self.algorithm_sections.get(&self.algorithm))
            .map_err(|reason| ExperimentError::Config { key: self.algorithm.clone(), reason })?;
        Ok((entry, settings))
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
        let bad = |reason: String| ExperimentError::Config { key: R::NAME.into(), reason };
        let mut settings = toml::Table::try_from(R::default_config()).map_err(|e| bad(e.to_string()))?;
        settings.extend(self.algorithm_sections.get(R::NAME).cloned().unwrap_or_default());
        R::Config::deserialize(toml::Value::Table(settings)).map_err(|e| bad(e.to_string()))
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
        let settings = toml::Table::try_from(config)
            .map_err(|e| ExperimentError::Config { key: R::NAME.into(), reason: e.to_string() })?;
        self.algorithm = R::NAME.into();
        self.algorithm_sections.insert(self.algorithm.clone(), settings);
        let (entry, settings) = self.algorithm_entry()?;
        entry.validate(&settings)?;
        Ok(self)
    }
}

#[cfg(test)]
mod label_tests {
    use std::path::Path;

    use super::{Engine, ExperimentConfig, ExperimentError, GoalDistance, Stack, TargetClip};

    // Guards the report's grouping: a single agent owning the whole hand is a
    // configuration of its own, never pooled with the paper's six-agent Sparse.
    #[test]
    fn a_single_agent_config_is_labelled_apart_from_the_paper_method() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/lite");
        let single = ExperimentConfig::load(&root.join("block_single_agent_sparse.toml")).unwrap();
        let six = ExperimentConfig::load(&root.join("block_sparse.toml")).unwrap();
        assert_eq!((single.label(), six.label()), ("Sparse, 1 agent".to_string(), "Sparse".to_string()));
    }

    // Guards the reproducibility of a run: its config.toml names every setting
    // of its algorithm, also those the experiment file left to their defaults,
    // so a later change of a default (say `teammates`) cannot change a run
    // that is resumed or evaluated.
    #[test]
    fn a_written_config_records_the_algorithms_settings() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/block_dense_fmsr_is_quick.toml");
        assert!(!std::fs::read_to_string(&path).unwrap().contains("[maddpg]"));
        let written = ExperimentConfig::load(&path).unwrap().to_toml().unwrap();
        let table: toml::Table = written.parse().unwrap();
        let maddpg = table.get("maddpg").and_then(toml::Value::as_table).expect("a [maddpg] section");
        for key in ["polyak", "teammates", "action_l2"] {
            assert!(maddpg.contains_key(key), "[maddpg] lacks `{key}`:\n{written}");
        }
        assert!(!table.contains_key("matd3") && !table.contains_key("masac"), "{written}");
    }

    // Guards the report's grouping of the teammates ablation: its runs are
    // labelled apart from the method's.
    #[test]
    fn the_current_teammates_ablation_is_labelled_apart() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/lite");
        let ablation =
            ExperimentConfig::load(&root.join("ablation/block_dense_fmsr_is_current_teammates.toml")).unwrap();
        let method = ExperimentConfig::load(&root.join("block_dense_fmsr_is.toml")).unwrap();
        assert_eq!(ablation.label(), "Dense+FMSR+IS, current teammates");
        assert_eq!(method.label(), "Dense+FMSR+IS");
    }

    // Guards the report's grouping by algorithm and training engine: a MATD3
    // or MuJoCo-trained run was once labelled as the method alone, and so
    // pooled with the MADDPG, rapier runs as one more seed.
    #[test]
    fn other_algorithms_and_engines_are_labelled_apart() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/lite");
        let method = ExperimentConfig::load(&root.join("block_dense.toml")).unwrap();
        let with = |algorithm: &str, engine| {
            ExperimentConfig { algorithm: algorithm.into(), engine, ..method.clone() }.label()
        };
        assert_eq!(with("maddpg", Engine::Rapier), "Dense");
        assert_eq!(with("matd3", Engine::Rapier), "Dense, MATD3");
        assert_eq!(with("masac", Engine::Mujoco), "Dense, MASAC, trained on MuJoCo");
        assert_eq!(with("maddpg", Engine::Mujoco), "Dense, trained on MuJoCo");
        assert_eq!(with("not_registered_here", Engine::Rapier), "Dense, NOT_REGISTERED_HERE");
    }

    // Guards the report's grouping of the full-angle experiments: E3's runs with
    // another shadow weight, E5's information sharing on gradients and the
    // runs of the yaw-only task before it were labelled as the method alone,
    // so a report over them and E2's runs pooled them as more seeds of
    // Dense+FMSR+IS, and `fmsr run` set the yaw-era policy beside its run.
    #[test]
    fn shadow_weight_and_sharing_changes_are_labelled_apart() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/lite");
        let method = ExperimentConfig::load(&root.join("egg_dense_fmsr_is.toml")).unwrap();
        assert_eq!(method.label(), "Dense+FMSR+IS");
        let alpha = ExperimentConfig::load(&root.join("alpha/egg_dense_fmsr_is_alpha003.toml")).unwrap();
        assert_eq!(alpha.label(), "Dense+FMSR+IS, alpha 0.03, trained on MuJoCo");
        let gradients = ExperimentConfig::load(&root.join("ablation/egg_dense_fmsr_is_gradient_sharing.toml")).unwrap();
        assert_eq!(gradients.label(), "Dense+FMSR+IS, IS on gradients");
        let mut critics = method.clone();
        critics.sharing.get_or_insert_with(Default::default).target = fmsr_core::sharing::ShareTarget::Both;
        assert_eq!(critics.label(), "Dense+FMSR+IS, IS on actors and critics");
        // A saved run of the yaw-only task (its config names no distance) is another task.
        let yaw = ExperimentConfig::from_saved_toml(
            &method.to_toml().unwrap().replace("goal_distance = \"full\"\n", ""),
            &root,
        )
        .unwrap();
        assert_eq!(yaw.label(), "Dense+FMSR+IS, yaw distance");
        // Dense+FMSR neither shares nor changes its label for sharing's defaults.
        let fmsr = ExperimentConfig::load(&root.join("egg_dense_fmsr.toml")).unwrap();
        assert_eq!(fmsr.label(), "Dense+FMSR");
    }

    /// `section.key` → value of every setting of a TOML file (the run's name left out).
    fn settings(path: &Path) -> std::collections::BTreeMap<String, toml::Value> {
        let table: toml::Table = std::fs::read_to_string(path).unwrap().parse().unwrap();
        let mut out = std::collections::BTreeMap::new();
        for (key, value) in table {
            match value {
                toml::Value::Table(section) => {
                    out.extend(section.into_iter().map(|(k, v)| (format!("{key}.{k}"), v)));
                }
                value if key != "name" => drop(out.insert(key, value)),
                _ => {}
            }
        }
        out
    }

    /// The TOML files of `dir`, sorted.
    fn toml_files(dir: &Path) -> Vec<std::path::PathBuf> {
        let mut files: Vec<_> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|e| e == "toml"))
            .collect();
        files.sort();
        files
    }

    /// The settings in which the ablation config `path` differs from its
    /// method's lite config in `root`, and the labels of the two.
    fn changes(root: &Path, path: &Path) -> (String, std::collections::BTreeSet<String>, [String; 2]) {
        let a = settings(path);
        let name = |key: &str| a[key].as_str().unwrap().to_string();
        let base = format!("{}_{}.toml", name("env.object"), name("method"));
        let b = settings(&root.join(&base));
        let changed = a.keys().chain(b.keys()).filter(|k| a.get(*k) != b.get(*k)).cloned().collect();
        let label = |p: &Path| ExperimentConfig::load(p).unwrap().label();
        (base.clone(), changed, [label(path), label(&root.join(base))])
    }

    // Guards the paper-budget pair on MuJoCo: each config
    // in configs/mujoco/ is the paper's config of its name with `engine`
    // changed, and with the shadow reward's `alpha` (chosen by E3) at most.
    #[test]
    fn paper_configs_on_mujoco_change_the_engine_alone() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("configs");
        let files = toml_files(&root.join("mujoco"));
        assert!(!files.is_empty());
        for path in files {
            let paper = root.join(path.file_name().unwrap());
            let (a, b) = (settings(&path), settings(&paper));
            let changed: std::collections::BTreeSet<_> =
                a.keys().chain(b.keys()).filter(|k| a.get(*k) != b.get(*k)).cloned().collect();
            assert!(changed.contains("engine"), "{}", path.display());
            assert!(
                changed.iter().all(|k| k == "engine" || k == "trainer.shadow.alpha"),
                "{} against {}: {changed:?}",
                path.display(),
                paper.display()
            );
            assert_eq!(a["engine"].as_str(), Some("mujoco"), "{}", path.display());
            let name = |p: &Path| ExperimentConfig::load(p).unwrap().name;
            assert_eq!(name(&path), name(&paper), "{}: the run keeps the paper config's name", path.display());
        }
    }

    // Guards what E6 and E7 compare: each config in configs/lite/paper_stack/
    // is its method's lite config with `stack = "paper"` alone, each in
    // configs/lite/attribution/ changes exactly one of the settings that
    // stack owns, to the stack's value, and every one is labelled apart.
    #[test]
    fn the_paper_stack_runs_change_what_they_say() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/lite");
        let stack = toml_files(&root.join("paper_stack"));
        assert_eq!(stack.len(), 2);
        for path in &stack {
            let (base, changed, [label, method]) = changes(&root, path);
            assert_eq!(changed, ["stack".to_string()].into(), "{} against {base}", path.display());
            assert_eq!(label, format!("{method}, paper stack"));
        }
        let attribution = toml_files(&root.join("attribution"));
        let mut owned = std::collections::BTreeSet::new();
        for path in &attribution {
            let (base, changed, [label, method]) = changes(&root, path);
            assert_eq!(changed.len(), 1, "{} against {base}: {changed:?}", path.display());
            let key = changed.into_iter().next().unwrap();
            let rule = Stack::OWNED.iter().find(|o| o.key == key).expect("a setting the paper stack owns");
            assert_eq!(settings(path)[&key].as_str(), Some(rule.paper), "{}", path.display());
            assert_ne!(label, method);
            owned.insert(key);
        }
        assert_eq!(owned.len(), Stack::OWNED.len(), "one attribution run per owned setting");
    }

    // Guards the preset's ownership: `stack = "paper"` sets both settings,
    // refuses a file that contradicts it (naming the key), and a run's
    // config.toml reads back as the same experiment.
    #[test]
    fn the_paper_stack_owns_its_settings() {
        let text = "name = \"x\"\nmethod = \"dense\"\nstack = \"paper\"\n";
        let config = ExperimentConfig::from_toml(text, "x.toml".as_ref()).unwrap();
        assert_eq!(config.env.goal_distance, GoalDistance::Gym);
        assert_eq!(config.networks.target_clip, TargetClip::HerBaselines);
        assert_eq!(config.networks.normalizer_stats, fmsr_nn::NormalizerStats::StoredEpisodes);
        let again = ExperimentConfig::from_saved_toml(&config.to_toml().unwrap(), "x.toml".as_ref()).unwrap();
        assert_eq!(again, config);
        for (extra, key) in [
            ("[env]\ngoal_distance = \"full\"\n", "env.goal_distance"),
            ("[networks]\ntarget_clip = \"reward_bounds\"\n", "networks.target_clip"),
            ("[networks]\nnormalizer_stats = \"sampled_batches\"\n", "networks.normalizer_stats"),
        ] {
            let err = ExperimentConfig::from_toml(&format!("{text}{extra}"), "x.toml".as_ref()).unwrap_err();
            assert!(matches!(&err, ExperimentError::Config { key: k, .. } if k == key), "{extra}: {err}");
            assert!(err.to_string().contains("stack"), "{err}");
        }
        // The stack's own values are no contradiction, and without the preset each is free.
        let agreeing = format!("{text}[env]\ngoal_distance = \"gym\"\n");
        assert!(ExperimentConfig::from_toml(&agreeing, "x.toml".as_ref()).is_ok());
        let free = "name = \"x\"\nmethod = \"dense\"\n[networks]\ntarget_clip = \"her_baselines\"\n";
        let free = ExperimentConfig::from_toml(free, "x.toml".as_ref()).unwrap();
        assert_eq!((free.stack, free.env.goal_distance), (Stack::Fmsr, GoalDistance::Full));
        assert_eq!(free.label(), "Dense, HER target clip");
    }

    // Guards what the ablations of docs/notebook/results.md claim: each config in
    // configs/lite/ablation/ is its method's lite config with one setting
    // changed, each in ablation/combined/ changes two or more of those
    // settings at once, and their runs are labelled apart from the method's.
    #[test]
    fn every_ablation_changes_one_setting_of_its_methods_config() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/lite");
        let mut switches = std::collections::BTreeSet::new();
        let singles = toml_files(&root.join("ablation"));
        for path in &singles {
            let (base, changed, [ablation, method]) = changes(&root, path);
            assert_eq!(changed.len(), 1, "{} against {base}: {changed:?}", path.display());
            assert_ne!(ablation, method, "{}", path.display());
            switches.extend(changed);
        }
        assert!(singles.len() >= 5, "{} ablation configs", singles.len());
        for path in toml_files(&root.join("ablation/combined")) {
            let (base, changed, [ablation, method]) = changes(&root, &path);
            assert!(changed.len() >= 2, "{} against {base}: {changed:?}", path.display());
            assert!(changed.is_subset(&switches), "{}: {changed:?} not all single switches", path.display());
            assert_ne!(ablation, method, "{}", path.display());
        }
    }
}
