//! Guards information sharing (paper eq. 8, DESIGN.md 3.7): with learning
//! rates 0, repeated `learn` calls with parameter sharing drive the agents'
//! trunks to their initial average (disagreement -> ~0, average preserved),
//! for actors and, with target Critics/Both, critics; without sharing they stay
//! apart; gradient sharing with equal trunks keeps them equal.

mod common;

use fmsr_core::Agent;
use fmsr_core::agent::{ShareMode, ShareTarget, Sharing};
use fmsr_graph::{Graph, MetropolisHastings, average, disagreement};
use fmsr_nn::prelude::*;

const N: usize = 6;

fn frozen() -> DdpgConfig {
    DdpgConfig::new().with_hidden(16).with_lr_actor(0.0).with_lr_critic(0.0).with_seed(8)
}

fn sharing(mode: ShareMode, target: ShareTarget) -> Option<Sharing> {
    Some(Sharing { mixing: MetropolisHastings::matrix(&Graph::ring(N)), mode, target })
}

fn actor_trunks(l: &DdpgLearner) -> Vec<Vec<f32>> {
    (0..N).map(|i| l.consensus_params(i).unwrap()).collect()
}

fn critic_trunks(l: &DdpgLearner) -> Vec<Vec<f32>> {
    (0..N).map(|i| l.critic_trunk(i).unwrap()).collect()
}

fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max)
}

#[test]
fn parameter_sharing_reaches_the_average() {
    let layout = common::layout(&[2, 3, 3, 3, 4, 5], 12, 3);
    let mut l = DdpgLearner::new(layout.clone(), frozen(), sharing(ShareMode::Parameters, ShareTarget::Both)).unwrap();
    let (a0, c0) = (actor_trunks(&l), critic_trunks(&l));
    let (avg_a, avg_c) = (average(&a0).unwrap(), average(&c0).unwrap());
    let (d_a, d_c) = (disagreement(&a0).unwrap(), disagreement(&c0).unwrap());
    assert!(d_a > 1.0 && d_c > 1.0);
    let b = common::batch(&layout, 8, 0);
    for _ in 0..60 {
        l.learn(&b).unwrap();
    }
    let (a1, c1) = (actor_trunks(&l), critic_trunks(&l));
    assert!(disagreement(&a1).unwrap() < 1e-6 * d_a, "actor disagreement {}", disagreement(&a1).unwrap());
    assert!(disagreement(&c1).unwrap() < 1e-6 * d_c, "critic disagreement {}", disagreement(&c1).unwrap());
    assert!(max_diff(&average(&a1).unwrap(), &avg_a) < 1e-5);
    assert!(max_diff(&average(&c1).unwrap(), &avg_c) < 1e-5);
    // Every agent holds the average.
    for t in &a1 {
        assert!(t.iter().zip(&avg_a).all(|(x, m)| (f64::from(*x) - m).abs() < 1e-4));
    }
}

#[test]
fn actor_only_sharing_leaves_critics_apart() {
    let layout = common::layout(&[1; N], 5, 2);
    let mut l =
        DdpgLearner::new(layout.clone(), frozen(), sharing(ShareMode::Parameters, ShareTarget::Actors)).unwrap();
    let c0 = critic_trunks(&l);
    let d_a = disagreement(&actor_trunks(&l)).unwrap();
    let b = common::batch(&layout, 8, 0);
    for _ in 0..40 {
        l.learn(&b).unwrap();
    }
    assert!(disagreement(&actor_trunks(&l)).unwrap() < 1e-4 * d_a);
    assert_eq!(critic_trunks(&l), c0);
}

#[test]
fn without_sharing_trunks_stay_apart() {
    let layout = common::layout(&[2, 3, 3, 3, 4, 5], 12, 3);
    let mut l = DdpgLearner::new(layout.clone(), frozen(), None).unwrap();
    let a0 = actor_trunks(&l);
    let b = common::batch(&layout, 8, 0);
    for _ in 0..20 {
        l.learn(&b).unwrap();
    }
    // lr = 0: nothing moves at all.
    assert_eq!(actor_trunks(&l), a0);
    assert!(disagreement(&a0).unwrap() > 1.0);
}

#[test]
fn gradient_sharing_keeps_equal_trunks_equal() {
    let layout = common::layout(&[2, 3, 3, 3, 4, 5], 12, 3);
    let config = DdpgConfig::new().with_hidden(16).with_seed(2);
    let complete = fmsr_graph::MixingMatrix::from_rows(vec![vec![1.0 / N as f64; N]; N]).unwrap();
    let share = Some(Sharing { mixing: complete, mode: ShareMode::Gradients, target: ShareTarget::Actors });
    let mut l = DdpgLearner::new(layout.clone(), config.clone(), share).unwrap();
    let mut plain = DdpgLearner::new(layout.clone(), config, None).unwrap();
    let t0 = l.consensus_params(0).unwrap();
    for i in 1..N {
        l.set_consensus_params(i, &t0).unwrap();
        plain.set_consensus_params(i, &t0).unwrap();
    }
    for step in 0..3 {
        let b = common::batch(&layout, 16, step);
        l.learn(&b).unwrap();
        plain.learn(&b).unwrap();
    }
    let shared = actor_trunks(&l);
    let max_gap = shared.iter().flat_map(|t| t.iter().zip(&shared[0]).map(|(a, b)| (a - b).abs())).fold(0.0, f32::max);
    assert!(max_gap < 1e-5, "trunks drifted apart by {max_gap}");
    // Without sharing, the different gradients pull the equal trunks apart.
    assert!(disagreement(&actor_trunks(&plain)).unwrap() > 1e-6);
}
