//! The factory of an experiment: the learner and the trainer that a
//! configuration ([`crate::experiment`], the schema) describes, built on the
//! environments it runs on.

use std::sync::Arc;

use fmsr_core::prelude::*;
use fmsr_nn::{AnyLearner, LearnerParts};

use crate::error::ExperimentError;
use crate::experiment::{ExperimentConfig, device_of};
use crate::tasks::Task;

impl ExperimentConfig {
    /// `n` environments of the task the config names, the Shadow Hand or
    /// a registered task of your own ([`crate::tasks`]), with its settings
    /// ([`ExperimentConfig::task_settings`]).
    ///
    /// # Errors
    /// [`ExperimentError::Config`] for key `task` when it names a task this
    /// process has not registered; the task's own errors.
    pub fn task_envs(&self, n: usize) -> Result<Vec<AnyEnv>, ExperimentError> {
        self.task_settings()?.envs(n)
    }

    /// Task `T`'s settings in this config ([`ExperimentConfig::task_settings`]).
    ///
    /// # Errors
    /// [`ExperimentError::Config`] for key `task` when the config's task is
    /// not `T`.
    pub fn task_config<T: Task>(&self) -> Result<T::Config, ExperimentError>
    where
        T::Config: Clone,
    {
        self.task_settings()?.get::<T>().cloned()
    }

    /// Builds the learner and the trainer on `env`, checking everything that
    /// needs the environment (agents, features, graph, mixing matrix). The
    /// learner is the registered algorithm that `algorithm` names
    /// ([`crate::algorithms`]), with the config's settings for it.
    ///
    /// The task reward is the environment's own: `method` sets it only in the
    /// Shadow Hand config of [`ExperimentConfig::env_config`]. Environments
    /// built otherwise must give the reward `method` names
    /// ([`Method::reward`]), or the run's label names another method than
    /// the one it trained; the generic [`Env`] does not say which it gives,
    /// so this is not checked.
    ///
    /// # Errors
    /// [`ExperimentError`] naming the key of the first setting that does not fit `env`.
    pub fn build_trainer<E: Env + Send>(&self, envs: Vec<E>) -> Result<Trainer<E, AnyLearner>, ExperimentError> {
        self.build_worker_trainer(envs, Arc::new(SingleProcess))
    }

    /// As [`ExperimentConfig::build_trainer`], as one of `comm.workers()`
    /// worker processes of one run (the trainer and the learner share `comm`).
    pub fn build_worker_trainer<E: Env + Send>(
        &self,
        envs: Vec<E>,
        comm: Arc<dyn Communicator>,
    ) -> Result<Trainer<E, AnyLearner>, ExperimentError> {
        let settings = self.algorithm_settings()?;
        self.build_worker_trainer_with(envs, comm, |parts| settings.build(parts))
    }

    /// As [`ExperimentConfig::build_trainer`], with the learner that
    /// `learner` builds from the experiment's parts (layout, networks,
    /// replay, discount, information sharing, device) instead of the one
    /// `algorithm` names: any [`Algorithm`] trains on the experiment's task,
    /// shadow rewards and sharing. (A rule that the configs should name is
    /// registered instead: [`crate::algorithms::register`].)
    ///
    /// # Errors
    /// As [`ExperimentConfig::build_trainer`], and those of `learner`.
    pub fn build_trainer_with<E: Env + Send, A: Algorithm>(
        &self,
        envs: Vec<E>,
        learner: impl FnOnce(LearnerParts) -> Result<A, ExperimentError>,
    ) -> Result<Trainer<E, A>, ExperimentError> {
        self.build_worker_trainer_with(envs, Arc::new(SingleProcess), learner)
    }

    /// [`ExperimentConfig::build_trainer_with`] as one of `comm.workers()` worker processes.
    fn build_worker_trainer_with<E: Env + Send, A: Algorithm>(
        &self,
        envs: Vec<E>,
        comm: Arc<dyn Communicator>,
        learner: impl FnOnce(LearnerParts) -> Result<A, ExperimentError>,
    ) -> Result<Trainer<E, A>, ExperimentError> {
        let spec = envs
            .first()
            .map(|e| e.spec().clone())
            .ok_or_else(|| ExperimentError::config("trainer.envs", "no environment"))?;
        let graph = self.graph.build(&spec)?;
        let layout = ObservationLayout::from_graph(spec.clone(), &graph)
            .map(|l| l.with_view(self.graph.actor_observation))
            .map_err(|source| ExperimentError::Invalid { key: "graph.edges", source })?;
        let trainer_config = self.trainer_config();
        trainer_config
            .shadow
            .agent_rewards(&spec)
            .map_err(|source| ExperimentError::Invalid { key: "trainer.shadow.assignment", source })?;
        let sharing = self
            .sharing_config()
            .build(&graph)
            .map_err(|source| ExperimentError::Invalid { key: "sharing.mixing", source })?;
        let networks = self.networks.clone().with_seed(trainer_config.seed.wrapping_add(self.networks.seed));
        let parts =
            LearnerParts::new(layout.clone(), networks, self.replay, trainer_config.gamma_for(spec.episode_len))
                .with_sharing(sharing)
                .with_communicator(Box::new(comm.clone()))
                .with_device(device_of(self.device)?);
        let learner = learner(parts)?;
        let mut trainer_config = trainer_config;
        if envs.len() != trainer_config.worker_envs(comm.workers())? {
            // fmsr eval runs the test set on one environment.
            trainer_config.envs = Some(envs.len());
        }
        Ok(Trainer::with_envs(trainer_config, envs, learner, layout)?.with_communicator(comm)?)
    }
}
