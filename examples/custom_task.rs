//! A new task, written in a user's crate by implementing `Env`, trained with
//! finger-specific shadow rewards and information sharing.
//!
//! `Pinch`: two fingers move along a line; the goal is a position for the
//! midpoint between them. The stability feature `grip` is on while the fingers
//! hold a gap between 0.1 and 0.3 (holding the object); shadow rewards on `grip`
//! are assigned to both fingers.
//!
//! Run with `cargo run --release --example custom_task`.

use anyhow::Result;
use fmsr::prelude::*;
use rand::{RngExt, SeedableRng};

/// The two-finger pinch task.
struct Pinch {
    spec: EnvSpec,
    fingers: [f32; 2],
    goal: f32,
    steps: usize,
}

#[derive(Debug, thiserror::Error)]
enum PinchError {
    #[error(transparent)]
    Core(#[from] CoreError),
}

impl Pinch {
    fn new() -> Result<Self> {
        let finger =
            |name: &str, slot: usize| AgentSpec { name: name.into(), action_slots: vec![slot], local_obs_dim: 2 };
        let spec = EnvSpec {
            agents: vec![finger("thumb", 0), finger("index", 1)],
            action_dim: 2,
            obs_dim: 2,
            goal_dim: 1,
            episode_len: 25,
            features: vec!["grip".into()],
            reward_range: (-4.0, 0.0),
        };
        spec.validate()?;
        Ok(Self { spec, fingers: [0.0; 2], goal: 0.0, steps: 0 })
    }

    fn observation(&self) -> Observation {
        let mid = (self.fingers[0] + self.fingers[1]) / 2.0;
        let gap = self.fingers[1] - self.fingers[0];
        Observation {
            global: self.fingers.to_vec(),
            locals: vec![vec![self.fingers[0], gap], vec![self.fingers[1], gap]],
            achieved_goal: vec![mid],
            desired_goal: vec![self.goal],
        }
    }
}

impl Env for Pinch {
    type Error = PinchError;

    fn spec(&self) -> &EnvSpec {
        &self.spec
    }

    fn reset(&mut self, seed: u64) -> Result<Observation, PinchError> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let start: f32 = rng.random_range(-1.0..1.0);
        self.fingers = [start - 0.2, start + 0.2];
        self.goal = rng.random_range(-1.0..1.0);
        self.steps = 0;
        Ok(self.observation())
    }

    fn step(&mut self, action: &JointAction) -> Result<StepOutcome, PinchError> {
        action.validate(&self.spec)?;
        for (f, a) in self.fingers.iter_mut().zip(&action.0) {
            *f = (*f + 0.15 * a.clamp(-1.0, 1.0)).clamp(-2.0, 2.0);
        }
        self.steps += 1;
        let obs = self.observation();
        let gap = self.fingers[1] - self.fingers[0];
        let distance = self.goal_distance(&obs.achieved_goal, &obs.desired_goal);
        Ok(StepOutcome {
            reward: self.goal_reward(&obs.achieved_goal, &obs.desired_goal),
            terminated: false,
            truncated: self.steps >= self.spec.episode_len,
            info: StepInfo {
                is_success: distance < 0.1,
                features: vec![f32::from(u8::from((0.1..=0.3).contains(&gap)))],
                dropped: gap > 1.0,
            },
            observation: obs,
        })
    }

    fn goal_distance(&self, achieved: &[f32], desired: &[f32]) -> f32 {
        (achieved[0] - desired[0]).abs()
    }

    fn goal_reward(&self, achieved: &[f32], desired: &[f32]) -> f32 {
        RewardType::Dense.reward(self.goal_distance(achieved, desired), 0.1)
    }
}

fn main() -> Result<()> {
    let env = Pinch::new()?;
    let graph = Graph::complete(2);
    let layout = ObservationLayout::from_graph(env.spec().clone(), &graph)?;
    let config = TrainerConfig {
        seed: 1,
        epochs: 5,
        cycles: 10,
        eval_episodes: 20,
        shadow: ShadowConfig {
            alpha: 0.05,
            assignment: Some(RewardAssignment::all_features(env.spec())),
            ..ShadowConfig::default()
        },
        ..TrainerConfig::default()
    };
    let sharing = SharingConfig::default().build(&graph)?;
    let networks = NetworkConfig::new().with_hidden(64).with_layers(2).with_seed(1);
    let replay = ReplayConfig { batches: 20, batch_size: 128, buffer_size: 50_000, ..ReplayConfig::default() };
    let parts = LearnerParts::new(layout.clone(), networks, replay, config.gamma_for(25)).with_sharing(sharing);
    let learner = Maddpg::new(parts, MaddpgConfig::new())?;
    let mut trainer = Trainer::new(config, env, learner, layout)?;
    trainer.train(|_, s| {
        println!(
            "epoch {}: success {:.2}, grip rate {:.2}, occupancy {:.3}",
            s.epoch, s.success_rate, s.eval_feature_rates[0], s.occupancy[0]
        );
        Ok(())
    })?;
    Ok(())
}
