//! The single error type of the crate.

use thiserror::Error;

/// Everything that can go wrong when building graphs, mixing matrices or
/// running consensus steps.
///
/// Every variant carries the indices and values needed to locate the problem.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum GraphError {
    /// A matrix is not square (or a row has a different length than the
    /// number of rows).
    #[error("matrix is not square: {rows} rows but a row has {cols} columns")]
    NotSquare {
        /// Number of rows.
        rows: usize,
        /// Length of the offending row.
        cols: usize,
    },
    /// A matrix entry is negative.
    #[error("negative entry {value} at ({row}, {col})")]
    NegativeEntry {
        /// Row of the entry.
        row: usize,
        /// Column of the entry.
        col: usize,
        /// The entry.
        value: f64,
    },
    /// A row does not sum to 1 (within [`TOLERANCE`](crate::TOLERANCE)).
    #[error("row {row} sums to {sum}, expected 1")]
    RowSum {
        /// The offending row.
        row: usize,
        /// Its sum.
        sum: f64,
    },
    /// A column does not sum to 1 (within [`TOLERANCE`](crate::TOLERANCE)).
    #[error("column {col} sums to {sum}, expected 1")]
    ColumnSum {
        /// The offending column.
        col: usize,
        /// Its sum.
        sum: f64,
    },
    /// `M[row][col] != M[col][row]` (beyond [`TOLERANCE`](crate::TOLERANCE)),
    /// with `row < col`.
    #[error("matrix is not symmetric: M[{row}][{col}] = {upper} but M[{col}][{row}] = {lower}")]
    Asymmetric {
        /// Row of the upper-triangle entry.
        row: usize,
        /// Column of the upper-triangle entry.
        col: usize,
        /// `M[row][col]`.
        upper: f64,
        /// `M[col][row]`.
        lower: f64,
    },
    /// A positive off-diagonal weight between two nodes that share no edge.
    #[error("weight {value} at ({row}, {col}) but the graph has no edge {row}-{col}")]
    WeightOnNonEdge {
        /// Row of the entry.
        row: usize,
        /// Column of the entry.
        col: usize,
        /// The entry.
        value: f64,
    },
    /// A matrix entry is NaN or infinite.
    #[error("entry at ({row}, {col}) is not finite")]
    NotFinite {
        /// Row of the entry.
        row: usize,
        /// Column of the entry.
        col: usize,
    },
    /// A node index is not smaller than the number of nodes.
    #[error("node {node} out of range for a graph of {nodes} nodes")]
    NodeOutOfRange {
        /// The offending index.
        node: usize,
        /// Number of nodes of the graph.
        nodes: usize,
    },
    /// More nodes than [`MAX_NODES`](crate::MAX_NODES) requested from
    /// [`Graph::from_edges`](crate::Graph::from_edges) (and so from
    /// deserialisation).
    #[error("{nodes} nodes requested, at most {max} supported")]
    TooManyNodes {
        /// Requested number of nodes.
        nodes: usize,
        /// The limit.
        max: usize,
    },
    /// An edge from a node to itself.
    #[error("self-loop edge at node {node}")]
    SelfLoopEdge {
        /// The node.
        node: usize,
    },
    /// The matrix size does not match the number of graph nodes.
    #[error("matrix is {found}x{found} but the graph has {expected} nodes")]
    SizeMismatch {
        /// Number of graph nodes.
        expected: usize,
        /// Matrix dimension.
        found: usize,
    },
    /// A vector passed to a consensus step has a different length than the
    /// first one.
    #[error("vector {index} has length {found}, expected {expected}")]
    UnequalLengths {
        /// Index of the offending vector.
        index: usize,
        /// Length of the first vector.
        expected: usize,
        /// Length of the offending vector.
        found: usize,
    },
    /// Wrong number of items (vectors for a consensus step, names for a
    /// graph).
    #[error("expected {expected} items, found {found}")]
    WrongCount {
        /// Expected count (usually the number of nodes).
        expected: usize,
        /// Count found.
        found: usize,
    },
    /// Two nodes share a name.
    #[error("duplicate node name {name:?}")]
    DuplicateName {
        /// The repeated name.
        name: String,
    },
    /// The graph (or the support of the mixing matrix) has more than one
    /// connected component, so consensus over all nodes is impossible.
    #[error("graph has {components} connected components, consensus cannot be reached")]
    Disconnected {
        /// Number of connected components.
        components: usize,
    },
    /// The laziness `alpha` of [`Lazy`](crate::Lazy) is outside `(0, 1]`.
    #[error("laziness alpha = {alpha} is outside (0, 1]")]
    InvalidLaziness {
        /// The offending value.
        alpha: f64,
    },
    /// The symmetric eigen-decomposition did not converge.
    #[error("eigen-decomposition of the {nodes}x{nodes} mixing matrix did not converge")]
    EigenDecomposition {
        /// Matrix dimension.
        nodes: usize,
    },
}
