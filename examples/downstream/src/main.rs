//! A user's crate: a new multi-agent task (`Env`, `herd.rs`), a
//! communication topology (`Topology`) and a mixing rule (`MixingRule`) of
//! its own, trained with fmsr's MADDPG, shadow rewards and information
//! sharing through the public API only; then an algorithm of its own
//! (`sac.rs`, SAC with a fixed temperature and its own Huber loss) and the
//! task registered by name and run by fmsr's own command, each alone and
//! together.

use anyhow::{Result, bail};
use fmsr_core::prelude::*;
use fmsr_graph::{Graph, GraphError, MixingMatrix, MixingRule, Topology};
use fmsr_nn::{LearnerParts, Maddpg, MaddpgConfig, NetworkConfig};
use herd::{AGENTS, Herd, HerdConfig};

mod herd;
mod sac;

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
    let env = Herd::new(HerdConfig::default())?;
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
    let ran = sac::run_by_name(&dir).and_then(|()| herd::run_by_name(&dir));
    std::fs::remove_dir_all(&dir)?;
    ran
}
