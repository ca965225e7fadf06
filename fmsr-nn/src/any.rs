//! Learners chosen at run time, by name: the `algorithm` of an experiment.
//!
//! [`AnyLearner`] holds an [`OffPolicy`] learner of any update rule behind
//! the traits the trainer needs, so that a trainer's type does not name the
//! algorithm. A rule that experiment configs can name implements
//! [`ConfiguredRule`]: its settings (the `[<NAME>]` section of a config) and
//! how the rule is made from them. MADDPG, MATD3 and MASAC are three such
//! rules; a rule of a user's crate is a fourth on the same terms (the `fmsr`
//! crate's `algorithms` registry finds them by name).

use std::any::Any;
use std::fmt::Debug;

use fmsr_core::algorithm::{Algorithm, RewardModel, UpdateStats};
use fmsr_core::policy::{ActMode, Policy, PolicyOutput, PolicyState};
use fmsr_core::replay::Episode;
use serde::Serialize;
use serde::de::DeserializeOwned;

use crate::config::{MaddpgConfig, MasacConfig, Matd3Config, Teammates};
use crate::error::NnError;
use crate::off_policy::{OffPolicy, UpdateRule};
use crate::{MaddpgRule, MasacRule, Matd3Rule};

/// An update rule that experiment configs name: `algorithm = "<NAME>"`
/// ([`UpdateRule::NAME`]), its settings in the config's `[<NAME>]` section.
///
/// ```
/// use fmsr_nn::{ConfiguredRule, MaddpgRule, Matd3Rule, UpdateRule};
/// assert_eq!(MaddpgRule::NAME, "maddpg");
/// assert_eq!(MaddpgRule::label(), None); // the paper's algorithm: runs are labelled by method alone
/// assert_eq!(Matd3Rule::label().as_deref(), Some("MATD3"));
/// assert!(Matd3Rule::from_config(Matd3Rule::default_config()).validate().is_ok());
/// ```
pub trait ConfiguredRule: UpdateRule {
    /// The settings of the rule's config section. A config names any of
    /// them; the others take [`ConfiguredRule::default_config`]'s values.
    type Config: Serialize + DeserializeOwned + Clone + Debug + PartialEq + Send + Sync + 'static;

    /// The settings a config leaves out.
    fn default_config() -> Self::Config;

    /// The rule with these settings (checked by [`UpdateRule::validate`]).
    fn from_config(config: Self::Config) -> Self;

    /// Which teammates' actions the actors' loss takes with these settings;
    /// runs that take the current policies' are labelled apart.
    fn teammates(_config: &Self::Config) -> Teammates {
        Teammates::Replay
    }

    /// The algorithm's name in run labels (`"MATD3"`: `Dense, MATD3`); `None`
    /// for the paper's own, whose runs are labelled by their method alone.
    #[must_use]
    fn label() -> Option<String> {
        Some(Self::NAME.to_uppercase())
    }
}

impl ConfiguredRule for MaddpgRule {
    type Config = MaddpgConfig;

    fn default_config() -> MaddpgConfig {
        MaddpgConfig::new()
    }

    fn from_config(config: MaddpgConfig) -> Self {
        Self::new(config)
    }

    fn teammates(config: &MaddpgConfig) -> Teammates {
        config.teammates
    }

    fn label() -> Option<String> {
        None
    }
}

impl ConfiguredRule for Matd3Rule {
    type Config = Matd3Config;

    fn default_config() -> Matd3Config {
        Matd3Config::new()
    }

    fn from_config(config: Matd3Config) -> Self {
        Self::new(config)
    }

    fn teammates(config: &Matd3Config) -> Teammates {
        config.teammates
    }
}

impl ConfiguredRule for MasacRule {
    type Config = MasacConfig;

    fn default_config() -> MasacConfig {
        MasacConfig::new()
    }

    fn from_config(config: MasacConfig) -> Self {
        Self::new(config)
    }

    fn teammates(config: &MasacConfig) -> Teammates {
        config.teammates
    }
}

/// What [`AnyLearner`] needs of the learner it holds; every
/// `OffPolicy<R>` has it.
trait Erased: Algorithm + PolicyState + Policy<Error = NnError> + Send + Debug {
    fn name(&self) -> &'static str;
    fn actor_trunk(&self, agent: usize) -> Result<Vec<f32>, NnError>;
    fn params(&self, agent: usize) -> Result<(Vec<f32>, Vec<f32>), NnError>;
    fn as_any(&self) -> &dyn Any;
}

impl<R: UpdateRule> Erased for OffPolicy<R> {
    fn name(&self) -> &'static str {
        R::NAME
    }

    fn actor_trunk(&self, agent: usize) -> Result<Vec<f32>, NnError> {
        OffPolicy::actor_trunk(self, agent)
    }

    fn params(&self, agent: usize) -> Result<(Vec<f32>, Vec<f32>), NnError> {
        OffPolicy::params(self, agent)
    }

    fn as_any(&self) -> &dyn Any {
        self
    }
}

/// A learner of any update rule, chosen at run time, behind the traits a
/// trainer needs ([`Policy`], [`Algorithm`], [`PolicyState`]): what the
/// `fmsr` crate's experiment factory builds from a config's `algorithm`.
///
/// ```
/// use fmsr_core::prelude::*;
/// use fmsr_nn::prelude::*;
/// use fmsr_nn::Matd3;
/// let agent = |n: &str, s: Vec<usize>| AgentSpec { name: n.into(), action_slots: s, local_obs_dim: 3 };
/// let spec = EnvSpec { agents: vec![agent("a", vec![0]), agent("b", vec![1, 2])], action_dim: 3, obs_dim: 4,
///     goal_dim: 2, episode_len: 10, features: vec![], reward_range: (-1.0, 0.0) };
/// let layout = ObservationLayout::new(spec, vec![vec![1], vec![0]])?;
/// let parts = LearnerParts::new(layout, NetworkConfig::new().with_hidden(16).with_layers(2), ReplayConfig::default(), 0.9);
/// let learner = AnyLearner::new(Matd3::new(parts, Matd3Config::new())?);
/// assert_eq!(learner.name(), "matd3");
/// assert!(learner.downcast_ref::<Matd3>().is_some() && learner.downcast_ref::<Maddpg>().is_none());
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug)]
pub struct AnyLearner(Box<dyn Erased>);

impl AnyLearner {
    /// Holds `learner`.
    #[must_use]
    pub fn new<R: UpdateRule>(learner: OffPolicy<R>) -> Self {
        Self(Box::new(learner))
    }

    /// The algorithm's name ([`UpdateRule::NAME`], e.g. `"maddpg"`).
    #[must_use]
    pub fn name(&self) -> &'static str {
        self.0.name()
    }

    /// The learner, if it is an `L` (e.g. [`crate::Maddpg`]).
    #[must_use]
    pub fn downcast_ref<L: 'static>(&self) -> Option<&L> {
        self.0.as_any().downcast_ref()
    }

    /// Agent `agent`'s actor trunk, flattened (what information sharing mixes).
    ///
    /// # Errors
    /// [`NnError::UnknownAgent`].
    pub fn actor_trunk(&self, agent: usize) -> Result<Vec<f32>, NnError> {
        self.0.actor_trunk(agent)
    }

    /// All parameters of agent `agent`'s online actor and (first) critic, flattened.
    ///
    /// # Errors
    /// [`NnError::UnknownAgent`], backend errors.
    pub fn params(&self, agent: usize) -> Result<(Vec<f32>, Vec<f32>), NnError> {
        self.0.params(agent)
    }
}

impl<R: UpdateRule> From<OffPolicy<R>> for AnyLearner {
    fn from(learner: OffPolicy<R>) -> Self {
        Self::new(learner)
    }
}

impl Policy for AnyLearner {
    type Error = NnError;

    fn num_agents(&self) -> usize {
        self.0.num_agents()
    }

    fn act(&mut self, inputs: &[Vec<f32>], n: usize, mode: ActMode) -> Result<PolicyOutput, NnError> {
        self.0.act(inputs, n, mode)
    }
}

impl Algorithm for AnyLearner {
    fn store(&mut self, episode: &Episode) -> Result<(), NnError> {
        self.0.store(episode)
    }

    fn update(&mut self, rewards: &dyn RewardModel) -> Result<UpdateStats, NnError> {
        self.0.update(rewards)
    }

    fn save_state(&self, include_storage: bool) -> Result<Vec<u8>, NnError> {
        self.0.save_state(include_storage)
    }

    fn load_state(&mut self, bytes: &[u8]) -> Result<(), NnError> {
        self.0.load_state(bytes)
    }

    fn load_rescue_state(&mut self, bytes: &[u8]) -> Result<(), NnError> {
        self.0.load_rescue_state(bytes)
    }

    fn storage_capacity(&self) -> usize {
        self.0.storage_capacity()
    }

    fn restore_storage(&mut self, total: u64, episodes: &[Episode]) -> Result<(), NnError> {
        self.0.restore_storage(total, episodes)
    }
}

impl PolicyState for AnyLearner {
    fn save_policy(&self) -> Result<Vec<u8>, NnError> {
        self.0.save_policy()
    }

    fn load_policy(&mut self, bytes: &[u8]) -> Result<(), NnError> {
        self.0.load_policy(bytes)
    }
}
