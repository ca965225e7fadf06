//! Guards the numbers a reader is given: an evaluation records every
//! episode, and no episode is both a success and a drop; validation episodes
//! never meet the test set; a policy file takes a new evaluation in place of
//! its old one; one `fmsr train` writes a run directory while `eval` and
//! `export` keep reading it; a replay buffer that could never fit is refused
//! before training, naming its key.

use crate::common;

use std::collections::HashSet;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::cli::{FMSR, fmsr, text, tiny_config, trained_run, trained_tiny_run};
use fmsr::artefacts::{EvalReport, SuccessRule, classify};
use fmsr::experiment::EpisodeSet;

fn read_eval(path: &Path) -> EvalReport {
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap()
}

#[test]
fn an_evaluation_records_each_episode_and_no_success_is_a_drop() {
    let tmp = tempfile::tempdir().unwrap();
    let run = trained_tiny_run(tmp.path());
    let out = fmsr(&["eval", run.to_str().unwrap(), "--episodes", "6"]);
    assert!(out.status.success(), "{}", text(&out));
    // The success rate is printed with its interval.
    assert!(text(&out).contains("% ["), "{}", text(&out));
    let eval = read_eval(&run.join("eval.json"));
    assert_eq!((eval.set, eval.success_rule, eval.records.len()), (EpisodeSet::Test, SuccessRule::ReachedAndHeld, 6));
    let config = fmsr::experiment::ExperimentConfig::load(&run.join("config.toml")).unwrap();
    let seeds: Vec<u64> = eval.records.iter().map(|r| r.seed).collect();
    assert_eq!(seeds, config.eval.seeds_of(EpisodeSet::Test, 6));
    let mut successes = 0;
    for r in &eval.records {
        assert_eq!(r.outcome, classify(r.final_error, eval.threshold, r.dropped), "{r:?}");
        assert_eq!(r.dropped, r.drop_step.is_some(), "{r:?}");
        let success = r.outcome == fmsr::core::metrics::EpisodeOutcome::Success;
        assert!(!(success && r.dropped), "an episode is both a success and a drop: {r:?}");
        successes += usize::from(success);
        assert!(r.initial_error.is_finite() && r.final_error.is_finite());
    }
    assert_eq!(eval.outcomes.successes, successes);
    assert_eq!(eval.outcomes.drop, eval.records.iter().filter(|r| r.dropped).count());
    assert_eq!(eval.records[0].total_contacts, eval.trace.contacts.iter().sum::<usize>());
}

// Guards the drop count of Table II: with the drop distance below where the
// object rests, every episode drops at its first step; the records, the counts
// and the printed table must all say so (the test above meets a drop only as
// its policy happens to play, and its checks hold with none).
#[test]
fn an_evaluation_counts_every_drop() {
    let tmp = tempfile::tempdir().unwrap();
    let base = common::tiny_config_text();
    let from = "success_threshold = 0.1\n";
    assert_eq!(base.matches(from).count(), 1, "the tiny config changed: update this test");
    let config = tmp.path().join("drops.toml");
    std::fs::write(&config, base.replace(from, "success_threshold = 0.1\ndrop_distance = 0.001\n")).unwrap();
    let run = trained_run(tmp.path(), &config);
    let out = fmsr(&["eval", run.to_str().unwrap(), "--episodes", "4"]);
    assert!(out.status.success(), "{}", text(&out));
    let eval = read_eval(&run.join("eval.json"));
    for r in &eval.records {
        assert_eq!((r.dropped, r.drop_step), (true, Some(0)), "{r:?}");
        assert_eq!(r.outcome, classify(r.final_error, eval.threshold, true), "{r:?}");
    }
    assert_eq!((eval.outcomes.episodes, eval.outcomes.successes, eval.outcomes.drop), (4, 0, 4));
    let f = &eval.failures;
    assert_eq!((f.failures, f.incomplete, f.drop, f.drop_percent), (4, 0, 4, Some(100.0)));
    assert!(text(&out).contains(&eval.table2_row()), "{}", text(&out));
}

#[test]
fn validation_episodes_never_meet_the_test_set() {
    let tmp = tempfile::tempdir().unwrap();
    let run = trained_tiny_run(tmp.path());
    let run_s = run.to_str().unwrap();
    for set in ["test", "validation"] {
        let out = fmsr(&["eval", run_s, "--episodes", "3", "--set", set]);
        assert!(out.status.success(), "{}", text(&out));
    }
    let test = read_eval(&run.join("eval.json"));
    let validation = read_eval(&run.join("eval-validation.json"));
    assert_eq!(validation.set, EpisodeSet::Validation);
    let test_seeds: HashSet<u64> = test.records.iter().map(|r| r.seed).collect();
    assert!(validation.records.iter().all(|r| !test_seeds.contains(&r.seed)));
    // Far beyond what any evaluation plays: the two streams never meet.
    let config = fmsr::experiment::ExperimentConfig::load(&run.join("config.toml")).unwrap();
    let many: HashSet<u64> = config.eval.seeds_of(EpisodeSet::Test, 100_000).into_iter().collect();
    assert!(config.eval.seeds_of(EpisodeSet::Validation, 100_000).iter().all(|s| !many.contains(s)));
    // The report shows the validation success beside the test success.
    let report = tmp.path().join("report");
    let out = fmsr(&["report", run_s, "--out", report.to_str().unwrap()]);
    assert!(out.status.success(), "{}", text(&out));
    let summary = std::fs::read_to_string(report.join("summary.md")).unwrap();
    assert!(summary.contains("| Validation success | Test success |"), "{summary}");
    assert!(summary.contains("(its only run)"), "{summary}");
}

#[test]
fn a_policy_file_takes_a_new_evaluation_in_place_of_its_old_one() {
    let tmp = tempfile::tempdir().unwrap();
    let run = trained_tiny_run(tmp.path());
    let file = tmp.path().join("tiny.fmsr");
    let file_s = file.to_str().unwrap();
    assert!(fmsr(&["eval", run.to_str().unwrap()]).status.success());
    assert!(fmsr(&["export", run.to_str().unwrap(), "--out", file_s]).status.success());
    let out = fmsr(&["eval", file_s, "--episodes", "3", "--record"]);
    assert!(out.status.success(), "{}", text(&out));
    let policy = fmsr::artefacts::PolicyFile::read(&file).unwrap();
    assert_eq!(policy.evals.len(), 1, "the test evaluation was replaced, not added");
    assert_eq!(policy.eval_on(fmsr::experiment::Engine::Rapier).unwrap().episodes, 3);
    let out = fmsr(&["eval", file_s, "--episodes", "3"]);
    assert!(text(&out).contains("the same results as the evaluation the file carries"), "{}", text(&out));
    let out = fmsr(&["eval", file_s, "--episodes", "2", "--set", "validation", "--record"]);
    assert!(out.status.success(), "{}", text(&out));
    assert_eq!(fmsr::artefacts::PolicyFile::read(&file).unwrap().evals.len(), 2);
    // A run's evaluation goes to its directory: --record there is a mistake.
    let out = fmsr(&["eval", run.to_str().unwrap(), "--record"]);
    assert!(!out.status.success() && text(&out).contains("--record writes into a policy file"), "{}", text(&out));
}

// Guards that an evaluation names the goal distance its success was counted
// by, and that it is the one used: every record's final error is its final
// orientation under the named distance, the other distance's evaluation goes
// to its own file and counts by the other one, and a saved run that names no
// distance is read as yaw, the distance of the runs written before the
// setting existed.
#[test]
fn an_evaluation_names_the_distance_it_counted_by() {
    use fmsr_envs::shadow_hand::GoalDistance;
    let tmp = tempfile::tempdir().unwrap();
    let run = trained_tiny_run(tmp.path());
    let run_s = run.to_str().unwrap();
    let config = std::fs::read_to_string(run.join("config.toml")).unwrap();
    assert!(config.contains("goal_distance = \"full\""), "{config}");
    for (args, file, distance) in [
        (vec!["eval", run_s, "--episodes", "4"], "eval.json", GoalDistance::Full),
        (vec!["eval", run_s, "--episodes", "4", "--goal-distance", "yaw"], "eval-yaw.json", GoalDistance::Yaw),
        (vec!["eval", run_s, "--episodes", "4", "--goal-distance", "gym"], "eval-gym.json", GoalDistance::Gym),
    ] {
        let out = fmsr(&args);
        assert!(out.status.success(), "{}", text(&out));
        assert!(text(&out).contains(&format!("by the {} distance", distance.key())), "{}", text(&out));
        for other in GoalDistance::ALL.into_iter().filter(|&d| d != distance) {
            assert!(text(&out).contains(&format!("Under the {} distance:", other.key())), "{}", text(&out));
        }
        let eval = read_eval(&run.join(file));
        assert_eq!(eval.goal_distance, distance, "{file}");
        let still = eval.still.expect("the hold-still baseline is simulated");
        assert_eq!(still.episodes, 4);
        for r in &eval.records {
            let o = r.orientation.expect("the final orientation is recorded");
            assert_eq!(Some(r.final_error), o.error(distance), "{file}: {r:?}");
            assert!(o.full_angle.is_finite() && o.tilt.is_finite() && o.yaw_error <= std::f32::consts::PI);
        }
    }
    // Every record holds the engine's final quaternion (sign kept) and the
    // goal's; gym's formula, written here as `manipulate.py` writes it
    // (`quat_mul(a, quat_conjugate(b))`, `2 arccos(clip(w))`), recomputed from
    // them gives each success flag of the evaluation under gym's distance.
    let gym = read_eval(&run.join("eval-gym.json"));
    for r in &gym.records {
        let o = r.orientation.unwrap();
        let (a, b) = (o.object_quaternion.expect("engine quaternion"), o.goal_quaternion.expect("goal quaternion"));
        let b = [f64::from(b[0]), -f64::from(b[1]), -f64::from(b[2]), -f64::from(b[3])];
        let w = a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3];
        let angle = 2.0 * w.clamp(-1.0, 1.0).acos();
        assert!((angle - f64::from(r.final_error)).abs() < 1e-4, "{r:?}: gym's formula gives {angle}");
        assert!((0.0..=std::f64::consts::TAU).contains(&angle));
        let success = angle < f64::from(gym.threshold) && !r.dropped;
        assert_eq!(success, r.outcome == fmsr_core::metrics::EpisodeOutcome::Success, "{r:?}");
    }
    // The same run, its config naming no distance: refused, naming the key.
    let unnamed = config.replace("goal_distance = \"full\"\n", "");
    assert_ne!(unnamed, config);
    std::fs::write(run.join("config.toml"), unnamed).unwrap();
    let out = fmsr(&["eval", run_s, "--episodes", "2"]);
    assert!(!out.status.success() && text(&out).contains("env.goal_distance"), "{}", text(&out));
}

/// Waits until `cond` holds, for at most a minute.
fn wait_for(what: &str, cond: impl Fn() -> bool) {
    let start = Instant::now();
    while !cond() {
        assert!(start.elapsed() < Duration::from_secs(60), "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(50));
    }
}

// Guards one writer per run directory (regression): two `fmsr train --resume`
// on one directory both trained, both wrote its checkpoint and logs, and both
// exited 0.
#[test]
fn a_second_writer_is_refused_while_readers_read_on() {
    let tmp = tempfile::tempdir().unwrap();
    let run = trained_tiny_run(tmp.path());
    let run_s = run.to_str().unwrap();
    let mut writer = Command::new(FMSR)
        .args(["train", "--out", run_s, "--resume", "--epochs", "1000", "--quiet"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let lock = run.join(".lock");
    let pid = format!("pid {}", writer.id());
    wait_for("the writer's lock", || std::fs::read_to_string(&lock).is_ok_and(|s| s.contains(&pid)));

    let second = fmsr(&["train", "--out", run_s, "--resume", "--epochs", "1000", "--quiet"]);
    assert!(!second.status.success(), "a second writer trained");
    assert!(
        text(&second).contains("being written by another process") && text(&second).contains(&pid),
        "{}",
        text(&second)
    );
    let fresh = fmsr(&["train", "--config", tiny_config(tmp.path(), "").to_str().unwrap(), "--out", run_s]);
    assert!(!fresh.status.success(), "{}", text(&fresh));

    // Readers go on while it trains: each sees one whole checkpoint.
    let metrics = run.join("metrics.csv");
    let epochs = || std::fs::read_to_string(&metrics).map_or(0, |s| s.lines().count().saturating_sub(1));
    let start = epochs();
    for i in 0..3 {
        let file = tmp.path().join(format!("during-{i}.fmsr"));
        let out = fmsr(&["export", run_s, "--out", file.to_str().unwrap()]);
        assert!(out.status.success(), "{}", text(&out));
        let exported = fmsr::artefacts::PolicyFile::read(&file).unwrap();
        assert_eq!(exported.metrics.len(), exported.epochs, "an export mixed two epochs");
        let out = fmsr(&["eval", run_s, "--episodes", "1", "--out", tmp.path().join("e.json").to_str().unwrap()]);
        assert!(out.status.success(), "{}", text(&out));
    }
    wait_for("the writer to train on", || epochs() > start);

    // A killed writer leaves no lock behind.
    writer.kill().unwrap();
    writer.wait().unwrap();
    let out = fmsr(&["train", "--out", run_s, "--resume", "--epochs", &(epochs() + 1).to_string(), "--quiet"]);
    assert!(out.status.success(), "{}", text(&out));
}

#[test]
fn a_replay_buffer_that_cannot_fit_is_refused_naming_the_key() {
    let tmp = tempfile::tempdir().unwrap();
    let text_config = tiny_config(tmp.path(), "");
    let config =
        std::fs::read_to_string(&text_config).unwrap().replace("buffer_size = 1000000", "buffer_size = 100000000000");
    std::fs::write(&text_config, config).unwrap();
    let run = tmp.path().join("run");
    let out = fmsr(&["train", "--config", text_config.to_str().unwrap(), "--out", run.to_str().unwrap()]);
    assert!(!out.status.success());
    let message = text(&out);
    assert!(message.contains("replay.buffer_size") && message.contains("GB of memory"), "{message}");
    assert!(!run.join("checkpoint.bin").exists());
}
