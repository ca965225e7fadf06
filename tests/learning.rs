//! Guards that the whole method learns: each of the paper's four
//! configurations (MADDPG), and MATD3 and MASAC with Dense+FMSR+IS, trained on
//! the TeamReach test env within a small budget, reach a success rate well
//! above a random policy's; and shadow rewards make the agents visit their
//! feature (the safe region) more often than Dense alone.

use crate::common;

use common::{random_policy_success, team_reach_trainer, team_reach_trainer_with};
use fmsr::prelude::*;

const EPOCHS: usize = 12;

#[test]
fn every_configuration_learns_well_above_random() {
    for method in Method::ALL {
        let mut trainer = team_reach_trainer(method, 1, EPOCHS);
        trainer.train(|_, _| Ok(())).unwrap();
        let seeds: Vec<u64> = (0..100).map(|i| 10_000 + i).collect();
        let random = random_policy_success(&seeds);
        let learned = trainer.evaluate(&seeds, Some(0.1)).unwrap().success_rate;
        let curve: Vec<f64> = trainer.history().iter().map(|s| s.success_rate).collect();
        eprintln!("{}: success {learned:.2} (random {random:.2}), curve {curve:?}", method.label());
        assert!(learned >= random + 0.4, "{} reached {learned}, random policy {random}", method.label());
    }
}

#[test]
fn shadow_reward_raises_the_occupancy_of_its_feature() {
    let rate = |method| {
        let mut trainer = team_reach_trainer(method, 2, EPOCHS);
        trainer.train(|_, _| Ok(())).unwrap();
        let seeds: Vec<u64> = (0..100).map(|i| 20_000 + i).collect();
        trainer.evaluate(&seeds, None).unwrap().feature_rates[0]
    };
    let (fmsr, dense) = (rate(Method::DenseFmsr), rate(Method::Dense));
    eprintln!("safe_region rate: Dense+FMSR {fmsr:.3}, Dense {dense:.3}");
    assert!(fmsr > dense + 0.1, "Dense+FMSR {fmsr} vs Dense {dense}");
}

#[test]
fn matd3_and_masac_learn_well_above_random() {
    for kind in ["matd3", "masac"] {
        let mut trainer = team_reach_trainer_with(kind, Method::DenseFmsrIs, 1, EPOCHS);
        trainer.train(|_, _| Ok(())).unwrap();
        let seeds: Vec<u64> = (0..100).map(|i| 10_000 + i).collect();
        let random = random_policy_success(&seeds);
        let learned = trainer.evaluate(&seeds, Some(0.1)).unwrap().success_rate;
        let curve: Vec<f64> = trainer.history().iter().map(|s| s.success_rate).collect();
        eprintln!("{kind:?}: success {learned:.2} (random {random:.2}), curve {curve:?}");
        assert!(learned >= random + 0.4, "{kind:?} reached {learned}, random policy {random}");
    }
}
