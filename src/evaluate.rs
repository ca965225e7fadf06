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
//! in `metrics.csv` is that same flag on deterministic episodes.
//!
//! Every success rate is given with its 95 % Wilson interval
//! ([`fmsr_core::interval`]); each episode is recorded ([`EpisodeRecord`]),
//! with its final orientation under every goal distance, the object's tilt
//! and the final quaternions of the object (as the engine reports it, sign
//! kept) and of the goal ([`FinalOrientation`]), from which anyone can
//! recompute gym's distance. The same episodes are also played by a hand
//! that holds still (zero action) on the same engine, the chance level every
//! success is compared with ([`StillBaseline`]).

use std::time::Instant;

use fmsr_core::metrics::{EpisodeOutcome, EpisodeSummary, FailureCounts, GraspTrace, StabilityRow};
use fmsr_core::prelude::*;

use crate::artefacts::{
    EpisodeRecord, EpisodeTrace, EvalReport, FinalOrientation, RunDir, Source, StillBaseline, SuccessRule, classify,
    write_eval,
};
use crate::experiment::{Engine, EpisodeSet, ExperimentConfig, ExperimentError};

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
    let mut engine_quaternion = None;
    let episode = trainer.rollout_with(seed, ActMode::Evaluate, &mut |env, outcome| {
        let o = &outcome.observation;
        distances.push(env.goal_distance(&o.achieved_goal, &o.desired_goal));
        engine_quaternion = env.object_orientation();
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
    let orientation = episode
        .observations
        .last()
        .and_then(|o| FinalOrientation::of(&o.achieved_goal, &o.desired_goal, engine_quaternion));
    let drop_step = episode.infos.iter().position(|i| i.dropped);
    let contacts = trace.contacts();
    let summary = trace.summary();
    let record = EpisodeRecord {
        seed,
        initial_error,
        final_error,
        dropped: drop_step.is_some(),
        drop_step,
        outcome: classify(final_error, threshold, drop_step.is_some()),
        total_contacts: summary.as_ref().map_or(0, |s| s.total_contacts),
        orientation,
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
    Ok(Played { record, summary, trace: series })
}

/// Plays the episodes of `seeds` on `env` with a hand that holds still:
/// every step the zero action (each control at the middle of its range, the
/// pose the reset settles in), as long as the policy's episodes.
///
/// # Errors
/// The environment's errors.
pub fn hold_still<E: Env>(env: &mut E, seeds: &[u64], threshold: f32) -> Result<StillBaseline, ExperimentError> {
    let spec = env.spec().clone();
    let zero = JointAction::zeros(spec.action_dim);
    let env_err = |e: E::Error| ExperimentError::Core(CoreError::Env(Box::new(e)));
    let mut still = StillBaseline { episodes: seeds.len(), successes: 0, drops: 0 };
    for &seed in seeds {
        let mut last = env.reset(seed).map_err(env_err)?;
        let mut dropped = false;
        for _ in 0..spec.episode_len {
            let outcome = env.step(&zero).map_err(env_err)?;
            dropped |= outcome.info.dropped;
            last = outcome.observation;
        }
        let distance = env.goal_distance(&last.achieved_goal, &last.desired_goal);
        still.drops += usize::from(dropped);
        still.successes += usize::from(classify(distance, threshold, dropped) == EpisodeOutcome::Success);
    }
    Ok(still)
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
    evaluate_source_with(config, env, engine, set, source, dt, &mut |_| {})
}

/// Where an evaluation stands, for a progress display ([`evaluate_source_with`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EvalProgress {
    /// `done` of the policy's `total` episodes played.
    Policy {
        /// Episodes played so far.
        done: usize,
        /// Episodes to play.
        total: usize,
    },
    /// The same episodes are being played by a hand that holds still.
    HoldingStill,
}

/// As [`evaluate_source_on`], telling `progress` after each of the policy's
/// episodes and before the hold-still baseline.
///
/// # Errors
/// As [`evaluate_source_on`].
pub fn evaluate_source_with<E: Env + ContactReadout + Send>(
    config: &ExperimentConfig,
    env: E,
    engine: Engine,
    set: EpisodeSet,
    source: &Source,
    dt: f64,
    progress: &mut dyn FnMut(EvalProgress),
) -> Result<EvalReport, ExperimentError> {
    let start = Instant::now();
    let mut trainer = config.build_trainer(vec![env])?;
    let epochs = source.load_into(&mut trainer)?;
    let seeds = config.eval.seeds_of(set, config.eval.episodes);
    let threshold = config.eval.threshold;
    let mut records = Vec::with_capacity(seeds.len());
    let mut summaries = Vec::with_capacity(seeds.len());
    let mut first_trace = None;
    for (i, &seed) in seeds.iter().enumerate() {
        let played = play(&mut trainer, seed, threshold, dt)?;
        records.push(played.record);
        summaries.extend(played.summary);
        first_trace.get_or_insert(played.trace);
        progress(EvalProgress::Policy { done: i + 1, total: seeds.len() });
    }
    progress(EvalProgress::HoldingStill);
    let still = hold_still(trainer.env_mut(), &seeds, threshold)?;
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
        goal_distance: config.env.goal_distance,
        still: Some(still),
        success_rate: outcomes.success_rate().unwrap_or(0.0),
        stability: StabilityRow::from_summaries(&summaries),
        failures: outcomes.row(),
        outcomes,
        episode_summaries: summaries,
        records,
        trace: first_trace.unwrap_or_default(),
        precision: source.precision(),
        seconds: start.elapsed().as_secs_f64(),
    })
}
