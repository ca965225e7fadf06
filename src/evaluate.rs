//! `fmsr eval`: the paper's evaluation of a trained policy on a fixed test set
//! (section IV.C, Tables I and II): success rate at the test threshold, total
//! contacts, `Q_MSV`, `Q_VEW`, `|Q'_MSV|`, `|Q'_VEW|`, `Q_DCC`, and failure types.
//!
//! **Success** at test time is an object *turned and held*: the final rotation
//! error is under the test threshold (paper: 0.4 rad) **and** the object was
//! never dropped ([`classify`]). The paper's Table II counts a drop as a
//! failure; an egg that rolled below the hand into the goal's orientation has
//! not been manipulated. Training keeps gymnasium's definition (the error
//! under the training threshold at the last step, drops not looked at): its
//! reward and "train success" follow HER's, and the per-epoch "eval success"
//! in `metrics.csv` is that same flag on deterministic episodes. Evaluations
//! written before this rule carry [`SuccessRule::Reached`] and are marked so.
//!
//! Every success rate is given with its 95 % Wilson interval
//! ([`fmsr_core::interval`]); each episode is recorded ([`EpisodeRecord`]).

use std::fmt::Write as _;
use std::time::Instant;

use serde::{Deserialize, Serialize};

use fmsr_core::metrics::{
    EpisodeOutcome, EpisodeSummary, FailureCounts, FailureRow, FailureType, GraspTrace, MeanStd, StabilityRow,
};
use fmsr_core::prelude::*;

use fmsr_core::interval::Interval;

use crate::experiment::{Engine, EpisodeSet, ExperimentConfig, ExperimentError};
use crate::policy_file::Source;
use crate::run::RunDir;

/// The per-step series of one test episode (the paper's Fig. 4).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct EpisodeTrace {
    /// The episode's seed.
    pub seed: u64,
    /// Active touch sensors per step.
    pub contacts: Vec<usize>,
    /// `Q_MSV` per step.
    pub q_msv: Vec<f64>,
    /// `Q_VEW` per step.
    pub q_vew: Vec<f64>,
    /// `|Q'_MSV|` per step difference.
    pub dq_msv: Vec<f64>,
    /// `|Q'_VEW|` per step difference.
    pub dq_vew: Vec<f64>,
    /// `Q_DCC` per step (m; `None` without contacts).
    pub q_dcc: Vec<Option<f64>>,
    /// Goal distance per step (rad).
    pub goal_distance: Vec<f32>,
}

/// What an evaluation counted as a success.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SuccessRule {
    /// Final rotation error under the threshold, whether or not the object
    /// was dropped: evaluations written before 2026-11-25 (commit after `bc9bb0c`).
    Reached,
    /// Final rotation error under the threshold and never dropped.
    ReachedAndHeld,
}

impl SuccessRule {
    /// The rule of files that do not name one: the old one.
    fn legacy() -> Self {
        Self::Reached
    }

    /// In words, for tables.
    #[must_use]
    pub fn describe(self) -> &'static str {
        match self {
            Self::Reached => "old definition: drops counted as successes when the final angle was within the threshold",
            Self::ReachedAndHeld => "turned and held: final angle within the threshold, never dropped",
        }
    }
}

/// One test episode of an evaluation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EpisodeRecord {
    /// The episode's seed.
    pub seed: u64,
    /// Rotation error after the reset (rad).
    pub initial_error: f32,
    /// Rotation error at the last step (rad).
    pub final_error: f32,
    /// Whether the object was dropped at any step.
    pub dropped: bool,
    /// The first step (from 0) at which it was dropped.
    pub drop_step: Option<usize>,
    /// Success, drop or incomplete ([`classify`]).
    pub outcome: EpisodeOutcome,
    /// Active touch sensors summed over the steps (Table I's "Total Contact").
    pub total_contacts: usize,
}

/// The evaluation of one run, as written to `eval.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EvalReport {
    /// The run's name.
    pub name: String,
    /// The configuration's label, e.g. `Dense+FMSR+IS`.
    pub method: String,
    /// The object (`block` or `egg`).
    pub task: String,
    /// The engine of this evaluation.
    pub engine: String,
    /// The engine the policy was trained on (absent in files of older
    /// versions, which evaluated on the training engine only).
    #[serde(default)]
    pub trained_on: Option<String>,
    /// Epochs the policy was trained for.
    pub epochs: usize,
    /// Test episodes.
    pub episodes: usize,
    /// Which episodes were played (absent in older files: the test set).
    #[serde(default)]
    pub set: EpisodeSet,
    /// The success threshold (rad).
    pub threshold: f32,
    /// What counted as a success (absent in older files: [`SuccessRule::Reached`]).
    #[serde(default = "SuccessRule::legacy")]
    pub success_rule: SuccessRule,
    /// Fraction of episodes that succeeded.
    pub success_rate: f64,
    /// Table I's stability measures over the test episodes.
    pub stability: Option<StabilityRow>,
    /// Outcome counts.
    pub outcomes: FailureCounts,
    /// Table II's columns.
    pub failures: FailureRow,
    /// Per-episode grasp measures.
    pub episode_summaries: Vec<EpisodeSummary>,
    /// Every episode: seed, errors, drop, outcome, contacts (absent in older files).
    #[serde(default)]
    pub records: Vec<EpisodeRecord>,
    /// Goal distance of each episode after the reset (rad): files of older
    /// versions only, whose episodes have no [`EpisodeRecord`] (their
    /// `final_distances` are not read).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub initial_distances: Vec<f32>,
    /// The per-step series of the first test episode.
    pub trace: EpisodeTrace,
    /// Wall time of the evaluation (s).
    pub seconds: f64,
}

fn cell(x: Option<MeanStd>, scale: f64, precision: usize) -> String {
    x.map_or_else(|| "n/a".into(), |m| format!("{:.*}±{:.*}", precision, m.mean * scale, precision, m.std * scale))
}

impl EvalReport {
    /// Table I's header, in Markdown.
    #[must_use]
    pub fn table1_header() -> String {
        "| Task | Configuration | Success Rate | Total Contact | Q_MSV | Q_VEW | \\|Q'_MSV\\| | \\|Q'_VEW\\| | Q_DCC (1e-3 m) |\n\
         |---|---|---|---|---|---|---|---|---|\n"
            .into()
    }

    /// This run's row of Table I, in Markdown.
    #[must_use]
    pub fn table1_row(&self) -> String {
        format!(
            "| {} | {} | {} | {} |\n",
            self.task,
            self.method,
            self.success_cell(),
            self.stability_cells().join(" | ")
        )
    }

    /// Table I's stability cells: contacts, Q_MSV, Q_VEW, |Q'_MSV|, |Q'_VEW|, Q_DCC.
    fn stability_cells(&self) -> [String; 6] {
        let s = self.stability.as_ref();
        [
            cell(s.map(|s| s.total_contacts), 1.0, 0),
            cell(s.map(|s| s.q_msv), 1.0, 3),
            cell(s.map(|s| s.q_vew), 1.0, 4),
            cell(s.and_then(|s| s.dq_msv), 1.0, 3),
            cell(s.and_then(|s| s.dq_vew), 1.0, 4),
            cell(s.and_then(|s| s.q_dcc), 1e3, 1),
        ]
    }

    /// The cells of this evaluation in the report's cross-engine table, from
    /// the task on; `trained_on` names the training engine.
    #[must_use]
    pub fn cross_engine_cells(&self, trained_on: &str) -> String {
        let drop = self.failures.drop_percent.map_or_else(|| "n/a".into(), |p| format!("{p:.1}%"));
        format!(
            "{} | {} | {} | {} | {} | {} | {drop}",
            self.task,
            self.method,
            self.trained_on.as_deref().unwrap_or(trained_on),
            self.engine,
            self.success_cell(),
            self.stability_cells().join(" | ")
        )
    }

    /// Table II's header, in Markdown.
    #[must_use]
    pub fn table2_header() -> String {
        "| Task | Configuration | Trials | # of F | Incom | Incom% | Drop | Drop% |\n|---|---|---|---|---|---|---|---|\n"
            .into()
    }

    /// This run's row of Table II, in Markdown.
    #[must_use]
    pub fn table2_row(&self) -> String {
        let pct = |p: Option<f64>| p.map_or_else(|| "n/a".into(), |p| format!("{p:.1}%"));
        let f = &self.failures;
        format!(
            "| {} | {} | {} | {} | {} | {} | {} | {} |\n",
            self.task,
            self.method,
            self.episodes,
            f.failures,
            f.incomplete,
            pct(f.incomplete_percent),
            f.drop,
            pct(f.drop_percent)
        )
    }

    /// The success rate with its 95 % Wilson interval.
    #[must_use]
    pub fn success_interval(&self) -> Option<Interval> {
        Interval::wilson(self.outcomes.successes, self.outcomes.episodes)
    }

    /// The success cell of the tables: `32% [24, 42]`, with `*` for the old
    /// definition ([`SuccessRule::Reached`]).
    #[must_use]
    pub fn success_cell(&self) -> String {
        let mark = if self.success_rule == SuccessRule::Reached { "*" } else { "" };
        self.success_interval().map_or_else(|| "n/a".into(), |i| format!("{}{mark}", i.percent()))
    }

    /// Each episode's rotation error after the reset (rad): from the records,
    /// or the list of older files.
    #[must_use]
    pub fn initial_errors(&self) -> Vec<f32> {
        if self.records.is_empty() {
            self.initial_distances.clone()
        } else {
            self.records.iter().map(|r| r.initial_error).collect()
        }
    }

    /// The chance level of these episodes, with its 95 % interval: the success
    /// of a policy that holds the object still without dropping it, i.e. the
    /// fraction of episodes that start within the threshold (`None` for files
    /// of older versions). A policy that never turns the object does no better
    /// (it may drop it). With the goal and the start drawn uniformly about Z,
    /// it tends to `threshold / pi` (12.7 % at 0.4 rad).
    #[must_use]
    pub fn still_success(&self) -> Option<Interval> {
        let initial = self.initial_errors();
        Interval::wilson(initial.iter().filter(|&&d| d < self.threshold).count(), initial.len())
    }

    /// Success against chance, in words, with both intervals.
    #[must_use]
    pub fn against_chance(&self) -> String {
        let what = format!("{} success {}", self.set.key(), self.success_cell());
        match self.still_success() {
            Some(still) => format!(
                "{what} against {} for a policy that holds the object still (the episodes that start within {} rad); 95 % Wilson intervals",
                still.percent(),
                self.threshold
            ),
            None => format!("{what} (chance level not recorded)"),
        }
    }

    /// Whether `other` has the same results: everything but the wall time
    /// (every episode's outcome, final angle and grasp measures, the trace).
    #[must_use]
    pub fn same_results(&self, other: &EvalReport) -> bool {
        *self == EvalReport { seconds: self.seconds, ..other.clone() }
    }

    /// Both tables for this run.
    #[must_use]
    pub fn to_markdown(&self) -> String {
        let mut out = String::new();
        let _ = writeln!(
            out,
            "{} ({}, {} epochs, {} {} episodes at {} rad, {:.0} s)\n",
            self.name,
            self.engine,
            self.epochs,
            self.episodes,
            self.set.key(),
            self.threshold,
            self.seconds
        );
        out.push_str(&Self::table1_header());
        out.push_str(&self.table1_row());
        out.push('\n');
        out.push_str(&Self::table2_header());
        out.push_str(&self.table2_row());
        let _ = writeln!(out, "\n{}: {}.", self.name, self.against_chance());
        if self.success_rule == SuccessRule::Reached {
            let _ = writeln!(out, "* {}.", self.success_rule.describe());
        }
        out
    }
}

/// The outcome of a test episode (Table II): a drop if the object was dropped
/// at any step, else success when the final goal distance is below
/// `threshold`, else incomplete. An object turned into the goal but dropped
/// on the way is a drop: success is an object turned and held.
///
/// ```
/// use fmsr::core::metrics::{EpisodeOutcome, FailureType};
/// use fmsr::evaluate::classify;
/// assert_eq!(classify(0.1, 0.4, false), EpisodeOutcome::Success);
/// assert_eq!(classify(0.1, 0.4, true), EpisodeOutcome::Failure(FailureType::Drop));
/// assert_eq!(classify(1.0, 0.4, true), EpisodeOutcome::Failure(FailureType::Drop));
/// assert_eq!(classify(1.0, 0.4, false), EpisodeOutcome::Failure(FailureType::Incomplete));
/// ```
#[must_use]
pub fn classify(final_distance: f32, threshold: f32, dropped: bool) -> EpisodeOutcome {
    if dropped {
        EpisodeOutcome::Failure(FailureType::Drop)
    } else if final_distance < threshold {
        EpisodeOutcome::Success
    } else {
        EpisodeOutcome::Failure(FailureType::Incomplete)
    }
}

/// Evaluates the policy of the run in `dir` (its last checkpoint) on `env`, on
/// the fixed test set of `config.eval`, and writes `eval.json`. `dt` is the
/// duration of one env step (s), for the derivatives.
pub fn evaluate_run<E: Env + ContactReadout + Send>(
    config: &ExperimentConfig,
    env: E,
    dir: &RunDir,
    dt: f64,
) -> Result<EvalReport, ExperimentError> {
    evaluate_run_on(config, env, config.engine, EpisodeSet::Test, dir, dt)
}

/// As [`evaluate_run`] with `env` an environment of `engine`, which may differ
/// from the engine the run trained on (cross-engine evaluation), on the
/// episodes of `set`: the report names both and goes to [`RunDir::eval_json_for`].
pub fn evaluate_run_on<E: Env + ContactReadout + Send>(
    config: &ExperimentConfig,
    env: E,
    engine: Engine,
    set: EpisodeSet,
    dir: &RunDir,
    dt: f64,
) -> Result<EvalReport, ExperimentError> {
    let report = evaluate_source_on(config, env, engine, set, &Source::Run(dir.clone()), dt)?;
    write_eval(&report, &dir.eval_json_for(engine, config.engine, set))?;
    Ok(report)
}

/// Writes an evaluation as JSON, atomically.
///
/// # Errors
/// I/O errors.
pub fn write_eval(report: &EvalReport, path: &std::path::Path) -> Result<(), ExperimentError> {
    let json = serde_json::to_vec_pretty(report)
        .map_err(|e| ExperimentError::Config { key: "eval".into(), reason: e.to_string() })?;
    Ok(fmsr_core::persist::write_atomic(path, &json)?)
}

/// One episode played for the evaluation: its record, grasp measures and trace.
struct Played {
    record: EpisodeRecord,
    summary: Option<EpisodeSummary>,
    trace: EpisodeTrace,
}

/// Plays the episode of `seed` deterministically, reading the contacts at every step.
fn play<E: Env + ContactReadout + Send>(
    trainer: &mut Trainer<E, fmsr_nn::AnyLearner>,
    seed: u64,
    threshold: f32,
    dt: f64,
) -> Result<Played, ExperimentError> {
    let mut trace = GraspTrace::new(dt)?;
    let mut metric_error = None;
    let mut distances = Vec::new();
    let episode = trainer.rollout_with(seed, ActMode::Evaluate, &mut |env, outcome| {
        let o = &outcome.observation;
        distances.push(env.goal_distance(&o.achieved_goal, &o.desired_goal));
        if let Err(e) = trace.push(&env.object_contacts())
            && metric_error.is_none()
        {
            metric_error = Some(e);
        }
    })?;
    if let Some(e) = metric_error {
        return Err(e.into());
    }
    let initial_error = episode
        .observations
        .first()
        .map_or(f32::INFINITY, |o| trainer.env().goal_distance(&o.achieved_goal, &o.desired_goal));
    let final_error = distances.last().copied().unwrap_or(f32::INFINITY);
    let drop_step = episode.infos.iter().position(|i| i.dropped);
    let contacts = trace.contacts();
    let record = EpisodeRecord {
        seed,
        initial_error,
        final_error,
        dropped: drop_step.is_some(),
        drop_step,
        outcome: classify(final_error, threshold, drop_step.is_some()),
        total_contacts: contacts.iter().sum(),
    };
    let series = EpisodeTrace {
        seed,
        contacts,
        q_msv: trace.q_msv(),
        q_vew: trace.q_vew(),
        dq_msv: trace.dq_msv(),
        dq_vew: trace.dq_vew(),
        q_dcc: trace.q_dcc(),
        goal_distance: distances,
    };
    Ok(Played { record, summary: trace.summary(), trace: series })
}

/// Evaluates the policy of `source` (a run's last checkpoint or a policy
/// file) on `env`, an environment of `engine`, on `config.eval.episodes`
/// episodes of `set` (`config` is `source`'s, possibly with another number of
/// episodes), and returns the evaluation without writing it.
///
/// # Errors
/// The errors of the policy, the environment and the grasp measures.
pub fn evaluate_source_on<E: Env + ContactReadout + Send>(
    config: &ExperimentConfig,
    env: E,
    engine: Engine,
    set: EpisodeSet,
    source: &Source,
    dt: f64,
) -> Result<EvalReport, ExperimentError> {
    let start = Instant::now();
    let mut trainer = config.build_trainer(vec![env])?;
    let epochs = source.load_into(&mut trainer)?;
    let seeds = config.eval.seeds_of(set, config.eval.episodes);
    let threshold = config.eval.threshold;
    let mut records = Vec::with_capacity(seeds.len());
    let mut summaries = Vec::with_capacity(seeds.len());
    let mut first_trace = None;
    for &seed in &seeds {
        let played = play(&mut trainer, seed, threshold, dt)?;
        records.push(played.record);
        summaries.extend(played.summary);
        first_trace.get_or_insert(played.trace);
    }
    let outcomes: FailureCounts = records.iter().map(|r| r.outcome).collect();
    Ok(EvalReport {
        name: config.name.clone(),
        method: config.label(),
        task: format!("{:?}", config.env.object).to_lowercase(),
        engine: engine.key().into(),
        trained_on: Some(config.engine.key().into()),
        epochs,
        episodes: seeds.len(),
        set,
        threshold,
        success_rule: SuccessRule::ReachedAndHeld,
        success_rate: outcomes.success_rate().unwrap_or(0.0),
        stability: StabilityRow::from_summaries(&summaries),
        failures: outcomes.row(),
        outcomes,
        episode_summaries: summaries,
        records,
        initial_distances: Vec::new(),
        trace: first_trace.unwrap_or_default(),
        seconds: start.elapsed().as_secs_f64(),
    })
}
