//! Guards what a user's update rule declares its critics see
//! ([`CriticView`]): the learner builds a critic of view `own` on agent `i`'s
//! actor input and action alone, one of view `neighbours` on those and its
//! neighbours' actions, and one padded stack of all agents (the GPU's
//! grouping) computes what one stack per agent (the CPU's, no padding) does,
//! so the joint action's columns land where each agent's critic reads them.
//! It also guards that the learner, not the rule, counts the steps.

use crate::common;
use fmsr_core::testing::L1Rewards;

use fmsr_core::algorithm::Algorithm;
use fmsr_core::policy::{ActMode, PolicyOutput};
use fmsr_core::replay::ReplayConfig;
use fmsr_core::sharing::{ShareMode, ShareTarget, Sharing};
use fmsr_graph::{Graph, MetropolisHastings};
use fmsr_nn::{
    BatchTensors, CriticView, Learner, LearnerParts, NetworkConfig, NnError, OffPolicy, StackedMlpConfig, Stacking,
    StepLosses, Teammates, UpdateRule,
};

/// MADDPG's losses with the critics of view `V` (0 global, 1 own, 2 neighbours).
#[derive(Debug, Clone, Default)]
struct Rule<const V: u8> {
    /// The step index the learner gave each step.
    seen: Vec<u64>,
}

impl<const V: u8> UpdateRule for Rule<V> {
    const NAME: &'static str = "view_test";
    const CRITIC_VIEW: CriticView = match V {
        0 => CriticView::Global,
        1 => CriticView::Own,
        _ => CriticView::Neighbours,
    };

    fn act(&mut self, l: &mut Learner, inputs: &[Vec<f32>], n: usize, mode: ActMode) -> Result<PolicyOutput, NnError> {
        l.deterministic_act(inputs, n, mode, 0.2, 0.3)
    }

    fn step(&mut self, l: &mut Learner, b: &BatchTensors) -> Result<StepLosses, NnError> {
        self.seen.push(l.step_index());
        let next = l.target_actions(b)?;
        let critic = l.critic_step(b, next)?;
        let actor = l.deterministic_actor_step(b, 1.0, Teammates::Replay)?;
        Ok(StepLosses { critic, actor: Some(actor) })
    }

    fn targets(&self) -> (f64, bool) {
        (0.95, true)
    }
}

const HIDDEN: usize = 16;

fn learner<const V: u8>(stacking: Stacking) -> (fmsr_core::agent::ObservationLayout, OffPolicy<Rule<V>>) {
    let layout = common::layout(&[2, 3, 1], 6, 2);
    let net = NetworkConfig::new().with_hidden(HIDDEN).with_layers(2).with_seed(5).with_stacking(stacking);
    let replay = ReplayConfig { batch_size: 8, batches: 3, ..ReplayConfig::default() };
    let sharing = Sharing {
        mixing: MetropolisHastings::matrix(&Graph::ring(3)),
        mode: ShareMode::Parameters,
        target: ShareTarget::Both,
    };
    let parts = LearnerParts::new(layout.clone(), net, replay, 0.9).with_sharing(Some(sharing));
    (layout, OffPolicy::with_rule(parts, Rule::default()).unwrap())
}

/// Two update cycles' losses, every agent's (actor, critic) parameters
/// afterwards, and the step indices the rule saw.
type Trace = (Vec<f64>, Vec<(Vec<f32>, Vec<f32>)>, Vec<u64>);

fn run<const V: u8>(stacking: Stacking) -> Trace {
    let (layout, mut l) = learner::<V>(stacking);
    for seed in 0..2 {
        l.store(&common::episode(&layout, seed)).unwrap();
    }
    let rewards = L1Rewards::new(3);
    let mut losses = Vec::new();
    for _ in 0..2 {
        let s = l.update(&rewards).unwrap();
        losses.extend(s.critic_loss.iter().chain(&s.actor_loss));
    }
    let params = (0..3).map(|i| l.params(i).unwrap()).collect();
    (losses, params, l.rule().seen.clone())
}

fn close(a: &[f32], b: &[f32]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| (x - y).abs() <= 1e-4 * (1.0 + x.abs()))
}

fn same_in_both_groupings<const V: u8>() {
    let (loss_a, params_a, seen) = run::<V>(Stacking::PerAgent);
    let (loss_b, params_b, _) = run::<V>(Stacking::All);
    let f = |v: &[f64]| v.iter().map(|&x| x as f32).collect::<Vec<_>>();
    assert!(close(&f(&loss_a), &f(&loss_b)), "losses per agent {loss_a:?}, all in one stack {loss_b:?}");
    for (i, ((actor_a, critic_a), (actor_b, critic_b))) in params_a.iter().zip(&params_b).enumerate() {
        assert!(close(actor_a, actor_b) && close(critic_a, critic_b), "agent {i}'s parameters differ by grouping");
    }
    assert_eq!(seen, (0..6).collect::<Vec<u64>>(), "the learner counts the steps, from 0");
}

/// Agent `i`'s critic's parameter count for an input of `width`.
fn critic_params(width: usize) -> usize {
    StackedMlpConfig::new(vec![width], HIDDEN, 2, vec![1]).layout().shapes[0].num_params()
}

#[test]
fn own_critics_see_their_agent_alone_in_either_grouping() {
    let (layout, l) = learner::<1>(Stacking::All);
    for (i, d) in [2, 3, 1].into_iter().enumerate() {
        assert_eq!(l.params(i).unwrap().1.len(), critic_params(layout.actor_input_dim(i) + d), "agent {i}");
    }
    same_in_both_groupings::<1>();
}

#[test]
fn neighbour_critics_see_their_ring_neighbours_actions_in_either_grouping() {
    let (layout, l) = learner::<2>(Stacking::All);
    // Ring of three: every agent sees all three actions beside its own input.
    for i in 0..3 {
        assert_eq!(l.params(i).unwrap().1.len(), critic_params(layout.actor_input_dim(i) + 6), "agent {i}");
    }
    same_in_both_groupings::<2>();
}

#[test]
fn global_critics_are_unchanged_and_local_ones_refuse_global_probes() {
    same_in_both_groupings::<0>();
    let (layout, l) = learner::<1>(Stacking::PerAgent);
    let b = common::batch(&layout, 4, 1);
    let err = l.q_values(0, &b.obs, &b.goals, &b.actions, 4).unwrap_err();
    assert!(matches!(err, NnError::InvalidConfig { key: "q_values", .. }), "{err}");
}
