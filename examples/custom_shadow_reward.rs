//! A shadow reward of your own, end to end: a user-defined occupancy estimator
//! and a user-defined utility train the agents of the TeamReach test env
//! through the public API, and the feature's occupancy is compared with the
//! Dense baseline's (no shadow reward).
//!
//! - `MeanOfRecent`: the plain mean of each feature over the last episodes
//!   (instead of the paper's discounted occupancy, eq. 1);
//! - `SqrtUtility`: `F(lambda) = sqrt(lambda + c)`, whose per-step shadow reward
//!   is `phi * F'(lambda) = phi / (2 sqrt(lambda + c))` (instead of the paper's
//!   `log(lambda + 0.1)`, eqs. 11-12).
//!
//! `cargo run --release --example custom_shadow_reward`;
//! `tests/user_shadow_reward.rs` runs this file's [`train`] and checks that
//! the user's shadow reward raises its feature above Dense's.

use std::collections::VecDeque;

use anyhow::Result;
use fmsr::prelude::*;

/// `F(lambda) = sqrt(lambda + c)`.
#[derive(Debug, Clone, Copy)]
pub struct SqrtUtility {
    /// The offset `c`.
    pub c: f64,
}

impl ShadowReward for SqrtUtility {
    fn utility(&self, lambda: f64) -> f64 {
        (lambda + self.c).sqrt()
    }

    fn step_reward(&self, phi: f64, lambda: f64) -> f64 {
        phi / (2.0 * (lambda.max(0.0) + self.c).sqrt())
    }

    fn step_reward_range(&self) -> (f64, f64) {
        (0.0, 1.0 / (2.0 * self.c.sqrt()))
    }
}

/// The mean of each feature over the last `window` episodes.
#[derive(Debug)]
pub struct MeanOfRecent {
    window: usize,
    episodes: VecDeque<Vec<f64>>,
    estimate: Vec<f64>,
}

impl OccupancyEstimator for MeanOfRecent {
    fn observe_episode(&mut self, features: &[Vec<f32>]) -> Result<(), CoreError> {
        let k = self.estimate.len();
        let mut mean = vec![0.0; k];
        for phi in features {
            if phi.len() != k {
                return Err(CoreError::Dimension { what: "feature vector", expected: k, found: phi.len() });
            }
            mean.iter_mut().zip(phi).for_each(|(m, v)| *m += f64::from(*v) / features.len() as f64);
        }
        self.episodes.push_back(mean);
        if self.episodes.len() > self.window {
            self.episodes.pop_front();
        }
        for (j, e) in self.estimate.iter_mut().enumerate() {
            *e = self.episodes.iter().map(|m| m[j]).sum::<f64>() / self.episodes.len() as f64;
        }
        Ok(())
    }

    fn estimate(&self) -> &[f64] {
        &self.estimate
    }
}

/// Trains MADDPG on TeamReach; with `shadow`, the wobbling agent `w` gets the
/// shadow reward of the `safe_region` feature. Returns the feature's rate on
/// 100 test episodes and the estimator's final estimate of it.
///
/// # Errors
/// Errors of the environment, the shadow rewards, the trainer or MADDPG.
pub fn train(shadow: bool) -> Result<(f64, f64)> {
    let env = TeamReachConfig::default().init()?;
    let spec = env.spec().clone();
    let graph = Graph::ring(3);
    let layout = ObservationLayout::from_graph(spec.clone(), &graph)?;
    let config = TrainerConfig { seed: 2, epochs: 12, cycles: 10, eval_episodes: 20, ..TrainerConfig::default() };
    let assignment = if shadow {
        RewardAssignment {
            agents: ["x", "y", "w"]
                .iter()
                .map(|a| AgentReward {
                    agent: (*a).into(),
                    task_weight: 1.0,
                    shadow: if *a == "w" { vec!["safe_region".into()] } else { vec![] },
                })
                .collect(),
        }
    } else {
        RewardAssignment::task_only(&spec)
    };
    let rewards = AgentRewards::new(assignment.resolve(&spec)?, SqrtUtility { c: 0.05 }, 0.2)?;
    let estimator = MeanOfRecent { window: 20, episodes: VecDeque::new(), estimate: vec![0.0; spec.features.len()] };
    let shadow = ShadowRewards::new(&spec, estimator, rewards)?;
    let collector = Collector::new(env, layout.clone())?;
    let networks = NetworkConfig::new().with_hidden(64).with_layers(2).with_seed(2);
    let replay = ReplayConfig { batches: 20, batch_size: 128, buffer_size: 100_000, ..ReplayConfig::default() };
    let parts = LearnerParts::new(layout, networks, replay, config.gamma_for(spec.episode_len));
    let mut trainer = Trainer::from_parts(config, collector, shadow, Maddpg::new(parts, MaddpgConfig::new())?)?;
    trainer.train(|_, s| {
        println!("  epoch {}: success {:.2}, estimate {:.3}", s.epoch, s.success_rate, s.occupancy[0]);
        Ok(())
    })?;
    let seeds: Vec<u64> = (0..100).map(|i| 20_000 + i).collect();
    Ok((trainer.evaluate(&seeds, None)?.feature_rates[0], trainer.occupancy()[0]))
}

fn main() -> Result<()> {
    println!("sqrt utility + mean-of-recent estimator:");
    let (user, _) = train(true)?;
    println!("Dense (task reward only):");
    let (dense, _) = train(false)?;
    println!("safe_region rate on the test episodes: user shadow reward {user:.3}, Dense {dense:.3}");
    Ok(())
}
