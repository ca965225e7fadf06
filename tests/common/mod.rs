//! Shared set-up of the integration tests: the trainer on the TeamReach test env
//! with the burn learners, for each of the paper's four configurations.

#![allow(dead_code)]

pub mod cli;

use fmsr::prelude::*;
use rand::{RngExt, SeedableRng};

/// Small networks and a small budget: enough for TeamReach to be learned.
pub fn trainer_config(method: Method, seed: u64, epochs: usize) -> TrainerConfig {
    TrainerConfig {
        seed,
        epochs,
        cycles: 10,
        episodes_per_cycle: 2,
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

/// The quick block config (`configs/`) cut down to seconds, with small networks.
/// Every replacement must apply: a quick config that no longer holds one of
/// these lines would otherwise give the CLI tests its full budget.
pub fn tiny_config_text() -> String {
    let mut text = std::fs::read_to_string("configs/block_dense_fmsr_is_quick.toml").unwrap();
    for (from, to) in [
        ("name = \"block_dense_fmsr_is_quick\"", "name = \"tiny\""),
        ("epochs = 8\n", "epochs = 1\n"),
        ("cycles = 50\n", "cycles = 1\n"),
        ("envs = 2\n", ""),
        ("batches = 40\n", "batches = 2\n"),
        ("batch_size = 256\n", "batch_size = 32\n"),
        ("eval_episodes = 10\n", "eval_episodes = 1\n"),
        ("episodes = 100\n", "episodes = 2\n"),
        ("hidden = 256\n", "hidden = 32\n"),
        ("layers = 3\n", "layers = 2\n"),
    ] {
        assert_eq!(text.matches(from).count(), 1, "the quick config changed (`{from}`): update this function");
        text = text.replace(from, to);
    }
    text
}

/// The replay and update schedule of the tests.
pub fn replay() -> ReplayConfig {
    ReplayConfig { buffer_size: 100_000, batch_size: 128, batches: 20, ..ReplayConfig::default() }
}

/// The TeamReach env of `method`'s task reward.
pub fn team_reach(method: Method) -> TeamReach {
    TeamReachConfig { reward: method.reward(), ..TeamReachConfig::default() }.init().unwrap()
}

/// The learner parts of the tests on `env`: ring graph, `method`'s sharing.
pub fn parts(env: &TeamReach, method: Method, seed: u64, gamma: f64) -> LearnerParts {
    let graph = Graph::ring(3);
    let layout = ObservationLayout::from_graph(env.spec().clone(), &graph).unwrap();
    let sharing = SharingConfig { enabled: method.sharing(), ..SharingConfig::default() }.build(&graph).unwrap();
    let net = NetworkConfig::new().with_hidden(64).with_layers(2).with_seed(seed);
    LearnerParts::new(layout, net, replay(), gamma).with_sharing(sharing)
}

/// A trainer of `algorithm` (a registered name) and `method` on TeamReach;
/// actors observe their ring neighbours.
pub fn team_reach_trainer_with(
    algorithm: &str,
    method: Method,
    seed: u64,
    epochs: usize,
) -> Trainer<TeamReach, AnyLearner> {
    team_reach_trainer_config(algorithm, method, trainer_config(method, seed, epochs))
}

/// A trainer of `algorithm` and `method` on `config.num_envs()` TeamReach
/// envs, its learner built by name as an experiment builds it.
pub fn team_reach_trainer_config(
    algorithm: &str,
    method: Method,
    config: TrainerConfig,
) -> Trainer<TeamReach, AnyLearner> {
    let env = team_reach(method);
    let parts = parts(&env, method, config.seed, config.gamma_for(env.spec().episode_len));
    let layout = parts.layout.clone();
    let learner = fmsr::algorithms::build(algorithm, None, parts).unwrap();
    let envs = (0..config.num_envs()).map(|_| team_reach(method)).collect();
    Trainer::with_envs(config, envs, learner, layout).unwrap()
}

/// A MADDPG Dense+FMSR+IS trainer on TeamReach whose replay holds `capacity` episodes.
pub fn trainer_with_capacity(seed: u64, epochs: usize, capacity: usize) -> Trainer<TeamReach, AnyLearner> {
    let method = Method::DenseFmsrIs;
    let config = trainer_config(method, seed, epochs);
    let env = team_reach(method);
    let mut parts = parts(&env, method, seed, config.gamma_for(env.spec().episode_len));
    parts.replay.buffer_size = capacity * env.spec().episode_len;
    let layout = parts.layout.clone();
    let learner = AnyLearner::new(Maddpg::new(parts, MaddpgConfig::new()).unwrap());
    Trainer::new(config, env, learner, layout).unwrap()
}

/// A MADDPG trainer of `method` on TeamReach.
pub fn team_reach_trainer(method: Method, seed: u64, epochs: usize) -> Trainer<TeamReach, AnyLearner> {
    team_reach_trainer_with("maddpg", method, seed, epochs)
}

/// An epoch's statistics without the wall-clock timings, which differ between runs.
pub fn learning_stats(s: &EpochStats) -> EpochStats {
    EpochStats { env_steps_per_sec: 0.0, updates_per_sec: 0.0, seconds: 0.0, ..s.clone() }
}

/// Success rate of uniformly random joint actions on the evaluation seeds.
pub fn random_policy_success(seeds: &[u64]) -> f64 {
    let mut env = TeamReachConfig::default().init().unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(99);
    let mut successes = 0;
    for &seed in seeds {
        env.reset(seed).unwrap();
        let mut last = None;
        for _ in 0..env.spec().episode_len {
            let a = JointAction((0..6).map(|_| rng.random_range(-1.0..=1.0)).collect());
            last = Some(env.step(&a).unwrap());
        }
        successes += usize::from(last.unwrap().info.is_success);
    }
    successes as f64 / seeds.len() as f64
}
