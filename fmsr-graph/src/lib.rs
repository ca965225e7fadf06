//! Communication graphs, mixing matrices and consensus steps for the
//! Information Sharing (IS) part of FMSR (paper section III.C).
//!
//! # The math
//!
//! `N` agents sit on the nodes of an undirected graph `G = (V, E)`. After
//! each update, every agent replaces its (shared) parameters by a weighted
//! average of its neighbours' parameters and its own — eq. (8) of the paper:
//!
//! ```text
//! theta_i <- sum_{j : (j, i) in E or j = i} M[i][j] * theta_j
//! ```
//!
//! (the paper writes `theta_i` on the right-hand side; it is `theta_j`).
//! `M` is a *mixing matrix*: nonnegative, symmetric, doubly stochastic
//! (`sum_j M[i][j] = sum_i M[i][j] = 1`) and zero between distinct nodes
//! without an edge. Then:
//!
//! - the average `xbar = (1/N) sum_i x_i` is preserved by every step
//!   (columns sum to 1);
//! - with eigenvalues `1 = lambda_1 >= lambda_2 >= ... >= lambda_N >= -1`
//!   and the *second largest eigenvalue modulus*
//!   `slem = max(|lambda_2|, |lambda_N|)`, the disagreement
//!   `D(x) = sum_i |x_i - xbar|^2` obeys `D(M x) <= slem^2 D(x)`, so
//!   `D` after `k` steps is at most `slem^(2k) D(x^0)`;
//! - `slem < 1` exactly when the graph of positive weights is connected and
//!   not periodic; on a disconnected graph each component converges to its
//!   own average and global consensus is never reached.
//!
//! Default rule ([`MetropolisHastings`]):
//! `M[i][j] = 1 / (1 + max(d_i, d_j))` on edges, `M[i][i] = 1 - sum_{j != i} M[i][j]`.
//!
//! # Features
//!
//! - [`Graph`]: normalised undirected graphs with optional node names; ring,
//!   path, complete, star, empty, from edges, and the paper's Shadow Hand
//!   topology ([`Graph::shadow_hand`]: the finger ring
//!   thumb-index-middle-ring-little-thumb, the wrist isolated). The
//!   [`Topology`] trait lets other crates describe new topologies.
//! - [`MixingMatrix`]: validated dense matrices, checked against a graph
//!   with [`MixingMatrix::validate`]; spectral quantities
//!   ([`MixingMatrix::slem`], [`MixingMatrix::spectral_gap`],
//!   [`MixingMatrix::convergence_rate`]) via faer's symmetric
//!   eigen-decomposition.
//! - [`MixingRule`]s: [`MetropolisHastings`], [`MaxDegree`], [`Lazy`] and
//!   [`UserMatrix`] (validated, with errors naming the offending entry).
//! - The consensus step on `f32` parameter vectors, accumulated in `f64`:
//!   [`MixingMatrix::mix`], [`MixingMatrix::mix_slices`], and the
//!   allocation-free, reusable [`Mixer`]; [`average`] and [`disagreement`].
//! - [`ConsensusGraph`]: a graph with a matching matrix, as stored in
//!   configs.
//! - serde for every data type; deserialising validates.
//! - One error type, [`GraphError`]; no panics on bad input.
//!
//! # Example
//!
//! ```
//! use fmsr_graph::prelude::*;
//!
//! // The paper's topology with Metropolis-Hastings weights.
//! let cg = ConsensusGraph::new(Graph::shadow_hand(), &MetropolisHastings)?;
//! let thumb = cg.graph().index_of("thumb").unwrap();
//! assert_eq!(cg.graph().neighbors(thumb)?, &[1, 4]);
//!
//! // One parameter vector per agent; mix them a few times.
//! let mut params: Vec<Vec<f32>> = (0..6).map(|i| vec![i as f32; 8]).collect();
//! let mut mixer = cg.mixer();
//! for _ in 0..50 {
//!     mixer.mix(&mut params)?;
//! }
//! // The fingers agree on their average (1+2+3+4+5)/5 = 3; the wrist is alone.
//! assert!(params[1..].iter().flatten().all(|&p| (p - 3.0).abs() < 1e-3));
//! assert_eq!(params[0], vec![0.0; 8]);
//!
//! // The full graph is disconnected; the finger ring alone converges.
//! assert!(matches!(cg.convergence_rate(), Err(GraphError::Disconnected { components: 2 })));
//! let ring = MetropolisHastings.mixing_matrix(&Graph::ring(5))?;
//! assert!(ring.convergence_rate(&Graph::ring(5))? < 1.0);
//! # Ok::<(), GraphError>(())
//! ```

#![warn(missing_docs)]

mod consensus;
mod error;
mod graph;
mod mixing;

pub use consensus::{ConsensusGraph, Mixer, average, disagreement};
pub use error::GraphError;
pub use graph::{Graph, MAX_NODES, SHADOW_HAND_AGENTS, Topology};
pub use mixing::{Lazy, MaxDegree, MetropolisHastings, MixingMatrix, MixingRule, UserMatrix};

/// Absolute tolerance of matrix validation: row and column sums must be
/// within `TOLERANCE` of 1 and `|M[i][j] - M[j][i]| <= TOLERANCE`.
pub const TOLERANCE: f64 = 1e-9;

/// Everything needed for typical use: `use fmsr_graph::prelude::*;`.
pub mod prelude {
    pub use crate::{
        ConsensusGraph, Graph, GraphError, Lazy, MAX_NODES, MaxDegree, MetropolisHastings, Mixer, MixingMatrix,
        MixingRule, SHADOW_HAND_AGENTS, TOLERANCE, Topology, UserMatrix, average, disagreement,
    };
}
