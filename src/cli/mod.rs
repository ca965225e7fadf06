//! The `fmsr` command: train, evaluate and report the paper's experiments.
//!
//! The command is this module, so that a crate of your own runs it with the
//! algorithms it registered ([`crate::algorithms::register`]): its binary is
//!
//! ```no_run
//! # use fmsr::nn::MaddpgRule as IddpgRule;
//! fn main() -> std::process::ExitCode {
//!     // `algorithm = "iddpg"` in a config now finds the rule, as
//!     // `algorithm = "maddpg"` finds MADDPG's.
//!     if let Err(e) = fmsr::algorithms::register::<IddpgRule>() {
//!         eprintln!("error: {e}");
//!         return std::process::ExitCode::FAILURE;
//!     }
//!     fmsr::cli::main()
//! }
//! ```
//!
//! and `my-fmsr train --config iddpg.toml`, `my-fmsr eval runs/iddpg`,
//! `my-fmsr export`, `report`, `render` and `run` are fmsr's own.

mod args;
mod commands;

use std::ffi::OsString;
use std::path::PathBuf;
use std::process::ExitCode;

use clap::Parser;

use crate::artefacts::RunDir;
use crate::error::ExperimentError;
use crate::experiment::ExperimentConfig;
use args::{AssetsCommand, Cli, Command, EvalArgs, SetArg, TrainArgs};
use commands::{Context, eval, export, render, report, train};

/// The default experiment of `fmsr run` and `fmsr train`.
pub(crate) const DEFAULT_CONFIG: &str = "configs/egg_dense_fmsr_is_quick.toml";

/// The experiment at `path`; the default one, where no file is at its path
/// (an installed `fmsr` run outside a checkout), from the copy built into
/// the binary.
pub(crate) fn load_experiment(path: &std::path::Path) -> Result<ExperimentConfig, ExperimentError> {
    if path == std::path::Path::new(DEFAULT_CONFIG) && !path.exists() {
        return ExperimentConfig::from_toml(include_str!("../../configs/egg_dense_fmsr_is_quick.toml"), path);
    }
    ExperimentConfig::load(path)
}

/// The `fmsr` command on this process's arguments. Prints an error with its
/// causes and returns failure.
///
/// It changes no process state. In a build with a GPU backend, burn creates
/// a loaded optimiser state on its default device (`BURN_DEVICE`, else the
/// GPU backend's default adapter) before moving it to the networks' device,
/// and a machine without that adapter fails there with a typed error; the
/// `fmsr` binary (`src/main.rs`) therefore sets `BURN_DEVICE=flex`, where
/// the state always can be made, before calling this. A binary of your own
/// does the same if it resumes runs in a GPU build. The `fmsr` binary also
/// keeps freed memory for the next training step
/// ([`crate::allocator::keep_freed_memory`]), which a binary of your own may call too.
#[must_use]
pub fn main() -> ExitCode {
    let cli = Cli::parse();
    match execute(cli.command) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", chain(&e));
            ExitCode::FAILURE
        }
    }
}

/// The `fmsr` command on `args` (the first is the program's name), in this
/// process: what a test or a program of your own runs without a binary.
///
/// # Errors
/// Bad arguments ([`ExperimentError::Cli`], with clap's message), and those of the command.
pub fn run<I, T>(args: I) -> Result<(), ExperimentError>
where
    I: IntoIterator<Item = T>,
    T: Into<OsString> + Clone,
{
    let cli = Cli::try_parse_from(args).map_err(|e| ExperimentError::Cli { arg: "fmsr", reason: e.to_string() })?;
    execute(cli.command)
}

/// An error and its causes, each said once: `a: b: c`.
fn chain(e: &ExperimentError) -> String {
    let mut text = e.to_string();
    let mut source = std::error::Error::source(e);
    while let Some(s) = source {
        let said = s.to_string();
        if !text.contains(&said) {
            text = format!("{text}: {said}");
        }
        source = s.source();
    }
    text
}

fn execute(command: Command) -> Result<(), ExperimentError> {
    match command {
        Command::Train(args) => train(&args).map(|_| ()),
        Command::Eval(args) => eval(&args),
        Command::Export(args) => export(&args),
        Command::Rescue(args) => {
            let dir = RunDir::new(&args.run);
            let point = crate::run::rescue_point(&dir, args.keep.into())
                .context(|| format!("the rescue point of {}", dir.root().display()))?;
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
            let name = load_experiment(&args.config)?.name;
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
                carried: false,
            })?;
            let config = dir.load_config()?;
            let mut runs = vec![dir.root().to_path_buf()];
            if config.is_shadow_hand() {
                runs.extend(crate::artefacts::matching_policies(&args.pretrained, &config));
            }
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
