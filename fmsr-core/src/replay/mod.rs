//! One replay buffer of joint transitions with hindsight experience replay
//! (HER, "future" strategy), shared by all agents (docs/design.md 3.8).
//!
//! Episodes of exactly `T` steps are stored whole. A batch samples `n` pairs
//! `(episode, t)` uniformly; with probability `1 - 1/(1 + k)` the goal of a sample
//! is replaced by the goal achieved at a uniformly chosen later step `t' in [t+1, T]`
//! and its task reward recomputed by [`crate::Env::goal_reward`]. Every agent's
//! update uses the same samples, goals and rewards. When full, the oldest
//! episode is overwritten.

use rand::{Rng, RngExt};
use serde::{Deserialize, Serialize};

use crate::agent::{Batch, ObservationLayout};
use crate::error::CoreError;
use crate::spec::{EnvSpec, JointAction, Observation, StepInfo};

/// Writes every agent's reward for a sample: `(task reward, features phi, out)`.
pub type AgentRewardFn<'a> = dyn Fn(f32, &[f32], &mut [f32]) + 'a;

/// Hindsight relabelling settings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HerConfig {
    /// Relabelled goals per original goal, `k` (default 4, so 80 % of samples are relabelled).
    pub replay_k: usize,
}

impl Default for HerConfig {
    fn default() -> Self {
        Self { replay_k: 4 }
    }
}

impl HerConfig {
    /// Probability that a sample's goal is relabelled, `1 - 1 / (1 + k)`.
    ///
    /// ```
    /// use fmsr_core::replay::HerConfig;
    /// assert_eq!(HerConfig { replay_k: 4 }.future_p(), 0.8);
    /// assert_eq!(HerConfig { replay_k: 0 }.future_p(), 0.0);
    /// ```
    #[must_use]
    pub fn future_p(&self) -> f64 {
        1.0 - 1.0 / (1.0 + self.replay_k as f64)
    }
}

/// The replay storage and update schedule of the off-policy algorithms
/// (defaults: HER baselines' and the paper's, docs/design.md 3.10).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ReplayConfig {
    /// Replay capacity in transitions (1e6).
    pub buffer_size: usize,
    /// Samples per gradient step over all worker processes (256, HER baselines'
    /// one-CPU setting; the paper's 4 MPI workers x 256 = 1024): each of `N`
    /// workers samples `batch_size / N` and their gradients are averaged, so a
    /// config means the same experiment on any number of workers.
    pub batch_size: usize,
    /// Gradient steps per training cycle (paper: 25).
    pub batches: usize,
    /// Hindsight relabelling.
    pub her: HerConfig,
}

impl Default for ReplayConfig {
    fn default() -> Self {
        Self { buffer_size: 1_000_000, batch_size: 256, batches: 25, her: HerConfig::default() }
    }
}

impl ReplayConfig {
    /// The samples one of `workers` worker processes draws per gradient step.
    ///
    /// ```
    /// use fmsr_core::replay::ReplayConfig;
    /// let paper = ReplayConfig { batch_size: 1024, ..ReplayConfig::default() };
    /// assert_eq!(paper.worker_batch(4).unwrap(), 256);
    /// assert!(paper.worker_batch(3).is_err());
    /// ```
    ///
    /// # Errors
    /// [`CoreError::InvalidConfig`] (key `replay.batch_size`) unless `workers` divides it.
    pub fn worker_batch(&self, workers: usize) -> Result<usize, CoreError> {
        per_worker("replay.batch_size", self.batch_size, workers)
    }

    /// Checks every value, naming the key of the first impossible one.
    ///
    /// ```
    /// use fmsr_core::replay::ReplayConfig;
    /// assert!(ReplayConfig::default().validate().is_ok());
    /// assert!(ReplayConfig { batch_size: 0, ..ReplayConfig::default() }.validate().is_err());
    /// ```
    pub fn validate(&self) -> Result<(), CoreError> {
        for (key, v) in [("replay.buffer_size", self.buffer_size), ("replay.batch_size", self.batch_size)] {
            if v == 0 {
                return Err(CoreError::InvalidConfig { key: key.into(), reason: "must be at least 1".into() });
            }
        }
        Ok(())
    }
}

/// `total / workers`, when `workers` divides `total` into nonzero parts.
pub(crate) fn per_worker(key: &str, total: usize, workers: usize) -> Result<usize, CoreError> {
    if workers == 0 || !total.is_multiple_of(workers) || total < workers {
        return Err(CoreError::InvalidConfig {
            key: key.into(),
            reason: format!("{total} is the total over all worker processes and must split evenly over {workers}"),
        });
    }
    Ok(total / workers)
}

/// One recorded episode: `T + 1` observations, `T` joint actions and `T` step infos.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct Episode {
    /// Observations `o_0 .. o_T`.
    pub observations: Vec<Observation>,
    /// Joint actions `a_0 .. a_{T-1}`.
    pub actions: Vec<JointAction>,
    /// Infos of the steps (features `phi(s_t, a_t)`, success, drop).
    pub infos: Vec<StepInfo>,
    /// `log pi_i(a_i | o_i)` of every agent at every step, when the policy
    /// reports them (stochastic policies); empty otherwise.
    #[serde(default)]
    pub log_probs: Vec<Vec<f32>>,
}

impl Episode {
    /// An empty episode with room for `steps` steps.
    #[must_use]
    pub fn with_capacity(steps: usize) -> Self {
        Self {
            observations: Vec::with_capacity(steps + 1),
            actions: Vec::with_capacity(steps),
            infos: Vec::with_capacity(steps),
            log_probs: Vec::new(),
        }
    }

    /// The feature trajectory `phi(s_t, a_t)`, `t = 0 .. T-1`.
    #[must_use]
    pub fn features(&self) -> Vec<Vec<f32>> {
        self.infos.iter().map(|i| i.features.clone()).collect()
    }
}

/// The shared replay buffer of joint transitions.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ReplayBuffer {
    obs_dim: usize,
    goal_dim: usize,
    action_dim: usize,
    local_dims: Vec<usize>,
    num_features: usize,
    horizon: usize,
    capacity: usize,
    len: usize,
    next: usize,
    global: Vec<f32>,
    locals: Vec<Vec<f32>>,
    achieved: Vec<f32>,
    desired: Vec<f32>,
    actions: Vec<f32>,
    features: Vec<f32>,
}

impl ReplayBuffer {
    /// A buffer for episodes of `spec` holding at least `capacity_transitions`
    /// transitions (rounded up to whole episodes). Memory grows as episodes arrive.
    pub fn new(spec: &EnvSpec, capacity_transitions: usize) -> Result<Self, CoreError> {
        spec.validate()?;
        if capacity_transitions == 0 {
            return Err(CoreError::InvalidConfig { key: "buffer_size".into(), reason: "must be at least 1".into() });
        }
        Ok(Self {
            obs_dim: spec.obs_dim,
            goal_dim: spec.goal_dim,
            action_dim: spec.action_dim,
            local_dims: spec.agents.iter().map(|a| a.local_obs_dim).collect(),
            num_features: spec.features.len(),
            horizon: spec.episode_len,
            capacity: capacity_transitions.div_ceil(spec.episode_len),
            len: 0,
            next: 0,
            global: Vec::new(),
            locals: vec![Vec::new(); spec.agents.len()],
            achieved: Vec::new(),
            desired: Vec::new(),
            actions: Vec::new(),
            features: Vec::new(),
        })
    }

    /// Number of episodes stored.
    #[must_use]
    pub fn episodes(&self) -> usize {
        self.len
    }

    /// Number of transitions stored.
    #[must_use]
    pub fn transitions(&self) -> usize {
        self.len * self.horizon
    }

    /// Capacity in episodes.
    #[must_use]
    pub fn capacity_episodes(&self) -> usize {
        self.capacity
    }

    /// The bytes the stored episodes take once the buffer is full (it grows to
    /// this as episodes arrive): per episode `T + 1` global and local
    /// observations and achieved goals, one desired goal, `T` actions and
    /// feature vectors, as `f32`.
    ///
    /// ```
    /// use fmsr_core::replay::ReplayBuffer;
    /// use fmsr_core::spec::{AgentSpec, EnvSpec};
    /// let spec = EnvSpec {
    ///     obs_dim: 4, goal_dim: 2, action_dim: 1, episode_len: 10,
    ///     agents: vec![AgentSpec { name: "a".into(), action_slots: vec![0], local_obs_dim: 3 }],
    ///     features: vec![], reward_range: (-1.0, 0.0),
    /// };
    /// let buffer = ReplayBuffer::new(&spec, 100).unwrap();
    /// // 10 episodes of 11 x (4 + 3 + 2) + 2 + 10 x 1 floats.
    /// assert_eq!(buffer.bytes_at_capacity(), 10 * (11 * 9 + 2 + 10) * 4);
    /// ```
    #[must_use]
    pub fn bytes_at_capacity(&self) -> u64 {
        let t = self.horizon;
        let per_step = self.obs_dim + self.local_dims.iter().sum::<usize>() + self.goal_dim;
        let floats = (t + 1) * per_step + self.goal_dim + t * (self.action_dim + self.num_features);
        self.capacity as u64 * floats as u64 * std::mem::size_of::<f32>() as u64
    }

    /// Stores one episode, overwriting the oldest when full.
    pub fn store(&mut self, episode: &Episode) -> Result<(), CoreError> {
        self.check_shape(episode)?;
        self.write_slot(self.next, episode);
        self.next = (self.next + 1) % self.capacity;
        self.len = (self.len + 1).min(self.capacity);
        Ok(())
    }

    /// Puts the buffer in the state it had after `total` episodes were stored,
    /// given the last `min(total, capacity)` of them in store order (what a
    /// replay log keeps): every episode lands in the slot it had, so sampling
    /// continues exactly as before.
    ///
    /// # Errors
    /// [`CoreError::InvalidConfig`] (key `replay log`) when the number of
    /// episodes is not `min(total, capacity)`; [`CoreError::EpisodeShape`] for an
    /// episode of another shape. The buffer is unchanged on error.
    pub fn restore_log(&mut self, total: u64, episodes: &[Episode]) -> Result<(), CoreError> {
        let kept = usize::try_from(total).map_or(self.capacity, |t| t.min(self.capacity));
        if episodes.len() != kept {
            return Err(CoreError::InvalidConfig {
                key: "replay log".into(),
                reason: format!("{} episodes for {total} stored into {} slots", episodes.len(), self.capacity),
            });
        }
        episodes.iter().try_for_each(|e| self.check_shape(e))?;
        let capacity = self.capacity as u64;
        let first = total - kept as u64;
        for (k, episode) in episodes.iter().enumerate() {
            self.write_slot(((first + k as u64) % capacity) as usize, episode);
        }
        self.next = (total % capacity) as usize;
        self.len = kept;
        Ok(())
    }

    fn check_shape(&self, episode: &Episode) -> Result<(), CoreError> {
        let t = self.horizon;
        let shape = |what, expected, found| {
            if expected == found { Ok(()) } else { Err(CoreError::EpisodeShape { what, expected, found }) }
        };
        shape("observations", t + 1, episode.observations.len())?;
        shape("actions", t, episode.actions.len())?;
        shape("step infos", t, episode.infos.len())?;
        for o in &episode.observations {
            shape("global observation values", self.obs_dim, o.global.len())?;
            shape("achieved goal values", self.goal_dim, o.achieved_goal.len())?;
            shape("local observations", self.local_dims.len(), o.locals.len())?;
            for (l, &d) in o.locals.iter().zip(&self.local_dims) {
                shape("local observation values", d, l.len())?;
            }
        }
        shape("desired goal values", self.goal_dim, episode.observations[0].desired_goal.len())?;
        for a in &episode.actions {
            shape("joint action values", self.action_dim, a.0.len())?;
        }
        for i in &episode.infos {
            shape("feature values", self.num_features, i.features.len())?;
        }
        Ok(())
    }

    /// Writes a checked episode into `slot`.
    fn write_slot(&mut self, slot: usize, episode: &Episode) {
        let t = self.horizon;
        let write = |dst: &mut Vec<f32>, per_episode: usize, src: &mut dyn Iterator<Item = &f32>| {
            let start = slot * per_episode;
            if dst.len() < start + per_episode {
                dst.resize(start + per_episode, 0.0);
            }
            for (d, s) in dst[start..start + per_episode].iter_mut().zip(src) {
                *d = *s;
            }
        };
        write(&mut self.global, (t + 1) * self.obs_dim, &mut episode.observations.iter().flat_map(|o| o.global.iter()));
        for (a, &d) in self.local_dims.iter().enumerate() {
            write(&mut self.locals[a], (t + 1) * d, &mut episode.observations.iter().flat_map(|o| o.locals[a].iter()));
        }
        write(
            &mut self.achieved,
            (t + 1) * self.goal_dim,
            &mut episode.observations.iter().flat_map(|o| o.achieved_goal.iter()),
        );
        write(&mut self.desired, self.goal_dim, &mut episode.observations[0].desired_goal.iter());
        write(&mut self.actions, t * self.action_dim, &mut episode.actions.iter().flat_map(|a| a.0.iter()));
        write(&mut self.features, t * self.num_features, &mut episode.infos.iter().flat_map(|i| i.features.iter()));
    }

    fn achieved_at(&self, ep: usize, t: usize) -> &[f32] {
        let start = (ep * (self.horizon + 1) + t) * self.goal_dim;
        &self.achieved[start..start + self.goal_dim]
    }

    /// Samples a batch of `n` joint transitions with HER relabelling.
    ///
    /// `goal_reward(achieved, desired)` recomputes the task reward (normally
    /// [`crate::Env::goal_reward`]); `agent_rewards(task, phi, out)` writes every
    /// agent's reward (e.g. [`crate::shadow::AgentRewards::compute`] with the
    /// current occupancy).
    pub fn sample<R: Rng + ?Sized>(
        &self,
        n: usize,
        her: &HerConfig,
        layout: &ObservationLayout,
        rng: &mut R,
        goal_reward: &dyn Fn(&[f32], &[f32]) -> f32,
        agent_rewards: &AgentRewardFn<'_>,
    ) -> Result<Batch, CoreError> {
        self.sample_among(self.len, n, her, layout, rng, goal_reward, agent_rewards)
    }

    /// As [`ReplayBuffer::sample`], the episodes drawn from the `latest` most
    /// recently stored ones only: HER baselines' `store_episode` samples the
    /// transitions of the episodes it just stored this way, relabelled, to
    /// update the input normalisers.
    ///
    /// # Errors
    /// As [`ReplayBuffer::sample`]; [`CoreError::InvalidConfig`] when `latest`
    /// is 0 or more than the episodes stored.
    #[allow(clippy::too_many_arguments)]
    pub fn sample_latest<R: Rng + ?Sized>(
        &self,
        latest: usize,
        n: usize,
        her: &HerConfig,
        layout: &ObservationLayout,
        rng: &mut R,
        goal_reward: &dyn Fn(&[f32], &[f32]) -> f32,
        agent_rewards: &AgentRewardFn<'_>,
    ) -> Result<Batch, CoreError> {
        if latest == 0 || latest > self.len {
            return Err(CoreError::InvalidConfig {
                key: "latest episodes".into(),
                reason: format!("{latest} asked, {} stored (need 1 to all of them)", self.len),
            });
        }
        self.sample_among(latest, n, her, layout, rng, goal_reward, agent_rewards)
    }

    /// Samples from the `latest` most recently stored episodes (`self.len`:
    /// all of them, the slots in any order, as [`ReplayBuffer::sample`] has
    /// always drawn them).
    #[allow(clippy::too_many_arguments)]
    fn sample_among<R: Rng + ?Sized>(
        &self,
        latest: usize,
        n: usize,
        her: &HerConfig,
        layout: &ObservationLayout,
        rng: &mut R,
        goal_reward: &dyn Fn(&[f32], &[f32]) -> f32,
        agent_rewards: &AgentRewardFn<'_>,
    ) -> Result<Batch, CoreError> {
        if self.len == 0 {
            return Err(CoreError::EmptyReplay);
        }
        let spec = layout.spec();
        if spec.obs_dim != self.obs_dim
            || spec.action_dim != self.action_dim
            || spec.agents.len() != self.local_dims.len()
        {
            return Err(CoreError::Dimension {
                what: "layout vs replay observation",
                expected: self.obs_dim,
                found: spec.obs_dim,
            });
        }
        let (t_max, od, gd, ad, k) = (self.horizon, self.obs_dim, self.goal_dim, self.action_dim, self.num_features);
        let agents = self.local_dims.len();
        let future_p = her.future_p();
        let mut b = Batch {
            size: n,
            obs: Vec::with_capacity(n * od),
            next_obs: Vec::with_capacity(n * od),
            goals: Vec::with_capacity(n * gd),
            actions: Vec::with_capacity(n * ad),
            actor_inputs: (0..agents).map(|i| Vec::with_capacity(n * layout.actor_input_dim(i))).collect(),
            next_actor_inputs: (0..agents).map(|i| Vec::with_capacity(n * layout.actor_input_dim(i))).collect(),
            task_rewards: Vec::with_capacity(n),
            features: Vec::with_capacity(n * k),
            rewards: vec![Vec::with_capacity(n); agents],
        };
        let zeros = vec![0.0f32; ad];
        let mut out = vec![0.0f32; agents];
        for _ in 0..n {
            let ep = if latest == self.len {
                rng.random_range(0..self.len)
            } else {
                // The slot written `back + 1` stores ago.
                let back = rng.random_range(0..latest);
                (self.next + self.capacity - 1 - back) % self.capacity
            };
            let t = rng.random_range(0..t_max);
            let goal: &[f32] = if rng.random::<f64>() < future_p {
                let future = t + 1 + rng.random_range(0..t_max - t);
                self.achieved_at(ep, future)
            } else {
                &self.desired[ep * gd..(ep + 1) * gd]
            };
            let row = |t: usize| (ep * (t_max + 1) + t) * od;
            b.obs.extend_from_slice(&self.global[row(t)..row(t) + od]);
            b.next_obs.extend_from_slice(&self.global[row(t + 1)..row(t + 1) + od]);
            let act = |t: usize| &self.actions[(ep * t_max + t) * ad..(ep * t_max + t + 1) * ad];
            let action = act(t);
            let prev = if t == 0 { &zeros[..] } else { act(t - 1) };
            b.actions.extend_from_slice(action);
            for (a, &d) in self.local_dims.iter().enumerate() {
                let lrow = |t: usize| (ep * (t_max + 1) + t) * d;
                let local = &self.locals[a][lrow(t)..lrow(t) + d];
                let next_local = &self.locals[a][lrow(t + 1)..lrow(t + 1) + d];
                let (global, next_global) =
                    (&self.global[row(t)..row(t) + od], &self.global[row(t + 1)..row(t + 1) + od]);
                layout.push_actor_input(a, local, global, goal, prev, &mut b.actor_inputs[a]);
                layout.push_actor_input(a, next_local, next_global, goal, action, &mut b.next_actor_inputs[a]);
            }
            let task = goal_reward(self.achieved_at(ep, t + 1), goal);
            let phi = &self.features[(ep * t_max + t) * k..(ep * t_max + t + 1) * k];
            agent_rewards(task, phi, &mut out);
            for (r, o) in b.rewards.iter_mut().zip(&out) {
                r.push(*o);
            }
            b.task_rewards.push(task);
            b.features.extend_from_slice(phi);
            b.goals.extend_from_slice(goal);
        }
        Ok(b)
    }
}

impl ReplayBuffer {
    /// Checks that the stored arrays are as long as the counters say, so that
    /// sampling can never index out of bounds (for buffers read back from a
    /// checkpoint; overflowing sizes are errors too).
    ///
    /// # Errors
    /// [`CoreError::InvalidConfig`] (key `replay buffer`) naming what is inconsistent.
    pub fn check_consistency(&self) -> Result<(), CoreError> {
        let bad = |reason: String| Err(CoreError::InvalidConfig { key: "replay buffer".into(), reason });
        if self.capacity == 0 || self.horizon == 0 || self.len > self.capacity || self.next >= self.capacity {
            return bad(format!(
                "counters out of range (capacity {}, horizon {}, len {}, next {})",
                self.capacity, self.horizon, self.len, self.next
            ));
        }
        if self.local_dims.len() != self.locals.len() {
            return bad("agents of the local observations differ".into());
        }
        let need = |steps: usize, dim: usize| self.len.checked_mul(steps).and_then(|v| v.checked_mul(dim));
        let arrays = [
            ("global observations", self.global.len(), need(self.horizon + 1, self.obs_dim)),
            ("achieved goals", self.achieved.len(), need(self.horizon + 1, self.goal_dim)),
            ("desired goals", self.desired.len(), need(1, self.goal_dim)),
            ("actions", self.actions.len(), need(self.horizon, self.action_dim)),
            ("features", self.features.len(), need(self.horizon, self.num_features)),
        ];
        let locals = self
            .locals
            .iter()
            .zip(&self.local_dims)
            .map(|(l, &d)| ("local observations", l.len(), need(self.horizon + 1, d)));
        for (what, found, expected) in arrays.into_iter().chain(locals) {
            match expected {
                Some(e) if found >= e => {}
                _ => return bad(format!("{what}: {found} values, the counters need {expected:?}")),
            }
        }
        Ok(())
    }

    /// Whether this buffer holds episodes of `spec`'s shape.
    #[must_use]
    pub fn is_compatible(&self, spec: &EnvSpec) -> bool {
        self.obs_dim == spec.obs_dim
            && self.goal_dim == spec.goal_dim
            && self.action_dim == spec.action_dim
            && self.num_features == spec.features.len()
            && self.horizon == spec.episode_len
            && self.local_dims.iter().eq(spec.agents.iter().map(|a| &a.local_obs_dim))
    }
}

#[cfg(test)]
mod tests;
