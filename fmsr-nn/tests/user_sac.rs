//! Guards that a SAC-like algorithm can be written outside the crate: a rule
//! of this file, on the learner's public stochastic steps alone
//! ([`Learner::sampled_next_actions`], [`Learner::soft_critic_step`],
//! [`Learner::squashed_gaussian_actor_step`], [`Learner::squashed_gaussian_act`]),
//! with fixed temperatures, learns exactly what the crate's MASAC learns when
//! its temperatures do not move (`lr_temperature = 0`): the same losses,
//! parameters and actions bit for bit, with information sharing on and with
//! either teammates' actions. It also guards the steps' typed error for a
//! temperature list that is not one per agent.

use crate::common;
use fmsr_core::testing::L1Rewards;

use fmsr_core::agent::ObservationLayout;
use fmsr_core::algorithm::Algorithm;
use fmsr_core::policy::{ActMode, Policy, PolicyOutput};
use fmsr_core::replay::ReplayConfig;
use fmsr_core::sharing::{ShareMode, ShareTarget, Sharing};
use fmsr_graph::{Graph, MetropolisHastings};
use fmsr_nn::{
    BatchTensors, Learner, LearnerParts, Masac, MasacConfig, NetworkConfig, NnError, OffPolicy, SquashedGaussian,
    StepLosses, Teammates, UpdateRule,
};

/// SAC with fixed temperatures: what a user writes in their own crate.
#[derive(Debug, Clone)]
struct FixedSac {
    alpha: Vec<f32>,
    dist: SquashedGaussian,
    teammates: Teammates,
    random_eps: f64,
}

impl UpdateRule for FixedSac {
    const NAME: &'static str = "fixed_sac";
    const CRITICS: usize = 2;
    const HEADS: usize = 2;

    fn act(&mut self, l: &mut Learner, inputs: &[Vec<f32>], n: usize, mode: ActMode) -> Result<PolicyOutput, NnError> {
        l.squashed_gaussian_act(inputs, n, mode, self.dist, self.random_eps)
    }

    fn step(&mut self, l: &mut Learner, b: &BatchTensors) -> Result<StepLosses, NnError> {
        let (next, soft) = l.sampled_next_actions(b, self.dist, &self.alpha)?;
        let critic = l.soft_critic_step(b, next, soft)?;
        let (actor, _mean_log_pi) = l.squashed_gaussian_actor_step(b, self.dist, &self.alpha, self.teammates)?;
        Ok(StepLosses { critic, actor: Some(actor) })
    }

    fn targets(&self) -> (f64, bool) {
        (0.95, false)
    }
}

fn config(teammates: Teammates) -> MasacConfig {
    MasacConfig::new()
        .with_teammates(teammates)
        .with_polyak(0.95)
        .with_lr_temperature(0.0)
        .with_initial_temperature(0.3)
}

fn parts() -> (ObservationLayout, LearnerParts) {
    let layout = common::layout(&[2, 3, 1], 6, 2);
    let net = NetworkConfig::new().with_hidden(16).with_layers(2).with_seed(11);
    let replay = ReplayConfig { batch_size: 8, batches: 3, ..ReplayConfig::default() };
    let sharing = Sharing {
        mixing: MetropolisHastings::matrix(&Graph::ring(3)),
        mode: ShareMode::Parameters,
        target: ShareTarget::Both,
    };
    (layout.clone(), LearnerParts::new(layout, net, replay, 0.9).with_sharing(Some(sharing)))
}

/// Two update cycles' losses, the parameters afterwards and an exploring and a greedy action.
type Trace = (Vec<u64>, Vec<Vec<u32>>, Vec<Vec<u32>>);

fn trace<R: UpdateRule>(layout: &ObservationLayout, mut l: OffPolicy<R>) -> Trace {
    for seed in 0..2 {
        l.store(&common::episode(layout, seed)).unwrap();
    }
    let rewards = L1Rewards::new(3);
    let mut losses = Vec::new();
    for _ in 0..2 {
        let s = l.update(&rewards).unwrap();
        losses.extend(s.critic_loss.iter().chain(&s.actor_loss).map(|v| v.to_bits()));
    }
    let mut bits = Vec::new();
    for i in 0..3 {
        let (actor, critic) = l.params(i).unwrap();
        bits.push(common::bits(&actor));
        bits.push(common::bits(&critic));
    }
    let inputs = common::inputs(layout, 4, 7);
    let mut actions = Vec::new();
    for mode in [ActMode::Explore, ActMode::Evaluate] {
        let out = l.act(&inputs, 4, mode).unwrap();
        actions.extend(out.actions.iter().map(|a| common::bits(a)));
        actions.extend(out.log_probs.iter().map(|a| common::bits(a)));
    }
    (losses, bits, actions)
}

#[test]
fn a_fixed_temperature_sac_of_a_users_crate_learns_what_masac_learns() {
    for teammates in [Teammates::Replay, Teammates::Current] {
        let c = config(teammates);
        let (layout, p) = parts();
        let masac = trace(&layout, Masac::new(p, c.clone()).unwrap());
        let rule = FixedSac {
            alpha: vec![c.initial_temperature as f32; 3],
            dist: SquashedGaussian { log_std_min: c.log_std_min as f32, log_std_max: c.log_std_max as f32 },
            teammates,
            random_eps: c.random_eps,
        };
        let (layout, p) = parts();
        let user = trace(&layout, OffPolicy::with_rule(p, rule).unwrap());
        assert!(!masac.0.is_empty() && !masac.2.is_empty());
        assert_eq!(masac.0, user.0, "losses ({teammates:?})");
        assert_eq!(masac.1, user.1, "parameters ({teammates:?})");
        assert_eq!(masac.2, user.2, "actions and log-probabilities ({teammates:?})");
    }
}

#[test]
fn temperatures_that_are_not_one_per_agent_are_refused() {
    let (layout, p) = parts();
    let c = config(Teammates::Replay);
    let rule = FixedSac {
        alpha: vec![0.3; 2],
        dist: SquashedGaussian { log_std_min: -5.0, log_std_max: 2.0 },
        teammates: Teammates::Replay,
        random_eps: c.random_eps,
    };
    let mut l = OffPolicy::with_rule(p, rule).unwrap();
    l.store(&common::episode(&layout, 0)).unwrap();
    let err = l.update(&L1Rewards::new(3)).unwrap_err();
    assert!(matches!(&err, NnError::Dimension { what, expected: 3, found: 2 } if what == "temperatures"), "{err}");
}

/// [`FixedSac`] with one head block per action: a rule that forgot `HEADS = 2`.
#[derive(Debug, Clone)]
struct OneHead(FixedSac);

impl UpdateRule for OneHead {
    const NAME: &'static str = "one_head";
    const CRITICS: usize = 2;

    fn act(&mut self, l: &mut Learner, inputs: &[Vec<f32>], n: usize, mode: ActMode) -> Result<PolicyOutput, NnError> {
        self.0.act(l, inputs, n, mode)
    }

    fn step(&mut self, l: &mut Learner, b: &BatchTensors) -> Result<StepLosses, NnError> {
        self.0.step(l, b)
    }

    fn targets(&self) -> (f64, bool) {
        (0.95, false)
    }
}

#[test]
fn actors_without_two_head_blocks_are_refused_not_misread() {
    let (layout, p) = parts();
    let rule = FixedSac {
        alpha: vec![0.3; 3],
        dist: SquashedGaussian { log_std_min: -5.0, log_std_max: 2.0 },
        teammates: Teammates::Replay,
        random_eps: 0.0,
    };
    let mut l = OffPolicy::with_rule(p, OneHead(rule)).unwrap();
    let is_heads = |e: &NnError| matches!(e, NnError::InvalidConfig { key: "UpdateRule::HEADS", .. });
    let err = l.act(&common::inputs(&layout, 2, 1), 2, ActMode::Evaluate).unwrap_err();
    assert!(is_heads(&err), "{err}");
    l.store(&common::episode(&layout, 0)).unwrap();
    let err = l.update(&L1Rewards::new(3)).unwrap_err();
    assert!(is_heads(&err), "{err}");
}
