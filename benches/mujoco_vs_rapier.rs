//! Env steps/s of the Shadow Hand block task on MuJoCo 3.17 (feature `mujoco`)
//! and on rapier3d (default settings), measured in one run on one thread with the
//! same random actions, and their ratio.
//!
//! ```text
//! scripts/setup_mujoco.sh
//! cargo bench --features mujoco --bench mujoco_vs_rapier
//! ```
//!
//! Each env runs episodes of 100 steps (resets included in the time, as in
//! training) until `SECONDS` have passed; both envs take turns, three rounds each,
//! and the best round of each is reported.

use std::hint::black_box;
use std::time::{Duration, Instant};

use fmsr_core::Env;
use fmsr_core::spec::JointAction;
use fmsr_envs::shadow_hand::{MujocoSettings, ShadowHandConfig};
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};

const SECONDS: f64 = 3.0;
const ROUNDS: usize = 3;

/// Steps `env` with random actions for about `SECONDS`; returns env steps/s.
fn measure<E: Env>(env: &mut E, seed: u64) -> f64
where
    E::Error: std::fmt::Debug,
{
    let mut rng = StdRng::seed_from_u64(seed);
    let len = env.spec().episode_len;
    let dim = env.spec().action_dim;
    let budget = Duration::from_secs_f64(SECONDS);
    let start = Instant::now();
    let (mut steps, mut episode) = (0u64, 0u64);
    while start.elapsed() < budget {
        env.reset(seed + episode).expect("reset");
        episode += 1;
        for _ in 0..len {
            let action = JointAction((0..dim).map(|_| rng.random_range(-1.0..1.0)).collect());
            black_box(env.step(&action).expect("step"));
            steps += 1;
        }
    }
    steps as f64 / start.elapsed().as_secs_f64()
}

fn main() {
    // `cargo bench` passes `--bench`; `cargo test --benches` runs it briefly as a smoke test.
    let quick = !std::env::args().any(|a| a == "--bench");
    let mut mujoco = ShadowHandConfig::default().init_mujoco(MujocoSettings::default()).expect("MuJoCo env");
    let mut rapier = ShadowHandConfig::default().init().expect("rapier env");
    if quick {
        let a = JointAction::zeros(20);
        mujoco.reset(0).expect("reset");
        rapier.reset(0).expect("reset");
        mujoco.step(&a).expect("step");
        rapier.step(&a).expect("step");
        println!("mujoco_vs_rapier: smoke test ok (run `cargo bench --features mujoco --bench mujoco_vs_rapier`)");
        return;
    }
    let (mut best_mj, mut best_ra) = (0.0f64, 0.0f64);
    for round in 0..ROUNDS {
        let mj = measure(&mut mujoco, 1000 * round as u64);
        let ra = measure(&mut rapier, 1000 * round as u64);
        println!("round {round}: MuJoCo {mj:.0} steps/s, rapier {ra:.0} steps/s");
        best_mj = best_mj.max(mj);
        best_ra = best_ra.max(ra);
    }
    let rapier_settings = rapier.config().rapier;
    println!(
        "Shadow Hand block, random actions, 1 thread, 20 x 0.002 s per env step \
         (rapier: dt {} x {} solver it x {} PGS)",
        rapier_settings.timestep, rapier_settings.solver_iterations, rapier_settings.pgs_iterations
    );
    println!("MuJoCo 3.17 (mujoco-rs 7.0.0): {best_mj:.0} env steps/s");
    println!("rapier3d:                      {best_ra:.0} env steps/s");
    println!("ratio MuJoCo / rapier:         {:.2}", best_mj / best_ra);
}
