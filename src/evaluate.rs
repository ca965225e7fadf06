//! `fmsr eval`: the paper's evaluation of a trained policy on a fixed test set
//! (section IV.C, Tables I and II): success rate at the test threshold, total
//! contacts, `Q_MSV`, `Q_VEW`, `|Q'_MSV|`, `|Q'_VEW|`, `Q_DCC`, and failure types.

use std::fmt::Write as _;
use std::time::Instant;

use serde::{Deserialize, Serialize};

use fmsr_core::metrics::{
    EpisodeOutcome, EpisodeSummary, FailureCounts, FailureRow, FailureType, GraspTrace, MeanStd, StabilityRow,
};
use fmsr_core::prelude::*;

use crate::experiment::{Engine, ExperimentConfig, ExperimentError};
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
    /// The success threshold (rad).
    pub threshold: f32,
    /// Fraction of test episodes that ended within the threshold.
    pub success_rate: f64,
    /// Table I's stability measures over the test episodes.
    pub stability: Option<StabilityRow>,
    /// Outcome counts.
    pub outcomes: FailureCounts,
    /// Table II's columns.
    pub failures: FailureRow,
    /// Per-episode summaries.
    pub episode_summaries: Vec<EpisodeSummary>,
    /// Final goal distance of each test episode (rad).
    pub final_distances: Vec<f32>,
    /// Goal distance of each test episode at its start, after the reset (rad;
    /// absent in files of older versions).
    #[serde(default)]
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
            "| {} | {} | {:.0}% | {} |\n",
            self.task,
            self.method,
            100.0 * self.success_rate,
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
            "{} | {} | {} | {} | {:.0}% | {} | {drop}",
            self.task,
            self.method,
            self.trained_on.as_deref().unwrap_or(trained_on),
            self.engine,
            100.0 * self.success_rate,
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

    /// The chance level of this test set: the success rate of a policy that
    /// holds the object still, i.e. the fraction of episodes that start within
    /// the threshold (`None` for files of older versions). With the goal and the
    /// start drawn uniformly about Z, it tends to `threshold / pi` (12.7 % at 0.4 rad).
    #[must_use]
    pub fn still_success_rate(&self) -> Option<f64> {
        let n = self.initial_distances.len();
        (n > 0).then(|| self.initial_distances.iter().filter(|&&d| d < self.threshold).count() as f64 / n as f64)
    }

    /// Test success against chance, in words.
    #[must_use]
    pub fn against_chance(&self) -> String {
        match self.still_success_rate() {
            Some(still) => format!(
                "test success {:.0}% against {:.0}% for a policy that never turns the object (the episodes that start within {} rad)",
                100.0 * self.success_rate,
                100.0 * still,
                self.threshold
            ),
            None => format!("test success {:.0}% (chance level not recorded)", 100.0 * self.success_rate),
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
            "{} ({}, {} epochs, {} test episodes at {} rad, {:.0} s)\n",
            self.name, self.engine, self.epochs, self.episodes, self.threshold, self.seconds
        );
        out.push_str(&Self::table1_header());
        out.push_str(&self.table1_row());
        out.push('\n');
        out.push_str(&Self::table2_header());
        out.push_str(&self.table2_row());
        let _ = writeln!(out, "\n{}: {}.", self.name, self.against_chance());
        out
    }
}

/// The outcome of a test episode (Table II): success when the final goal
/// distance is below `threshold`, else a drop if the object was dropped at any
/// step, else incomplete.
///
/// ```
/// use fmsr::core::metrics::{EpisodeOutcome, FailureType};
/// assert_eq!(fmsr::evaluate::classify(0.1, 0.4, true), EpisodeOutcome::Success);
/// assert_eq!(fmsr::evaluate::classify(1.0, 0.4, true), EpisodeOutcome::Failure(FailureType::Drop));
/// ```
#[must_use]
pub fn classify(final_distance: f32, threshold: f32, dropped: bool) -> EpisodeOutcome {
    if final_distance < threshold {
        EpisodeOutcome::Success
    } else if dropped {
        EpisodeOutcome::Failure(FailureType::Drop)
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
    evaluate_run_on(config, env, config.engine, dir, dt)
}

/// As [`evaluate_run`] with `env` an environment of `engine`, which may differ
/// from the engine the run trained on (cross-engine evaluation): the report
/// names both and goes to [`RunDir::eval_json_on`].
pub fn evaluate_run_on<E: Env + ContactReadout + Send>(
    config: &ExperimentConfig,
    env: E,
    engine: Engine,
    dir: &RunDir,
    dt: f64,
) -> Result<EvalReport, ExperimentError> {
    let report = evaluate_source_on(config, env, engine, &Source::Run(dir.clone()), dt)?;
    write_eval(&report, &dir.eval_json_on(engine, config.engine))?;
    Ok(report)
}

/// Writes an evaluation as JSON, atomically.
///
/// # Errors
/// I/O errors.
pub fn write_eval(report: &EvalReport, path: &std::path::Path) -> Result<(), ExperimentError> {
    let json = serde_json::to_vec_pretty(report)
        .map_err(|e| ExperimentError::Config { key: "eval".into(), reason: e.to_string() })?;
    Ok(fmsr_core::trainer::write_atomic(path, &json)?)
}

/// Evaluates the policy of `source` (a run's last checkpoint or a policy
/// file) on `env`, an environment of `engine`, on the fixed test set of
/// `config.eval` (`config` is `source`'s, possibly with fewer episodes), and
/// returns the evaluation without writing it.
///
/// # Errors
/// The errors of the policy, the environment and the grasp measures.
pub fn evaluate_source_on<E: Env + ContactReadout + Send>(
    config: &ExperimentConfig,
    env: E,
    engine: Engine,
    source: &Source,
    dt: f64,
) -> Result<EvalReport, ExperimentError> {
    let start = Instant::now();
    let mut trainer = config.build_trainer(vec![env])?;
    let epochs = source.load_into(&mut trainer)?;
    let seeds = config.eval.seeds();
    let threshold = config.eval.threshold;
    let mut outcomes = FailureCounts::new();
    let mut summaries = Vec::with_capacity(seeds.len());
    let mut final_distances = Vec::with_capacity(seeds.len());
    let mut initial_distances = Vec::with_capacity(seeds.len());
    let mut first_trace = None;
    for &seed in &seeds {
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
        if let Some(o) = episode.observations.first() {
            initial_distances.push(trainer.env().goal_distance(&o.achieved_goal, &o.desired_goal));
        }
        let d = distances.last().copied().unwrap_or(f32::INFINITY);
        final_distances.push(d);
        outcomes.record(classify(d, threshold, episode.infos.iter().any(|i| i.dropped)));
        if let Some(summary) = trace.summary() {
            summaries.push(summary);
        }
        if first_trace.is_none() {
            first_trace = Some(EpisodeTrace {
                seed,
                contacts: trace.contacts(),
                q_msv: trace.q_msv(),
                q_vew: trace.q_vew(),
                dq_msv: trace.dq_msv(),
                dq_vew: trace.dq_vew(),
                q_dcc: trace.q_dcc(),
                goal_distance: distances,
            });
        }
    }
    let report = EvalReport {
        name: config.name.clone(),
        method: config.label(),
        task: format!("{:?}", config.env.object).to_lowercase(),
        engine: engine.key().into(),
        trained_on: Some(config.engine.key().into()),
        epochs,
        episodes: seeds.len(),
        threshold,
        success_rate: outcomes.success_rate().unwrap_or(0.0),
        stability: StabilityRow::from_summaries(&summaries),
        failures: outcomes.row(),
        outcomes,
        episode_summaries: summaries,
        final_distances,
        initial_distances,
        trace: first_trace.unwrap_or_default(),
        seconds: start.elapsed().as_secs_f64(),
    };
    Ok(report)
}
