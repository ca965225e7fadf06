//! Guards the worker seam: every gradient goes through
//! `Communicator::all_reduce_mean` before the optimiser step (as HER's MPI
//! Adam), so a communicator that zeroes them freezes the networks, and every
//! parameter's gradient and every normaliser update is reduced.

use crate::common;

use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

use fmsr_core::agent::Communicator;
use fmsr_nn::prelude::*;

/// Two workers; with `zero` the other one wipes everything out.
#[derive(Debug, Default)]
struct Fake {
    zero: bool,
    calls: Arc<AtomicUsize>,
}

impl Communicator for Fake {
    fn workers(&self) -> usize {
        2
    }

    fn rank(&self) -> usize {
        0
    }

    fn all_reduce_mean(&self, values: &mut [f32]) {
        self.calls.fetch_add(1, Ordering::Relaxed);
        for v in values {
            *v = if self.zero { 0.0 } else { *v / 2.0 };
        }
    }

    fn all_gather(&self, local: &[f32]) -> Vec<f32> {
        [local, local].concat()
    }

    fn gather_bytes(&self, local: Vec<u8>) -> Option<Vec<Vec<u8>>> {
        Some(vec![local.clone(), local])
    }
}

fn learner(comm: Fake) -> (fmsr_core::agent::ObservationLayout, Maddpg) {
    let layout = common::layout(&[2, 1, 1], 5, 2);
    let net = NetworkConfig::new().with_hidden(16).with_layers(2).with_seed(1);
    let parts = common::parts(&layout, net, 0.9).with_communicator(Box::new(comm));
    (layout, Maddpg::new(parts, MaddpgConfig::new()).unwrap())
}

#[test]
fn gradients_pass_through_the_communicator() {
    let (layout, mut l) = learner(Fake { zero: true, ..Fake::default() });
    let before: Vec<_> = (0..3).map(|i| l.params(i).unwrap()).collect();
    l.learn_batch(&common::batch(&layout, 8, 0), &common::bounds(&layout)).unwrap();
    for (i, b) in before.iter().enumerate() {
        assert_eq!(&l.params(i).unwrap(), b, "agent {i} moved although every gradient was zeroed");
    }
}

#[test]
fn every_gradient_is_reduced() {
    let calls = Arc::new(AtomicUsize::new(0));
    let (layout, mut l) = learner(Fake { zero: false, calls: calls.clone() });
    l.learn_batch(&common::batch(&layout, 8, 0), &common::bounds(&layout)).unwrap();
    // Per agent: critic 3 layers x (weight + bias) = 6, actor 6; normalisers: critic + 3 actors,
    // each reducing its sums, squares and count = 3 calls. 3 * 12 + 4 * 3 = 48.
    let n = calls.load(Ordering::Relaxed);
    assert_eq!(n, 3 * 12 + 4 * normaliser_calls());
}

/// Calls one normaliser update makes (measured on a fresh normaliser).
fn normaliser_calls() -> usize {
    let calls = Arc::new(AtomicUsize::new(0));
    let comm = Fake { zero: false, calls: calls.clone() };
    Normalizer::new(2, 0.01, 5.0).update(&[1.0, 2.0], &comm);
    calls.load(Ordering::Relaxed)
}

/// Guards the per-update sample count over workers:
/// `replay.batch_size` is the total over all workers, so it must split evenly.
#[test]
fn the_batch_is_split_over_the_workers() {
    let layout = common::layout(&[2, 1, 1], 5, 2);
    let net = NetworkConfig::new().with_hidden(16).with_layers(2).with_seed(1);
    let mut parts = common::parts(&layout, net, 0.9).with_communicator(Box::new(Fake::default()));
    parts.replay.batch_size = 3;
    let err = Maddpg::new(parts, MaddpgConfig::new()).unwrap_err();
    assert!(err.to_string().contains("replay.batch_size"), "{err}");
}
