//! Tasks found by name: the registry behind an experiment's
//! `task = "<name>"` and its `[<name>]` section, as [`crate::algorithms`] is
//! for `algorithm = "<name>"`.
//!
//! A task is an environment of your own crate ([`Env`]) with its settings:
//! it implements [`Task`] and is registered with one call; then fmsr's
//! configs, factory, runner and command line train, resume, export and
//! evaluate it as they do the Shadow Hand, with any registered algorithm,
//! the shadow rewards of its features and information sharing over its
//! agents' graph:
//!
//! ```
//! use fmsr::tasks::{self, Task};
//! use fmsr::envs::team_reach::{TeamReach, TeamReachConfig};
//!
//! /// fmsr-envs' small test task, chosen by `task = "team_reach"`.
//! struct Reach;
//!
//! impl Task for Reach {
//!     const NAME: &'static str = "team_reach";
//!     type Config = TeamReachConfig;
//!     type Env = TeamReach;
//!
//!     fn env(config: &TeamReachConfig) -> Result<TeamReach, fmsr::envs::EnvError> {
//!         config.init()
//!     }
//! }
//!
//! tasks::register::<Reach>()?;
//! assert!(tasks::names().contains(&"team_reach"));
//! # Ok::<(), fmsr::error::ExperimentError>(())
//! ```
//!
//! The Shadow Hand is the task `"shadow_hand"` ([`ShadowHandTask`]), every
//! experiment's default, in the registry from the start and trained through
//! the same entry as yours. Its settings are the `[env]` section and
//! `engine`, and its evaluation measures the grasp as the paper does
//! ([`crate::evaluate`]). A task of your own reads its `[<name>]` section
//! instead (keys it does not have are refused naming them, and the run's
//! `config.toml` writes every setting out), and is evaluated by the
//! measures every task has and its own ([`crate::task_eval`]). The registry
//! is one per process, as the command line that reads configs is.

use std::any::{Any, TypeId};
use std::collections::BTreeMap;
use std::marker::PhantomData;
use std::sync::{Arc, LazyLock, PoisonError, RwLock};

use fmsr_core::env::AnyEnv;
use fmsr_core::prelude::*;
use serde::Serialize;
use serde::de::DeserializeOwned;

use crate::error::ExperimentError;

mod shadow_hand;

pub use self::shadow_hand::{ShadowHandSettings, ShadowHandTask};

/// The name of the Shadow Hand task, the default of every experiment.
pub const SHADOW_HAND: &str = "shadow_hand";

/// A task of your own crate, trained and evaluated by name; see the
/// [module docs](self).
pub trait Task: 'static {
    /// The name a config chooses it by (`task = "<NAME>"`) and of its
    /// settings' section: a lowercase key (`a-z`, `0-9`, `_`).
    const NAME: &'static str;

    /// The settings of its `[<NAME>]` section; its [`Default`] holds the
    /// value of every key the section leaves out.
    type Config: Serialize + DeserializeOwned + Default + Send + Sync + 'static;

    /// Its environment; the experiment builds `trainer.envs` of them.
    type Env: Env + Send + 'static;

    /// An environment of these settings.
    ///
    /// # Errors
    /// Settings the environment refuses.
    fn env(config: &Self::Config) -> Result<Self::Env, <Self::Env as Env>::Error>;

    /// The names of the task's own evaluation measures, in the order
    /// [`Task::measure`] gives their values: lowercase keys (`a-z`, `0-9`,
    /// `_`), each once. None by default.
    const MEASURES: &'static [&'static str] = &[];

    /// The task's own measures of one evaluation episode, a finite value
    /// for each name of [`Task::MEASURES`] in its order: `env` as the
    /// episode's last step left it, `episode` its observations, joint
    /// actions and step infos. `fmsr eval` keeps each episode's values and
    /// reports their mean and standard deviation across the episodes, and
    /// `fmsr report` sets them beside the success rates. What a measure
    /// needs of every step, the environment can count itself between
    /// resets. None by default.
    fn measure(env: &Self::Env, episode: &Episode) -> Vec<f64> {
        let _ = (env, episode);
        Vec::new()
    }
}

/// A registered task's settings, read once: the task's own
/// [`Task::Config`], every setting resolved (the section's keys over the
/// task's defaults), beside the registry's entry that reads it. An
/// experiment keeps these from the moment it is loaded; building its
/// environments and writing a run take them as they are, as
/// [`crate::algorithms::AlgorithmSettings`] for its algorithm.
#[derive(Clone)]
pub struct TaskSettings {
    entry: Arc<dyn Entry>,
    config: Arc<dyn Any + Send + Sync>,
}

impl TaskSettings {
    /// The settings of registered task `name` from its section (absent:
    /// the task's defaults).
    ///
    /// # Errors
    /// [`ExperimentError::Config`] for a task not registered (key `task`),
    /// an unknown key or a value of the wrong type, naming the key.
    pub fn resolve(name: &str, section: Option<&toml::Table>) -> Result<Self, ExperimentError> {
        let entry = find(name)?;
        let config = entry.resolve(section)?;
        Ok(Self { entry, config })
    }

    /// Task `T`'s settings as given, for settings made in code rather than
    /// read from a section.
    ///
    /// # Errors
    /// [`ExperimentError::Config`] for key `task` when `T` is not registered.
    pub fn new<T: Task>(config: T::Config) -> Result<Self, ExperimentError> {
        let entry = find(T::NAME)?;
        if entry.task() != TypeId::of::<T>() {
            return Err(ExperimentError::config(
                "task",
                format!("another task than the one given is registered as `{}`", T::NAME),
            ));
        }
        Ok(Self { entry, config: Arc::new(config) })
    }

    /// The task's registered name.
    #[must_use]
    pub fn name(&self) -> &'static str {
        self.entry.name()
    }

    /// Task `T`'s own settings.
    ///
    /// # Errors
    /// [`ExperimentError::Config`] for key `task` when these are another
    /// task's settings.
    pub fn get<T: Task>(&self) -> Result<&T::Config, ExperimentError> {
        match self.config.downcast_ref::<T::Config>() {
            Some(config) if self.entry.task() == TypeId::of::<T>() => Ok(config),
            _ => Err(ExperimentError::config(
                "task",
                format!("these are the settings of `{}`, not of `{}`", self.name(), T::NAME),
            )),
        }
    }

    /// The settings as the task's TOML section, every setting written out.
    ///
    /// # Errors
    /// [`ExperimentError::Config`] when a value cannot be written as TOML.
    pub fn to_table(&self) -> Result<toml::Table, ExperimentError> {
        self.entry.write(&*self.config)
    }

    /// `n` environments of these settings.
    ///
    /// # Errors
    /// The task's own errors ([`ExperimentError::Context`]).
    pub fn envs(&self, n: usize) -> Result<Vec<AnyEnv>, ExperimentError> {
        (0..n).map(|_| self.entry.env(&*self.config)).collect()
    }

    /// The names of the task's own evaluation measures ([`Task::MEASURES`]).
    #[must_use]
    pub fn measures(&self) -> &'static [&'static str] {
        self.entry.measures()
    }

    /// The task's own measures of an evaluation `episode` that `env`, one of
    /// [`TaskSettings::envs`], played ([`Task::measure`]).
    ///
    /// # Errors
    /// [`ExperimentError::Config`] for key `task` when `env` is not this
    /// task's environment, or the task gave another number of values than
    /// it has measures, or a value that is not finite, naming the measure.
    pub fn measure(&self, env: &AnyEnv, episode: &Episode) -> Result<Vec<f64>, ExperimentError> {
        let values = self.entry.measure(env, episode)?;
        let names = self.measures();
        let bad = |reason: String| Err(ExperimentError::config("task", format!("`{}`: {reason}", self.name())));
        if values.len() != names.len() {
            return bad(format!("gave {} measure value(s) for its {} measure(s) {names:?}", values.len(), names.len()));
        }
        if let Some((name, value)) = names.iter().zip(&values).find(|(_, v)| !v.is_finite()) {
            return bad(format!("its measure `{name}` is {value}, which is not finite"));
        }
        Ok(values)
    }
}

impl PartialEq for TaskSettings {
    /// The same task with the same settings as TOML writes them (a task's
    /// settings need not implement `PartialEq`).
    fn eq(&self, other: &Self) -> bool {
        self.entry.task() == other.entry.task()
            && matches!((self.to_table(), other.to_table()), (Ok(a), Ok(b)) if a == b)
    }
}

impl std::fmt::Debug for TaskSettings {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let mut d = f.debug_struct("TaskSettings");
        d.field("task", &self.name());
        match self.to_table() {
            Ok(table) => d.field("settings", &table),
            Err(_) => d.field("settings", &"(not writable as TOML)"),
        };
        d.finish()
    }
}

/// What the registry keeps of one task. Its methods take the task's
/// settings as the [`TaskSettings`] it made hold them (`&dyn Any`: the
/// task's `Config`).
pub(crate) trait Entry: Send + Sync {
    /// The task's type, to tell a second registration from a clash.
    fn task(&self) -> TypeId;

    /// The task's name.
    fn name(&self) -> &'static str;

    /// The settings of `section` (absent: all defaults); the error names the key.
    fn resolve(&self, section: Option<&toml::Table>) -> Result<Arc<dyn Any + Send + Sync>, ExperimentError>;

    /// The settings written out as the task's section.
    fn write(&self, config: &dyn Any) -> Result<toml::Table, ExperimentError>;

    /// An environment of these settings.
    fn env(&self, config: &dyn Any) -> Result<AnyEnv, ExperimentError>;

    /// The names of the task's own measures.
    fn measures(&self) -> &'static [&'static str];

    /// The task's own measures of an episode `env` played.
    fn measure(&self, env: &AnyEnv, episode: &Episode) -> Result<Vec<f64>, ExperimentError>;
}

struct TaskEntry<T>(PhantomData<fn() -> T>);

impl<T: Task> TaskEntry<T> {
    /// The task's settings; [`TaskSettings`] pairs every entry with
    /// settings it resolved itself, so another type is a bug of this module.
    fn config(config: &dyn Any) -> &T::Config {
        config.downcast_ref::<T::Config>().expect("an entry is only given the settings it resolved")
    }
}

impl<T: Task> Entry for TaskEntry<T> {
    fn task(&self) -> TypeId {
        TypeId::of::<T>()
    }

    fn name(&self) -> &'static str {
        T::NAME
    }

    fn resolve(&self, section: Option<&toml::Table>) -> Result<Arc<dyn Any + Send + Sync>, ExperimentError> {
        Ok(Arc::new(crate::algorithms::resolve_section(T::NAME, &T::Config::default(), section)?))
    }

    fn write(&self, config: &dyn Any) -> Result<toml::Table, ExperimentError> {
        toml::Table::try_from(Self::config(config))
            .map_err(|e| ExperimentError::config_source(T::NAME, "the settings cannot be written as TOML", e))
    }

    fn env(&self, config: &dyn Any) -> Result<AnyEnv, ExperimentError> {
        let env = T::env(Self::config(config)).map_err(|e| ExperimentError::Context {
            what: format!("building the task `{}`", T::NAME),
            source: Box::new(e),
        })?;
        Ok(AnyEnv::new(env))
    }

    fn measures(&self) -> &'static [&'static str] {
        T::MEASURES
    }

    fn measure(&self, env: &AnyEnv, episode: &Episode) -> Result<Vec<f64>, ExperimentError> {
        let env = env.downcast_ref::<T::Env>().ok_or_else(|| {
            ExperimentError::config("task", format!("the environment measured is not the task `{}`'s", T::NAME))
        })?;
        Ok(T::measure(env, episode))
    }
}

type Registry = BTreeMap<&'static str, Arc<dyn Entry>>;

/// The registry, holding the Shadow Hand from the start.
static REGISTRY: LazyLock<RwLock<Registry>> = LazyLock::new(|| {
    let hand: Arc<dyn Entry> = Arc::new(TaskEntry::<ShadowHandTask>(PhantomData));
    RwLock::new(Registry::from([(SHADOW_HAND, hand)]))
});

/// Registers task `T` under its name, so that configs may say
/// `task = "<T::NAME>"` and set its settings in `[<T::NAME>]`.
/// Registering the same task again does nothing.
///
/// # Errors
/// [`ExperimentError::Register`] when another task or an algorithm holds the
/// name, or the name is not a lowercase key (`a-z`, `0-9`, `_`, starting
/// with a letter), is `shadow_hand` or one of an experiment's own keys.
pub fn register<T: Task>() -> Result<(), ExperimentError> {
    let name = T::NAME;
    let refuse = |reason: String| Err(ExperimentError::Register { name: name.into(), reason });
    if let Err(reason) = crate::algorithms::check_key(name) {
        return refuse(reason);
    }
    if name == SHADOW_HAND && TypeId::of::<T>() != TypeId::of::<ShadowHandTask>() {
        return refuse("`shadow_hand` is fmsr's own task".into());
    }
    if crate::algorithms::names().contains(&name) {
        return refuse(format!("an algorithm is registered as `{name}`, and its section would be the task's"));
    }
    for (i, measure) in T::MEASURES.iter().enumerate() {
        if !crate::algorithms::is_lowercase_key(measure) {
            return refuse(format!("its measure `{measure}` is not a lowercase key (a-z, 0-9 and _, from a letter)"));
        }
        if T::MEASURES[..i].contains(measure) {
            return refuse(format!("it names its measure `{measure}` twice"));
        }
    }
    let mut registry = REGISTRY.write().unwrap_or_else(PoisonError::into_inner);
    match registry.get(name) {
        Some(entry) if entry.task() == TypeId::of::<T>() => Ok(()),
        Some(_) => refuse(format!("another task is registered as `{name}`")),
        None => {
            registry.insert(name, Arc::new(TaskEntry::<T>(PhantomData)));
            Ok(())
        }
    }
}

/// The registered tasks' names, `shadow_hand` among them, sorted.
#[must_use]
pub fn names() -> Vec<&'static str> {
    names_of(&REGISTRY.read().unwrap_or_else(PoisonError::into_inner))
}

/// The entry of registered task `name`.
///
/// # Errors
/// [`ExperimentError::Config`] for key `task`, listing the tasks.
pub(crate) fn find(name: &str) -> Result<Arc<dyn Entry>, ExperimentError> {
    let registry = REGISTRY.read().unwrap_or_else(PoisonError::into_inner);
    registry.get(name).cloned().ok_or_else(|| {
        ExperimentError::config(
            "task",
            format!(
                "no task `{name}`; there are: {} (a task of your own crate is registered with fmsr::tasks::register)",
                names_of(&registry).join(", ")
            ),
        )
    })
}

fn names_of(registry: &Registry) -> Vec<&'static str> {
    registry.keys().copied().collect()
}

/// Takes the task of an experiment's TOML `value` out of it: its name
/// (`task`, default `shadow_hand`) and, for a registered task, its `[<name>]`
/// section read as its settings. A registered task refuses the Shadow
/// Hand's `[env]` and `engine`.
///
/// # Errors
/// [`ExperimentError::Config`] naming the key.
pub(crate) fn take_section(
    value: &mut toml::Table,
    algorithm: &str,
) -> Result<(String, Option<TaskSettings>), ExperimentError> {
    let bad = |key: &str, reason: String| ExperimentError::config(key, reason);
    let name = match value.get("task") {
        None => return Ok((SHADOW_HAND.into(), None)),
        Some(toml::Value::String(name)) => name.clone(),
        Some(_) => return Err(bad("task", "must be a string, the name of a task".into())),
    };
    if name == SHADOW_HAND {
        return Ok((name, None));
    }
    find(&name)?;
    if name == algorithm {
        return Err(bad("task", format!("`{name}` is also the algorithm's name, and the two would share `[{name}]`")));
    }
    for key in ["env", "engine"] {
        if value.contains_key(key) {
            return Err(bad(
                key,
                format!("`task = \"{name}\"` does not read the Shadow Hand's `{key}`: its settings are `[{name}]`"),
            ));
        }
    }
    let section = match value.remove(&name) {
        None => None,
        Some(toml::Value::Table(section)) => Some(section),
        Some(_) => return Err(bad(&name, "must be a table".into())),
    };
    let settings = TaskSettings::resolve(&name, section.as_ref())?;
    Ok((name, Some(settings)))
}

#[cfg(test)]
mod tests;
