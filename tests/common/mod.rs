//! Shared set-up of the integration tests: the trainer on the TeamReach test env
//! with the burn learners, for each of the paper's four configurations.

#![allow(dead_code)]

use fmsr::prelude::*;

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
pub fn tiny_config_text() -> String {
    let base = std::fs::read_to_string("configs/block_dense_fmsr_is_quick.toml").unwrap();
    let text = base
        .replace("name = \"block_dense_fmsr_is_quick\"", "name = \"tiny\"")
        .replace("epochs = 5", "epochs = 1")
        .replace("cycles = 10", "cycles = 1")
        .replace("batches = 20", "batches = 2")
        .replace("batch_size = 256", "batch_size = 32")
        .replace("eval_episodes = 5", "eval_episodes = 1")
        .replace("episodes = 100", "episodes = 2")
        .replace("hidden = 256", "hidden = 32")
        .replace("layers = 3", "layers = 2");
    assert_ne!(text, base, "the quick config changed: update this function");
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

/// A trainer of `kind` and `method` on TeamReach; actors observe their ring neighbours.
pub fn team_reach_trainer_with(
    kind: AlgorithmKind,
    method: Method,
    seed: u64,
    epochs: usize,
) -> Trainer<TeamReach, AnyLearner> {
    team_reach_trainer_config(kind, method, trainer_config(method, seed, epochs))
}

/// A trainer of `kind` and `method` on `config.num_envs()` TeamReach envs.
pub fn team_reach_trainer_config(
    kind: AlgorithmKind,
    method: Method,
    config: TrainerConfig,
) -> Trainer<TeamReach, AnyLearner> {
    let env = team_reach(method);
    let parts = parts(&env, method, config.seed, config.gamma_for(env.spec().episode_len));
    let layout = parts.layout.clone();
    let learner = match kind {
        AlgorithmKind::Maddpg => AnyLearner::Maddpg(Maddpg::new(parts, MaddpgConfig::new()).unwrap()),
        AlgorithmKind::Matd3 => AnyLearner::Matd3(Matd3::new(parts, Matd3Config::new()).unwrap()),
        AlgorithmKind::Masac => AnyLearner::Masac(Masac::new(parts, MasacConfig::new()).unwrap()),
    };
    let envs = (0..config.num_envs()).map(|_| team_reach(method)).collect();
    Trainer::with_envs(config, envs, learner, layout).unwrap()
}

/// A MADDPG trainer of `method` on TeamReach.
pub fn team_reach_trainer(method: Method, seed: u64, epochs: usize) -> Trainer<TeamReach, AnyLearner> {
    team_reach_trainer_with(AlgorithmKind::Maddpg, method, seed, epochs)
}

/// An epoch's statistics without the wall-clock timings, which differ between runs.
pub fn learning_stats(s: &EpochStats) -> EpochStats {
    EpochStats { env_steps_per_sec: 0.0, updates_per_sec: 0.0, seconds: 0.0, ..s.clone() }
}
