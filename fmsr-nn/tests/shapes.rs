//! Guards the learners' shapes and input checks: actions of every agent in
//! `[-1, 1]` with the agent's width, zero rows, wrong inputs and impossible
//! configs rejected with typed errors, and the learners are `Send`.

use crate::common;

use fmsr_core::sharing::{ShareMode, ShareTarget, Sharing};
use fmsr_graph::{Graph, MetropolisHastings};
use fmsr_nn::prelude::*;

fn small() -> NetworkConfig {
    NetworkConfig::new().with_hidden(16).with_layers(3).with_seed(1)
}

#[test]
fn every_algorithm_acts_in_range_with_the_right_shapes() {
    let layout = common::layout(&[2, 3, 1], 6, 2);
    let learners: Vec<AnyLearner> = vec![
        AnyLearner::new(Maddpg::new(common::parts(&layout, small(), 0.9), MaddpgConfig::new()).unwrap()),
        AnyLearner::new(Matd3::new(common::parts(&layout, small(), 0.9), Matd3Config::new()).unwrap()),
        AnyLearner::new(Masac::new(common::parts(&layout, small(), 0.9), MasacConfig::new()).unwrap()),
    ];
    for mut l in learners {
        for mode in [ActMode::Explore, ActMode::Evaluate] {
            let out = l.act(&common::inputs(&layout, 5, 1), 5, mode).unwrap();
            for (i, a) in out.actions.iter().enumerate() {
                assert_eq!(a.len(), 5 * layout.spec().agents[i].action_dim(), "{:?}", l.name());
                assert!(a.iter().all(|v| v.abs() <= 1.0), "{:?}", l.name());
            }
        }
        let empty = l.act(&common::inputs(&layout, 0, 1), 0, ActMode::Evaluate).unwrap();
        assert_eq!(empty.actions, vec![Vec::<f32>::new(); 3]);
        assert_eq!(l.actor_trunk(0).unwrap().len(), 2 * (16 * 16 + 16));
    }
}

#[test]
fn masac_reports_log_probabilities_only_when_exploring() {
    let layout = common::layout(&[2, 1], 4, 2);
    let mut l = Masac::new(common::parts(&layout, small(), 0.9), MasacConfig::new()).unwrap();
    let out = l.act(&common::inputs(&layout, 3, 2), 3, ActMode::Explore).unwrap();
    assert_eq!(out.log_probs.len(), 2);
    assert!(out.log_probs.iter().all(|lp| lp.len() == 3 && lp.iter().all(|v| v.is_finite())));
    assert!(l.act(&common::inputs(&layout, 3, 2), 3, ActMode::Evaluate).unwrap().log_probs.is_empty());
}

#[test]
fn bad_inputs_are_typed_errors() {
    let layout = common::layout(&[1, 2], 4, 2);
    let mut l = Maddpg::new(common::parts(&layout, small(), 0.9), MaddpgConfig::new()).unwrap();
    let mut inputs = common::inputs(&layout, 2, 0);
    inputs[0][0] = f32::NAN;
    assert!(matches!(l.act(&inputs, 2, ActMode::Evaluate), Err(NnError::NotFinite { .. })));
    inputs[0].pop();
    assert!(matches!(l.act(&inputs, 2, ActMode::Evaluate), Err(NnError::Dimension { .. })));
    assert!(matches!(l.act(&inputs[..1], 2, ActMode::Evaluate), Err(NnError::Dimension { .. })));
    assert!(matches!(l.actor_trunk(2), Err(NnError::UnknownAgent { agent: 2, agents: 2 })));
    assert!(matches!(l.set_actor_trunk(0, &[0.0; 3]), Err(NnError::Dimension { .. })));
    let mut b = common::batch(&layout, 4, 0);
    b.rewards.pop();
    assert!(matches!(l.learn_batch(&b, &common::bounds(&layout)), Err(NnError::Dimension { .. })));
    let b = common::batch(&layout, 4, 0);
    assert!(matches!(l.learn_batch(&b, &[(0.0, -1.0); 2]), Err(NnError::InvalidConfig { key: "q_bounds", .. })));
}

#[test]
fn impossible_configs_are_rejected() {
    let layout = common::layout(&[1, 2], 4, 2);
    let err = |r: Result<Maddpg, NnError>| r.unwrap_err();
    assert!(matches!(
        err(Maddpg::new(common::parts(&layout, small().with_hidden(0), 0.9), MaddpgConfig::new())),
        NnError::InvalidConfig { key: "networks.hidden", .. }
    ));
    assert!(matches!(
        err(Maddpg::new(common::parts(&layout, small(), 1.0), MaddpgConfig::new())),
        NnError::InvalidConfig { key: "gamma", .. }
    ));
    assert!(matches!(
        Matd3::new(common::parts(&layout, small(), 0.9), Matd3Config::new().with_policy_delay(0)).unwrap_err(),
        NnError::InvalidConfig { key: "matd3.policy_delay", .. }
    ));
    let sharing = Sharing {
        mixing: MetropolisHastings::matrix(&Graph::ring(3)),
        mode: ShareMode::Parameters,
        target: ShareTarget::Actors,
    };
    let parts = common::parts(&layout, small(), 0.9).with_sharing(Some(sharing));
    assert!(matches!(err(Maddpg::new(parts, MaddpgConfig::new())), NnError::Sharing { .. }));
}

#[test]
fn learners_are_send() {
    fn assert_send<T: Send>() {}
    assert_send::<Maddpg>();
    assert_send::<Matd3>();
    assert_send::<Masac>();
}
