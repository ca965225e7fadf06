//! Hand-computed values, edge cases of the constructors, and serde
//! round-trips (including rejection of invalid data on deserialise).

use fmsr_graph::prelude::*;

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-12
}

#[test]
fn metropolis_hastings_on_path_of_three() {
    // Degrees 1, 2, 1: every edge gets 1 / (1 + 2) = 1/3.
    let m = MetropolisHastings.mixing_matrix(&Graph::path(3)).unwrap();
    let third = 1.0 / 3.0;
    let expected = [[2.0 * third, third, 0.0], [third, third, third], [0.0, third, 2.0 * third]];
    for (row, want) in m.rows().zip(expected) {
        for (&got, want) in row.iter().zip(want) {
            assert!(close(got, want), "{got} != {want}");
        }
    }
    // M = I - L / 3 with path Laplacian eigenvalues 0, 1, 3: eigenvalues 1, 2/3, 0.
    let ev = m.eigenvalues().unwrap();
    assert!(close(ev[0], 0.0) && close(ev[1], 2.0 / 3.0) && close(ev[2], 1.0));
    assert!(close(m.slem().unwrap(), 2.0 / 3.0));
    assert!(close(m.spectral_gap().unwrap(), 1.0 / 3.0));
}

#[test]
fn halves_on_path_of_three() {
    // The weights 1 / max(d_i, d_j): valid on the path, eigenvalues -1/2, 1/2, 1.
    let graph = Graph::path(3);
    let m = UserMatrix { rows: vec![vec![0.5, 0.5, 0.0], vec![0.5, 0.0, 0.5], vec![0.0, 0.5, 0.5]] }
        .mixing_matrix(&graph)
        .unwrap();
    let ev = m.eigenvalues().unwrap();
    assert!(close(ev[0], -0.5) && close(ev[1], 0.5) && close(ev[2], 1.0));
    assert!(close(m.convergence_rate(&graph).unwrap(), 0.5));
}

#[test]
fn max_degree_on_complete_graph_reaches_consensus_in_one_step() {
    for n in 1..8 {
        let m = MaxDegree.mixing_matrix(&Graph::complete(n)).unwrap();
        assert!(m.as_slice().iter().all(|&w| close(w, 1.0 / n as f64)));
        assert!(m.slem().unwrap() < 1e-12, "n = {n}");
        assert!(close(m.convergence_rate(&Graph::complete(n)).unwrap(), 0.0));
    }
    let m = MaxDegree.mixing_matrix(&Graph::complete(4)).unwrap();
    let mut xs = vec![vec![4.0_f32], vec![0.0], vec![0.0], vec![0.0]];
    m.mix(&mut xs).unwrap();
    assert!(xs.iter().all(|x| (x[0] - 1.0).abs() < 1e-6));
}

#[test]
fn metropolis_hastings_ring_of_four_has_slem_one_third() {
    let m = MetropolisHastings.mixing_matrix(&Graph::ring(4)).unwrap();
    // Degree 2 everywhere: 1/3 on edges and the diagonal; eigenvalues
    // (1 + 2 cos(2 pi k / 4)) / 3 = 1, 1/3, -1/3, 1/3.
    assert!(close(m.get(0, 1).unwrap(), 1.0 / 3.0));
    assert!(close(m.get(0, 0).unwrap(), 1.0 / 3.0));
    assert_eq!(m.get(0, 2), Some(0.0));
    assert!(close(m.slem().unwrap(), 1.0 / 3.0));
    assert!(close(m.convergence_rate(&Graph::ring(4)).unwrap(), 1.0 / 3.0));
}

#[test]
fn metropolis_hastings_uses_the_larger_degree() {
    // Star with center 0 and three leaves: d_0 = 3, leaves have degree 1.
    let m = MetropolisHastings.mixing_matrix(&Graph::star(4, 0).unwrap()).unwrap();
    assert!(close(m.get(0, 1).unwrap(), 0.25));
    assert!(close(m.get(0, 0).unwrap(), 0.25));
    assert!(close(m.get(1, 1).unwrap(), 0.75));
    // Eigenvalues of this star: 1, 3/4 (twice), 0.
    assert!(close(m.slem().unwrap(), 0.75));
}

#[test]
fn lazy_shifts_the_spectrum() {
    let graph = Graph::path(2);
    // MH on one edge: [[1/2, 1/2], [1/2, 1/2]]; eigenvalues 0, 1.
    // MaxDegree on one edge is the same; alpha = 1 keeps it.
    let m = Lazy::new(MaxDegree, 1.0).unwrap().mixing_matrix(&graph).unwrap();
    assert!(close(m.slem().unwrap(), 0.0));
    let m = Lazy::new(MetropolisHastings, 0.25).unwrap().mixing_matrix(&graph).unwrap();
    // (1 - a) I + a M has eigenvalues 1 - a and 1.
    assert!(close(m.slem().unwrap(), 0.75));
    for alpha in [0.0, -0.5, 1.5, f64::NAN, f64::INFINITY] {
        assert!(matches!(Lazy::new(MetropolisHastings, alpha), Err(GraphError::InvalidLaziness { .. })));
        let lazy = Lazy { inner: MetropolisHastings, alpha };
        assert!(matches!(lazy.mixing_matrix(&graph), Err(GraphError::InvalidLaziness { .. })));
    }
}

#[test]
fn bipartite_without_self_weight_oscillates() {
    // [[0, 1], [1, 0]] is a valid mixing matrix but swaps the two values:
    // eigenvalue -1, so slem = 1 and no convergence.
    let graph = Graph::path(2);
    let m = UserMatrix { rows: vec![vec![0.0, 1.0], vec![1.0, 0.0]] }.mixing_matrix(&graph).unwrap();
    assert!(close(m.convergence_rate(&graph).unwrap(), 1.0));
}

#[test]
fn shadow_hand_topology() {
    let g = Graph::shadow_hand();
    assert_eq!(g.nodes(), 6);
    assert_eq!(g.names().unwrap(), &["wrist", "index", "middle", "ring", "little", "thumb"]);
    assert_eq!(g.edges(), &[(1, 2), (1, 5), (2, 3), (3, 4), (4, 5)]);
    for (a, b) in [("thumb", "index"), ("index", "middle"), ("middle", "ring"), ("ring", "little"), ("little", "thumb")]
    {
        let (i, j) = (g.index_of(a).unwrap(), g.index_of(b).unwrap());
        assert!(g.has_edge(i, j) && g.has_edge(j, i));
    }
    assert_eq!(g.neighbors(0).unwrap(), &[] as &[usize]);
    assert!(!g.is_connected());
    assert_eq!(g.max_degree(), 2);

    let cg = ConsensusGraph::shadow_hand();
    assert_eq!(cg, ConsensusGraph::new(Graph::shadow_hand(), &MetropolisHastings).unwrap());
    assert_eq!(cg.convergence_rate(), Err(GraphError::Disconnected { components: 2 }));
    // The finger ring alone is a 5-cycle with weights 1/3: eigenvalues
    // (1 + 2 cos(2 pi k / 5)) / 3, the largest modulus besides 1 at k = 1.
    let ring = MetropolisHastings.mixing_matrix(&Graph::ring(5)).unwrap();
    let expected = (1.0 + 2.0 * (2.0 * std::f64::consts::PI / 5.0).cos()) / 3.0;
    assert!(close(ring.slem().unwrap(), expected));
}

#[test]
fn constructors_and_queries() {
    assert_eq!(Graph::ring(0).edges(), &[]);
    assert_eq!(Graph::ring(1).edges(), &[]);
    assert_eq!(Graph::ring(2).edges(), &[(0, 1)]);
    assert_eq!(Graph::ring(3).edges(), &[(0, 1), (0, 2), (1, 2)]);
    assert_eq!(Graph::path(1).edges(), &[]);
    assert_eq!(Graph::complete(0).nodes(), 0);
    assert!(Graph::empty(0).is_connected());
    assert!(Graph::empty(1).is_connected());
    assert!(!Graph::empty(2).is_connected());
    assert_eq!(Graph::empty(3).components(), vec![vec![0], vec![1], vec![2]]);
    assert_eq!(Graph::star(3, 3), Err(GraphError::NodeOutOfRange { node: 3, nodes: 3 }));
    assert_eq!(Graph::from_edges(3, &[(0, 3)]), Err(GraphError::NodeOutOfRange { node: 3, nodes: 3 }));
    assert_eq!(Graph::from_edges(3, &[(2, 2)]), Err(GraphError::SelfLoopEdge { node: 2 }));
    let g = Graph::ring(5);
    assert_eq!(g.neighbors(5), Err(GraphError::NodeOutOfRange { node: 5, nodes: 5 }));
    assert_eq!(g.degree(7), Err(GraphError::NodeOutOfRange { node: 7, nodes: 5 }));
    assert!(!g.has_edge(0, 9));
    assert!(!g.has_edge(0, 0));
    assert_eq!(g.index_of("a"), None);
    assert_eq!(g.clone().with_names(vec!["a".into()]), Err(GraphError::WrongCount { expected: 5, found: 1 }));
    let names: Vec<String> = ["a", "b", "c", "b", "e"].map(String::from).to_vec();
    assert_eq!(g.with_names(names), Err(GraphError::DuplicateName { name: "b".into() }));
    assert_eq!(Graph::ring(3).graph(), Ok(Graph::ring(3)));
    assert_eq!(
        Graph::from_edges(MAX_NODES + 1, &[]),
        Err(GraphError::TooManyNodes { nodes: MAX_NODES + 1, max: MAX_NODES })
    );
}

#[test]
fn empty_and_single_node_cases() {
    let m = MetropolisHastings.mixing_matrix(&Graph::empty(0)).unwrap();
    assert_eq!(m.n(), 0);
    assert_eq!(m.slem(), Ok(0.0));
    let mut none: Vec<Vec<f32>> = Vec::new();
    m.mix(&mut none).unwrap();
    let m = MetropolisHastings.mixing_matrix(&Graph::empty(1)).unwrap();
    assert_eq!(m.to_rows(), vec![vec![1.0]]);
    assert_eq!(m.convergence_rate(&Graph::empty(1)), Ok(0.0));
    let mut one = vec![vec![1.5_f32, 2.5]];
    m.mix(&mut one).unwrap();
    assert_eq!(one, vec![vec![1.5, 2.5]]);
    let mut empty_vectors = vec![Vec::new(), Vec::new()];
    MetropolisHastings::matrix(&Graph::path(2)).mix(&mut empty_vectors).unwrap();
    assert_eq!(average(&[] as &[Vec<f32>]), Ok(vec![]));
    assert_eq!(disagreement(&[] as &[Vec<f32>]), Ok(0.0));
    assert_eq!(
        disagreement(&[vec![1.0_f32], vec![]]),
        Err(GraphError::UnequalLengths { index: 1, expected: 1, found: 0 })
    );
    assert_eq!(MixingMatrix::identity(2).get(1, 1), Some(1.0));
    assert_eq!(MixingMatrix::identity(2).get(2, 0), None);
    assert_eq!(MixingMatrix::identity(2).row(2), None);
}

#[test]
fn consensus_graph_checks_counts() {
    let cg = ConsensusGraph::new(Graph::ring(3), &MaxDegree).unwrap();
    assert_eq!(cg.disagreement(&[vec![1.0_f32]]), Err(GraphError::WrongCount { expected: 3, found: 1 }));
    assert_eq!(cg.average(&vec![vec![1.0_f32]; 4]), Err(GraphError::WrongCount { expected: 3, found: 4 }));
    let wrong = MetropolisHastings.mixing_matrix(&Graph::complete(3)).unwrap();
    assert!(matches!(ConsensusGraph::with_matrix(Graph::path(3), wrong), Err(GraphError::WeightOnNonEdge { .. })));
    let (g, m) = cg.into_parts();
    assert_eq!(m.n(), g.nodes());
}

#[test]
fn errors_render_their_context() {
    let e = GraphError::RowSum { row: 2, sum: 1.5 };
    assert_eq!(e.to_string(), "row 2 sums to 1.5, expected 1");
    let e = GraphError::Asymmetric { row: 0, col: 1, upper: 0.25, lower: 0.5 };
    assert!(e.to_string().contains("M[0][1] = 0.25"));
}

#[test]
fn graph_serde_round_trip_and_validation() {
    let g = Graph::shadow_hand();
    let json = serde_json::to_string(&g).unwrap();
    let back: Graph = serde_json::from_str(&json).unwrap();
    assert_eq!(back, g);

    // Unnormalised input is normalised.
    let g: Graph = serde_json::from_str(r#"{"nodes":3,"edges":[[2,0],[0,2],[1,0]]}"#).unwrap();
    assert_eq!(g.edges(), &[(0, 1), (0, 2)]);
    assert_eq!(g.names(), None);

    for bad in [
        r#"{"nodes":3,"edges":[[1,1]]}"#,
        r#"{"nodes":3,"edges":[[0,3]]}"#,
        r#"{"nodes":2,"names":["a"],"edges":[]}"#,
        r#"{"nodes":2,"names":["a","a"],"edges":[]}"#,
        r#"{"nodes":2,"edges":[],"extra":1}"#,
        r#"{"nodes":1000000000000000000,"edges":[]}"#,
    ] {
        assert!(serde_json::from_str::<Graph>(bad).is_err(), "{bad}");
    }
}

#[test]
fn matrix_serde_round_trip_and_validation() {
    let m = Lazy::new(MetropolisHastings, 0.5).unwrap().mixing_matrix(&Graph::path(2)).unwrap();
    let json = serde_json::to_string(&m).unwrap();
    assert_eq!(json, r#"{"rows":[[0.75,0.25],[0.25,0.75]]}"#);
    let back: MixingMatrix = serde_json::from_str(&json).unwrap();
    assert_eq!(back, m);

    for (bad, what) in [
        (r#"{"rows":[[0.5,0.6],[0.5,0.4]]}"#, "row 0 sums to"),
        (r#"{"rows":[[1.5,-0.5],[-0.5,1.5]]}"#, "negative entry"),
        (r#"{"rows":[[1.0,0.0]]}"#, "not square"),
        (r#"{"rows":[[0.5,0.5],[0.5,null]]}"#, "null"),
    ] {
        let err = serde_json::from_str::<MixingMatrix>(bad).unwrap_err();
        assert!(err.to_string().contains(what), "{bad}: {err}");
    }
}

#[test]
fn consensus_graph_serde_checks_matrix_against_graph() {
    let cg = ConsensusGraph::new(Graph::ring(4), &Lazy::new(MaxDegree, 0.5).unwrap()).unwrap();
    let json = serde_json::to_string(&cg).unwrap();
    let back: ConsensusGraph = serde_json::from_str(&json).unwrap();
    assert_eq!(back, cg);

    // The complete-graph matrix on a path: weight on the non-edge 0-2.
    let bad = format!(
        r#"{{"graph":{},"mixing":{}}}"#,
        serde_json::to_string(&Graph::path(3)).unwrap(),
        serde_json::to_string(&MaxDegree.mixing_matrix(&Graph::complete(3)).unwrap()).unwrap()
    );
    let err = serde_json::from_str::<ConsensusGraph>(&bad).unwrap_err();
    assert!(err.to_string().contains("no edge 0-2"), "{err}");

    // Rules serialise too, for configs.
    let lazy = Lazy::new(MetropolisHastings, 0.5).unwrap();
    let back: Lazy<MetropolisHastings> = serde_json::from_str(&serde_json::to_string(&lazy).unwrap()).unwrap();
    assert_eq!(back, lazy);
}

#[test]
fn rules_work_behind_references_and_boxes() {
    let rules: Vec<Box<dyn MixingRule>> =
        vec![Box::new(MetropolisHastings), Box::new(MaxDegree), Box::new(Lazy::new(MaxDegree, 0.3).unwrap())];
    let graph = Graph::star(5, 2).unwrap();
    for rule in &rules {
        let m = rule.mixing_matrix(&graph).unwrap();
        assert!(m.validate(&graph).is_ok());
        assert!(ConsensusGraph::new(graph.clone(), rule).is_ok());
        assert!(ConsensusGraph::new(graph.clone(), &rule.as_ref()).is_ok());
    }
}
