//! Guards information sharing (paper eq. 8) as every learner applies it
//! through `fmsr_core::sharing::InformationSharing`: trunks that are mixed
//! start identical; with learning rates 0, parameter sharing drives different
//! trunks to their average (disagreement -> ~0, average preserved); without
//! sharing nothing moves; gradient sharing keeps equal trunks equal while
//! plain learning pulls them apart; critics are mixed only when targeted.

use crate::common;

use fmsr_core::sharing::{ShareMode, ShareTarget, Sharing};
use fmsr_graph::{Graph, MetropolisHastings, average, disagreement};
use fmsr_nn::prelude::*;

const N: usize = 6;

fn frozen() -> NetworkConfig {
    NetworkConfig::new().with_hidden(16).with_lr_actor(0.0).with_lr_critic(0.0).with_seed(8)
}

fn sharing(mode: ShareMode, target: ShareTarget) -> Option<Sharing> {
    Some(Sharing { mixing: MetropolisHastings::matrix(&Graph::ring(N)), mode, target })
}

fn learner(net: NetworkConfig, sharing: Option<Sharing>) -> (fmsr_core::agent::ObservationLayout, Maddpg) {
    let layout = common::layout(&[2, 3, 3, 3, 4, 5], 12, 3);
    let parts = common::parts(&layout, net, 0.9).with_sharing(sharing);
    (layout, Maddpg::new(parts, MaddpgConfig::new()).unwrap())
}

fn trunks(l: &Maddpg) -> Vec<Vec<f32>> {
    (0..N).map(|i| l.actor_trunk(i).unwrap()).collect()
}

fn critic_trunks(l: &Maddpg) -> Vec<Vec<f32>> {
    (0..N).map(|i| l.critic_trunk(i).unwrap()).collect()
}

/// Gives every agent a different trunk (agent 0's scaled by `1 + i`).
fn spread(l: &mut Maddpg) {
    let t0 = l.actor_trunk(0).unwrap();
    for i in 1..N {
        let t: Vec<f32> = t0.iter().map(|v| v * (1.0 + i as f32)).collect();
        l.set_actor_trunk(i, &t).unwrap();
    }
}

#[test]
fn mixed_trunks_start_identical() {
    let (_, shared) = learner(frozen(), sharing(ShareMode::Parameters, ShareTarget::Both));
    assert!(disagreement(&trunks(&shared)).unwrap() == 0.0);
    assert!(disagreement(&critic_trunks(&shared)).unwrap() == 0.0);
    let (_, plain) = learner(frozen(), None);
    assert!(disagreement(&trunks(&plain)).unwrap() > 1.0);
    let (_, actors_only) = learner(frozen(), sharing(ShareMode::Gradients, ShareTarget::Actors));
    assert!(disagreement(&trunks(&actors_only)).unwrap() == 0.0);
    assert!(disagreement(&critic_trunks(&actors_only)).unwrap() > 1.0);
}

#[test]
fn parameter_sharing_reaches_the_average() {
    let (layout, mut l) = learner(frozen(), sharing(ShareMode::Parameters, ShareTarget::Actors));
    spread(&mut l);
    let a0 = trunks(&l);
    let (avg, d0) = (average(&a0).unwrap(), disagreement(&a0).unwrap());
    let c0 = critic_trunks(&l);
    let b = common::batch(&layout, 8, 0);
    for _ in 0..60 {
        l.learn_batch(&b, &common::bounds(&layout)).unwrap();
    }
    let a1 = trunks(&l);
    assert!(disagreement(&a1).unwrap() < 1e-6 * d0, "disagreement {}", disagreement(&a1).unwrap());
    for t in &a1 {
        assert!(t.iter().zip(&avg).all(|(x, m)| (f64::from(*x) - m).abs() < 1e-4));
    }
    assert_eq!(critic_trunks(&l), c0, "critics are not targeted");
}

#[test]
fn without_sharing_nothing_moves_at_lr_zero() {
    let (layout, mut l) = learner(frozen(), None);
    let a0 = trunks(&l);
    let b = common::batch(&layout, 8, 0);
    for _ in 0..10 {
        l.learn_batch(&b, &common::bounds(&layout)).unwrap();
    }
    assert_eq!(trunks(&l), a0);
}

#[test]
fn gradient_sharing_keeps_equal_trunks_equal() {
    let net = NetworkConfig::new().with_hidden(16).with_seed(2);
    let complete = fmsr_graph::MixingMatrix::from_rows(vec![vec![1.0 / N as f64; N]; N]).unwrap();
    let share = Some(Sharing { mixing: complete, mode: ShareMode::Gradients, target: ShareTarget::Actors });
    let (layout, mut l) = learner(net.clone(), share);
    let (_, mut plain) = learner(net, None);
    let t0 = l.actor_trunk(0).unwrap();
    for i in 1..N {
        plain.set_actor_trunk(i, &t0).unwrap();
    }
    for step in 0..3 {
        let b = common::batch(&layout, 16, step);
        l.learn_batch(&b, &common::bounds(&layout)).unwrap();
        plain.learn_batch(&b, &common::bounds(&layout)).unwrap();
    }
    let shared = trunks(&l);
    let gap = shared.iter().flat_map(|t| t.iter().zip(&shared[0]).map(|(a, b)| (a - b).abs())).fold(0.0, f32::max);
    assert!(gap < 1e-5, "trunks drifted apart by {gap}");
    assert!(disagreement(&trunks(&plain)).unwrap() > 1e-6);
}
