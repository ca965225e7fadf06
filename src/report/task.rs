//! `fmsr report` over runs of registered tasks ([`crate::tasks`]): the
//! measures every task has ([`crate::task_eval`]) where the Shadow Hand's
//! report has the paper's Tables I and II.
//!
//! - Per task, one row per configuration: the run standing for it (chosen on
//!   the validation episodes by [`choice`](super::choice)'s rule), its
//!   validation and test success with their 95 % Wilson intervals, the zero
//!   action's success on the same test episodes, the drops, each
//!   stability feature's rate and the task's own measures (mean ± std across
//!   the test episodes); then the differences of test success between
//!   configurations with Newcombe's intervals.
//! - `fig3_<task>.png`: the per-epoch evaluation success of every
//!   configuration (mean and min-max band over seeds), as the Shadow Hand's
//!   Fig. 3.
//! - Every run with its seed, epochs and evaluations, and the runs not yet
//!   evaluated (`fmsr eval RUN`, `fmsr eval RUN --set validation`).

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use fmsr_core::interval::Interval;
use fmsr_core::persist::write_atomic;
use fmsr_core::trainer::EpochStats;

use super::choice::{self, Chosen};
use super::links::RunLinks;
use super::{Configuration, ReportFiles};
use crate::artefacts::{RunDir, Source, read_json};
use crate::experiment::{EpisodeSet, ExperimentConfig, ExperimentError};
use crate::task_eval::TaskEvalReport;

/// One run of a registered task as the report sees it.
#[derive(Debug, Clone)]
pub struct TaskRunRecord {
    /// Where it lives.
    pub dir: PathBuf,
    /// Its configuration.
    pub config: ExperimentConfig,
    /// Its per-epoch statistics.
    pub metrics: Vec<EpochStats>,
    /// Its evaluation on the fixed test set (`fmsr eval`), if it ran.
    pub eval: Option<TaskEvalReport>,
    /// Its evaluation on the validation episodes (`fmsr eval --set
    /// validation`), on which a seed is chosen.
    pub validation: Option<TaskEvalReport>,
    /// Whether it is a policy file (which carries no task evaluation).
    pub policy_file: bool,
}

impl TaskRunRecord {
    /// Reads a run directory (with the evaluations `fmsr eval` wrote in it)
    /// or a policy file ([`Source::open`]).
    ///
    /// # Errors
    /// The errors of reading the run, its evaluations or the file;
    /// [`ExperimentError::Config`] for key `task` when it trained the
    /// Shadow Hand ([`super::RunRecord`] reads those).
    pub fn open(path: &Path) -> Result<Self, ExperimentError> {
        let record = match Source::open(path)? {
            Source::Run(_) => {
                let run = RunDir::new(path);
                let read = |set| read_json::<TaskEvalReport>(&TaskEvalReport::path_in(&run, set));
                Self {
                    dir: path.to_path_buf(),
                    config: run.load_config()?,
                    metrics: run.load_metrics()?,
                    eval: read(EpisodeSet::Test)?,
                    validation: read(EpisodeSet::Validation)?,
                    policy_file: false,
                }
            }
            Source::Policy { path, file } => Self {
                dir: path,
                config: file.config,
                metrics: file.metrics,
                eval: None,
                validation: None,
                policy_file: true,
            },
        };
        if record.config.is_shadow_hand() {
            return Err(ExperimentError::config(
                "task",
                format!("{} trained the Shadow Hand, whose report has the paper's tables", path.display()),
            ));
        }
        Ok(record)
    }

    /// The configuration it stands for.
    #[must_use]
    pub fn configuration(&self) -> Configuration {
        Configuration { key: self.config.key(), policy_file: self.policy_file }
    }
}

/// A rate's cell: the percentage with its interval, or `none`.
fn cell(interval: Option<Interval>, none: &str) -> String {
    interval.as_ref().map_or_else(|| none.into(), Interval::percent)
}

/// Writes the report of runs of registered tasks into `out`: `summary.md`
/// and a learning-curve figure per task.
///
/// # Errors
/// [`ExperimentError::Cli`] for no runs; the errors of writing the files.
pub fn write_task_report(runs: &[TaskRunRecord], out: &Path) -> Result<ReportFiles, ExperimentError> {
    if runs.is_empty() {
        return Err(ExperimentError::Cli { arg: "RUNS", reason: "no run to report on".into() });
    }
    crate::font::register_font();
    std::fs::create_dir_all(out).map_err(|source| ExperimentError::Io { path: out.to_path_buf(), source })?;
    super::remove_previous_report(out)?;
    let links = RunLinks::new(out)?;
    let mut by_task: BTreeMap<&str, Vec<&TaskRunRecord>> = BTreeMap::new();
    for r in runs {
        by_task.entry(r.config.task.as_str()).or_default().push(r);
    }
    let mut files = ReportFiles { summary: out.join("summary.md"), figures: Vec::new() };
    let mut summary = String::from("# fmsr report\n\n");
    let _ = writeln!(
        summary,
        "{} run(s) over {} registered task(s). Success on an episode: the task says success at its last step \
         and never said dropped; every rate with its 95 % Wilson interval. A configuration with several seeds \
         is shown by its best run on the validation episodes (seeds apart from the test set's); the zero \
         action plays the same test episodes, the chance level.\n",
        runs.len(),
        by_task.len()
    );
    let mut missing = Vec::new();
    for (task, task_runs) in &by_task {
        let _ = writeln!(summary, "## {task}\n");
        let first = task_runs.iter().find_map(|r| r.eval.as_ref());
        let features = first.map(|e| e.features.clone()).unwrap_or_default();
        let measures = first.map(|e| e.measures.clone()).unwrap_or_default();
        summary.push_str("| Configuration | Run | Validation success | Test success | Zero action | Drops |");
        let mut rule = String::from("|---|---|---|---|---|---|");
        for f in &features {
            let _ = write!(summary, " `{f}` rate |");
            rule.push_str("---|");
        }
        for m in &measures {
            let _ = write!(summary, " `{m}` (mean ± std) |");
            rule.push_str("---|");
        }
        let _ = writeln!(summary, "\n{rule}");
        let configurations = super::configurations(task_runs.iter().map(|r| r.configuration()));
        let mut chosen: Vec<(Configuration, &TaskEvalReport, Chosen)> = Vec::new();
        for c in &configurations {
            let candidates: Vec<&TaskRunRecord> =
                task_runs.iter().copied().filter(|r| r.configuration() == *c).collect();
            let Some((r, e, how)) = choice::choose_by(
                &candidates,
                |r| r.eval.as_ref(),
                |r| r.validation.as_ref().and_then(TaskEvalReport::success).map(|i| i.estimate),
            ) else {
                continue;
            };
            let _ = write!(
                summary,
                "| {} | {} ({}) | {} | {} | {} | {} of {} |",
                c.label(),
                links.link(&r.dir),
                how.describe(),
                cell(r.validation.as_ref().and_then(TaskEvalReport::success), "not evaluated"),
                cell(e.success(), "-"),
                cell(e.still_success(), "-"),
                e.drops,
                e.episodes
            );
            for i in 0..features.len() {
                let rate = e.feature_rates.get(i).map_or_else(|| "-".into(), |r| format!("{r:.3}"));
                let _ = write!(summary, " {rate} |");
            }
            for m in &measures {
                let i = e.measures.iter().position(|n| n == m);
                let value = i.and_then(|i| e.measure(i)).map_or_else(|| "-".into(), |v| format!("{v:.3}"));
                let _ = write!(summary, " {value} |");
            }
            summary.push('\n');
            chosen.push((c.clone(), e, how));
        }
        if chosen.len() > 1 {
            summary.push_str(
                "\nDifferences in test success, the first configuration's minus the second's, in points, with \
                 the 95 % interval of the difference (Newcombe's, from the two Wilson intervals):\n\n\
                 | Configuration | Against | Difference |\n|---|---|---|\n",
            );
            for (i, (a, ea, _)) in chosen.iter().enumerate() {
                for (b, eb, _) in &chosen[i + 1..] {
                    if let (Some(ia), Some(ib)) = (ea.success(), eb.success()) {
                        let _ =
                            writeln!(summary, "| {} | {} | {} |", a.label(), b.label(), ia.difference(&ib).points());
                    }
                }
            }
        }
        let curves: Vec<(Configuration, &[EpochStats])> =
            task_runs.iter().map(|r| (r.configuration(), r.metrics.as_slice())).collect();
        let fig = out.join(format!("fig3_{task}.png"));
        super::plot_learning_curves(task, &curves, &fig)?;
        let name = fig.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        let _ = writeln!(summary, "\n![{name}]({name})\n");
        files.figures.push(fig);
        summary.push_str(
            "| Run | Configuration | Seed | Epochs | Last eval success | Validation success | Test success |\n\
             |---|---|---|---|---|---|---|\n",
        );
        for r in task_runs {
            let last = r.metrics.last().map_or_else(|| "n/a".into(), |m| format!("{:.2}", m.success_rate));
            let _ = writeln!(
                summary,
                "| {} | {} | {} | {} | {last} | {} | {} |",
                links.link(&r.dir),
                r.configuration().label(),
                r.config.trainer.seed,
                r.metrics.len(),
                cell(r.validation.as_ref().and_then(TaskEvalReport::success), "not evaluated"),
                cell(r.eval.as_ref().and_then(TaskEvalReport::success), "not evaluated"),
            );
            if r.eval.is_none() {
                missing.push(links.link(&r.dir));
            }
        }
        summary.push('\n');
    }
    if !missing.is_empty() {
        let _ = writeln!(
            summary,
            "Not in the tables (run `fmsr eval` on them; a policy file of a task carries no evaluation): {}",
            missing.join(", ")
        );
    }
    write_atomic(&files.summary, summary.as_bytes())?;
    Ok(files)
}
