//! Guards that learner states of format 4 still load (issue 39: checkpoints
//! written before the redesign, the long runs' among them, must keep
//! loading). `tests/data/state_v4/` holds one state of each algorithm, saved
//! by the build of commit c854538 (format 4, where a rule's own state was a
//! list of values), with what that learner did next: its greedy actions, the
//! losses of its next update and its exploring actions after it (and MASAC's
//! temperatures). A learner of another seed that loads the file must do the
//! same, within 1e-5 (another CPU's kernels may round differently; on the
//! recording's CPU it is bit for bit).
//!
//! To record anew (only from a build that writes format 4):
//! `FMSR_STATE_V4=record cargo test --workspace --test nn_integration -- state_v4::`. To record
//! only what the saved learners do next, after a change meant to change it,
//! run `FMSR_STATE_V4=expect` on a format-4 build with that change made: the
//! exploring actions and MATD3's and MASAC's updates were recorded so when
//! the normals moved to rand_distr, from c854538 with fmsr-nn's `gaussian`
//! drawing from `rand_distr::StandardNormal` (the same command on c854538
//! itself gave the earlier files bit for bit).

use crate::common;
use fmsr_core::testing::L1Rewards;

use common::AlgorithmKind;

use std::path::PathBuf;

use fmsr_nn::prelude::*;
use serde::{Deserialize, Serialize};

/// What a learner did after its state was saved.
#[derive(Debug, PartialEq, Serialize, Deserialize)]
struct Next {
    greedy: Vec<Vec<f32>>,
    critic_loss: Vec<f64>,
    actor_loss: Vec<f64>,
    exploring: Vec<Vec<f32>>,
    temperatures: Vec<f64>,
}

impl Next {
    /// Every value, in order.
    fn values(&self) -> Vec<f64> {
        let actions = |a: &Vec<Vec<f32>>| a.iter().flatten().map(|&v| f64::from(v)).collect::<Vec<f64>>();
        [
            actions(&self.greedy),
            self.critic_loss.clone(),
            self.actor_loss.clone(),
            actions(&self.exploring),
            self.temperatures.clone(),
        ]
        .concat()
    }
}

fn dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/state_v4")
}

fn net(seed: u64) -> NetworkConfig {
    NetworkConfig::new().with_hidden(16).with_layers(2).with_seed(seed)
}

/// What `l` does next: greedy actions, one update, exploring actions.
fn next(l: &mut AnyLearner, layout: &fmsr_core::agent::ObservationLayout) -> Next {
    let x = common::inputs(layout, 3, 11);
    let greedy = l.act(&x, 3, ActMode::Evaluate).unwrap().actions;
    let stats = l.update(&L1Rewards::new(3)).unwrap();
    let exploring = l.act(&x, 3, ActMode::Explore).unwrap().actions;
    let temperatures = l.downcast_ref::<Masac>().map(Masac::temperatures).unwrap_or_default();
    Next { greedy, critic_loss: stats.critic_loss, actor_loss: stats.actor_loss, exploring, temperatures }
}

#[test]
fn states_of_format_4_load_and_continue_as_saved() {
    let layout = common::layout(&[2, 3, 1], 7, 3);
    let mode = std::env::var("FMSR_STATE_V4").unwrap_or_default();
    let record = mode == "record";
    for kind in AlgorithmKind::ALL {
        let (state, expected) = (dir().join(format!("{}.bin", kind.key())), dir().join(format!("{}.json", kind.key())));
        if record {
            let mut l = common::learner(kind, &layout, net(21));
            for e in 0..3 {
                l.store(&common::episode(&layout, e)).unwrap();
                l.update(&L1Rewards::new(3)).unwrap();
            }
            std::fs::create_dir_all(dir()).unwrap();
            std::fs::write(&state, l.save_state(true).unwrap()).unwrap();
            std::fs::write(&expected, serde_json::to_string(&next(&mut l, &layout)).unwrap() + "\n").unwrap();
            continue;
        }
        let mut l = common::learner(kind, &layout, net(99));
        l.load_state(&std::fs::read(&state).unwrap()).unwrap();
        let now = next(&mut l, &layout);
        if mode == "expect" {
            std::fs::write(&expected, serde_json::to_string(&now).unwrap() + "\n").unwrap();
            continue;
        }
        let then: Next = serde_json::from_slice(&std::fs::read(&expected).unwrap()).unwrap();
        let (a, b) = (now.values(), then.values());
        assert_eq!(a.len(), b.len(), "{kind:?}: shapes differ");
        for (k, (x, y)) in a.iter().zip(&b).enumerate() {
            assert!((x - y).abs() <= 1e-5 * (1.0 + y.abs()), "{kind:?}: value {k} is {x}, saved learner's {y}");
        }
    }
}
