//! The registry's guarantees.

use super::*;
use fmsr_envs::shadow_hand::Engine;
use fmsr_envs::team_reach::{TeamReach, TeamReachConfig};

/// TeamReach registered as a task of name `$name`.
macro_rules! reach_task {
    ($(#[$doc:meta])* $task:ident, $name:literal) => {
        $(#[$doc])*
        struct $task;

        impl Task for $task {
            const NAME: &'static str = $name;
            type Config = TeamReachConfig;
            type Env = TeamReach;

            fn env(config: &TeamReachConfig) -> Result<TeamReach, fmsr_envs::EnvError> {
                config.init()
            }
        }
    };
}

reach_task!(Reach, "reach_test");
reach_task!(
    /// Another task of `Reach`'s name.
    Impostor,
    "reach_test"
);
reach_task!(
    /// A task of an algorithm's name.
    Maddpg,
    "maddpg"
);
reach_task!(
    /// A task that claims the Shadow Hand's name.
    Hand,
    "shadow_hand"
);

/// A task whose measures are as `MEASURES` names and `VALUES` gives.
struct Measured<const K: usize>;

macro_rules! measured {
    ($k:literal, $name:literal, $measures:expr, $values:expr) => {
        impl Task for Measured<$k> {
            const NAME: &'static str = $name;
            type Config = TeamReachConfig;
            type Env = TeamReach;

            fn env(config: &TeamReachConfig) -> Result<TeamReach, fmsr_envs::EnvError> {
                config.init()
            }

            const MEASURES: &'static [&'static str] = $measures;

            fn measure(_: &TeamReach, episode: &Episode) -> Vec<f64> {
                $values(episode)
            }
        }
    };
}

measured!(0, "measured_ok", &["steps", "last_reward"], |e: &Episode| vec![e.infos.len() as f64, -1.0]);
measured!(1, "measured_short", &["steps", "last_reward"], |e: &Episode| vec![e.infos.len() as f64]);
measured!(2, "measured_nan", &["steps"], |_: &Episode| vec![f64::NAN]);
measured!(3, "measured_upper", &["Steps"], |_: &Episode| vec![0.0]);
measured!(4, "measured_twice", &["steps", "steps"], |_: &Episode| vec![0.0, 0.0]);

// Guards a task's own evaluation measures: names that are keys, each
// once, checked at registration; one finite value a name for each
// episode, from the task's own environment, else an error naming the
// task and the measure.
#[test]
fn a_tasks_measures_are_checked() {
    for err in [register::<Measured<3>>(), register::<Measured<4>>()] {
        let err = err.unwrap_err().to_string();
        assert!(err.contains("measure") && err.contains("teps"), "{err}");
    }
    register::<Reach>().unwrap();
    let reach = TaskSettings::resolve("reach_test", None).unwrap();
    let mut env = reach.envs(1).unwrap().pop().unwrap();
    let mut episode = Episode { observations: vec![env.reset(3).unwrap()], ..Episode::default() };
    let zero = JointAction::zeros(env.spec().action_dim);
    for _ in 0..4 {
        let outcome = env.step(&zero).unwrap();
        episode.observations.push(outcome.observation);
        episode.actions.push(zero.clone());
        episode.infos.push(outcome.info);
    }
    assert!(reach.measures().is_empty() && reach.measure(&env, &episode).unwrap().is_empty());
    register::<Measured<0>>().unwrap();
    register::<Measured<1>>().unwrap();
    register::<Measured<2>>().unwrap();
    let measure = |task: &str| TaskSettings::resolve(task, None).unwrap().measure(&env, &episode);
    assert_eq!(measure("measured_ok").unwrap(), [4.0, -1.0]);
    let err = measure("measured_short").unwrap_err().to_string();
    assert!(err.contains("measured_short") && err.contains("gave 1 measure value(s)"), "{err}");
    let err = measure("measured_nan").unwrap_err().to_string();
    assert!(err.contains("measured_nan") && err.contains("`steps` is NaN"), "{err}");
    let other = AnyEnv::new(env);
    let err = TaskSettings::resolve("measured_ok", None).unwrap().measure(&other, &episode).unwrap_err();
    assert!(err.to_string().contains("measured_ok"), "{err}");
}

// Guards the registry's promise: a name finds one task. A second task
// of a taken name, an algorithm's name and the Shadow Hand's are refused.
#[test]
fn a_name_finds_one_task() {
    register::<Reach>().unwrap();
    register::<Reach>().unwrap();
    let err = register::<Impostor>().unwrap_err();
    assert!(matches!(err, ExperimentError::Register { .. }), "{err}");
    assert!(!err.to_string().contains("the algorithm"), "a task is not called an algorithm: {err}");
    assert_eq!(find("reach_test").unwrap().task(), TypeId::of::<Reach>());
    let err = register::<Maddpg>().unwrap_err().to_string();
    assert!(err.contains("algorithm"), "{err}");
    assert!(names().contains(&SHADOW_HAND) && names().contains(&"reach_test"));
    let err = find("no_such_task").map(|_| ()).unwrap_err().to_string();
    assert!(err.contains("no_such_task") && err.contains("shadow_hand"), "{err}");
}

// Guards reading a section once into the task's own type: defaults for
// what it leaves out, an unknown key named, the typed settings given
// back only as their own task's.
#[test]
fn a_section_is_read_as_the_tasks_settings() {
    register::<Reach>().unwrap();
    let all = TaskSettings::resolve("reach_test", None).unwrap();
    assert_eq!(all.to_table().unwrap(), toml::Table::try_from(TeamReachConfig::default()).unwrap());
    let err = TaskSettings::resolve("reach_test", Some(&"warp = 1".parse().unwrap())).unwrap_err();
    assert!(err.to_string().contains("`reach_test.warp`"), "{err}");
    let env = all.envs(1).unwrap().pop().unwrap();
    assert_eq!(env.spec(), TeamReachConfig::default().init().unwrap().spec());
    let mut other = toml::Table::try_from(TeamReachConfig::default()).unwrap();
    let key = other.keys().next().unwrap().clone();
    let changed = TaskSettings::resolve(
        "reach_test",
        Some(&std::iter::once((key.clone(), other.remove(&key).unwrap())).collect()),
    );
    assert_eq!(changed.unwrap(), all, "a section that repeats the defaults reads as the defaults");
    assert!(all.get::<Reach>().is_ok());
    let err = all.get::<Maddpg>().unwrap_err().to_string();
    assert!(err.contains("reach_test") && err.contains("maddpg"), "{err}");
}

// Guards the Shadow Hand's place in the registry: there before any
// registration, as fmsr's own task type, which registers again as a no-op
// while another type of its name is refused; settings made in code are
// given back only as their own task's.
#[test]
fn the_shadow_hand_is_a_registered_task() {
    assert!(names().contains(&SHADOW_HAND));
    assert_eq!(find(SHADOW_HAND).unwrap().task(), TypeId::of::<ShadowHandTask>());
    register::<ShadowHandTask>().unwrap();
    let err = register::<Hand>().unwrap_err().to_string();
    assert!(err.contains("fmsr's own task"), "{err}");
    assert_eq!(find(SHADOW_HAND).unwrap().task(), TypeId::of::<ShadowHandTask>());
    let settings = ShadowHandSettings { engine: Engine::Mujoco, ..ShadowHandSettings::default() };
    let hand = TaskSettings::new::<ShadowHandTask>(settings.clone()).unwrap();
    assert_eq!(hand.name(), SHADOW_HAND);
    assert_eq!(hand.get::<ShadowHandTask>().unwrap(), &settings);
    assert_eq!(hand.to_table().unwrap(), toml::Table::try_from(&settings).unwrap());
    let err = TaskSettings::new::<Hand>(TeamReachConfig::default()).unwrap_err().to_string();
    assert!(err.contains("shadow_hand"), "{err}");
    assert!(hand.get::<Reach>().is_err());
}
