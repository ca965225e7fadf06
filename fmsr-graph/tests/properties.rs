//! Property tests guarding the guarantees the trainers rely on:
//!
//! - every mixing rule (Metropolis-Hastings, max-degree, and the lazy version
//!   of each) yields a symmetric, nonnegative, doubly stochastic matrix with
//!   weight only on graph edges and the diagonal, on random connected graphs
//!   of 2-30 nodes (a random spanning tree plus random extra edges);
//! - consensus steps preserve the average of the vectors and shrink the
//!   disagreement at least by `slem^2` per step;
//! - on a graph with two components consensus is never reached, and
//!   `convergence_rate` reports `Disconnected`;
//! - corrupted matrices (negated entry, scaled row, broken symmetry, weight
//!   on a non-edge, NaN/inf, dropped row, wrong size) are rejected with the
//!   error variant that names the problem.

use fmsr_graph::prelude::*;
use proptest::prelude::*;
use proptest::sample::Index;

/// A random connected graph: node `k >= 1` hangs off a random earlier node
/// (a random spanning tree), plus random extra edges.
#[derive(Debug, Clone)]
struct RandomGraph {
    n: usize,
    /// `parent[k - 1]` is the tree parent of node `k`.
    parent: Vec<usize>,
    extra: Vec<(usize, usize)>,
}

impl RandomGraph {
    fn edges(&self) -> Vec<(usize, usize)> {
        let mut edges: Vec<(usize, usize)> = self.parent.iter().enumerate().map(|(k, &p)| (p, k + 1)).collect();
        edges.extend(self.extra.iter().copied().filter(|(a, b)| a != b));
        edges
    }

    fn graph(&self) -> Graph {
        Graph::from_edges(self.n, &self.edges()).expect("valid random graph")
    }
}

fn random_graph(nodes: std::ops::RangeInclusive<usize>) -> impl Strategy<Value = RandomGraph> {
    nodes.prop_flat_map(|n| {
        (
            prop::collection::vec(any::<Index>(), n - 1),
            prop::collection::vec((any::<Index>(), any::<Index>()), 0..=2 * n),
        )
            .prop_map(move |(parents, extra)| RandomGraph {
                n,
                parent: parents.iter().enumerate().map(|(k, ix)| ix.index(k + 1)).collect(),
                extra: extra.iter().map(|(a, b)| (a.index(n), b.index(n))).collect(),
            })
    })
}

/// Which rule to use, with the laziness of the lazy variants.
#[derive(Debug, Clone, Copy)]
enum Rule {
    Mh,
    MaxDeg,
    LazyMh(f64),
    LazyMaxDeg(f64),
}

fn rule() -> impl Strategy<Value = Rule> {
    prop_oneof![
        Just(Rule::Mh),
        Just(Rule::MaxDeg),
        (0.05..=1.0_f64).prop_map(Rule::LazyMh),
        (0.05..=1.0_f64).prop_map(Rule::LazyMaxDeg),
    ]
}

fn matrix(rule: Rule, graph: &Graph) -> MixingMatrix {
    match rule {
        Rule::Mh => MetropolisHastings.mixing_matrix(graph),
        Rule::MaxDeg => MaxDegree.mixing_matrix(graph),
        Rule::LazyMh(alpha) => Lazy::new(MetropolisHastings, alpha).and_then(|lazy| lazy.mixing_matrix(graph)),
        Rule::LazyMaxDeg(alpha) => Lazy::new(MaxDegree, alpha).and_then(|lazy| lazy.mixing_matrix(graph)),
    }
    .expect("rules accept every graph")
}

/// Vectors of one length, one per node, with values in [-10, 10].
fn vectors(n: usize) -> impl Strategy<Value = Vec<Vec<f32>>> {
    (1usize..20).prop_flat_map(move |len| prop::collection::vec(prop::collection::vec(-10.0_f32..10.0, len), n))
}

fn graph_and_vectors() -> impl Strategy<Value = (RandomGraph, Vec<Vec<f32>>)> {
    random_graph(2..=30).prop_flat_map(|g| {
        let n = g.n;
        (Just(g), vectors(n))
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn rules_give_symmetric_doubly_stochastic_matrices_on_the_graph(
        g in random_graph(2..=30),
        rule in rule(),
    ) {
        let graph = g.graph();
        prop_assert!(graph.is_connected());
        let m = matrix(rule, &graph);
        let n = graph.nodes();
        prop_assert_eq!(m.n(), n);
        prop_assert!(m.validate(&graph).is_ok());
        for i in 0..n {
            let row_sum: f64 = (0..n).map(|j| m.get(i, j).unwrap()).sum();
            let col_sum: f64 = (0..n).map(|j| m.get(j, i).unwrap()).sum();
            prop_assert!((row_sum - 1.0).abs() < 1e-12, "row {} sums to {}", i, row_sum);
            prop_assert!((col_sum - 1.0).abs() < 1e-12, "col {} sums to {}", i, col_sum);
            for j in 0..n {
                let w = m.get(i, j).unwrap();
                prop_assert!(w >= 0.0 && w.is_finite());
                prop_assert_eq!(w, m.get(j, i).unwrap());
                if i != j {
                    // Positive exactly on the edges.
                    prop_assert_eq!(w > 0.0, graph.has_edge(i, j), "({}, {}) = {}", i, j, w);
                }
            }
        }
        let slem = m.slem().unwrap();
        // Connected with a positive diagonal everywhere: aperiodic, so slem < 1.
        prop_assert!((0.0..1.0).contains(&slem), "slem = {}", slem);
        prop_assert!((m.spectral_gap().unwrap() - (1.0 - slem)).abs() < 1e-15);
    }

    // Guards each rule's weights, entry by entry, on random graphs: the
    // checks above hold for any valid matrix, so a rule returning another
    // rule's weights (max-degree built as Metropolis-Hastings, which agree on
    // regular graphs, the only ones the known values use for max-degree) or
    // a lazy matrix with the wrong alpha would pass them.
    #[test]
    fn rules_give_their_own_weights(
        g in random_graph(2..=30),
        alpha in 0.05..=1.0_f64,
    ) {
        let graph = g.graph();
        let n = graph.nodes();
        let degree = |i: usize| graph.degree(i).unwrap() as f64;
        let d_max = (0..n).map(degree).fold(0.0, f64::max);
        let mh = matrix(Rule::Mh, &graph);
        let maxdeg = matrix(Rule::MaxDeg, &graph);
        let lazy_mh = matrix(Rule::LazyMh(alpha), &graph);
        let lazy_maxdeg = matrix(Rule::LazyMaxDeg(alpha), &graph);
        for i in 0..n {
            for j in 0..n {
                let (want_mh, want_maxdeg) = if i == j {
                    let rest: f64 = graph.neighbors(i).unwrap().iter().map(|&k| 1.0 / (1.0 + degree(i).max(degree(k)))).sum();
                    (1.0 - rest, 1.0 - degree(i) / (1.0 + d_max))
                } else if graph.has_edge(i, j) {
                    (1.0 / (1.0 + degree(i).max(degree(j))), 1.0 / (1.0 + d_max))
                } else {
                    (0.0, 0.0)
                };
                let eye = if i == j { 1.0 } else { 0.0 };
                for (what, m, want) in [
                    ("MH", &mh, want_mh),
                    ("max-degree", &maxdeg, want_maxdeg),
                    ("lazy MH", &lazy_mh, (1.0 - alpha) * eye + alpha * want_mh),
                    ("lazy max-degree", &lazy_maxdeg, (1.0 - alpha) * eye + alpha * want_maxdeg),
                ] {
                    let got = m.get(i, j).unwrap();
                    prop_assert!((got - want).abs() < 1e-12, "{} ({}, {}) = {}, expected {}", what, i, j, got, want);
                }
            }
        }
    }

    #[test]
    fn mixing_preserves_average_and_contracts_by_slem_squared(
        (g, xs) in graph_and_vectors(),
        rule in rule(),
        steps in 1usize..30,
    ) {
        let graph = g.graph();
        let m = matrix(rule, &graph);
        let slem = m.convergence_rate(&graph).unwrap();
        let cg = ConsensusGraph::with_matrix(graph, m).unwrap();
        let mean0 = cg.average(&xs).unwrap();
        let d0 = cg.disagreement(&xs).unwrap();
        let elements = (xs.len() * xs[0].len()) as f64;
        let tol = 1e-5 * (d0 + elements);
        let mut xs = xs;
        let mut mixer = cg.mixer();
        for k in 1..=steps {
            if k % 2 == 0 {
                mixer.mix(&mut xs).unwrap();
            } else {
                cg.mix(&mut xs).unwrap();
            }
            let mean = cg.average(&xs).unwrap();
            for (a, b) in mean.iter().zip(&mean0) {
                prop_assert!((a - b).abs() < 1e-4, "step {}: average {} drifted from {}", k, a, b);
            }
            let d = cg.disagreement(&xs).unwrap();
            let bound = slem.powi(2 * k as i32) * d0;
            prop_assert!(d <= bound + tol, "step {}: disagreement {} > slem^2k D0 = {}", k, d, bound);
        }
    }

    #[test]
    fn two_components_never_reach_consensus(
        a in random_graph(1..=15),
        b in random_graph(1..=15),
        rule in rule(),
        offset in prop_oneof![-20.0_f32..-1.0, 1.0_f32..20.0],
        len in 1usize..8,
        seed in prop::collection::vec(-5.0_f32..5.0, 30 * 8),
    ) {
        let (na, nb) = (a.n, b.n);
        let n = na + nb;
        let mut edges = a.edges();
        edges.extend(b.edges().iter().map(|&(i, j)| (i + na, j + na)));
        let graph = Graph::from_edges(n, &edges).unwrap();
        prop_assert_eq!(graph.components().len(), 2);
        let m = matrix(rule, &graph);
        prop_assert_eq!(m.convergence_rate(&graph), Err(GraphError::Disconnected { components: 2 }));
        prop_assert!(m.slem().unwrap() > 1.0 - 1e-9);

        let mut xs: Vec<Vec<f32>> = (0..n)
            .map(|i| {
                let shift = if i < na { 0.0 } else { offset };
                (0..len).map(|e| seed[i * 8 + e] + shift).collect()
            })
            .collect();
        // Each component keeps its own average, so the disagreement can never
        // drop below that of the component averages.
        let mean_a = average(&xs[..na]).unwrap();
        let mean_b = average(&xs[na..]).unwrap();
        let mean = average(&xs).unwrap();
        let floor: f64 = (0..len)
            .map(|e| na as f64 * (mean_a[e] - mean[e]).powi(2) + nb as f64 * (mean_b[e] - mean[e]).powi(2))
            .sum();
        prop_assert!(floor > 0.0);
        let mut mixer = Mixer::new(&m);
        for _ in 0..300 {
            mixer.mix(&mut xs).unwrap();
        }
        let d = disagreement(&xs).unwrap();
        prop_assert!(d >= floor * (1.0 - 1e-4) - 1e-6, "disagreement {} fell below the floor {}", d, floor);
    }

    #[test]
    fn corrupted_matrices_are_rejected_with_the_right_variant(
        g in random_graph(3..=30),
        rule in rule(),
        pick in any::<Index>(),
        factor in prop_oneof![0.1_f64..0.9, 1.1_f64..3.0],
    ) {
        // Close a triangle so that a cycle exists for the symmetry-breaking
        // circulation below: either k - parent(k) - parent(parent(k)), or two
        // children of the root.
        let (tri, closing) = match (1..g.n).find(|&k| g.parent[k - 1] != 0) {
            Some(k) => {
                let p = g.parent[k - 1];
                let pp = g.parent[p - 1];
                ((k, p, pp), (k, pp))
            }
            None => ((1, 0, 2), (1, 2)),
        };
        let mut edges = g.edges();
        edges.push(closing);
        let graph = Graph::from_edges(g.n, &edges).unwrap();
        let n = graph.nodes();
        let valid = matrix(rule, &graph).to_rows();
        let check = |rows: Vec<Vec<f64>>| UserMatrix { rows }.mixing_matrix(&graph);
        prop_assert!(check(valid.clone()).is_ok());

        // Negate a positive entry.
        let positive: Vec<(usize, usize)> = (0..n)
            .flat_map(|i| (0..n).map(move |j| (i, j)))
            .filter(|&(i, j)| valid[i][j] > 0.0)
            .collect();
        let (i, j) = positive[pick.index(positive.len())];
        let mut rows = valid.clone();
        rows[i][j] = -rows[i][j];
        prop_assert_eq!(check(rows.clone()), Err(GraphError::NegativeEntry { row: i, col: j, value: rows[i][j] }));
        let intrinsic = MixingMatrix::from_rows(rows);
        let ok = matches!(intrinsic, Err(GraphError::NegativeEntry { row, col, .. }) if (row, col) == (i, j));
        prop_assert!(ok, "{:?}", intrinsic);

        // Scale a row.
        let r = pick.index(n);
        let mut rows = valid.clone();
        rows[r].iter_mut().for_each(|w| *w *= factor);
        match check(rows.clone()) {
            Err(GraphError::RowSum { row, sum }) => {
                prop_assert_eq!(row, r);
                prop_assert!((sum - factor).abs() < 1e-9);
            }
            other => prop_assert!(false, "expected RowSum, got {:?}", other),
        }
        let intrinsic = MixingMatrix::from_rows(rows);
        let ok = matches!(intrinsic, Err(GraphError::RowSum { row, .. }) if row == r);
        prop_assert!(ok, "{:?}", intrinsic);

        // Break symmetry but keep the matrix doubly stochastic: push weight
        // around the triangle a -> b -> c -> a.
        let (a, b, c) = tri;
        let mut rows = valid.clone();
        let d = 0.5 * rows[b][a].min(rows[c][b]).min(rows[a][c]);
        for (from, to) in [(a, b), (b, c), (c, a)] {
            rows[from][to] += d;
            rows[to][from] -= d;
        }
        match check(rows.clone()) {
            Err(GraphError::Asymmetric { row, col, upper, lower }) => {
                prop_assert!(row < col);
                prop_assert!([a, b, c].contains(&row) && [a, b, c].contains(&col));
                prop_assert_eq!(upper, rows[row][col]);
                prop_assert_eq!(lower, rows[col][row]);
            }
            other => prop_assert!(false, "expected Asymmetric, got {:?}", other),
        }
        let intrinsic = MixingMatrix::from_rows(rows);
        let ok = matches!(intrinsic, Err(GraphError::Asymmetric { .. }));
        prop_assert!(ok, "{:?}", intrinsic);

        // Weight on a non-edge (the intrinsic checks alone cannot see it).
        let non_edges: Vec<(usize, usize)> = (0..n)
            .flat_map(|i| (0..n).map(move |j| (i, j)))
            .filter(|&(i, j)| i != j && !graph.has_edge(i, j))
            .collect();
        if !non_edges.is_empty() {
            let (i, j) = non_edges[pick.index(non_edges.len())];
            let mut rows = valid.clone();
            rows[i][j] = 0.1;
            prop_assert_eq!(check(rows), Err(GraphError::WeightOnNonEdge { row: i, col: j, value: 0.1 }));
            // Symmetric and still doubly stochastic: only the graph check catches it.
            let dd = 0.5 * valid[i][i].min(valid[j][j]);
            if dd > 0.0 {
                let mut rows = valid.clone();
                rows[i][j] = dd;
                rows[j][i] = dd;
                rows[i][i] -= dd;
                rows[j][j] -= dd;
                let m = MixingMatrix::from_rows(rows).unwrap();
                let (lo, hi) = (i.min(j), i.max(j));
                prop_assert_eq!(m.validate(&graph), Err(GraphError::WeightOnNonEdge { row: lo, col: hi, value: dd }));
            }
        }

        // NaN and infinities.
        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            let mut rows = valid.clone();
            rows[i][j] = bad;
            prop_assert_eq!(check(rows.clone()), Err(GraphError::NotFinite { row: i, col: j }));
            prop_assert_eq!(MixingMatrix::from_rows(rows), Err(GraphError::NotFinite { row: i, col: j }));
        }

        // Drop a row.
        let mut rows = valid.clone();
        rows.remove(r);
        prop_assert_eq!(check(rows.clone()), Err(GraphError::NotSquare { rows: n - 1, cols: n }));
        prop_assert_eq!(MixingMatrix::from_rows(rows), Err(GraphError::NotSquare { rows: n - 1, cols: n }));

        // Right matrix, wrong graph size.
        let bigger = Graph::from_edges(n + 1, graph.edges()).unwrap();
        let m = MixingMatrix::from_rows(valid.clone()).unwrap();
        prop_assert_eq!(m.validate(&bigger), Err(GraphError::SizeMismatch { expected: n + 1, found: n }));
        prop_assert_eq!(UserMatrix { rows: valid }.mixing_matrix(&bigger), Err(GraphError::SizeMismatch { expected: n + 1, found: n }));
    }

    #[test]
    fn mixing_rejects_bad_vector_shapes_without_touching_them(
        (g, xs) in graph_and_vectors(),
        pick in any::<Index>(),
    ) {
        let graph = g.graph();
        let cg = ConsensusGraph::new(graph, &MetropolisHastings).unwrap();
        let n = cg.nodes();
        let mut fewer = xs[1..].to_vec();
        prop_assert_eq!(cg.mix(&mut fewer), Err(GraphError::WrongCount { expected: n, found: n - 1 }));
        let mut uneven = xs.clone();
        let victim = 1 + pick.index(n - 1);
        uneven[victim].push(1.0);
        let snapshot = uneven.clone();
        let len = xs[0].len();
        prop_assert_eq!(
            cg.mix(&mut uneven),
            Err(GraphError::UnequalLengths { index: victim, expected: len, found: len + 1 })
        );
        prop_assert_eq!(uneven, snapshot);
    }

    #[test]
    fn mix_slices_matches_mix(
        (g, xs) in graph_and_vectors(),
        rule in rule(),
    ) {
        let m = matrix(rule, &g.graph());
        let mut owned = xs.clone();
        m.mix(&mut owned).unwrap();
        let mut copy = xs;
        let mut slices: Vec<&mut [f32]> = copy.iter_mut().map(Vec::as_mut_slice).collect();
        m.mix_slices(&mut slices).unwrap();
        prop_assert_eq!(owned, copy);
    }
}

/// Long vectors cross the internal block boundary; compare against a plain
/// f64 reference.
#[test]
fn long_vectors_match_reference() {
    let graph = Graph::shadow_hand();
    let m = MetropolisHastings.mixing_matrix(&graph).unwrap();
    let len = 1537;
    let xs: Vec<Vec<f32>> = (0..6).map(|i| (0..len).map(|e| ((i * 31 + e * 7) % 19) as f32 - 9.0).collect()).collect();
    let mut mixed = xs.clone();
    m.mix(&mut mixed).unwrap();
    for (i, out) in mixed.iter().enumerate() {
        for (e, &got) in out.iter().enumerate() {
            let expect: f64 = (0..6).map(|j| m.get(i, j).unwrap() * f64::from(xs[j][e])).sum();
            assert!((f64::from(got) - expect).abs() < 1e-5);
        }
    }
    // The isolated wrist is untouched.
    assert_eq!(mixed[0], xs[0]);
}
