//! Guards that the DDPG updates actually learn: on a fixed toy batch with
//! gamma = 0 the critic fits a fixed reward function of the observation (its
//! TD loss falls by more than 10x), and the actor loss decreases as the actor
//! climbs the critic; polyak averaging moves targets by (1 - polyak).

mod common;

use fmsr_core::Agent;
use fmsr_nn::prelude::*;

#[test]
fn critic_fits_a_fixed_target() {
    let layout = common::layout(&[2, 1], 4, 2);
    let config = DdpgConfig::new().with_hidden(64).with_layers(2).with_gamma(0.0).with_seed(4);
    let mut l = DdpgLearner::new(layout.clone(), config, None).unwrap();
    let mut b = common::batch(&layout, 64, 1);
    // r_i = -(x_0^2 + |x_1|) / 2 - 0.1 i, a smooth fixed function of the observation.
    for (i, r) in b.rewards.iter_mut().enumerate() {
        for (k, v) in r.iter_mut().enumerate() {
            let x = &b.obs[k * 4..k * 4 + 4];
            *v = -(x[0] * x[0] + x[1].abs()) / 2.0 - 0.1 * i as f32;
        }
    }
    let first = l.learn(&b).unwrap();
    let mut last = first.clone();
    for _ in 0..300 {
        last = l.learn(&b).unwrap();
    }
    for i in 0..2 {
        assert!(
            last.critic_loss[i] < first.critic_loss[i] / 10.0,
            "agent {i}: critic loss {} -> {}",
            first.critic_loss[i],
            last.critic_loss[i]
        );
    }
    // The learned Q approximates the reward.
    let q = l.q_values(0, &b.obs, &b.goals, &b.actions, 64).unwrap();
    let mse: f32 = q.iter().zip(&b.rewards[0]).map(|(q, r)| (q - r) * (q - r)).sum::<f32>() / 64.0;
    assert!(mse < 0.01, "mse {mse}");
}

#[test]
fn actors_climb_the_critic() {
    // r_i = -mean over agent i's slots of (a_s - 0.5)^2; with the action penalty
    // mean(mu^2) (action_l2 = 1) the best action is 0.25 in every slot.
    let layout = common::layout(&[2, 1], 4, 2);
    let config = DdpgConfig::new().with_hidden(64).with_layers(2).with_gamma(0.0).with_seed(6);
    let mut l = DdpgLearner::new(layout.clone(), config, None).unwrap();
    let mut b = common::batch(&layout, 128, 3);
    for (i, r) in b.rewards.iter_mut().enumerate() {
        let slots = &layout.spec().agents[i].action_slots;
        for (k, v) in r.iter_mut().enumerate() {
            let a = &b.actions[k * 3..k * 3 + 3];
            *v = -slots.iter().map(|&s| (a[s] - 0.5) * (a[s] - 0.5)).sum::<f32>() / slots.len() as f32;
        }
    }
    let first = l.learn(&b).unwrap();
    let mut last = first.clone();
    for _ in 0..400 {
        last = l.learn(&b).unwrap();
    }
    let acts = l.act(&b.actor_inputs, 128).unwrap();
    for (i, a) in acts.iter().enumerate() {
        let err = a.iter().map(|x| (x - 0.25).abs()).sum::<f32>() / a.len() as f32;
        assert!(err < 0.1, "agent {i}: mean |mu - 0.25| = {err}");
        // At the optimum the loss is (0.25^2 + 0.25^2) = 0.125.
        assert!(last.actor_loss[i] < first.actor_loss[i], "agent {i}: actor loss {first:?} -> {last:?}");
    }
}

#[test]
fn targets_follow_by_polyak() {
    let layout = common::layout(&[1, 1], 3, 1);
    let config = DdpgConfig::new().with_hidden(8).with_polyak(0.75);
    let mut l = DdpgLearner::new(layout.clone(), config, None).unwrap();
    let b = common::batch(&layout, 8, 0);
    let before = l.critic_params(0).unwrap().to_vec();
    l.learn(&b).unwrap();
    // With gamma = 0.99 the target critic matters: a second learn with the
    // targets unchanged and with the targets updated differ.
    let mut moved = DdpgLearner::new(layout.clone(), DdpgConfig::new().with_hidden(8).with_polyak(0.75), None).unwrap();
    moved.learn(&b).unwrap();
    assert_ne!(before, l.critic_params(0).unwrap());
    moved.update_targets().unwrap();
    let s1 = l.learn(&b).unwrap();
    let s2 = moved.learn(&b).unwrap();
    assert_ne!(s1.critic_loss, s2.critic_loss);
    // polyak = 1 keeps the targets: updating them changes nothing.
    let mut frozen = DdpgLearner::new(layout.clone(), DdpgConfig::new().with_hidden(8).with_polyak(1.0), None).unwrap();
    let mut reference = DdpgLearner::new(layout, DdpgConfig::new().with_hidden(8).with_polyak(1.0), None).unwrap();
    frozen.learn(&b).unwrap();
    reference.learn(&b).unwrap();
    frozen.update_targets().unwrap();
    assert_eq!(frozen.learn(&b).unwrap(), reference.learn(&b).unwrap());
}
