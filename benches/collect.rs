//! Collection on one core and on all: env steps/s of a paper config's
//! lockstep rollouts (8 environments, one batched policy call a step, the
//! policy's own actors acting), with the stepping threads (`trainer.threads`)
//! and the learner's threads (`networks.threads`) set apart, and the ratio of
//! each setting to one core's rate. The ceiling beside them: the same
//! environments stepped with zero actions and no policy, on one thread
//! (the env's own step rate, physics and observation), and the machine's
//! own ceiling for two cores: two processes collecting on one core each at
//! once (their summed rate; a VM's two cores may give less than twice one).
//!
//! Default: the paper's block config on rapier; `FMSR_EPOCH_CONFIG` names
//! another (`configs/mujoco/egg_dense_fmsr_is.toml` with `--features mujoco`).
//! `FMSR_COLLECT_EPISODES` episodes a setting (default 16, two rounds of the
//! 8 environments). The last lines are `two cores / one core X.XX` and
//! `two cores / two processes X.XX`.
//!
//! `cargo bench --bench collect` (with `--features mujoco` for MuJoCo).

use std::time::Instant;

use anyhow::{Context, Result};
use fmsr::experiment::ExperimentConfig;
use fmsr::prelude::*;

mod common;
use common::config_path;
use fmsr_core::spec::JointAction;

const ENVS: usize = 8;

/// Env steps/s of `episodes` exploring rollouts with `threads` stepping
/// threads and `learner_threads` learner threads (one warm-up round first).
fn rate(config: &ExperimentConfig, episodes: usize, threads: usize, learner_threads: usize) -> Result<f64> {
    let mut config = config.clone();
    config.trainer.envs = Some(ENVS);
    config.trainer.threads = Some(threads);
    config.networks.threads = learner_threads;
    let hands = (0..ENVS)
        .map(|_| config.env_config().init_engine(config.engine))
        .collect::<Result<Vec<_>, _>>()
        .context("Shadow Hand")?;
    let mut trainer = config.build_trainer(hands)?;
    let seeds: Vec<u64> = (0..episodes as u64).collect();
    trainer.evaluate(&seeds[..ENVS.min(episodes)], None)?;
    let steps = episodes * trainer.env().spec().episode_len;
    let start = Instant::now();
    trainer.evaluate(&seeds, None)?;
    Ok(steps as f64 / start.elapsed().as_secs_f64())
}

/// Env steps/s of the environments alone: zero actions, one thread.
fn env_rate(config: &ExperimentConfig, episodes: usize) -> Result<f64> {
    let mut hands = (0..ENVS)
        .map(|_| config.env_config().init_engine(config.engine))
        .collect::<Result<Vec<_>, _>>()
        .context("Shadow Hand")?;
    let spec = hands[0].spec().clone();
    let zero = JointAction(vec![0.0; spec.action_dim]);
    let mut steps = 0usize;
    let start = Instant::now();
    for round in 0..episodes.div_ceil(ENVS) {
        for (e, hand) in hands.iter_mut().enumerate() {
            hand.reset((round * ENVS + e) as u64).map_err(|e| anyhow::anyhow!("{e}"))?;
        }
        for _ in 0..spec.episode_len {
            for hand in &mut hands {
                hand.step(&zero).map_err(|e| anyhow::anyhow!("{e}"))?;
                steps += 1;
            }
        }
    }
    Ok(steps as f64 / start.elapsed().as_secs_f64())
}

/// The environment variable that makes this binary one of the two
/// single-core processes of the two-process ceiling.
const CHILD: &str = "FMSR_COLLECT_ONE_CORE";

/// The summed env steps/s of two processes of this bench, each collecting
/// with one stepping and one learner thread, started together.
fn two_processes() -> Result<f64> {
    let exe = std::env::current_exe()?;
    let children = (0..2)
        .map(|_| {
            std::process::Command::new(&exe)
                .env(CHILD, "1")
                .env("RAYON_NUM_THREADS", "1")
                .stdout(std::process::Stdio::piped())
                .spawn()
        })
        .collect::<Result<Vec<_>, _>>()?;
    let mut sum = 0.0;
    for child in children {
        let out = child.wait_with_output()?;
        anyhow::ensure!(out.status.success(), "a one-core process failed: {}", out.status);
        let text = String::from_utf8_lossy(&out.stdout);
        sum += text.trim().parse::<f64>().with_context(|| format!("a one-core process printed {text:?}"))?;
    }
    Ok(sum)
}

fn main() -> Result<()> {
    if std::env::args().any(|a| a == "--list") {
        return Ok(());
    }
    let episodes: usize = std::env::var("FMSR_COLLECT_EPISODES").ok().map(|v| v.parse()).transpose()?.unwrap_or(16);
    let cores = std::thread::available_parallelism().map_or(1, std::num::NonZero::get);
    let config = ExperimentConfig::load(&config_path())?;
    if std::env::var_os(CHILD).is_some() {
        println!("{}", rate(&config, episodes, 1, 1)?);
        return Ok(());
    }
    println!(
        "collection of {} on the {} ({}): {ENVS} envs in lockstep, {episodes} episodes a setting; {cores} cores",
        config.label(),
        format!("{:?}", config.env.object).to_lowercase(),
        config.engine.key()
    );
    let ceiling = env_rate(&config, episodes)?;
    println!("the envs alone, zero actions, one thread: {ceiling:.0} env steps/s");
    let one = rate(&config, episodes, 1, 1)?;
    println!("stepping 1 thread, learner 1 thread: {one:.0} env steps/s ({:.2} of the envs alone)", one / ceiling);
    let mut all = one;
    if cores > 1 {
        for (threads, learner) in [(cores, 1), (cores, cores)] {
            let r = rate(&config, episodes, threads, learner)?;
            println!(
                "stepping {threads} threads, learner {learner} thread{}: {r:.0} env steps/s ({:.2} of one core's)",
                if learner == 1 { "" } else { "s" },
                r / one
            );
            all = r;
        }
    }
    println!("two cores / one core {:.2}", all / one);
    if cores > 1 {
        let two = two_processes()?;
        println!("two processes of one core each at once: {two:.0} env steps/s ({:.2} of one core's)", two / one);
        println!("two cores / two processes {:.2}", all / two);
    }
    Ok(())
}
