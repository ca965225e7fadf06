//! One paper epoch of a paper config (default Dense+FMSR+IS on the block,
//! rapier; `FMSR_EPOCH_CONFIG` names another, the egg on MuJoCo say), with
//! the paper's proportions: 25 cycles x 8 rollouts x 100 steps = 20k env steps and
//! 25 cycles x 25 = 625 joint updates of the 6 agents (batch 1024, the paper's
//! 4 workers x 256; networks 3 x 256), evaluation excluded. To fit a bench run it times `FMSR_EPOCH_CYCLES`
//! cycles (default 5, i.e. 1/5 of both) and scales to the whole epoch.
//!
//! Settings, measured in one run:
//! 1. one env on one thread (the trainer before vectorised rollouts);
//! 2. 8 envs in lockstep (one batched policy call per step), stepped on all
//!    cores, the agents' updates on all cores.
//!
//! Each setting's line names the task and splits its time into the updates
//! and the rest (collection, storing, sharing). The last line is
//! `speedup X.XX` of setting 2 over setting 1.
//!
//! `cargo bench --bench paper_epoch`; `FMSR_DEVICE=wgpu:0` (with `--features
//! wgpu`) puts the networks on a GPU. `FMSR_EPOCH_CONFIG` names another
//! experiment file (a bench binary carried to another machine has no
//! checkout at the path it was built in).

use std::time::Instant;

use anyhow::{Context, Result};
use fmsr::experiment::ExperimentConfig;
use fmsr::prelude::*;

mod common;
use common::config_path;

const PAPER_CYCLES: usize = 25;

/// Seconds of `cycles` cycles of the paper config with `envs` envs, `threads`
/// stepping threads and `learner_threads` update threads.
fn time_cycles(cycles: usize, envs: usize, threads: usize, learner_threads: usize) -> Result<(f64, EpochStats)> {
    let mut config = ExperimentConfig::load(&config_path())?;
    config.trainer.epochs = 1;
    config.trainer.cycles = cycles;
    config.trainer.eval_episodes = 0;
    config.trainer.envs = Some(envs);
    config.trainer.threads = Some(threads);
    config.networks.threads = learner_threads;
    if let Ok(device) = std::env::var("FMSR_DEVICE") {
        config.device = device.parse().context("FMSR_DEVICE")?;
    }
    let engine = config.engine;
    let hands = (0..envs)
        .map(|_| config.env_config().init_engine(engine))
        .collect::<Result<Vec<_>, _>>()
        .context("Shadow Hand")?;
    let mut trainer = config.build_trainer(hands)?;
    let start = Instant::now();
    let stats = trainer.run_epoch()?;
    Ok((start.elapsed().as_secs_f64(), stats))
}

fn main() -> Result<()> {
    if std::env::args().any(|a| a == "--list") {
        return Ok(()); // `cargo test --benches` lists benches; nothing to list here
    }
    // As the `fmsr` binary trains: freed memory kept for the next step (fmsr::allocator).
    let kept = fmsr::allocator::keep_freed_memory();
    println!("allocator: {}", if kept { "freed memory kept (fmsr::allocator)" } else { "the C library's defaults" });
    let cycles: usize = std::env::var("FMSR_EPOCH_CYCLES").ok().map(|v| v.parse()).transpose()?.unwrap_or(5);
    let cores = std::thread::available_parallelism().map_or(1, std::num::NonZero::get);
    let scale = PAPER_CYCLES as f64 / cycles as f64;
    let config = ExperimentConfig::load(&config_path())?;
    println!(
        "paper epoch of {} on the {} ({}, {}): {cycles} of {PAPER_CYCLES} cycles timed, scaled x{scale:.1}; {cores} cores",
        config.label(),
        format!("{:?}", config.env.object).to_lowercase(),
        config.engine.key(),
        config.name
    );
    let mut epochs = Vec::new();
    for (name, envs, threads) in [("1 env, 1 thread", 1, 1), ("8 envs, all cores", 8, cores)] {
        let (secs, stats) = time_cycles(cycles, envs, threads, threads)?;
        let epoch = secs * scale;
        let update = stats.updates as f64 / stats.updates_per_sec.max(1e-9);
        println!(
            "{name}: {secs:.1} s for {} env steps and {} updates -> {epoch:.1} s per paper epoch: updates {:.1} s \
             ({:.0} %), collection, storing and sharing {:.1} s ({:.0} env steps/s while collecting, {:.1} updates/s)",
            stats.env_steps,
            stats.updates,
            update * scale,
            100.0 * update / secs,
            (secs - update) * scale,
            stats.env_steps_per_sec,
            stats.updates_per_sec
        );
        epochs.push(epoch);
    }
    println!("speedup {:.2}", epochs[0] / epochs[1]);
    Ok(())
}
