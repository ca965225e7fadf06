//! `fmsr report`: the paper's tables and figures over several runs.
//!
//! - Table I (success rate with its 95 % Wilson interval, and stability
//!   measures) and Table II (failure types), in Markdown, one row per task and
//!   configuration. As in the paper, a configuration trained with several seeds
//!   is represented by its best run, chosen on the validation episodes
//!   ([`choice`]); the differences between configurations come with their
//!   intervals.
//! - Fig. 3: learning curves (evaluation success rate per epoch, mean and
//!   min-max spread over seeds) per task, `fig3_<task>.png`.
//! - Fig. 4: the stability measures over one test episode (the first of the fixed
//!   test set, the same for every policy) per task, `fig4_<task>.png`.
//! - `summary.md`: a one-page summary linking all of it. It names each run by
//!   its path from the report's directory, as a link, whatever path it was
//!   given by, so the summary names no machine's checkout and its links work
//!   wherever the report and the runs move together.
//!
//! A report written into a directory that holds an earlier one replaces it:
//! the files an earlier report wrote there and this one does not (the figures
//! of a task no longer reported, `cross_engine.md`, renderings of other runs)
//! are removed first, and nothing else in the directory is touched.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use plotters::prelude::*;

use fmsr_core::method::Method;
use fmsr_core::persist::write_atomic;
use fmsr_core::trainer::EpochStats;

pub mod choice;
mod links;
mod task;

pub use task::{TaskRunRecord, write_task_report};

use crate::artefacts::{EvalReport, PolicyFile, RenderTarget, RunDir, Source, read_eval};
use crate::experiment::{Engine, EpisodeSet, ExperimentConfig, ExperimentError, RunKey};
use links::RunLinks;

/// One run as the report sees it.
#[derive(Debug, Clone)]
pub struct RunRecord {
    /// Where it lives.
    pub dir: PathBuf,
    /// Its configuration.
    pub config: ExperimentConfig,
    /// Its per-epoch statistics.
    pub metrics: Vec<EpochStats>,
    /// Its evaluation on the fixed test set, if `fmsr eval` ran.
    pub eval: Option<EvalReport>,
    /// Its evaluation on the validation episodes (`fmsr eval --set
    /// validation`), on which a seed is chosen.
    pub validation: Option<EvalReport>,
    /// Its evaluations on the other engine (`fmsr eval --engine`).
    pub cross_evals: Vec<EvalReport>,
    /// Test episode 0 drawn by `fmsr render` on its own engine: the GIF and its frame strip.
    pub rendering: Option<(PathBuf, PathBuf)>,
    /// The configuration's label in the tables and figures
    /// ([`ExperimentConfig::label`]; a policy file's adds `(policy file)`).
    pub label: String,
    /// Whether it is a policy file, which stands beside the runs of its
    /// configuration rather than as their seed.
    pub policy_file: bool,
}

/// A configuration of a report: a run's [`RunKey`], and whether it is a
/// policy file (which stands beside the runs of its key, not as their seed).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Configuration {
    /// The configuration's identity.
    pub key: RunKey,
    /// A policy file rather than a run.
    pub policy_file: bool,
}

impl Configuration {
    /// Its name in tables and figures.
    #[must_use]
    pub fn label(&self) -> String {
        if self.policy_file { format!("{} (policy file)", self.key) } else { self.key.to_string() }
    }

    /// The order of the tables: the paper's methods, then the labels.
    fn order(&self) -> (Option<usize>, String) {
        (Method::ALL.iter().position(|m| *m == self.key.method), self.label())
    }
}

impl RunRecord {
    /// Reads a run directory.
    ///
    /// # Errors
    /// The errors of reading the run's files.
    pub fn load(dir: &Path) -> Result<Self, ExperimentError> {
        let run = RunDir::new(dir);
        let config = run.load_config()?;
        let metrics = run.load_metrics()?;
        let eval = read_eval(&run.eval_json())?;
        let validation = read_eval(&run.eval_json_for(config.engine, config.engine, EpisodeSet::Validation))?;
        let cross_evals: Vec<EvalReport> = Engine::ALL
            .into_iter()
            .filter(|&e| e != config.engine)
            .map(|e| read_eval(&run.eval_json_on(e, config.engine)))
            .filter_map(Result::transpose)
            .collect::<Result<_, _>>()?;
        let target = RenderTarget::default_for(&run, 0, config.engine);
        Ok(Self::assemble(dir, &target, config, metrics, [eval, validation], cross_evals, false))
    }

    /// Reads a run directory or a policy file ([`Source::open`]); a policy
    /// file's record carries the learning curve and evaluations stored in it.
    ///
    /// # Errors
    /// The errors of reading the run or the file.
    pub fn open(path: &Path) -> Result<Self, ExperimentError> {
        let source = Source::open(path)?;
        let target = source.render_target(0, None)?;
        match source {
            Source::Run(_) => Self::load(path),
            Source::Policy { path, file } => {
                let own = file.config.engine.key();
                let eval = file.eval_on(file.config.engine).cloned();
                let validation = file.eval_for(own, EpisodeSet::Validation).cloned();
                let cross =
                    file.evals.iter().filter(|e| e.engine != own && e.set == EpisodeSet::Test).cloned().collect();
                let PolicyFile { config, metrics, .. } = *file;
                Ok(Self::assemble(&path, &target, config, metrics, [eval, validation], cross, true))
            }
        }
    }

    /// A record of `dir` whose rendering of test episode 0 (if drawn) is `target`.
    fn assemble(
        dir: &Path,
        target: &RenderTarget,
        config: ExperimentConfig,
        metrics: Vec<EpochStats>,
        [mut eval, mut validation]: [Option<EvalReport>; 2],
        mut cross_evals: Vec<EvalReport>,
        policy_file: bool,
    ) -> Self {
        let label = Configuration { key: config.key(), policy_file }.label();
        // The configuration names the run in every table (files of older versions
        // carry only the method's label).
        for e in eval.iter_mut().chain(validation.iter_mut()).chain(cross_evals.iter_mut()) {
            e.method.clone_from(&label);
        }
        let rendering = match (target, target.strip_path()) {
            (RenderTarget::Gif(gif), Some(strip)) if gif.exists() && strip.exists() => Some((gif.clone(), strip)),
            _ => None,
        };
        Self { dir: dir.to_path_buf(), config, metrics, eval, validation, cross_evals, rendering, label, policy_file }
    }

    /// The configuration it stands for.
    #[must_use]
    pub fn configuration(&self) -> Configuration {
        Configuration { key: self.config.key(), policy_file: self.policy_file }
    }

    fn task(&self) -> String {
        format!("{:?}", self.config.env.object).to_lowercase()
    }
}

/// The cross-engine table: every run evaluated on another engine, beside its
/// evaluation on its own (`None` when no run was).
fn cross_engine_table(runs: &[RunRecord], links: &RunLinks) -> Option<String> {
    let rows: Vec<&RunRecord> = runs.iter().filter(|r| !r.cross_evals.is_empty()).collect();
    if rows.is_empty() {
        return None;
    }
    let mut md = String::from(
        "| Run | Task | Configuration | Trained on | Evaluated on | Success Rate | Total Contact | Q_MSV | Q_VEW | \\|Q'_MSV\\| | \\|Q'_VEW\\| | Q_DCC (1e-3 m) | Drop% |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        for e in r.eval.iter().chain(&r.cross_evals) {
            let _ = writeln!(md, "| {} | {} |", links.link(&r.dir), e.cross_engine_cells(r.config.engine.key()));
        }
    }
    Some(md)
}

/// Copies each run's rendered test episode into `out/render/` and returns the
/// summary's section: per run, the strip of its first, middle and last frames and a
/// link to the GIF.
fn renderings_section(runs: &[RunRecord], out: &Path, links: &RunLinks) -> Result<String, ExperimentError> {
    let mut md = String::from("## Test episode 0, rendered\n\n");
    md.push_str("The first episode of the fixed test set, played by each run's policy on its own engine (`fmsr render`): first, middle and last step.\n\n");
    let dir = out.join("render");
    let mut missing = Vec::new();
    for (i, r) in runs.iter().enumerate() {
        let Some((gif, strip)) = &r.rendering else {
            missing.push(links.link(&r.dir));
            continue;
        };
        std::fs::create_dir_all(&dir).map_err(|source| ExperimentError::Io { path: dir.clone(), source })?;
        let stem = format!("{i:02}-{}", r.config.name);
        for (from, ext) in [(gif, "gif"), (strip, "png")] {
            let to = dir.join(format!("{stem}.{ext}"));
            std::fs::copy(from, &to).map_err(|source| ExperimentError::Io { path: to.clone(), source })?;
        }
        let _ = writeln!(
            md,
            "**{}** ({}, {}): [animation](render/{stem}.gif)\n\n![{stem}](render/{stem}.png)\n",
            links.link(&r.dir),
            r.label,
            r.config.engine.key()
        );
    }
    if !missing.is_empty() {
        let _ = writeln!(md, "Not rendered (run `fmsr render RUN`): {}\n", missing.join(", "));
    }
    Ok(md)
}

/// Each evaluated run's test success beside the chance level of its test set.
fn chance_section(runs: &[RunRecord], links: &RunLinks) -> String {
    let mut md = String::from(
        "\n## Against chance\n\nThe same test episodes played by a hand that holds still (zero action, simulated on the evaluation's engine; in evaluations older than the full-angle task, estimated as the episodes that start within the threshold): a result near that level has not learned to rotate. The goal distance is the one the success was counted by: `full` (the full angle between the orientations, `q` and `-q` one orientation), `gym` (gymnasium-robotics' `2 arccos(w)` over [0, 2 pi], the engine's quaternion sign kept) or `yaw` (rotation about Z alone, the oldest records).\n\n| Run | Configuration | Goal distance | Test success | Holding still |\n|---|---|---|---|---|\n",
    );
    for r in runs {
        let Some(e) = &r.eval else { continue };
        let (test, still) = choice::chance_cells(e);
        let _ =
            writeln!(md, "| {} | {} | {} | {test} | {still} |", links.link(&r.dir), e.method, e.goal_distance.key());
    }
    md
}

/// What [`write_report`] wrote.
#[derive(Debug, Clone, Default)]
pub struct ReportFiles {
    /// `summary.md`.
    pub summary: PathBuf,
    /// The PNG figures.
    pub figures: Vec<PathBuf>,
}

/// The method's colour: Okabe and Ito's colour-blind-safe palette.
fn method_color(m: Method) -> RGBColor {
    match m {
        Method::DenseFmsrIs => RGBColor(0, 114, 178),
        Method::DenseFmsr => RGBColor(213, 94, 0),
        Method::Dense => RGBColor(230, 159, 0),
        Method::Sparse => RGBColor(0, 158, 115),
    }
}

fn plot_err<E: std::fmt::Display>(path: &Path) -> impl Fn(E) -> ExperimentError + '_ {
    move |e| ExperimentError::Plot { path: path.to_path_buf(), reason: e.to_string() }
}

/// The distinct configurations among `runs`, in the paper's method order.
fn configurations(of: impl IntoIterator<Item = Configuration>) -> Vec<Configuration> {
    let mut out: Vec<Configuration> = of.into_iter().collect();
    out.sort_by_key(Configuration::order);
    out.dedup();
    out
}

/// The colour of a configuration among `all`: its method's, darker for each
/// further configuration of the same method (an ablation, another engine),
/// so that every method keeps its hue and no two configurations share a colour.
fn configuration_color(c: &Configuration, all: &[Configuration]) -> RGBColor {
    let method = c.key.method;
    let variant = all.iter().filter(|o| o.key.method == method).position(|o| o == c).unwrap_or(0);
    let RGBColor(r, g, b) = method_color(method);
    let scale = 0.6f64.powi(i32::try_from(variant.min(4)).unwrap_or(4));
    let dim = |c: u8| (f64::from(c) * scale).round() as u8;
    RGBColor(dim(r), dim(g), dim(b))
}

/// Learning curves of one task: success rate per epoch per configuration
/// (each run's curve beside its configuration), mean over seeds with the
/// min-max band.
fn plot_learning_curves(
    task: &str,
    runs: &[(Configuration, &[EpochStats])],
    path: &Path,
) -> Result<(), ExperimentError> {
    let err = plot_err(path);
    let root = BitMapBackend::new(path, (900, 560)).into_drawing_area();
    root.fill(&WHITE).map_err(&err)?;
    let epochs = runs.iter().map(|(_, m)| m.len()).max().unwrap_or(1).max(2);
    let mut chart = ChartBuilder::on(&root)
        .caption(format!("Fig. 3 - {task}: success rate during training"), ("sans-serif", 24))
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(55)
        .build_cartesian_2d(0f64..(epochs - 1) as f64, 0f64..1.0)
        .map_err(&err)?;
    chart
        .configure_mesh()
        .x_desc("epoch")
        .y_desc("success rate (per-epoch evaluation episodes, training threshold)")
        .draw()
        .map_err(&err)?;
    let all = configurations(runs.iter().map(|(c, _)| c.clone()));
    for c in &all {
        let seeds: Vec<&[EpochStats]> = runs.iter().filter(|(o, _)| o == c).map(|(_, m)| *m).collect();
        // Mean and spread over the runs that reached each epoch.
        let n = seeds.iter().map(|m| m.len()).max().unwrap_or(0);
        let at = |e: usize| seeds.iter().filter_map(|m| m.get(e).map(|m| m.success_rate)).collect::<Vec<_>>();
        let mean: Vec<(f64, f64)> = (0..n)
            .map(|e| {
                let v = at(e);
                (e as f64, v.iter().sum::<f64>() / v.len() as f64)
            })
            .collect();
        let color = configuration_color(c, &all);
        if seeds.len() > 1 {
            let upper = (0..n).map(|e| (e as f64, at(e).into_iter().fold(f64::MIN, f64::max)));
            let lower = (0..n).rev().map(|e| (e as f64, at(e).into_iter().fold(f64::MAX, f64::min)));
            chart
                .draw_series(std::iter::once(Polygon::new(upper.chain(lower).collect::<Vec<_>>(), color.mix(0.2))))
                .map_err(&err)?;
        }
        chart
            .draw_series(LineSeries::new(mean, color.stroke_width(2)))
            .map_err(&err)?
            .label(format!("{} ({} run{})", c.label(), seeds.len(), if seeds.len() == 1 { "" } else { "s" }))
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2)));
    }
    chart.configure_series_labels().background_style(WHITE.mix(0.8)).border_style(BLACK).draw().map_err(&err)?;
    root.present().map_err(&err)?;
    Ok(())
}

/// The six time-domain panels of Fig. 4 for one task.
fn plot_time_domain(task: &str, best: &[(&RunRecord, &EvalReport)], path: &Path) -> Result<(), ExperimentError> {
    let err = plot_err(path);
    let root = BitMapBackend::new(path, (1200, 900)).into_drawing_area();
    root.fill(&WHITE).map_err(&err)?;
    let seed = best.first().map_or(0, |(_, e)| e.trace.seed);
    let (title, body) = root.split_vertically(40);
    title
        .titled(&format!("Fig. 4 - {task}: stability over the test episode with seed {seed}"), ("sans-serif", 22))
        .map_err(&err)?;
    type Series = fn(&EvalReport) -> Vec<f64>;
    let panels: [(&str, Series); 6] = [
        ("Q_VEW", |e| e.trace.q_vew.clone()),
        ("|Q'_VEW| (1/s)", |e| e.trace.dq_vew.clone()),
        ("Q_MSV", |e| e.trace.q_msv.clone()),
        ("|Q'_MSV| (1/s)", |e| e.trace.dq_msv.clone()),
        ("active touch sensors", |e| e.trace.contacts.iter().map(|&c| c as f64).collect()),
        ("Q_DCC (mm)", |e| e.trace.q_dcc.iter().map(|d| d.map_or(f64::NAN, |d| d * 1e3)).collect()),
    ];
    let mut all: Vec<Configuration> = best.iter().map(|(r, _)| r.configuration()).collect();
    all.sort_by_key(Configuration::order);
    all.dedup();
    for (area, (name, series)) in body.split_evenly((3, 2)).iter().zip(panels) {
        let data: Vec<(Configuration, Vec<f64>)> = best.iter().map(|(r, e)| (r.configuration(), series(e))).collect();
        let steps = data.iter().map(|(_, v)| v.len()).max().unwrap_or(1).max(2);
        let ymax = data.iter().flat_map(|(_, v)| v.iter().copied()).filter(|v| v.is_finite()).fold(0.0, f64::max);
        let ymax = if ymax > 0.0 { ymax * 1.05 } else { 1.0 };
        let mut chart = ChartBuilder::on(area)
            .caption(name, ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(30)
            .y_label_area_size(60)
            .build_cartesian_2d(0f64..(steps - 1) as f64, 0f64..ymax)
            .map_err(&err)?;
        chart.configure_mesh().x_desc("env step").draw().map_err(&err)?;
        for (c, values) in data {
            let color = configuration_color(&c, &all);
            let points = values.iter().enumerate().filter(|(_, v)| v.is_finite()).map(|(i, &v)| (i as f64, v));
            chart
                .draw_series(LineSeries::new(points, color.stroke_width(2)))
                .map_err(&err)?
                .label(c.label())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2)));
        }
        chart.configure_series_labels().background_style(WHITE.mix(0.8)).border_style(BLACK).draw().map_err(&err)?;
    }
    root.present().map_err(&err)?;
    Ok(())
}

/// Whether `name`, a file directly in a report directory, is one `write_report` writes.
fn is_report_file(name: &str) -> bool {
    matches!(name, "summary.md" | "table1.md" | "table2.md" | "cross_engine.md")
        || ((name.starts_with("fig3_") || name.starts_with("fig4_")) && name.ends_with(".png"))
}

/// Whether `name`, a file in a report's `render/`, is one `renderings_section`
/// writes: `NN-<config name>.gif` or `.png`.
fn is_report_rendering(name: &str) -> bool {
    let numbered = name.len() > 3 && name.as_bytes()[..2].iter().all(u8::is_ascii_digit) && name.as_bytes()[2] == b'-';
    numbered && (name.ends_with(".gif") || name.ends_with(".png"))
}

/// Removes from `out` the files an earlier `write_report` left there, so that a
/// report never shows a figure or rendering of runs it no longer covers. Other
/// files are kept; `render/` is removed only if nothing else is in it.
fn remove_previous_report(out: &Path) -> Result<(), ExperimentError> {
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |source| ExperimentError::Io { path, source }
    };
    let remove_matching = |dir: &Path, owned: fn(&str) -> bool| -> Result<(), ExperimentError> {
        for entry in std::fs::read_dir(dir).map_err(io(dir))? {
            let path = entry.map_err(io(dir))?.path();
            let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
            if path.is_file() && owned(&name) {
                std::fs::remove_file(&path).map_err(io(&path))?;
            }
        }
        Ok(())
    };
    remove_matching(out, is_report_file)?;
    let render = out.join("render");
    if render.is_dir() {
        remove_matching(&render, is_report_rendering)?;
        if std::fs::read_dir(&render).map_err(io(&render))?.next().is_none() {
            std::fs::remove_dir(&render).map_err(io(&render))?;
        }
    }
    Ok(())
}

/// Writes the tables, figures and summary of `runs` into `out`.
pub fn write_report(runs: &[RunRecord], out: &Path) -> Result<ReportFiles, ExperimentError> {
    if runs.is_empty() {
        return Err(ExperimentError::Cli { arg: "RUNS", reason: "no run to report on".into() });
    }
    crate::font::register_font();
    std::fs::create_dir_all(out).map_err(|source| ExperimentError::Io { path: out.to_path_buf(), source })?;
    remove_previous_report(out)?;
    let links = RunLinks::new(out)?;
    let mut by_task: BTreeMap<String, Vec<&RunRecord>> = BTreeMap::new();
    for r in runs {
        by_task.entry(r.task()).or_default().push(r);
    }
    let mut files = ReportFiles { summary: out.join("summary.md"), figures: Vec::new() };
    let mut table1 = EvalReport::table1_header();
    let mut table2 = EvalReport::table2_header();
    let mut runs_md = String::from(
        "| Run | Task | Configuration | Seed | Epochs | Last eval success (train threshold) | Validation success | Test success |\n|---|---|---|---|---|---|---|---|\n",
    );
    let mut chosen_md = String::new();
    let mut differences = String::new();
    let mut missing_eval = Vec::new();
    let mut distances = std::collections::BTreeSet::new();
    for (task, task_runs) in &by_task {
        let mut chosen = Vec::new();
        for configuration in configurations(task_runs.iter().map(|r| r.configuration())) {
            let candidates: Vec<&RunRecord> =
                task_runs.iter().copied().filter(|r| r.configuration() == configuration).collect();
            if let Some((r, e, how)) = choice::choose(&candidates) {
                table1.push_str(&e.table1_row());
                table2.push_str(&e.table2_row());
                distances.insert(e.goal_distance.key());
                let _ = writeln!(
                    chosen_md,
                    "- {task}, {}: {} ({})",
                    configuration.label(),
                    links.link(&r.dir),
                    how.describe()
                );
                chosen.push((r, e, how));
            }
        }
        if let Some(rows) = choice::differences_table(task, &chosen) {
            differences.push_str(&rows);
        }
        let best: Vec<(&RunRecord, &EvalReport)> = chosen.iter().map(|(r, e, _)| (*r, *e)).collect();
        let fig3 = out.join(format!("fig3_{task}.png"));
        let curves: Vec<(Configuration, &[EpochStats])> =
            task_runs.iter().map(|r| (r.configuration(), r.metrics.as_slice())).collect();
        plot_learning_curves(task, &curves, &fig3)?;
        files.figures.push(fig3);
        if !best.is_empty() {
            let fig4 = out.join(format!("fig4_{task}.png"));
            plot_time_domain(task, &best, &fig4)?;
            files.figures.push(fig4);
        }
        for r in task_runs {
            let last = r.metrics.last().map_or_else(|| "n/a".into(), |m| format!("{:.2}", m.success_rate));
            let test = choice::rate_cell(r.eval.as_ref(), "not evaluated");
            let validation = choice::rate_cell(r.validation.as_ref(), "not evaluated");
            if r.eval.is_none() {
                missing_eval.push(links.link(&r.dir));
            }
            let _ = writeln!(
                runs_md,
                "| {} | {task} | {} | {} | {} | {last} | {validation} | {test} |",
                links.link(&r.dir),
                r.label,
                r.config.trainer.seed,
                r.metrics.len()
            );
        }
    }
    let mut summary = String::from("# fmsr report\n\n");
    let _ = writeln!(summary, "{} run(s) over {} task(s).\n", runs.len(), by_task.len());
    summary.push_str("## Table I: task performance and manipulation stability\n\n");
    summary.push_str("Success on the fixed test set: the object within the test threshold at the last step and never dropped, with its 95 % Wilson interval; the other columns are mean ± std across the test episodes of the per-episode values (total active touch sensors over the episode; mean Q_MSV and Q_VEW of the grasp matrix; mean |dQ/dt|; mean distance of the contacts to the centre of mass). A configuration with several seeds is shown by its best run on the validation episodes, as the paper shows its best.\n\n");
    summary.push_str(&table1);
    if !distances.is_empty() {
        let _ = writeln!(
            summary,
            "\nSuccess counted by the goal distance: {} (`full`: the full angle between the orientations, `q` and `-q` one orientation; `gym`: gymnasium-robotics' `2 arccos(w)` over [0, 2 pi]; `yaw`: rotation about Z alone, the oldest records).",
            distances.into_iter().collect::<Vec<_>>().join(", ")
        );
    }
    let _ = write!(summary, "\nThe run standing for each configuration:\n\n{chosen_md}");
    if !differences.is_empty() {
        summary.push_str("\n### Differences in test success\n\nThe first configuration's success minus the second's, in points, with the 95 % interval of the difference (Newcombe's hybrid score interval for independent rates; the policies played the same test episodes, so it is conservative).\n\n| Task | Configuration | Against | Difference |\n|---|---|---|---|\n");
        summary.push_str(&differences);
    }
    summary.push_str("\n## Table II: failure types\n\n");
    summary.push_str(&table2);
    summary.push_str(&chance_section(runs, &links));
    if let Some(table) = cross_engine_table(runs, &links) {
        summary.push_str("\n## Cross-engine evaluation\n\nThe same checkpoint on the fixed test set of each engine (`fmsr eval --engine`).\n\n");
        summary.push_str(&table);
        write_atomic(&out.join("cross_engine.md"), table.as_bytes())?;
    }
    summary.push_str("\n## Figures\n\n");
    for f in &files.figures {
        let name = f.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        let _ = writeln!(summary, "![{name}]({name})\n");
    }
    summary.push_str(&renderings_section(runs, out, &links)?);
    summary.push_str("## Runs\n\n");
    summary.push_str(&runs_md);
    if !missing_eval.is_empty() {
        let _ = writeln!(summary, "\nNot in the tables (run `fmsr eval` on them): {}", missing_eval.join(", "));
    }
    write_atomic(&files.summary, summary.as_bytes())?;
    write_atomic(&out.join("table1.md"), table1.as_bytes())?;
    write_atomic(&out.join("table2.md"), table2.as_bytes())?;
    Ok(files)
}

#[cfg(test)]
mod tests {
    use super::*;

    // Guards the figures' legibility: the paper-budget report drew both arms
    // in one grey, every configuration whose label was more than its
    // method's name (", trained on MuJoCo") getting the same colour. Each
    // configuration now has a colour of its own in its method's hue.
    #[test]
    fn every_configuration_has_a_colour_of_its_own() {
        use crate::experiment::Distinction::{PaperStack, TrainedOnMujoco};
        let c = |method, distinctions| Configuration { key: RunKey { method, distinctions }, policy_file: false };
        let all = vec![
            c(Method::DenseFmsrIs, vec![TrainedOnMujoco]),
            c(Method::DenseFmsrIs, vec![PaperStack, TrainedOnMujoco]),
            c(Method::Dense, vec![TrainedOnMujoco]),
            c(Method::Sparse, vec![]),
        ];
        let colours: Vec<RGBColor> = all.iter().map(|c| configuration_color(c, &all)).collect();
        for (i, a) in colours.iter().enumerate() {
            for b in &colours[i + 1..] {
                assert_ne!(a, b);
            }
        }
        assert_eq!(colours[0], method_color(Method::DenseFmsrIs));
        assert_eq!(colours[2], method_color(Method::Dense));
    }

    // Guards the report's directory (regression): a report written over an
    // earlier one used to leave that report's figures and renderings behind
    // (a task or run no longer reported still showed in `render/`), while a
    // user's own files in the directory must survive.
    #[test]
    fn a_new_report_removes_only_what_an_earlier_one_wrote() {
        let tmp = tempfile::tempdir().unwrap();
        let out = tmp.path();
        let owned = ["summary.md", "table1.md", "table2.md", "cross_engine.md", "fig3_egg.png", "fig4_block.png"];
        let kept = ["notes.md", "fig3_egg.svg", "figure.png", "render/notes.txt", "render/x-block.png"];
        std::fs::create_dir(out.join("render")).unwrap();
        for f in owned.iter().chain(&kept).chain(&["render/00-lite_egg.gif", "render/07-lite_block.png"]) {
            std::fs::write(out.join(f), b"old").unwrap();
        }
        remove_previous_report(out).unwrap();
        for f in owned.iter().chain(&["render/00-lite_egg.gif", "render/07-lite_block.png"]) {
            assert!(!out.join(f).exists(), "{f} was left");
        }
        for f in kept {
            assert!(out.join(f).exists(), "{f} was removed");
        }
    }

    // Guards the same cleaning when `render/` held only renderings: it goes too.
    #[test]
    fn an_emptied_render_directory_is_removed() {
        let tmp = tempfile::tempdir().unwrap();
        std::fs::create_dir(tmp.path().join("render")).unwrap();
        std::fs::write(tmp.path().join("render/01-tiny.gif"), b"old").unwrap();
        remove_previous_report(tmp.path()).unwrap();
        assert!(!tmp.path().join("render").exists());
        remove_previous_report(tmp.path()).unwrap();
    }
}
