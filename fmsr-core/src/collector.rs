//! The collector: runs episodes of an [`Env`] with a [`Policy`] and records
//! them (observations, actions, the stability features `phi(s_t, a_t)` of each
//! step). What the features become, occupancy estimates (eq. 1) and each
//! agent's shadow reward (eqs. 7, 11-15), is [`crate::shadow`]'s job.
//!
//! **Vectorised rollouts.** [`Collector::rollouts`] runs a list of seeded
//! episodes on the collector's environments in lockstep: at every step one
//! batched call of the policy acts for all running environments, which then
//! step in parallel on a thread pool ([`Collector::with_threads`]). Each
//! environment's step depends only on its own state, and episodes come back in
//! the order of their seeds, so the result does not depend on the number of
//! threads; it does depend on the number of environments (the policy's
//! exploration noise is drawn per batch row).
//!
//! ```
//! use fmsr_core::prelude::*;
//! use fmsr_core::collector::Collector;
//! # use fmsr_core::spec::{AgentSpec, StepOutcome};
//! # #[derive(Debug)] struct Line { spec: EnvSpec, x: f32 }
//! # impl Env for Line {
//! #     type Error = std::io::Error;
//! #     fn spec(&self) -> &EnvSpec { &self.spec }
//! #     fn reset(&mut self, _seed: u64) -> Result<Observation, Self::Error> { self.x = 0.0; Ok(self.obs()) }
//! #     fn step(&mut self, a: &JointAction) -> Result<StepOutcome, Self::Error> {
//! #         self.x += 0.1 * a.0[0];
//! #         let info = StepInfo { features: vec![f32::from(self.x > 0.0)], ..StepInfo::default() };
//! #         Ok(StepOutcome { observation: self.obs(), reward: -self.x.abs(), terminated: false, truncated: false, info })
//! #     }
//! #     fn goal_distance(&self, a: &[f32], d: &[f32]) -> f32 { (a[0] - d[0]).abs() }
//! #     fn goal_reward(&self, a: &[f32], d: &[f32]) -> f32 { -self.goal_distance(a, d) }
//! # }
//! # impl Line { fn obs(&self) -> Observation { Observation { global: vec![self.x], locals: vec![vec![self.x]],
//! #     achieved_goal: vec![self.x], desired_goal: vec![1.0] } } }
//! # let spec = EnvSpec { agents: vec![AgentSpec { name: "a".into(), action_slots: vec![0], local_obs_dim: 1 }],
//! #     action_dim: 1, obs_dim: 1, goal_dim: 1, episode_len: 4, features: vec!["right".into()], reward_range: (-1.0, 0.0) };
//! # let env = Line { spec: spec.clone(), x: 0.0 };
//! /// Always pushes right.
//! struct Right;
//! impl Policy for Right {
//!     type Error = std::convert::Infallible;
//!     fn num_agents(&self) -> usize { 1 }
//!     fn act(&mut self, _: &[Vec<f32>], n: usize, _: ActMode) -> Result<PolicyOutput, Self::Error> {
//!         Ok(PolicyOutput::actions(vec![vec![1.0; n]]))
//!     }
//! }
//! let layout = ObservationLayout::new(spec.clone(), vec![vec![]])?;
//! let mut collector = Collector::new(env, layout)?;
//! let episode = collector.rollout(&mut Right, 7, ActMode::Explore, &mut |_, _| {})?;
//! // The feature is on at every step, and 4 steps were run.
//! assert!(episode.features().iter().all(|phi| phi[0] == 1.0));
//! assert_eq!(collector.env_steps(), 4);
//! # Ok::<(), CoreError>(())
//! ```

use rayon::prelude::*;

use crate::agent::ObservationLayout;
use crate::env::Env;
use crate::error::CoreError;
use crate::policy::{ActMode, Policy};
use crate::replay::Episode;
use crate::spec::{JointAction, Observation, StepOutcome};

fn env_err<E: std::error::Error + Send + Sync + 'static>(e: E) -> CoreError {
    CoreError::Env(Box::new(e))
}

/// Runs episodes; see the [module docs](self).
#[derive(Debug)]
pub struct Collector<E> {
    /// At least one environment; [`Collector::rollouts`] uses all of them.
    envs: Vec<E>,
    /// Threads stepping the environments (`None`: on the calling thread).
    pool: Option<rayon::ThreadPool>,
    layout: ObservationLayout,
    env_steps: u64,
}

impl<E: Env> Collector<E> {
    /// A collector of `env` whose policies see actor inputs laid out by `layout`.
    ///
    /// # Errors
    /// [`CoreError`] when the layout does not fit `env`'s spec.
    pub fn new(env: E, layout: ObservationLayout) -> Result<Self, CoreError> {
        Self::with_envs(vec![env], layout)
    }

    /// A collector of several copies of one environment (all with the same
    /// spec), for [`Collector::rollouts`].
    ///
    /// # Errors
    /// [`CoreError`] when `envs` is empty, their specs differ, or the layout
    /// does not fit the spec.
    pub fn with_envs(envs: Vec<E>, layout: ObservationLayout) -> Result<Self, CoreError> {
        let Some(first) = envs.first() else {
            return Err(CoreError::InvalidConfig { key: "trainer.envs".into(), reason: "must be at least 1".into() });
        };
        if envs.iter().any(|e| e.spec() != first.spec()) {
            return Err(CoreError::InvalidConfig {
                key: "trainer.envs".into(),
                reason: "the environments do not share one spec".into(),
            });
        }
        let spec = first.spec();
        spec.validate()?;
        if layout.spec() != spec {
            return Err(CoreError::InvalidConfig {
                key: "layout".into(),
                reason: "the observation layout was built for another environment spec".into(),
            });
        }
        Ok(Self { envs, pool: None, layout, env_steps: 0 })
    }

    /// Steps the environments on `threads` threads, at most one per
    /// environment (1: on the calling thread).
    ///
    /// # Errors
    /// [`CoreError::InvalidConfig`] for 0 threads or a pool that cannot start.
    pub fn with_threads(mut self, threads: usize) -> Result<Self, CoreError> {
        let bad = |reason: String| CoreError::InvalidConfig { key: "trainer.threads".into(), reason };
        self.pool = match threads.min(self.envs.len()) {
            0 => return Err(bad("must be at least 1".into())),
            1 => None,
            n => Some(
                rayon::ThreadPoolBuilder::new()
                    .num_threads(n)
                    .thread_name(|k| format!("fmsr-env-{k}"))
                    .build()
                    .map_err(|e| bad(e.to_string()))?,
            ),
        };
        Ok(self)
    }

    /// Number of environments.
    #[must_use]
    pub fn num_envs(&self) -> usize {
        self.envs.len()
    }

    /// Threads stepping the environments (1: on the calling thread).
    #[must_use]
    pub fn threads(&self) -> usize {
        self.pool.as_ref().map_or(1, rayon::ThreadPool::current_num_threads)
    }

    /// The (first) environment.
    #[must_use]
    pub fn env(&self) -> &E {
        &self.envs[0]
    }

    /// The (first) environment, mutably.
    pub fn env_mut(&mut self) -> &mut E {
        &mut self.envs[0]
    }

    /// How actor inputs are assembled.
    #[must_use]
    pub fn layout(&self) -> &ObservationLayout {
        &self.layout
    }

    /// Environment steps run so far.
    #[must_use]
    pub fn env_steps(&self) -> u64 {
        self.env_steps
    }

    /// Restores the step counter of a checkpoint.
    pub(crate) fn restore(&mut self, env_steps: u64) {
        self.env_steps = env_steps;
    }
}

impl<E: Env + Send> Collector<E> {
    /// Runs one episode per seed, in lockstep on the environments (chunks of
    /// [`Collector::num_envs`] seeds); returns the episodes in seed order. See
    /// the [module docs](self).
    ///
    /// # Errors
    /// Errors of the environments or the policy, and outputs of the wrong shape.
    pub fn rollouts<P: Policy>(
        &mut self,
        policy: &mut P,
        seeds: &[u64],
        mode: ActMode,
    ) -> Result<Vec<Episode>, CoreError> {
        let spec = self.envs[0].spec().clone();
        check_policy(policy, &spec)?;
        let mut episodes = Vec::with_capacity(seeds.len());
        for chunk in seeds.chunks(self.envs.len()) {
            episodes.extend(self.lockstep(policy, chunk, mode, &mut |_, _| {})?);
        }
        Ok(episodes)
    }

    /// Runs one episode from `seed`, acting with `policy` in `mode`, and calls
    /// `on_step(env, outcome)` after every step (e.g. to read contacts).
    ///
    /// # Errors
    /// Errors of the environment or the policy, and observations or features
    /// of the wrong shape.
    pub fn rollout<P: Policy>(
        &mut self,
        policy: &mut P,
        seed: u64,
        mode: ActMode,
        on_step: &mut dyn FnMut(&E, &StepOutcome),
    ) -> Result<Episode, CoreError> {
        check_policy(policy, self.envs[0].spec())?;
        let mut episodes = self.lockstep(policy, &[seed], mode, on_step)?;
        episodes.pop().ok_or(CoreError::Dimension { what: "episodes", expected: 1, found: 0 })
    }

    /// One episode on each of the first `seeds.len()` environments, calling
    /// `on_step(env, outcome)` after every step of every environment.
    fn lockstep<P: Policy>(
        &mut self,
        policy: &mut P,
        seeds: &[u64],
        mode: ActMode,
        on_step: &mut dyn FnMut(&E, &StepOutcome),
    ) -> Result<Vec<Episode>, CoreError> {
        let spec = self.envs[0].spec().clone();
        let k = seeds.len();
        let mut obs = self.map_envs(k, |env, e| env.reset(seeds[e]))?;
        for o in &obs {
            o.validate(&spec)?;
        }
        let mut prev = vec![JointAction::zeros(spec.action_dim); k];
        let mut episodes: Vec<Episode> = (0..k).map(|_| Episode::with_capacity(spec.episode_len)).collect();
        for _ in 0..spec.episode_len {
            let inputs = self.batched_inputs(&obs, &prev);
            let out = policy.act(&inputs, k, mode).map_err(|e| CoreError::Algorithm(Box::new(e)))?;
            let joints = (0..k)
                .map(|e| JointAction::from_agents(&spec.agents, &row(&out.actions, e, k)))
                .collect::<Result<Vec<_>, _>>()?;
            let outcomes = self.map_envs(k, |env, e| env.step(&joints[e]))?;
            for (e, (outcome, joint)) in outcomes.into_iter().zip(joints).enumerate() {
                check_outcome(&outcome, &spec)?;
                on_step(&self.envs[e], &outcome);
                let episode = &mut episodes[e];
                if !out.log_probs.is_empty() {
                    episode.log_probs.push(out.log_probs.iter().map(|l| l.get(e).copied().unwrap_or(0.0)).collect());
                }
                episode.observations.push(std::mem::replace(&mut obs[e], outcome.observation));
                episode.actions.push(joint.clone());
                episode.infos.push(outcome.info);
                prev[e] = joint;
            }
        }
        for (episode, o) in episodes.iter_mut().zip(obs) {
            episode.observations.push(o);
        }
        self.env_steps += (k * spec.episode_len) as u64;
        Ok(episodes)
    }

    /// Each agent's actor inputs of every environment, one row per environment.
    fn batched_inputs(&self, obs: &[Observation], prev: &[JointAction]) -> Vec<Vec<f32>> {
        let agents = self.layout.spec().agents.len();
        (0..agents)
            .map(|i| {
                let mut rows = Vec::with_capacity(obs.len() * self.layout.actor_input_dim(i));
                for (o, p) in obs.iter().zip(prev) {
                    self.layout.push_actor_input(i, &o.locals[i], &o.global, &o.desired_goal, &p.0, &mut rows);
                }
                rows
            })
            .collect()
    }

    /// `f(env_e, e)` for the first `k` environments, on the pool when there is one.
    fn map_envs<T: Send>(
        &mut self,
        k: usize,
        f: impl Fn(&mut E, usize) -> Result<T, E::Error> + Sync,
    ) -> Result<Vec<T>, CoreError> {
        let envs = &mut self.envs[..k];
        let results: Vec<Result<T, E::Error>> = match &self.pool {
            // One environment (a single rollout) stays on the calling thread.
            Some(pool) if k > 1 => pool.install(|| envs.par_iter_mut().enumerate().map(|(e, env)| f(env, e)).collect()),
            _ => envs.iter_mut().enumerate().map(|(e, env)| f(env, e)).collect(),
        };
        results.into_iter().map(|r| r.map_err(env_err)).collect()
    }
}

/// Row `e` of every agent's `k`-row output.
fn row(actions: &[Vec<f32>], e: usize, k: usize) -> Vec<Vec<f32>> {
    actions
        .iter()
        .map(|a| {
            let d = a.len() / k.max(1);
            a[e * d..(e + 1) * d].to_vec()
        })
        .collect()
}

fn check_policy<P: Policy>(policy: &P, spec: &crate::spec::EnvSpec) -> Result<(), CoreError> {
    if policy.num_agents() != spec.agents.len() {
        return Err(CoreError::Dimension {
            what: "policy agents",
            expected: spec.agents.len(),
            found: policy.num_agents(),
        });
    }
    Ok(())
}

fn check_outcome(outcome: &StepOutcome, spec: &crate::spec::EnvSpec) -> Result<(), CoreError> {
    outcome.observation.validate(spec)?;
    if outcome.info.features.len() != spec.features.len() {
        return Err(CoreError::Dimension {
            what: "step features",
            expected: spec.features.len(),
            found: outcome.info.features.len(),
        });
    }
    Ok(())
}
