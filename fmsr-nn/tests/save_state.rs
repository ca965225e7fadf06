//! Guards `Algorithm::save_state` / `load_state` of every learner: save ->
//! load into a fresh learner (another seed) gives the same exploring actions
//! (the RNG is restored), the same next update's losses and the same state bit
//! for bit, whatever the agents' stacking; the replay travels only when
//! asked; a state of another shape, algorithm or stacking, truncated or
//! corrupted bytes are `NnError`s that leave the learner unchanged.

use crate::common;
use fmsr_core::testing::L1Rewards;

use common::AlgorithmKind;

use fmsr_nn::prelude::*;

fn net(seed: u64) -> NetworkConfig {
    NetworkConfig::new().with_hidden(24).with_layers(2).with_seed(seed)
}

#[test]
fn round_trip_is_bit_exact_for_every_algorithm() {
    let layout = common::layout(&[2, 3, 1], 7, 3);
    let rewards = L1Rewards::new(3);
    for (kind, stacking) in AlgorithmKind::ALL.into_iter().flat_map(|k| [(k, Stacking::PerAgent), (k, Stacking::All)]) {
        let net = |seed| net(seed).with_stacking(stacking);
        let mut a = common::learner(kind, &layout, net(21));
        for e in 0..2 {
            a.store(&common::episode(&layout, e)).unwrap();
            a.update(&rewards).unwrap();
        }
        let bytes = a.save_state(true).unwrap();
        let mut b = common::learner(kind, &layout, net(99));
        b.load_state(&bytes).unwrap();
        let x = common::inputs(&layout, 4, 7);
        let (xa, xb) = (a.act(&x, 4, ActMode::Explore).unwrap(), b.act(&x, 4, ActMode::Explore).unwrap());
        assert_eq!(format!("{xa:?}"), format!("{xb:?}"), "{kind:?} {stacking:?}");
        let (sa, sb) = (a.update(&rewards).unwrap(), b.update(&rewards).unwrap());
        assert_eq!(sa, sb, "{kind:?} {stacking:?}");
        // (The bytes themselves may differ: burn keys optimiser states by a hash map.)
        let (xa, xb) = (a.act(&x, 4, ActMode::Explore).unwrap(), b.act(&x, 4, ActMode::Explore).unwrap());
        assert_eq!(format!("{xa:?}"), format!("{xb:?}"), "{kind:?} after an update");
    }
}

#[test]
fn the_replay_travels_only_when_asked() {
    let layout = common::layout(&[2, 1], 5, 2);
    let mut a = Maddpg::new(common::parts(&layout, net(1), 0.9), MaddpgConfig::new()).unwrap();
    a.store(&common::episode(&layout, 0)).unwrap();
    let mut with = Maddpg::new(common::parts(&layout, net(1), 0.9), MaddpgConfig::new()).unwrap();
    with.load_state(&a.save_state(true).unwrap()).unwrap();
    assert_eq!(with.replay_len(), 10);
    let mut without = Maddpg::new(common::parts(&layout, net(1), 0.9), MaddpgConfig::new()).unwrap();
    without.load_state(&a.save_state(false).unwrap()).unwrap();
    assert_eq!(without.replay_len(), 0);
}

#[test]
fn bad_states_are_errors() {
    let layout = common::layout(&[2, 3, 1], 7, 3);
    let mut a = Maddpg::new(common::parts(&layout, net(21), 0.9), MaddpgConfig::new()).unwrap();
    a.learn_batch(&common::batch(&layout, 8, 0), &common::bounds(&layout)).unwrap();
    let bytes = a.save_state(false).unwrap();
    let mut fresh = Maddpg::new(common::parts(&layout, net(21), 0.9), MaddpgConfig::new()).unwrap();
    let snapshot = |l: &Maddpg| (0..3).map(|i| l.params(i).unwrap()).collect::<Vec<_>>();
    let before = snapshot(&fresh);

    let mut flipped = bytes.clone();
    let mid = flipped.len() / 2;
    flipped[mid] ^= 0x10;
    assert!(matches!(fresh.load_state(&flipped), Err(NnError::CorruptState { .. })));
    assert!(matches!(fresh.load_state(&bytes[..bytes.len() - 5]), Err(NnError::CorruptState { .. })));
    assert!(matches!(fresh.load_state(b"hello"), Err(NnError::CorruptState { .. })));
    assert!(matches!(fresh.load_state(&[]), Err(NnError::CorruptState { .. })));

    // Another shape, another layout, another algorithm.
    let mut wide = Maddpg::new(common::parts(&layout, net(21).with_hidden(32), 0.9), MaddpgConfig::new()).unwrap();
    assert!(matches!(wide.load_state(&bytes), Err(NnError::StateMismatch { .. })));
    let other_layout = common::layout(&[2, 3], 7, 3);
    let mut other = Maddpg::new(common::parts(&other_layout, net(21), 0.9), MaddpgConfig::new()).unwrap();
    let err = other.load_state(&bytes).unwrap_err();
    assert!(err.to_string().contains("agents"), "{err}");
    let mut td3 = Matd3::new(common::parts(&layout, net(21), 0.9), Matd3Config::new()).unwrap();
    assert!(matches!(td3.load_state(&bytes), Err(NnError::StateMismatch { .. })));
    // Another grouping of the agents: the optimiser records do not map.
    let all = net(21).with_stacking(Stacking::All);
    let mut stacked = Maddpg::new(common::parts(&layout, all, 0.9), MaddpgConfig::new()).unwrap();
    let err = stacked.load_state(&bytes).unwrap_err();
    assert!(err.to_string().contains("networks.stacking"), "{err}");

    // Nothing was changed by the failed loads.
    assert_eq!(snapshot(&fresh), before);
    fresh.load_state(&bytes).unwrap();
    assert_eq!(snapshot(&fresh), snapshot(&a));
}
