//! `fmsr eval` of a registered task ([`crate::tasks`]): the measures every
//! task has, where the Shadow Hand's evaluation ([`crate::evaluate`]) also
//! measures the grasp.
//!
//! The policy plays the episodes of the chosen set deterministically. An
//! episode **succeeds** as a Shadow Hand episode does at test time: the
//! environment says success at its last step
//! ([`StepInfo::is_success`](fmsr_core::spec::StepInfo)) and it never said
//! dropped. The report gives the success rate with its 95 % Wilson interval,
//! the drops, each stability feature's rate (the share of steps it was on,
//! over every episode), every episode's final goal distance, the task's own
//! measures ([`Task::measure`](crate::tasks::Task::measure)) of every episode
//! with their mean and standard deviation across the episodes, and the same
//! episodes played with the zero action, the chance level the success is
//! compared with.

use std::time::Instant;

use fmsr_core::interval::Interval;
use fmsr_core::prelude::*;
use serde::{Deserialize, Serialize};

use crate::artefacts::{RunDir, Source};
use crate::error::ExperimentError;
use crate::experiment::{EpisodeSet, ExperimentConfig};

/// One episode of a task's evaluation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TaskEpisode {
    /// The seed of its reset.
    pub seed: u64,
    /// Success at the last step, never dropped.
    pub success: bool,
    /// Whether any step said dropped.
    pub dropped: bool,
    /// The goal distance after the last step.
    pub final_distance: f32,
    /// The task's own measures of the episode, in the order of
    /// [`TaskEvalReport::measures`].
    #[serde(default)]
    pub measures: Vec<f64>,
}

/// The evaluation of a registered task's policy, as `fmsr eval` writes it
/// (`task-eval.json`, `task-eval-validation.json` in a run directory).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TaskEvalReport {
    /// The run's name.
    pub name: String,
    /// The run's label ([`ExperimentConfig::label`]).
    pub method: String,
    /// The task's registered name.
    pub task: String,
    /// Epochs the policy trained.
    pub epochs: usize,
    /// The episodes' set.
    pub set: EpisodeSet,
    /// Episodes played.
    pub episodes: usize,
    /// Episodes that succeeded.
    pub successes: usize,
    /// Episodes with a drop.
    pub drops: usize,
    /// The stability features' names.
    pub features: Vec<String>,
    /// Each feature's rate over every step of every episode.
    pub feature_rates: Vec<f64>,
    /// The names of the task's own measures
    /// ([`Task::MEASURES`](crate::tasks::Task::MEASURES)), whose values each
    /// episode's record holds.
    #[serde(default)]
    pub measures: Vec<String>,
    /// Successes of the zero action on the same episodes.
    pub still_successes: usize,
    /// Every episode, in seed order.
    pub records: Vec<TaskEpisode>,
    /// Seconds the evaluation took.
    pub seconds: f64,
}

impl TaskEvalReport {
    /// The success rate with its 95 % Wilson interval.
    #[must_use]
    pub fn success(&self) -> Option<Interval> {
        Interval::wilson(self.successes, self.episodes)
    }

    /// The zero action's success rate with its 95 % Wilson interval.
    #[must_use]
    pub fn still_success(&self) -> Option<Interval> {
        Interval::wilson(self.still_successes, self.episodes)
    }

    /// The task's measure `i` ([`TaskEvalReport::measures`]): its mean and
    /// standard deviation across the episodes; `None` for no such measure
    /// or no episode.
    #[must_use]
    pub fn measure(&self, i: usize) -> Option<MeanStd> {
        let values: Option<Vec<f64>> = self.records.iter().map(|r| r.measures.get(i).copied()).collect();
        MeanStd::from_samples(&values?)
    }

    /// A Markdown table of the evaluation.
    #[must_use]
    pub fn to_markdown(&self) -> String {
        let cell = |i: Option<Interval>| {
            i.map_or_else(|| "-".into(), |i| format!("{:.2} [{:.2}, {:.2}]", i.estimate, i.lower, i.upper))
        };
        let mut text = format!(
            "| {} ({}), task `{}`, {} set, {} epochs | |\n|---|---|\n| success | {} |\n| zero action | {} |\n| drops | {} of {} |\n",
            self.name,
            self.method,
            self.task,
            self.set.key(),
            self.epochs,
            cell(self.success()),
            cell(self.still_success()),
            self.drops,
            self.episodes
        );
        for (name, rate) in self.features.iter().zip(&self.feature_rates) {
            text.push_str(&format!("| feature `{name}` | {rate:.3} |\n"));
        }
        for (i, name) in self.measures.iter().enumerate() {
            let value = self.measure(i).map_or_else(|| "-".into(), |m| format!("{m:.3}"));
            text.push_str(&format!("| measure `{name}` (mean ± std) | {value} |\n"));
        }
        text
    }

    /// Where a run's evaluation of `set` goes.
    #[must_use]
    pub fn path_in(dir: &RunDir, set: EpisodeSet) -> std::path::PathBuf {
        match set {
            EpisodeSet::Test => dir.root().join("task-eval.json"),
            EpisodeSet::Validation => dir.root().join("task-eval-validation.json"),
        }
    }
}

/// Evaluates the policy of `source` on the registered task of `config` (the
/// source's, possibly with another number of episodes), on
/// `config.eval.episodes` episodes of `set`, and returns the evaluation
/// without writing it.
///
/// # Errors
/// [`ExperimentError::Config`] for the Shadow Hand (evaluated by
/// [`crate::evaluate`]) or a task not registered; the errors of the policy,
/// the environment and the task's measures ([`crate::tasks::TaskSettings::measure`]).
pub fn evaluate_task(
    config: &ExperimentConfig,
    set: EpisodeSet,
    source: &Source,
) -> Result<TaskEvalReport, ExperimentError> {
    let start = Instant::now();
    if config.is_shadow_hand() {
        return Err(ExperimentError::config("task", "the Shadow Hand is evaluated by fmsr::evaluate"));
    }
    let settings = config.task_settings()?;
    let env = settings.envs(1)?.pop().ok_or_else(|| ExperimentError::config("task", "no environment"))?;
    let features = env.spec().features.clone();
    let mut trainer = config.build_trainer(vec![env])?;
    let epochs = source.load_into(&mut trainer)?;
    let seeds = config.eval.seeds_of(set, config.eval.episodes);
    let mut records = Vec::with_capacity(seeds.len());
    let (mut on, mut steps) = (vec![0.0_f64; features.len()], 0_usize);
    for &seed in &seeds {
        let episode = trainer.rollout_with(seed, ActMode::Evaluate, &mut |_, _| {})?;
        for info in &episode.infos {
            for (sum, phi) in on.iter_mut().zip(&info.features) {
                *sum += f64::from(*phi);
            }
        }
        steps += episode.infos.len();
        let dropped = episode.infos.iter().any(|i| i.dropped);
        let final_distance = episode
            .observations
            .last()
            .map_or(f32::INFINITY, |o| trainer.env().goal_distance(&o.achieved_goal, &o.desired_goal));
        let success = episode.infos.last().is_some_and(|i| i.is_success) && !dropped;
        let measures = settings.measure(trainer.env(), &episode).map_err(|e| ExperimentError::Context {
            what: format!("measuring the evaluation episode of seed {seed}"),
            source: Box::new(e),
        })?;
        records.push(TaskEpisode { seed, success, dropped, final_distance, measures });
    }
    let still_successes = zero_action_successes(trainer.env_mut(), &seeds)?;
    Ok(TaskEvalReport {
        name: config.name.clone(),
        method: config.label(),
        task: config.task.clone(),
        epochs,
        set,
        episodes: seeds.len(),
        successes: records.iter().filter(|r| r.success).count(),
        drops: records.iter().filter(|r| r.dropped).count(),
        features,
        feature_rates: on.iter().map(|s| s / steps.max(1) as f64).collect(),
        measures: settings.measures().iter().map(|&m| m.to_owned()).collect(),
        still_successes,
        records,
        seconds: start.elapsed().as_secs_f64(),
    })
}

/// Successes of the zero action on the episodes of `seeds`.
fn zero_action_successes<E: Env>(env: &mut E, seeds: &[u64]) -> Result<usize, ExperimentError> {
    let spec = env.spec().clone();
    let zero = JointAction::zeros(spec.action_dim);
    let env_err = |e: E::Error| ExperimentError::Core(CoreError::Env(Box::new(e)));
    let mut successes = 0;
    for &seed in seeds {
        env.reset(seed).map_err(env_err)?;
        let (mut dropped, mut success) = (false, false);
        for _ in 0..spec.episode_len {
            let outcome = env.step(&zero).map_err(env_err)?;
            dropped |= outcome.info.dropped;
            success = outcome.info.is_success;
        }
        successes += usize::from(success && !dropped);
    }
    Ok(successes)
}
