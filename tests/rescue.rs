//! Guards rescue points: a run whose checkpoint and replay log are lost
//! restarts from a rescue point with everything but its replay buffer (the
//! `full` level, bit for bit), or with its online networks (`online`, and at
//! f16 precision `half`); the restart is in its history; a checkpoint written
//! after the restart resumes exactly as the restarted run goes on (the lost
//! episodes are never looked for); a thinned state is refused by a
//! whole-state reader, and a corrupted or truncated rescue point by its own
//! reader, with typed errors.

use crate::common;

use std::path::Path;

use common::{learning_stats, team_reach_trainer};
use fmsr::core::trainer::RescuePoint;
use fmsr::nn::{RescueLevel, rescue_state};
use fmsr::prelude::*;

const SEED: u64 = 11;
const EPOCHS: usize = 4;

/// A Dense+FMSR+IS run on TeamReach after two epochs, with its checkpoint in `dir`.
fn trained(dir: &Path) -> Trainer<TeamReach, AnyLearner> {
    let mut t = team_reach_trainer(Method::DenseFmsrIs, SEED, EPOCHS);
    t.run_epoch().unwrap();
    t.run_epoch().unwrap();
    t.save_checkpoint(&dir.join("checkpoint.bin")).unwrap();
    t
}

/// The rescue point of the checkpoint in `dir` at `level`, through its file.
fn rescue(dir: &Path, level: RescueLevel) -> RescuePoint {
    let mut point = RescuePoint::from_checkpoint(&dir.join("checkpoint.bin"), level.key()).unwrap();
    point.algorithm = rescue_state(&point.algorithm, level).unwrap();
    let file = dir.join(format!("rescue-{}.fmsr", level.key()));
    point.write(&file).unwrap();
    RescuePoint::read(&file).unwrap()
}

#[test]
fn a_full_rescue_point_restores_everything_but_the_replay_buffer() {
    let tmp = tempfile::tempdir().unwrap();
    let mut run = trained(tmp.path());
    let point = rescue(tmp.path(), RescueLevel::Full);
    assert_eq!((point.epoch, point.keeps.as_str()), (2, "full"));
    // Without a refill it is the checkpoint without its replay: a trainer
    // that read the checkpoint's state alone trains its next epoch the same,
    // bit for bit (networks, optimisers, normalisers, RNG, counters).
    let mut bare = team_reach_trainer(Method::DenseFmsrIs, SEED, EPOCHS);
    bare.restore_rescue(&point, 0).unwrap();
    let mut no_replay = team_reach_trainer(Method::DenseFmsrIs, SEED, EPOCHS);
    no_replay.load_checkpoint_without_storage(&tmp.path().join("checkpoint.bin")).unwrap();
    assert_eq!(bare.algorithm().save_policy().unwrap(), run.algorithm().save_policy().unwrap());
    assert_eq!(bare.occupancy(), run.occupancy());
    assert_eq!(learning_stats(&bare.run_epoch().unwrap()), learning_stats(&no_replay.run_epoch().unwrap()));
    // With one (storing updates the input normalisers, as HER's does).
    let mut restarted = team_reach_trainer(Method::DenseFmsrIs, SEED, EPOCHS);
    let restart = restarted.restore_rescue(&point, 3).unwrap();
    assert_eq!((restart.epoch, restart.lost_episodes, restart.refill_episodes), (2, point.stored_episodes, 3));
    assert!(point.stored_episodes > 0);
    assert_eq!(restart.buffer_episodes, Some(point.stored_episodes), "a buffer below its capacity held every episode");
    assert_eq!(restarted.history(), run.history());
    assert_eq!(restarted.restarts(), [restart]);
    assert_eq!(restarted.algorithm().save_policy().unwrap().len(), run.algorithm().save_policy().unwrap().len());
    // It trains on; its next checkpoint resumes as it goes on, without the lost episodes.
    restarted.run_epoch().unwrap();
    let after = tmp.path().join("after");
    std::fs::create_dir_all(&after).unwrap();
    restarted.save_checkpoint(&after.join("checkpoint.bin")).unwrap();
    let mut resumed = team_reach_trainer(Method::DenseFmsrIs, SEED, EPOCHS);
    resumed.load_checkpoint(&after.join("checkpoint.bin")).unwrap();
    assert_eq!(resumed.restarts(), restarted.restarts());
    let (a, b) = (restarted.run_epoch().unwrap(), resumed.run_epoch().unwrap());
    assert_eq!(learning_stats(&a), learning_stats(&b));
    // The uninterrupted run went on with its whole buffer: another run from here.
    let c = run.run_epoch().unwrap();
    assert_eq!(c.epoch, 2);
}

#[test]
fn an_online_rescue_point_restores_the_policy_and_is_a_quarter_of_the_state() {
    let tmp = tempfile::tempdir().unwrap();
    let run = trained(tmp.path());
    let full = rescue(tmp.path(), RescueLevel::Full);
    let online = rescue(tmp.path(), RescueLevel::Online);
    let targets = rescue(tmp.path(), RescueLevel::Targets);
    let len = |p: &RescuePoint| p.algorithm.len() as f64;
    assert!(len(&online) < 0.3 * len(&full), "online {} of full {}", len(&online), len(&full));
    assert!(len(&online) < len(&targets) && len(&targets) < len(&full));
    let mut restarted = team_reach_trainer(Method::DenseFmsrIs, SEED, EPOCHS);
    restarted.restore_rescue(&online, 2).unwrap();
    assert_eq!(restarted.algorithm().save_policy().unwrap(), run.algorithm().save_policy().unwrap());
    restarted.run_epoch().unwrap();
    // A whole-state reader refuses the thinned state, naming what does not fit.
    let mut whole = team_reach_trainer(Method::DenseFmsrIs, SEED, EPOCHS);
    let err = whole.algorithm_mut().load_state(&online.algorithm).unwrap_err();
    assert!(matches!(err, fmsr::nn::NnError::StateMismatch { .. }), "{err}");
}

// Guards the `half` level: the online networks at f16 precision, about
// half of an `online` rescue point, each parameter restored within f16's
// rounding of the run's, training on from there; a whole-state reader
// refuses it and a damaged one is a typed error.
#[test]
fn a_half_rescue_point_is_half_of_online_and_restores_the_networks_to_f16_precision() {
    let tmp = tempfile::tempdir().unwrap();
    let run = trained(tmp.path());
    let online = rescue(tmp.path(), RescueLevel::Online);
    let half = rescue(tmp.path(), RescueLevel::Half);
    assert_eq!(half.keeps, "half");
    let (h, o) = (half.algorithm.len() as f64, online.algorithm.len() as f64);
    assert!(h < 0.56 * o && h > 0.4 * o, "half {h} bytes against online {o}");
    let mut restarted = team_reach_trainer(Method::DenseFmsrIs, SEED, EPOCHS);
    restarted.restore_rescue(&half, 2).unwrap();
    let mut moved = 0;
    for i in 0..3 {
        let ((a, c), (ha, hc)) = (run.algorithm().params(i).unwrap(), restarted.algorithm().params(i).unwrap());
        assert_eq!((a.len(), c.len()), (ha.len(), hc.len()));
        for (x, y) in a.iter().chain(&c).zip(ha.iter().chain(&hc)) {
            assert!((x - y).abs() <= x.abs() * 2f32.powi(-11) + 6e-8, "agent {i}: {x} restored as {y}");
            moved += usize::from(x != y);
        }
    }
    assert!(moved > 0, "f16 rounds the parameters");
    restarted.run_epoch().unwrap();
    let mut whole = team_reach_trainer(Method::DenseFmsrIs, SEED, EPOCHS);
    let err = whole.algorithm_mut().load_state(&half.algorithm).unwrap_err();
    assert!(matches!(err, fmsr::nn::NnError::StateMismatch { .. }), "{err}");
    let mut damaged = half.algorithm.clone();
    let last = damaged.len() - 1;
    damaged[last] ^= 1;
    let err = whole.algorithm_mut().load_rescue_state(&damaged).unwrap_err();
    assert!(matches!(err, fmsr::nn::NnError::CorruptState { .. }), "{err}");
}

#[test]
fn a_damaged_rescue_point_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    trained(tmp.path());
    let point = rescue(tmp.path(), RescueLevel::Online);
    let bytes = point.to_bytes().unwrap();
    let mut flipped = bytes.clone();
    let last = flipped.len() - 1;
    flipped[last] ^= 1;
    for (what, bad) in [("flipped", flipped), ("truncated", bytes[..bytes.len() / 2].to_vec())] {
        let err = RescuePoint::from_bytes(&bad, Path::new("r.fmsr")).unwrap_err();
        assert!(matches!(err, CoreError::Corrupt { .. }), "{what}: {err}");
    }
    let checkpoint = std::fs::read(tmp.path().join("checkpoint.bin")).unwrap();
    let err = RescuePoint::from_bytes(&checkpoint, Path::new("checkpoint.bin")).unwrap_err();
    assert!(err.to_string().contains("magic") || err.to_string().contains("rescue point"), "{err}");
}

// The command line end to end: `fmsr rescue` writes a run's rescue point;
// `fmsr train --rescue` restarts the run in a directory that holds only its
// config.toml (as a machine that lost the run's home would), records the
// restart, and trains on to the epochs asked.
#[test]
fn the_command_line_rescues_and_restarts_a_run() {
    use common::cli::{fmsr, text, trained_tiny_run};
    let tmp = tempfile::tempdir().unwrap();
    let run = trained_tiny_run(tmp.path());
    let point = tmp.path().join("rescue.fmsr");
    let out = fmsr(&["rescue", run.to_str().unwrap(), "--out", point.to_str().unwrap()]);
    assert!(out.status.success(), "{}", text(&out));
    assert!(text(&out).contains("keeps online"), "{}", text(&out));
    let lost = tmp.path().join("restarted");
    std::fs::create_dir_all(&lost).unwrap();
    std::fs::copy(run.join("config.toml"), lost.join("config.toml")).unwrap();
    let lost_s = lost.to_str().unwrap();
    let out = fmsr(&["train", "--rescue", point.to_str().unwrap(), "--out", lost_s, "--epochs", "2", "--refill", "1"]);
    assert!(out.status.success(), "{}", text(&out));
    let restarts = std::fs::read_to_string(lost.join("restarts.jsonl")).unwrap();
    assert_eq!(restarts.lines().count(), 1, "{restarts}");
    let line: serde_json::Value = serde_json::from_str(restarts.lines().next().unwrap()).unwrap();
    assert_eq!(line["restart"]["epoch"], 1);
    assert_eq!(line["restart"]["refill_episodes"], 1);
    assert!(line["binary"]["version"].is_string(), "{line}");
    let metrics = std::fs::read_to_string(lost.join("metrics.jsonl")).unwrap();
    assert_eq!(metrics.lines().count(), 2, "the rescued epoch and one more");
    // A run directory that still has its checkpoint is resumed, not rescued.
    let out = fmsr(&["train", "--rescue", point.to_str().unwrap(), "--out", lost_s, "--epochs", "3"]);
    assert!(!out.status.success() && text(&out).contains("--resume"), "{}", text(&out));
}

// Guards what a restart records as lost (the paper-budget pair's records
// once said 24200 episodes of replay lost from a buffer of 10000): the
// episodes the buffer held, those stored since the run's start
// or its previous restart, at most its capacity; `lost_episodes` stays the
// replay floor, every episode stored before the restart.
#[test]
fn a_restart_counts_the_buffer_it_lost_since_the_last_restart_and_within_its_capacity() {
    let tmp = tempfile::tempdir().unwrap();
    let mut run = common::trainer_with_capacity(SEED, EPOCHS, 15);
    run.run_epoch().unwrap();
    run.run_epoch().unwrap();
    assert_eq!(run.algorithm().storage_capacity(), 15);
    let first = tmp.path().join("first");
    std::fs::create_dir_all(&first).unwrap();
    run.save_checkpoint(&first.join("checkpoint.bin")).unwrap();
    let point = rescue(&first, RescueLevel::Online);
    assert_eq!(point.stored_episodes, 40, "two epochs of 10 cycles x 2 episodes");
    let mut restarted = common::trainer_with_capacity(SEED, EPOCHS, 15);
    let restart = restarted.restore_rescue(&point, 3).unwrap();
    assert_eq!((restart.lost_episodes, restart.buffer_episodes), (40, Some(15)), "a full buffer of 15");
    // One epoch (20 episodes) after the refill (3): 23 stored since the
    // restart, of which the buffer holds its 15; a second restart loses those.
    restarted.run_epoch().unwrap();
    let second = tmp.path().join("second");
    std::fs::create_dir_all(&second).unwrap();
    restarted.save_checkpoint(&second.join("checkpoint.bin")).unwrap();
    let point = rescue(&second, RescueLevel::Online);
    let mut again = common::trainer_with_capacity(SEED, EPOCHS, 15);
    let restart = again.restore_rescue(&point, 2).unwrap();
    assert_eq!((restart.lost_episodes, restart.buffer_episodes), (63, Some(15)));
    assert_eq!(again.restarts().len(), 2);
    // With a larger buffer the second restart counts only the 23 stored since the first.
    let mut wide = common::trainer_with_capacity(SEED, EPOCHS, 1000);
    let restart = wide.restore_rescue(&point, 0).unwrap();
    assert_eq!((restart.lost_episodes, restart.buffer_episodes), (63, Some(23)));
}
