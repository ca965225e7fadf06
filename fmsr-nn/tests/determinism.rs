//! Guards reproducibility: two learners built from the same config and seed
//! produce bit-identical actions, losses and parameters over several updates,
//! whatever the number of threads the agents' updates are split over; another
//! seed gives other networks.

use crate::common;

use fmsr_core::sharing::{ShareMode, ShareTarget, Sharing};
use fmsr_graph::{Graph, MetropolisHastings};
use fmsr_nn::prelude::*;

/// Bit patterns of (actions, losses, final parameters).
type Trace = (Vec<Vec<u32>>, Vec<Vec<u32>>, Vec<Vec<u32>>);

fn run(net: NetworkConfig, sharing: Option<Sharing>) -> Trace {
    let layout = common::layout(&[2, 3, 3, 1], 9, 3);
    let parts = common::parts(&layout, net, 0.9).with_sharing(sharing);
    let mut l = Maddpg::new(parts, MaddpgConfig::new()).unwrap();
    let (mut actions, mut losses) = (Vec::new(), Vec::new());
    for step in 0..4 {
        let (c, a) = l.learn_batch(&common::batch(&layout, 16, step), &common::bounds(&layout)).unwrap();
        losses.push(common::bits(&c));
        losses.push(common::bits(&a));
        l.update_targets();
        for a in l.act(&common::inputs(&layout, 3, 100 + step), 3, ActMode::Explore).unwrap().actions {
            actions.push(common::bits(&a));
        }
    }
    let params = (0..4)
        .flat_map(|i| {
            let (a, c) = l.params(i).unwrap();
            [common::bits(&a), common::bits(&c)]
        })
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
    let net = NetworkConfig::new().with_hidden(32).with_seed(11);
    assert_eq!(run(net.clone(), None), run(net.clone(), None));
    assert_eq!(run(net.clone(), ring()), run(net, ring()));
}

#[test]
fn thread_count_does_not_change_results() {
    let net = NetworkConfig::new().with_hidden(32).with_seed(5);
    let one = run(net.clone().with_threads(1), ring());
    assert_eq!(one, run(net.clone().with_threads(2), ring()));
    assert_eq!(one, run(net.with_threads(3), ring()));
}

#[test]
fn other_seed_other_networks() {
    let a = run(NetworkConfig::new().with_hidden(32).with_seed(1), None);
    let b = run(NetworkConfig::new().with_hidden(32).with_seed(2), None);
    assert_ne!(a.2, b.2);
}

#[test]
fn thread_count_does_not_change_results_at_paper_sizes() {
    // Batch 256 x 3 x 256 hidden: large enough for burn's matmuls to go multi-threaded
    // (on rayon's global pool with 1 worker thread, single-threaded inside each worker otherwise).
    let layout = common::layout(&[2, 3, 3, 3, 4, 5], 153, 7);
    let trace = |threads: usize| {
        let net = NetworkConfig::new().with_seed(3).with_threads(threads);
        let mut l = Maddpg::new(common::parts(&layout, net, 0.98), MaddpgConfig::new()).unwrap();
        let mut out = Vec::new();
        for step in 0..2 {
            let (c, a) = l.learn_batch(&common::batch(&layout, 256, step), &common::bounds(&layout)).unwrap();
            out.push(common::bits(&c));
            out.push(common::bits(&a));
        }
        out.extend((0..6).map(|i| common::bits(&l.params(i).unwrap().0)));
        out
    };
    assert_eq!(trace(1), trace(2));
}
