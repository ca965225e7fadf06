//! The commands of [`super`], each as a function of its arguments ([`super::args`]).

use std::io::IsTerminal;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use indicatif::{ProgressBar, ProgressStyle};

use super::args::{EvalArgs, ExportArgs, RenderArgs, TrainArgs};
use crate::artefacts::{POLICY_FILE_NAME, PolicyFile, RunDir, Source};
use crate::error::ExperimentError;
use crate::evaluate::EvalProgress;
use crate::experiment::{Engine, EpisodeSet, ExperimentConfig};
use crate::run;
use fmsr_core::prelude::*;

type Result<T, E = ExperimentError> = std::result::Result<T, E>;

/// What a command was doing when an error stopped it
/// ([`ExperimentError::Context`]).
pub(super) trait Context<T> {
    /// The error, said to have happened while doing `what`.
    fn context<S: Into<String>>(self, what: impl FnOnce() -> S) -> Result<T>;
}

impl<T, E: std::error::Error + Send + Sync + 'static> Context<T> for Result<T, E> {
    fn context<S: Into<String>>(self, what: impl FnOnce() -> S) -> Result<T> {
        self.map_err(|e| ExperimentError::Context { what: what().into(), source: Box::new(e) })
    }
}

/// The run's Shadow Hand on `engine` (which `fmsr eval` and `render` may
/// choose apart from the one it trained on).
fn hand_on(config: &ExperimentConfig, engine: Engine) -> Result<fmsr_envs::shadow_hand::ShadowHand> {
    config.env_config().init_engine(engine).context(|| format!("building the {} Shadow Hand", engine.key()))
}

/// A refused argument.
fn refuse<T>(arg: &'static str, reason: String) -> Result<T> {
    Err(ExperimentError::Cli { arg, reason })
}

fn resolve_config(args: &TrainArgs) -> Result<(ExperimentConfig, RunDir, bool)> {
    let default_dir = |config: &ExperimentConfig| PathBuf::from("runs").join(&config.name);
    let resume = args.resume || args.rescue.is_some();
    let (mut config, dir) = if resume {
        // A resumed run keeps its own configuration; --config only names it when --out is absent.
        let dir = match &args.out {
            Some(out) => RunDir::new(out),
            None => {
                RunDir::new(default_dir(&super::load_experiment(&args.config).context(|| "reading the experiment")?))
            }
        };
        (dir.load_config().context(|| "reading the run's config.toml")?, dir)
    } else {
        let config = super::load_experiment(&args.config).context(|| "reading the experiment")?;
        let dir = RunDir::new(args.out.clone().unwrap_or_else(|| default_dir(&config)));
        (config, dir)
    };
    if let Some(e) = args.engine {
        let engine = Engine::from(e);
        if !config.is_shadow_hand() {
            return refuse(
                "--engine",
                format!("the task `{}` has no engines: --engine chooses the Shadow Hand's", config.task),
            );
        }
        if resume && engine != config.engine {
            return refuse(
                "--engine",
                format!(
                    "--engine {} differs from the run's engine {}: a resumed run keeps its engine \
                     (`fmsr eval --engine {}` evaluates it on the other)",
                    engine.key(),
                    config.engine.key(),
                    engine.key()
                ),
            );
        }
        config.engine = engine;
    }
    if let Some(seed) = args.seed {
        if resume && seed != config.trainer.seed {
            return refuse(
                "--seed",
                format!(
                    "--seed {seed} differs from the run's seed {}: a resumed run keeps its seed",
                    config.trainer.seed
                ),
            );
        }
        config.trainer.seed = seed;
    }
    if let Some(epochs) = args.epochs {
        config.trainer.epochs = epochs;
    }
    if let Some(device) = &args.device {
        config.device = device
            .parse()
            .map_err(|e: fmsr_nn::NnError| ExperimentError::Cli { arg: "--device", reason: e.to_string() })?;
    }
    config.validate()?;
    Ok((config, dir, resume))
}

/// How training shows its progress: a bar on a terminal, one line per epoch
/// in a log (stderr not a terminal), nothing with `--quiet` or on other MPI ranks.
enum Progress {
    Bar(ProgressBar),
    Lines { total: usize, episodes: (usize, usize), start: Instant, timed: usize },
    Quiet,
}

impl Progress {
    fn new(config: &ExperimentConfig, done: usize, show: bool) -> Self {
        if !show {
            return Self::Quiet;
        }
        if !std::io::stderr().is_terminal() {
            let t = &config.trainer;
            let episodes = (t.cycles * t.episodes_per_cycle, t.eval_episodes);
            return Self::Lines { total: t.epochs, episodes, start: Instant::now(), timed: 0 };
        }
        let bar = ProgressBar::new(config.trainer.epochs as u64);
        bar.set_style(
            ProgressStyle::with_template("{prefix} [{bar:30}] epoch {pos}/{len} ETA {eta} {msg}")
                .expect("a valid template")
                .progress_chars("=> "),
        );
        bar.set_prefix(format!("{} ({})", config.name, config.method.label()));
        bar.set_position(done as u64);
        Self::Bar(bar)
    }

    fn epoch(&mut self, s: &EpochStats) {
        match self {
            Self::Bar(bar) => {
                bar.set_message(format!(
                    "success {:.2} | train {:.2} | {:.0} steps/s | {:.1} updates/s",
                    s.success_rate, s.train_success_rate, s.env_steps_per_sec, s.updates_per_sec
                ));
                bar.inc(1);
            }
            Self::Lines { total, episodes, start, timed } => {
                *timed += 1;
                eprintln!("{}", run::epoch_line(s, *episodes, *total, start.elapsed().as_secs_f64(), *timed));
            }
            Self::Quiet => {}
        }
    }

    fn finish(&self) {
        if let Self::Bar(bar) = self {
            bar.finish();
        }
    }
}

/// How a long command other than training shows where it stands: a bar of
/// its items on a terminal, else one line per stage on stderr (for logs).
struct StageProgress {
    what: String,
    bar: Option<ProgressBar>,
    start: Instant,
}

impl StageProgress {
    fn new(what: &str, items: usize) -> Self {
        let bar = std::io::stderr().is_terminal().then(|| {
            let bar = ProgressBar::new(items as u64);
            bar.set_style(
                ProgressStyle::with_template("{prefix} [{bar:30}] {pos}/{len} ETA {eta} {msg}")
                    .expect("a valid template")
                    .progress_chars("=> "),
            );
            bar.set_prefix(what.to_owned());
            bar
        });
        Self { what: what.to_owned(), bar, start: Instant::now() }
    }

    /// A new stage: the bar's message, or a line.
    fn stage(&mut self, stage: &str) {
        match &self.bar {
            Some(bar) => bar.set_message(stage.to_owned()),
            None => eprintln!("{}: {stage} ({:.0} s)", self.what, self.start.elapsed().as_secs_f64()),
        }
    }

    /// `done` items so far (the bar only: a log gets the stages).
    fn set(&self, done: usize) {
        if let Some(bar) = &self.bar {
            bar.set_position(done as u64);
        }
    }

    fn finish(&self) {
        match &self.bar {
            Some(bar) => bar.finish_and_clear(),
            None => eprintln!("{}: done in {:.0} s", self.what, self.start.elapsed().as_secs_f64()),
        }
    }
}

/// `fmsr train`: in this process, or as one rank of an `mpirun` job.
pub(super) fn train(args: &TrainArgs) -> Result<RunDir> {
    if run::launched_with_several_ranks() {
        return train_mpi(args);
    }
    train_with(args, Arc::new(SingleProcess))
}

#[cfg(feature = "mpi")]
fn train_mpi(args: &TrainArgs) -> Result<RunDir> {
    let mpi = crate::mpi::Mpi::init().context(|| "starting MPI")?;
    let comm = Arc::new(mpi.communicator());
    match train_with(args, comm.clone()) {
        Ok(dir) => Ok(dir),
        Err(e) => {
            // The other ranks would wait for this one forever: end the job.
            eprintln!("error on MPI rank {}: {e}", comm.rank());
            comm.abort(1)
        }
    }
}

#[cfg(not(feature = "mpi"))]
fn train_mpi(_args: &TrainArgs) -> Result<RunDir> {
    refuse(
        "mpirun",
        "started by mpirun as one of several ranks, but this fmsr was built without the `mpi` feature: \
         build with `cargo build --release --features mpi` (after scripts/setup_mpi.sh)"
            .into(),
    )
}

fn train_with(args: &TrainArgs, comm: Arc<dyn Communicator>) -> Result<RunDir> {
    let (config, dir, resume) = resolve_config(args)?;
    let done = if resume { dir.load_metrics().map(|m| m.len()).unwrap_or(0) } else { 0 };
    let rank = comm.rank();
    if rank == 0 {
        let on = if config.is_shadow_hand() { format!("{:?}", config.engine) } else { config.task.clone() };
        eprintln!(
            "training {} ({}, {}, {on}) for {} epochs into {}{}",
            config.name,
            config.method.label(),
            config.algorithm,
            config.trainer.epochs,
            dir.root().display(),
            if resume { " (resumed)" } else { "" }
        );
        if comm.workers() > 1 {
            eprintln!("on {} MPI ranks", comm.workers());
        }
    }
    let progress = Progress::new(&config, done, rank == 0 && !args.quiet);
    let envs = config.task_envs(config.trainer.worker_envs(comm.workers())?)?;
    train_on(args, &config, dir, envs, comm, progress)
}

/// Trains `config` on `envs` into `dir`, as `args` say (new, resumed, rescued).
fn train_on(
    args: &TrainArgs,
    config: &ExperimentConfig,
    dir: RunDir,
    envs: Vec<AnyEnv>,
    comm: Arc<dyn Communicator>,
    mut progress: Progress,
) -> Result<RunDir> {
    let resume = args.resume || args.rescue.is_some();
    let on_epoch = |s: &EpochStats| progress.epoch(s);
    let rescue = args.rescue.as_deref().map(fmsr_core::trainer::RescuePoint::read).transpose()?;
    let start = match &rescue {
        Some(point) => {
            let refill = args.refill.unwrap_or(config.trainer.cycles * config.trainer.episodes_per_cycle);
            eprintln!(
                "restarting from the rescue point of epoch {} (keeps {}): its replay buffer is lost (restarts.jsonl counts it), {refill} episodes collected first",
                point.epoch, point.keeps
            );
            run::Start::Rescue { point, refill }
        }
        None if resume => run::Start::Resume,
        None => run::Start::New,
    };
    run::train_from(config, envs, &dir, start, comm.clone(), on_epoch)?;
    progress.finish();
    Ok(dir)
}

/// One evaluation's choices, from the command line or from a carried evaluation.
struct EvalChoice {
    episodes: Option<usize>,
    set: EpisodeSet,
    engine: Option<Engine>,
    goal_distance: Option<fmsr_envs::shadow_hand::GoalDistance>,
    out: Option<PathBuf>,
    record: bool,
}

pub(super) fn eval(args: &EvalArgs) -> Result<()> {
    let choice = EvalChoice {
        episodes: args.episodes,
        set: EpisodeSet::from(args.set),
        engine: args.engine.map(Engine::from),
        goal_distance: args.goal_distance.map(Into::into),
        out: args.out.clone(),
        record: args.record,
    };
    if !args.carried {
        return eval_once(&args.run, &choice);
    }
    let Source::Policy { file, path } = Source::open(&args.run)? else {
        return refuse("--carried", "a run directory carries no evaluations: give it a policy file".into());
    };
    if file.evals.is_empty() {
        return refuse("--carried", format!("{} carries no evaluation", path.display()));
    }
    for carried in &file.evals {
        let Some(engine) = Engine::ALL.into_iter().find(|e| e.key() == carried.engine) else {
            return refuse(
                "--carried",
                format!("{} carries an evaluation on an unknown engine {:?}", path.display(), carried.engine),
            );
        };
        let one = EvalChoice {
            episodes: Some(carried.episodes),
            set: carried.set,
            engine: Some(engine),
            goal_distance: Some(carried.goal_distance),
            out: None,
            record: args.record,
        };
        // Each --record rewrites the file: read it again for the next.
        eval_once(&path, &one)?;
    }
    Ok(())
}

fn eval_once(run: &std::path::Path, choice: &EvalChoice) -> Result<()> {
    let source = Source::open(run)?;
    let mut config = source.config().context(|| "reading the run's config.toml")?;
    if let Some(n) = choice.episodes {
        config.eval.episodes = n;
    }
    if !config.is_shadow_hand() {
        return eval_task(run, &source, &config, choice);
    }
    let trained_under = config.env.goal_distance;
    if let Some(d) = choice.goal_distance {
        config.env.goal_distance = d;
    }
    config.validate()?;
    let engine = choice.engine.unwrap_or(config.engine);
    let set = choice.set;
    let dt = crate::experiment::MODEL_TIMESTEP * config.env.substeps as f64;
    let env = hand_on(&config, engine)?;
    let what = format!("{} on {} ({} episodes)", set.key(), engine.key(), config.eval.episodes);
    let mut shown = StageProgress::new(&format!("eval {}", run.display()), config.eval.episodes);
    shown.stage(&format!("playing the {what}"));
    let mut on_progress = |p: EvalProgress| match p {
        EvalProgress::Policy { done, .. } => shown.set(done),
        EvalProgress::HoldingStill => shown.stage("the same episodes by a hand that holds still"),
    };
    let summary = crate::evaluate::evaluate_source_with(&config, env, engine, set, &source, dt, &mut on_progress)?;
    shown.finish();
    println!("{}", summary.to_markdown());
    let out = match &source {
        Source::Run(dir) => Some(choice.out.clone().unwrap_or_else(|| {
            let path = dir.eval_json_for(engine, config.engine, set);
            if config.env.goal_distance == trained_under {
                return path;
            }
            let stem = path.file_stem().and_then(|s| s.to_str()).unwrap_or("eval").to_owned();
            path.with_file_name(format!("{stem}-{}.json", config.env.goal_distance.key()))
        })),
        Source::Policy { .. } => choice.out.clone(),
    };
    if let Some(out) = out {
        crate::artefacts::write_eval(&summary, &out)?;
        println!("evaluation written to {}", out.display());
    }
    match &source {
        Source::Policy { file, path } if choice.record => {
            compare_with_carried(file, path, &summary);
            let mut file = file.as_ref().clone();
            file.record_eval(summary);
            file.write(path)?;
            println!(
                "{}: the evaluation is now the one the file carries for {} ({})",
                path.display(),
                engine.key(),
                set.key()
            );
        }
        Source::Policy { file, path } => compare_with_carried(file, path, &summary),
        Source::Run(_) if choice.record => {
            return refuse(
                "--record",
                "--record writes into a policy file; a run's evaluation is written to its directory".into(),
            );
        }
        Source::Run(_) => {}
    }
    Ok(())
}

/// `fmsr eval` of a registered task ([`crate::task_eval`]): printed, and
/// written into a run's directory or to `--out`.
fn eval_task(run: &std::path::Path, source: &Source, config: &ExperimentConfig, choice: &EvalChoice) -> Result<()> {
    let task = &config.task;
    let none_of = |arg: &'static str, what: &str| {
        refuse(arg, format!("the task `{task}` has no {what}: {arg} is the Shadow Hand's"))
    };
    if choice.engine.is_some() {
        return none_of("--engine", "engines");
    }
    if choice.goal_distance.is_some() {
        return none_of("--goal-distance", "choice of goal distance");
    }
    if choice.record {
        return refuse("--record", format!("a policy file of the task `{task}` carries no evaluation"));
    }
    config.validate()?;
    let mut shown = StageProgress::new(&format!("eval {}", run.display()), 1);
    shown.stage(&format!("playing the {} set of {task} ({} episodes)", choice.set.key(), config.eval.episodes));
    let report = crate::task_eval::evaluate_task(config, choice.set, source)?;
    shown.set(1);
    shown.finish();
    println!("{}", report.to_markdown());
    let out = match source {
        Source::Run(dir) => {
            Some(choice.out.clone().unwrap_or_else(|| crate::task_eval::TaskEvalReport::path_in(dir, choice.set)))
        }
        Source::Policy { .. } => choice.out.clone(),
    };
    if let Some(out) = out {
        let json = serde_json::to_vec_pretty(&report)
            .map_err(|e| ExperimentError::Encode { what: "the task's evaluation", reason: e.to_string() })?;
        fmsr_core::persist::write_atomic(&out, &json)?;
        println!("evaluation written to {}", out.display());
    }
    Ok(())
}

/// Says whether a policy file's new evaluation repeats the one it carries.
fn compare_with_carried(file: &PolicyFile, path: &std::path::Path, summary: &crate::artefacts::EvalReport) {
    let engine = summary.engine.as_str();
    match file.eval_under(engine, summary.set, summary.goal_distance) {
        Some(recorded) if recorded.same_results(summary) => println!(
            "{}: the same results as the evaluation the file carries (every episode's outcome and final angle)",
            path.display()
        ),
        Some(recorded) if recorded.precision != summary.precision => {
            let changed = summary.outcome_changes(recorded).map_or_else(String::new, |(changed, both)| {
                format!("; {changed} of the {both} episodes end otherwise")
            });
            println!(
                "{}: at {} precision {} (the evaluation the file carries, at {} precision: {}){changed}.",
                path.display(),
                summary.precision.key(),
                summary.success_cell(),
                recorded.precision.key(),
                recorded.success_cell()
            );
        }
        Some(recorded) => println!(
            "{}: differs from the evaluation the file carries ({} now, {} recorded over {} episodes)",
            path.display(),
            summary.success_cell(),
            recorded.success_cell(),
            recorded.episodes
        ),
        None => println!(
            "{}: the file carries no {} evaluation on {engine} by the {} distance to compare with",
            path.display(),
            summary.set.key(),
            summary.goal_distance.key()
        ),
    }
}

pub(super) fn export(args: &ExportArgs) -> Result<()> {
    let precision = fmsr_nn::PolicyPrecision::from(args.precision);
    let (file, out) = match Source::open(&args.run)? {
        Source::Run(dir) => {
            let file = PolicyFile::from_run(&dir).context(|| format!("exporting {}", dir.root().display()))?;
            let out = args.out.clone().unwrap_or_else(|| dir.root().join(POLICY_FILE_NAME));
            (file, out)
        }
        Source::Policy { file, path } => {
            let Some(out) = args.out.clone() else {
                return refuse(
                    "--out",
                    format!("{} is a policy file: name the file to write with --out", path.display()),
                );
            };
            (*file, out)
        }
    };
    let file = file
        .at_precision(precision)
        .context(|| format!("writing {} at {} precision", out.display(), precision.key()))?;
    file.write(&out)?;
    if file.evals.is_empty() {
        eprintln!("note: the run has no evaluation (run `fmsr eval` on it first), so the file carries none");
    } else if file.evals.iter().any(|e| e.precision != precision) {
        eprintln!(
            "note: the file carries evaluations measured at another precision: `fmsr eval {}` compares a new one with them, `--record` makes it the file's own",
            out.display()
        );
    }
    if file.provenance.commit.is_none() {
        eprintln!("note: the run names no commit (it predates provenance.json, or was not started in a git checkout)");
    }
    let bytes = std::fs::metadata(&out).map_or(0, |m| m.len());
    println!(
        "wrote {} ({:.1} MB, {} precision: {} after {} epochs, commit {})",
        out.display(),
        bytes as f64 / 1e6,
        precision.key(),
        file.config.label(),
        file.epochs,
        file.provenance.commit_label()
    );
    Ok(())
}

pub(super) fn render(args: &RenderArgs) -> Result<Vec<PathBuf>> {
    use crate::artefacts::RenderTarget;
    use crate::render::record_source_episode;
    let source = Source::open(&args.run)?;
    let config = source.config().context(|| "reading the run's config.toml")?;
    if !config.is_shadow_hand() {
        return refuse(
            "run",
            format!("`fmsr render` draws the Shadow Hand; {} trained the task `{}`", args.run.display(), config.task),
        );
    }
    let engine = args.engine.map_or(config.engine, Engine::from);
    let target = match &args.out {
        Some(out) => RenderTarget::from_path(out)?,
        None => source.render_target(args.episode, Some(engine))?,
    };
    let env = hand_on(&config, engine)?;
    let mut shown = StageProgress::new(&format!("render {}", args.run.display()), 3);
    shown.stage(&format!("playing test episode {} on {}", args.episode, engine.key()));
    let film = record_source_episode(&config, env, engine, &source, args.episode)?;
    shown.set(1);
    shown.stage("loading the meshes");
    let scene = crate::render::load_scene(&config)?;
    shown.set(2);
    shown.stage("drawing the frames");
    let camera = fmsr_envs::shadow_hand::render::Camera::gym(args.width, args.height);
    let written = crate::render::write_film(&scene, &film, &camera, &target)?;
    shown.set(3);
    shown.finish();
    Ok(written)
}

/// Renders test episode 0 of each run on its own engine, unless already drawn
/// (the report shows its frame strip and links the GIF).
fn render_for_report(runs: &[PathBuf]) {
    for run in runs {
        let Ok(source) = Source::open(run) else { continue };
        let Ok(target) = source.render_target(0, None) else { continue };
        let untrained = matches!(&source, Source::Run(dir) if !dir.checkpoint().exists());
        if target.strip_path().is_some_and(|p| p.exists()) || untrained {
            continue;
        }
        let args = RenderArgs { run: run.clone(), episode: 0, engine: None, out: None, width: 320, height: 240 };
        // A run the report can still tabulate (an old checkpoint format, an engine
        // not built in) is reported without its rendering; the summary lists it.
        if let Err(e) = render(&args) {
            eprintln!("warning: not rendering {}: {e}", run.display());
        }
    }
}

pub(super) fn report(runs: &[PathBuf], out: &std::path::Path) -> Result<()> {
    let mut tasks = Vec::new();
    for run in runs {
        let config = Source::open(run)?.config().context(|| format!("reading the run {}", run.display()))?;
        if !config.is_shadow_hand() {
            tasks.push(run);
        }
    }
    if !tasks.is_empty() {
        if tasks.len() < runs.len() {
            return refuse(
                "runs",
                format!(
                    "{} trained a registered task and the others the Shadow Hand: report them apart (the \
                     Shadow Hand's report has the paper's tables, a task's the measures every task has)",
                    tasks[0].display()
                ),
            );
        }
        let records = runs
            .iter()
            .map(|r| crate::report::TaskRunRecord::open(r).context(|| format!("reading the run {}", r.display())))
            .collect::<Result<Vec<_>>>()?;
        let files = crate::report::write_task_report(&records, out)?;
        println!("report written to {} ({} figures)", files.summary.display(), files.figures.len());
        return Ok(());
    }
    let mut shown = StageProgress::new("report", 3);
    shown.stage(&format!("rendering test episode 0 of the {} run(s) not yet drawn", runs.len()));
    render_for_report(runs);
    shown.set(1);
    shown.stage("reading the runs");
    let records = runs
        .iter()
        .map(|r| crate::report::RunRecord::open(r).context(|| format!("reading the run {}", r.display())))
        .collect::<Result<Vec<_>>>()?;
    shown.set(2);
    shown.stage("writing the tables and figures");
    let files = crate::report::write_report(&records, out)?;
    shown.set(3);
    shown.finish();
    println!("report written to {} ({} figures)", files.summary.display(), files.figures.len());
    Ok(())
}
