//! An evaluation's file (`eval.json`, [`EvalReport`]): the outcome of every
//! test episode ([`classify`](fmsr_core::metrics::classify): success is turned and held), the paper's
//! measures and their rows of Tables I and II. `fmsr eval` writes it
//! ([`crate::evaluate`]), reports and policy files read it.

use std::fmt::Write as _;
use std::path::Path;

use serde::{Deserialize, Serialize};

use fmsr_core::interval::Interval;
use fmsr_core::metrics::{EpisodeOutcome, EpisodeSummary, FailureCounts, FailureRow, MeanStd, StabilityRow};
use fmsr_envs::shadow_hand::GoalDistance;
use fmsr_nn::PolicyPrecision;

use crate::error::ExperimentError;
use crate::experiment::EpisodeSet;

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

/// What an evaluation counted as a success.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SuccessRule {
    /// Final rotation error under the threshold and never dropped.
    ReachedAndHeld,
}

impl SuccessRule {
    /// In words, for tables.
    #[must_use]
    pub fn describe(self) -> &'static str {
        match self {
            Self::ReachedAndHeld => "turned and held: final angle within the threshold, never dropped",
        }
    }
}

/// One test episode of an evaluation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EpisodeRecord {
    /// The episode's seed.
    pub seed: u64,
    /// Rotation error after the reset (rad).
    pub initial_error: f32,
    /// Rotation error at the last step (rad).
    pub final_error: f32,
    /// Whether the object was dropped at any step.
    pub dropped: bool,
    /// The first step (from 0) at which it was dropped.
    pub drop_step: Option<usize>,
    /// Success, drop or incomplete ([`classify`](fmsr_core::metrics::classify)).
    pub outcome: EpisodeOutcome,
    /// Active touch sensors summed over the steps (Table I's "Total Contact").
    pub total_contacts: usize,
    /// The object's final orientation against the goal's, under both
    /// distances, and its tilt (absent in files older than the full-angle task).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub orientation: Option<FinalOrientation>,
}

/// Where the object ended, by every measure of its orientation (rad), and
/// the quaternions the measures are taken from.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FinalOrientation {
    /// The full angle between the final and the goal orientation.
    pub full_angle: f32,
    /// The difference of their rotations about Z.
    pub yaw_error: f32,
    /// The angle between the object's axis and the world's Z axis.
    pub tilt: f32,
    /// gymnasium-robotics' `2 arccos(w)` of the engine's final quaternion
    /// against the goal's, over `[0, 2 pi]` (absent in files written before
    /// the records held the engine's quaternion).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gym_angle: Option<f32>,
    /// The object's final quaternion `[w, x, y, z]` as the engine reported
    /// it, its sign kept (absent in older files).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub object_quaternion: Option<[f64; 4]>,
    /// The goal's quaternion `[w, x, y, z]` (absent in older files).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub goal_quaternion: Option<[f32; 4]>,
}

impl FinalOrientation {
    /// The orientations of a 7-dim achieved and desired goal (position,
    /// `[w, x, y, z]`), with `engine`, the object's quaternion as the engine
    /// reported it (sign kept), where the env reads it out.
    #[must_use]
    pub fn of(achieved: &[f32], desired: &[f32], engine: Option<[f64; 4]>) -> Option<Self> {
        use fmsr_envs::shadow_hand::rotation::{full_angle, gym_angle, tilt, yaw_error};
        if achieved.len() < 7 || desired.len() < 7 {
            return None;
        }
        let goal = [desired[3], desired[4], desired[5], desired[6]];
        // gym's angle of the quaternion the task observed under "gym": the
        // engine's, in the observation's f32.
        let gym = engine.map(|q| gym_angle(&q.map(|v| v as f32), &goal));
        Some(Self {
            full_angle: full_angle(&achieved[3..7], &goal),
            yaw_error: yaw_error(&achieved[3..7], &goal),
            tilt: tilt(&achieved[3..7]),
            gym_angle: gym,
            object_quaternion: engine,
            goal_quaternion: engine.map(|_| goal),
        })
    }

    /// The final error under `distance` (`None` for gym's where the record
    /// does not hold the engine's quaternion).
    #[must_use]
    pub fn error(&self, distance: GoalDistance) -> Option<f32> {
        match distance {
            GoalDistance::Full => Some(self.full_angle),
            GoalDistance::Gym => self.gym_angle,
            GoalDistance::Yaw => Some(self.yaw_error),
        }
    }
}

/// The same episodes played by a hand that holds still (zero action, the
/// controls at the middle of their ranges), on the same engine: what an
/// evaluation's success is compared with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct StillBaseline {
    /// Episodes played.
    pub episodes: usize,
    /// Turned (by chance) and held: final distance under the threshold, never dropped.
    pub successes: usize,
    /// Episodes in which the object was dropped.
    pub drops: usize,
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
    /// Which episodes were played.
    pub set: EpisodeSet,
    /// The success threshold (rad).
    pub threshold: f32,
    /// What counted as a success.
    pub success_rule: SuccessRule,
    /// The goal distance of the threshold.
    pub goal_distance: GoalDistance,
    /// The episodes played by a hand that holds still (absent in files
    /// older than the full-angle task, whose chance level is estimated from the
    /// initial errors).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub still: Option<StillBaseline>,
    /// Fraction of episodes that succeeded.
    pub success_rate: f64,
    /// Table I's stability measures over the test episodes.
    pub stability: Option<StabilityRow>,
    /// Outcome counts.
    pub outcomes: FailureCounts,
    /// Table II's columns.
    pub failures: FailureRow,
    /// Per-episode grasp measures.
    pub episode_summaries: Vec<EpisodeSummary>,
    /// Every episode: seed, errors, drop, outcome, contacts.
    pub records: Vec<EpisodeRecord>,
    /// The per-step series of the first test episode.
    pub trace: EpisodeTrace,
    /// The precision of the actors that played (absent: `full`, the only one
    /// before half-precision policy files).
    #[serde(default, skip_serializing_if = "is_full")]
    pub precision: PolicyPrecision,
    /// Wall time of the evaluation (s).
    pub seconds: f64,
}

fn is_full(p: &PolicyPrecision) -> bool {
    *p == PolicyPrecision::Full
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
            "| {} | {} | {} | {} |\n",
            self.task,
            self.method,
            self.success_cell(),
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
            "{} | {} | {} | {} | {} | {} | {drop}",
            self.task,
            self.method,
            self.trained_on.as_deref().unwrap_or(trained_on),
            self.engine,
            self.success_cell(),
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

    /// The success rate with its 95 % Wilson interval.
    #[must_use]
    pub fn success_interval(&self) -> Option<Interval> {
        Interval::wilson(self.outcomes.successes, self.outcomes.episodes)
    }

    /// The success cell of the tables: `32% [24, 42]`.
    #[must_use]
    pub fn success_cell(&self) -> String {
        self.success_interval().map_or_else(|| "n/a".into(), |i| i.percent())
    }

    /// Each episode's rotation error after the reset (rad).
    #[must_use]
    pub fn initial_errors(&self) -> Vec<f32> {
        self.records.iter().map(|r| r.initial_error).collect()
    }

    /// The success of a hand that holds still on these episodes, with its
    /// 95 % interval: simulated ([`Self::still`]), or in files written before
    /// the full-angle task estimated as the fraction of episodes that start within the
    /// threshold (`None` for files older still). Under the yaw distance the
    /// estimate tends to `threshold / pi` (12.7 % at 0.4 rad); it ignores that
    /// an object left alone may tip over or fall, which the simulation sees.
    #[must_use]
    pub fn still_success(&self) -> Option<Interval> {
        if let Some(still) = self.still {
            return Interval::wilson(still.successes, still.episodes);
        }
        let initial = self.initial_errors();
        Interval::wilson(initial.iter().filter(|&&d| d < self.threshold).count(), initial.len())
    }

    /// Success against chance, in words, with both intervals.
    #[must_use]
    pub fn against_chance(&self) -> String {
        let what = format!("{} success {}", self.set.key(), self.success_cell());
        let how = if self.still.is_some() {
            "the same episodes simulated with zero action".to_string()
        } else {
            format!("estimated: the episodes that start within {} rad", self.threshold)
        };
        match self.still_success() {
            Some(still) => format!(
                "{what} against {} for a hand that holds still ({how}); {} distance; 95 % Wilson intervals",
                still.percent(),
                self.goal_distance.key()
            ),
            None => format!("{what} (chance level not recorded)"),
        }
    }

    /// Of this evaluation's successes, how many would fail under the goal
    /// distance `other`, and of its failures how many would succeed under it:
    /// `None` when the records do not hold what `other` needs (files written
    /// before the final orientations, or before the engine's quaternions for
    /// gym's distance).
    #[must_use]
    pub fn under_distance(&self, other: GoalDistance) -> Option<(usize, usize)> {
        let mut lost = 0;
        let mut gained = 0;
        for r in &self.records {
            let error = r.orientation?.error(other)?;
            let success = r.outcome == EpisodeOutcome::Success;
            let other_success = error < self.threshold && !r.dropped;
            lost += usize::from(success && !other_success);
            gained += usize::from(!success && other_success);
        }
        (!self.records.is_empty()).then_some((lost, gained))
    }

    /// The episodes (by seed) whose outcome differs between this evaluation
    /// and `other` of the same episodes, and how many both played: `None` when
    /// either lacks per-episode records.
    #[must_use]
    pub fn outcome_changes(&self, other: &EvalReport) -> Option<(usize, usize)> {
        if self.records.is_empty() || other.records.is_empty() {
            return None;
        }
        let theirs: std::collections::BTreeMap<u64, EpisodeOutcome> =
            other.records.iter().map(|r| (r.seed, r.outcome)).collect();
        let (mut both, mut changed) = (0, 0);
        for r in &self.records {
            if let Some(&o) = theirs.get(&r.seed) {
                both += 1;
                changed += usize::from(o != r.outcome);
            }
        }
        Some((changed, both))
    }

    /// Whether `other` has the same results: everything but the wall time and
    /// the configuration's label, which later builds may spell otherwise
    /// (every episode's outcome, final angle and grasp measures, the trace).
    /// What only one of the two records (an evaluation written before the
    /// hold-still simulation, the final orientations or the engine's
    /// quaternions existed) is not compared.
    #[must_use]
    pub fn same_results(&self, other: &EvalReport) -> bool {
        let still = self.still.is_some() && other.still.is_some();
        let orientation = self.records.iter().chain(&other.records).all(|r| r.orientation.is_some());
        let quaternions =
            self.records.iter().chain(&other.records).all(|r| r.orientation.is_some_and(|o| o.gym_angle.is_some()));
        let common = |e: &EvalReport| {
            let mut e = EvalReport { seconds: 0.0, method: String::new(), ..e.clone() };
            if !still {
                e.still = None;
            }
            if !orientation {
                e.records.iter_mut().for_each(|r| r.orientation = None);
            }
            if !quaternions {
                for o in e.records.iter_mut().filter_map(|r| r.orientation.as_mut()) {
                    (o.gym_angle, o.object_quaternion, o.goal_quaternion) = (None, None, None);
                }
            }
            e
        };
        common(self) == common(other)
    }

    /// Both tables for this run.
    #[must_use]
    pub fn to_markdown(&self) -> String {
        let mut out = String::new();
        let _ = writeln!(
            out,
            "{} ({}, {} epochs{}, {} {} episodes at {} rad by the {} distance, {:.0} s)\n",
            self.name,
            self.engine,
            self.epochs,
            if self.precision == PolicyPrecision::Full { "" } else { ", actors at half precision" },
            self.episodes,
            self.set.key(),
            self.threshold,
            self.goal_distance.key(),
            self.seconds
        );
        out.push_str(&Self::table1_header());
        out.push_str(&self.table1_row());
        out.push('\n');
        out.push_str(&Self::table2_header());
        out.push_str(&self.table2_row());
        let _ = writeln!(out, "\n{}: {}.", self.name, self.against_chance());
        for other in GoalDistance::ALL.into_iter().filter(|&d| d != self.goal_distance) {
            let Some((lost, gained)) = self.under_distance(other) else { continue };
            let (this, other) = (self.goal_distance.key(), other.key());
            let _ = writeln!(
                out,
                "Under the {other} distance: {lost} of the {} successes by the {this} distance would fail, \
                 and {gained} of its failures would succeed.",
                self.outcomes.successes
            );
        }
        out
    }
}

/// Writes an evaluation as JSON, atomically.
///
/// # Errors
/// I/O errors.
pub fn write_eval(report: &EvalReport, path: &std::path::Path) -> Result<(), ExperimentError> {
    let json = serde_json::to_vec_pretty(report)
        .map_err(|e| ExperimentError::Encode { what: "eval.json", reason: e.to_string() })?;
    Ok(fmsr_core::persist::write_atomic(path, &json)?)
}

/// The evaluation in `path`, if the file exists.
pub fn read_eval(path: &Path) -> Result<Option<EvalReport>, ExperimentError> {
    read_json(path)
}

/// The JSON file at `path` read as a `T`; `None` when there is none.
pub(crate) fn read_json<T: serde::de::DeserializeOwned>(path: &Path) -> Result<Option<T>, ExperimentError> {
    if !path.exists() {
        return Ok(None);
    }
    let bytes = std::fs::read(path).map_err(|source| ExperimentError::Io { path: path.into(), source })?;
    serde_json::from_slice(&bytes)
        .map(Some)
        .map_err(|e| ExperimentError::parse_source(path, "not a JSON record of this kind", e))
}

#[cfg(test)]
mod tests {
    use super::*;
    use fmsr_core::metrics::{EpisodeOutcome, FailureType};

    /// 100 episodes: 32 successes, 60 incomplete, 8 drops; initial errors
    /// 0.1, 0.39, 0.4 (the threshold itself), 1.0, 3.0, then 2.0 for the rest.
    fn report(rule: SuccessRule) -> EvalReport {
        let outcomes: Vec<EpisodeOutcome> = std::iter::repeat_n(EpisodeOutcome::Success, 32)
            .chain(std::iter::repeat_n(EpisodeOutcome::Failure(FailureType::Incomplete), 60))
            .chain(std::iter::repeat_n(EpisodeOutcome::Failure(FailureType::Drop), 8))
            .collect();
        let initial = [0.1, 0.39, 0.4, 1.0, 3.0];
        let records: Vec<EpisodeRecord> = outcomes
            .iter()
            .enumerate()
            .map(|(i, &outcome)| EpisodeRecord {
                seed: i as u64,
                initial_error: initial.get(i).copied().unwrap_or(2.0),
                final_error: if outcome == EpisodeOutcome::Success { 0.1 } else { 1.0 },
                dropped: outcome == EpisodeOutcome::Failure(FailureType::Drop),
                drop_step: (outcome == EpisodeOutcome::Failure(FailureType::Drop)).then_some(7),
                outcome,
                total_contacts: 0,
                orientation: None,
            })
            .collect();
        let counts: FailureCounts = outcomes.into_iter().collect();
        EvalReport {
            name: "r".into(),
            method: "Dense".into(),
            task: "egg".into(),
            engine: "rapier".into(),
            trained_on: Some("rapier".into()),
            epochs: 1,
            episodes: 100,
            set: EpisodeSet::Test,
            threshold: 0.4,
            success_rule: rule,
            goal_distance: GoalDistance::Yaw,
            still: None,
            success_rate: counts.success_rate().unwrap(),
            stability: None,
            outcomes: counts,
            failures: counts.row(),
            episode_summaries: Vec::new(),
            records,
            trace: EpisodeTrace::default(),
            precision: PolicyPrecision::Full,
            seconds: 0.0,
        }
    }

    // Guards the cells the tables print from an evaluation: Table II's
    // columns in their order (failures, incomplete and drops with their
    // shares of the failures), the success cell's Wilson interval from the
    // outcome counts and the `*` of the old success rule, the Drop% column
    // of the cross-engine table, and the chance level counting the episodes
    // that start strictly within the threshold, as `classify` counts a
    // success. No test read these rows before; the CLI tests look for a
    // configuration's name only.
    #[test]
    fn table_cells_show_the_counts_in_their_columns() {
        let e = report(SuccessRule::ReachedAndHeld);
        assert_eq!(e.table2_row(), "| egg | Dense | 100 | 68 | 60 | 88.2% | 8 | 11.8% |\n");
        assert_eq!(e.success_cell(), "32% [24, 42]");
        assert_eq!(e.table1_row(), "| egg | Dense | 32% [24, 42] | n/a | n/a | n/a | n/a | n/a | n/a |\n");
        assert!(e.cross_engine_cells("mujoco").ends_with("| 32% [24, 42] | n/a | n/a | n/a | n/a | n/a | n/a | 11.8%"));
        let still = e.still_success().unwrap();
        assert_eq!(still, Interval::wilson(2, 100).unwrap());
        assert_eq!(e.initial_errors().len(), 100);
        assert!(e.against_chance().contains("test success 32% [24, 42] against 2% ["), "{}", e.against_chance());
        // Files older than the simulated baseline: the chance level from the episodes' initial distances.
        let mut records = e.records[..4].to_vec();
        records.iter_mut().zip([0.39, 0.4, 0.41, 0.0]).for_each(|(r, d)| r.initial_error = d);
        let old = EvalReport { records, still: None, ..e };
        assert_eq!(old.still_success(), Interval::wilson(2, 4));
    }

    // Guards `fmsr eval`'s check of a policy file against the evaluation it
    // carries: when the configuration's label gained `yaw distance`, every
    // shipped policy's evaluation "differed" from the one it carries, though
    // every episode ended as before. The label and the wall time are not
    // results; an episode's outcome is.
    #[test]
    fn the_same_results_under_another_label_are_the_same() {
        let e = report(SuccessRule::ReachedAndHeld);
        let relabelled = EvalReport { method: "Dense, yaw distance".into(), seconds: 9.0, ..e.clone() };
        assert!(e.same_results(&relabelled));
        let mut other = e.clone();
        other.records[40].final_error = 0.9;
        assert!(!e.same_results(&other));
    }

    // Guards `fmsr eval`'s check of the shipped policies, whose evaluations
    // were written before the records held the engine's quaternions: an
    // evaluation that has them repeats one that has not, when every episode
    // ended as before, and differs where an episode's angle does.
    #[test]
    fn the_engines_quaternions_are_compared_only_where_both_hold_them() {
        let at = |q: Option<[f64; 4]>| {
            let a = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0];
            let mut e = report(SuccessRule::ReachedAndHeld);
            e.records.iter_mut().for_each(|r| r.orientation = FinalOrientation::of(&a, &a, q));
            e
        };
        let (without, with) = (at(None), at(Some([1.0, 0.0, 0.0, 0.0])));
        assert!(with.records[0].orientation.unwrap().gym_angle.is_some());
        assert!(without.same_results(&with) && with.same_results(&without));
        assert!(!with.same_results(&at(Some([-1.0, 0.0, 0.0, 0.0]))), "gym's 2 pi is another result");
    }
}
