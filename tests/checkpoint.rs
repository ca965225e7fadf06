//! Guards reproducibility and checkpoints: two runs with the same seed give
//! identical statistics on the CPU backend, whatever the number of threads
//! stepping the vectorised environments; a run resumed from a checkpoint (with
//! its replay buffer read back from the replay log, wrapped or not) continues
//! exactly as the uninterrupted run; corrupted, truncated or mismatched
//! checkpoints are clear errors.

use crate::common;

use common::{learning_stats, team_reach_trainer, team_reach_trainer_config};
use fmsr::prelude::*;

#[test]
fn same_seed_same_run() {
    let run = || {
        let mut t = team_reach_trainer(Method::DenseFmsrIs, 5, 2);
        t.train(|_, _| Ok(())).unwrap();
        t.history().iter().map(learning_stats).collect::<Vec<_>>()
    };
    let (a, b) = (run(), run());
    assert_eq!(a, b);
    let mut other = team_reach_trainer(Method::DenseFmsrIs, 6, 1);
    other.train(|_, _| Ok(())).unwrap();
    assert_ne!(learning_stats(&other.history()[0]), a[0], "a different seed should change the run");
}

#[test]
fn stepping_threads_do_not_change_the_history() {
    let run = |threads: usize| {
        let config = TrainerConfig {
            envs: Some(4),
            threads: Some(threads),
            episodes_per_cycle: 4,
            ..common::trainer_config(Method::DenseFmsrIs, 9, 2)
        };
        let mut t = team_reach_trainer_config("maddpg", Method::DenseFmsrIs, config);
        t.train(|_, _| Ok(())).unwrap();
        t.history().iter().map(learning_stats).collect::<Vec<_>>()
    };
    let one = run(1);
    assert_eq!(one, run(2));
    assert_eq!(one, run(3));
    // Per epoch: 10 cycles x 4 rollouts and 20 evaluation episodes of 20 steps.
    assert_eq!(one[1].env_steps, 2 * (10 * 4 + 20) * 20);
}

/// Guards `trainer.threads`, which the trainer once never passed to its
/// collector: every run stepped its environments one after another.
#[test]
fn the_trainer_steps_its_environments_on_trainer_threads() {
    let threads = |envs: usize, threads: Option<usize>| {
        let config = TrainerConfig {
            envs: Some(envs),
            threads,
            episodes_per_cycle: envs,
            ..common::trainer_config(Method::DenseFmsrIs, 9, 1)
        };
        team_reach_trainer_config("maddpg", Method::DenseFmsrIs, config).collector().threads()
    };
    assert_eq!(threads(4, Some(1)), 1);
    assert_eq!(threads(4, Some(3)), 3);
    assert_eq!(threads(2, Some(8)), 2, "at most one thread per environment");
    let cores = std::thread::available_parallelism().map_or(1, std::num::NonZero::get);
    assert_eq!(threads(4, None), cores.min(4));
}

fn segments(dir: &std::path::Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir.join("checkpoint.replay"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

#[test]
fn resumed_run_matches_uninterrupted_run() {
    // 20 episodes an epoch: a replay of 5000 episodes never wraps, one of 30
    // wraps in the second epoch and lets the log prune its first segment.
    for capacity in [5000, 30] {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("checkpoint.bin");

        let mut full = common::trainer_with_capacity(7, 4, capacity);
        full.train(|_, _| Ok(())).unwrap();

        let mut first = common::trainer_with_capacity(7, 3, capacity);
        first.train(|t, _| t.save_checkpoint(&path)).unwrap();
        drop(first);
        let kept = segments(dir.path());
        let expected: Vec<String> = if capacity == 30 { vec![20, 40] } else { vec![0, 20, 40] }
            .into_iter()
            .map(|first| format!("{first:020}.seg"))
            .collect();
        assert_eq!(kept, expected, "capacity {capacity}");

        // A fresh process would build the same trainer from the same config, with
        // more epochs, and load the checkpoint and the replay log.
        let mut resumed = common::trainer_with_capacity(7, 4, capacity);
        resumed.load_checkpoint(&path).unwrap();
        assert_eq!(resumed.epoch(), 3);
        resumed.train(|_, _| Ok(())).unwrap();

        let a: Vec<_> = full.history().iter().map(learning_stats).collect();
        let b: Vec<_> = resumed.history().iter().map(learning_stats).collect();
        assert_eq!(a, b, "capacity {capacity}");
    }
}

#[test]
fn a_missing_replay_segment_is_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("checkpoint.bin");
    let mut t = common::trainer_with_capacity(2, 2, 5000);
    t.train(|t, _| t.save_checkpoint(&path)).unwrap();
    std::fs::remove_file(dir.path().join("checkpoint.replay").join(format!("{:020}.seg", 20))).unwrap();
    let mut fresh = common::trainer_with_capacity(2, 2, 5000);
    let err = fresh.load_checkpoint(&path).unwrap_err();
    assert!(err.to_string().contains("lacks episode 20"), "{err}");
    // Evaluating needs no replay.
    fresh.load_checkpoint_without_storage(&path).unwrap();
}

#[test]
fn bad_checkpoints_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("checkpoint.bin");
    let mut t = team_reach_trainer(Method::Dense, 3, 1);
    t.train(|t, _| t.save_checkpoint(&path)).unwrap();
    let good = std::fs::read(&path).unwrap();

    let mut fresh = team_reach_trainer(Method::Dense, 3, 1);
    fresh.load_checkpoint(&path).unwrap();

    // A flipped byte in the body.
    let mut bad = good.clone();
    let n = bad.len();
    bad[n / 2] ^= 0x40;
    std::fs::write(&path, &bad).unwrap();
    let err = fresh.load_checkpoint(&path).unwrap_err();
    assert!(matches!(err, CoreError::Corrupt { .. }), "{err}");
    assert!(err.to_string().contains("checksum"), "{err}");

    // Truncated.
    std::fs::write(&path, &good[..good.len() / 3]).unwrap();
    assert!(matches!(fresh.load_checkpoint(&path), Err(CoreError::Corrupt { .. })));

    // Not a checkpoint at all.
    std::fs::write(&path, b"hello").unwrap();
    assert!(matches!(fresh.load_checkpoint(&path), Err(CoreError::Corrupt { .. })));

    // Missing file.
    assert!(matches!(fresh.load_checkpoint(&dir.path().join("nope.bin")), Err(CoreError::Io { .. })));

    // Another configuration (different seed).
    std::fs::write(&path, &good).unwrap();
    let mut other = team_reach_trainer(Method::Dense, 4, 1);
    let err = other.load_checkpoint(&path).unwrap_err();
    assert!(matches!(err, CoreError::InvalidConfig { .. }), "{err}");

    // A learner of another shape: wider networks on the same config.
    let env = common::team_reach(Method::Dense);
    let mut parts = common::parts(&env, Method::Dense, 3, 0.9);
    parts.networks = parts.networks.with_hidden(32);
    let layout = parts.layout.clone();
    let learner = AnyLearner::new(Maddpg::new(parts, MaddpgConfig::new()).unwrap());
    let mut wrong = Trainer::new(common::trainer_config(Method::Dense, 3, 1), env, learner, layout).unwrap();
    let err = wrong.load_checkpoint(&path).unwrap_err();
    assert!(matches!(err, CoreError::Algorithm(_)), "{err}");
}

/// Guards the shadow-reward scale check: shadow rewards that outweigh the task
/// reward in the first cycle stop training with an error naming the key and
/// both magnitudes; the magnitudes are logged.
#[test]
fn shadow_rewards_that_outweigh_the_task_are_refused() {
    let mut config = common::trainer_config(Method::DenseFmsr, 1, 1);
    config.shadow.alpha = 50.0;
    let mut t = team_reach_trainer_config("maddpg", Method::DenseFmsr, config.clone());
    let err = t.train(|_, _| Ok(())).unwrap_err();
    assert!(err.to_string().contains("trainer.shadow.max_scale") && err.to_string().contains("agent `w`"), "{err}");

    config.shadow.max_scale = f64::INFINITY;
    let mut t = team_reach_trainer_config("maddpg", Method::DenseFmsr, config);
    t.train(|_, _| Ok(())).unwrap();
    let stats = &t.history()[0];
    assert!(stats.shadow_reward_abs[2] > stats.task_reward_abs[2], "{stats:?}");
    assert_eq!(stats.shadow_reward_abs[0], 0.0, "agent x has no shadow reward");
    // The same parts in the sampled batches, and the critics' mean Q.
    assert!(stats.batch_shadow_reward_abs[2] > stats.batch_task_reward_abs[2], "{stats:?}");
    assert_eq!(stats.batch_shadow_reward_abs[0], 0.0, "agent x has no shadow reward");
    assert!(stats.batch_task_reward_abs.iter().all(|&v| v > 0.0), "{stats:?}");
    assert_eq!(stats.q_mean.len(), 3);
    assert!(stats.q_mean.iter().all(|q| q.is_finite() && *q != 0.0), "{stats:?}");
}
