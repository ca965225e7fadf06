//! Guards `SaveState`: save -> load into a fresh learner gives the same
//! actions and the same next `learn` losses and parameters bit for bit; a
//! state of another shape, truncated or corrupted bytes are `NnError`s that
//! leave the learner unchanged.

mod common;

use fmsr_core::Agent;
use fmsr_core::agent::SaveState;
use fmsr_nn::prelude::*;

fn config() -> DdpgConfig {
    DdpgConfig::new().with_hidden(24).with_seed(21)
}

#[test]
fn round_trip_is_bit_exact() {
    let layout = common::layout(&[2, 3, 1], 7, 3);
    let mut a = DdpgLearner::new(layout.clone(), config(), None).unwrap();
    for step in 0..3 {
        a.learn(&common::batch(&layout, 16, step)).unwrap();
        a.update_targets().unwrap();
    }
    let bytes = a.save_state().unwrap();
    // A fresh learner with another seed: everything must come from the state.
    let mut b = DdpgLearner::new(layout.clone(), config().with_seed(99), None).unwrap();
    b.load_state(&bytes).unwrap();
    let x = common::inputs(&layout, 4, 7);
    let (xa, xb) = (a.act(&x, 4).unwrap(), b.act(&x, 4).unwrap());
    assert_eq!(
        xa.iter().map(|v| common::bits(v)).collect::<Vec<_>>(),
        xb.iter().map(|v| common::bits(v)).collect::<Vec<_>>()
    );
    for step in 3..5 {
        let batch = common::batch(&layout, 16, step);
        let (sa, sb) = (a.learn(&batch).unwrap(), b.learn(&batch).unwrap());
        assert_eq!(common::bits(&sa.critic_loss), common::bits(&sb.critic_loss));
        assert_eq!(common::bits(&sa.actor_loss), common::bits(&sb.actor_loss));
        a.update_targets().unwrap();
        b.update_targets().unwrap();
    }
    for i in 0..3 {
        assert_eq!(common::bits(a.actor_params(i).unwrap()), common::bits(b.actor_params(i).unwrap()));
        assert_eq!(common::bits(a.critic_params(i).unwrap()), common::bits(b.critic_params(i).unwrap()));
    }
    assert_eq!(a.critic_normalizer(), b.critic_normalizer());
    assert_eq!(a.save_state().unwrap(), b.save_state().unwrap());
}

#[test]
fn bad_states_are_errors() {
    let layout = common::layout(&[2, 3, 1], 7, 3);
    let mut a = DdpgLearner::new(layout.clone(), config(), None).unwrap();
    a.learn(&common::batch(&layout, 8, 0)).unwrap();
    let bytes = a.save_state().unwrap();
    let mut fresh = DdpgLearner::new(layout.clone(), config(), None).unwrap();
    let before = fresh.save_state().unwrap();

    let mut flipped = bytes.clone();
    let mid = flipped.len() / 2;
    flipped[mid] ^= 0x10;
    assert!(matches!(fresh.load_state(&flipped), Err(NnError::CorruptState { .. })));
    assert!(matches!(fresh.load_state(&bytes[..bytes.len() - 5]), Err(NnError::CorruptState { .. })));
    assert!(matches!(fresh.load_state(b"hello"), Err(NnError::CorruptState { .. })));
    assert!(matches!(fresh.load_state(&[]), Err(NnError::CorruptState { .. })));
    let mut bad_magic = bytes.clone();
    bad_magic[0] = b'X';
    assert!(matches!(fresh.load_state(&bad_magic), Err(NnError::CorruptState { .. })));

    // Another shape: wider hidden layers, or another layout.
    let mut wide = DdpgLearner::new(layout, config().with_hidden(32), None).unwrap();
    assert!(matches!(wide.load_state(&bytes), Err(NnError::StateMismatch { .. })));
    let mut other = DdpgLearner::new(common::layout(&[2, 3], 7, 3), config(), None).unwrap();
    assert!(matches!(other.load_state(&bytes), Err(NnError::StateMismatch { .. })));
    let err = other.load_state(&bytes).unwrap_err().to_string();
    assert!(err.contains("agents"), "{err}");

    // Nothing was changed by the failed loads.
    assert_eq!(fresh.save_state().unwrap(), before);
    fresh.load_state(&bytes).unwrap();
    assert_eq!(fresh.save_state().unwrap(), bytes);
}
