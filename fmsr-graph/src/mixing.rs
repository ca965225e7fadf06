//! Symmetric doubly stochastic mixing matrices and the rules that build them.

use serde::{Deserialize, Serialize};

use crate::consensus::Mixer;
use crate::graph::components_of;
use crate::{Graph, GraphError, TOLERANCE};

/// A dense, row-major, square mixing matrix `M` that is finite, nonnegative,
/// symmetric and doubly stochastic (rows and columns sum to 1 within
/// [`TOLERANCE`]).
///
/// Every constructor and deserialisation checks these properties; whether the
/// weights respect a particular graph is checked by
/// [`MixingMatrix::validate`] (and by [`ConsensusGraph`](crate::ConsensusGraph)).
///
/// ```
/// use fmsr_graph::{Graph, MetropolisHastings, MixingRule};
///
/// let m = MetropolisHastings.mixing_matrix(&Graph::path(2))?;
/// assert_eq!(m.get(0, 1), Some(0.5));
/// assert_eq!(m.get(1, 1), Some(0.5));
/// assert_eq!(m.get(2, 0), None);
/// assert!(m.slem()? < 1e-12);
/// # Ok::<(), fmsr_graph::GraphError>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "MatrixRepr", into = "MatrixRepr")]
pub struct MixingMatrix {
    n: usize,
    data: Vec<f64>,
}

/// Serialised form of a [`MixingMatrix`]: `{"rows": [[...], ...]}`.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct MatrixRepr {
    rows: Vec<Vec<f64>>,
}

impl TryFrom<MatrixRepr> for MixingMatrix {
    type Error = GraphError;

    fn try_from(repr: MatrixRepr) -> Result<Self, Self::Error> {
        MixingMatrix::from_rows(repr.rows)
    }
}

impl From<MixingMatrix> for MatrixRepr {
    fn from(matrix: MixingMatrix) -> Self {
        MatrixRepr { rows: matrix.to_rows() }
    }
}

/// Checks that `rows` is square and returns its dimension.
fn check_square(rows: &[Vec<f64>]) -> Result<usize, GraphError> {
    let n = rows.len();
    match rows.iter().find(|row| row.len() != n) {
        Some(row) => Err(GraphError::NotSquare { rows: n, cols: row.len() }),
        None => Ok(n),
    }
}

/// Checks a row-major `n x n` matrix, in this order: finite entries,
/// nonnegative entries, no weight off the edges of `graph` (if given), row
/// sums, column sums, symmetry. The first violation found is returned.
fn check_entries(n: usize, data: &[f64], graph: Option<&Graph>) -> Result<(), GraphError> {
    let at = |row: usize, col: usize| data[row * n + col];
    for row in 0..n {
        for col in 0..n {
            if !at(row, col).is_finite() {
                return Err(GraphError::NotFinite { row, col });
            }
        }
    }
    for row in 0..n {
        for col in 0..n {
            let value = at(row, col);
            if value < 0.0 {
                return Err(GraphError::NegativeEntry { row, col, value });
            }
        }
    }
    if let Some(graph) = graph {
        for row in 0..n {
            for col in 0..n {
                let value = at(row, col);
                if row != col && value > 0.0 && !graph.has_edge(row, col) {
                    return Err(GraphError::WeightOnNonEdge { row, col, value });
                }
            }
        }
    }
    for row in 0..n {
        let sum: f64 = (0..n).map(|col| at(row, col)).sum();
        if (sum - 1.0).abs() > TOLERANCE {
            return Err(GraphError::RowSum { row, sum });
        }
    }
    for col in 0..n {
        let sum: f64 = (0..n).map(|row| at(row, col)).sum();
        if (sum - 1.0).abs() > TOLERANCE {
            return Err(GraphError::ColumnSum { col, sum });
        }
    }
    for row in 0..n {
        for col in row + 1..n {
            let (upper, lower) = (at(row, col), at(col, row));
            if (upper - lower).abs() > TOLERANCE {
                return Err(GraphError::Asymmetric { row, col, upper, lower });
            }
        }
    }
    Ok(())
}

/// Checks that the matrix size equals the number of graph nodes.
fn check_size(graph: &Graph, n: usize) -> Result<(), GraphError> {
    if graph.nodes() == n { Ok(()) } else { Err(GraphError::SizeMismatch { expected: graph.nodes(), found: n }) }
}

impl MixingMatrix {
    /// Builds a matrix from its rows, checking (in this order) that it is
    /// square, finite, nonnegative, has unit row and column sums and is
    /// symmetric.
    ///
    /// # Errors
    /// The first violated property: [`GraphError::NotSquare`],
    /// [`GraphError::NotFinite`], [`GraphError::NegativeEntry`],
    /// [`GraphError::RowSum`], [`GraphError::ColumnSum`] or
    /// [`GraphError::Asymmetric`].
    ///
    /// ```
    /// use fmsr_graph::{GraphError, MixingMatrix};
    ///
    /// let m = MixingMatrix::from_rows(vec![vec![0.25, 0.75], vec![0.75, 0.25]])?;
    /// assert_eq!(m.n(), 2);
    /// let bad = MixingMatrix::from_rows(vec![vec![0.5, 0.6], vec![0.5, 0.4]]);
    /// assert!(matches!(bad, Err(GraphError::RowSum { row: 0, .. })));
    /// # Ok::<(), GraphError>(())
    /// ```
    pub fn from_rows(rows: Vec<Vec<f64>>) -> Result<MixingMatrix, GraphError> {
        let n = check_square(&rows)?;
        let data: Vec<f64> = rows.into_iter().flatten().collect();
        check_entries(n, &data, None)?;
        Ok(MixingMatrix { n, data })
    }

    /// The `n x n` identity (no mixing at all).
    #[must_use]
    pub fn identity(n: usize) -> MixingMatrix {
        let mut data = vec![0.0; n * n];
        for i in 0..n {
            data[i * n + i] = 1.0;
        }
        MixingMatrix { n, data }
    }

    /// Builds a matrix from symmetric off-diagonal edge weights; the
    /// diagonal takes the rest of each row, `1 - sum_j M[i][j]`.
    ///
    /// Only used by the rules of this crate, whose weights keep every row sum
    /// at most 1.
    fn from_edge_weights(graph: &Graph, weight: impl Fn(usize, usize) -> f64) -> MixingMatrix {
        let n = graph.nodes();
        let mut data = vec![0.0; n * n];
        for &(i, j) in graph.edges() {
            let w = weight(i, j);
            data[i * n + j] = w;
            data[j * n + i] = w;
        }
        for i in 0..n {
            let off: f64 = (0..n).filter(|&j| j != i).map(|j| data[i * n + j]).sum();
            data[i * n + i] = (1.0 - off).max(0.0);
        }
        MixingMatrix { n, data }
    }

    /// Checks the matrix against `graph`: same size, and no positive weight
    /// between two distinct nodes without an edge (the intrinsic properties
    /// are re-checked too).
    ///
    /// # Errors
    /// [`GraphError::SizeMismatch`], [`GraphError::WeightOnNonEdge`], or any
    /// error of [`MixingMatrix::from_rows`].
    ///
    /// ```
    /// use fmsr_graph::{Graph, GraphError, MetropolisHastings, MixingRule};
    ///
    /// let m = MetropolisHastings.mixing_matrix(&Graph::complete(3))?;
    /// assert!(m.validate(&Graph::complete(3)).is_ok());
    /// assert!(matches!(m.validate(&Graph::path(3)), Err(GraphError::WeightOnNonEdge { .. })));
    /// # Ok::<(), GraphError>(())
    /// ```
    pub fn validate(&self, graph: &Graph) -> Result<(), GraphError> {
        check_size(graph, self.n)?;
        check_entries(self.n, &self.data, Some(graph))
    }

    /// Dimension (number of nodes).
    #[must_use]
    pub fn n(&self) -> usize {
        self.n
    }

    /// The entry `M[i][j]`, or `None` if out of range.
    #[must_use]
    pub fn get(&self, i: usize, j: usize) -> Option<f64> {
        if i < self.n && j < self.n { Some(self.data[i * self.n + j]) } else { None }
    }

    /// Row `i`, or `None` if out of range.
    #[must_use]
    pub fn row(&self, i: usize) -> Option<&[f64]> {
        (i < self.n).then(|| &self.data[i * self.n..(i + 1) * self.n])
    }

    /// The rows in order.
    pub fn rows(&self) -> impl ExactSizeIterator<Item = &[f64]> + '_ {
        (0..self.n).map(move |i| &self.data[i * self.n..(i + 1) * self.n])
    }

    /// The rows as owned vectors.
    #[must_use]
    pub fn to_rows(&self) -> Vec<Vec<f64>> {
        self.rows().map(<[f64]>::to_vec).collect()
    }

    /// All entries, row-major.
    #[must_use]
    pub fn as_slice(&self) -> &[f64] {
        &self.data
    }

    /// All eigenvalues in nondecreasing order (symmetric eigen-decomposition
    /// with faer). They lie in `[-1, 1]` and the largest is 1.
    ///
    /// # Errors
    /// [`GraphError::EigenDecomposition`] if the solver does not converge.
    pub fn eigenvalues(&self) -> Result<Vec<f64>, GraphError> {
        let n = self.n;
        if n == 0 {
            return Ok(Vec::new());
        }
        let mat = faer::Mat::<f64>::from_fn(n, n, |i, j| self.data[i * n + j]);
        mat.self_adjoint_eigenvalues(faer::Side::Lower).map_err(|_| GraphError::EigenDecomposition { nodes: n })
    }

    /// The second largest eigenvalue modulus: `max |lambda_i|` over all
    /// eigenvalues except one eigenvalue 1 (0 for `n <= 1`).
    ///
    /// For `y` orthogonal to the all-ones vector, `|M y| <= slem |y|`, so the
    /// disagreement `sum_i |x_i - mean|^2` shrinks by at least `slem^2` per
    /// consensus step. A value of 1 means no convergence: the support of `M`
    /// is disconnected (eigenvalue 1 repeated) or periodic (eigenvalue -1).
    ///
    /// # Errors
    /// [`GraphError::EigenDecomposition`] if the solver does not converge.
    ///
    /// ```
    /// use fmsr_graph::{Graph, MetropolisHastings, MixingRule};
    ///
    /// let m = MetropolisHastings.mixing_matrix(&Graph::ring(4))?;
    /// assert!((m.slem()? - 1.0 / 3.0).abs() < 1e-12);
    /// # Ok::<(), fmsr_graph::GraphError>(())
    /// ```
    pub fn slem(&self) -> Result<f64, GraphError> {
        let eigenvalues = self.eigenvalues()?;
        // Ascending order: the last one is the eigenvalue 1 of the all-ones
        // vector; the modulus of the rest is largest at either end.
        let rest = &eigenvalues[..eigenvalues.len().saturating_sub(1)];
        let slem = match (rest.first(), rest.last()) {
            (Some(lo), Some(hi)) => lo.abs().max(hi.abs()),
            _ => 0.0,
        };
        Ok(slem.min(1.0))
    }

    /// The spectral gap `1 - slem`.
    ///
    /// # Errors
    /// [`GraphError::EigenDecomposition`] if the solver does not converge.
    pub fn spectral_gap(&self) -> Result<f64, GraphError> {
        self.slem().map(|slem| 1.0 - slem)
    }

    /// The per-step contraction factor of consensus on `graph`: the
    /// [`slem`](MixingMatrix::slem), after checking the matrix against the
    /// graph and that consensus is possible at all.
    ///
    /// # Errors
    /// [`GraphError::Disconnected`] if the graph, or the graph formed by the
    /// positive off-diagonal weights of `M`, has more than one component
    /// (`components` counts those of the latter); any error of
    /// [`MixingMatrix::validate`] or [`MixingMatrix::slem`].
    ///
    /// ```
    /// use fmsr_graph::{Graph, GraphError, MetropolisHastings, MixingRule};
    ///
    /// let g = Graph::shadow_hand();
    /// let m = MetropolisHastings.mixing_matrix(&g)?;
    /// assert_eq!(m.convergence_rate(&g), Err(GraphError::Disconnected { components: 2 }));
    /// # Ok::<(), GraphError>(())
    /// ```
    pub fn convergence_rate(&self, graph: &Graph) -> Result<f64, GraphError> {
        self.validate(graph)?;
        let n = self.n;
        let components = components_of(n, |i| (0..n).filter(move |&j| j != i && self.data[i * n + j] > 0.0)).len();
        if components > 1 {
            return Err(GraphError::Disconnected { components });
        }
        self.slem()
    }

    /// One consensus step `x_i <- sum_j M[i][j] x_j`, in place, over `n`
    /// vectors of equal length. Builds a temporary [`Mixer`]; keep one around
    /// to avoid the (small) allocations when mixing repeatedly.
    ///
    /// # Errors
    /// [`GraphError::WrongCount`] if `xs.len() != n`,
    /// [`GraphError::UnequalLengths`] if a vector's length differs from the
    /// first one's. Nothing is modified on error.
    ///
    /// ```
    /// use fmsr_graph::{Graph, MetropolisHastings, MixingRule};
    ///
    /// let m = MetropolisHastings.mixing_matrix(&Graph::path(2))?;
    /// let mut xs = vec![vec![1.0_f32, 0.0], vec![3.0, 2.0]];
    /// m.mix(&mut xs)?;
    /// assert_eq!(xs, vec![vec![2.0, 1.0], vec![2.0, 1.0]]);
    /// # Ok::<(), fmsr_graph::GraphError>(())
    /// ```
    pub fn mix(&self, xs: &mut [Vec<f32>]) -> Result<(), GraphError> {
        Mixer::new(self).mix(xs)
    }

    /// [`MixingMatrix::mix`] over borrowed slices.
    ///
    /// # Errors
    /// As [`MixingMatrix::mix`].
    pub fn mix_slices(&self, xs: &mut [&mut [f32]]) -> Result<(), GraphError> {
        Mixer::new(self).mix_slices(xs)
    }
}

/// A rule that turns a graph into a mixing matrix whose weights respect it.
///
/// Implement it in your own crate for new weighting schemes; the result is
/// expected to pass [`MixingMatrix::validate`] against the graph.
pub trait MixingRule {
    /// Builds the mixing matrix for `graph`.
    ///
    /// # Errors
    /// Whatever the rule rejects (invalid parameters, matrices that do not
    /// fit the graph).
    fn mixing_matrix(&self, graph: &Graph) -> Result<MixingMatrix, GraphError>;
}

impl<R: MixingRule + ?Sized> MixingRule for &R {
    fn mixing_matrix(&self, graph: &Graph) -> Result<MixingMatrix, GraphError> {
        (**self).mixing_matrix(graph)
    }
}

impl<R: MixingRule + ?Sized> MixingRule for Box<R> {
    fn mixing_matrix(&self, graph: &Graph) -> Result<MixingMatrix, GraphError> {
        (**self).mixing_matrix(graph)
    }
}

/// Metropolis-Hastings weights: `M[i][j] = 1 / (1 + max(d_i, d_j))` on each
/// edge, `M[i][i] = 1 - sum_{j != i} M[i][j]`, 0 elsewhere. Only local degree
/// information is needed; an isolated node keeps its own value.
///
/// ```
/// use fmsr_graph::{Graph, MetropolisHastings, MixingRule};
///
/// // Star with center 0: d_0 = 2, the leaves have degree 1.
/// let m = MetropolisHastings.mixing_matrix(&Graph::star(3, 0)?)?;
/// let (a, b) = (1.0 / 3.0, 2.0 / 3.0);
/// let expected = [[a, a, a], [a, b, 0.0], [a, 0.0, b]];
/// for (row, want) in m.rows().zip(expected) {
///     assert!(row.iter().zip(want).all(|(x, y)| (x - y).abs() < 1e-15));
/// }
/// # Ok::<(), fmsr_graph::GraphError>(())
/// ```
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct MetropolisHastings;

impl MetropolisHastings {
    /// The matrix, infallibly (the rule accepts every graph).
    #[must_use]
    pub fn matrix(graph: &Graph) -> MixingMatrix {
        let degrees: Vec<usize> = (0..graph.nodes()).map(|i| graph.neighbors(i).map_or(0, <[usize]>::len)).collect();
        MixingMatrix::from_edge_weights(graph, |i, j| 1.0 / (1.0 + degrees[i].max(degrees[j]) as f64))
    }
}

impl MixingRule for MetropolisHastings {
    fn mixing_matrix(&self, graph: &Graph) -> Result<MixingMatrix, GraphError> {
        Ok(MetropolisHastings::matrix(graph))
    }
}

/// Maximum-degree weights: `M[i][j] = 1 / (1 + d_max)` on each edge,
/// `M[i][i] = 1 - d_i / (1 + d_max)`, 0 elsewhere.
///
/// ```
/// use fmsr_graph::{Graph, MaxDegree, MixingRule};
///
/// // On the complete graph every entry is 1/n: consensus in one step.
/// let m = MaxDegree.mixing_matrix(&Graph::complete(4))?;
/// assert!(m.as_slice().iter().all(|&w| w == 0.25));
/// assert!(m.slem()? < 1e-12);
/// # Ok::<(), fmsr_graph::GraphError>(())
/// ```
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct MaxDegree;

impl MixingRule for MaxDegree {
    fn mixing_matrix(&self, graph: &Graph) -> Result<MixingMatrix, GraphError> {
        let w = 1.0 / (1.0 + graph.max_degree() as f64);
        Ok(MixingMatrix::from_edge_weights(graph, |_, _| w))
    }
}

/// The lazy version of another rule: `(1 - alpha) I + alpha M_inner`, with
/// `alpha` in `(0, 1]`. Laziness makes every eigenvalue at least
/// `1 - 2 alpha`, which removes oscillation (eigenvalue -1) for
/// `alpha < 1`.
///
/// ```
/// use fmsr_graph::{Graph, GraphError, Lazy, MetropolisHastings, MixingRule};
///
/// let m = Lazy::new(MetropolisHastings, 0.5)?.mixing_matrix(&Graph::path(2))?;
/// assert_eq!(m.to_rows(), vec![vec![0.75, 0.25], vec![0.25, 0.75]]);
/// assert_eq!(Lazy::new(MetropolisHastings, 0.0).err(), Some(GraphError::InvalidLaziness { alpha: 0.0 }));
/// # Ok::<(), GraphError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Lazy<R> {
    /// The rule being made lazy.
    pub inner: R,
    /// Weight of the inner rule, in `(0, 1]`.
    pub alpha: f64,
}

/// Checks that a laziness parameter lies in `(0, 1]`.
fn check_alpha(alpha: f64) -> Result<(), GraphError> {
    if alpha > 0.0 && alpha <= 1.0 { Ok(()) } else { Err(GraphError::InvalidLaziness { alpha }) }
}

impl<R: MixingRule> Lazy<R> {
    /// Wraps `inner`, checking `alpha`.
    ///
    /// # Errors
    /// [`GraphError::InvalidLaziness`] unless `0 < alpha <= 1`.
    pub fn new(inner: R, alpha: f64) -> Result<Lazy<R>, GraphError> {
        check_alpha(alpha)?;
        Ok(Lazy { inner, alpha })
    }
}

impl<R: MixingRule> MixingRule for Lazy<R> {
    fn mixing_matrix(&self, graph: &Graph) -> Result<MixingMatrix, GraphError> {
        check_alpha(self.alpha)?;
        let inner = self.inner.mixing_matrix(graph)?;
        inner.validate(graph)?;
        let n = inner.n;
        let mut data: Vec<f64> = inner.data.iter().map(|w| self.alpha * w).collect();
        for i in 0..n {
            data[i * n + i] += 1.0 - self.alpha;
        }
        Ok(MixingMatrix { n, data })
    }
}

/// A matrix given by the user (for instance from a config file), validated
/// against the graph when turned into a [`MixingMatrix`].
///
/// ```
/// use fmsr_graph::{Graph, GraphError, MixingRule, UserMatrix};
///
/// let g = Graph::path(2);
/// let ok = UserMatrix { rows: vec![vec![0.9, 0.1], vec![0.1, 0.9]] };
/// assert_eq!(ok.mixing_matrix(&g)?.get(0, 1), Some(0.1));
/// let neg = UserMatrix { rows: vec![vec![1.1, -0.1], vec![-0.1, 1.1]] };
/// assert!(matches!(neg.mixing_matrix(&g), Err(GraphError::NegativeEntry { row: 0, col: 1, .. })));
/// # Ok::<(), GraphError>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct UserMatrix {
    /// The rows of the matrix.
    pub rows: Vec<Vec<f64>>,
}

impl MixingRule for UserMatrix {
    /// Validates, in this order: square ([`GraphError::NotSquare`]), size
    /// equal to the number of nodes ([`GraphError::SizeMismatch`]), finite,
    /// nonnegative, no weight on a non-edge, row sums, column sums,
    /// symmetry.
    fn mixing_matrix(&self, graph: &Graph) -> Result<MixingMatrix, GraphError> {
        let n = check_square(&self.rows)?;
        check_size(graph, n)?;
        let data: Vec<f64> = self.rows.iter().flatten().copied().collect();
        check_entries(n, &data, Some(graph))?;
        Ok(MixingMatrix { n, data })
    }
}
