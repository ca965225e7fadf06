//! Env steps/s of the rapier3d Shadow Hand block task with random actions:
//! one env at the default solver settings and at the settings of the table in
//! the crate docs, and `N` envs stepped as a batch across rayon's threads
//! (`step_batch`), to see the scaling.
//!
//! Run with `cargo bench --bench env_step`. One criterion iteration is one
//! env step (batched: one step of every env in the batch; throughput counts env steps).

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use fmsr_core::Env;
use fmsr_core::spec::JointAction;
use fmsr_envs::shadow_hand::{RapierHand, RapierSettings, ShadowHand, ShadowHandConfig, step_batch};
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};

fn random_action(rng: &mut StdRng) -> JointAction {
    JointAction((0..20).map(|_| rng.random_range(-1.0..1.0)).collect())
}

fn env(rapier: RapierSettings, seed: u64) -> ShadowHand<RapierHand> {
    let mut env = ShadowHandConfig { rapier, ..Default::default() }.init().expect("model fetched");
    env.reset(seed).expect("reset");
    env
}

fn single(c: &mut Criterion) {
    let mut group = c.benchmark_group("hand_block_single");
    group.throughput(Throughput::Elements(1));
    group.sample_size(20);
    let d = RapierSettings::default();
    let cases = [
        ("default_dt0.008_it1_pgs4", d),
        ("dt0.002_it2", RapierSettings { timestep: 0.002, solver_iterations: 2, pgs_iterations: 1, ..d }),
        ("dt0.002_it1", RapierSettings { timestep: 0.002, solver_iterations: 1, pgs_iterations: 1, ..d }),
        ("dt0.004_it1_pgs4", RapierSettings { timestep: 0.004, solver_iterations: 1, pgs_iterations: 4, ..d }),
        ("dt0.02_it1_pgs4", RapierSettings { timestep: 0.02, solver_iterations: 1, pgs_iterations: 4, ..d }),
    ];
    for (name, settings) in cases {
        let mut e = env(settings, 0);
        let mut rng = StdRng::seed_from_u64(1);
        let mut steps = 0u64;
        group.bench_function(name, |b| {
            b.iter(|| {
                steps += 1;
                if steps.is_multiple_of(100) {
                    e.reset(steps).expect("reset");
                }
                black_box(e.step(&random_action(&mut rng)).expect("step"))
            });
        });
    }
    group.finish();
}

fn batched(c: &mut Criterion) {
    let mut group = c.benchmark_group("hand_block_batched");
    group.sample_size(10);
    let threads = std::thread::available_parallelism().map_or(1, std::num::NonZero::get);
    for n in [1, 2, 4, 8] {
        let mut envs: Vec<ShadowHand<RapierHand>> = (0..n).map(|i| env(RapierSettings::default(), i as u64)).collect();
        let mut rng = StdRng::seed_from_u64(2);
        group.throughput(Throughput::Elements(n as u64));
        let mut steps = 0u64;
        group.bench_function(format!("n{n}_threads{threads}"), |b| {
            b.iter(|| {
                steps += 1;
                if steps.is_multiple_of(100) {
                    for (i, e) in envs.iter_mut().enumerate() {
                        e.reset(steps + i as u64).expect("reset");
                    }
                }
                let actions: Vec<JointAction> = (0..n).map(|_| random_action(&mut rng)).collect();
                black_box(step_batch(&mut envs, &actions))
            });
        });
    }
    group.finish();
}

criterion_group! {
    name = benches;
    // No plots: plotters finds no font on headless machines and panics.
    config = Criterion::default().without_plots();
    targets = single, batched
}
criterion_main!(benches);
