//! The training loop of Algorithm 1: epochs x cycles of
//! collect -> store -> update (with information sharing) -> evaluate -> checkpoint.
//!
//! Each cycle: `episodes_per_cycle` rollouts with the algorithm's exploration
//! (`Trainer::collect`); each episode goes into the algorithm's storage and its
//! features update the occupancy estimate `lambda` (eq. 1); then the algorithm's
//! updates of the cycle (`Trainer::update`), with every agent's reward `r_i`
//! (eq. 7) computed from the current `lambda` by the [`ShadowRewards`], and the
//! information sharing the algorithm applies at its critic and actor steps
//! ([`crate::sharing`]: after each step in parameter mode, to its gradients in
//! gradient mode). At the end of an epoch the policy is evaluated on fresh
//! seeded episodes ([`Trainer::evaluate`]); the caller of [`Trainer::train`]
//! writes the checkpoint ([`Trainer::save_checkpoint`]), which keeps the stored
//! episodes in an append-only [replay log](crate::replay_log).

mod checkpoint;
mod config;
mod rescue;
mod stats;

use std::sync::Arc;
use std::time::Instant;

use rand::RngExt;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

pub use self::checkpoint::{CheckpointContents, read_checkpoint_contents};
pub use self::config::TrainerConfig;
pub use self::rescue::{RescuePoint, Restart};
pub use self::stats::{EpochStats, EvalSummary};
use self::stats::{EpochTally, accumulate_features};
use crate::agent::{Communicator, ObservationLayout, SingleProcess};
use crate::algorithm::Algorithm;
use crate::collector::Collector;
use crate::env::Env;
use crate::error::CoreError;
use crate::policy::ActMode;
use crate::replay::Episode;
use crate::replay_log::ReplayLog;
use crate::seeding::{rank_rng, splitmix64};
use crate::shadow::{DiscountedOccupancy, LogUtility, OccupancyEstimator, ShadowReward, ShadowRewards};
use crate::spec::StepOutcome;

/// The loop's own state: what a checkpoint restores besides the algorithm and the estimator.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct TrainerState {
    epoch: usize,
    rng: ChaCha8Rng,
    updates: u64,
    history: Vec<EpochStats>,
    /// Episodes handed to [`Algorithm::store`] so far.
    stored_episodes: u64,
    /// Store index of the first episode the algorithm's storage can hold:
    /// those before it were lost at a restart from a rescue point (0 for a
    /// run never restarted so, and in checkpoints older than the full-angle task).
    #[serde(default)]
    replay_floor: u64,
    /// Each restart from a rescue point, in order.
    #[serde(default)]
    restarts: Vec<Restart>,
}

/// The training loop; see the [module docs](self).
#[derive(Debug)]
pub struct Trainer<E, A, O = DiscountedOccupancy, S = LogUtility> {
    config: TrainerConfig,
    collector: Collector<E>,
    shadow: ShadowRewards<O, S>,
    algorithm: A,
    state: TrainerState,
    log: ReplayLog,
    comm: Arc<dyn Communicator>,
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
    /// rollouts in lockstep ([`Collector::rollouts`]), stepped on
    /// `config.threads` threads (at most one per environment).
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
        let shadow = ShadowRewards::new(&spec, occupancy, rewards)?;
        let collector = Collector::with_envs(envs, layout)?.with_threads(config.num_threads())?;
        Self::from_parts(config, collector, shadow, algorithm)
    }
}

impl<E: Env + Send, A: Algorithm, O: OccupancyEstimator, S: ShadowReward> Trainer<E, A, O, S> {
    /// A trainer of `algorithm` from its parts: a collector, and shadow rewards
    /// of your own (your own [`OccupancyEstimator`] and [`ShadowReward`]).
    /// `config.shadow` is not used to build anything here, except its
    /// `max_scale` check: `shadow` carries the estimator and rewards; nor is
    /// `config.threads`: the collector steps on its own
    /// ([`Collector::with_threads`]).
    ///
    /// # Errors
    /// [`CoreError`] when the config is invalid, or the shadow rewards or the
    /// algorithm have another number of agents than the collector's environment.
    pub fn from_parts(
        config: TrainerConfig,
        collector: Collector<E>,
        shadow: ShadowRewards<O, S>,
        algorithm: A,
    ) -> Result<Self, CoreError> {
        config.validate()?;
        let agents = collector.env().spec().agents.len();
        if shadow.rewards().num_agents() != agents {
            return Err(CoreError::Dimension {
                what: "reward assignment agents",
                expected: agents,
                found: shadow.rewards().num_agents(),
            });
        }
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
            replay_floor: 0,
            restarts: Vec::new(),
        };
        Ok(Self {
            config,
            collector,
            shadow,
            algorithm,
            state,
            log: ReplayLog::default(),
            comm: Arc::new(SingleProcess),
        })
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

    /// The collector (environments, layout, steps run).
    #[must_use]
    pub fn collector(&self) -> &Collector<E> {
        &self.collector
    }

    /// The shadow rewards (occupancy estimate and the agents' rewards).
    #[must_use]
    pub fn shadow_rewards(&self) -> &ShadowRewards<O, S> {
        &self.shadow
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

    /// The run's restarts from rescue points, in order ([`Trainer::restore_rescue`]).
    #[must_use]
    pub fn restarts(&self) -> &[Restart] {
        &self.state.restarts
    }

    /// Epochs finished so far.
    #[must_use]
    pub fn epoch(&self) -> usize {
        self.state.epoch
    }

    /// The current occupancy estimate, one value per feature.
    #[must_use]
    pub fn occupancy(&self) -> &[f64] {
        self.shadow.estimate()
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
    /// environment's own success flag at the last step (its training threshold):
    /// drops are not looked at, as HER's logging counts success (with `None`,
    /// the eval success of `metrics.csv`). Dropped episodes are counted apart
    /// ([`EvalSummary::drop_rate`]), and the successes under the test's rule,
    /// where a drop is a failure ([`crate::metrics::classify`]), apart too
    /// ([`EvalSummary::held_success_rate`]).
    ///
    /// # Errors
    /// Errors of the environment or the policy.
    pub fn evaluate(&mut self, seeds: &[u64], threshold: Option<f32>) -> Result<EvalSummary, CoreError> {
        let k = self.env().spec().features.len();
        let mut summary = EvalSummary { episodes: seeds.len(), feature_rates: vec![0.0; k], ..EvalSummary::default() };
        let (mut successes, mut held, mut drops, mut steps) = (0usize, 0usize, 0usize, 0usize);
        for ep in self.collector.rollouts(&mut self.algorithm, seeds, ActMode::Evaluate)? {
            let Some(last) = ep.observations.last() else { continue };
            let d = self.env().goal_distance(&last.achieved_goal, &last.desired_goal);
            let success = match threshold {
                Some(t) => d < t,
                None => ep.infos.last().is_some_and(|i| i.is_success),
            };
            let dropped = ep.infos.iter().any(|i| i.dropped);
            successes += usize::from(success);
            held += usize::from(success && !dropped);
            drops += usize::from(dropped);
            summary.final_distances.push(d);
            accumulate_features(&ep.infos, &mut summary.feature_rates);
            steps += ep.infos.len();
        }
        let n = seeds.len().max(1) as f64;
        summary.success_rate = successes as f64 / n;
        summary.drop_rate = drops as f64 / n;
        summary.held_success_rate = held as f64 / n;
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
            tally.add_episode(&episode, &self.shadow.reward_sums(self.collector.env(), &episode));
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
            self.shadow.observe_episode(&features)?;
        }
        Ok(())
    }

    /// Update (and share): the algorithm's updates of one cycle.
    fn update(&mut self, tally: &mut EpochTally) -> Result<(), CoreError> {
        let start = Instant::now();
        let rewards = self.shadow.reward_model(self.collector.env());
        let stats = self.algorithm.update(&rewards).map_err(algo_err)?;
        tally.add_update(&stats, start.elapsed().as_secs_f64());
        Ok(())
    }

    /// `trainer.shadow.max_scale`: no agent's shadow rewards may outweigh its
    /// task rewards by more than that ratio in the first cycle, as the critics
    /// see them: in the sampled batches, HER's relabelled goals included (in
    /// the cycle's episodes when the algorithm does not report its batches).
    /// Every epoch logs both magnitudes in the batches; only the first cycle
    /// stops training, because the task's magnitude falls as the policy
    /// learns (0.1 per step at the training threshold), and a fixed bound
    /// would stop a run for succeeding.
    fn check_shadow_scale(&self, tally: &EpochTally) -> Result<(), CoreError> {
        let max = self.config.shadow.max_scale;
        let names = &self.env().spec().agents;
        let (task_abs, shadow_abs, rows, where_) = if tally.reports_batches {
            (&tally.batch_task_abs, &tally.batch_shadow_abs, 1, "sampled batches")
        } else {
            (&tally.task_abs, &tally.shadow_abs, tally.steps, "episodes")
        };
        for (i, (&task, &shadow)) in task_abs.iter().zip(shadow_abs).enumerate() {
            if shadow > max * task {
                let steps = rows.max(1) as f64;
                return Err(CoreError::InvalidConfig {
                    key: "trainer.shadow.max_scale".into(),
                    reason: format!(
                        "in the first cycle's {where_} agent `{}`'s shadow rewards average {:.3} per step \
                         against {:.3} for the task (ratio {:.2} > {max}): lower trainer.shadow.alpha (now {}) \
                         or raise trainer.shadow.max_scale",
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
        let batch = |v: &[f64]| if tally.reports_batches { per(v, tally.loss_cycles) } else { Vec::new() };
        EpochStats {
            epoch: self.state.epoch,
            success_rate: eval.success_rate,
            train_success_rate: tally.successes as f64 / tally.episodes.max(1) as f64,
            drop_rate: eval.drop_rate,
            held_success_rate: Some(eval.held_success_rate),
            eval_feature_rates: eval.feature_rates,
            train_feature_rates: per(&tally.features, tally.steps),
            returns: per(&tally.returns, tally.episodes),
            task_reward_abs: per(&tally.task_abs, tally.steps),
            shadow_reward_abs: per(&tally.shadow_abs, tally.steps),
            occupancy: self.occupancy().to_vec(),
            critic_loss: per(&tally.critic_loss, tally.loss_cycles),
            actor_loss: per(&tally.actor_loss, tally.loss_cycles),
            batch_task_reward_abs: batch(&tally.batch_task_abs),
            batch_shadow_reward_abs: batch(&tally.batch_shadow_abs),
            q_mean: batch(&tally.q_mean),
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
            self.update(&mut tally)?;
            if self.state.epoch == 0 && cycle == 0 {
                self.check_shadow_scale(&tally)?;
            }
        }
        self.state.updates += tally.updates;
        tally.reduce(self.comm.as_ref());
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
