//! The one off-policy learner: [`OffPolicy<R>`] implements [`Policy`],
//! [`Algorithm`] and [`PolicyState`] once, over an update rule (the crate's
//! `UpdateRule` trait) that holds only what makes an algorithm itself (its
//! config, its losses and targets, its own state). MADDPG, MATD3 and MASAC are the three rules
//! ([`crate::Maddpg`] is `OffPolicy<MaddpgRule>`, and so on); everything else,
//! the networks, normalisers, HER replay, information sharing, worker
//! averaging and saved states, is the shared learner (the crate's `learner` module).
//!
//! One update cycle (Algorithm 1, stages 2-4):
//!
//! ```text
//! repeat `replay.batches` times: sample a HER batch (rewards r_i from the trainer's
//!     RewardModel, eq. 7), then the rule's step: critics, actors, sharing hooks
//! then the targets move once: theta' <- polyak theta' + (1 - polyak) theta   (eq. 9)
//! ```
//!
//! A rule is public: an algorithm of your own crate is a struct and this
//! trait, written against the learner's public view ([`Learner`]: target
//! actions, the critic step, the deterministic actor step and acting; their
//! stochastic twins for squashed Gaussian policies; the step index and the RNG), and `OffPolicy<YourRule>` is then a whole learner with
//! everything above, resumable and exportable (the `fmsr` crate's
//! `examples/custom_algorithm.rs`: IDDPG in one short file). The learner
//! counts the steps, applies information sharing and worker averaging inside
//! the steps it offers, moves the targets and saves the state.

use fmsr_core::algorithm::{Algorithm, RewardModel, UpdateStats};
use fmsr_core::policy::{ActMode, Policy, PolicyOutput, PolicyState};
use fmsr_core::replay::Episode;

use crate::config::CriticView;
use crate::error::NnError;
use crate::learner::{BatchTensors, Learner, LearnerParts};
use crate::state::RuleState;

/// What distinguishes one off-policy algorithm; see the [module docs](self).
///
/// A rule holds its config and its own state. The learner builds `CRITICS`
/// critics per agent that see `CRITIC_VIEW`, actor heads of `HEADS` blocks,
/// and calls [`UpdateRule::step`] `replay.batches` times a cycle on sampled
/// HER batches, counting the steps ([`Learner::step_index`]) itself. A rule
/// with state of its own beside the networks (MASAC's temperatures) saves it
/// as a versioned [`RuleState`]; a rule without any implements neither
/// [`UpdateRule::state`] nor [`UpdateRule::restore`] and writes nothing.
pub trait UpdateRule: std::fmt::Debug + Clone + Send + 'static {
    /// The name saved states and policy states carry (`"maddpg"`).
    const NAME: &'static str;
    /// Critics per agent (2 for twin critics).
    const CRITICS: usize = 1;
    /// Output blocks of each actor head (2 for a Gaussian's mean and log-std).
    const HEADS: usize = 1;
    /// What each agent's critic sees.
    const CRITIC_VIEW: CriticView = CriticView::Global;

    /// Checks the rule's own settings.
    ///
    /// # Errors
    /// [`NnError::InvalidConfig`] naming the first impossible setting.
    fn validate(&self) -> Result<(), NnError> {
        Ok(())
    }

    /// Prepares the rule's own state for a learner of `agents` agents.
    fn init(&mut self, _agents: usize) {}

    /// Acts for all agents (`n` rows of inputs each), exploring in [`ActMode::Explore`].
    ///
    /// # Errors
    /// Backend and shape errors.
    fn act(&mut self, l: &mut Learner, inputs: &[Vec<f32>], n: usize, mode: ActMode) -> Result<PolicyOutput, NnError>;

    /// One gradient step on a sampled batch: the critics, and the actors when
    /// the rule updates them at this step.
    ///
    /// # Errors
    /// Backend and shape errors.
    fn step(&mut self, l: &mut Learner, b: &BatchTensors) -> Result<StepLosses, NnError>;

    /// How the targets move after a cycle: `polyak` and whether the actors have targets.
    fn targets(&self) -> (f64, bool);

    /// The rule's own state, to save with the learner (`None`: it has none).
    ///
    /// # Errors
    /// [`NnError::Backend`] when it does not encode.
    fn state(&self) -> Result<Option<RuleState>, NnError> {
        Ok(None)
    }

    /// Restores the saved state of a learner of `agents` agents (`None`
    /// when the state holds none). The learner calls this on a copy of the
    /// rule before it changes anything, so an error leaves both as they were.
    ///
    /// # Errors
    /// [`NnError::StateMismatch`] / [`NnError::CorruptState`] naming what does not fit.
    fn restore(&mut self, state: Option<&RuleState>, _agents: usize) -> Result<(), NnError> {
        match state {
            None => Ok(()),
            Some(s) => Err(NnError::StateMismatch {
                what: format!("{} state", Self::NAME),
                expected: "none".into(),
                found: format!("version {}, {} bytes", s.version, s.bytes.len()),
            }),
        }
    }
}

/// Each agent's losses of one gradient step.
#[derive(Debug, Clone, PartialEq)]
pub struct StepLosses {
    /// Critic (TD) loss of each agent.
    pub critic: Vec<f32>,
    /// Actor loss of each agent, when the step updated the actors.
    pub actor: Option<Vec<f32>>,
}

/// An off-policy learner with update rule `R`; see the [module docs](self).
#[derive(Debug)]
pub struct OffPolicy<R> {
    pub(crate) learner: Learner,
    pub(crate) rule: R,
}

impl<R: UpdateRule> OffPolicy<R> {
    /// The learner of `rule` from the shared parts.
    ///
    /// # Errors
    /// [`NnError::InvalidConfig`] / [`NnError::Sharing`] naming the first impossible setting.
    pub fn with_rule(parts: LearnerParts, mut rule: R) -> Result<Self, NnError> {
        rule.validate()?;
        let learner = Learner::new(parts, R::CRITICS, R::HEADS, R::CRITIC_VIEW)?;
        rule.init(learner.num_agents());
        Ok(Self { learner, rule })
    }

    /// The update rule (the algorithm's config and own state).
    #[must_use]
    pub fn rule(&self) -> &R {
        &self.rule
    }

    /// One gradient step of the rule; `None` while the replay is empty.
    ///
    /// # Errors
    /// Backend and shape errors.
    pub fn step(&mut self, rewards: &dyn RewardModel) -> Result<Option<StepLosses>, NnError> {
        let Some(b) = self.learner.sample(rewards)? else { return Ok(None) };
        self.rule_step(&b).map(Some)
    }

    /// The rule's step on `b`, counted.
    pub(crate) fn rule_step(&mut self, b: &BatchTensors) -> Result<StepLosses, NnError> {
        let losses = self.rule.step(&mut self.learner, b)?;
        self.learner.steps += 1;
        Ok(losses)
    }

    /// Moves the target networks towards the online networks (eq. 9); the
    /// update cycle does this once per cycle.
    pub fn update_targets(&mut self) {
        let (polyak, actors) = self.rule.targets();
        self.learner.soft_update_targets(polyak, actors);
    }

    /// Agent `agent`'s actor trunk, flattened (what information sharing mixes).
    ///
    /// # Errors
    /// [`NnError::UnknownAgent`].
    pub fn actor_trunk(&self, agent: usize) -> Result<Vec<f32>, NnError> {
        self.learner.actor_trunk(agent)
    }

    /// Replaces agent `agent`'s actor trunk.
    ///
    /// # Errors
    /// [`NnError::UnknownAgent`], [`NnError::Dimension`].
    pub fn set_actor_trunk(&mut self, agent: usize, trunk: &[f32]) -> Result<(), NnError> {
        self.learner.set_actor_trunk(agent, trunk)
    }

    /// Agent `agent`'s critic trunk, flattened.
    ///
    /// # Errors
    /// [`NnError::UnknownAgent`].
    pub fn critic_trunk(&self, agent: usize) -> Result<Vec<f32>, NnError> {
        self.learner.critic_trunk(agent)
    }

    /// All parameters of agent `agent`'s online actor and (first) critic, flattened.
    ///
    /// # Errors
    /// [`NnError::UnknownAgent`], backend errors.
    pub fn params(&self, agent: usize) -> Result<(Vec<f32>, Vec<f32>), NnError> {
        self.learner.params(agent)
    }

    /// `Q_i(x, g, a)` of agent `agent`'s (first) online critic for `n` rows of
    /// raw observations, goals and joint actions (in the environment's slot order).
    ///
    /// # Errors
    /// [`NnError::UnknownAgent`], [`NnError::Dimension`] / [`NnError::NotFinite`].
    pub fn q_values(
        &self,
        agent: usize,
        obs: &[f32],
        goals: &[f32],
        actions: &[f32],
        n: usize,
    ) -> Result<Vec<f32>, NnError> {
        self.learner.q_values(agent, obs, goals, actions, n)
    }

    /// Transitions stored in the replay buffer.
    #[must_use]
    pub fn replay_len(&self) -> usize {
        self.learner.replay.transitions()
    }
}

/// Runs `batches` steps and averages their losses (actor losses over the
/// steps that updated the actors).
fn run_cycle(
    batches: usize,
    agents: usize,
    mut step: impl FnMut() -> Result<Option<StepLosses>, NnError>,
) -> Result<UpdateStats, NnError> {
    let mut stats =
        UpdateStats { updates: 0, critic_loss: vec![0.0; agents], actor_loss: vec![0.0; agents], ..Default::default() };
    let mut actor_steps = 0usize;
    for _ in 0..batches {
        let Some(StepLosses { critic, actor }) = step()? else { break };
        stats.updates += 1;
        stats.critic_loss.iter_mut().zip(&critic).for_each(|(a, v)| *a += f64::from(*v));
        if let Some(actor) = actor {
            actor_steps += 1;
            stats.actor_loss.iter_mut().zip(&actor).for_each(|(a, v)| *a += f64::from(*v));
        }
    }
    let n = stats.updates.max(1) as f64;
    stats.critic_loss.iter_mut().for_each(|v| *v /= n);
    stats.actor_loss.iter_mut().for_each(|v| *v /= actor_steps.max(1) as f64);
    Ok(stats)
}

impl<R: UpdateRule> Policy for OffPolicy<R> {
    type Error = NnError;

    fn num_agents(&self) -> usize {
        self.learner.num_agents()
    }

    fn act(&mut self, inputs: &[Vec<f32>], n: usize, mode: ActMode) -> Result<PolicyOutput, NnError> {
        self.rule.act(&mut self.learner, inputs, n, mode)
    }
}

impl<R: UpdateRule> Algorithm for OffPolicy<R> {
    fn store(&mut self, episode: &Episode) -> Result<(), NnError> {
        self.learner.store(episode)
    }

    fn update(&mut self, rewards: &dyn RewardModel) -> Result<UpdateStats, NnError> {
        let (batches, agents) = (self.learner.replay_config.batches, self.learner.num_agents());
        let mut stats = run_cycle(batches, agents, || self.step(rewards))?;
        if stats.updates > 0 {
            self.update_targets();
        }
        self.learner.diagnostics.take_into(&mut stats);
        Ok(stats)
    }

    fn save_state(&self, include_storage: bool) -> Result<Vec<u8>, NnError> {
        self.learner.save(R::NAME, include_storage, self.rule.state()?)
    }

    fn load_state(&mut self, bytes: &[u8]) -> Result<(), NnError> {
        self.load_learner(bytes, false)
    }

    fn load_rescue_state(&mut self, bytes: &[u8]) -> Result<(), NnError> {
        self.load_learner(bytes, true)
    }

    fn storage_capacity(&self) -> usize {
        self.learner.storage_capacity()
    }

    fn restore_storage(&mut self, total: u64, episodes: &[Episode]) -> Result<(), NnError> {
        self.learner.restore_storage(total, episodes)
    }
}

impl<R: UpdateRule> OffPolicy<R> {
    /// [`Algorithm::load_state`], or with `thinned` a rescue state whose
    /// targets and optimiser moments may be absent ([`crate::rescue_state`]).
    fn load_learner(&mut self, bytes: &[u8], thinned: bool) -> Result<(), NnError> {
        let (rule, agents) = (&self.rule, self.learner.num_agents());
        let restored = self.learner.load(R::NAME, bytes, thinned, |state| {
            let mut restored = rule.clone();
            restored.restore(state.as_ref(), agents)?;
            Ok(restored)
        })?;
        self.rule = restored;
        Ok(())
    }
}

impl<R: UpdateRule> PolicyState for OffPolicy<R> {
    fn save_policy(&self) -> Result<Vec<u8>, NnError> {
        self.learner.save_policy(R::NAME)
    }

    fn load_policy(&mut self, bytes: &[u8]) -> Result<(), NnError> {
        self.learner.load_policy(R::NAME, bytes)
    }
}
