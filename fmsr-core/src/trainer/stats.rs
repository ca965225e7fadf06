//! What an epoch reports ([`EpochStats`]) and an evaluation ([`EvalSummary`]),
//! and the running sums they come from, summed over worker processes.

use serde::{Deserialize, Serialize};

use crate::agent::Communicator;
use crate::algorithm::UpdateStats;
use crate::replay::Episode;
use crate::shadow::RewardSums;
use crate::spec::StepInfo;

/// Statistics of one epoch.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct EpochStats {
    /// Epoch index, from 0.
    pub epoch: usize,
    /// Success rate of the evaluation episodes (deterministic policy).
    pub success_rate: f64,
    /// Success rate of the training rollouts (with exploration).
    pub train_success_rate: f64,
    /// Fraction of evaluation episodes that ended with the object dropped.
    pub drop_rate: f64,
    /// Fraction of evaluation episodes that succeeded under the test's rule,
    /// turned and held: within the training threshold at the last step and
    /// never dropped; `None` where it was not measured (metrics older than
    /// the full-angle task).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub held_success_rate: Option<f64>,
    /// Mean per-step value of each feature over the evaluation episodes.
    pub eval_feature_rates: Vec<f64>,
    /// Mean per-step value of each feature over the training rollouts.
    pub train_feature_rates: Vec<f64>,
    /// Mean undiscounted return of each agent (task + shadow) over the training rollouts.
    pub returns: Vec<f64>,
    /// The occupancy estimate `lambda_k` at the end of the epoch.
    pub occupancy: Vec<f64>,
    /// Mean critic loss of each agent over the epoch's updates.
    pub critic_loss: Vec<f64>,
    /// Mean actor loss of each agent over the epoch's updates.
    pub actor_loss: Vec<f64>,
    /// Each agent's mean per-step task reward magnitude `|w_i r|` over this
    /// epoch's training episodes.
    #[serde(default)]
    pub task_reward_abs: Vec<f64>,
    /// Each agent's mean per-step shadow reward magnitude `|alpha sum_k z_k|`
    /// (what `trainer.shadow.max_scale` bounds relative to the task's).
    #[serde(default)]
    pub shadow_reward_abs: Vec<f64>,
    /// Each agent's mean `|task part|` of the rewards in this epoch's sampled
    /// batches, HER's relabelled goals included: the task reward as the
    /// critics learn it (empty when the algorithm does not say, and in
    /// metrics older than the full-angle task).
    #[serde(default)]
    pub batch_task_reward_abs: Vec<f64>,
    /// Each agent's mean `|shadow part|` of the same rewards.
    #[serde(default)]
    pub batch_shadow_reward_abs: Vec<f64>,
    /// Each agent's mean `Q_i(x, g, a)` of its online critic over this epoch's batches.
    #[serde(default)]
    pub q_mean: Vec<f64>,
    /// Environment steps so far.
    pub env_steps: u64,
    /// Updates so far.
    pub updates: u64,
    /// Environment steps per second in this epoch (rollouts and evaluation).
    pub env_steps_per_sec: f64,
    /// Updates per second in this epoch.
    pub updates_per_sec: f64,
    /// Wall time of the epoch (s).
    pub seconds: f64,
}

/// Result of evaluating the policy on a set of seeded episodes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct EvalSummary {
    /// Episodes run.
    pub episodes: usize,
    /// Fraction that ended within the success threshold.
    pub success_rate: f64,
    /// Fraction that ended with the object dropped.
    pub drop_rate: f64,
    /// Fraction that succeeded and were never dropped (the test's rule, [`crate::metrics::classify`]).
    pub held_success_rate: f64,
    /// Mean per-step value of each feature.
    pub feature_rates: Vec<f64>,
    /// Final goal distance of each episode.
    pub final_distances: Vec<f32>,
}

/// The running sums of one epoch.
#[derive(Debug, Default)]
pub(super) struct EpochTally {
    pub(super) returns: Vec<f64>,
    pub(super) task_abs: Vec<f64>,
    pub(super) shadow_abs: Vec<f64>,
    pub(super) features: Vec<f64>,
    pub(super) successes: usize,
    pub(super) episodes: usize,
    pub(super) steps: usize,
    pub(super) critic_loss: Vec<f64>,
    pub(super) actor_loss: Vec<f64>,
    pub(super) batch_task_abs: Vec<f64>,
    pub(super) batch_shadow_abs: Vec<f64>,
    pub(super) q_mean: Vec<f64>,
    pub(super) loss_cycles: usize,
    /// Whether the algorithm reported its batches' reward parts and Q.
    pub(super) reports_batches: bool,
    pub(super) updates: u64,
    pub(super) update_seconds: f64,
}

impl EpochTally {
    pub(super) fn new(agents: usize, features: usize) -> Self {
        Self {
            returns: vec![0.0; agents],
            task_abs: vec![0.0; agents],
            shadow_abs: vec![0.0; agents],
            features: vec![0.0; features],
            critic_loss: vec![0.0; agents],
            actor_loss: vec![0.0; agents],
            batch_task_abs: vec![0.0; agents],
            batch_shadow_abs: vec![0.0; agents],
            q_mean: vec![0.0; agents],
            ..Self::default()
        }
    }

    pub(super) fn add_episode(&mut self, episode: &Episode, sums: &RewardSums) {
        let add = |acc: &mut Vec<f64>, v: &[f64]| acc.iter_mut().zip(v).for_each(|(a, x)| *a += x);
        add(&mut self.returns, &sums.returns);
        add(&mut self.task_abs, &sums.task_abs);
        add(&mut self.shadow_abs, &sums.shadow_abs);
        accumulate_features(&episode.infos, &mut self.features);
        self.successes += usize::from(episode.infos.last().is_some_and(|i| i.is_success));
        self.episodes += 1;
        self.steps += episode.infos.len();
    }

    pub(super) fn add_update(&mut self, stats: &UpdateStats, seconds: f64) {
        self.update_seconds += seconds;
        if stats.updates == 0 {
            return;
        }
        self.updates += stats.updates;
        self.loss_cycles += 1;
        self.critic_loss.iter_mut().zip(&stats.critic_loss).for_each(|(a, v)| *a += v);
        self.actor_loss.iter_mut().zip(&stats.actor_loss).for_each(|(a, v)| *a += v);
        self.batch_task_abs.iter_mut().zip(&stats.batch_task_reward_abs).for_each(|(a, v)| *a += v);
        self.batch_shadow_abs.iter_mut().zip(&stats.batch_shadow_reward_abs).for_each(|(a, v)| *a += v);
        self.q_mean.iter_mut().zip(&stats.q_mean).for_each(|(a, v)| *a += v);
        self.reports_batches |= !stats.q_mean.is_empty();
    }

    /// With several workers: the epoch's sums over all of them (losses: the
    /// mean). Every worker evaluates the same seeds with the same networks.
    pub(super) fn reduce(&mut self, comm: &dyn Communicator) {
        let workers = comm.workers();
        if workers <= 1 {
            return;
        }
        let counts = [self.successes, self.episodes, self.steps].map(|c| c as f64);
        let mut v: Vec<f32> = [
            &self.returns[..],
            &self.task_abs,
            &self.shadow_abs,
            &self.features,
            &self.critic_loss,
            &self.actor_loss,
            &self.batch_task_abs,
            &self.batch_shadow_abs,
            &self.q_mean,
            &counts,
        ]
        .concat()
        .into_iter()
        .map(|x| x as f32)
        .collect();
        comm.all_reduce_mean(&mut v);
        let w = workers as f64;
        let mut it = v.into_iter().map(f64::from);
        for (field, scale) in [
            (&mut self.returns, w),
            (&mut self.task_abs, w),
            (&mut self.shadow_abs, w),
            (&mut self.features, w),
            (&mut self.critic_loss, 1.0),
            (&mut self.actor_loss, 1.0),
            (&mut self.batch_task_abs, 1.0),
            (&mut self.batch_shadow_abs, 1.0),
            (&mut self.q_mean, 1.0),
        ] {
            field.iter_mut().zip(it.by_ref()).for_each(|(x, m)| *x = m * scale);
        }
        let mut count = || (it.next().unwrap_or(0.0) * w).round() as usize;
        (self.successes, self.episodes, self.steps) = (count(), count(), count());
    }
}

pub(super) fn accumulate_features(infos: &[StepInfo], acc: &mut [f64]) {
    for info in infos {
        for (a, v) in acc.iter_mut().zip(&info.features) {
            *a += f64::from(*v);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::EpochStats;

    // Guards what an old record means: an epoch written before the held
    // success rate was measured reads it as unmeasured, never as 0, and a
    // measured one reads back as written.
    #[test]
    fn an_unmeasured_held_success_rate_reads_as_none() {
        let path =
            concat!(env!("CARGO_MANIFEST_DIR"), "/../docs/results/gpu_lease_2026-11-27/block_dense/metrics.jsonl");
        let line = std::fs::read_to_string(path).unwrap().lines().next().unwrap().to_owned();
        let old: EpochStats = serde_json::from_str(&line).unwrap();
        assert_eq!(old.held_success_rate, None);
        let measured = EpochStats { held_success_rate: Some(0.25), ..old };
        let text = serde_json::to_string(&measured).unwrap();
        assert!(text.contains("\"held_success_rate\":0.25"), "{text}");
        assert_eq!(serde_json::from_str::<EpochStats>(&text).unwrap().held_success_rate, Some(0.25));
    }
}
