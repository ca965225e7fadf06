//! Where FMSR looks, do the engines agree? The same action sequences on MuJoCo
//! 3.17 and on rapier3d (without the fidelity settings of `RapierSettings`,
//! with each alone, and with all), and what each engine makes of them: active touch sensors,
//! the occupancy of the `contacts` feature (>= 10 active), the grasp measures
//! Q_MSV, Q_VEW and Q_DCC, how far the object turned, and drops.
//!
//! ```text
//! scripts/setup_mujoco.sh
//! cargo run --release --features mujoco --example engine_parity -- [--episodes 20] [--run runs/lite/block_sparse_s0]
//! ```
//!
//! Action sources: uniform random actions, scripted finger gaits (20 steps at
//! zero, then slow sinusoids of amplitude 0.5, one phase per actuator), and with
//! `--run`, the actions a trained policy chose on rapier, replayed open-loop.
//! Each source runs the same `--episodes` seeds (same object pose and goal) on every engine.

use anyhow::{Context, Result, bail};
use fmsr::artefacts::RunDir;
use fmsr::experiment::{ExperimentConfig, MODEL_TIMESTEP};
use fmsr_core::metrics::GraspTrace;
use fmsr_core::prelude::*;
use fmsr_envs::shadow_hand::{HandPhysics, MujocoSettings, RapierSettings, ShadowHand, ShadowHandConfig};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// What one engine made of one action source, averaged over its episodes.
#[derive(Debug, Default)]
struct Row {
    touch: f64,
    contacts_occupancy: f64,
    q_msv: f64,
    q_vew: f64,
    q_dcc: f64,
    turned: f64,
    drops: usize,
}

fn yaw(q: [f64; 4]) -> f64 {
    (2.0 * (q[0] * q[3] + q[1] * q[2])).atan2(1.0 - 2.0 * (q[2] * q[2] + q[3] * q[3]))
}

fn wrapped(d: f64) -> f64 {
    let d = d.rem_euclid(2.0 * std::f64::consts::PI);
    d.min(2.0 * std::f64::consts::PI - d)
}

/// Plays `actions[e]` from `reset(seeds[e])` for every episode `e`.
fn measure<P: HandPhysics>(env: &mut ShadowHand<P>, seeds: &[u64], actions: &[Vec<JointAction>]) -> Result<Row> {
    let dt = MODEL_TIMESTEP * env.config().substeps as f64;
    let mut row = Row::default();
    let (mut steps, mut with_contacts) = (0usize, 0usize);
    for (&seed, episode) in seeds.iter().zip(actions) {
        env.reset(seed)?;
        let start = yaw(env.physics().object_pose().1);
        let mut trace = GraspTrace::new(dt)?;
        let mut dropped = false;
        for action in episode {
            let out = env.step(action)?;
            row.touch += env.active_touch_count() as f64;
            row.contacts_occupancy += f64::from(out.info.features[1]);
            dropped |= out.info.dropped;
            trace.push(&env.object_contacts())?;
            steps += 1;
        }
        row.turned += wrapped(yaw(env.physics().object_pose().1) - start);
        row.drops += usize::from(dropped);
        if let Some(s) = trace.summary() {
            row.q_msv += s.q_msv.mean;
            row.q_vew += s.q_vew.mean;
            if let Some(d) = s.q_dcc {
                row.q_dcc += d.mean;
                with_contacts += 1;
            }
        }
    }
    let n = seeds.len() as f64;
    row.touch /= steps as f64;
    row.contacts_occupancy /= steps as f64;
    row.q_msv /= n;
    row.q_vew /= n;
    row.q_dcc /= with_contacts.max(1) as f64;
    row.turned /= n;
    Ok(row)
}

fn random_actions(seeds: &[u64], len: usize) -> Vec<Vec<JointAction>> {
    seeds
        .iter()
        .map(|&s| {
            let mut rng = ChaCha8Rng::seed_from_u64(s ^ 0x5eed);
            (0..len).map(|_| JointAction((0..20).map(|_| rng.random_range(-1.0..1.0)).collect())).collect()
        })
        .collect()
}

fn scripted_actions(seeds: &[u64], len: usize) -> Vec<Vec<JointAction>> {
    let step = |t: usize| {
        if t < 20 {
            return JointAction::zeros(20);
        }
        let s = (t - 20) as f32 * 0.04;
        JointAction((0..20).map(|i| 0.5 * (2.0 * s + i as f32 * 0.7).sin()).collect())
    };
    seeds.iter().map(|_| (0..len).map(step).collect()).collect()
}

/// The actions the run's policy chose on rapier, episode by episode.
fn policy_actions(run: &str, seeds: &[u64]) -> Result<Vec<Vec<JointAction>>> {
    let dir = RunDir::new(run);
    let config: ExperimentConfig = dir.load_config().context("reading the run's config.toml")?;
    let mut trainer = config.build_trainer(vec![config.env_config().init()?])?;
    trainer.load_checkpoint_without_storage(&dir.checkpoint())?;
    seeds.iter().map(|&s| Ok(trainer.rollout_with(s, ActMode::Evaluate, &mut |_, _| {})?.actions)).collect()
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let value = |flag: &str| args.iter().position(|a| a == flag).and_then(|i| args.get(i + 1)).cloned();
    if args.iter().any(|a| a.starts_with("--") && !["--episodes", "--run"].contains(&a.as_str())) {
        bail!("usage: engine_parity [--episodes N] [--run RUN_DIR]");
    }
    let episodes: u64 = value("--episodes").map(|v| v.parse()).transpose()?.unwrap_or(20);
    let seeds: Vec<u64> = (0..episodes).map(|s| 1000 + s).collect();
    let config = ShadowHandConfig::test_block();
    let len = config.episode_len;
    let mut sources = vec![("random", random_actions(&seeds, len)), ("scripted", scripted_actions(&seeds, len))];
    if let Some(run) = value("--run") {
        sources.push(("policy", policy_actions(&run, &seeds)?));
    }
    let before = RapierSettings::without_fidelity();
    let variants: [(&str, RapierSettings); 5] = [
        ("rapier, object contacts only, no torsion, no slack", before),
        ("rapier, + every contact on touch", RapierSettings { touch_every_contact: true, ..before }),
        ("rapier, + torsional friction", RapierSettings { torsional_friction: true, ..before }),
        ("rapier, + tendon slack", RapierSettings { tendon_slack: true, ..before }),
        ("rapier, all three (default)", RapierSettings::default()),
    ];
    println!("{} episodes of {len} steps per source, seeds {}..{}\n", seeds.len(), seeds[0], seeds[seeds.len() - 1]);
    println!(
        "| actions | engine | active touch / step | contacts occupancy | Q_MSV | Q_VEW | Q_DCC (1e-3 m) | turned (rad) | drops |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    for (name, actions) in &sources {
        let mut mujoco = config.clone().init_mujoco(MujocoSettings::default())?;
        print_row(name, "MuJoCo 3.17", &measure(&mut mujoco, &seeds, actions)?);
        for (label, settings) in &variants {
            let mut rapier = ShadowHandConfig { rapier: *settings, ..config.clone() }.init()?;
            print_row(name, label, &measure(&mut rapier, &seeds, actions)?);
        }
    }
    Ok(())
}

fn print_row(actions: &str, engine: &str, r: &Row) {
    println!(
        "| {actions} | {engine} | {:.2} | {:.3} | {:.4} | {:.5} | {:.1} | {:.2} | {} |",
        r.touch,
        r.contacts_occupancy,
        r.q_msv,
        r.q_vew,
        1e3 * r.q_dcc,
        r.turned,
        r.drops
    );
}
