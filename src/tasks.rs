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
//! The Shadow Hand is the task `"shadow_hand"`, every experiment's default:
//! its settings are the `[env]` section and `engine`, and its evaluation
//! measures the grasp as the paper does ([`crate::evaluate`]). A registered
//! task reads its `[<name>]` section instead (keys it does not have are
//! refused naming them, and the run's `config.toml` writes every setting
//! out), and is evaluated by the measures every task has
//! ([`crate::task_eval`]). The registry is one per process, as the command
//! line that reads configs is.

use std::any::TypeId;
use std::collections::BTreeMap;
use std::marker::PhantomData;
use std::sync::{Arc, LazyLock, PoisonError, RwLock};

use fmsr_core::env::AnyEnv;
use fmsr_core::prelude::*;
use serde::de::DeserializeOwned;
use serde::{Deserialize as _, Serialize};

use crate::error::ExperimentError;

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
    type Config: Serialize + DeserializeOwned + Default;

    /// Its environment; the experiment builds `trainer.envs` of them.
    type Env: Env + Send + 'static;

    /// An environment of these settings.
    ///
    /// # Errors
    /// Settings the environment refuses.
    fn env(config: &Self::Config) -> Result<Self::Env, <Self::Env as Env>::Error>;
}

/// What the registry keeps of one task.
pub(crate) trait Entry: Send + Sync {
    /// The task's type, to tell a second registration from a clash.
    fn task(&self) -> TypeId;

    /// The settings of `section` (absent: all defaults), every setting
    /// written out; `Err` holds what is wrong, naming the key.
    fn resolve(&self, section: Option<&toml::Table>) -> Result<toml::Table, ExperimentError>;

    /// An environment of resolved settings.
    fn env(&self, settings: &toml::Table) -> Result<AnyEnv, ExperimentError>;
}

struct TaskEntry<T>(PhantomData<fn() -> T>);

impl<T: Task> Entry for TaskEntry<T> {
    fn task(&self) -> TypeId {
        TypeId::of::<T>()
    }

    fn resolve(&self, section: Option<&toml::Table>) -> Result<toml::Table, ExperimentError> {
        let config = crate::algorithms::resolve_section(T::NAME, &T::Config::default(), section)?;
        toml::Table::try_from(config)
            .map_err(|e| ExperimentError::config_source(T::NAME, "the settings cannot be written as TOML", e))
    }

    fn env(&self, settings: &toml::Table) -> Result<AnyEnv, ExperimentError> {
        let config = T::Config::deserialize(toml::Value::Table(settings.clone())).map_err(|e| {
            ExperimentError::config_source(T::NAME, format!("`[{}]` does not read as its settings", T::NAME), e)
        })?;
        let env = T::env(&config).map_err(|e| ExperimentError::Context {
            what: format!("building the task `{}`", T::NAME),
            source: Box::new(e),
        })?;
        Ok(AnyEnv::new(env))
    }
}

type Registry = BTreeMap<&'static str, Arc<dyn Entry>>;

static REGISTRY: LazyLock<RwLock<Registry>> = LazyLock::new(|| RwLock::new(Registry::new()));

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
    if name == SHADOW_HAND {
        return refuse("`shadow_hand` is fmsr's own task".into());
    }
    if crate::algorithms::names().contains(&name) {
        return refuse(format!("an algorithm is registered as `{name}`, and its section would be the task's"));
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

/// The tasks' names, `shadow_hand` and every registered one, sorted.
#[must_use]
pub fn names() -> Vec<&'static str> {
    names_of(&REGISTRY.read().unwrap_or_else(PoisonError::into_inner))
}

/// The entry of registered task `name` (not `shadow_hand`).
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
    let mut names: Vec<_> = registry.keys().copied().chain([SHADOW_HAND]).collect();
    names.sort_unstable();
    names
}

/// Takes the task of an experiment's TOML `value` out of it: its name
/// (`task`, default `shadow_hand`) and, for a registered task, its `[<name>]`
/// section resolved (every setting written out). A registered task refuses
/// the Shadow Hand's `[env]` and `engine`.
///
/// # Errors
/// [`ExperimentError::Config`] naming the key.
pub(crate) fn take_section(
    value: &mut toml::Table,
    algorithm: &str,
) -> Result<(String, Option<toml::Table>), ExperimentError> {
    let bad = |key: &str, reason: String| ExperimentError::config(key, reason);
    let name = match value.get("task") {
        None => return Ok((SHADOW_HAND.into(), None)),
        Some(toml::Value::String(name)) => name.clone(),
        Some(_) => return Err(bad("task", "must be a string, the name of a task".into())),
    };
    if name == SHADOW_HAND {
        return Ok((name, None));
    }
    let entry = find(&name)?;
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
    let settings = entry.resolve(section.as_ref())?;
    Ok((name, Some(settings)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use fmsr_envs::team_reach::{TeamReach, TeamReachConfig};

    struct Reach;

    impl Task for Reach {
        const NAME: &'static str = "reach_test";
        type Config = TeamReachConfig;
        type Env = TeamReach;

        fn env(config: &TeamReachConfig) -> Result<TeamReach, fmsr_envs::EnvError> {
            config.init()
        }
    }

    struct Impostor;

    impl Task for Impostor {
        const NAME: &'static str = "reach_test";
        type Config = TeamReachConfig;
        type Env = TeamReach;

        fn env(config: &TeamReachConfig) -> Result<TeamReach, fmsr_envs::EnvError> {
            config.init()
        }
    }

    struct Maddpg;

    impl Task for Maddpg {
        const NAME: &'static str = "maddpg";
        type Config = TeamReachConfig;
        type Env = TeamReach;

        fn env(config: &TeamReachConfig) -> Result<TeamReach, fmsr_envs::EnvError> {
            config.init()
        }
    }

    // Guards the registry's promise: a name finds one task. A second task
    // of a taken name, an algorithm's name and the Shadow Hand's are refused.
    #[test]
    fn a_name_finds_one_task() {
        register::<Reach>().unwrap();
        register::<Reach>().unwrap();
        assert!(matches!(register::<Impostor>(), Err(ExperimentError::Register { .. })));
        assert_eq!(find("reach_test").unwrap().task(), TypeId::of::<Reach>());
        let err = register::<Maddpg>().unwrap_err().to_string();
        assert!(err.contains("algorithm"), "{err}");
        assert!(names().contains(&SHADOW_HAND) && names().contains(&"reach_test"));
        let err = find("no_such_task").map(|_| ()).unwrap_err().to_string();
        assert!(err.contains("no_such_task") && err.contains("shadow_hand"), "{err}");
    }

    #[test]
    fn a_section_is_resolved_against_the_tasks_settings() {
        register::<Reach>().unwrap();
        let entry = find("reach_test").unwrap();
        let all = entry.resolve(None).unwrap();
        assert_eq!(all, toml::Table::try_from(TeamReachConfig::default()).unwrap());
        let err = entry.resolve(Some(&"warp = 1".parse().unwrap())).unwrap_err();
        assert!(err.to_string().contains("`reach_test.warp`"), "{err}");
        let env = entry.env(&all).unwrap();
        assert_eq!(env.spec(), TeamReachConfig::default().init().unwrap().spec());
    }
}
