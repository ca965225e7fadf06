//! Guards the collector seam end to end: a user-defined `OccupancyEstimator`
//! (undiscounted mean over the last episodes) and a user-defined
//! `ShadowReward` (a square-root utility) plug into training through the
//! public API only, and their shadow reward raises the occupancy of its
//! feature (the safe region of TeamReach) above the Dense baseline's.

mod common;

use std::collections::VecDeque;

use fmsr::prelude::*;

/// `F(lambda) = sqrt(lambda + c)`; per-step reward `phi * F'(lambda) = phi / (2 sqrt(lambda + c))`.
#[derive(Debug, Clone, Copy)]
struct SqrtUtility {
    c: f64,
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

/// The plain (undiscounted) mean of each feature over the last `window` episodes.
#[derive(Debug)]
struct MeanOfRecent {
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

fn safe_region_rate(shadow: bool) -> f64 {
    let method = if shadow { Method::DenseFmsr } else { Method::Dense };
    let env = common::team_reach(method);
    let config = common::trainer_config(method, 2, 12);
    let spec = env.spec().clone();
    let parts = common::parts(&env, method, 2, config.gamma_for(spec.episode_len));
    let layout = parts.layout.clone();
    let assignment = config.shadow.assignment.clone().unwrap_or_else(|| RewardAssignment::task_only(&spec));
    let assignment = if shadow { assignment } else { RewardAssignment::task_only(&spec) };
    let rewards = AgentRewards::new(assignment.resolve(&spec).unwrap(), SqrtUtility { c: 0.05 }, 0.2).unwrap();
    let estimator = MeanOfRecent { window: 20, episodes: VecDeque::new(), estimate: vec![0.0; spec.features.len()] };
    let shadow = ShadowRewards::new(&spec, estimator, rewards).unwrap();
    let collector = Collector::new(env, layout).unwrap();
    let learner = AnyLearner::Maddpg(Maddpg::new(parts, MaddpgConfig::new()).unwrap());
    let mut trainer = Trainer::from_parts(config, collector, shadow, learner).unwrap();
    trainer.train(|_, _| Ok(())).unwrap();
    assert!(trainer.occupancy()[0] > 0.0, "the user's estimator saw the feature");
    let seeds: Vec<u64> = (0..100).map(|i| 20_000 + i).collect();
    trainer.evaluate(&seeds, None).unwrap().feature_rates[0]
}

#[test]
fn user_estimator_and_utility_raise_their_feature() {
    let (user, dense) = (safe_region_rate(true), safe_region_rate(false));
    eprintln!("safe_region rate: sqrt utility + mean-of-recent estimator {user:.3}, Dense {dense:.3}");
    assert!(user > dense + 0.1, "user shadow reward {user} vs Dense {dense}");
}
