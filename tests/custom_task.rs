//! Guards that a task of a user's crate, registered by name, is trained,
//! resumed, exported, evaluated and reported by fmsr's own command from a
//! config that says `task = "team_reach"`, with its settings written out in
//! the run's `config.toml` and its own evaluation measures in its
//! evaluations and report; and that the Shadow Hand's keys, flags and
//! commands are refused for it with errors that name them.

use fmsr::core::prelude::Episode;
use fmsr::experiment::ExperimentConfig;
use fmsr::task_eval::TaskEvalReport;
use fmsr::tasks::{self, Task};
use fmsr_envs::team_reach::{TeamReach, TeamReachConfig};

/// fmsr-envs' TeamReach, as a user's crate would register it.
struct Reach;

impl Task for Reach {
    const NAME: &'static str = "team_reach";
    type Config = TeamReachConfig;
    type Env = TeamReach;

    fn env(config: &TeamReachConfig) -> Result<TeamReach, fmsr_envs::EnvError> {
        config.init()
    }

    const MEASURES: &'static [&'static str] = &["steps_to_success", "mean_abs_action"];

    fn measure(_env: &TeamReach, episode: &Episode) -> Vec<f64> {
        vec![steps_to_success(episode), mean_abs_action(episode)]
    }
}

/// The steps until the first that says success, all of them if none does.
fn steps_to_success(episode: &Episode) -> f64 {
    let first = episode.infos.iter().position(|i| i.is_success);
    first.map_or(episode.infos.len(), |i| i + 1) as f64
}

/// The mean absolute action component over the episode.
fn mean_abs_action(episode: &Episode) -> f64 {
    let values: Vec<f64> = episode.actions.iter().flat_map(|a| a.as_slice()).map(|x| f64::from(x.abs())).collect();
    values.iter().sum::<f64>() / values.len().max(1) as f64
}

const CONFIG: &str = r#"
name = "reach"
method = "dense_fmsr_is"
task = "team_reach"

[team_reach]
episode_len = 12
step_size = 0.25

[graph]
edges = [["x", "y"], ["y", "w"], ["w", "x"]]

[trainer]
seed = 2
epochs = 1
cycles = 2
eval_episodes = 2

[trainer.shadow]
alpha = 0.05
assignment = { agents = [
  { agent = "x", shadow = ["safe_region"] },
  { agent = "y", shadow = ["gentle"] },
  { agent = "w", shadow = ["safe_region", "gentle"] },
] }

[replay]
batches = 2
batch_size = 32

[networks]
hidden = 32
layers = 2

[eval]
episodes = 6
"#;

#[test]
fn a_registered_task_runs_through_the_fmsr_command() {
    tasks::register::<Reach>().unwrap();
    let config = ExperimentConfig::from_toml(CONFIG, "reach.toml".as_ref()).unwrap();
    assert_eq!(config.label(), "Dense+FMSR+IS, alpha 0.05, team_reach");
    let settings = config.task_config::<Reach>().unwrap();
    assert_eq!(settings, TeamReachConfig { episode_len: 12, step_size: 0.25, ..TeamReachConfig::default() });
    assert_eq!(config.task_envs(2).unwrap().len(), 2);
    // The saved config reads back as the same experiment, every setting written out.
    let saved = config.to_toml().unwrap();
    assert_eq!(ExperimentConfig::from_saved_toml(&saved, "saved.toml".as_ref()).unwrap(), config);
    let table: toml::Table = saved.parse().unwrap();
    assert!(!table.contains_key("env") && !table.contains_key("engine"), "{saved}");
    assert_eq!(table["team_reach"].as_table().unwrap().len(), 6, "{saved}");

    let tmp = tempfile::tempdir().unwrap();
    let config_path = tmp.path().join("reach.toml");
    std::fs::write(&config_path, CONFIG).unwrap();
    let run = tmp.path().join("run");
    let (config_arg, run_arg) = (config_path.to_str().unwrap(), run.to_str().unwrap());
    fmsr::cli::run(["fmsr", "train", "--config", config_arg, "--out", run_arg, "--quiet"]).unwrap();
    fmsr::cli::run(["fmsr", "train", "--out", run_arg, "--resume", "--epochs", "2", "--quiet"]).unwrap();
    assert_eq!(std::fs::read_to_string(run.join("metrics.csv")).unwrap().lines().count() - 1, 2);
    fmsr::cli::run(["fmsr", "eval", run_arg]).unwrap();
    let report: TaskEvalReport = serde_json::from_slice(&std::fs::read(run.join("task-eval.json")).unwrap()).unwrap();
    assert_eq!((report.task.as_str(), report.epochs, report.episodes), ("team_reach", 2, 6));
    assert_eq!(report.records.len(), 6);
    assert_eq!(report.features, ["safe_region", "gentle"]);
    assert!(report.feature_rates.iter().all(|r| (0.0..=1.0).contains(r)), "{:?}", report.feature_rates);
    assert_eq!(report.successes, report.records.iter().filter(|r| r.success).count());
    // The task's own measures: every episode's values, their mean across episodes.
    assert_eq!(report.measures, ["steps_to_success", "mean_abs_action"]);
    for r in &report.records {
        assert_eq!(r.measures.len(), 2, "{r:?}");
        assert!((1.0..=12.0).contains(&r.measures[0]) && (0.0..=1.0).contains(&r.measures[1]), "{r:?}");
    }
    let mean = report.records.iter().map(|r| r.measures[0]).sum::<f64>() / 6.0;
    assert!((report.measure(0).unwrap().mean - mean).abs() < 1e-12);
    assert!(report.to_markdown().contains("measure `steps_to_success`"));

    // The exported policy plays the same episodes to the same ends.
    let policy = tmp.path().join("reach.fmsr");
    let (policy_arg, out) = (policy.to_str().unwrap(), tmp.path().join("policy-eval.json"));
    fmsr::cli::run(["fmsr", "export", run_arg, "--out", policy_arg]).unwrap();
    fmsr::cli::run(["fmsr", "eval", policy_arg, "--out", out.to_str().unwrap()]).unwrap();
    let again: TaskEvalReport = serde_json::from_slice(&std::fs::read(&out).unwrap()).unwrap();
    assert_eq!(again.records, report.records);

    // The report: the run's row with its test and validation success, the
    // policy file beside it as not evaluated, and the learning curves.
    fmsr::cli::run(["fmsr", "eval", run_arg, "--set", "validation"]).unwrap();
    let out = tmp.path().join("report");
    fmsr::cli::run(["fmsr", "report", run_arg, policy_arg, "--out", out.to_str().unwrap()]).unwrap();
    let summary = std::fs::read_to_string(out.join("summary.md")).unwrap();
    let test = fmsr_core::interval::Interval::wilson(report.successes, report.episodes).unwrap().percent();
    assert!(summary.contains("## team_reach") && summary.contains(&test), "{summary}");
    assert!(summary.contains("`safe_region` rate") && summary.contains("`gentle` rate"), "{summary}");
    let steps = format!("{:.3}", report.measure(0).unwrap());
    assert!(summary.contains("`steps_to_success` (mean ± std)") && summary.contains(&steps), "{summary}");
    assert!(summary.contains("Not in the tables") && summary.contains("reach.fmsr"), "{summary}");
    assert!(out.join("fig3_team_reach.png").exists());
    // A Shadow Hand run is reported apart.
    let hand = tmp.path().join("hand");
    std::fs::create_dir_all(&hand).unwrap();
    let egg = ExperimentConfig::load(std::path::Path::new("configs/egg_dense_quick.toml")).unwrap();
    std::fs::write(hand.join("config.toml"), egg.to_toml().unwrap()).unwrap();
    let mixed = ["fmsr", "report", run_arg, hand.to_str().unwrap(), "--out", out.to_str().unwrap()];
    let err = fmsr::cli::run(mixed).unwrap_err().to_string();
    assert!(err.contains("apart") && err.contains("runs"), "{err}");

    // The Shadow Hand's flags and commands are refused, naming them.
    for (args, named) in [
        (vec!["fmsr", "eval", run_arg, "--engine", "mujoco"], "--engine"),
        (vec!["fmsr", "train", "--out", run_arg, "--resume", "--engine", "mujoco"], "--engine"),
        (vec!["fmsr", "render", run_arg], "team_reach"),
    ] {
        let err = fmsr::cli::run(args.clone()).unwrap_err().to_string();
        assert!(err.contains(named), "{args:?}: {err}");
    }
}

#[test]
fn a_registered_tasks_config_errors_name_their_key() {
    tasks::register::<Reach>().unwrap();
    let err = |text: &str| ExperimentConfig::from_toml(text, "bad.toml".as_ref()).unwrap_err().to_string();
    let e = err(&CONFIG.replace("step_size = 0.25", "warp = 1"));
    assert!(e.contains("`team_reach.warp`"), "{e}");
    let e = err(&CONFIG.replace("step_size = 0.25", "step_size = \"far\""));
    assert!(e.contains("team_reach"), "{e}");
    let e = err(&format!("{CONFIG}\n[env]\nobject = \"egg\"\n"));
    assert!(e.contains("`env`") && e.contains("[team_reach]"), "{e}");
    let e = err(&CONFIG.replace("task = \"team_reach\"", "task = \"team_reach\"\nengine = \"mujoco\""));
    assert!(e.contains("`engine`"), "{e}");
    let e = err(&CONFIG.replace("task = \"team_reach\"", "task = \"no_such_task\""));
    assert!(e.contains("no_such_task") && e.contains("team_reach") && e.contains("shadow_hand"), "{e}");
    // The graph and the shadow assignment default to the Shadow Hand's: a
    // task names its own, or is refused at load, naming the key.
    let e = err(&CONFIG.replace("edges = [[\"x\", \"y\"], [\"y\", \"w\"], [\"w\", \"x\"]]", ""));
    assert!(e.contains("`graph.edges`") && e.contains("team_reach"), "{e}");
    let start = CONFIG.find("assignment = {").unwrap();
    let end = start + CONFIG[start..].find("\n] }").unwrap() + "\n] }".len();
    let e = err(&format!("{}{}", &CONFIG[..start], &CONFIG[end..]));
    assert!(e.contains("`trainer.shadow.assignment`") && e.contains("team_reach"), "{e}");
    // The Shadow Hand's experiment does not read a registered task's section.
    let e = err(&CONFIG.replace("task = \"team_reach\"", "task = \"shadow_hand\""));
    assert!(e.contains("[team_reach]"), "{e}");
}
