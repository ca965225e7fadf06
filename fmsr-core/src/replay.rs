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
mod tests {
    use super::*;
    use crate::agent::ActorView;
    use crate::spec::AgentSpec;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    const T: usize = 5;

    fn spec() -> EnvSpec {
        let agent = |n: &str, s: Vec<usize>, d| AgentSpec { name: n.into(), action_slots: s, local_obs_dim: d };
        EnvSpec {
            agents: vec![agent("a", vec![0], 1), agent("b", vec![1, 2], 2)],
            action_dim: 3,
            obs_dim: 2,
            goal_dim: 1,
            episode_len: T,
            features: vec!["f".into()],
            reward_range: (-10.0, 0.0),
        }
    }

    /// Episode `e`: global observation (e, t), achieved goal 10 e + t, desired
    /// goal -1 - e, action (t, e, -t), feature t mod 2.
    fn episode(e: usize) -> Episode {
        let ef = e as f32;
        let obs = |t: usize| Observation {
            global: vec![ef, t as f32],
            locals: vec![vec![t as f32], vec![ef, t as f32]],
            achieved_goal: vec![10.0 * ef + t as f32],
            desired_goal: vec![-1.0 - ef],
        };
        Episode {
            observations: (0..=T).map(obs).collect(),
            actions: (0..T).map(|t| JointAction(vec![t as f32, ef, -(t as f32)])).collect(),
            infos: (0..T).map(|t| StepInfo { features: vec![(t % 2) as f32], ..StepInfo::default() }).collect(),
            log_probs: Vec::new(),
        }
    }

    proptest::proptest! {
        // Guards resuming from the replay log: the last `min(total, capacity)`
        // episodes put back in place give the buffer the uninterrupted run had.
        #[test]
        fn restoring_the_log_rebuilds_the_stored_buffer(capacity in 1usize..6, total in 0usize..15) {
            let spec = spec();
            let mut stored = ReplayBuffer::new(&spec, capacity * T).unwrap();
            (0..total).for_each(|e| stored.store(&episode(e)).unwrap());
            let kept: Vec<Episode> = (total.saturating_sub(capacity)..total).map(episode).collect();
            let mut restored = ReplayBuffer::new(&spec, capacity * T).unwrap();
            restored.restore_log(total as u64, &kept).unwrap();
            proptest::prop_assert_eq!(&restored, &stored);
            restored.store(&episode(99)).unwrap();
            stored.store(&episode(99)).unwrap();
            proptest::prop_assert_eq!(&restored, &stored);
            let mut short = ReplayBuffer::new(&spec, capacity * T).unwrap();
            proptest::prop_assert!(short.restore_log(total as u64 + 1, &kept).is_err() || total >= capacity);
            proptest::prop_assert!(short.restore_log(total as u64, &kept[..kept.len().saturating_sub(1)]).is_err() || kept.is_empty());
        }
    }

    #[test]
    fn her_future_relabels_with_later_achieved_goals_and_recomputed_rewards() {
        let spec = spec();
        let layout = ObservationLayout::new(spec.clone(), vec![vec![1], vec![0]]).unwrap();
        let mut buffer = ReplayBuffer::new(&spec, 100).unwrap();
        for e in 0..4 {
            buffer.store(&episode(e)).unwrap();
        }
        let reward = |a: &[f32], d: &[f32]| -(a[0] - d[0]).abs();
        let agent_rewards = |task: f32, phi: &[f32], out: &mut [f32]| {
            out[0] = task;
            out[1] = task + phi[0];
        };
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let b = buffer.sample(8000, &HerConfig::default(), &layout, &mut rng, &reward, &agent_rewards).unwrap();
        let mut relabelled = 0;
        // counts[t][t']: samples at step t relabelled with the goal achieved at t'.
        let mut counts = [[0usize; T + 1]; T];
        for i in 0..b.size {
            let (e, t) = (b.obs[2 * i] as usize, b.obs[2 * i + 1] as usize);
            assert_eq!(b.next_obs[2 * i + 1] as usize, t + 1);
            let goal = b.goals[i];
            if goal >= 0.0 {
                // a future achieved goal 10 e + t' with t < t' <= T
                let future = goal as usize - 10 * e;
                assert!(future > t && future <= T, "sample ({e}, {t}) relabelled with t' = {future}");
                counts[t][future] += 1;
                relabelled += 1;
            } else {
                assert_eq!(goal, -1.0 - e as f32);
            }
            let achieved_next = 10.0 * e as f32 + (t + 1) as f32;
            assert_eq!(b.task_rewards[i], reward(&[achieved_next], &[goal]));
            assert_eq!(b.rewards[0][i], b.task_rewards[i]);
            assert_eq!(b.rewards[1][i], b.task_rewards[i] + (t % 2) as f32);
            assert_eq!(&b.actions[3 * i..3 * i + 3], &[t as f32, e as f32, -(t as f32)]);
            // agent a: local t, goal, then b's previous action (zeros at t = 0)
            let prev = if t == 0 { [0.0, 0.0] } else { [e as f32, -((t - 1) as f32)] };
            assert_eq!(&b.actor_inputs[0][4 * i..4 * i + 4], &[t as f32, goal, prev[0], prev[1]]);
            assert_eq!(&b.next_actor_inputs[0][4 * i..4 * i + 4], &[(t + 1) as f32, goal, e as f32, -(t as f32)]);
            // agent b: local (e, t), goal, then a's previous action
            let prev_a = if t == 0 { 0.0 } else { (t - 1) as f32 };
            assert_eq!(&b.actor_inputs[1][4 * i..4 * i + 4], &[e as f32, t as f32, goal, prev_a]);
        }
        let frac = relabelled as f64 / b.size as f64;
        assert!((frac - 0.8).abs() < 0.02, "relabelled fraction {frac}");
        // The "future" strategy draws t' uniformly from t+1..=T (HER baselines'
        // `t + 1 + uniform(T - t)`): each count lies within 4.5 standard
        // deviations of its binomial mean, so a draw that favoured the episode's
        // end, or skipped t+1 or T, fails.
        for (t, row) in counts.iter().enumerate() {
            let n: usize = row.iter().sum();
            let p = 1.0 / (T - t) as f64;
            let (mean, sd) = (n as f64 * p, (n as f64 * p * (1.0 - p)).sqrt());
            for (future, &c) in row.iter().enumerate().skip(t + 1) {
                assert!((c as f64 - mean).abs() <= 4.5 * sd.max(1.0), "t = {t}: t' = {future} drawn {c} times of {n}");
            }
        }
    }

    // Guards the normalisers' sample of HER baselines' `store_episode`: the
    // latest episodes only, the newest first after the ring has wrapped.
    #[test]
    fn sampling_the_latest_episodes_draws_only_them() {
        let spec = spec();
        let layout = ObservationLayout::new(spec.clone(), vec![vec![1], vec![0]]).unwrap();
        let mut buffer = ReplayBuffer::new(&spec, 3 * T).unwrap();
        for e in 0..5 {
            buffer.store(&episode(e)).unwrap();
        }
        let reward = |_: &[f32], _: &[f32]| 0.0;
        let agent_rewards = |_: f32, _: &[f32], out: &mut [f32]| out.fill(0.0);
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let her = HerConfig::default();
        for (latest, allowed) in [(1, vec![4]), (2, vec![3, 4]), (3, vec![2, 3, 4])] {
            let b = buffer.sample_latest(latest, 600, &her, &layout, &mut rng, &reward, &agent_rewards).unwrap();
            let seen: std::collections::BTreeSet<usize> = (0..b.size).map(|i| b.obs[2 * i] as usize).collect();
            assert_eq!(seen.into_iter().collect::<Vec<_>>(), allowed, "latest {latest}");
        }
        for latest in [0, 4] {
            assert!(buffer.sample_latest(latest, 1, &her, &layout, &mut rng, &reward, &agent_rewards).is_err());
        }
    }

    // Guards the `global` actor view (an ablation): every actor's
    // sampled input starts with the global observation of its step (its
    // local one under the default view, tested above), then the goal and the
    // neighbours' previous actions.
    #[test]
    fn actors_of_the_global_view_sample_the_global_observation() {
        let spec = spec();
        let layout = ObservationLayout::new(spec.clone(), vec![vec![1], vec![0]]).unwrap().with_view(ActorView::Global);
        assert_eq!((layout.actor_input_dim(0), layout.actor_input_dim(1)), (2 + 1 + 2, 2 + 1 + 1));
        let mut buffer = ReplayBuffer::new(&spec, 100).unwrap();
        for e in 0..4 {
            buffer.store(&episode(e)).unwrap();
        }
        let reward = |a: &[f32], d: &[f32]| -(a[0] - d[0]).abs();
        let agent_rewards = |task: f32, _: &[f32], out: &mut [f32]| out.fill(task);
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let b = buffer.sample(200, &HerConfig::default(), &layout, &mut rng, &reward, &agent_rewards).unwrap();
        for i in 0..b.size {
            let (obs, next) = (&b.obs[2 * i..2 * i + 2], &b.next_obs[2 * i..2 * i + 2]);
            assert_eq!(&b.actor_inputs[0][5 * i..5 * i + 3], &[obs[0], obs[1], b.goals[i]]);
            assert_eq!(&b.next_actor_inputs[0][5 * i..5 * i + 3], &[next[0], next[1], b.goals[i]]);
            assert_eq!(&b.actor_inputs[1][4 * i..4 * i + 3], &[obs[0], obs[1], b.goals[i]]);
        }
        let o = episode(2).observations[3].clone();
        let inputs = layout.actor_inputs(&o, &JointAction(vec![0.5, 0.25, 0.125]));
        assert_eq!(inputs, vec![vec![2.0, 3.0, -3.0, 0.25, 0.125], vec![2.0, 3.0, -3.0, 0.5]]);
    }

    #[test]
    fn overwrites_oldest_when_full_and_checks_shapes() {
        let spec = spec();
        let mut buffer = ReplayBuffer::new(&spec, 2 * T).unwrap();
        assert_eq!(buffer.capacity_episodes(), 2);
        for e in 0..3 {
            buffer.store(&episode(e)).unwrap();
        }
        assert_eq!(buffer.episodes(), 2);
        let layout = ObservationLayout::new(spec.clone(), vec![vec![], vec![]]).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(0);
        let b = buffer.sample(200, &HerConfig { replay_k: 0 }, &layout, &mut rng, &|_, _| 0.0, &|_, _, _| {}).unwrap();
        assert!(b.obs.chunks(2).all(|o| o[0] != 0.0), "episode 0 was overwritten");
        let mut bad = episode(0);
        bad.actions.pop();
        assert!(matches!(buffer.store(&bad), Err(CoreError::EpisodeShape { what: "actions", .. })));
        let empty = ReplayBuffer::new(&spec, 10).unwrap();
        assert!(matches!(
            empty.sample(1, &HerConfig::default(), &layout, &mut rng, &|_, _| 0.0, &|_, _, _| {}),
            Err(CoreError::EmptyReplay)
        ));
    }

    /// Reads a buffer the way learners restore it: postcard, then the consistency check.
    fn decode(bytes: &[u8]) -> Result<ReplayBuffer, String> {
        let buffer: ReplayBuffer = postcard::from_bytes(bytes).map_err(|e| e.to_string())?;
        buffer.check_consistency().map_err(|e| e.to_string())?;
        Ok(buffer)
    }

    // Guards the serde round trip of checkpoints and the consistency check behind it.
    #[test]
    fn serde_round_trip_and_inconsistent_buffers_rejected() {
        let spec = spec();
        let mut buffer = ReplayBuffer::new(&spec, 3 * T).unwrap();
        for e in 0..2 {
            buffer.store(&episode(e)).unwrap();
        }
        let bytes = postcard::to_stdvec(&buffer).unwrap();
        assert_eq!(decode(&bytes).unwrap(), buffer);
        assert!(decode(&bytes[..bytes.len() - 3]).is_err());
        assert!(buffer.is_compatible(&spec));
        let mut short = buffer.clone();
        short.actions.truncate(5);
        assert!(short.check_consistency().is_err());
        let mut huge = buffer;
        huge.len = usize::MAX;
        huge.capacity = usize::MAX;
        assert!(huge.check_consistency().is_err(), "overflowing sizes are errors");
    }

    /// Cases per fuzz property: small in `cargo test`, more with `FMSR_FUZZ_CASES`.
    fn fuzz_cases() -> u32 {
        std::env::var("FMSR_FUZZ_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(256)
    }

    fn valid_bytes() -> Vec<u8> {
        let mut buffer = ReplayBuffer::new(&spec(), 100).unwrap();
        for e in 0..3 {
            buffer.store(&episode(e)).unwrap();
        }
        postcard::to_stdvec(&buffer).unwrap()
    }

    /// A buffer that reads back must also sample without panicking.
    fn read_and_sample(bytes: &[u8]) {
        if let Ok(buffer) = decode(bytes)
            && buffer.is_compatible(&spec())
        {
            let layout = ObservationLayout::new(spec(), vec![vec![1], vec![0]]).unwrap();
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
            let _ = buffer.sample(8, &HerConfig::default(), &layout, &mut rng, &|_, _| 0.0, &|_, _, _| {});
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(fuzz_cases()))]

        // Guards the replay reader of checkpoints (postcard + check_consistency): bit flips,
        // truncations and random bytes give an error or a consistent buffer,
        // never a panic or a huge allocation from a corrupted length field.
        #[test]
        fn corrupted_replay_bytes_never_panic(
            flips in proptest::collection::vec((0usize..10_000, 0u8..8), 1..4),
            cut in proptest::option::of(0usize..10_000),
            noise in proptest::collection::vec(proptest::num::u8::ANY, 0..256),
        ) {
            let good = valid_bytes();
            let mut bytes = good.clone();
            for (at, bit) in flips {
                let i = at % bytes.len();
                bytes[i] ^= 1 << bit;
            }
            if let Some(c) = cut {
                bytes.truncate(c % (good.len() + 1));
            }
            read_and_sample(&bytes);
            let mut random = good[..good.len().min(16)].to_vec();
            random.extend(&noise);
            read_and_sample(&random);
            read_and_sample(&noise);
        }
    }
}
