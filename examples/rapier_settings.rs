//! How much of a policy's success survives on rapier, by rapier's solver
//! settings: plays a policy (a run or a policy file, trained on either engine)
//! closed-loop on the fixed test set on rapier under each of a list of
//! `RapierSettings`, and prints its success at the evaluation threshold, drops,
//! the median final angle and a hand that holds still on the same episodes.
//! A MuJoCo-trained policy that succeeds on MuJoCo points at what in rapier's
//! physics its skill does not carry over to.
//!
//! ```text
//! cargo run --release --example rapier_settings -- pretrained/egg_dense_paper [--episodes 100]
//! ```

use anyhow::{Context, Result, bail};
use fmsr::artefacts::Source;
use fmsr::experiment::{EpisodeSet, MODEL_TIMESTEP};
use fmsr_envs::shadow_hand::{Engine, RapierSettings};

fn main() -> Result<()> {
    let _ = fmsr::allocator::keep_freed_memory();
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(run) = args.first() else {
        bail!("usage: rapier_settings RUN_OR_POLICY [--episodes N]");
    };
    let episodes: Option<usize> = match args.iter().position(|a| a == "--episodes") {
        Some(i) => Some(args.get(i + 1).context("--episodes needs a number")?.parse()?),
        None => None,
    };
    let source = Source::open(std::path::Path::new(run))?;
    let base = source.config()?;
    let default = RapierSettings::default();
    let variants = [
        ("default (0.008 s, 1 solver it., 4 PGS)", default),
        ("0.004 s", RapierSettings { timestep: 0.004, ..default }),
        ("0.002 s (MuJoCo's step)", RapierSettings { timestep: 0.002, ..default }),
        ("4 solver it.", RapierSettings { solver_iterations: 4, ..default }),
        ("16 PGS it.", RapierSettings { pgs_iterations: 16, ..default }),
        ("fine() (0.002 s, 2 solver it., 1 PGS)", RapierSettings::fine()),
    ];
    println!("{run} ({}), the test set on rapier\n", base.label());
    println!("| rapier settings | success | drops | median final angle (rad) | holding still | seconds |");
    println!("|---|---|---|---|---|---|");
    for (name, rapier) in variants {
        let mut config = base.clone();
        if let Some(n) = episodes {
            config.eval.episodes = n;
        }
        config.env.rapier = rapier;
        let env = config.env_config().init_engine(Engine::Rapier)?;
        let dt = MODEL_TIMESTEP * config.env.substeps as f64;
        let e = fmsr::evaluate::evaluate_source_on(&config, env, Engine::Rapier, EpisodeSet::Test, &source, dt)?;
        let mut angles: Vec<f32> = e.records.iter().map(|r| r.final_error).collect();
        angles.sort_by(f32::total_cmp);
        let still = e.still.as_ref().map_or_else(|| "n/a".into(), |s| format!("{} of {}", s.successes, s.episodes));
        println!(
            "| {name} | {} of {} | {} | {:.3} | {still} | {:.0} |",
            e.outcomes.successes,
            e.outcomes.episodes,
            e.outcomes.drop,
            angles[angles.len() / 2],
            e.seconds
        );
    }
    Ok(())
}
