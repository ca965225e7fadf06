//! The loop's settings ([`TrainerConfig`]): budget, seed, discount and shadow rewards.

use serde::{Deserialize, Serialize};

use crate::error::CoreError;
use crate::shadow::ShadowConfig;

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
    /// Threads that step the environments (at most one per environment);
    /// `None` is the number of cores. The history does not depend on it.
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
        self.shadow.validate()
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
