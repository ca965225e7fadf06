//! The training loop of Algorithm 1: epochs x cycles of
//! collect -> store -> update (with information sharing) -> evaluate -> checkpoint.
//!
//! Each cycle: `episodes_per_cycle` rollouts with the algorithm's exploration
//! (`Trainer::collect`); each episode goes into the algorithm's storage and its
//! features update the occupancy estimate `lambda` (eq. 1); then the algorithm's
//! updates of the cycle (`Trainer::update`), with every agent's reward `r_i`
//! (eq. 7) computed from the current `lambda` by the [`Collector`], and the
//! information sharing the algorithm applies between its critic and actor steps
//! ([`crate::sharing`]). At the end of an epoch the policy is evaluated on fresh
//! seeded episodes ([`Trainer::evaluate`]); the caller of [`Trainer::train`]
//! writes the checkpoint ([`Trainer::save_checkpoint`]), which keeps the stored
//! episodes in an append-only [replay log](crate::replay_log).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

use std::sync::Arc;

use crate::agent::{Communicator, ObservationLayout, SingleProcess};
use crate::algorithm::{Algorithm, UpdateStats};
use crate::collector::{Collector, RewardSums};
use crate::config::ShadowConfig;
use crate::env::Env;
use crate::error::CoreError;
use crate::occupancy::{DiscountedOccupancy, OccupancyEstimator};
use crate::persist;
use crate::policy::ActMode;
use crate::replay::Episode;
use crate::replay_log::ReplayLog;
use crate::shadow::{LogUtility, ShadowReward};
use crate::spec::{StepInfo, StepOutcome};

/// Settings of the training loop (defaults: the paper's, docs/design.md 3.10). The
/// algorithm's own settings (replay, batches, networks, exploration) live in
/// its config.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TrainerConfig {
    /// Seed of the trainer's random choices (episode seeds, evaluation seeds).
    pub seed: u64,
    /// Epochs (paper: 400).
    pub epochs: usize,
    /// Cycles per epoch (paper: 25).
    pub cycles: usize,
    /// Rollouts per cycle over all worker processes (HER baselines: 2 per
    /// worker; the paper: 4 MPI workers x 2 = 8): each of `N` workers runs
    /// `episodes_per_cycle / N`, so a config means the same experiment on any
    /// number of workers.
    pub episodes_per_cycle: usize,
    /// Environments that run rollouts in lockstep, with one batched policy
    /// call per step; `None` is `episodes_per_cycle`, so a cycle's rollouts run
    /// at once. The history depends on it (exploration noise is drawn per row).
    pub envs: Option<usize>,
    /// Threads that step the environments; `None` is the number of cores. The
    /// history does not depend on it.
    pub threads: Option<usize>,
    /// Discount of the whole method: occupancy (eq. 1) and critic targets; `None` is `1 - 1/T`.
    pub gamma: Option<f64>,
    /// Evaluation episodes at the end of every epoch (paper: 50).
    pub eval_episodes: usize,
    /// Shadow rewards.
    pub shadow: ShadowConfig,
}

impl Default for TrainerConfig {
    fn default() -> Self {
        Self {
            seed: 0,
            epochs: 400,
            cycles: 25,
            episodes_per_cycle: 2,
            envs: None,
            threads: None,
            gamma: None,
            eval_episodes: 50,
            shadow: ShadowConfig::default(),
        }
    }
}

impl TrainerConfig {
    /// Checks every value, naming the key of the first impossible one.
    ///
    /// ```
    /// use fmsr_core::trainer::TrainerConfig;
    /// assert!(TrainerConfig::default().validate().is_ok());
    /// assert!(TrainerConfig { gamma: Some(1.0), ..TrainerConfig::default() }.validate().is_err());
    /// ```
    pub fn validate(&self) -> Result<(), CoreError> {
        let bad = |key: &str, reason: &str| Err(CoreError::InvalidConfig { key: key.into(), reason: reason.into() });
        for (key, v) in [("trainer.cycles", self.cycles), ("trainer.episodes_per_cycle", self.episodes_per_cycle)] {
            if v == 0 {
                return bad(key, "must be at least 1");
            }
        }
        if let Some(g) = self.gamma
            && !(0.0..1.0).contains(&g)
        {
            return bad("trainer.gamma", "must be in [0, 1)");
        }
        if self.envs == Some(0) {
            return bad("trainer.envs", "must be at least 1");
        }
        if self.threads == Some(0) {
            return bad("trainer.threads", "must be at least 1");
        }
        Ok(())
    }

    /// The number of environments: `envs` or `episodes_per_cycle`.
    ///
    /// ```
    /// use fmsr_core::trainer::TrainerConfig;
    /// assert_eq!(TrainerConfig { episodes_per_cycle: 8, ..TrainerConfig::default() }.num_envs(), 8);
    /// assert_eq!(TrainerConfig { envs: Some(3), ..TrainerConfig::default() }.num_envs(), 3);
    /// ```
    #[must_use]
    pub fn num_envs(&self) -> usize {
        self.envs.unwrap_or(self.episodes_per_cycle)
    }

    /// The rollouts per cycle of one of `workers` worker processes.
    ///
    /// ```
    /// use fmsr_core::trainer::TrainerConfig;
    /// let paper = TrainerConfig { episodes_per_cycle: 8, ..TrainerConfig::default() };
    /// assert_eq!(paper.worker_episodes(4).unwrap(), 2);
    /// assert!(paper.worker_episodes(3).is_err());
    /// ```
    ///
    /// # Errors
    /// [`CoreError::InvalidConfig`] (key `trainer.episodes_per_cycle`) unless `workers` divides it.
    pub fn worker_episodes(&self, workers: usize) -> Result<usize, CoreError> {
        crate::replay::per_worker("trainer.episodes_per_cycle", self.episodes_per_cycle, workers)
    }

    /// The environments of one of `workers` worker processes: `envs`, or its rollouts per cycle.
    ///
    /// # Errors
    /// As [`TrainerConfig::worker_episodes`].
    pub fn worker_envs(&self, workers: usize) -> Result<usize, CoreError> {
        Ok(self.envs.unwrap_or(self.worker_episodes(workers)?))
    }

    /// The number of stepping threads: `threads` or the number of cores.
    #[must_use]
    pub fn num_threads(&self) -> usize {
        self.threads.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, std::num::NonZero::get))
    }

    /// The discount for episodes of length `horizon`: `gamma` or `1 - 1/T`.
    ///
    /// ```
    /// use fmsr_core::trainer::TrainerConfig;
    /// assert_eq!(TrainerConfig::default().gamma_for(100), 0.99);
    /// ```
    #[must_use]
    pub fn gamma_for(&self, horizon: usize) -> f64 {
        self.gamma.unwrap_or(1.0 - 1.0 / horizon as f64)
    }
}

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
    /// Mean per-step value of each feature.
    pub feature_rates: Vec<f64>,
    /// Final goal distance of each episode.
    pub final_distances: Vec<f32>,
}

/// The loop's own state: what a checkpoint restores besides the algorithm and the estimator.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct TrainerState {
    epoch: usize,
    rng: ChaCha8Rng,
    updates: u64,
    history: Vec<EpochStats>,
    /// Episodes handed to [`Algorithm::store`] so far.
    stored_episodes: u64,
}

/// The running sums of one epoch.
#[derive(Debug, Default)]
struct EpochTally {
    returns: Vec<f64>,
    task_abs: Vec<f64>,
    shadow_abs: Vec<f64>,
    features: Vec<f64>,
    successes: usize,
    episodes: usize,
    steps: usize,
    critic_loss: Vec<f64>,
    actor_loss: Vec<f64>,
    loss_cycles: usize,
    updates: u64,
    update_seconds: f64,
}

impl EpochTally {
    fn new(agents: usize, features: usize) -> Self {
        Self {
            returns: vec![0.0; agents],
            task_abs: vec![0.0; agents],
            shadow_abs: vec![0.0; agents],
            features: vec![0.0; features],
            critic_loss: vec![0.0; agents],
            actor_loss: vec![0.0; agents],
            ..Self::default()
        }
    }

    fn add_episode(&mut self, episode: &Episode, sums: &RewardSums) {
        let add = |acc: &mut Vec<f64>, v: &[f64]| acc.iter_mut().zip(v).for_each(|(a, x)| *a += x);
        add(&mut self.returns, &sums.returns);
        add(&mut self.task_abs, &sums.task_abs);
        add(&mut self.shadow_abs, &sums.shadow_abs);
        accumulate_features(&episode.infos, &mut self.features);
        self.successes += usize::from(episode.infos.last().is_some_and(|i| i.is_success));
        self.episodes += 1;
        self.steps += episode.infos.len();
    }

    fn add_update(&mut self, stats: &UpdateStats, seconds: f64) {
        self.update_seconds += seconds;
        if stats.updates == 0 {
            return;
        }
        self.updates += stats.updates;
        self.loss_cycles += 1;
        self.critic_loss.iter_mut().zip(&stats.critic_loss).for_each(|(a, v)| *a += v);
        self.actor_loss.iter_mut().zip(&stats.actor_loss).for_each(|(a, v)| *a += v);
    }
}

/// The training loop; see the [module docs](self).
#[derive(Debug)]
pub struct Trainer<E, A, O = DiscountedOccupancy, S = LogUtility> {
    config: TrainerConfig,
    collector: Collector<E, O, S>,
    algorithm: A,
    state: TrainerState,
    log: ReplayLog,
    comm: Arc<dyn Communicator>,
}

/// A well-mixed 64-bit hash (splitmix64), used to derive evaluation seeds.
#[must_use]
pub fn splitmix64(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^ (x >> 31)
}

/// The trainer's random stream of worker `rank` (worker 0: the single-process one).
fn rank_rng(seed: u64, rank: usize) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(rank as u64);
    rng
}

fn algo_err<E: std::error::Error + Send + Sync + 'static>(e: E) -> CoreError {
    CoreError::Algorithm(Box::new(e))
}

impl<E: Env + Send, A: Algorithm> Trainer<E, A> {
    /// A trainer of `algorithm` on `env` with the paper's occupancy estimator and
    /// log utility as configured in `config.shadow`; actors see inputs laid out by `layout`.
    ///
    /// # Errors
    /// [`CoreError`] naming the first setting that does not fit `env`.
    pub fn new(config: TrainerConfig, env: E, algorithm: A, layout: ObservationLayout) -> Result<Self, CoreError> {
        Self::with_envs(config, vec![env], algorithm, layout)
    }

    /// As [`Trainer::new`] with several copies of one environment, which run
    /// rollouts in lockstep ([`Collector::rollouts`]).
    ///
    /// # Errors
    /// [`CoreError`] naming the first setting that does not fit the environments.
    pub fn with_envs(
        config: TrainerConfig,
        envs: Vec<E>,
        algorithm: A,
        layout: ObservationLayout,
    ) -> Result<Self, CoreError> {
        config.validate()?;
        let spec = envs
            .first()
            .map(|e| e.spec().clone())
            .ok_or(CoreError::InvalidConfig { key: "trainer.envs".into(), reason: "must be at least 1".into() })?;
        let gamma = config.gamma_for(spec.episode_len);
        let rewards = config.shadow.agent_rewards(&spec)?;
        let occupancy = config.shadow.occupancy(&spec, gamma)?;
        let collector = Collector::with_envs(envs, layout, occupancy, rewards)?;
        Self::with_collector(config, collector, algorithm)
    }
}

impl<E: Env + Send, A: Algorithm, O: OccupancyEstimator, S: ShadowReward> Trainer<E, A, O, S> {
    /// A trainer of `algorithm` with a collector of your own (your own
    /// [`OccupancyEstimator`] and [`ShadowReward`]). `config.shadow` is not
    /// used to build anything here: the collector carries the estimator and rewards.
    ///
    /// # Errors
    /// [`CoreError`] when the config is invalid or the algorithm has another number of agents.
    pub fn with_collector(
        config: TrainerConfig,
        collector: Collector<E, O, S>,
        algorithm: A,
    ) -> Result<Self, CoreError> {
        config.validate()?;
        let agents = collector.env().spec().agents.len();
        if algorithm.num_agents() != agents {
            return Err(CoreError::Dimension {
                what: "algorithm agents",
                expected: agents,
                found: algorithm.num_agents(),
            });
        }
        let state = TrainerState {
            epoch: 0,
            rng: rank_rng(config.seed, 0),
            updates: 0,
            history: Vec::new(),
            stored_episodes: 0,
        };
        Ok(Self { config, collector, algorithm, state, log: ReplayLog::default(), comm: Arc::new(SingleProcess) })
    }

    /// Trains as one of `comm.workers()` worker processes (MPI) of one run:
    /// episode seeds come from a random stream of the worker's own (worker 0's
    /// is the single-process one), every worker's occupancy estimate observes
    /// the episodes of all workers, the epoch statistics are summed over them,
    /// and worker 0 writes the checkpoints of all (each worker's own RNG, replay
    /// log and learner state; see [`Trainer::save_checkpoint`]). Give the
    /// algorithm the same communicator, so that gradients are averaged.
    ///
    /// # Errors
    /// [`CoreError::InvalidConfig`] when `episodes_per_cycle` does not split
    /// evenly over the workers.
    pub fn with_communicator(mut self, comm: Arc<dyn Communicator>) -> Result<Self, CoreError> {
        self.config.worker_episodes(comm.workers())?;
        self.state.rng = rank_rng(self.config.seed, comm.rank());
        self.comm = comm;
        Ok(self)
    }

    /// The communicator between worker processes ([`SingleProcess`] by default).
    #[must_use]
    pub fn communicator(&self) -> &dyn Communicator {
        self.comm.as_ref()
    }

    /// The configuration.
    #[must_use]
    pub fn config(&self) -> &TrainerConfig {
        &self.config
    }

    /// The algorithm.
    #[must_use]
    pub fn algorithm(&self) -> &A {
        &self.algorithm
    }

    /// The algorithm, mutably.
    pub fn algorithm_mut(&mut self) -> &mut A {
        &mut self.algorithm
    }

    /// The collector (environment, layout, occupancy estimate, rewards).
    #[must_use]
    pub fn collector(&self) -> &Collector<E, O, S> {
        &self.collector
    }

    /// The environment.
    #[must_use]
    pub fn env(&self) -> &E {
        self.collector.env()
    }

    /// The environment, mutably.
    pub fn env_mut(&mut self) -> &mut E {
        self.collector.env_mut()
    }

    /// How actor inputs are assembled.
    #[must_use]
    pub fn layout(&self) -> &ObservationLayout {
        self.collector.layout()
    }

    /// The statistics of every finished epoch.
    #[must_use]
    pub fn history(&self) -> &[EpochStats] {
        &self.state.history
    }

    /// Epochs finished so far.
    #[must_use]
    pub fn epoch(&self) -> usize {
        self.state.epoch
    }

    /// The current occupancy estimate, one value per feature.
    #[must_use]
    pub fn occupancy(&self) -> &[f64] {
        self.collector.occupancy().estimate()
    }

    /// Runs one episode from `seed` with the algorithm's policy in `mode`.
    ///
    /// # Errors
    /// Errors of the environment or the policy.
    pub fn rollout(&mut self, seed: u64, mode: ActMode) -> Result<Episode, CoreError> {
        self.rollout_with(seed, mode, &mut |_, _| {})
    }

    /// As [`Trainer::rollout`], calling `on_step(env, outcome)` after every step
    /// (e.g. to read contacts for the grasp metrics).
    ///
    /// # Errors
    /// Errors of the environment or the policy.
    pub fn rollout_with(
        &mut self,
        seed: u64,
        mode: ActMode,
        on_step: &mut dyn FnMut(&E, &StepOutcome),
    ) -> Result<Episode, CoreError> {
        self.collector.rollout(&mut self.algorithm, seed, mode, on_step)
    }

    /// Evaluates the policy ([`ActMode::Evaluate`]) on one episode per seed.
    /// Success is a final goal distance below `threshold`, or with `None` the
    /// environment's own success flag at the last step (its training threshold).
    ///
    /// # Errors
    /// Errors of the environment or the policy.
    pub fn evaluate(&mut self, seeds: &[u64], threshold: Option<f32>) -> Result<EvalSummary, CoreError> {
        let k = self.env().spec().features.len();
        let mut summary = EvalSummary { episodes: seeds.len(), feature_rates: vec![0.0; k], ..EvalSummary::default() };
        let (mut successes, mut drops, mut steps) = (0usize, 0usize, 0usize);
        for ep in self.collector.rollouts(&mut self.algorithm, seeds, ActMode::Evaluate)? {
            let Some(last) = ep.observations.last() else { continue };
            let d = self.env().goal_distance(&last.achieved_goal, &last.desired_goal);
            let success = match threshold {
                Some(t) => d < t,
                None => ep.infos.last().is_some_and(|i| i.is_success),
            };
            successes += usize::from(success);
            drops += usize::from(ep.infos.iter().any(|i| i.dropped));
            summary.final_distances.push(d);
            accumulate_features(&ep.infos, &mut summary.feature_rates);
            steps += ep.infos.len();
        }
        let n = seeds.len().max(1) as f64;
        summary.success_rate = successes as f64 / n;
        summary.drop_rate = drops as f64 / n;
        summary.feature_rates.iter_mut().for_each(|r| *r /= steps.max(1) as f64);
        Ok(summary)
    }

    /// The evaluation seeds of epoch `epoch`: fresh every epoch, fixed by the config seed.
    #[must_use]
    pub fn eval_seeds(&self, epoch: usize) -> Vec<u64> {
        (0..self.config.eval_episodes as u64)
            .map(|i| splitmix64(splitmix64(self.config.seed ^ 0xE7A1_5EED) ^ ((epoch as u64) << 32) ^ i))
            .collect()
    }

    /// Collect and store: one cycle's exploring rollouts, each stored by the
    /// algorithm; the occupancy estimator observes the cycle's episodes of every
    /// worker, in rank order, and the epoch's sums use the updated estimate.
    fn collect(&mut self, tally: &mut EpochTally) -> Result<(), CoreError> {
        let n = self.config.worker_episodes(self.comm.workers())?;
        let seeds: Vec<u64> = (0..n).map(|_| self.state.rng.random::<u64>()).collect();
        let episodes = self.collector.rollouts(&mut self.algorithm, &seeds, ActMode::Explore)?;
        for episode in &episodes {
            self.algorithm.store(episode).map_err(algo_err)?;
        }
        self.observe_every_worker(&episodes)?;
        for episode in episodes {
            tally.add_episode(&episode, &self.collector.reward_sums(&episode));
            self.log.push(episode, self.algorithm.storage_capacity());
            self.state.stored_episodes += 1;
        }
        Ok(())
    }

    /// The occupancy estimator observes the features of every worker's
    /// `episodes` (all of them `T` steps long), in rank order.
    fn observe_every_worker(&mut self, episodes: &[Episode]) -> Result<(), CoreError> {
        let (steps, k) = (self.env().spec().episode_len, self.env().spec().features.len());
        let local: Vec<f32> = episodes.iter().flat_map(|e| e.infos.iter().flat_map(|i| i.features.clone())).collect();
        if local.len() != episodes.len() * steps * k {
            return Err(CoreError::Dimension {
                what: "episode features",
                expected: episodes.len() * steps * k,
                found: local.len(),
            });
        }
        let all = self.comm.all_gather(&local);
        for e in 0..episodes.len() * self.comm.workers() {
            let episode = &all[e * steps * k..(e + 1) * steps * k];
            let features: Vec<Vec<f32>> = (0..steps).map(|t| episode[t * k..(t + 1) * k].to_vec()).collect();
            self.collector.observe_features(&features)?;
        }
        Ok(())
    }

    /// Update (and share): the algorithm's updates of one cycle.
    fn update(&mut self, tally: &mut EpochTally) -> Result<(), CoreError> {
        let start = Instant::now();
        let stats = self.algorithm.update(&self.collector).map_err(algo_err)?;
        tally.add_update(&stats, start.elapsed().as_secs_f64());
        Ok(())
    }

    /// With several workers: the epoch's sums over all of them (losses: the
    /// mean). Every worker evaluates the same seeds with the same networks.
    fn reduce_tally(&self, tally: &mut EpochTally) {
        let workers = self.comm.workers();
        if workers <= 1 {
            return;
        }
        let counts = [tally.successes, tally.episodes, tally.steps].map(|c| c as f64);
        let mut v: Vec<f32> = [
            &tally.returns[..],
            &tally.task_abs,
            &tally.shadow_abs,
            &tally.features,
            &tally.critic_loss,
            &tally.actor_loss,
            &counts,
        ]
        .concat()
        .into_iter()
        .map(|x| x as f32)
        .collect();
        self.comm.all_reduce_mean(&mut v);
        let w = workers as f64;
        let mut it = v.into_iter().map(f64::from);
        for (field, scale) in [
            (&mut tally.returns, w),
            (&mut tally.task_abs, w),
            (&mut tally.shadow_abs, w),
            (&mut tally.features, w),
            (&mut tally.critic_loss, 1.0),
            (&mut tally.actor_loss, 1.0),
        ] {
            field.iter_mut().zip(it.by_ref()).for_each(|(x, m)| *x = m * scale);
        }
        let mut count = || (it.next().unwrap_or(0.0) * w).round() as usize;
        (tally.successes, tally.episodes, tally.steps) = (count(), count(), count());
    }

    /// `trainer.shadow.max_scale`: no agent's shadow rewards may outweigh its
    /// task rewards by more than that ratio in the first cycle.
    fn check_shadow_scale(&self, tally: &EpochTally) -> Result<(), CoreError> {
        let max = self.config.shadow.max_scale;
        let names = &self.env().spec().agents;
        for (i, (&task, &shadow)) in tally.task_abs.iter().zip(&tally.shadow_abs).enumerate() {
            if shadow > max * task {
                let steps = tally.steps.max(1) as f64;
                return Err(CoreError::InvalidConfig {
                    key: "trainer.shadow.max_scale".into(),
                    reason: format!(
                        "in the first cycle agent `{}`'s shadow rewards average {:.3} per step against {:.3} for \
                         the task (ratio {:.2} > {max}): lower trainer.shadow.alpha (now {}) or raise \
                         trainer.shadow.max_scale",
                        names.get(i).map_or("?", |a| a.name.as_str()),
                        shadow / steps,
                        task / steps,
                        shadow / task.max(f64::MIN_POSITIVE),
                        self.config.shadow.alpha
                    ),
                });
            }
        }
        Ok(())
    }

    /// The statistics of a finished epoch.
    fn epoch_stats(&self, tally: &EpochTally, eval: EvalSummary, seconds: f64, env_steps: u64) -> EpochStats {
        let per = |v: &[f64], n: usize| v.iter().map(|x| x / n.max(1) as f64).collect();
        EpochStats {
            epoch: self.state.epoch,
            success_rate: eval.success_rate,
            train_success_rate: tally.successes as f64 / tally.episodes.max(1) as f64,
            drop_rate: eval.drop_rate,
            eval_feature_rates: eval.feature_rates,
            train_feature_rates: per(&tally.features, tally.steps),
            returns: per(&tally.returns, tally.episodes),
            task_reward_abs: per(&tally.task_abs, tally.steps),
            shadow_reward_abs: per(&tally.shadow_abs, tally.steps),
            occupancy: self.occupancy().to_vec(),
            critic_loss: per(&tally.critic_loss, tally.loss_cycles),
            actor_loss: per(&tally.actor_loss, tally.loss_cycles),
            env_steps: self.collector.env_steps() * self.comm.workers() as u64,
            updates: self.state.updates,
            env_steps_per_sec: (env_steps * self.comm.workers() as u64) as f64
                / (seconds - tally.update_seconds).max(1e-9),
            updates_per_sec: tally.updates as f64 / tally.update_seconds.max(1e-9),
            seconds,
        }
    }

    /// Runs one epoch (cycles of collect, store, update and share, then evaluate)
    /// and returns (and records) its statistics.
    ///
    /// # Errors
    /// Errors of the environment, the policy or the algorithm's updates.
    pub fn run_epoch(&mut self) -> Result<EpochStats, CoreError> {
        let start = Instant::now();
        let spec = self.env().spec();
        let mut tally = EpochTally::new(spec.agents.len(), spec.features.len());
        let steps_before = self.collector.env_steps();
        for cycle in 0..self.config.cycles {
            self.collect(&mut tally)?;
            if self.state.epoch == 0 && cycle == 0 {
                self.check_shadow_scale(&tally)?;
            }
            self.update(&mut tally)?;
        }
        self.state.updates += tally.updates;
        self.reduce_tally(&mut tally);
        let eval = self.evaluate(&self.eval_seeds(self.state.epoch), None)?;
        let stats =
            self.epoch_stats(&tally, eval, start.elapsed().as_secs_f64(), self.collector.env_steps() - steps_before);
        self.state.history.push(stats.clone());
        self.state.epoch += 1;
        Ok(stats)
    }

    /// Runs the remaining epochs up to `config.epochs`, calling `on_epoch` after
    /// each (e.g. to log and write a checkpoint).
    ///
    /// # Errors
    /// The first error of an epoch or of `on_epoch`.
    pub fn train(
        &mut self,
        mut on_epoch: impl FnMut(&mut Self, &EpochStats) -> Result<(), CoreError>,
    ) -> Result<(), CoreError> {
        while self.state.epoch < self.config.epochs {
            let stats = self.run_epoch()?;
            on_epoch(self, &stats)?;
        }
        Ok(())
    }
}

fn accumulate_features(infos: &[StepInfo], acc: &mut [f64]) {
    for info in infos {
        for (a, v) in acc.iter_mut().zip(&info.features) {
            *a += f64::from(*v);
        }
    }
}

const MAGIC: &[u8; 8] = b"FMSRCKPT";
/// Version 3: the [`persist`] framing; the replay lives in the replay log.
const VERSION: u32 = 3;

/// A checkpoint file: the trainer's part as JSON (the configuration's tagged
/// enums need a self-describing format), the algorithm's as its own bytes.
#[derive(Serialize, Deserialize)]
struct CheckpointFile {
    meta: String,
    algorithm: Vec<u8>,
}

#[derive(Serialize, Deserialize)]
struct CheckpointMeta<O> {
    config: TrainerConfig,
    state: TrainerState,
    occupancy: O,
    env_steps: u64,
    /// Worker processes of the run, and which one this file belongs to.
    workers: usize,
    rank: usize,
}

/// What a checkpoint holds for a reader that does not train: how far the run
/// got and the algorithm's state (e.g. to take its policy out, `fmsr export`).
#[derive(Debug, Clone, PartialEq)]
pub struct CheckpointContents {
    /// Epochs trained when the checkpoint was written.
    pub epoch: usize,
    /// Env steps collected by then (this worker's).
    pub env_steps: u64,
    /// The algorithm's state ([`Algorithm::save_state`] without storage).
    pub algorithm: Vec<u8>,
    /// The per-epoch statistics up to the checkpoint, as the trainer kept
    /// them: `metrics.jsonl` is written after the checkpoint, so a reader of a
    /// run that trains can find it one epoch behind; this never is.
    pub history: Vec<EpochStats>,
}

/// Reads worker 0's checkpoint file written by [`Trainer::save_checkpoint`]
/// without building a trainer (any occupancy estimator, any configuration).
///
/// # Errors
/// [`CoreError::Io`]; [`CoreError::Corrupt`] for a file that is not a
/// checkpoint of this build, truncated or corrupted.
pub fn read_checkpoint_contents(path: &Path) -> Result<CheckpointContents, CoreError> {
    #[derive(Deserialize)]
    struct Progress {
        epoch: usize,
        #[serde(default)]
        history: Vec<EpochStats>,
    }
    #[derive(Deserialize)]
    struct Meta {
        state: Progress,
        env_steps: u64,
    }
    let corrupt = |reason: String| CoreError::Corrupt { path: path.into(), reason };
    let bytes = std::fs::read(path).map_err(|source| CoreError::Io { path: path.into(), source })?;
    let file: CheckpointFile = persist::decode(MAGIC, VERSION, &bytes).map_err(|e| corrupt(e.to_string()))?;
    let meta: Meta = serde_json::from_str(&file.meta).map_err(|e| corrupt(e.to_string()))?;
    Ok(CheckpointContents {
        epoch: meta.state.epoch,
        env_steps: meta.env_steps,
        algorithm: file.algorithm,
        history: meta.state.history,
    })
}

/// What one worker contributes to a checkpoint: its checkpoint file and its
/// new replay segment (name and bytes).
#[derive(Serialize, Deserialize)]
struct WorkerFiles {
    checkpoint: Vec<u8>,
    segment: Option<(String, Vec<u8>)>,
}

const WORKER_MAGIC: &[u8; 8] = b"FMSRWRKR";

/// The checkpoint file of worker `rank` at `epoch`: `path` itself for worker 0
/// (the file whose rename commits a checkpoint), else
/// `<stem>.worker<rank>.e<epoch>.<ext>` beside it.
fn worker_path(path: &Path, rank: usize, epoch: usize) -> PathBuf {
    if rank == 0 {
        return path.to_path_buf();
    }
    let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let ext = path.extension().map(|e| e.to_string_lossy().into_owned()).unwrap_or_default();
    path.with_file_name(format!("{stem}.worker{rank}.e{epoch:06}.{ext}"))
}

/// The replay log folder of worker `rank`: [`ReplayLog::dir`] for worker 0,
/// else `<stem>.worker<rank>.replay`.
fn worker_replay_dir(path: &Path, rank: usize) -> PathBuf {
    if rank == 0 {
        return ReplayLog::dir(path);
    }
    let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    path.with_file_name(format!("{stem}.worker{rank}.replay"))
}

/// Deletes the checkpoint files of workers `1..workers` from other epochs than `epoch`.
fn remove_stale_worker_files(path: &Path, workers: usize, epoch: usize) -> Result<(), CoreError> {
    let dir = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let current: Vec<PathBuf> = (1..workers).map(|r| worker_path(path, r, epoch)).collect();
    let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let prefix = format!("{stem}.worker");
    let entries = std::fs::read_dir(dir).map_err(|source| CoreError::Io { path: dir.into(), source })?;
    for entry in entries.flatten() {
        let p = entry.path();
        let name = entry.file_name().to_string_lossy().into_owned();
        let stale = name.starts_with(&prefix) && p.extension() == path.extension() && !current.contains(&p);
        if stale && p.is_file() {
            std::fs::remove_file(&p).map_err(|source| CoreError::Io { path: p.clone(), source })?;
        }
    }
    Ok(())
}

/// Writes `bytes` to `path` atomically: a temporary file in the same folder,
/// flushed to disk, then renamed over `path`. A crash leaves either the old or the
/// new file, never a torn one.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), CoreError> {
    let io = |source| CoreError::Io { path: path.to_path_buf(), source };
    let dir = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir).map_err(io)?;
    let file_name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let tmp: PathBuf = dir.join(format!(".{file_name}.tmp{}", std::process::id()));
    let mut f = std::fs::File::create(&tmp).map_err(io)?;
    f.write_all(bytes).map_err(io)?;
    f.sync_all().map_err(io)?;
    drop(f);
    std::fs::rename(&tmp, path).map_err(io)?;
    if let Ok(d) = std::fs::File::open(dir) {
        let _ = d.sync_all();
    }
    Ok(())
}

impl<E, A, O, S> Trainer<E, A, O, S>
where
    E: Env + Send,
    A: Algorithm,
    O: OccupancyEstimator + Serialize + DeserializeOwned,
    S: ShadowReward,
{
    /// Writes a checkpoint of everything training needs to continue: the
    /// algorithm's state (networks, optimisers, normalisers, RNG), the trainer's
    /// RNG, counters and history, and the occupancy estimate, to `path`; and the
    /// episodes stored since the previous checkpoint to the replay log beside it
    /// ([`ReplayLog::dir`]). Resuming continues exactly as an uninterrupted run.
    /// Every file is written atomically, in an order that leaves a loadable
    /// checkpoint whenever the process is killed (see [`crate::replay_log`]).
    ///
    /// With several workers every worker calls this; worker 0 gathers and
    /// writes every worker's files (`<stem>.worker<r>.e<epoch>.<ext>` and
    /// `<stem>.worker<r>.replay/` beside `path`), its own last.
    ///
    /// # Errors
    /// I/O errors, and errors of the algorithm's `save_state`.
    pub fn save_checkpoint(&mut self, path: &Path) -> Result<(), CoreError> {
        let files = WorkerFiles {
            segment: self.log.take_segment(self.state.stored_episodes)?,
            checkpoint: self.checkpoint_bytes(path)?,
        };
        let all = if self.comm.workers() <= 1 {
            vec![files]
        } else {
            let corrupt = |e: persist::FormatError| CoreError::Corrupt { path: path.into(), reason: e.to_string() };
            let bytes = persist::encode(WORKER_MAGIC, VERSION, &files).map_err(corrupt)?;
            let Some(gathered) = self.comm.gather_bytes(bytes) else { return Ok(()) };
            gathered
                .iter()
                .map(|b| persist::decode(WORKER_MAGIC, VERSION, b).map_err(corrupt))
                .collect::<Result<_, _>>()?
        };
        self.write_checkpoint_files(path, all)
    }

    /// This worker's checkpoint file.
    fn checkpoint_bytes(&self, path: &Path) -> Result<Vec<u8>, CoreError> {
        let meta = CheckpointMeta {
            config: self.config.clone(),
            state: self.state.clone(),
            occupancy: self.collector.occupancy(),
            env_steps: self.collector.env_steps(),
            workers: self.comm.workers(),
            rank: self.comm.rank(),
        };
        let corrupt = |reason: String| CoreError::Corrupt { path: path.into(), reason };
        let meta = serde_json::to_string(&meta).map_err(|e| corrupt(e.to_string()))?;
        let algorithm = self.algorithm.save_state(false).map_err(algo_err)?;
        persist::encode(MAGIC, VERSION, &CheckpointFile { meta, algorithm }).map_err(|e| corrupt(e.to_string()))
    }

    /// Writes every worker's segment, then the other workers' checkpoints, then
    /// worker 0's (the commit), then prunes what the new checkpoint no longer needs.
    fn write_checkpoint_files(&self, path: &Path, all: Vec<WorkerFiles>) -> Result<(), CoreError> {
        let epoch = self.state.epoch;
        for (rank, files) in all.iter().enumerate() {
            if let Some((name, bytes)) = &files.segment {
                write_atomic(&worker_replay_dir(path, rank).join(name), bytes)?;
            }
        }
        for (rank, files) in all.iter().enumerate().skip(1).chain(all.iter().enumerate().take(1)) {
            write_atomic(&worker_path(path, rank, epoch), &files.checkpoint)?;
        }
        for rank in 0..all.len() {
            ReplayLog::prune(&worker_replay_dir(path, rank), self.window_start())?;
        }
        if all.len() > 1 { remove_stale_worker_files(path, all.len(), epoch) } else { Ok(()) }
    }

    /// Restores a checkpoint written by [`Trainer::save_checkpoint`], with the
    /// algorithm's storage read back from the replay log. The checkpoint must
    /// come from the same configuration, except `epochs`, which may be raised to
    /// train longer, and `envs` and `threads`, and from as many workers; each
    /// worker reads its own files. A corrupted, truncated or mismatched file is
    /// an error naming the problem.
    ///
    /// # Errors
    /// [`CoreError::Io`], [`CoreError::Corrupt`] (also for a damaged or missing
    /// replay log), [`CoreError::InvalidConfig`] (another configuration, or
    /// another number of workers) or the algorithm's error (another shape).
    pub fn load_checkpoint(&mut self, path: &Path) -> Result<(), CoreError> {
        let (rank, workers) = (self.comm.rank(), self.comm.workers());
        let (main, algorithm) = self.read_checkpoint(path)?;
        if main.workers != workers {
            return Err(CoreError::InvalidConfig {
                key: "checkpoint".into(),
                reason: format!(
                    "{} was written by a run of {} worker process(es), this one has {workers}: resume with as many \
                     (`mpirun -np {}`), or start a new run",
                    path.display(),
                    main.workers,
                    main.workers
                ),
            });
        }
        let own = worker_path(path, rank, main.state.epoch);
        let (meta, algorithm) = if rank == 0 { (main, algorithm) } else { self.read_checkpoint(&own)? };
        if meta.rank != rank {
            return Err(CoreError::Corrupt { path: own, reason: format!("holds worker {}'s state", meta.rank) });
        }
        self.apply_checkpoint(meta, &algorithm)?;
        let (from, to) = (self.window_start(), self.state.stored_episodes);
        let episodes = ReplayLog::read(&worker_replay_dir(path, rank), from, to)?;
        self.algorithm.restore_storage(to, &episodes).map_err(algo_err)
    }

    /// As [`Trainer::load_checkpoint`] but leaves the algorithm's storage as it
    /// is and reads no replay log, and only worker 0's file: enough to evaluate
    /// the policy (of a run of any number of workers), not to train on.
    ///
    /// # Errors
    /// As [`Trainer::load_checkpoint`].
    pub fn load_checkpoint_without_storage(&mut self, path: &Path) -> Result<(), CoreError> {
        let (meta, algorithm) = self.read_checkpoint(path)?;
        self.apply_checkpoint(meta, &algorithm)
    }

    /// A checkpoint file's trainer part (checked against this trainer's
    /// configuration) and algorithm bytes.
    fn read_checkpoint(&self, path: &Path) -> Result<(CheckpointMeta<O>, Vec<u8>), CoreError> {
        let corrupt = |reason: String| CoreError::Corrupt { path: path.into(), reason };
        let bytes = std::fs::read(path).map_err(|source| CoreError::Io { path: path.into(), source })?;
        let file: CheckpointFile = persist::decode(MAGIC, VERSION, &bytes).map_err(|e| corrupt(e.to_string()))?;
        let meta: CheckpointMeta<O> = serde_json::from_str(&file.meta).map_err(|e| corrupt(e.to_string()))?;
        let mut expected = self.config.clone();
        expected.epochs = meta.config.epochs;
        // Threads do not change the history; envs only batch the remaining
        // rollouts differently (and `fmsr eval` runs on one environment).
        expected.threads = meta.config.threads;
        expected.envs = meta.config.envs;
        if meta.config != expected {
            return Err(CoreError::InvalidConfig {
                key: "checkpoint".into(),
                reason: format!("{} was written with a different configuration", path.display()),
            });
        }
        if meta.occupancy.estimate().len() != self.env().spec().features.len() {
            return Err(corrupt("occupancy has a different number of features".into()));
        }
        Ok((meta, file.algorithm))
    }

    fn apply_checkpoint(&mut self, meta: CheckpointMeta<O>, algorithm: &[u8]) -> Result<(), CoreError> {
        self.algorithm.load_state(algorithm).map_err(algo_err)?;
        self.collector.restore(meta.occupancy, meta.env_steps);
        self.log = ReplayLog::default();
        self.state = meta.state;
        Ok(())
    }

    /// The store index of the oldest episode the algorithm's storage still holds.
    fn window_start(&self) -> u64 {
        self.state.stored_episodes.saturating_sub(self.algorithm.storage_capacity() as u64)
    }
}
