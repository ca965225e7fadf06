//! A custom information-sharing topology and mixing matrix, from a user's crate.
//!
//! Builds a topology by implementing `Topology` (the finger ring plus the wrist
//! linked to the thumb and the little finger), compares the mixing rules on it
//! (spectral gap = how fast consensus is reached), validates a hand-written
//! matrix, and runs consensus steps on parameter vectors (eq. 8).
//!
//! Run with `cargo run --release --example custom_mixing`.

use anyhow::Result;
use fmsr::prelude::*;

/// The paper's finger ring, with the wrist joined to the thumb and the little finger.
struct WristInTheLoop;

impl Topology for WristInTheLoop {
    fn graph(&self) -> Result<Graph, GraphError> {
        // Agents in the Shadow Hand order: 0 wrist, 1 index, 2 middle, 3 ring, 4 little, 5 thumb.
        let ring = Graph::shadow_hand();
        let mut edges = ring.edges().to_vec();
        edges.extend([(0, 5), (0, 4)]);
        Graph::from_edges(6, &edges)?.with_names(SHADOW_HAND_AGENTS.iter().map(|s| (*s).to_owned()).collect())
    }
}

fn main() -> Result<()> {
    let graph = WristInTheLoop.graph()?;
    println!("edges: {:?}, connected: {}", graph.edges(), graph.is_connected());

    let rules: Vec<(&str, Box<dyn MixingRule>)> = vec![
        ("Metropolis-Hastings", Box::new(MetropolisHastings)),
        ("max-degree", Box::new(MaxDegree)),
        ("lazy MH (alpha 0.5)", Box::new(Lazy::new(MetropolisHastings, 0.5)?)),
    ];
    for (name, rule) in &rules {
        let m = rule.mixing_matrix(&graph)?;
        println!("{name:>22}: SLEM {:.3}, spectral gap {:.3}", m.slem()?, m.spectral_gap()?);
    }

    // A hand-written matrix is validated against the graph: this one puts weight
    // on index-ring, which is not an edge, and is rejected with the entry named.
    let mut rows = MetropolisHastings.mixing_matrix(&graph)?.to_rows();
    rows[1][3] += 0.05;
    rows[1][1] -= 0.05;
    rows[3][1] += 0.05;
    rows[3][3] -= 0.05;
    match (UserMatrix { rows }).mixing_matrix(&graph) {
        Err(e) => println!("rejected: {e}"),
        Ok(_) => anyhow::bail!("a matrix with weight on a non-edge was accepted"),
    }

    // Consensus on six parameter vectors: the average is kept, disagreement shrinks.
    let consensus = ConsensusGraph::new(graph, &MetropolisHastings)?;
    let mut params: Vec<Vec<f32>> = (0..6).map(|i| vec![i as f32; 4]).collect();
    for step in 0..=20 {
        if step % 5 == 0 {
            println!("step {step:>2}: disagreement {:.6}", consensus.disagreement(&params)?);
        }
        consensus.mix(&mut params)?;
    }
    println!("average kept: {:?}", consensus.average(&params)?);

    // The same graph and rule, as an experiment's config would build them.
    let sharing = SharingConfig::default().build(consensus.graph())?.expect("sharing is enabled by default");
    println!("learner mixing matrix is {}x{}", sharing.mixing.n(), sharing.mixing.n());
    Ok(())
}
