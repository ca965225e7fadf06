//! Guards reproducibility: two learners built from the same config and seed
//! produce bit-identical actions, losses and parameters over several updates,
//! whatever the number of threads the agents' updates are split over; another
//! seed gives other networks.

mod common;

use fmsr_core::Agent;
use fmsr_core::agent::{ShareMode, ShareTarget, Sharing};
use fmsr_graph::{Graph, MetropolisHastings};
use fmsr_nn::prelude::*;

/// Bit patterns of (actions, losses, final parameters).
type Trace = (Vec<Vec<u32>>, Vec<Vec<u32>>, Vec<Vec<u32>>);

fn run(config: DdpgConfig, sharing: Option<Sharing>) -> Trace {
    let layout = common::layout(&[2, 3, 3, 1], 9, 3);
    let mut l = DdpgLearner::new(layout.clone(), config, sharing).unwrap();
    let mut actions = Vec::new();
    let mut losses = Vec::new();
    for step in 0..4 {
        let stats = l.learn(&common::batch(&layout, 16, step)).unwrap();
        losses.push(common::bits(&stats.critic_loss));
        losses.push(common::bits(&stats.actor_loss));
        l.update_targets().unwrap();
        for a in l.act(&common::inputs(&layout, 3, 100 + step), 3).unwrap() {
            actions.push(common::bits(&a));
        }
    }
    let params = (0..4)
        .flat_map(|i| [common::bits(l.actor_params(i).unwrap()), common::bits(l.critic_params(i).unwrap())])
        .collect();
    (actions, losses, params)
}

fn ring() -> Option<Sharing> {
    Some(Sharing {
        mixing: MetropolisHastings::matrix(&Graph::ring(4)),
        mode: ShareMode::Parameters,
        target: ShareTarget::Both,
    })
}

#[test]
fn same_seed_same_results() {
    let config = DdpgConfig::new().with_hidden(32).with_seed(11);
    assert_eq!(run(config.clone(), None), run(config.clone(), None));
    assert_eq!(run(config.clone(), ring()), run(config, ring()));
}

#[test]
fn thread_count_does_not_change_results() {
    let config = DdpgConfig::new().with_hidden(32).with_seed(5);
    let one = run(config.clone().with_threads(1), ring());
    assert_eq!(one, run(config.clone().with_threads(2), ring()));
    assert_eq!(one, run(config.with_threads(3), ring()));
}

#[test]
fn other_seed_other_networks() {
    let a = run(DdpgConfig::new().with_hidden(32).with_seed(1), None);
    let b = run(DdpgConfig::new().with_hidden(32).with_seed(2), None);
    assert_ne!(a.2, b.2);
}

#[test]
fn thread_count_does_not_change_results_at_paper_sizes() {
    // Batch 256 x 3 x 256 hidden: large enough for burn's matmuls to go multi-threaded
    // (on rayon's global pool with 1 worker thread, single-threaded inside each worker otherwise).
    let layout = common::layout(&[2, 3, 3, 3, 4, 5], 153, 7);
    let config = DdpgConfig::new().with_seed(3);
    let trace = |threads: usize| {
        let mut l = DdpgLearner::new(layout.clone(), config.clone().with_threads(threads), None).unwrap();
        let mut out = Vec::new();
        for step in 0..2 {
            let stats = l.learn(&common::batch(&layout, 256, step)).unwrap();
            out.push(common::bits(&stats.critic_loss));
            out.push(common::bits(&stats.actor_loss));
        }
        out.extend((0..6).map(|i| common::bits(l.actor_params(i).unwrap())));
        out
    };
    assert_eq!(trace(1), trace(2));
}
