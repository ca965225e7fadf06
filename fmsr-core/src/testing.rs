//! What the tests of a user's rule, reward model or environment need without
//! an environment: a random episode of any [`EnvSpec`] and a plain
//! [`RewardModel`]. Behind the `testing` feature (a dev-dependency's
//! `features = ["testing"]`).
//!
//! ```
//! use fmsr_core::spec::{AgentSpec, EnvSpec};
//! use fmsr_core::testing::{L1Rewards, random_episode};
//! use fmsr_core::RewardModel;
//! let spec = EnvSpec {
//!     agents: vec![AgentSpec { name: "a".into(), action_slots: vec![0], local_obs_dim: 2 }],
//!     action_dim: 1, obs_dim: 3, goal_dim: 1, episode_len: 5,
//!     features: vec!["on".into()], reward_range: (-1.0, 0.0),
//! };
//! let episode = random_episode(&spec, 7);
//! assert_eq!((episode.observations.len(), episode.actions.len()), (6, 5));
//! assert_eq!(random_episode(&spec, 7).actions, episode.actions, "the seed decides it");
//! let mut r = [0.0];
//! L1Rewards::new(1).agent_rewards(-0.5, &[0.0], &mut r);
//! assert_eq!(r, [-0.5]);
//! ```

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::algorithm::RewardModel;
use crate::replay::Episode;
use crate::spec::{EnvSpec, JointAction, Observation, StepInfo};

/// An episode of `spec` drawn from `seed`: every observation, goal and
/// action uniform in `[-1, 1)`, one desired goal for the episode, every
/// feature off. Not a trajectory of any dynamics: for code that stores,
/// samples, relabels or learns from episodes.
#[must_use]
pub fn random_episode(spec: &EnvSpec, seed: u64) -> Episode {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut v = |len: usize| (0..len).map(|_| rng.random_range(-1.0f32..1.0)).collect::<Vec<f32>>();
    let goal = v(spec.goal_dim);
    let mut ep = Episode::with_capacity(spec.episode_len);
    for t in 0..=spec.episode_len {
        ep.observations.push(Observation {
            global: v(spec.obs_dim),
            locals: spec.agents.iter().map(|a| v(a.local_obs_dim)).collect(),
            achieved_goal: v(spec.goal_dim),
            desired_goal: goal.clone(),
        });
        if t < spec.episode_len {
            ep.actions.push(JointAction(v(spec.action_dim)));
            ep.infos.push(StepInfo { features: vec![0.0; spec.features.len()], ..StepInfo::default() });
        }
    }
    ep
}

/// Every agent's reward is the task reward `-|achieved - desired|_1`, with
/// per-step bounds `[-10, 0]`; features give nothing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct L1Rewards {
    agents: usize,
}

impl L1Rewards {
    /// For `agents` agents.
    #[must_use]
    pub fn new(agents: usize) -> Self {
        Self { agents }
    }
}

impl RewardModel for L1Rewards {
    fn goal_reward(&self, achieved: &[f32], desired: &[f32]) -> f32 {
        -achieved.iter().zip(desired).map(|(a, d)| (a - d).abs()).sum::<f32>()
    }

    fn agent_rewards(&self, task: f32, _phi: &[f32], out: &mut [f32]) {
        out.iter_mut().for_each(|o| *o = task);
    }

    fn reward_bounds(&self) -> Vec<(f64, f64)> {
        vec![(-10.0, 0.0); self.agents]
    }
}
