//! Guards that a user's algorithm written in one file against the public
//! traits alone (`examples/custom_algorithm.rs`, independent DDPG) trains
//! through the crate's trainer, and that its saved state restores its policy.

mod common;
#[path = "../examples/custom_algorithm.rs"]
#[allow(dead_code)]
mod custom_algorithm;

use custom_algorithm::{Iddpg, IddpgConfig};
use fmsr::prelude::*;

/// The success IDDPG must reach on 100 held-out TeamReach episodes after 12
/// epochs (it reaches 0.99 at seed 1; a random policy 0.00).
const SUCCESS: f64 = 0.8;

#[test]
fn iddpg_from_the_public_traits_learns_team_reach() {
    let seeds: Vec<u64> = (0..100).map(|i| 10_000 + i).collect();
    let random = common::random_policy_success(&seeds);
    let learned = custom_algorithm::train_team_reach(1, 12).unwrap();
    eprintln!("IDDPG: success {learned:.2} (random {random:.2})");
    assert!(learned >= SUCCESS && learned >= random + 0.4, "IDDPG reached {learned}, random policy {random}");
}

fn iddpg(seed: u64) -> (Iddpg, ObservationLayout) {
    let env = TeamReachConfig::default().init().unwrap();
    let layout = ObservationLayout::from_graph(env.spec().clone(), &Graph::ring(3)).unwrap();
    (Iddpg::new(layout.clone(), 0.95, IddpgConfig { seed, ..IddpgConfig::default() }).unwrap(), layout)
}

#[test]
fn iddpg_state_restores_its_policy_and_refuses_garbage() {
    let (mut a, layout) = iddpg(3);
    let (mut b, _) = iddpg(4);
    let inputs: Vec<Vec<f32>> =
        (0..3).map(|i| (0..2 * layout.actor_input_dim(i)).map(|k| (k as f32 * 0.37).sin()).collect()).collect();
    let act = |p: &mut Iddpg| p.act(&inputs, 2, ActMode::Evaluate).unwrap().actions;
    assert_ne!(act(&mut a), act(&mut b), "two seeds start from different networks");
    b.load_state(&a.save_state(false).unwrap()).unwrap();
    assert_eq!(act(&mut a), act(&mut b));
    assert!(b.load_state(b"not a state").is_err());
}
