//! Which run stands for a configuration in the tables, and how far apart the
//! configurations are.
//!
//! As in the paper, a configuration trained with several seeds is shown by its
//! best run; "best" is judged on the **validation episodes** (`fmsr eval --set
//! validation`, seeds disjoint from the test set's), never on the test set the
//! tables then report. Where some seed has no validation evaluation, no run is
//! chosen on merit: the first one given stands for the configuration, and the
//! summary says so.

use std::fmt::Write as _;

use fmsr_core::interval::Interval;

use crate::artefacts::EvalReport;

use super::RunRecord;

/// How the run standing for a configuration was picked.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Chosen {
    /// The configuration has one evaluated run.
    Only,
    /// The best of several on the validation episodes.
    OnValidation,
    /// The first of several: not all of them have a validation evaluation.
    FirstGiven,
}

impl Chosen {
    /// In words, for the summary.
    #[must_use]
    pub fn describe(self) -> &'static str {
        match self {
            Self::Only => "its only run",
            Self::OnValidation => "best on the validation episodes",
            Self::FirstGiven => {
                "the first run given (not every seed has a validation evaluation: none chosen on merit)"
            }
        }
    }
}

/// The run standing for the configuration among `candidates` (runs of one
/// configuration, in the order given) that have a test evaluation.
#[must_use]
pub fn choose<'a>(candidates: &[&'a RunRecord]) -> Option<(&'a RunRecord, &'a EvalReport, Chosen)> {
    choose_by(candidates, |r| r.eval.as_ref(), |r| r.validation.as_ref().map(|v| v.success_rate))
}

/// The rule of [`choose`] for any kind of run: among `candidates` with a
/// test evaluation (`test`), the best by validation success (`validation`;
/// the first of equal scores), or the first given when one has none.
pub(crate) fn choose_by<'a, R, E>(
    candidates: &[&'a R],
    test: impl Fn(&'a R) -> Option<&'a E>,
    validation: impl Fn(&R) -> Option<f64>,
) -> Option<(&'a R, &'a E, Chosen)> {
    let evaluated: Vec<(&R, &E)> = candidates.iter().filter_map(|r| test(r).map(|e| (*r, e))).collect();
    match evaluated.as_slice() {
        [] => None,
        [(r, e)] => Some((r, e, Chosen::Only)),
        [(first, first_eval), ..] => {
            let scores: Option<Vec<f64>> = evaluated.iter().map(|(r, _)| validation(r)).collect();
            match scores {
                Some(scores) => {
                    // The first of equal scores: a later seed must do better to be chosen.
                    let best = (1..scores.len()).fold(0, |best, i| if scores[i] > scores[best] { i } else { best });
                    let (r, e) = evaluated[best];
                    Some((r, e, Chosen::OnValidation))
                }
                None => Some((first, first_eval, Chosen::FirstGiven)),
            }
        }
    }
}

/// The differences of test success between every two configurations of one
/// task, with the 95 % interval of each difference (Newcombe's, from the two
/// Wilson intervals); `None` with fewer than two.
#[must_use]
pub fn differences_table(task: &str, chosen: &[(&RunRecord, &EvalReport, Chosen)]) -> Option<String> {
    if chosen.len() < 2 {
        return None;
    }
    let mut md = String::new();
    for (i, (_, a, _)) in chosen.iter().enumerate() {
        for (_, b, _) in &chosen[i + 1..] {
            let (Some(ia), Some(ib)) = (a.success_interval(), b.success_interval()) else { continue };
            let _ = writeln!(md, "| {task} | {} | {} | {} |", a.method, b.method, ia.difference(&ib).points());
        }
    }
    Some(md)
}

/// A success rate with its interval, or the text for none.
#[must_use]
pub fn rate_cell(e: Option<&EvalReport>, none: &str) -> String {
    e.map_or_else(|| none.into(), EvalReport::success_cell)
}

/// The test success of `eval` against its chance level, as table cells.
#[must_use]
pub fn chance_cells(eval: &EvalReport) -> (String, String) {
    let still = eval.still_success().as_ref().map_or_else(|| "not recorded".into(), Interval::percent);
    (eval.success_cell(), still)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::experiment::{EpisodeSet, ExperimentConfig};

    fn eval(rate: f64, set: EpisodeSet) -> EvalReport {
        let json = serde_json::json!({
            "name": "r", "method": "Dense", "task": "egg", "engine": "rapier", "epochs": 1,
            "episodes": 100, "set": set, "threshold": 0.4, "success_rule": "reached_and_held", "goal_distance": "full", "records": [],
            "success_rate": rate, "stability": null,
            "outcomes": {"episodes": 100, "successes": (rate * 100.0).round() as usize,
                "incomplete": 100 - (rate * 100.0).round() as usize, "drop": 0},
            "failures": {"failures": 0, "incomplete": 0, "incomplete_percent": null, "drop": 0, "drop_percent": null},
            "episode_summaries": [], "trace": {"seed": 0, "contacts": [], "q_msv": [], "q_vew": [], "dq_msv": [],
            "dq_vew": [], "q_dcc": [], "goal_distance": []}, "seconds": 0.0
        });
        serde_json::from_value(json).unwrap()
    }

    fn record(seed: u64, test: f64, validation: Option<f64>) -> RunRecord {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/egg_dense_quick.toml");
        let mut config = ExperimentConfig::load(&path).unwrap();
        config.trainer.seed = seed;
        RunRecord {
            dir: format!("runs/s{seed}").into(),
            label: config.label(),
            policy_file: false,
            config,
            metrics: Vec::new(),
            eval: Some(eval(test, EpisodeSet::Test)),
            validation: validation.map(|v| eval(v, EpisodeSet::Validation)),
            cross_evals: Vec::new(),
            rendering: None,
        }
    }

    // Guards the selection (regression): the best seed used to be the one with
    // the highest test success, the number the tables then report.
    #[test]
    fn the_best_seed_is_chosen_on_validation_not_on_test() {
        let runs = [record(0, 0.9, Some(0.2)), record(1, 0.3, Some(0.5))];
        let refs: Vec<&RunRecord> = runs.iter().collect();
        let (r, e, how) = choose(&refs).unwrap();
        assert_eq!((r.config.trainer.seed, how), (1, Chosen::OnValidation));
        assert!((e.success_rate - 0.3).abs() < 1e-12);
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(48))]

        // Guards the selection rule on any number of seeds: with a validation
        // evaluation for every seed, the chosen run is the first of the best
        // validation scores, whatever the test scores. The two-seed case
        // above also passes for a rule that takes the last run, or the last
        // of equal scores; scores from a short list make ties common.
        #[test]
        fn the_first_best_on_validation_is_chosen(
            runs in proptest::collection::vec((0usize..4, 0usize..4), 2..6),
        ) {
            let runs: Vec<RunRecord> = runs
                .iter()
                .enumerate()
                .map(|(seed, &(test, validation))| record(seed as u64, test as f64 / 4.0, Some(validation as f64 / 4.0)))
                .collect();
            let scores: Vec<f64> = runs.iter().map(|r| r.validation.as_ref().unwrap().success_rate).collect();
            let top = scores.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            let first_best = scores.iter().position(|&s| s == top).unwrap();
            let (r, e, how) = choose(&runs.iter().collect::<Vec<_>>()).unwrap();
            proptest::prop_assert_eq!(how, Chosen::OnValidation);
            proptest::prop_assert_eq!(r.config.trainer.seed, first_best as u64);
            proptest::prop_assert!(std::ptr::eq(e, runs[first_best].eval.as_ref().unwrap()));
        }
    }

    #[test]
    fn without_validation_for_every_seed_the_first_run_stands() {
        let runs = [record(0, 0.2, None), record(1, 0.9, Some(0.9))];
        let refs: Vec<&RunRecord> = runs.iter().collect();
        let (r, _, how) = choose(&refs).unwrap();
        assert_eq!((r.config.trainer.seed, how), (0, Chosen::FirstGiven));
        let single = [record(3, 0.5, None)];
        assert_eq!(choose(&single.iter().collect::<Vec<_>>()).unwrap().2, Chosen::Only);
    }

    #[test]
    fn differences_name_both_configurations_with_an_interval() {
        let (a, b) = (eval(0.56, EpisodeSet::Test), eval(0.35, EpisodeSet::Test));
        let r = record(0, 0.5, None);
        let md = differences_table("egg", &[(&r, &a, Chosen::Only), (&r, &b, Chosen::Only)]).unwrap();
        assert_eq!(md, "| egg | Dense | Dense | +21 pts [+7, +34] |\n");
    }
}
