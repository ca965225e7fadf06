//! One consensus step `x_i <- sum_j M[i][j] x_j` over 6 agents with 200k f32
//! parameters each (the size of a shared actor trunk), Metropolis-Hastings
//! weights, on the paper's Shadow Hand topology (finger ring, isolated
//! wrist) and on the ring of 6.
//!
//! Run with `cargo bench --bench consensus`.

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use fmsr_graph::{ConsensusGraph, Graph, MetropolisHastings};

const AGENTS: usize = 6;
const PARAMS: usize = 200_000;

fn params() -> Vec<Vec<f32>> {
    (0..AGENTS).map(|i| (0..PARAMS).map(|e| ((i * 7919 + e * 31) % 1000) as f32 * 1e-3 - 0.5).collect()).collect()
}

fn consensus_step(c: &mut Criterion) {
    let mut group = c.benchmark_group("consensus_6x200k");
    group.throughput(Throughput::Bytes((AGENTS * PARAMS * 4) as u64));
    let cases = [
        ("shadow_hand_mh", ConsensusGraph::shadow_hand()),
        ("ring6_mh", ConsensusGraph::new(Graph::ring(AGENTS), &MetropolisHastings).expect("MH accepts every graph")),
    ];
    for (name, cg) in &cases {
        let mut xs = params();
        let mut mixer = cg.mixer();
        group.bench_function(format!("{name}/mixer"), |b| {
            b.iter(|| mixer.mix(black_box(&mut xs)).expect("6 equal vectors"));
        });
        let mut xs = params();
        group.bench_function(format!("{name}/matrix_mix"), |b| {
            b.iter(|| cg.mix(black_box(&mut xs)).expect("6 equal vectors"));
        });
    }
    group.finish();
}

criterion_group! {
    name = benches;
    // No plots: this workspace builds plotters with ab_glyph (fonts registered by the
    // report), so criterion's plotting finds no font and would panic.
    config = Criterion::default().without_plots();
    targets = consensus_step
}
criterion_main!(benches);
