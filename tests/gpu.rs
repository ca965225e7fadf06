//! Guards the GPU code path (feature `wgpu`), run by `scripts/test_gpu.sh` on
//! Mesa's CPU Vulkan driver (lavapipe, device `wgpu:cpu`) or on a GPU (CI only
//! type-checks fmsr-nn's GPU code: this build takes over 20 minutes on 2 cores): the
//! device is found by name and a missing one is an error listing what
//! exists; joint MADDPG updates on the device, where the agents are one
//! stacked network (`Stacking::Auto`), equal the same updates on burn's `flex`
//! CPU backend, one stack per agent, within float tolerance; and
//! Dense+FMSR+IS learns TeamReach on the device.
//!
//! One test, so that the kernels, which lavapipe takes minutes to compile on
//! first use, are compiled once per process.
//!
//! `cargo test --features wgpu --test gpu` (with `XDG_RUNTIME_DIR` set to a
//! private directory, or wgpu warns on every call).

mod common;

use std::time::Instant;

use fmsr::prelude::*;
use fmsr_nn::DeviceSpec;
use rand::{RngExt, SeedableRng};

/// The device the test runs on: `FMSR_GPU_TEST_DEVICE` or lavapipe's `wgpu:cpu`.
fn device_name() -> String {
    std::env::var("FMSR_GPU_TEST_DEVICE").unwrap_or_else(|_| "wgpu:cpu".into())
}

fn devices_are_found_by_name(name: &str) -> Device {
    let available = fmsr_nn::device::available();
    assert!(available.iter().any(|d| d == name), "{name} not among {available:?}");
    let missing = "wgpu:integrated:9".parse::<DeviceSpec>().unwrap().device().unwrap_err().to_string();
    assert!(missing.contains(name), "the error should list the devices that exist: {missing}");
    name.parse::<DeviceSpec>().unwrap().device().unwrap()
}

/// A random batch of `n` samples fitting `layout`.
fn batch(layout: &ObservationLayout, n: usize, seed: u64) -> Batch {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let spec = layout.spec();
    let mut v = |len: usize| (0..len).map(|_| rng.random_range(-1.0f32..1.0)).collect::<Vec<f32>>();
    let agents = spec.num_agents();
    Batch {
        size: n,
        obs: v(n * spec.obs_dim),
        next_obs: v(n * spec.obs_dim),
        goals: v(n * spec.goal_dim),
        actions: v(n * spec.action_dim),
        actor_inputs: (0..agents).map(|i| v(n * layout.actor_input_dim(i))).collect(),
        next_actor_inputs: (0..agents).map(|i| v(n * layout.actor_input_dim(i))).collect(),
        task_rewards: v(n),
        features: vec![],
        rewards: (0..agents).map(|_| v(n).into_iter().map(|r| r - 1.0).collect()).collect(),
    }
}

/// Losses of three joint updates and the final parameters of every agent.
fn three_updates(device: Device) -> (Vec<f32>, Vec<f32>) {
    let env = common::team_reach(Method::DenseFmsrIs);
    let parts = common::parts(&env, Method::DenseFmsrIs, 3, 0.98).with_device(device);
    let layout = parts.layout.clone();
    let mut l = Maddpg::new(parts, MaddpgConfig::new()).unwrap();
    let mut losses = Vec::new();
    for step in 0..3 {
        let (c, a) = l.learn_batch(&batch(&layout, 64, step), &[(-50.0, 0.0); 3]).unwrap();
        losses.extend(c.into_iter().chain(a));
    }
    let params = (0..3).flat_map(|i| {
        let (a, c) = l.params(i).unwrap();
        a.into_iter().chain(c)
    });
    (losses, params.collect())
}

/// The largest `|a - b| / (atol + rtol |b|)`.
fn worst(a: &[f32], b: &[f32], atol: f32, rtol: f32) -> f32 {
    assert_eq!(a.len(), b.len());
    a.iter().zip(b).map(|(x, y)| (x - y).abs() / (atol + rtol * y.abs())).fold(0.0, f32::max)
}

#[test]
fn the_gpu_path_computes_and_learns_as_the_cpu_path() {
    let name = device_name();
    let start = Instant::now();
    let device = devices_are_found_by_name(&name);

    let (gpu_losses, gpu_params) = three_updates(device.clone());
    eprintln!("three updates on {name}: {:.1} s (kernel compilation included)", start.elapsed().as_secs_f64());
    let (cpu_losses, cpu_params) = three_updates(Device::flex());
    // Losses to 1e-4 relative; parameters within a few Adam steps (lr 1e-3) of
    // gradients near zero, whose sign the order of summation may flip.
    let (l, p) = (worst(&gpu_losses, &cpu_losses, 1e-5, 1e-4), worst(&gpu_params, &cpu_params, 2e-3, 1e-3));
    assert!(l <= 1.0 && p <= 1.0, "{name} differs from flex: losses {l}, parameters {p} (1 = tolerance)");

    let start = Instant::now();
    let epochs = 8;
    let method = Method::DenseFmsrIs;
    let config = common::trainer_config(method, 1, epochs);
    let env = common::team_reach(method);
    let parts = common::parts(&env, method, config.seed, config.gamma_for(env.spec().episode_len)).with_device(device);
    let layout = parts.layout.clone();
    let learner = AnyLearner::new(Maddpg::new(parts, MaddpgConfig::new()).unwrap());
    let envs = (0..config.num_envs()).map(|_| common::team_reach(method)).collect();
    let mut trainer = Trainer::with_envs(config, envs, learner, layout).unwrap();
    trainer.train(|_, _| Ok(())).unwrap();
    let seeds: Vec<u64> = (0..100).map(|i| 10_000 + i).collect();
    let learned = trainer.evaluate(&seeds, Some(0.1)).unwrap().success_rate;
    let curve: Vec<f64> = trainer.history().iter().map(|s| s.success_rate).collect();
    eprintln!(
        "TeamReach on {name}, {epochs} epochs in {:.0} s: success {learned:.2}, curve {curve:?}",
        start.elapsed().as_secs_f64()
    );
    // tests/learning.rs asks random + 0.4 of the CPU path after 12 epochs; 8
    // keep CI on lavapipe short (the CPU path is at 0.6-0.9 by then).
    let random = common::random_policy_success(&seeds);
    assert!(learned >= random + 0.3, "Dense+FMSR+IS reached {learned} on {name}, random play {random}");
}
