//! The `fmsr` command: train, evaluate and report the paper's experiments.

use std::path::PathBuf;
use std::sync::Arc;

use std::io::IsTerminal;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};

use fmsr::artefacts::{POLICY_FILE_NAME, PolicyFile, RunDir, Source};
use fmsr::experiment::{Engine, EpisodeSet, ExperimentConfig};
use fmsr::run;
use fmsr_core::prelude::*;
use fmsr_envs::shadow_hand::GoalDistance;

/// Finger-specific Multi-agent Shadow Reward with Information Sharing.
#[derive(Debug, Parser)]
#[command(name = "fmsr", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Train one experiment; writes config, logs and a checkpoint per epoch to the run directory.
    Train(TrainArgs),
    /// Evaluate a trained run or policy file on the fixed test set (success, contacts, grasp measures, failure types).
    Eval(EvalArgs),
    /// Write a trained run's policy alone (actors, normalisers, config, commit, evaluations) into one file.
    Export(ExportArgs),
    /// Write a run's rescue point: its training state without the replay buffer, to restart it
    /// (`fmsr train --rescue`) when its checkpoint is lost.
    Rescue(RescueArgs),
    /// Write the paper's tables and figures over several runs (Tables I and II, Figs. 3 and 4).
    Report(ReportArgs),
    /// Draw one test episode of a trained run's or policy file's policy as an animated GIF (or PNG frames), headless.
    Render(RenderArgs),
    /// The main job: train the default experiment (egg, Dense+FMSR+IS, rapier, quick budget),
    /// evaluate it and write the report beside the shipped policy of its configuration.
    Run(RunArgs),
    /// The Shadow Hand model cache (the model comes from the gymnasium-robotics wheel on PyPI).
    #[command(subcommand)]
    Assets(AssetsCommand),
    /// List the network devices this build and machine can use (`cpu`, then each GPU adapter the drivers report).
    Devices,
}

#[derive(Debug, Subcommand)]
enum AssetsCommand {
    /// Download (once) and extract the model into the cache; prints the model folder.
    Fetch {
        /// Cache directory (default: `$FMSR_ASSETS_DIR`, `$XDG_CACHE_HOME/fmsr` or `~/.cache/fmsr`).
        #[arg(long)]
        dir: Option<PathBuf>,
    },
    /// Print the default cache directory.
    Path,
}

#[derive(Debug, clap::Args)]
struct TrainArgs {
    /// The experiment (TOML); with --resume the run's own config.toml is used.
    #[arg(long, default_value = "configs/egg_dense_fmsr_is_quick.toml")]
    config: PathBuf,
    /// Physics engine, overriding the config (with --resume: must be the run's).
    #[arg(long, value_enum)]
    engine: Option<EngineArg>,
    /// Seed of the trainer (and of the networks), overriding the config.
    #[arg(long)]
    seed: Option<u64>,
    /// The burn device of the networks (`cpu`; `wgpu`, `wgpu:N`, `wgpu:cpu` with
    /// `--features wgpu`; `vulkan:N` with `--features vulkan`), overriding the config.
    #[arg(long)]
    device: Option<String>,
    /// Number of epochs, overriding the config (with --resume: train up to this many).
    #[arg(long)]
    epochs: Option<usize>,
    /// Run directory (default `runs/<name>`).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Continue the run in the run directory from its last checkpoint.
    #[arg(long)]
    resume: bool,
    /// Restart the run in --out, whose checkpoint was lost, from this rescue
    /// point (`fmsr rescue`), with the run's config.toml in --out: the replay
    /// buffer is lost and refilled (--refill) before the next update; the
    /// restart goes into the run's restarts.jsonl.
    #[arg(long, conflicts_with = "resume", requires = "out")]
    rescue: Option<PathBuf>,
    /// With --rescue: exploring episodes collected into the empty replay
    /// buffer before the next update (default: one epoch's, cycles x episodes per cycle).
    #[arg(long, requires = "rescue")]
    refill: Option<usize>,
    /// No progress bar or per-epoch lines.
    #[arg(long)]
    quiet: bool,
}

#[derive(Debug, clap::Args)]
struct EvalArgs {
    /// The run directory, policy file (`fmsr export`) or directory holding `policy.fmsr` to evaluate.
    run: PathBuf,
    /// Episodes, overriding the config (paper: 100).
    #[arg(long)]
    episodes: Option<usize>,
    /// Which episodes: the fixed test set (reported) or the validation
    /// episodes, disjoint from it (to choose an epoch, a snapshot or a seed).
    #[arg(long, value_enum, default_value = "test")]
    set: SetArg,
    /// With a policy file: write this evaluation into the file, in place of
    /// the one it carries for the same engine and episodes.
    #[arg(long)]
    record: bool,
    /// Evaluate on this engine (default: the one the run trained on); another
    /// engine's evaluation goes to `eval-<engine>.json` and into the report's
    /// cross-engine table.
    #[arg(long, value_enum)]
    engine: Option<EngineArg>,
    /// Write the evaluation (JSON) here instead: by default a run's goes into
    /// its directory, a policy file's is only printed and compared with the
    /// evaluation the file carries.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Count success by this goal distance (default: the one the policy
    /// trained under, `env.goal_distance`): `full` (the full angle, gym's) or
    /// `yaw` (rotation about Z alone, the records before 2026-11-27). In a run
    /// directory, an evaluation under the other distance goes to
    /// `eval-...-<distance>.json`.
    #[arg(long, value_enum)]
    goal_distance: Option<DistanceArg>,
}

#[derive(Debug, Clone, Copy, clap::ValueEnum)]
enum DistanceArg {
    Full,
    Yaw,
}

impl From<DistanceArg> for GoalDistance {
    fn from(d: DistanceArg) -> Self {
        match d {
            DistanceArg::Full => GoalDistance::Full,
            DistanceArg::Yaw => GoalDistance::Yaw,
        }
    }
}

#[derive(Debug, clap::Args)]
struct ExportArgs {
    /// The trained run directory.
    run: PathBuf,
    /// The policy file to write (default `RUN/policy.fmsr`).
    #[arg(long)]
    out: Option<PathBuf>,
}

#[derive(Debug, clap::Args)]
struct RescueArgs {
    /// The run directory (its last checkpoint).
    run: PathBuf,
    /// The file to write (default `RUN/rescue.fmsr`).
    #[arg(long)]
    out: Option<PathBuf>,
    /// What to keep of the learner: `online` (the online networks; targets restored as
    /// them, Adam's moments fresh; about a quarter of a checkpoint), `targets`, or `full`
    /// (everything but the replay buffer).
    #[arg(long, value_enum, default_value = "online")]
    keep: KeepArg,
}

#[derive(Debug, Clone, Copy, clap::ValueEnum)]
enum KeepArg {
    Online,
    Targets,
    Full,
}

impl From<KeepArg> for fmsr_nn::RescueLevel {
    fn from(k: KeepArg) -> Self {
        match k {
            KeepArg::Online => Self::Online,
            KeepArg::Targets => Self::Targets,
            KeepArg::Full => Self::Full,
        }
    }
}

#[derive(Debug, clap::Args)]
struct ReportArgs {
    /// Run directories or policy files (each trained, and evaluated for the tables).
    #[arg(required = true)]
    runs: Vec<PathBuf>,
    /// Where to write summary.md, the tables and the PNG figures.
    #[arg(long, default_value = "report")]
    out: PathBuf,
}

#[derive(Debug, clap::Args)]
struct RenderArgs {
    /// The run directory (its last checkpoint plays the episode), or a policy file.
    run: PathBuf,
    /// Which episode of the fixed test set (0-based).
    #[arg(long, default_value_t = 0)]
    episode: usize,
    /// Simulate on this engine (default: the one the run trained on).
    #[arg(long, value_enum)]
    engine: Option<EngineArg>,
    /// A `.gif` file, or a directory for PNG frames (default `RUN/render/episode-K-ENGINE.gif`,
    /// for a policy file `render/` beside it).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Frame width (pixels).
    #[arg(long, default_value_t = 320)]
    width: usize,
    /// Frame height (pixels).
    #[arg(long, default_value_t = 240)]
    height: usize,
}

#[derive(Debug, clap::Args)]
struct RunArgs {
    /// The experiment (TOML).
    #[arg(long, default_value = "configs/egg_dense_fmsr_is_quick.toml")]
    config: PathBuf,
    /// Run directory (default `runs/<name>`); an existing run there is resumed.
    #[arg(long)]
    out: Option<PathBuf>,
    /// No progress bar or per-epoch lines.
    #[arg(long)]
    quiet: bool,
    /// Where shipped policies are looked for: the report sets the run beside
    /// those of the same configuration.
    #[arg(long, default_value = "pretrained")]
    pretrained: PathBuf,
}

#[derive(Debug, Clone, Copy, clap::ValueEnum)]
enum SetArg {
    Test,
    Validation,
}

impl From<SetArg> for EpisodeSet {
    fn from(s: SetArg) -> Self {
        match s {
            SetArg::Test => EpisodeSet::Test,
            SetArg::Validation => EpisodeSet::Validation,
        }
    }
}

#[derive(Debug, Clone, Copy, clap::ValueEnum)]
enum EngineArg {
    Rapier,
    Mujoco,
}

impl From<EngineArg> for Engine {
    fn from(e: EngineArg) -> Self {
        match e {
            EngineArg::Rapier => Engine::Rapier,
            EngineArg::Mujoco => Engine::Mujoco,
        }
    }
}

fn main() -> Result<()> {
    if std::env::var_os("BURN_DEVICE").is_none() {
        // burn creates a loaded optimiser state on its default device (a GPU
        // backend's default adapter in a GPU build) before moving it to the
        // networks' device; on the CPU that always exists (fmsr_nn::device).
        // SAFETY: the first statement of main, before any thread exists.
        unsafe { std::env::set_var("BURN_DEVICE", "flex") };
    }
    let cli = Cli::parse();
    match cli.command {
        Command::Train(args) => train(&args).map(|_| ()),
        Command::Eval(args) => eval(&args),
        Command::Export(args) => export(&args),
        Command::Rescue(args) => {
            let dir = RunDir::new(&args.run);
            let point = fmsr::run::rescue_point(&dir, args.keep.into())
                .with_context(|| format!("the rescue point of {}", dir.root().display()))?;
            let out = args.out.clone().unwrap_or_else(|| dir.root().join("rescue.fmsr"));
            point.write(&out)?;
            let bytes = std::fs::metadata(&out).map_or(0, |m| m.len());
            println!(
                "wrote {} ({:.1} MB: epoch {}, {} env steps, keeps {})",
                out.display(),
                bytes as f64 / 1e6,
                point.epoch,
                point.env_steps,
                point.keeps
            );
            Ok(())
        }
        Command::Report(args) => report(&args.runs, &args.out),
        Command::Render(args) => {
            for file in render(&args)? {
                println!("wrote {}", file.display());
            }
            Ok(())
        }
        Command::Assets(AssetsCommand::Fetch { dir }) => {
            let assets = fmsr_envs::shadow_hand::assets::fetch_hand_assets(dir.as_deref())?;
            println!("{}", assets.root.display());
            Ok(())
        }
        Command::Devices => {
            for device in fmsr_nn::device::available() {
                println!("{device}");
            }
            Ok(())
        }
        Command::Assets(AssetsCommand::Path) => {
            println!("{}", fmsr_envs::shadow_hand::assets::default_assets_dir()?.display());
            Ok(())
        }
        Command::Run(args) => {
            let name = ExperimentConfig::load(&args.config)?.name;
            let out = args.out.clone().unwrap_or_else(|| PathBuf::from("runs").join(name));
            let train_args = TrainArgs {
                config: args.config.clone(),
                engine: None,
                seed: None,
                device: None,
                epochs: None,
                resume: RunDir::new(&out).checkpoint().exists(),
                rescue: None,
                refill: None,
                out: Some(out),
                quiet: args.quiet,
            };
            let dir = train(&train_args)?;
            eval(&EvalArgs {
                run: dir.root().to_path_buf(),
                episodes: None,
                set: SetArg::Test,
                record: false,
                engine: None,
                out: None,
                goal_distance: None,
            })?;
            let config = dir.load_config()?;
            let mut runs = vec![dir.root().to_path_buf()];
            runs.extend(fmsr::artefacts::matching_policies(&args.pretrained, &config));
            report(&runs, &dir.root().join("report"))?;
            if runs.len() > 1 {
                println!(
                    "the report sets the run beside the shipped policy of its configuration: {}",
                    runs[1].display()
                );
            }
            println!("run, logs and evaluation in {}", dir.root().display());
            Ok(())
        }
    }
}

fn resolve_config(args: &TrainArgs) -> Result<(ExperimentConfig, RunDir, bool)> {
    let default_dir = |config: &ExperimentConfig| PathBuf::from("runs").join(&config.name);
    let resume = args.resume || args.rescue.is_some();
    let (mut config, dir) = if resume {
        // A resumed run keeps its own configuration; --config only names it when --out is absent.
        let dir = match &args.out {
            Some(out) => RunDir::new(out),
            None => RunDir::new(default_dir(&ExperimentConfig::load(&args.config).context("reading the experiment")?)),
        };
        (dir.load_config().context("reading the run's config.toml")?, dir)
    } else {
        let config = ExperimentConfig::load(&args.config).context("reading the experiment")?;
        let dir = RunDir::new(args.out.clone().unwrap_or_else(|| default_dir(&config)));
        (config, dir)
    };
    if let Some(e) = args.engine {
        let engine = Engine::from(e);
        if resume && engine != config.engine {
            bail!(
                "--engine {} differs from the run's engine {}: a resumed run keeps its engine \
                 (`fmsr eval --engine {}` evaluates it on the other)",
                engine.key(),
                config.engine.key(),
                engine.key()
            );
        }
        config.engine = engine;
    }
    if let Some(seed) = args.seed {
        if resume && seed != config.trainer.seed {
            bail!("--seed {seed} differs from the run's seed {}: a resumed run keeps its seed", config.trainer.seed);
        }
        config.trainer.seed = seed;
    }
    if let Some(epochs) = args.epochs {
        config.trainer.epochs = epochs;
    }
    if let Some(device) = &args.device {
        config.device.clone_from(device);
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

/// `fmsr train`: in this process, or as one rank of an `mpirun` job.
fn train(args: &TrainArgs) -> Result<RunDir> {
    if run::launched_with_several_ranks() {
        return train_mpi(args);
    }
    train_with(args, Arc::new(SingleProcess))
}

#[cfg(feature = "mpi")]
fn train_mpi(args: &TrainArgs) -> Result<RunDir> {
    let mpi = fmsr::mpi::Mpi::init()?;
    let comm = Arc::new(mpi.communicator());
    match train_with(args, comm.clone()) {
        Ok(dir) => Ok(dir),
        Err(e) => {
            // The other ranks would wait for this one forever: end the job.
            eprintln!("error on MPI rank {}: {e:#}", comm.rank());
            comm.abort(1)
        }
    }
}

#[cfg(not(feature = "mpi"))]
fn train_mpi(_args: &TrainArgs) -> Result<RunDir> {
    bail!(
        "started by mpirun as one of several ranks, but this fmsr was built without the `mpi` feature: \
         build with `cargo build --release --features mpi` (after scripts/setup_mpi.sh)"
    )
}

fn train_with(args: &TrainArgs, comm: Arc<dyn Communicator>) -> Result<RunDir> {
    let (config, dir, resume) = resolve_config(args)?;
    let done = if resume { dir.load_metrics().map(|m| m.len()).unwrap_or(0) } else { 0 };
    let rank = comm.rank();
    if rank == 0 {
        eprintln!(
            "training {} ({}, {}, {:?}) for {} epochs into {}{}",
            config.name,
            config.method.label(),
            config.algorithm.key(),
            config.engine,
            config.trainer.epochs,
            dir.root().display(),
            if resume { " (resumed)" } else { "" }
        );
        if comm.workers() > 1 {
            eprintln!("on {} MPI ranks", comm.workers());
        }
    }
    let mut progress = Progress::new(&config, done, rank == 0 && !args.quiet);
    let on_epoch = |s: &EpochStats| progress.epoch(s);
    let envs = (0..config.trainer.worker_envs(comm.workers())?)
        .map(|_| config.env_config().init_engine(config.engine))
        .collect::<Result<Vec<_>, _>>()
        .with_context(|| format!("building the {} Shadow Hand", config.engine.key()))?;
    let rescue = args.rescue.as_deref().map(fmsr::core::trainer::RescuePoint::read).transpose()?;
    let start = match &rescue {
        Some(point) => {
            let refill = args.refill.unwrap_or(config.trainer.cycles * config.trainer.episodes_per_cycle);
            eprintln!(
                "restarting from the rescue point of epoch {} (keeps {}): {} episodes of replay lost, {refill} collected first",
                point.epoch, point.keeps, point.stored_episodes
            );
            run::Start::Rescue { point, refill }
        }
        None if resume => run::Start::Resume,
        None => run::Start::New,
    };
    run::train_from(&config, envs, &dir, start, comm.clone(), on_epoch)?;
    progress.finish();
    Ok(dir)
}

fn eval(args: &EvalArgs) -> Result<()> {
    let source = Source::open(&args.run)?;
    let mut config = source.config().context("reading the run's config.toml")?;
    if let Some(n) = args.episodes {
        config.eval.episodes = n;
    }
    let trained_under = config.env.goal_distance;
    if let Some(d) = args.goal_distance {
        config.env.goal_distance = d.into();
    }
    config.validate()?;
    let engine = args.engine.map_or(config.engine, Engine::from);
    let set = EpisodeSet::from(args.set);
    let dt = fmsr::experiment::MODEL_TIMESTEP * config.env.substeps as f64;
    let env = config
        .env_config()
        .init_engine(engine)
        .with_context(|| format!("building the {} Shadow Hand", engine.key()))?;
    let summary = fmsr::evaluate::evaluate_source_on(&config, env, engine, set, &source, dt)?;
    println!("{}", summary.to_markdown());
    let out = match &source {
        Source::Run(dir) => Some(args.out.clone().unwrap_or_else(|| {
            let path = dir.eval_json_for(engine, config.engine, set);
            if config.env.goal_distance == trained_under {
                return path;
            }
            let stem = path.file_stem().and_then(|s| s.to_str()).unwrap_or("eval").to_owned();
            path.with_file_name(format!("{stem}-{}.json", config.env.goal_distance.key()))
        })),
        Source::Policy { .. } => args.out.clone(),
    };
    if let Some(out) = out {
        fmsr::artefacts::write_eval(&summary, &out)?;
        println!("evaluation written to {}", out.display());
    }
    match &source {
        Source::Policy { file, path } if args.record => {
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
        Source::Run(_) if args.record => {
            bail!("--record writes into a policy file; a run's evaluation is written to its directory")
        }
        Source::Run(_) => {}
    }
    Ok(())
}

/// Says whether a policy file's new evaluation repeats the one it carries.
fn compare_with_carried(file: &PolicyFile, path: &std::path::Path, summary: &fmsr::artefacts::EvalReport) {
    let engine = summary.engine.as_str();
    match file.eval_under(engine, summary.set, summary.goal_distance) {
        Some(recorded) if recorded.same_results(summary) => println!(
            "{}: the same results as the evaluation the file carries (every episode's outcome and final angle)",
            path.display()
        ),
        Some(recorded) if recorded.success_rule != summary.success_rule => println!(
            "{}: the file carries an evaluation under the old definition of success ({}: {}); this one counts a drop as a failure \
             (`fmsr eval {} --record` writes it into the file)",
            path.display(),
            recorded.success_cell(),
            recorded.success_rule.describe(),
            path.display()
        ),
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

fn export(args: &ExportArgs) -> Result<()> {
    let dir = RunDir::new(&args.run);
    let file = PolicyFile::from_run(&dir).with_context(|| format!("exporting {}", dir.root().display()))?;
    let out = args.out.clone().unwrap_or_else(|| dir.root().join(POLICY_FILE_NAME));
    file.write(&out)?;
    if file.evals.is_empty() {
        eprintln!("note: the run has no evaluation (run `fmsr eval` on it first), so the file carries none");
    }
    if file.provenance.commit.is_none() {
        eprintln!("note: the run names no commit (it predates provenance.json, or was not started in a git checkout)");
    }
    let bytes = std::fs::metadata(&out).map_or(0, |m| m.len());
    println!(
        "wrote {} ({:.1} MB: {} after {} epochs, commit {})",
        out.display(),
        bytes as f64 / 1e6,
        file.config.label(),
        file.epochs,
        file.provenance.commit_label()
    );
    Ok(())
}

fn render(args: &RenderArgs) -> Result<Vec<PathBuf>> {
    use fmsr::artefacts::RenderTarget;
    use fmsr::render::record_source_episode;
    let source = Source::open(&args.run)?;
    let config = source.config().context("reading the run's config.toml")?;
    let engine = args.engine.map_or(config.engine, Engine::from);
    let target = match &args.out {
        Some(out) => RenderTarget::from_path(out)?,
        None => source.render_target(args.episode, Some(engine))?,
    };
    let env = config
        .env_config()
        .init_engine(engine)
        .with_context(|| format!("building the {} Shadow Hand", engine.key()))?;
    let film = record_source_episode(&config, env, engine, &source, args.episode)?;
    let scene = fmsr::render::load_scene(&config)?;
    let camera = fmsr::envs::shadow_hand::render::Camera::gym(args.width, args.height);
    Ok(fmsr::render::write_film(&scene, &film, &camera, &target)?)
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
            eprintln!("warning: not rendering {}: {e:#}", run.display());
        }
    }
}

fn report(runs: &[PathBuf], out: &std::path::Path) -> Result<()> {
    render_for_report(runs);
    let records = runs
        .iter()
        .map(|r| fmsr::report::RunRecord::open(r).with_context(|| format!("reading the run {}", r.display())))
        .collect::<Result<Vec<_>>>()?;
    let files = fmsr::report::write_report(&records, out)?;
    println!("report written to {} ({} figures)", files.summary.display(), files.figures.len());
    Ok(())
}
