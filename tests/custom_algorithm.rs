//! Guards that a user's algorithm written as one update rule in one file
//! (`examples/custom_algorithm.rs`, independent DDPG) gets everything else
//! from the crate: it learns TeamReach with information sharing on, resumes
//! exactly (Adam's moments included), exports its policy, refuses a state of
//! another algorithm, and trains a Shadow Hand epoch of an experiment config;
//! registered by name, fmsr's own command trains, resumes, exports and
//! evaluates it from a config that says `algorithm = "iddpg"`.

use crate::common;
#[path = "../examples/custom_algorithm.rs"]
#[allow(dead_code)]
mod example;

use example::{Iddpg, IddpgConfig, IddpgRule};
use fmsr::experiment::ExperimentConfig;
use fmsr::prelude::*;
use fmsr_core::testing::L1Rewards;

/// The success IDDPG must reach on 100 held-out TeamReach episodes after 12
/// epochs with sharing on (a random policy: about 0.00).
const SUCCESS: f64 = 0.8;

#[test]
fn iddpg_as_a_rule_learns_team_reach_and_resumes_exactly() {
    let seeds: Vec<u64> = (0..100).map(|i| 10_000 + i).collect();
    let random = common::random_policy_success(&seeds);
    let (mut trainer, learned) = example::train_team_reach(1, 12).unwrap();
    eprintln!("IDDPG: success {learned:.2} (random {random:.2})");
    assert!(learned >= SUCCESS && learned >= random + 0.4, "IDDPG reached {learned}, random policy {random}");

    // The whole state, replay and optimiser moments included, continues as the learner itself would.
    let state = trainer.algorithm().save_state(true).unwrap();
    let env = TeamReachConfig::default().init().unwrap();
    let fresh = || {
        let parts = example::team_reach_parts(&env, 2, 0.95).unwrap();
        Iddpg::with_rule(parts, IddpgRule::default()).unwrap()
    };
    let mut copy = fresh();
    copy.load_state(&state).unwrap();
    let original = trainer.algorithm_mut();
    let a = original.update(&L1Rewards::new(3)).unwrap();
    let b = copy.update(&L1Rewards::new(3)).unwrap();
    assert_eq!(a.critic_loss, b.critic_loss, "a restored IDDPG steps as the original");
    assert_eq!(a.actor_loss, b.actor_loss);
    assert_eq!(original.params(1).unwrap(), copy.params(1).unwrap());

    // Its policy state is the crate's: a fresh learner of the rule acts the same after loading it.
    let mut other = fresh();
    other.load_policy(&original.save_policy().unwrap()).unwrap();
    let inputs: Vec<Vec<f32>> = (0..3).map(|i| vec![0.3; trainer.layout().actor_input_dim(i)]).collect();
    let act = |l: &mut Iddpg| l.act(&inputs, 1, ActMode::Evaluate).unwrap().actions;
    let acted = act(trainer.algorithm_mut());
    assert_eq!(acted, act(&mut other));
}

#[test]
fn iddpg_critics_see_their_own_agent_and_refuse_maddpg_states() {
    let env = TeamReachConfig::default().init().unwrap();
    let layout = ObservationLayout::from_graph(env.spec().clone(), &Graph::ring(3)).unwrap();
    let parts = || LearnerParts::new(layout.clone(), NetworkConfig::new().with_hidden(16), common::replay(), 0.95);
    let iddpg = Iddpg::with_rule(parts(), IddpgRule::default()).unwrap();
    let maddpg = Maddpg::new(parts(), MaddpgConfig::new()).unwrap();
    for i in 0..3 {
        // First layer: (input + 1) x hidden, the input being o_i and a_i alone.
        let own = layout.actor_input_dim(i) + env.spec().agents[i].action_dim();
        assert_eq!(
            iddpg.params(i).unwrap().1.len(),
            maddpg.params(i).unwrap().1.len() - 16 * (layout.critic_input_dim() - own)
        );
    }
    let mut iddpg = iddpg;
    let err = iddpg.load_state(&maddpg.save_state(false).unwrap()).unwrap_err();
    assert!(matches!(err, NnError::StateMismatch { .. }), "{err}");
    let bad = IddpgRule { config: IddpgConfig { polyak: 1.5, ..IddpgConfig::default() } };
    let err = Iddpg::with_rule(parts(), bad).unwrap_err();
    assert!(matches!(err, NnError::InvalidConfig { key: "iddpg.polyak", .. }), "{err}");
}

#[test]
fn iddpg_trains_a_shadow_hand_epoch_of_an_experiment_with_sharing() {
    let config = ExperimentConfig::from_toml(&common::tiny_config_text(), "tiny.toml".as_ref()).unwrap();
    assert!(config.sharing_config().enabled, "the tiny config shares information");
    let env = config.env_config().init().unwrap();
    let mut trainer = example::on_experiment(&config, vec![env]).unwrap();
    let before = trainer.algorithm().actor_trunk(0).unwrap();
    let stats = trainer.run_epoch().unwrap();
    assert!(stats.updates > 0, "the epoch updated the networks");
    assert_ne!(trainer.algorithm().actor_trunk(0).unwrap(), before);
}

// Guards the registry's promise to a user's crate: one call registers the
// rule, and then fmsr's own command, configs and run directories train,
// resume, export and evaluate it by name, with its section written out in
// the run's config.toml.
#[test]
fn iddpg_registered_by_name_runs_through_the_fmsr_command() {
    fmsr::algorithms::register::<IddpgRule>().unwrap();
    // A second registration of the same rule is harmless (tests share the process).
    fmsr::algorithms::register::<IddpgRule>().unwrap();
    assert!(fmsr::algorithms::names().contains(&"iddpg"));
    let tmp = tempfile::tempdir().unwrap();
    let text = common::tiny_config_text()
        .replace("method = \"dense_fmsr_is\"\n", "method = \"dense_fmsr_is\"\nalgorithm = \"iddpg\"\n")
        + "\n[iddpg]\npolyak = 0.9\n";
    let config_path = tmp.path().join("iddpg.toml");
    std::fs::write(&config_path, &text).unwrap();
    let config = ExperimentConfig::load(&config_path).unwrap();
    assert_eq!(config.label(), "Dense+FMSR+IS, IDDPG");
    assert_eq!(config.algorithm_config::<IddpgRule>().unwrap(), IddpgConfig { polyak: 0.9, ..IddpgConfig::default() });

    let (run, config_arg) = (tmp.path().join("run"), config_path.to_str().unwrap());
    let run_arg = run.to_str().unwrap();
    fmsr::cli::run(["fmsr", "train", "--config", config_arg, "--out", run_arg, "--quiet"]).unwrap();
    let written: toml::Table = std::fs::read_to_string(run.join("config.toml")).unwrap().parse().unwrap();
    assert_eq!(written["algorithm"].as_str(), Some("iddpg"));
    let section = written["iddpg"].as_table().expect("an [iddpg] section");
    assert_eq!(section.len(), 4, "every setting written out: {section:?}");
    assert_eq!(section["polyak"].as_float(), Some(0.9));

    fmsr::cli::run(["fmsr", "train", "--out", run_arg, "--resume", "--epochs", "2", "--quiet"]).unwrap();
    let epochs = std::fs::read_to_string(run.join("metrics.csv")).unwrap().lines().count() - 1;
    assert_eq!(epochs, 2, "resumed for a second epoch");
    let policy = tmp.path().join("iddpg.fmsr");
    fmsr::cli::run(["fmsr", "export", run_arg, "--out", policy.to_str().unwrap()]).unwrap();
    fmsr::cli::run(["fmsr", "eval", policy.to_str().unwrap()]).unwrap();
    fmsr::cli::run(["fmsr", "eval", run_arg]).unwrap();
    assert!(run.join("eval.json").exists());

    // A section of another algorithm is refused, naming it.
    let bad = text.replace("[iddpg]\npolyak = 0.9\n", "[matd3]\npolicy_delay = 2\n");
    let err = ExperimentConfig::from_toml(&bad, "bad.toml".as_ref()).unwrap_err();
    assert!(err.to_string().contains("matd3"), "{err}");
    let bad = text.replace("polyak = 0.9", "polyak = 1.5");
    let err = ExperimentConfig::from_toml(&bad, "bad.toml".as_ref()).unwrap_err();
    assert!(err.to_string().contains("iddpg.polyak"), "{err}");
}
