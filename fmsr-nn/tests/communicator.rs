//! Guards the worker seam: every flattened gradient goes through
//! `Communicator::all_reduce_mean` before the optimiser step (as HER's MPI
//! Adam), so a communicator that averages in zeros from a silent worker
//! halves every Adam input, and one that zeroes them freezes the networks.

mod common;

use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

use fmsr_core::Agent;
use fmsr_core::agent::Communicator;
use fmsr_nn::prelude::*;

/// Two workers, the other one contributing zeros (or, with `zero`, everything zeroed).
#[derive(Debug, Default)]
struct Fake {
    zero: bool,
    calls: Arc<AtomicUsize>,
}

impl Communicator for Fake {
    fn workers(&self) -> usize {
        2
    }
    fn all_reduce_mean(&self, values: &mut [f32]) {
        self.calls.fetch_add(1, Ordering::Relaxed);
        for v in values {
            *v = if self.zero { 0.0 } else { *v / 2.0 };
        }
    }
}

#[test]
fn gradients_pass_through_the_communicator() {
    let layout = common::layout(&[2, 1, 1], 5, 2);
    let config = DdpgConfig::new().with_hidden(16).with_seed(1);
    let frozen = Box::new(Fake { zero: true, ..Fake::default() });
    let mut l = DdpgLearner::with_parts(layout.clone(), config, None, frozen, burn::tensor::Device::flex()).unwrap();
    let before: Vec<Vec<f32>> = (0..3).map(|i| l.actor_params(i).unwrap().to_vec()).collect();
    let before_c: Vec<Vec<f32>> = (0..3).map(|i| l.critic_params(i).unwrap().to_vec()).collect();
    l.learn(&common::batch(&layout, 8, 0)).unwrap();
    for i in 0..3 {
        assert_eq!(l.actor_params(i).unwrap(), before[i]);
        assert_eq!(l.critic_params(i).unwrap(), before_c[i]);
    }
}

#[test]
fn every_gradient_is_reduced() {
    let layout = common::layout(&[2, 1, 1], 5, 2);
    let config = DdpgConfig::new().with_hidden(16).with_seed(1);
    let calls = Arc::new(AtomicUsize::new(0));
    let comm = Box::new(Fake { zero: false, calls: calls.clone() });
    let mut l = DdpgLearner::with_parts(layout.clone(), config, None, comm, burn::tensor::Device::flex()).unwrap();
    l.learn(&common::batch(&layout, 8, 0)).unwrap();
    // 3 critic + 3 actor gradients + 4 normaliser updates (critic + 3 actors) = 10 calls.
    assert_eq!(calls.load(Ordering::Relaxed), 10);
}
