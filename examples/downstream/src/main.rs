//! A user's crate: a new multi-agent task (`Env`), a communication topology
//! (`Topology`) and a mixing rule (`MixingRule`) of its own, trained with
//! fmsr's MADDPG, shadow rewards and information sharing through the public
//! API only; then an algorithm of its own (`sac.rs`, SAC with a fixed
//! temperature) registered by name and run by fmsr's own command.
//!
//! `Herd`: three agents move along a line; the goal is a position for their
//! mean. The stability feature `together` is on while the agents stay within
//! 0.5 of each other; every agent gets its shadow reward.

use anyhow::{Result, bail};
use fmsr_core::prelude::*;
use fmsr_graph::{Graph, GraphError, MixingMatrix, MixingRule, Topology};
use fmsr_nn::{LearnerParts, Maddpg, MaddpgConfig, NetworkConfig};
use rand::{Rng, SeedableRng};

mod sac;

const AGENTS: usize = 3;

#[derive(Debug, thiserror::Error)]
#[error(transparent)]
struct HerdError(#[from] CoreError);

/// The herding task.
struct Herd {
    spec: EnvSpec,
    x: [f32; AGENTS],
    goal: f32,
}

impl Herd {
    fn new() -> Result<Self> {
        let agents =
            (0..AGENTS).map(|i| AgentSpec { name: format!("a{i}"), action_slots: vec![i], local_obs_dim: 2 }).collect();
        let spec = EnvSpec {
            agents,
            action_dim: AGENTS,
            obs_dim: AGENTS,
            goal_dim: 1,
            episode_len: 20,
            features: vec!["together".into()],
            reward_range: (-4.0, 0.0),
        };
        spec.validate()?;
        Ok(Self { spec, x: [0.0; AGENTS], goal: 0.0 })
    }

    fn mean(&self) -> f32 {
        self.x.iter().sum::<f32>() / AGENTS as f32
    }

    fn observation(&self) -> Observation {
        let mean = self.mean();
        Observation {
            global: self.x.to_vec(),
            locals: self.x.iter().map(|&x| vec![x, x - mean]).collect(),
            achieved_goal: vec![mean],
            desired_goal: vec![self.goal],
        }
    }
}

impl Env for Herd {
    type Error = HerdError;

    fn spec(&self) -> &EnvSpec {
        &self.spec
    }

    fn reset(&mut self, seed: u64) -> Result<Observation, HerdError> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        for x in &mut self.x {
            *x = rng.random_range(-1.0..1.0);
        }
        self.goal = rng.random_range(-1.0..1.0);
        Ok(self.observation())
    }

    fn step(&mut self, action: &JointAction) -> Result<StepOutcome, HerdError> {
        action.validate(&self.spec)?;
        for (x, a) in self.x.iter_mut().zip(&action.0) {
            *x = (*x + 0.15 * a).clamp(-2.0, 2.0);
        }
        let obs = self.observation();
        let spread = self.x.iter().fold(f32::MIN, |m, &x| m.max(x)) - self.x.iter().fold(f32::MAX, |m, &x| m.min(x));
        let distance = self.goal_distance(&obs.achieved_goal, &obs.desired_goal);
        Ok(StepOutcome {
            reward: self.goal_reward(&obs.achieved_goal, &obs.desired_goal),
            terminated: false,
            truncated: false,
            info: StepInfo {
                is_success: distance < 0.1,
                features: vec![f32::from(u8::from(spread < 0.5))],
                dropped: false,
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

/// A chain a0 - a1 - a2.
struct Chain;

impl Topology for Chain {
    fn graph(&self) -> Result<Graph, GraphError> {
        Graph::from_edges(AGENTS, &[(0, 1), (1, 2)])
    }
}

/// Half-lazy max-degree weights: `M_ij = 1 / (2 d_max)` on edges, the rest on
/// the diagonal; symmetric and doubly stochastic on any graph.
struct HalfLazyMaxDegree;

impl MixingRule for HalfLazyMaxDegree {
    fn mixing_matrix(&self, graph: &Graph) -> Result<MixingMatrix, GraphError> {
        let n = graph.nodes();
        let dmax = (0..n).map(|i| graph.degree(i)).collect::<Result<Vec<_>, _>>()?.into_iter().max().unwrap_or(0);
        let w = 1.0 / (2.0 * dmax.max(1) as f64);
        let mut rows = vec![vec![0.0; n]; n];
        for &(i, j) in graph.edges() {
            rows[i][j] = w;
            rows[j][i] = w;
        }
        for (i, row) in rows.iter_mut().enumerate() {
            row[i] = 1.0 - row.iter().sum::<f64>();
        }
        MixingMatrix::from_rows(rows)
    }
}

fn main() -> Result<()> {
    let env = Herd::new()?;
    let spec = env.spec().clone();
    let graph = Chain.graph()?;
    let mixing = HalfLazyMaxDegree.mixing_matrix(&graph)?;
    mixing.validate(&graph)?;
    let layout = ObservationLayout::from_graph(spec.clone(), &graph)?;
    let config = TrainerConfig {
        seed: 3,
        epochs: 4,
        cycles: 10,
        eval_episodes: 20,
        shadow: ShadowConfig {
            alpha: 0.05,
            assignment: Some(RewardAssignment::all_features(&spec)),
            ..ShadowConfig::default()
        },
        ..TrainerConfig::default()
    };
    let sharing = Sharing { mixing, mode: ShareMode::Parameters, target: ShareTarget::Actors };
    let networks = NetworkConfig::new().with_hidden(64).with_layers(2).with_seed(3);
    let replay = ReplayConfig { batches: 20, batch_size: 128, buffer_size: 20_000, ..ReplayConfig::default() };
    let parts = LearnerParts::new(layout.clone(), networks, replay, config.gamma_for(spec.episode_len))
        .with_sharing(Some(sharing));
    let mut trainer = Trainer::new(config, env, Maddpg::new(parts, MaddpgConfig::new())?, layout)?;
    trainer.train(|_, s| {
        println!("epoch {}: success {:.2}, together {:.2}", s.epoch, s.success_rate, s.eval_feature_rates[0]);
        Ok(())
    })?;
    let last = trainer.history().last().map_or(f64::NAN, |s| s.success_rate);
    if !last.is_finite() {
        bail!("training produced no statistics");
    }
    println!("downstream crate trained {} epochs through the public API", trainer.epoch());
    let dir = std::env::temp_dir().join(format!("fmsr-downstream-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let ran = sac::run_by_name(&dir);
    std::fs::remove_dir_all(&dir)?;
    ran
}
