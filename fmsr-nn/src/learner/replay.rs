//! The learner's storage: the HER replay buffer, its sampling with every
//! agent's reward from the [`RewardModel`], and the batches it uploads to the
//! device.

use burn::tensor::{Tensor, TensorData};
use fmsr_core::RewardModel;
use fmsr_core::agent::Batch;
use fmsr_core::replay::{Episode, ReplayBuffer};

use crate::config::NormalizerStats;
use crate::error::{NnError, check_values};
use crate::group::GroupBatch;

use super::{Learner, matrix};

/// A sampled batch on the device: normalised inputs, joint actions in
/// agent-major column order, and each group's share; what an update rule's
/// step hands to the learner's steps.
#[derive(Clone)]
pub struct BatchTensors {
    pub(crate) n: usize,
    /// `[x, g]` normalised, `n x (obs + goal)`.
    pub(crate) og: Tensor<2>,
    /// `[x', g]` normalised.
    pub(crate) og_next: Tensor<2>,
    /// `a_1 .. a_N` agent-major, `n x action_dim`.
    pub(crate) actions: Tensor<2>,
    /// Each group's inputs, rewards and bounds.
    pub(crate) groups: Vec<GroupBatch>,
}

impl BatchTensors {
    /// The batch's rows.
    #[must_use]
    pub fn rows(&self) -> usize {
        self.n
    }
}

impl Learner {
    /// Stores an episode in the replay buffer; with
    /// [`NormalizerStats::StoredEpisodes`], adds `T` of its transitions,
    /// sampled with HER relabelling, to the input normalisers.
    pub(crate) fn store(&mut self, episode: &Episode) -> Result<(), NnError> {
        let replay_err = |e: fmsr_core::CoreError| NnError::Replay { reason: e.to_string() };
        self.replay.store(episode).map_err(replay_err)?;
        if self.net.normalizer_stats != NormalizerStats::StoredEpisodes {
            return Ok(());
        }
        let rows = self.layout.spec().episode_len;
        let b = self
            .replay
            .sample_latest(
                1,
                rows,
                &self.replay_config.her,
                &self.layout,
                &mut self.rng,
                &|_, _| 0.0,
                &|_, _, out: &mut [f32]| out.fill(0.0),
            )
            .map_err(replay_err)?;
        let og = self.obs_goal_rows(&b, &b.obs);
        self.critic_norm.update(&og, self.comm.as_ref());
        for (norm, x) in self.actor_norms.iter_mut().zip(&b.actor_inputs) {
            norm.update(x, self.comm.as_ref());
        }
        Ok(())
    }

    /// `[x, g]` of every row of `b`, with `obs` its observations or next observations.
    fn obs_goal_rows(&self, b: &Batch, obs: &[f32]) -> Vec<f32> {
        let spec = self.layout.spec();
        let (od, gd) = (spec.obs_dim, spec.goal_dim);
        let mut out = Vec::with_capacity(b.size * (od + gd));
        for r in 0..b.size {
            out.extend_from_slice(&obs[r * od..(r + 1) * od]);
            out.extend_from_slice(&b.goals[r * gd..(r + 1) * gd]);
        }
        out
    }

    /// The replay buffer's capacity in episodes.
    pub(crate) fn storage_capacity(&self) -> usize {
        self.replay.capacity_episodes()
    }

    /// [`fmsr_core::Algorithm::restore_storage`] for the replay buffer.
    pub(crate) fn restore_storage(&mut self, total: u64, episodes: &[Episode]) -> Result<(), NnError> {
        self.replay.restore_log(total, episodes).map_err(|e| NnError::Replay { reason: e.to_string() })
    }

    /// Samples a batch with HER, updates the normalisers with it (with
    /// [`NormalizerStats::SampledBatches`]) and puts it on the device. `None` while the buffer is empty.
    pub(crate) fn sample(&mut self, rewards: &dyn RewardModel) -> Result<Option<BatchTensors>, NnError> {
        if self.replay.episodes() == 0 {
            return Ok(None);
        }
        // Each row's reward parts, for the epoch's statistics: the shadow part
        // is the agent's reward with a zero task reward, the task part the rest.
        let na = self.num_agents();
        let parts = std::cell::RefCell::new((vec![0.0f64; na], vec![0.0f64; na], vec![0.0f32; na], 0u64));
        let b = self
            .replay
            .sample(
                // This worker's share; `new` checked that it divides evenly.
                self.replay_config.batch_size / self.comm.workers(),
                &self.replay_config.her,
                &self.layout,
                &mut self.rng,
                &|a, d| rewards.goal_reward(a, d),
                &|task, phi, out| {
                    rewards.agent_rewards(task, phi, out);
                    let (task_abs, shadow_abs, shadow, rows) = &mut *parts.borrow_mut();
                    rewards.agent_rewards(0.0, phi, shadow);
                    for i in 0..out.len().min(na) {
                        task_abs[i] += f64::from((out[i] - shadow[i]).abs());
                        shadow_abs[i] += f64::from(shadow[i].abs());
                    }
                    *rows += 1;
                },
            )
            .map_err(|e| NnError::Replay { reason: e.to_string() })?;
        let (task_abs, shadow_abs, _, rows) = parts.into_inner();
        let d = &mut self.diagnostics;
        d.task_abs.resize(na, 0.0);
        d.shadow_abs.resize(na, 0.0);
        d.task_abs.iter_mut().zip(&task_abs).for_each(|(a, v)| *a += v);
        d.shadow_abs.iter_mut().zip(&shadow_abs).for_each(|(a, v)| *a += v);
        d.rows += rows;
        let bounds = rewards.reward_bounds();
        if bounds.len() != self.num_agents() {
            return Err(NnError::Dimension {
                what: "reward bounds (agents)".into(),
                expected: self.num_agents(),
                found: bounds.len(),
            });
        }
        let bounds = self.net.target_clip.bounds(&bounds, self.gamma);
        self.tensors(&b, bounds).map(Some)
    }

    fn check_batch(&self, b: &Batch, bounds: &[(f32, f32)]) -> Result<(), NnError> {
        let spec = self.layout.spec();
        let (n, na) = (b.size, self.num_agents());
        if n == 0 {
            return Err(NnError::Dimension { what: "batch.size (must be positive)".into(), expected: 1, found: 0 });
        }
        check_values(|| "batch.obs".into(), &b.obs, n * spec.obs_dim)?;
        check_values(|| "batch.next_obs".into(), &b.next_obs, n * spec.obs_dim)?;
        check_values(|| "batch.goals".into(), &b.goals, n * spec.goal_dim)?;
        check_values(|| "batch.actions".into(), &b.actions, n * spec.action_dim)?;
        for (what, v) in [("batch.actor_inputs", &b.actor_inputs), ("batch.next_actor_inputs", &b.next_actor_inputs)] {
            if v.len() != na {
                return Err(NnError::Dimension { what: format!("{what} (agents)"), expected: na, found: v.len() });
            }
            for (i, x) in v.iter().enumerate() {
                check_values(|| format!("{what}[{i}]"), x, n * self.layout.actor_input_dim(i))?;
            }
        }
        if b.rewards.len() != na {
            return Err(NnError::Dimension {
                what: "batch.rewards (agents)".into(),
                expected: na,
                found: b.rewards.len(),
            });
        }
        for (i, r) in b.rewards.iter().enumerate() {
            check_values(|| format!("batch.rewards[{i}]"), r, n)?;
        }
        if bounds.len() != na {
            return Err(NnError::Dimension {
                what: "Q-target bounds (agents)".into(),
                expected: na,
                found: bounds.len(),
            });
        }
        if let Some((i, (lo, hi))) =
            bounds.iter().enumerate().find(|(_, (lo, hi))| lo.is_nan() || hi.is_nan() || lo > hi)
        {
            return Err(NnError::InvalidConfig {
                key: "q_bounds",
                reason: format!("agent {i} has bounds ({lo}, {hi}); need lo <= hi"),
            });
        }
        Ok(())
    }

    /// Checks and normalises a host batch and uploads it.
    pub(crate) fn tensors(&mut self, b: &Batch, bounds: Vec<(f32, f32)>) -> Result<BatchTensors, NnError> {
        self.check_batch(b, &bounds)?;
        let n = b.size;
        let (mut og, mut og_next) = (self.obs_goal_rows(b, &b.obs), self.obs_goal_rows(b, &b.next_obs));
        if self.net.normalizer_stats == NormalizerStats::SampledBatches {
            self.critic_norm.update(&og, self.comm.as_ref());
            for (norm, x) in self.actor_norms.iter_mut().zip(&b.actor_inputs) {
                norm.update(x, self.comm.as_ref());
            }
        }
        self.critic_norm.normalize(&mut og);
        self.critic_norm.normalize(&mut og_next);
        let ad = self.perm.len();
        let mut actions = Vec::with_capacity(n * ad);
        for row in b.actions.chunks_exact(ad).take(n) {
            actions.extend(self.perm.iter().map(|&s| row[s]));
        }
        let groups = (0..self.groups.len()).map(|g| self.group_batch(g, b, &bounds)).collect();
        let dev = &self.device;
        let spec = self.layout.spec();
        let (od, gd) = (spec.obs_dim, spec.goal_dim);
        Ok(BatchTensors {
            n,
            og: matrix(og, n, od + gd, dev),
            og_next: matrix(og_next, n, od + gd, dev),
            actions: matrix(actions, n, ad, dev),
            groups,
        })
    }

    /// Group `g`'s share of a checked host batch.
    fn group_batch(&self, g: usize, b: &Batch, bounds: &[(f32, f32)]) -> GroupBatch {
        let (n, dev) = (b.size, &self.device);
        let group = &self.groups[g];
        let (a, width, r) = (group.len(), group.input_width(), group.agents.clone());
        let stack = |v: Vec<f32>, cols: usize| Tensor::<3>::from_data(TensorData::new(v, [a, n, cols]), dev);
        let per_agent = |f: fn(&(f32, f32)) -> f32| {
            Tensor::<3>::from_data(
                TensorData::new(bounds[r.clone()].iter().map(f).collect::<Vec<f32>>(), [a, 1, 1]),
                dev,
            )
        };
        GroupBatch {
            x_now: stack(self.padded_inputs(g, &b.actor_inputs, n), width),
            x_next: stack(self.padded_inputs(g, &b.next_actor_inputs, n), width),
            rewards: stack(b.rewards[r.clone()].concat(), 1),
            lo: per_agent(|b| b.0),
            hi: per_agent(|b| b.1),
        }
    }
}

/// The machine's physical memory (`MemTotal` of `/proc/meminfo`); `None`
/// where it cannot be read (not Linux).
#[must_use]
pub fn physical_memory_bytes() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemTotal:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// Refuses a replay buffer that could never fit: the buffer allocates as
/// episodes arrive, so without this a `replay.buffer_size` beyond the
/// machine's `memory` would only fail hours into training.
///
/// # Errors
/// [`NnError::InvalidConfig`] naming `replay.buffer_size`, with the bytes it
/// would take at full size and the memory there is.
pub fn check_replay_fits(replay: &ReplayBuffer, buffer_size: usize, memory: Option<u64>) -> Result<(), NnError> {
    let need = replay.bytes_at_capacity();
    match memory {
        Some(memory) if need > memory => Err(NnError::InvalidConfig {
            key: "replay.buffer_size",
            reason: format!(
                "{buffer_size} transitions would take {:.1} GB at full size ({} episodes), more than this machine's \
                 {:.1} GB of memory: lower it",
                need as f64 / 1e9,
                replay.capacity_episodes(),
                memory as f64 / 1e9
            ),
        }),
        _ => Ok(()),
    }
}
