//! Guards `Teammates` (which actions of the other agents enter an actor's
//! loss): with `Current`, agent i's actor loss does not depend on the
//! teammates' actions stored in the batch, which are replaced by their current
//! policies; with `Replay` (HER baselines' choice, the default) it does. The
//! critics are frozen (learning rate 0) so only the actor loss's input differs.

mod common;

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

#[test]
fn every_algorithm_takes_the_setting() {
    let layout = common::layout(&[2, 1], 4, 2);
    let net = || NetworkConfig::new().with_hidden(16).with_layers(2);
    let rewards = common::L1Rewards(2);
    let mut td3 =
        Matd3::new(common::parts(&layout, net(), 0.9), Matd3Config::new().with_teammates(Teammates::Current)).unwrap();
    let mut sac =
        Masac::new(common::parts(&layout, net(), 0.9), MasacConfig::new().with_teammates(Teammates::Current)).unwrap();
    for l in [&mut td3 as &mut dyn Algorithm<Error = NnError>, &mut sac] {
        l.store(&common::episode(&layout, 0)).unwrap();
        let stats = l.update(&rewards).unwrap();
        assert!(stats.updates > 0 && stats.actor_loss.iter().all(|v| v.is_finite()));
    }
}
