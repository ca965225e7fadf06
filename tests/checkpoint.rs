//! Guards reproducibility and checkpoints (issue 3, item 6): two runs with the
//! same seed give identical statistics on the CPU backend, whatever the number
//! of threads stepping the vectorised environments; a run resumed from a
//! checkpoint (with its replay buffer) continues exactly as the uninterrupted
//! run; corrupted, truncated or mismatched checkpoints are clear errors.

mod common;

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
        let mut t = team_reach_trainer_config(AlgorithmKind::Maddpg, Method::DenseFmsrIs, config);
        t.train(|_, _| Ok(())).unwrap();
        t.history().iter().map(learning_stats).collect::<Vec<_>>()
    };
    let one = run(1);
    assert_eq!(one, run(2));
    assert_eq!(one, run(3));
    // Per epoch: 10 cycles x 4 rollouts and 20 evaluation episodes of 20 steps.
    assert_eq!(one[1].env_steps, 2 * (10 * 4 + 20) * 20);
}

#[test]
fn resumed_run_matches_uninterrupted_run() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("run").join("checkpoint.bin");

    let mut full = team_reach_trainer(Method::DenseFmsrIs, 7, 3);
    full.train(|_, _| Ok(())).unwrap();

    let mut first = team_reach_trainer(Method::DenseFmsrIs, 7, 2);
    first.train(|t, _| t.save_checkpoint(&path, true)).unwrap();
    drop(first);

    // A fresh process would build the same trainer from the same config, with
    // more epochs, and load the checkpoint.
    let mut resumed = team_reach_trainer(Method::DenseFmsrIs, 7, 3);
    resumed.load_checkpoint(&path).unwrap();
    assert_eq!(resumed.epoch(), 2);
    resumed.train(|_, _| Ok(())).unwrap();

    let a: Vec<_> = full.history().iter().map(learning_stats).collect();
    let b: Vec<_> = resumed.history().iter().map(learning_stats).collect();
    assert_eq!(a, b);
}

#[test]
fn bad_checkpoints_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("checkpoint.bin");
    let mut t = team_reach_trainer(Method::Dense, 3, 1);
    t.train(|t, _| t.save_checkpoint(&path, false)).unwrap();
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
    let learner = AnyLearner::Maddpg(Maddpg::new(parts, MaddpgConfig::new()).unwrap());
    let mut wrong = Trainer::new(common::trainer_config(Method::Dense, 3, 1), env, learner, layout).unwrap();
    let err = wrong.load_checkpoint(&path).unwrap_err();
    assert!(matches!(err, CoreError::Algorithm(_)), "{err}");
}
