//! What tells one configuration from another ([`RunKey`]): the identity
//! under which reports pool runs as seeds of one configuration and `fmsr run`
//! finds the shipped policy of a run's configuration. Its words are the
//! configuration's label ([`ExperimentConfig::label`]); the key, not the
//! words, is compared.

use std::fmt;

use fmsr_core::method::Method;
use fmsr_core::shadow::ShadowConfig;
use fmsr_core::sharing::{ShareMode, ShareTarget};
use fmsr_envs::shadow_hand::GoalDistance;
use fmsr_nn::{CriticTying, NormalizerStats, TargetClip, Teammates};

use super::{ActorView, Engine, ExperimentConfig, Stack};
use crate::algorithms::AlgorithmSettings;

/// A configuration's identity: its method and every way it departs from the
/// method as the paper runs it, in a fixed order; see [`Distinction`].
///
/// ```
/// use fmsr::experiment::{Distinction, ExperimentConfig};
/// let text = "name = \"x\"\nmethod = \"dense\"\nalgorithm = \"matd3\"\nengine = \"mujoco\"\n";
/// let key = ExperimentConfig::from_toml(text, "x.toml".as_ref())?.key();
/// assert_eq!(key.distinctions, [Distinction::Algorithm("MATD3".into()), Distinction::TrainedOnMujoco]);
/// assert_eq!(key.to_string(), "Dense, MATD3, trained on MuJoCo");
/// # Ok::<(), fmsr::error::ExperimentError>(())
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RunKey {
    /// One of the paper's four configurations.
    pub method: Method,
    /// How this configuration departs from the method as the paper runs it.
    pub distinctions: Vec<Distinction>,
}

/// One way a configuration departs from its method as the paper runs it, so
/// that an ablation, another task, algorithm or engine is never pooled with
/// the method's runs.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Distinction {
    /// The hand split into other than the paper's six agents.
    Agents(usize),
    /// The actors' loss takes the teammates' current policies ([`Teammates::Current`]).
    CurrentTeammates,
    /// Actors observe the global state ([`ActorView::Global`]).
    GlobalActors,
    /// Success by the rotation about Z alone, the task of the oldest records ([`GoalDistance::Yaw`]).
    YawDistance,
    /// gym's distance alone, without the rest of the paper's stack.
    GymDistance,
    /// HER baselines' critic target clip alone.
    HerTargetClip,
    /// HER baselines' normaliser statistics alone.
    HerNormaliserStats,
    /// The paper's stack ([`Stack::Paper`]).
    PaperStack,
    /// A shadow-reward weight other than the default, as the bits of the `f64`.
    Alpha(u64),
    /// Information sharing on gradients.
    SharingGradients,
    /// Information sharing on the critics.
    SharingCritics,
    /// Information sharing on the actors and the critics.
    SharingBoth,
    /// One critic trunk for all agents, a head each.
    SharedCriticTrunk,
    /// One critic for all agents.
    SharedCritic,
    /// An algorithm other than MADDPG, by the name it is shown by.
    Algorithm(String),
    /// Trained on MuJoCo.
    TrainedOnMujoco,
    /// A task other than the Shadow Hand, by its registered name.
    Task(String),
}

impl fmt::Display for Distinction {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Agents(n) => write!(f, "{n} agent{}", if *n == 1 { "" } else { "s" }),
            Self::CurrentTeammates => f.write_str("current teammates"),
            Self::GlobalActors => f.write_str("global actors"),
            Self::YawDistance => f.write_str("yaw distance"),
            Self::GymDistance => f.write_str("gym distance"),
            Self::HerTargetClip => f.write_str("HER target clip"),
            Self::HerNormaliserStats => f.write_str("HER normaliser statistics"),
            Self::PaperStack => f.write_str("paper stack"),
            Self::Alpha(bits) => write!(f, "alpha {}", f64::from_bits(*bits)),
            Self::SharingGradients => f.write_str("IS on gradients"),
            Self::SharingCritics => f.write_str("IS on critics"),
            Self::SharingBoth => f.write_str("IS on actors and critics"),
            Self::SharedCriticTrunk => f.write_str("shared critic trunk"),
            Self::SharedCritic => f.write_str("shared critic"),
            Self::Algorithm(name) | Self::Task(name) => f.write_str(name),
            Self::TrainedOnMujoco => f.write_str("trained on MuJoCo"),
        }
    }
}

impl fmt::Display for RunKey {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.method.label())?;
        for d in &self.distinctions {
            write!(f, ", {d}")?;
        }
        Ok(())
    }
}

impl ExperimentConfig {
    /// The configuration's identity ([`RunKey`]): its method, then, in this
    /// order, the number of agents when the hand is not split into the
    /// paper's six; `current teammates` ([`Teammates::Current`]), `global
    /// actors` ([`ActorView::Global`]); `yaw distance` for the task of the
    /// oldest records; `paper stack` under [`Stack::Paper`], otherwise `gym
    /// distance`, `HER target clip` and `HER normaliser statistics` for each
    /// of its settings alone; the shadow rewards' `alpha` where it is not the
    /// default 0.1; information sharing's mode and target where they are not
    /// the paper's parameters and actors; a shared critic (trunk)
    /// ([`CriticTying`]); the algorithm when it is not MADDPG (an algorithm
    /// this process has not registered, a saved run's read where its crate is
    /// absent, by its name in capitals); `trained on MuJoCo`; and the task
    /// when it is not the Shadow Hand.
    #[must_use]
    pub fn key(&self) -> RunKey {
        let mut d = Vec::new();
        if let Some(agents) = &self.env.agents
            && agents.len() != fmsr_envs::shadow_hand::HandAgent::paper().len()
        {
            d.push(Distinction::Agents(agents.len()));
        }
        let algorithm = self.algorithm_settings().ok();
        let teammates = algorithm.as_ref().map(AlgorithmSettings::teammates);
        if teammates == Some(Teammates::Current) {
            d.push(Distinction::CurrentTeammates);
        }
        if self.graph.actor_observation == ActorView::Global {
            d.push(Distinction::GlobalActors);
        }
        match (self.stack, self.env.goal_distance) {
            (_, GoalDistance::Yaw) => d.push(Distinction::YawDistance),
            (Stack::Fmsr, GoalDistance::Gym) => d.push(Distinction::GymDistance),
            _ => {}
        }
        if self.stack == Stack::Fmsr && self.networks.target_clip == TargetClip::HerBaselines {
            d.push(Distinction::HerTargetClip);
        }
        if self.stack == Stack::Fmsr && self.networks.normalizer_stats == NormalizerStats::StoredEpisodes {
            d.push(Distinction::HerNormaliserStats);
        }
        if self.stack == Stack::Paper {
            d.push(Distinction::PaperStack);
        }
        let alpha = self.trainer.shadow.alpha;
        if self.method.shadow() && alpha != ShadowConfig::default().alpha {
            d.push(Distinction::Alpha(alpha.to_bits()));
        }
        if self.method.sharing() {
            let (mode, target) = self
                .sharing
                .as_ref()
                .map_or_else(|| (ShareMode::default(), ShareTarget::default()), |s| (s.mode, s.target));
            if mode == ShareMode::Gradients {
                d.push(Distinction::SharingGradients);
            }
            match target {
                ShareTarget::Actors => {}
                ShareTarget::Critics => d.push(Distinction::SharingCritics),
                ShareTarget::Both => d.push(Distinction::SharingBoth),
            }
        }
        match self.networks.critic {
            CriticTying::PerAgent => {}
            CriticTying::SharedTrunk => d.push(Distinction::SharedCriticTrunk),
            CriticTying::Shared => d.push(Distinction::SharedCritic),
        }
        match algorithm {
            Some(settings) => d.extend(settings.label().map(Distinction::Algorithm)),
            None => d.push(Distinction::Algorithm(self.algorithm.to_uppercase())),
        }
        if self.engine == Engine::Mujoco && self.is_shadow_hand() {
            d.push(Distinction::TrainedOnMujoco);
        }
        if !self.is_shadow_hand() {
            d.push(Distinction::Task(self.task.clone()));
        }
        RunKey { method: self.method, distinctions: d }
    }
}
