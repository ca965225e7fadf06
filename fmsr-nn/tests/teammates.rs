//! Guards `Teammates` (which actions of the other agents enter an actor's
//! loss): with `Current`, agent i's actor loss does not depend on the
//! teammates' actions stored in the batch, which are replaced by their current
//! policies; with `Replay` (HER baselines' choice, the default) it does. The
//! critics are frozen (learning rate 0) so only the actor loss's input differs.

use crate::common;
use fmsr_core::testing::L1Rewards;

use common::AlgorithmKind;

use fmsr_nn::Teammates;
use fmsr_nn::prelude::*;

fn actor_losses(teammates: Teammates, actions_seed: u64) -> Vec<f32> {
    let layout = common::layout(&[2, 1, 2], 5, 2);
    let net = NetworkConfig::new().with_hidden(16).with_layers(2).with_lr_critic(0.0).with_seed(4);
    let mut l = Maddpg::new(common::parts(&layout, net, 0.9), MaddpgConfig::new().with_teammates(teammates)).unwrap();
    let mut b = common::batch(&layout, 32, 1);
    b.actions = common::batch(&layout, 32, actions_seed).actions;
    l.learn_batch(&b, &common::bounds(&layout)).unwrap().1
}

#[test]
fn current_teammates_ignore_the_stored_joint_action() {
    assert_eq!(actor_losses(Teammates::Current, 2), actor_losses(Teammates::Current, 3));
    assert_ne!(actor_losses(Teammates::Replay, 2), actor_losses(Teammates::Replay, 3));
    assert_ne!(actor_losses(Teammates::Current, 2), actor_losses(Teammates::Replay, 2));
}

/// The actor losses of one update cycle of `kind` with `teammates` (critics
/// frozen, actors updated at every step), on an episode whose stored joint
/// actions are drawn from `actions_seed`. The actors observe no neighbours'
/// actions, so only the actor loss's teammates' actions can carry the stored ones.
fn cycle_actor_losses(kind: AlgorithmKind, teammates: Teammates, actions_seed: u64) -> Vec<u64> {
    let ring = common::layout(&[2, 1], 4, 2);
    let layout = fmsr_core::agent::ObservationLayout::new(ring.spec().clone(), vec![vec![], vec![]]).unwrap();
    let net = NetworkConfig::new().with_hidden(16).with_layers(2).with_lr_critic(0.0).with_seed(4);
    let parts = common::parts(&layout, net, 0.9);
    let mut l = match kind {
        AlgorithmKind::Maddpg => {
            AnyLearner::new(Maddpg::new(parts, MaddpgConfig::new().with_teammates(teammates)).unwrap())
        }
        AlgorithmKind::Matd3 => AnyLearner::new(
            Matd3::new(parts, Matd3Config::new().with_teammates(teammates).with_policy_delay(1)).unwrap(),
        ),
        AlgorithmKind::Masac => {
            AnyLearner::new(Masac::new(parts, MasacConfig::new().with_teammates(teammates)).unwrap())
        }
    };
    let mut episode = common::episode(&layout, 0);
    episode.actions = common::episode(&layout, actions_seed).actions;
    l.store(&episode).unwrap();
    let stats = l.update(&L1Rewards::new(2)).unwrap();
    assert!(stats.updates > 0 && stats.actor_loss.iter().all(|v| v.is_finite()), "{kind:?}: {stats:?}");
    stats.actor_loss.iter().map(|v| v.to_bits()).collect()
}

// Guards that every algorithm applies `teammates`, MATD3's and MASAC's too,
// through the update cycle that training runs (this test once only checked
// that they updated with `Current` set, which they would have ignoring it).
#[test]
fn every_algorithm_takes_the_setting() {
    for kind in AlgorithmKind::ALL {
        let current = |seed| cycle_actor_losses(kind, Teammates::Current, seed);
        let replay = |seed| cycle_actor_losses(kind, Teammates::Replay, seed);
        assert_eq!(current(2), current(3), "{kind:?} with current teammates read the stored actions");
        assert_ne!(replay(2), replay(3), "{kind:?} with replayed teammates ignored the stored actions");
    }
}
