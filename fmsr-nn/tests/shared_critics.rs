//! Guards `NetworkConfig::critic` (`CriticTying`), the critic ablation: with
//! `SharedTrunk` every agent's critic keeps one trunk through learning while
//! the heads stay their own; with `Shared` every agent reads one value; both
//! save and load (a loaded learner updates as the saved one), refuse states of
//! the other design, and every algorithm trains with them. The paper's design
//! (`PerAgent`) keeps a trunk per agent.

use crate::common;
use fmsr_core::testing::L1Rewards;

use common::AlgorithmKind;

use fmsr_core::sharing::{ShareMode, ShareTarget, Sharing};
use fmsr_graph::{Graph, MetropolisHastings};
use fmsr_nn::prelude::*;
use fmsr_nn::{CriticTying, NnError};

fn net(critic: CriticTying, seed: u64) -> NetworkConfig {
    NetworkConfig::new().with_hidden(16).with_layers(2).with_seed(seed).with_critic(critic)
}

/// A MADDPG of three agents after four gradient steps.
fn trained(critic: CriticTying) -> (fmsr_core::agent::ObservationLayout, Maddpg) {
    let layout = common::layout(&[2, 1, 2], 5, 2);
    let mut l = Maddpg::new(common::parts(&layout, net(critic, 3), 0.9), MaddpgConfig::new()).unwrap();
    for s in 0..4 {
        l.learn_batch(&common::batch(&layout, 32, s), &common::bounds(&layout)).unwrap();
    }
    (layout, l)
}

/// Each agent's online critic, whole (input layer, trunk, head), and its trunk.
fn critics(l: &Maddpg) -> (Vec<Vec<f32>>, Vec<Vec<f32>>) {
    (0..3).map(|i| (l.params(i).unwrap().1, l.critic_trunk(i).unwrap())).unzip()
}

fn q_values(layout: &fmsr_core::agent::ObservationLayout, l: &Maddpg) -> Vec<Vec<f32>> {
    let b = common::batch(layout, 8, 9);
    (0..3).map(|i| l.q_values(i, &b.obs, &b.goals, &b.actions, 8).unwrap()).collect()
}

#[test]
fn a_shared_trunk_stays_one_while_the_heads_stay_their_own() {
    let (layout, l) = trained(CriticTying::SharedTrunk);
    let (whole, trunks) = critics(&l);
    assert!(trunks.iter().all(|t| t == &trunks[0]) && !trunks[0].is_empty());
    assert!(whole.iter().all(|w| w[..16 * 2 + 16] == whole[0][..16 * 2 + 16]), "the input layer is shared");
    assert!(whole[1..].iter().all(|w| w != &whole[0]), "each head is its own");
    let q = q_values(&layout, &l);
    assert!(q[1..].iter().all(|v| v != &q[0]));
}

#[test]
fn a_shared_critic_gives_every_agent_one_value() {
    let (layout, l) = trained(CriticTying::Shared);
    let (whole, _) = critics(&l);
    assert!(whole.iter().all(|w| w == &whole[0]));
    let q = q_values(&layout, &l);
    assert!(q.iter().all(|v| v == &q[0]) && q[0].iter().all(|v| v.is_finite()));
}

#[test]
fn per_agent_critics_keep_their_own_trunks() {
    let (_, l) = trained(CriticTying::PerAgent);
    let (_, trunks) = critics(&l);
    assert!(trunks[1..].iter().all(|t| t != &trunks[0]));
}

#[test]
fn shared_critics_save_and_load_and_refuse_the_other_design() {
    let layout = common::layout(&[2, 3, 1], 7, 3);
    let rewards = L1Rewards::new(3);
    for critic in [CriticTying::SharedTrunk, CriticTying::Shared] {
        for kind in AlgorithmKind::ALL {
            let mut a = common::learner(kind, &layout, net(critic, 21));
            for e in 0..2 {
                a.store(&common::episode(&layout, e)).unwrap();
                let stats = a.update(&rewards).unwrap();
                assert!(stats.updates > 0 && stats.critic_loss.iter().chain(&stats.actor_loss).all(|v| v.is_finite()));
            }
            let bytes = a.save_state(true).unwrap();
            let mut b = common::learner(kind, &layout, net(critic, 99));
            b.load_state(&bytes).unwrap();
            // (The bytes may differ: burn keys optimiser states by a hash map.)
            assert_eq!(a.update(&rewards).unwrap(), b.update(&rewards).unwrap(), "{kind:?} {critic:?}");
            let x = common::inputs(&layout, 4, 7);
            let (xa, xb) = (a.act(&x, 4, ActMode::Explore).unwrap(), b.act(&x, 4, ActMode::Explore).unwrap());
            assert_eq!(format!("{xa:?}"), format!("{xb:?}"), "{kind:?} {critic:?}");
            let mut own = common::learner(kind, &layout, net(CriticTying::PerAgent, 99).with_stacking(Stacking::All));
            assert!(matches!(own.load_state(&bytes), Err(NnError::StateMismatch { .. })), "{kind:?} {critic:?}");
            let per_agent = own.save_state(true).unwrap();
            assert!(matches!(b.load_state(&per_agent), Err(NnError::StateMismatch { .. })), "{kind:?} {critic:?}");
        }
    }
}

#[test]
fn impossible_settings_are_typed_errors() {
    let layout = common::layout(&[2, 1, 2], 5, 2);
    let stacked = net(CriticTying::Shared, 0).with_stacking(Stacking::PerAgent);
    let err = Maddpg::new(common::parts(&layout, stacked, 0.9), MaddpgConfig::new()).unwrap_err();
    assert!(matches!(err, NnError::InvalidConfig { key: "networks.critic", .. }), "{err}");
    let sharing = Sharing {
        mixing: MetropolisHastings::matrix(&Graph::ring(3)),
        mode: ShareMode::Parameters,
        target: ShareTarget::Critics,
    };
    let parts = common::parts(&layout, net(CriticTying::SharedTrunk, 0), 0.9).with_sharing(Some(sharing));
    let err = Maddpg::new(parts, MaddpgConfig::new()).unwrap_err();
    assert!(matches!(err, NnError::Sharing { .. }), "{err}");
}
