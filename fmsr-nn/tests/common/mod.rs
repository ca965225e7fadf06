//! Shared helpers of the fmsr-nn integration tests: hand-built layouts and
//! batches (no environment needed).
#![allow(dead_code)]

use fmsr_core::agent::{Batch, ObservationLayout};
use fmsr_core::replay::Episode;
use fmsr_core::spec::{AgentSpec, EnvSpec};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A layout of agents with the given action dims (slots interleaved so that
/// agents do not own contiguous slots), local obs dims `3 + i`, a ring of
/// neighbours, global obs `obs_dim` and goal `goal_dim`.
pub fn layout(action_dims: &[usize], obs_dim: usize, goal_dim: usize) -> ObservationLayout {
    let total: usize = action_dims.iter().sum();
    // Deal the slots round robin so that ownership is not contiguous.
    let mut slots: Vec<Vec<usize>> = vec![Vec::new(); action_dims.len()];
    let mut s = 0;
    while s < total {
        for (i, &d) in action_dims.iter().enumerate() {
            if slots[i].len() < d && s < total {
                slots[i].push(s);
                s += 1;
            }
        }
    }
    let agents = slots
        .into_iter()
        .enumerate()
        .map(|(i, action_slots)| AgentSpec { name: format!("agent{i}"), action_slots, local_obs_dim: 3 + i })
        .collect();
    let spec = EnvSpec {
        agents,
        action_dim: total,
        obs_dim,
        goal_dim,
        episode_len: 10,
        features: vec![],
        reward_range: (-1.0, 0.0),
    };
    let n = action_dims.len();
    let neighbours = (0..n)
        .map(|i| {
            if n < 2 {
                vec![]
            } else if n == 2 {
                vec![1 - i]
            } else {
                vec![(i + 1) % n, (i + n - 1) % n]
            }
        })
        .collect();
    ObservationLayout::new(spec, neighbours).unwrap()
}

/// A random batch of `n` samples fitting `layout`, from `seed`.
pub fn batch(layout: &ObservationLayout, n: usize, seed: u64) -> Batch {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let spec = layout.spec();
    let na = spec.num_agents();
    let mut v = |len: usize, scale: f32| (0..len).map(|_| rng.random_range(-scale..scale)).collect::<Vec<f32>>();
    let obs = v(n * spec.obs_dim, 2.0);
    let next_obs = v(n * spec.obs_dim, 2.0);
    let goals = v(n * spec.goal_dim, 1.0);
    let actions = v(n * spec.action_dim, 1.0);
    let actor_inputs = (0..na).map(|i| v(n * layout.actor_input_dim(i), 2.0)).collect();
    let next_actor_inputs = (0..na).map(|i| v(n * layout.actor_input_dim(i), 2.0)).collect();
    let rewards = (0..na).map(|_| v(n, 1.0).into_iter().map(|r| r - 1.0).collect()).collect();
    Batch {
        size: n,
        obs,
        next_obs,
        goals,
        actions,
        actor_inputs,
        next_actor_inputs,
        task_rewards: vec![-1.0; n],
        features: vec![],
        rewards,
    }
}

/// Q-target bounds wide enough not to clip.
pub fn bounds(layout: &ObservationLayout) -> Vec<(f32, f32)> {
    vec![(-100.0, 0.0); layout.spec().num_agents()]
}

/// Learner parts on the CPU with `net`, no sharing, discount `gamma`.
pub fn parts(layout: &ObservationLayout, net: fmsr_nn::NetworkConfig, gamma: f64) -> fmsr_nn::LearnerParts {
    fmsr_nn::LearnerParts::new(layout.clone(), net, fmsr_core::replay::ReplayConfig::default(), gamma)
}

/// The crate's three algorithms, for the tests that run each.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AlgorithmKind {
    Maddpg,
    Matd3,
    Masac,
}

impl AlgorithmKind {
    pub const ALL: [AlgorithmKind; 3] = [AlgorithmKind::Maddpg, AlgorithmKind::Matd3, AlgorithmKind::Masac];

    /// The algorithm's name (`UpdateRule::NAME`).
    pub fn key(self) -> &'static str {
        match self {
            AlgorithmKind::Maddpg => "maddpg",
            AlgorithmKind::Matd3 => "matd3",
            AlgorithmKind::Masac => "masac",
        }
    }

    /// A learner of this algorithm with default settings.
    pub fn build(self, parts: fmsr_nn::LearnerParts) -> fmsr_nn::AnyLearner {
        use fmsr_nn::{AnyLearner, Maddpg, MaddpgConfig, Masac, MasacConfig, Matd3, Matd3Config};
        match self {
            AlgorithmKind::Maddpg => AnyLearner::new(Maddpg::new(parts, MaddpgConfig::new()).unwrap()),
            AlgorithmKind::Matd3 => AnyLearner::new(Matd3::new(parts, Matd3Config::new()).unwrap()),
            AlgorithmKind::Masac => AnyLearner::new(Masac::new(parts, MasacConfig::new()).unwrap()),
        }
    }
}

/// A learner of `kind` with `net`, small batches (16 samples, 2 gradient steps a cycle), discount 0.9.
pub fn learner(kind: AlgorithmKind, layout: &ObservationLayout, net: fmsr_nn::NetworkConfig) -> fmsr_nn::AnyLearner {
    let replay = fmsr_core::replay::ReplayConfig { batch_size: 16, batches: 2, ..Default::default() };
    kind.build(fmsr_nn::LearnerParts::new(layout.clone(), net, replay, 0.9))
}

/// One row of actor inputs per agent.
pub fn inputs(layout: &ObservationLayout, n: usize, seed: u64) -> Vec<Vec<f32>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..layout.spec().num_agents())
        .map(|i| (0..n * layout.actor_input_dim(i)).map(|_| rng.random_range(-1.0..1.0)).collect())
        .collect()
}

/// Bit patterns of a float vector, for exact comparisons.
pub fn bits(v: &[f32]) -> Vec<u32> {
    v.iter().map(|x| x.to_bits()).collect()
}

/// A random episode of `layout`'s spec (observations, actions, no features):
/// [`fmsr_core::testing::random_episode`].
pub fn episode(layout: &ObservationLayout, seed: u64) -> Episode {
    fmsr_core::testing::random_episode(layout.spec(), seed)
}
