//! Times one joint update of the 6 Shadow Hand agents at the paper's sizes
//! (batch 256, 3 x 256 hidden) and prints updates/s, for 1 and 2 threads.
//!
//! `cargo run -p fmsr-nn --example joint_update --release [iters]`
//! (the criterion version is `cargo bench --bench ddpg_update`).

use std::time::Instant;

use fmsr_core::agent::{Batch, ObservationLayout};
use fmsr_core::replay::ReplayConfig;
use fmsr_core::spec::{AgentSpec, EnvSpec};
use fmsr_nn::{LearnerParts, Maddpg, MaddpgConfig, NetworkConfig};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let iters: usize = std::env::args().nth(1).map(|s| s.parse()).transpose()?.unwrap_or(20);
    let action_dims = [2, 3, 3, 3, 4, 5];
    let local_dims = [60, 52, 52, 52, 58, 165];
    let mut slot = 0;
    let agents = (0..6)
        .map(|i| {
            let slots = (slot..slot + action_dims[i]).collect();
            slot += action_dims[i];
            AgentSpec { name: format!("agent{i}"), action_slots: slots, local_obs_dim: local_dims[i] }
        })
        .collect();
    let spec = EnvSpec {
        agents,
        action_dim: 20,
        obs_dim: 153,
        goal_dim: 7,
        episode_len: 100,
        features: vec![],
        reward_range: (-1.0, 0.0),
    };
    let neighbours = vec![vec![], vec![5, 2], vec![1, 3], vec![2, 4], vec![3, 5], vec![4, 1]];
    let layout = ObservationLayout::new(spec, neighbours)?;
    let n = 256;
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    let mut v = |len: usize| (0..len).map(|_| rng.random_range(-1.0f32..1.0)).collect::<Vec<_>>();
    let batch = Batch {
        size: n,
        obs: v(n * 153),
        next_obs: v(n * 153),
        goals: v(n * 7),
        actions: v(n * 20),
        actor_inputs: (0..6).map(|i| v(n * layout.actor_input_dim(i))).collect(),
        next_actor_inputs: (0..6).map(|i| v(n * layout.actor_input_dim(i))).collect(),
        task_rewards: v(n),
        features: vec![],
        rewards: (0..6).map(|_| v(n)).collect(),
    };
    for threads in [1, 2] {
        let net = NetworkConfig::new().with_threads(threads);
        let parts = LearnerParts::new(layout.clone(), net, ReplayConfig::default(), 0.99);
        let mut learner = Maddpg::new(parts, MaddpgConfig::new())?;
        let bounds = vec![(-100.0, 0.0); 6];
        for _ in 0..3 {
            learner.learn_batch(&batch, &bounds)?;
        }
        let start = Instant::now();
        for _ in 0..iters {
            learner.learn_batch(&batch, &bounds)?;
        }
        let rate = iters as f64 / start.elapsed().as_secs_f64();
        println!("threads={threads}: {rate:.2} joint updates/s ({:.1} ms each)", 1e3 / rate);
    }
    Ok(())
}
