//! The measurement behind the rapier solver defaults: for each candidate
//! setting, the rest height of the block at mid controls, the servo tracking
//! error, the behaviour under random actions and the env steps/s,
//! to compare with MuJoCo 3.17 on the same model (block: rest 0.1661 m, tracking
//! mean |q - ctrl| 0.057 rad, random actions 0/20 drops with 5.15 active touch
//! sensors per step on average, 1.56k steps/s). Prints a markdown table; it is
//! `#[ignore]`d because it takes about a minute:
//! `cargo test -p fmsr-envs --test envs_integration -- shadow_hand_settings:: --ignored --nocapture`.
//! The non-ignored test guards that the default settings stay stable under
//! random actions.

use std::time::Instant;

use fmsr_core::Env;
use fmsr_core::spec::JointAction;
use fmsr_envs::shadow_hand::model::{ACTUATORS, HAND_JOINTS};
use fmsr_envs::shadow_hand::{
    HandObject, HandPhysics, RapierHand, RapierSettings, ShadowHandConfig, fetch_hand_assets, load_rapier_model,
};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

struct Row {
    rest: f64,
    tracking: f64,
    drops: usize,
    touch: f64,
    steps_per_s: f64,
}

fn substeps(s: &RapierSettings) -> usize {
    (0.04 / s.timestep).round() as usize
}

/// 20 model timesteps of 0.002 s: one env step.
const SUBSTEPS: usize = 20;

fn hold(h: &mut RapierHand, a: f64, secs: f64, subs: usize) -> Vec<f64> {
    h.reset();
    let ctrl: Vec<f64> = h.ctrl_range().iter().map(|r| (r[0] + r[1]) / 2.0 + a * (r[1] - r[0]) / 2.0).collect();
    h.set_ctrl(&ctrl);
    for _ in 0..(secs / 0.04).round() as usize {
        h.step(subs);
    }
    ctrl
}

fn measure(s: RapierSettings, episodes: u64) -> Row {
    let assets = fetch_hand_assets(None).unwrap();
    let model = load_rapier_model(&assets, HandObject::Block).unwrap();
    let mut h = RapierHand::new(model, s).unwrap();
    let subs = SUBSTEPS;
    hold(&mut h, 0.0, 2.0, subs);
    let rest = h.object_pose().0[2];
    let mut err = Vec::new();
    for a in [0.5, -0.5] {
        let ctrl = hold(&mut h, a, 1.0, subs);
        let mut q = [0.0; 24];
        h.hand_qpos(&mut q);
        for (i, name) in ACTUATORS.iter().enumerate() {
            let j = HAND_JOINTS.iter().position(|n| n == name).unwrap();
            err.push((q[j] - ctrl[i]).abs());
        }
    }
    let tracking = err.iter().sum::<f64>() / err.len() as f64;
    let mut env = ShadowHandConfig { rapier: s, ..Default::default() }.init().unwrap();
    let (mut drops, mut touch, mut steps) = (0, 0usize, 0usize);
    let mut time = 0.0;
    for ep in 0..episodes {
        let mut rng = ChaCha8Rng::seed_from_u64(ep);
        env.reset(ep).unwrap();
        let t = Instant::now();
        for _ in 0..100 {
            let a = JointAction((0..20).map(|_| rng.random_range(-1.0..1.0)).collect());
            env.step(&a).unwrap();
            touch += env.active_touch_count();
            steps += 1;
        }
        time += t.elapsed().as_secs_f64();
        drops += usize::from(env.physics().object_pose().0[2] < 0.1);
    }
    Row { rest, tracking, drops, touch: touch as f64 / steps as f64, steps_per_s: steps as f64 / time }
}

#[test]
fn default_settings_hold_the_block_under_random_actions() {
    let row = measure(RapierSettings::default(), 2);
    assert_eq!(row.drops, 0);
    assert!((0.165..0.172).contains(&row.rest), "rest height {}", row.rest);
}

#[test]
#[ignore = "prints the settings table; about a minute"]
fn settings_table() {
    let d = RapierSettings { prediction_distance: 0.002, contact_recycling: true, ..RapierSettings::default() };
    let mut candidates = vec![];
    for (timestep, solver_iterations, pgs_iterations) in [
        (0.002, 4, 1),
        (0.002, 2, 1),
        (0.002, 1, 1),
        (0.002, 1, 4),
        (0.004, 1, 1),
        (0.004, 1, 4),
        (0.008, 2, 1),
        (0.008, 1, 2),
        (0.008, 1, 4),
        (0.02 / 1.5, 1, 4),
        (0.02, 1, 4),
    ] {
        candidates.push(RapierSettings { timestep, solver_iterations, pgs_iterations, ..d });
    }
    candidates.push(RapierSettings { prediction_distance: 0.02, ..RapierSettings::fine() });
    candidates.push(RapierSettings { contact_recycling: false, ..RapierSettings::fine() });
    candidates.push(RapierSettings { prediction_distance: 0.02, ..d });
    println!(
        "| rapier dt (s) | rapier steps/env step | solver it. | PGS it. | pred. dist (m) | recycling | rest z (m) | tracking (rad) | drops/20 | active touch | env steps/s |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    println!("| MuJoCo 3.17 | 20 | - | - | - | - | 0.1661 | 0.057 | 0 | 5.15 | 1563 |");
    for s in candidates {
        let r = measure(s, 20);
        println!(
            "| {:.4} | {} | {} | {} | {} | {} | {:.4} | {:.3} | {} | {:.2} | {:.0} |",
            s.timestep,
            substeps(&s),
            s.solver_iterations,
            s.pgs_iterations,
            s.prediction_distance,
            s.contact_recycling,
            r.rest,
            r.tracking,
            r.drops,
            r.touch,
            r.steps_per_s
        );
    }
}

#[test]
#[ignore = "prints env steps/s of batched stepping; about 20 s"]
fn batch_scaling() {
    use fmsr_envs::shadow_hand::{RapierHand, ShadowHand, step_batch};
    println!("| envs | rayon threads | env steps/s |");
    println!("|---|---|---|");
    for n in [1usize, 2, 4, 8] {
        let mut envs: Vec<ShadowHand<RapierHand>> =
            (0..n).map(|_| ShadowHandConfig::default().init().unwrap()).collect::<Vec<_>>();
        for (i, e) in envs.iter_mut().enumerate() {
            e.reset(i as u64).unwrap();
        }
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let t = Instant::now();
        let steps = 100;
        for _ in 0..steps {
            let actions: Vec<JointAction> =
                (0..n).map(|_| JointAction((0..20).map(|_| rng.random_range(-1.0..1.0)).collect())).collect();
            for r in step_batch(&mut envs, &actions) {
                r.unwrap();
            }
        }
        let rate = (n * steps) as f64 / t.elapsed().as_secs_f64();
        println!("| {n} | {} | {rate:.0} |", rayon::current_num_threads());
    }
}
