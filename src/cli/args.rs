//! The arguments of the `fmsr` command ([`super`]), as clap parses them.

use std::path::PathBuf;

use clap::{Parser, Subcommand};

use crate::experiment::{Engine, EpisodeSet};
use fmsr_envs::shadow_hand::GoalDistance;

/// Finger-specific Multi-agent Shadow Reward with Information Sharing.
#[derive(Debug, Parser)]
#[command(name = "fmsr", version, about)]
pub(super) struct Cli {
    #[command(subcommand)]
    pub(super) command: Command,
}

#[derive(Debug, Subcommand)]
pub(super) enum Command {
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
pub(super) enum AssetsCommand {
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
pub(super) struct TrainArgs {
    /// The experiment (TOML); with --resume the run's own config.toml is used.
    /// The default, where no file is at its path, is the copy built into the binary.
    #[arg(long, default_value = super::DEFAULT_CONFIG)]
    pub(super) config: PathBuf,
    /// Physics engine, overriding the config (with --resume: must be the run's).
    #[arg(long, value_enum)]
    pub(super) engine: Option<EngineArg>,
    /// Seed of the trainer (and of the networks), overriding the config.
    #[arg(long)]
    pub(super) seed: Option<u64>,
    /// The burn device of the networks (`cpu`; `wgpu`, `wgpu:N`, `wgpu:cpu` with
    /// `--features wgpu`; `vulkan:N` with `--features vulkan`), overriding the config.
    #[arg(long)]
    pub(super) device: Option<String>,
    /// Number of epochs, overriding the config (with --resume: train up to this many).
    #[arg(long)]
    pub(super) epochs: Option<usize>,
    /// Run directory (default `runs/<name>`).
    #[arg(long)]
    pub(super) out: Option<PathBuf>,
    /// Continue the run in the run directory from its last checkpoint.
    #[arg(long)]
    pub(super) resume: bool,
    /// Restart the run in --out, whose checkpoint was lost, from this rescue
    /// point (`fmsr rescue`), with the run's config.toml in --out: the replay
    /// buffer is lost and refilled (--refill) before the next update; the
    /// restart goes into the run's restarts.jsonl.
    #[arg(long, conflicts_with = "resume", requires = "out")]
    pub(super) rescue: Option<PathBuf>,
    /// With --rescue: exploring episodes collected into the empty replay
    /// buffer before the next update (default: one epoch's, cycles x episodes per cycle).
    #[arg(long, requires = "rescue")]
    pub(super) refill: Option<usize>,
    /// No progress bar or per-epoch lines.
    #[arg(long)]
    pub(super) quiet: bool,
}

#[derive(Debug, clap::Args)]
pub(super) struct EvalArgs {
    /// The run directory, policy file (`fmsr export`) or directory holding `policy.fmsr` to evaluate.
    pub(super) run: PathBuf,
    /// Episodes, overriding the config (paper: 100).
    #[arg(long)]
    pub(super) episodes: Option<usize>,
    /// Which episodes: the fixed test set (reported) or the validation
    /// episodes, disjoint from it (to choose an epoch, a snapshot or a seed).
    #[arg(long, value_enum, default_value = "test")]
    pub(super) set: SetArg,
    /// With a policy file: write this evaluation into the file, in place of
    /// the one it carries for the same engine and episodes (after comparing the two).
    #[arg(long)]
    pub(super) record: bool,
    /// Evaluate on this engine (default: the one the run trained on); another
    /// engine's evaluation goes to `eval-<engine>.json` and into the report's
    /// cross-engine table.
    #[arg(long, value_enum)]
    pub(super) engine: Option<EngineArg>,
    /// Write the evaluation (JSON) here instead: by default a run's goes into
    /// its directory, a policy file's is only printed and compared with the
    /// evaluation the file carries.
    #[arg(long)]
    pub(super) out: Option<PathBuf>,
    /// Count success by this goal distance (default: the one the policy
    /// trained under, `env.goal_distance`): `full` (the full angle, `q` and
    /// `-q` one orientation), `gym` (gymnasium-robotics' `2 arccos(w)` over
    /// [0, 2 pi]; the policy then observes the engine's quaternion sign) or
    /// `yaw` (rotation about Z alone, the oldest records). In a run
    /// directory, an evaluation under the other distance goes to
    /// `eval-...-<distance>.json`.
    #[arg(long, value_enum)]
    pub(super) goal_distance: Option<DistanceArg>,
    /// With a policy file: every evaluation the file carries, again (its engine,
    /// episode set, episodes and goal distance), each compared with the carried one;
    /// with --record, each then replaces it (after `fmsr export --precision half`, say).
    #[arg(long, conflicts_with_all = ["episodes", "engine", "out", "goal_distance"])]
    pub(super) carried: bool,
}

#[derive(Debug, Clone, Copy, clap::ValueEnum)]
pub(super) enum DistanceArg {
    Full,
    Gym,
    Yaw,
}

impl From<DistanceArg> for GoalDistance {
    fn from(d: DistanceArg) -> Self {
        match d {
            DistanceArg::Full => GoalDistance::Full,
            DistanceArg::Gym => GoalDistance::Gym,
            DistanceArg::Yaw => GoalDistance::Yaw,
        }
    }
}

#[derive(Debug, clap::Args)]
pub(super) struct ExportArgs {
    /// The trained run directory, or a policy file to write again at another precision.
    pub(super) run: PathBuf,
    /// The policy file to write (default `RUN/policy.fmsr`; needed when RUN is a policy file).
    #[arg(long)]
    pub(super) out: Option<PathBuf>,
    /// The actors' precision: `full` (f32, as trained) or `half` (f16, about half the
    /// bytes; the file keeps its evaluations, measured at full precision, until `fmsr
    /// eval --record` gives it its own, and `fmsr eval` compares them episode by episode).
    #[arg(long, value_enum, default_value = "full")]
    pub(super) precision: PrecisionArg,
}

#[derive(Debug, Clone, Copy, clap::ValueEnum)]
pub(super) enum PrecisionArg {
    Full,
    Half,
}

impl From<PrecisionArg> for fmsr_nn::PolicyPrecision {
    fn from(p: PrecisionArg) -> Self {
        match p {
            PrecisionArg::Full => Self::Full,
            PrecisionArg::Half => Self::Half,
        }
    }
}

#[derive(Debug, clap::Args)]
pub(super) struct RescueArgs {
    /// The run directory (its last checkpoint).
    pub(super) run: PathBuf,
    /// The file to write (default `RUN/rescue.fmsr`).
    #[arg(long)]
    pub(super) out: Option<PathBuf>,
    /// What to keep of the learner: `online` (the online networks; targets restored as
    /// them, Adam's moments fresh; about a quarter of a checkpoint), `half` (as `online`,
    /// the networks at f16 precision: about half of that), `targets`, or `full`
    /// (everything but the replay buffer).
    #[arg(long, value_enum, default_value = "online")]
    pub(super) keep: KeepArg,
}

#[derive(Debug, Clone, Copy, clap::ValueEnum)]
pub(super) enum KeepArg {
    Online,
    Half,
    Targets,
    Full,
}

impl From<KeepArg> for fmsr_nn::RescueLevel {
    fn from(k: KeepArg) -> Self {
        match k {
            KeepArg::Online => Self::Online,
            KeepArg::Half => Self::Half,
            KeepArg::Targets => Self::Targets,
            KeepArg::Full => Self::Full,
        }
    }
}

#[derive(Debug, clap::Args)]
pub(super) struct ReportArgs {
    /// Run directories or policy files (each trained, and evaluated for the tables).
    #[arg(required = true)]
    pub(super) runs: Vec<PathBuf>,
    /// Where to write summary.md, the tables and the PNG figures.
    #[arg(long, default_value = "report")]
    pub(super) out: PathBuf,
}

#[derive(Debug, clap::Args)]
pub(super) struct RenderArgs {
    /// The run directory (its last checkpoint plays the episode), or a policy file.
    pub(super) run: PathBuf,
    /// Which episode of the fixed test set (0-based).
    #[arg(long, default_value_t = 0)]
    pub(super) episode: usize,
    /// Simulate on this engine (default: the one the run trained on).
    #[arg(long, value_enum)]
    pub(super) engine: Option<EngineArg>,
    /// A `.gif` file, or a directory for PNG frames (default `RUN/render/episode-K-ENGINE.gif`,
    /// for a policy file `render/` beside it).
    #[arg(long)]
    pub(super) out: Option<PathBuf>,
    /// Frame width (pixels).
    #[arg(long, default_value_t = 320)]
    pub(super) width: usize,
    /// Frame height (pixels).
    #[arg(long, default_value_t = 240)]
    pub(super) height: usize,
}

#[derive(Debug, clap::Args)]
pub(super) struct RunArgs {
    /// The experiment (TOML). The default, where no file is at its path, is
    /// the copy built into the binary.
    #[arg(long, default_value = super::DEFAULT_CONFIG)]
    pub(super) config: PathBuf,
    /// Run directory (default `runs/<name>`); an existing run there is resumed.
    #[arg(long)]
    pub(super) out: Option<PathBuf>,
    /// No progress bar or per-epoch lines.
    #[arg(long)]
    pub(super) quiet: bool,
    /// Where shipped policies are looked for: the report sets the run beside
    /// those of the same configuration.
    #[arg(long, default_value = "pretrained")]
    pub(super) pretrained: PathBuf,
}

#[derive(Debug, Clone, Copy, clap::ValueEnum)]
pub(super) enum SetArg {
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
pub(super) enum EngineArg {
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
