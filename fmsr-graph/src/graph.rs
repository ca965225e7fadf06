//! Undirected communication graphs between agents.

use std::collections::VecDeque;

use serde::{Deserialize, Serialize};

use crate::GraphError;

/// Names of the six Shadow Hand agents, in the actuator order of the model
/// (node `i` of [`Graph::shadow_hand`] is `SHADOW_HAND_AGENTS[i]`).
pub const SHADOW_HAND_AGENTS: [&str; 6] = ["wrist", "index", "middle", "ring", "little", "thumb"];

/// The largest number of nodes [`Graph::from_edges`] (and deserialisation)
/// accepts. A dense mixing matrix on this many nodes already holds 2^32
/// entries.
pub const MAX_NODES: usize = 1 << 16;

/// An undirected graph on `n` nodes `0..n`, optionally with unique node names.
///
/// Edges are stored normalised: each edge `(i, j)` has `i < j`, the list is
/// sorted and free of duplicates, and self-loops are rejected. Deserialising
/// runs the same validation as [`Graph::from_edges`] and [`Graph::with_names`].
///
/// ```
/// use fmsr_graph::Graph;
///
/// let g = Graph::from_edges(4, &[(1, 0), (2, 1), (0, 1)])?;
/// assert_eq!(g.edges(), &[(0, 1), (1, 2)]);
/// assert_eq!(g.components(), vec![vec![0, 1, 2], vec![3]]);
/// # Ok::<(), fmsr_graph::GraphError>(())
/// ```
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(try_from = "GraphRepr", into = "GraphRepr")]
pub struct Graph {
    nodes: usize,
    names: Option<Vec<String>>,
    edges: Vec<(usize, usize)>,
    adjacency: Vec<Vec<usize>>,
}

/// Serialised form of a [`Graph`].
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct GraphRepr {
    nodes: usize,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    names: Option<Vec<String>>,
    edges: Vec<(usize, usize)>,
}

impl TryFrom<GraphRepr> for Graph {
    type Error = GraphError;

    fn try_from(repr: GraphRepr) -> Result<Self, Self::Error> {
        let graph = Graph::from_edges(repr.nodes, &repr.edges)?;
        match repr.names {
            Some(names) => graph.with_names(names),
            None => Ok(graph),
        }
    }
}

impl From<Graph> for GraphRepr {
    fn from(graph: Graph) -> Self {
        GraphRepr { nodes: graph.nodes, names: graph.names, edges: graph.edges }
    }
}

impl Graph {
    /// Builds a graph from already normalised edges (i < j, sorted, unique,
    /// in range).
    fn from_normalised(nodes: usize, edges: Vec<(usize, usize)>) -> Graph {
        let mut adjacency = vec![Vec::new(); nodes];
        for &(i, j) in &edges {
            adjacency[i].push(j);
            adjacency[j].push(i);
        }
        for list in &mut adjacency {
            list.sort_unstable();
        }
        Graph { nodes, names: None, edges, adjacency }
    }

    /// A graph with `n` nodes and no edges.
    ///
    /// ```
    /// let g = fmsr_graph::Graph::empty(3);
    /// assert_eq!(g.nodes(), 3);
    /// assert!(g.edges().is_empty());
    /// ```
    #[must_use]
    pub fn empty(n: usize) -> Graph {
        Graph::from_normalised(n, Vec::new())
    }

    /// The cycle `0-1-...-(n-1)-0`. For `n = 2` this is the single edge
    /// `0-1`; for `n < 2` there are no edges.
    ///
    /// ```
    /// let g = fmsr_graph::Graph::ring(4);
    /// assert_eq!(g.edges(), &[(0, 1), (0, 3), (1, 2), (2, 3)]);
    /// assert!(g.neighbors(0)?.contains(&3));
    /// # Ok::<(), fmsr_graph::GraphError>(())
    /// ```
    #[must_use]
    pub fn ring(n: usize) -> Graph {
        let mut edges: Vec<(usize, usize)> = (1..n).map(|i| (i - 1, i)).collect();
        if n >= 3 {
            edges.push((0, n - 1));
        }
        edges.sort_unstable();
        Graph::from_normalised(n, edges)
    }

    /// The path `0-1-...-(n-1)`.
    ///
    /// ```
    /// let g = fmsr_graph::Graph::path(3);
    /// assert_eq!(g.edges(), &[(0, 1), (1, 2)]);
    /// assert_eq!(g.max_degree(), 2);
    /// ```
    #[must_use]
    pub fn path(n: usize) -> Graph {
        Graph::from_normalised(n, (1..n).map(|i| (i - 1, i)).collect())
    }

    /// The complete graph: every pair of distinct nodes shares an edge.
    ///
    /// ```
    /// let g = fmsr_graph::Graph::complete(4);
    /// assert_eq!(g.edges().len(), 6);
    /// assert_eq!(g.degree(2)?, 3);
    /// # Ok::<(), fmsr_graph::GraphError>(())
    /// ```
    #[must_use]
    pub fn complete(n: usize) -> Graph {
        let edges = (0..n).flat_map(|i| (i + 1..n).map(move |j| (i, j))).collect();
        Graph::from_normalised(n, edges)
    }

    /// The star with every other node joined to `center`.
    ///
    /// # Errors
    /// [`GraphError::NodeOutOfRange`] if `center >= n`.
    ///
    /// ```
    /// let g = fmsr_graph::Graph::star(4, 2)?;
    /// assert_eq!(g.edges(), &[(0, 2), (1, 2), (2, 3)]);
    /// assert!(fmsr_graph::Graph::star(4, 4).is_err());
    /// # Ok::<(), fmsr_graph::GraphError>(())
    /// ```
    #[must_use = "the graph is returned, not stored"]
    pub fn star(n: usize, center: usize) -> Result<Graph, GraphError> {
        if center >= n {
            return Err(GraphError::NodeOutOfRange { node: center, nodes: n });
        }
        let mut edges: Vec<(usize, usize)> =
            (0..n).filter(|&i| i != center).map(|i| (i.min(center), i.max(center))).collect();
        edges.sort_unstable();
        Ok(Graph::from_normalised(n, edges))
    }

    /// A graph with `n` nodes and the given undirected edges, in any order
    /// and orientation; duplicates are merged.
    ///
    /// # Errors
    /// [`GraphError::NodeOutOfRange`] for an endpoint `>= n`,
    /// [`GraphError::SelfLoopEdge`] for an edge `(i, i)`,
    /// [`GraphError::TooManyNodes`] if `n > MAX_NODES` (this guards
    /// deserialisation against absurd sizes).
    ///
    /// ```
    /// use fmsr_graph::{Graph, GraphError};
    ///
    /// let g = Graph::from_edges(3, &[(2, 0), (0, 2), (1, 0)])?;
    /// assert_eq!(g.edges(), &[(0, 1), (0, 2)]);
    /// assert_eq!(Graph::from_edges(3, &[(1, 1)]), Err(GraphError::SelfLoopEdge { node: 1 }));
    /// # Ok::<(), GraphError>(())
    /// ```
    #[must_use = "the graph is returned, not stored"]
    pub fn from_edges(n: usize, edges: &[(usize, usize)]) -> Result<Graph, GraphError> {
        if n > MAX_NODES {
            return Err(GraphError::TooManyNodes { nodes: n, max: MAX_NODES });
        }
        let mut normalised = Vec::with_capacity(edges.len());
        for &(a, b) in edges {
            for node in [a, b] {
                if node >= n {
                    return Err(GraphError::NodeOutOfRange { node, nodes: n });
                }
            }
            if a == b {
                return Err(GraphError::SelfLoopEdge { node: a });
            }
            normalised.push((a.min(b), a.max(b)));
        }
        normalised.sort_unstable();
        normalised.dedup();
        Ok(Graph::from_normalised(n, normalised))
    }

    /// The paper's default information-sharing topology on the six Shadow
    /// Hand agents, in the actuator order of the model: 0 wrist, 1 index,
    /// 2 middle, 3 ring, 4 little, 5 thumb (see [`SHADOW_HAND_AGENTS`]).
    ///
    /// The fingers form the ring thumb-index-middle-ring-little-thumb (edges
    /// 5-1, 1-2, 2-3, 3-4, 4-5); the wrist is its own node without edges, so
    /// the graph has two components and consensus happens among the fingers
    /// only.
    ///
    /// ```
    /// let g = fmsr_graph::Graph::shadow_hand();
    /// assert_eq!(g.index_of("thumb"), Some(5));
    /// assert!(g.has_edge(5, 1) && g.has_edge(4, 5));
    /// assert_eq!(g.degree(0)?, 0);
    /// assert_eq!(g.components(), vec![vec![0], vec![1, 2, 3, 4, 5]]);
    /// # Ok::<(), fmsr_graph::GraphError>(())
    /// ```
    #[must_use]
    pub fn shadow_hand() -> Graph {
        let mut graph = Graph::from_normalised(6, vec![(1, 2), (1, 5), (2, 3), (3, 4), (4, 5)]);
        graph.names = Some(SHADOW_HAND_AGENTS.iter().map(|s| (*s).to_owned()).collect());
        graph
    }

    /// The same graph with the given node names (one per node, unique).
    ///
    /// # Errors
    /// [`GraphError::WrongCount`] if there is not exactly one name per node,
    /// [`GraphError::DuplicateName`] if a name repeats.
    ///
    /// ```
    /// let g = fmsr_graph::Graph::path(2).with_names(vec!["a".into(), "b".into()])?;
    /// assert_eq!(g.index_of("b"), Some(1));
    /// assert_eq!(g.name(0), Some("a"));
    /// # Ok::<(), fmsr_graph::GraphError>(())
    /// ```
    #[must_use = "the graph is returned, not stored"]
    pub fn with_names(mut self, names: Vec<String>) -> Result<Graph, GraphError> {
        if names.len() != self.nodes {
            return Err(GraphError::WrongCount { expected: self.nodes, found: names.len() });
        }
        let mut sorted: Vec<&String> = names.iter().collect();
        sorted.sort_unstable();
        if let Some(pair) = sorted.windows(2).find(|w| w[0] == w[1]) {
            return Err(GraphError::DuplicateName { name: pair[0].clone() });
        }
        self.names = Some(names);
        Ok(self)
    }

    /// Number of nodes.
    #[must_use]
    pub fn nodes(&self) -> usize {
        self.nodes
    }

    /// The normalised edges: `i < j`, sorted, unique.
    #[must_use]
    pub fn edges(&self) -> &[(usize, usize)] {
        &self.edges
    }

    /// The neighbours of node `i`, sorted ascending.
    ///
    /// # Errors
    /// [`GraphError::NodeOutOfRange`] if `i >= self.nodes()`.
    pub fn neighbors(&self, i: usize) -> Result<&[usize], GraphError> {
        self.adjacency.get(i).map(Vec::as_slice).ok_or(GraphError::NodeOutOfRange { node: i, nodes: self.nodes })
    }

    /// The degree (number of neighbours) of node `i`.
    ///
    /// # Errors
    /// [`GraphError::NodeOutOfRange`] if `i >= self.nodes()`.
    pub fn degree(&self, i: usize) -> Result<usize, GraphError> {
        self.neighbors(i).map(<[usize]>::len)
    }

    /// The largest degree (0 for a graph without edges or nodes).
    #[must_use]
    pub fn max_degree(&self) -> usize {
        self.adjacency.iter().map(Vec::len).max().unwrap_or(0)
    }

    /// Whether `i` and `j` share an edge (in either orientation). Out-of-range
    /// nodes and `i == j` give `false`.
    #[must_use]
    pub fn has_edge(&self, i: usize, j: usize) -> bool {
        self.adjacency.get(i).is_some_and(|list| list.binary_search(&j).is_ok())
    }

    /// The connected components, each sorted ascending, ordered by their
    /// smallest node. Isolated nodes are their own components.
    #[must_use]
    pub fn components(&self) -> Vec<Vec<usize>> {
        components_of(self.nodes, |i| self.adjacency[i].iter().copied())
    }

    /// Whether the graph has at most one connected component (graphs with 0
    /// or 1 node are connected).
    #[must_use]
    pub fn is_connected(&self) -> bool {
        self.components().len() <= 1
    }

    /// The node names, if any were given.
    #[must_use]
    pub fn names(&self) -> Option<&[String]> {
        self.names.as_deref()
    }

    /// The name of node `i`, if the graph has names and `i` is in range.
    #[must_use]
    pub fn name(&self, i: usize) -> Option<&str> {
        self.names.as_ref()?.get(i).map(String::as_str)
    }

    /// The index of the node with the given name.
    #[must_use]
    pub fn index_of(&self, name: &str) -> Option<usize> {
        self.names.as_ref()?.iter().position(|n| n == name)
    }
}

/// Connected components of the graph on `n` nodes given by `neighbors`.
pub(crate) fn components_of<I, F>(n: usize, neighbors: F) -> Vec<Vec<usize>>
where
    I: Iterator<Item = usize>,
    F: Fn(usize) -> I,
{
    let mut seen = vec![false; n];
    let mut components = Vec::new();
    let mut queue = VecDeque::new();
    for start in 0..n {
        if seen[start] {
            continue;
        }
        seen[start] = true;
        queue.push_back(start);
        let mut component = Vec::new();
        while let Some(node) = queue.pop_front() {
            component.push(node);
            for next in neighbors(node) {
                if !seen[next] {
                    seen[next] = true;
                    queue.push_back(next);
                }
            }
        }
        component.sort_unstable();
        components.push(component);
    }
    components
}

/// A source of communication graphs.
///
/// Implement it in your own crate to describe a new topology (for instance
/// one built from a configuration file); [`Graph`] implements it by cloning
/// itself.
///
/// ```
/// use fmsr_graph::{Graph, GraphError, Topology};
///
/// /// The fingers' ring of the Shadow Hand plus the wrist joined to the thumb.
/// struct WristToThumb;
///
/// impl Topology for WristToThumb {
///     fn graph(&self) -> Result<Graph, GraphError> {
///         let base = Graph::shadow_hand();
///         let mut edges = base.edges().to_vec();
///         edges.push((0, 5));
///         let names = base.names().map(<[String]>::to_vec).unwrap_or_default();
///         Graph::from_edges(base.nodes(), &edges)?.with_names(names)
///     }
/// }
///
/// assert!(WristToThumb.graph()?.is_connected());
/// # Ok::<(), GraphError>(())
/// ```
pub trait Topology {
    /// Builds the graph.
    ///
    /// # Errors
    /// Whatever validation error the construction hits.
    fn graph(&self) -> Result<Graph, GraphError>;
}

impl Topology for Graph {
    fn graph(&self) -> Result<Graph, GraphError> {
        Ok(self.clone())
    }
}
