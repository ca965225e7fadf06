//! Shared set-up of the integration tests: the trainer on the TeamReach test env
//! with the burn DDPG learner, for each of the paper's four configurations.

#![allow(dead_code)]

use fmsr::prelude::*;

/// Small networks and a small budget: enough for TeamReach to be learned.
pub fn trainer_config(method: Method, seed: u64, epochs: usize) -> TrainerConfig {
    TrainerConfig {
        seed,
        epochs,
        cycles: 10,
        episodes_per_cycle: 2,
        batches: 20,
        batch_size: 128,
        buffer_size: 100_000,
        eval_episodes: 20,
        shadow: ShadowConfig {
            enabled: method.shadow(),
            alpha: 0.05,
            assignment: Some(RewardAssignment {
                agents: vec![
                    AgentReward { agent: "x".into(), task_weight: 1.0, shadow: vec![] },
                    AgentReward { agent: "y".into(), task_weight: 1.0, shadow: vec![] },
                    AgentReward { agent: "w".into(), task_weight: 1.0, shadow: vec!["safe_region".into()] },
                ],
            }),
            ..ShadowConfig::default()
        },
        ..TrainerConfig::default()
    }
}

/// A trainer of `method` on TeamReach; actors observe their ring neighbours.
pub fn team_reach_trainer(method: Method, seed: u64, epochs: usize) -> Trainer<TeamReach, DdpgLearner> {
    let env = TeamReachConfig { reward: method.reward(), ..TeamReachConfig::default() }.init().unwrap();
    let graph = Graph::ring(3);
    let layout = ObservationLayout::from_graph(env.spec().clone(), &graph).unwrap();
    let config = trainer_config(method, seed, epochs);
    let sharing = SharingConfig { enabled: method.sharing(), ..SharingConfig::default() }.build(&graph).unwrap();
    let ddpg = DdpgConfig::new()
        .with_hidden(64)
        .with_layers(2)
        .with_seed(seed)
        .with_gamma(config.gamma_for(env.spec().episode_len));
    let learner = DdpgLearner::new(layout.clone(), ddpg, sharing).unwrap();
    Trainer::new(config, env, learner, layout).unwrap()
}

/// An epoch's statistics without the wall-clock timings, which differ between runs.
pub fn learning_stats(s: &EpochStats) -> EpochStats {
    EpochStats { env_steps_per_sec: 0.0, updates_per_sec: 0.0, seconds: 0.0, ..s.clone() }
}
