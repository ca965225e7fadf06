//! Guards the shapes of the networks and of the learner's outputs, and that
//! every malformed input (wrong dims, NaN, bad agent index, mismatched mixing
//! matrix, impossible config) is a typed `NnError`, never a panic.

mod common;

use fmsr_core::Agent;
use fmsr_core::agent::{ShareMode, ShareTarget, Sharing};
use fmsr_graph::{Graph, MetropolisHastings};
use fmsr_nn::prelude::*;

fn small() -> DdpgConfig {
    DdpgConfig::new().with_hidden(16).with_layers(3).with_seed(3)
}

#[test]
fn network_and_output_shapes() {
    let layout = common::layout(&[2, 3, 1], 11, 4);
    let mut l = DdpgLearner::new(layout.clone(), small(), None).unwrap();
    assert_eq!(l.num_agents(), 3);
    for i in 0..3 {
        let s = l.actor_shape(i).unwrap();
        let a = layout.spec().agents[i].action_dim();
        assert_eq!(s.layers, vec![(layout.actor_input_dim(i), 16), (16, 16), (16, 16), (16, a)]);
        assert_eq!(l.actor_params(i).unwrap().len(), s.num_params());
        // The trunk: layers - 1 = 2 layers of 16 x 16 + 16.
        assert_eq!(l.consensus_params(i).unwrap().len(), 2 * (16 * 16 + 16));
        assert_eq!(l.critic_trunk(i).unwrap().len(), 2 * (16 * 16 + 16));
    }
    assert_eq!(l.critic_shape().layers, vec![(11 + 4 + 6, 16), (16, 16), (16, 16), (16, 1)]);
    let out = l.act(&common::inputs(&layout, 5, 1), 5).unwrap();
    for (i, o) in out.iter().enumerate() {
        assert_eq!(o.len(), 5 * layout.spec().agents[i].action_dim());
        assert!(o.iter().all(|a| a.abs() <= 1.0));
    }
    assert_eq!(l.act(&common::inputs(&layout, 0, 1), 0).unwrap(), vec![Vec::<f32>::new(); 3]);
    let b = common::batch(&layout, 7, 2);
    let stats = l.learn(&b).unwrap();
    assert_eq!((stats.critic_loss.len(), stats.actor_loss.len()), (3, 3));
    assert!(stats.critic_loss.iter().chain(&stats.actor_loss).all(|v| v.is_finite()));
    let q = l.q_values(0, &b.obs, &b.goals, &b.actions, 7).unwrap();
    assert_eq!(q.len(), 7);
}

#[test]
fn single_hidden_layer_has_an_empty_trunk() {
    let layout = common::layout(&[1, 2], 5, 2);
    let mut l = DdpgLearner::new(layout.clone(), small().with_layers(1), None).unwrap();
    assert!(l.consensus_params(1).unwrap().is_empty());
    l.learn(&common::batch(&layout, 4, 0)).unwrap();
}

#[test]
fn bad_batches_are_errors() {
    let layout = common::layout(&[2, 3], 6, 3);
    let mut l = DdpgLearner::new(layout.clone(), small(), None).unwrap();
    let good = common::batch(&layout, 4, 9);

    let mut b = good.clone();
    b.obs.pop();
    assert!(matches!(l.learn(&b), Err(NnError::Dimension { .. })));
    let mut b = good.clone();
    b.actor_inputs[1].push(0.0);
    assert!(matches!(l.learn(&b), Err(NnError::Dimension { .. })));
    let mut b = good.clone();
    b.rewards.pop();
    assert!(matches!(l.learn(&b), Err(NnError::Dimension { .. })));
    let mut b = good.clone();
    b.q_bounds = vec![(0.0, -1.0); 2];
    assert!(matches!(l.learn(&b), Err(NnError::InvalidConfig { .. })));
    let mut b = good.clone();
    b.next_obs[3] = f32::NAN;
    assert!(matches!(l.learn(&b), Err(NnError::NotFinite { index: 3, .. })));
    let mut b = good.clone();
    b.size = 0;
    assert!(l.learn(&b).is_err());
    // The failures changed nothing: the same learn still works.
    l.learn(&good).unwrap();

    let mut inputs = common::inputs(&layout, 2, 0);
    inputs[0].push(1.0);
    assert!(matches!(l.act(&inputs, 2), Err(NnError::Dimension { .. })));
    assert!(matches!(l.act(&inputs[..1], 2), Err(NnError::Dimension { .. })));
    assert!(matches!(l.consensus_params(2), Err(NnError::UnknownAgent { agent: 2, agents: 2 })));
    assert!(matches!(l.set_consensus_params(0, &[0.0; 3]), Err(NnError::Dimension { .. })));
    assert!(matches!(l.q_values(0, &good.obs, &good.goals, &good.actions, 5), Err(NnError::Dimension { .. })));
}

#[test]
fn bad_configs_are_errors() {
    let layout = common::layout(&[2, 3, 1], 6, 3);
    assert!(matches!(
        DdpgLearner::new(layout.clone(), small().with_hidden(0), None),
        Err(NnError::InvalidConfig { key: "hidden", .. })
    ));
    assert!(matches!(
        DdpgLearner::new(layout.clone(), small().with_gamma(f64::NAN), None),
        Err(NnError::InvalidConfig { key: "gamma", .. })
    ));
    let sharing = Sharing {
        mixing: MetropolisHastings::matrix(&Graph::ring(4)),
        mode: ShareMode::Parameters,
        target: ShareTarget::Actors,
    };
    assert!(matches!(DdpgLearner::new(layout, small(), Some(sharing)), Err(NnError::Sharing { .. })));
}

#[test]
fn learner_can_move_between_threads() {
    fn assert_send<T: Send>() {}
    assert_send::<DdpgLearner>();
}
