//! The consensus step and the graph + matrix bundle used by trainers.

use serde::{Deserialize, Serialize};

use crate::{Graph, GraphError, MetropolisHastings, MixingMatrix, MixingRule};

/// Number of vector elements processed per block: the block of every vector
/// plus the `f64` accumulators stay in the L1/L2 cache.
const BLOCK: usize = 512;

/// A reusable consensus step for one mixing matrix.
///
/// It keeps the nonzero weights of each row and an `f64` scratch buffer of
/// `n x 512` entries, so [`Mixer::mix`] allocates nothing after the first
/// call. Vectors are processed in blocks: for each block, every output is
/// accumulated in `f64` from the inputs (zero weights skipped) and then
/// written back, so reading and writing the same vectors is safe. Rows that
/// are exactly the identity (isolated nodes) are left untouched.
///
/// ```
/// use fmsr_graph::{Graph, MetropolisHastings, Mixer};
///
/// let mut mixer = Mixer::new(&MetropolisHastings::matrix(&Graph::complete(3)));
/// let mut xs = vec![vec![3.0_f32; 4], vec![0.0; 4], vec![0.0; 4]];
/// mixer.mix(&mut xs)?;
/// assert!(xs.iter().flatten().all(|&x| (x - 1.0).abs() < 1e-6));
/// # Ok::<(), fmsr_graph::GraphError>(())
/// ```
#[derive(Debug, Clone)]
pub struct Mixer {
    /// Nonzero `(j, M[i][j])` of each row `i`; empty for identity rows.
    weights: Vec<Vec<(usize, f64)>>,
    scratch: Vec<f64>,
}

impl Mixer {
    /// Prepares the step for `matrix`.
    #[must_use]
    pub fn new(matrix: &MixingMatrix) -> Mixer {
        let weights = matrix
            .rows()
            .enumerate()
            .map(|(i, row)| {
                let nonzero: Vec<(usize, f64)> =
                    row.iter().enumerate().filter(|&(_, &w)| w != 0.0).map(|(j, &w)| (j, w)).collect();
                if nonzero == [(i, 1.0)] { Vec::new() } else { nonzero }
            })
            .collect();
        Mixer { weights, scratch: Vec::new() }
    }

    /// Number of nodes (vectors expected per step).
    #[must_use]
    pub fn n(&self) -> usize {
        self.weights.len()
    }

    /// One consensus step `x_i <- sum_j M[i][j] x_j`, in place.
    ///
    /// # Errors
    /// [`GraphError::WrongCount`] if `xs.len() != n`,
    /// [`GraphError::UnequalLengths`] if a vector's length differs from the
    /// first one's. Nothing is modified on error.
    pub fn mix(&mut self, xs: &mut [Vec<f32>]) -> Result<(), GraphError> {
        self.mix_any(xs)
    }

    /// [`Mixer::mix`] over borrowed slices.
    ///
    /// # Errors
    /// As [`Mixer::mix`].
    pub fn mix_slices(&mut self, xs: &mut [&mut [f32]]) -> Result<(), GraphError> {
        self.mix_any(xs)
    }

    /// [`Mixer::mix`] over any mutable `f32` buffers.
    ///
    /// # Errors
    /// As [`Mixer::mix`].
    pub fn mix_any<V>(&mut self, xs: &mut [V]) -> Result<(), GraphError>
    where
        V: AsMut<[f32]> + AsRef<[f32]>,
    {
        let n = self.weights.len();
        check_vectors(n, xs)?;
        let Some(len) = xs.first().map(|x| x.as_ref().len()) else {
            return Ok(());
        };
        self.scratch.resize(n * BLOCK, 0.0);
        let mut start = 0;
        while start < len {
            let end = (start + BLOCK).min(len);
            let width = end - start;
            for (row, acc) in self.weights.iter().zip(self.scratch.chunks_exact_mut(BLOCK)) {
                let acc = &mut acc[..width];
                let Some((&(first, w0), rest)) = row.split_first() else {
                    continue;
                };
                for (a, &x) in acc.iter_mut().zip(&xs[first].as_ref()[start..end]) {
                    *a = w0 * f64::from(x);
                }
                for &(j, w) in rest {
                    for (a, &x) in acc.iter_mut().zip(&xs[j].as_ref()[start..end]) {
                        *a += w * f64::from(x);
                    }
                }
            }
            for ((row, acc), x) in self.weights.iter().zip(self.scratch.chunks_exact(BLOCK)).zip(xs.iter_mut()) {
                if row.is_empty() {
                    continue;
                }
                for (out, &a) in x.as_mut()[start..end].iter_mut().zip(&acc[..width]) {
                    *out = a as f32;
                }
            }
            start = end;
        }
        Ok(())
    }
}

/// Checks that there are `n` vectors of equal length.
fn check_vectors<V: AsRef<[f32]>>(n: usize, xs: &[V]) -> Result<(), GraphError> {
    if xs.len() != n {
        return Err(GraphError::WrongCount { expected: n, found: xs.len() });
    }
    check_lengths(xs).map(|_| ())
}

/// Checks that all vectors have the length of the first and returns it (0
/// for no vectors).
fn check_lengths<V: AsRef<[f32]>>(xs: &[V]) -> Result<usize, GraphError> {
    let expected = xs.first().map_or(0, |x| x.as_ref().len());
    for (index, x) in xs.iter().enumerate() {
        let found = x.as_ref().len();
        if found != expected {
            return Err(GraphError::UnequalLengths { index, expected, found });
        }
    }
    Ok(expected)
}

/// The elementwise mean of equally long vectors, accumulated in `f64`
/// (empty for no vectors).
///
/// # Errors
/// [`GraphError::UnequalLengths`] if a vector's length differs from the first
/// one's.
///
/// ```
/// let mean = fmsr_graph::average(&[vec![1.0_f32, 2.0], vec![3.0, 6.0]])?;
/// assert_eq!(mean, vec![2.0, 4.0]);
/// # Ok::<(), fmsr_graph::GraphError>(())
/// ```
pub fn average<V: AsRef<[f32]>>(xs: &[V]) -> Result<Vec<f64>, GraphError> {
    let len = check_lengths(xs)?;
    let mut mean = vec![0.0_f64; len];
    for x in xs {
        for (m, &v) in mean.iter_mut().zip(x.as_ref()) {
            *m += f64::from(v);
        }
    }
    let count = xs.len() as f64;
    if !xs.is_empty() {
        for m in &mut mean {
            *m /= count;
        }
    }
    Ok(mean)
}

/// The disagreement `sum_i |x_i - mean|^2` of equally long vectors, in `f64`
/// (0 for no vectors). It is 0 exactly at consensus.
///
/// # Errors
/// [`GraphError::UnequalLengths`] if a vector's length differs from the first
/// one's.
///
/// ```
/// let d = fmsr_graph::disagreement(&[vec![1.0_f32, 2.0], vec![3.0, 6.0]])?;
/// assert_eq!(d, 1.0 + 1.0 + 4.0 + 4.0);
/// # Ok::<(), fmsr_graph::GraphError>(())
/// ```
pub fn disagreement<V: AsRef<[f32]>>(xs: &[V]) -> Result<f64, GraphError> {
    let mean = average(xs)?;
    Ok(xs.iter().map(|x| x.as_ref().iter().zip(&mean).map(|(&v, &m)| (f64::from(v) - m).powi(2)).sum::<f64>()).sum())
}

/// A communication graph together with a mixing matrix that respects it:
/// what a trainer needs for information sharing.
///
/// Deserialising checks the matrix against the graph
/// ([`MixingMatrix::validate`]).
///
/// ```
/// use fmsr_graph::{ConsensusGraph, Graph, MetropolisHastings};
///
/// let cg = ConsensusGraph::new(Graph::ring(6), &MetropolisHastings)?;
/// let mut xs: Vec<Vec<f32>> = (0..6).map(|i| vec![i as f32; 3]).collect();
/// let before = cg.disagreement(&xs)?;
/// cg.mix(&mut xs)?;
/// assert!(cg.disagreement(&xs)? < before);
/// assert!((cg.average(&xs)?[0] - 2.5).abs() < 1e-6);
/// # Ok::<(), fmsr_graph::GraphError>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "ConsensusRepr", into = "ConsensusRepr")]
pub struct ConsensusGraph {
    graph: Graph,
    mixing: MixingMatrix,
}

/// Serialised form of a [`ConsensusGraph`].
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ConsensusRepr {
    graph: Graph,
    mixing: MixingMatrix,
}

impl TryFrom<ConsensusRepr> for ConsensusGraph {
    type Error = GraphError;

    fn try_from(repr: ConsensusRepr) -> Result<Self, Self::Error> {
        ConsensusGraph::with_matrix(repr.graph, repr.mixing)
    }
}

impl From<ConsensusGraph> for ConsensusRepr {
    fn from(cg: ConsensusGraph) -> Self {
        ConsensusRepr { graph: cg.graph, mixing: cg.mixing }
    }
}

impl ConsensusGraph {
    /// The graph with the matrix built by `rule` (checked against the graph).
    ///
    /// # Errors
    /// Whatever the rule returns, or a [`MixingMatrix::validate`] error if
    /// the rule's matrix does not fit the graph.
    pub fn new(graph: Graph, rule: &impl MixingRule) -> Result<ConsensusGraph, GraphError> {
        let mixing = rule.mixing_matrix(&graph)?;
        ConsensusGraph::with_matrix(graph, mixing)
    }

    /// The graph with a given matrix.
    ///
    /// # Errors
    /// Any error of [`MixingMatrix::validate`].
    pub fn with_matrix(graph: Graph, mixing: MixingMatrix) -> Result<ConsensusGraph, GraphError> {
        mixing.validate(&graph)?;
        Ok(ConsensusGraph { graph, mixing })
    }

    /// The paper's default: [`Graph::shadow_hand`] with Metropolis-Hastings
    /// weights.
    ///
    /// ```
    /// let cg = fmsr_graph::ConsensusGraph::shadow_hand();
    /// assert_eq!(cg.mixing().get(0, 0), Some(1.0)); // the wrist keeps its own parameters
    /// assert_eq!(cg.mixing().get(5, 1), Some(1.0 / 3.0)); // thumb <-> index
    /// ```
    #[must_use]
    pub fn shadow_hand() -> ConsensusGraph {
        let graph = Graph::shadow_hand();
        let mixing = MetropolisHastings::matrix(&graph);
        ConsensusGraph { graph, mixing }
    }

    /// The graph.
    #[must_use]
    pub fn graph(&self) -> &Graph {
        &self.graph
    }

    /// The mixing matrix.
    #[must_use]
    pub fn mixing(&self) -> &MixingMatrix {
        &self.mixing
    }

    /// Splits into graph and matrix.
    #[must_use]
    pub fn into_parts(self) -> (Graph, MixingMatrix) {
        (self.graph, self.mixing)
    }

    /// Number of nodes.
    #[must_use]
    pub fn nodes(&self) -> usize {
        self.graph.nodes()
    }

    /// A reusable [`Mixer`] for repeated steps without allocation.
    #[must_use]
    pub fn mixer(&self) -> Mixer {
        Mixer::new(&self.mixing)
    }

    /// One consensus step, see [`MixingMatrix::mix`].
    ///
    /// # Errors
    /// As [`MixingMatrix::mix`].
    pub fn mix(&self, xs: &mut [Vec<f32>]) -> Result<(), GraphError> {
        self.mixing.mix(xs)
    }

    /// One consensus step over borrowed slices, see
    /// [`MixingMatrix::mix_slices`].
    ///
    /// # Errors
    /// As [`MixingMatrix::mix`].
    pub fn mix_slices(&self, xs: &mut [&mut [f32]]) -> Result<(), GraphError> {
        self.mixing.mix_slices(xs)
    }

    /// The disagreement `sum_i |x_i - mean|^2` of one vector per node.
    ///
    /// # Errors
    /// [`GraphError::WrongCount`] if `xs.len()` is not the number of nodes,
    /// [`GraphError::UnequalLengths`] for vectors of different lengths.
    pub fn disagreement<V: AsRef<[f32]>>(&self, xs: &[V]) -> Result<f64, GraphError> {
        check_vectors(self.nodes(), xs)?;
        disagreement(xs)
    }

    /// The elementwise mean of one vector per node, in `f64`. Consensus
    /// steps preserve it.
    ///
    /// # Errors
    /// As [`ConsensusGraph::disagreement`].
    pub fn average<V: AsRef<[f32]>>(&self, xs: &[V]) -> Result<Vec<f64>, GraphError> {
        check_vectors(self.nodes(), xs)?;
        average(xs)
    }

    /// See [`MixingMatrix::convergence_rate`].
    ///
    /// # Errors
    /// As [`MixingMatrix::convergence_rate`].
    pub fn convergence_rate(&self) -> Result<f64, GraphError> {
        self.mixing.convergence_rate(&self.graph)
    }
}
