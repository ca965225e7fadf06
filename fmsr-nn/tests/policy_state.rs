//! Guards `PolicyState::save_policy` / `load_policy` (the actors of a trained
//! policy file): a policy saved by one learner and loaded into a
//! fresh one of another seed acts the same in evaluation, bit for bit, for
//! every algorithm, and one of another stacking to float rounding (a batched
//! matmul sums in another order); the policy taken from a whole learner state equals the one
//! saved by the learner; a policy of another shape or algorithm, or corrupted
//! bytes, is an `NnError` that leaves the learner unchanged. A policy at half
//! precision (for shipping) takes about half the bytes, acts within f16's
//! rounding of the full one, says its precision, and converts back and forth
//! without drifting.

use crate::common;
use fmsr_core::testing::L1Rewards;

use common::AlgorithmKind;

use fmsr_core::agent::ObservationLayout;
use fmsr_core::policy::PolicyOutput;
use fmsr_nn::prelude::*;
use fmsr_nn::{RescueLevel, rescue_state};

fn net(seed: u64, stacking: Stacking) -> NetworkConfig {
    NetworkConfig::new().with_hidden(24).with_layers(2).with_seed(seed).with_stacking(stacking)
}

/// A learner of `kind` after two cycles of learning.
fn trained(kind: AlgorithmKind, layout: &ObservationLayout, stacking: Stacking) -> AnyLearner {
    let rewards = L1Rewards::new(layout.spec().agents.len());
    let mut a = common::learner(kind, layout, net(21, stacking));
    for e in 0..2 {
        a.store(&common::episode(layout, e)).unwrap();
        a.update(&rewards).unwrap();
    }
    a
}

/// The largest difference between two outputs' actions.
fn max_difference(a: &PolicyOutput, b: &PolicyOutput) -> f32 {
    assert_eq!(a.actions.len(), b.actions.len());
    a.actions.iter().flatten().zip(b.actions.iter().flatten()).map(|(x, y)| (x - y).abs()).fold(0.0, f32::max)
}

#[test]
fn a_loaded_policy_acts_as_the_saved_one() {
    let layout = common::layout(&[2, 3, 1], 7, 3);
    let x = common::inputs(&layout, 4, 7);
    for kind in AlgorithmKind::ALL {
        for from in [Stacking::PerAgent, Stacking::All] {
            let mut a = trained(kind, &layout, from);
            let policy = a.save_policy().unwrap();
            let expected = a.act(&x, 4, ActMode::Evaluate).unwrap();
            for to in [Stacking::PerAgent, Stacking::All] {
                let mut b = common::learner(kind, &layout, net(99, to));
                let before = b.act(&x, 4, ActMode::Evaluate).unwrap();
                assert!(max_difference(&before, &expected) > 1e-3, "{kind:?}: the fresh learner acts the same already");
                b.load_policy(&policy).unwrap();
                let found = b.act(&x, 4, ActMode::Evaluate).unwrap();
                if from == to {
                    assert_eq!(format!("{found:?}"), format!("{expected:?}"), "{kind:?} {from:?}");
                } else {
                    let d = max_difference(&found, &expected);
                    assert!(d < 1e-5, "{kind:?} {from:?} -> {to:?}: actions differ by {d}");
                }
            }
            // The policy inside a checkpoint's learner state is the same policy.
            let from_state = policy_from_learner_state(&a.save_state(false).unwrap()).unwrap();
            assert_eq!(from_state, policy, "{kind:?} {from:?}");
        }
    }
}

#[test]
fn bad_policies_are_errors_that_change_nothing() {
    let layout = common::layout(&[2, 3, 1], 7, 3);
    let policy = trained(AlgorithmKind::Maddpg, &layout, Stacking::PerAgent).save_policy().unwrap();
    let x = common::inputs(&layout, 2, 3);
    let mut fresh = common::learner(AlgorithmKind::Maddpg, &layout, net(5, Stacking::PerAgent));
    let before = format!("{:?}", fresh.act(&x, 2, ActMode::Evaluate).unwrap());

    let mut flipped = policy.clone();
    let mid = flipped.len() / 2;
    flipped[mid] ^= 0x10;
    for bad in [&flipped[..], &policy[..policy.len() - 3], b"hello", &[]] {
        assert!(matches!(fresh.load_policy(bad), Err(NnError::CorruptState { .. })));
    }
    // A whole learner state is not a policy state.
    let state = fresh.save_state(false).unwrap();
    assert!(matches!(fresh.load_policy(&state), Err(NnError::CorruptState { .. })));

    let wide = common::learner(AlgorithmKind::Maddpg, &layout, net(5, Stacking::PerAgent).with_hidden(32));
    let other_layout = common::layout(&[2, 3], 7, 3);
    let fewer = common::learner(AlgorithmKind::Maddpg, &other_layout, net(5, Stacking::PerAgent));
    let td3 = common::learner(AlgorithmKind::Matd3, &layout, net(5, Stacking::PerAgent));
    for (mut learner, what) in [(wide, "actor"), (fewer, "agents"), (td3, "algorithm")] {
        let err = learner.load_policy(&policy).unwrap_err();
        assert!(matches!(err, NnError::StateMismatch { .. }) && err.to_string().contains(what), "{err}");
    }
    assert_eq!(format!("{:?}", fresh.act(&x, 2, ActMode::Evaluate).unwrap()), before);
}

#[test]
fn a_half_policy_is_half_the_bytes_and_acts_within_rounding() {
    let layout = common::layout(&[2, 3, 1], 7, 3);
    let x = common::inputs(&layout, 4, 7);
    for kind in AlgorithmKind::ALL {
        let mut a = trained(kind, &layout, Stacking::PerAgent);
        let full = a.save_policy().unwrap();
        let half = policy_at_precision(&full, PolicyPrecision::Half).unwrap();
        assert_eq!(PolicyPrecision::of(&full), PolicyPrecision::Full);
        assert_eq!(PolicyPrecision::of(&half), PolicyPrecision::Half);
        // The normalisers stay whole, so a little over half of the bytes.
        assert!(half.len() < full.len() * 6 / 10, "{kind:?}: {} of {} bytes", half.len(), full.len());
        // Full to full is the same bytes; half to full to half too.
        assert_eq!(policy_at_precision(&full, PolicyPrecision::Full).unwrap(), full);
        let widened = policy_at_precision(&half, PolicyPrecision::Full).unwrap();
        assert_ne!(widened, full, "{kind:?}: rounding to f16 changed nothing");
        assert_eq!(policy_at_precision(&widened, PolicyPrecision::Half).unwrap(), half);

        let expected = a.act(&x, 4, ActMode::Evaluate).unwrap();
        let mut b = common::learner(kind, &layout, net(99, Stacking::All));
        b.load_policy(&half).unwrap();
        let found = b.act(&x, 4, ActMode::Evaluate).unwrap();
        let d = max_difference(&found, &expected);
        assert!(d > 0.0 && d < 1e-2, "{kind:?}: a half policy's actions differ by {d}");
        // Loading the widened bytes acts exactly as loading the half ones.
        let mut c = common::learner(kind, &layout, net(7, Stacking::All));
        c.load_policy(&widened).unwrap();
        assert_eq!(format!("{:?}", c.act(&x, 4, ActMode::Evaluate).unwrap()), format!("{found:?}"));
    }
}

#[test]
fn bad_half_policies_are_errors() {
    let layout = common::layout(&[2, 3, 1], 7, 3);
    let full = trained(AlgorithmKind::Maddpg, &layout, Stacking::PerAgent).save_policy().unwrap();
    let half = policy_at_precision(&full, PolicyPrecision::Half).unwrap();
    let mut flipped = half.clone();
    let mid = flipped.len() / 2;
    flipped[mid] ^= 0x10;
    let mut fresh = common::learner(AlgorithmKind::Maddpg, &layout, net(5, Stacking::PerAgent));
    for bad in [&flipped[..], &half[..half.len() - 3]] {
        assert!(matches!(fresh.load_policy(bad), Err(NnError::CorruptState { .. })));
        assert!(matches!(policy_at_precision(bad, PolicyPrecision::Full), Err(NnError::CorruptState { .. })));
    }
    // A half-precision learner state (a rescue point) is not a policy.
    let state = fresh.save_state(false).unwrap();
    let rescue = rescue_state(&state, RescueLevel::Half).unwrap();
    assert!(matches!(policy_at_precision(&rescue, PolicyPrecision::Half), Err(NnError::CorruptState { .. })));
}
