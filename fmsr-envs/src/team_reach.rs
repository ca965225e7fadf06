//! `TeamReach`: a small, fast multi-agent goal-conditioned test environment
//! with no physics engine.
//!
//! Three agents of different action sizes move a point `p` in the plane to a
//! goal `g`, while an unstable "wobble" `w` drifts away from zero unless it is
//! held:
//!
//! ```text
//! p_x <- clip(p_x + step * a_x)            a_x = action of agent "x" (1 value)
//! p_y <- clip(p_y + step * a_y[0])         agent "y" (2 values; the 2nd is inert)
//! w   <- clip(drift * w + step * a_w[0])   agent "w" (3 values; the 2nd and 3rd are inert)
//! ```
//!
//! The goal is `g ~ U(-1, 1)^2`, achieved goal `p`, success `|p - g| < threshold`.
//! Dense reward `-|p - g|`, sparse `-1` until success. Features:
//! `safe_region` = `|w| < safe_radius` (the stability feature a shadow reward can
//! promote), `gentle` = mean `|a|` below one half. The object is "dropped" when
//! `|w|` reaches 1. Each agent observes the coordinate it moves and `w`; the
//! global observation is `(p_x, p_y, w)`.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use fmsr_core::Env;
use fmsr_core::spec::{AgentSpec, EnvSpec, JointAction, Observation, RewardType, StepInfo, StepOutcome};

use crate::error::EnvError;

/// Settings of [`TeamReach`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TeamReachConfig {
    /// Steps per episode (default 20).
    pub episode_len: usize,
    /// Dense (default) or sparse task reward.
    pub reward: RewardType,
    /// Success threshold on the goal distance (default 0.1).
    pub success_threshold: f32,
    /// How far one step at full action moves a coordinate (default 0.2).
    pub step_size: f32,
    /// Growth factor of the wobble per step, > 1 makes it unstable (default 1.15).
    pub drift: f32,
    /// `|w|` below which the `safe_region` feature is on (default 0.2).
    pub safe_radius: f32,
}

impl Default for TeamReachConfig {
    fn default() -> Self {
        Self {
            episode_len: 20,
            reward: RewardType::Dense,
            success_threshold: 0.1,
            step_size: 0.2,
            drift: 1.15,
            safe_radius: 0.2,
        }
    }
}

impl TeamReachConfig {
    /// Builds the environment, checking every value.
    ///
    /// ```
    /// use fmsr_envs::team_reach::TeamReachConfig;
    /// use fmsr_core::Env;
    /// let env = TeamReachConfig::default().init().unwrap();
    /// assert_eq!(env.spec().agents.len(), 3);
    /// assert!(TeamReachConfig { episode_len: 0, ..Default::default() }.init().is_err());
    /// ```
    pub fn init(self) -> Result<TeamReach, EnvError> {
        let positive = |key: &'static str, v: f32| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(EnvError::InvalidConfig { key, reason: format!("{v} must be positive and finite") })
            }
        };
        if self.episode_len == 0 {
            return Err(EnvError::InvalidConfig { key: "episode_len", reason: "must be at least 1".into() });
        }
        positive("success_threshold", self.success_threshold)?;
        positive("step_size", self.step_size)?;
        positive("drift", self.drift)?;
        positive("safe_radius", self.safe_radius)?;
        let agent =
            |name: &str, slots: Vec<usize>| AgentSpec { name: name.into(), action_slots: slots, local_obs_dim: 2 };
        let spec = EnvSpec {
            agents: vec![agent("x", vec![0]), agent("y", vec![1, 2]), agent("w", vec![3, 4, 5])],
            action_dim: 6,
            obs_dim: 3,
            goal_dim: 2,
            episode_len: self.episode_len,
            features: vec!["safe_region".into(), "gentle".into()],
            reward_range: match self.reward {
                RewardType::Dense => (-(8.0f32.sqrt()), 0.0),
                RewardType::Sparse => (-1.0, 0.0),
            },
        };
        spec.validate()?;
        Ok(TeamReach { config: self, spec, p: [0.0; 2], w: 0.0, goal: [0.0; 2], steps: None })
    }
}

/// The test environment; see the [module docs](self).
#[derive(Debug, Clone)]
pub struct TeamReach {
    config: TeamReachConfig,
    spec: EnvSpec,
    p: [f32; 2],
    w: f32,
    goal: [f32; 2],
    steps: Option<usize>,
}

impl TeamReach {
    fn observation(&self) -> Observation {
        Observation {
            global: vec![self.p[0], self.p[1], self.w],
            locals: vec![vec![self.p[0], self.w], vec![self.p[1], self.w], vec![self.w, self.w.abs()]],
            achieved_goal: self.p.to_vec(),
            desired_goal: self.goal.to_vec(),
        }
    }

    /// The current wobble `w`.
    #[must_use]
    pub fn wobble(&self) -> f32 {
        self.w
    }
}

impl Env for TeamReach {
    type Error = EnvError;

    fn spec(&self) -> &EnvSpec {
        &self.spec
    }

    fn reset(&mut self, seed: u64) -> Result<Observation, EnvError> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        self.p = [rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0)];
        self.goal = [rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0)];
        self.w = rng.random_range(-0.1..0.1);
        self.steps = Some(0);
        Ok(self.observation())
    }

    fn step(&mut self, action: &JointAction) -> Result<StepOutcome, EnvError> {
        action.validate(&self.spec)?;
        let steps = self.steps.ok_or(EnvError::NotReset)?;
        let a: Vec<f32> = action.0.iter().map(|v| v.clamp(-1.0, 1.0)).collect();
        let c = &self.config;
        self.p[0] = (self.p[0] + c.step_size * a[0]).clamp(-1.5, 1.5);
        self.p[1] = (self.p[1] + c.step_size * a[1]).clamp(-1.5, 1.5);
        self.w = (c.drift * self.w + c.step_size * a[3]).clamp(-1.0, 1.0);
        let steps = steps + 1;
        self.steps = Some(steps);
        let distance = self.goal_distance(&self.p, &self.goal);
        let mean_abs = a.iter().map(|v| v.abs()).sum::<f32>() / a.len() as f32;
        let info = StepInfo {
            is_success: distance < c.success_threshold,
            features: vec![f32::from(u8::from(self.w.abs() < c.safe_radius)), f32::from(u8::from(mean_abs < 0.5))],
            dropped: self.w.abs() >= 1.0,
        };
        Ok(StepOutcome {
            observation: self.observation(),
            reward: c.reward.reward(distance, c.success_threshold),
            terminated: false,
            truncated: steps >= c.episode_len,
            info,
        })
    }

    fn goal_distance(&self, achieved: &[f32], desired: &[f32]) -> f32 {
        achieved.iter().zip(desired).map(|(a, d)| (a - d) * (a - d)).sum::<f32>().sqrt()
    }

    fn goal_reward(&self, achieved: &[f32], desired: &[f32]) -> f32 {
        self.config.reward.reward(self.goal_distance(achieved, desired), self.config.success_threshold)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_seed_same_episode() {
        let mut a = TeamReachConfig::default().init().unwrap();
        let mut b = TeamReachConfig::default().init().unwrap();
        assert_eq!(a.reset(7).unwrap(), b.reset(7).unwrap());
        let act = JointAction(vec![0.3, -0.2, 0.9, 0.1, 0.0, -1.0]);
        for _ in 0..5 {
            assert_eq!(a.step(&act).unwrap(), b.step(&act).unwrap());
        }
        assert_ne!(a.reset(8).unwrap(), b.reset(7).unwrap());
    }

    #[test]
    fn moves_towards_goal_and_reports_features() {
        let mut env = TeamReachConfig::default().init().unwrap();
        let obs = env.reset(1).unwrap();
        obs.validate(env.spec()).unwrap();
        let (p, g) = (obs.achieved_goal.clone(), obs.desired_goal.clone());
        let d0 = env.goal_distance(&p, &g);
        let dir = [(g[0] - p[0]).signum() * 0.25, (g[1] - p[1]).signum() * 0.25];
        let out = env.step(&JointAction(vec![dir[0], dir[1], 0.0, 0.0, 0.0, 0.0])).unwrap();
        assert!(env.goal_distance(&out.observation.achieved_goal, &g) < d0);
        assert!((out.reward + env.goal_distance(&out.observation.achieved_goal, &g)).abs() < 1e-6);
        assert_eq!(out.info.features, vec![1.0, 1.0]); // |w| < 0.2 and gentle
        assert_eq!(out.reward, env.goal_reward(&out.observation.achieved_goal, &g));
    }

    #[test]
    fn wobble_escapes_unless_held() {
        let mut env = TeamReachConfig::default().init().unwrap();
        env.reset(3).unwrap();
        let push = JointAction(vec![0.0, 0.0, 0.0, 1.0, 0.0, 0.0]);
        let mut last = None;
        for _ in 0..20 {
            last = Some(env.step(&push).unwrap());
        }
        let last = last.unwrap();
        assert_eq!(last.info.features[0], 0.0);
        assert!(last.info.dropped);
        assert!(last.truncated);
    }

    #[test]
    fn bad_actions_are_rejected() {
        let mut env = TeamReachConfig::default().init().unwrap();
        assert!(matches!(env.step(&JointAction::zeros(6)), Err(EnvError::NotReset)));
        env.reset(0).unwrap();
        assert!(env.step(&JointAction::zeros(5)).is_err());
        assert!(env.step(&JointAction(vec![f32::NAN; 6])).is_err());
    }

    #[test]
    fn sparse_reward_is_zero_only_on_success() {
        let env = TeamReachConfig { reward: RewardType::Sparse, ..Default::default() }.init().unwrap();
        assert_eq!(env.goal_reward(&[0.0, 0.0], &[0.05, 0.0]), 0.0);
        assert_eq!(env.goal_reward(&[0.0, 0.0], &[0.5, 0.0]), -1.0);
    }
}
