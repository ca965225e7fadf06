//! Guards the grasp-stability measures of the paper's section IV.C
//! (`fmsr_core::metrics`): the grasp matrix of point contacts with friction, its
//! singular values, Q_MSV (eq. 16), Q_VEW (eq. 17) and Q_DCC (eq. 18) on hand-made
//! contact sets whose answers are worked out by hand below; their invariance to
//! rigid motions of the grasp and to the contact frames; the per-episode trace
//! with its derivative series and summaries (Table I); the aggregation across
//! episodes into "mean±std" cells; and the failure counting of Table II.
//!
//! Useful identity for the hand derivations (module docs of `metrics`): with
//! `r_i = p_i - c` and `S(r)` the cross-product matrix,
//!
//! ```text
//! G G^T = sum_i [ I        S(r_i)^T         ]      S(r) S(r)^T = |r|^2 I - r r^T,
//!               [ S(r_i)   S(r_i) S(r_i)^T  ]
//! ```
//!
//! and the singular values of `G` are the square roots of the eigenvalues of `G G^T`.

use std::f64::consts::PI;

use fmsr_core::CoreError;
use fmsr_core::metrics::{
    EpisodeOutcome, EpisodeSummary, FailureCounts, FailureType, GraspQuality, GraspTrace, MeanStd, StabilityRow,
    contact_frame, grasp_matrix, grasp_singular_values, q_dcc, q_msv, q_vew,
};
use fmsr_core::prelude::{ContactPoint, ObjectContacts};
use proptest::prelude::*;

const TOL: f64 = 1e-10;

fn contact(position: [f64; 3], normal: [f64; 3]) -> ContactPoint {
    ContactPoint { position, normal, normal_force: 1.0 }
}

/// A contact at `p` on a sphere centred at `c`, the normal pointing to the centre.
fn inward(p: [f64; 3], c: [f64; 3]) -> ContactPoint {
    let d = [c[0] - p[0], c[1] - p[1], c[2] - p[2]];
    let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    contact(p, [d[0] / len, d[1] / len, d[2] / len])
}

fn contacts_of(points: Vec<ContactPoint>, center_of_mass: [f64; 3]) -> ObjectContacts {
    let active_touch_sensors = points.len();
    ObjectContacts { points, center_of_mass, active_touch_sensors }
}

fn sv(contacts: &ObjectContacts) -> [f64; 6] {
    grasp_singular_values(&grasp_matrix(contacts)).unwrap()
}

fn assert_close(found: &[f64], expected: &[f64], tol: f64) {
    assert_eq!(found.len(), expected.len());
    for (i, (f, e)) in found.iter().zip(expected).enumerate() {
        assert!((f - e).abs() <= tol * (1.0 + e.abs()), "entry {i}: found {f}, expected {e} (all: {found:?})");
    }
}

// ---------------------------------------------------------------- hand-made grasps

/// One contact at r = (2, 0, 0) from the centre. G = [R; S(r) R] is 6 x 3, rank 3.
/// G^T G = R^T (I + S^T S) R and S^T S = |r|^2 I - r r^T, whose eigenvalues are
/// 0 (along r) and |r|^2 = 4 (twice); so G^T G has eigenvalues 1, 5, 5 and the six
/// singular values are [sqrt 5, sqrt 5, 1, 0, 0, 0]: Q_MSV = 0, Q_VEW = 0.
#[test]
fn single_contact_has_rank_three_and_zero_quality() {
    let contacts = contacts_of(vec![contact([2.0, 0.0, 0.0], [-1.0, 0.0, 0.0])], [0.0; 3]);
    let g = grasp_matrix(&contacts);
    assert_eq!((g.nrows(), g.ncols()), (6, 3));
    let s = sv(&contacts);
    assert_close(&s, &[5f64.sqrt(), 5f64.sqrt(), 1.0, 0.0, 0.0, 0.0], TOL);
    assert_eq!(s.iter().filter(|v| **v > 1e-9).count(), 3, "rank 3");
    assert_eq!(q_msv(&g).unwrap(), 0.0);
    assert_eq!(q_vew(&g).unwrap(), 0.0);
    assert_eq!(q_dcc(&contacts), Some(2.0));
}

/// Two antipodal contacts on the unit sphere, p_1 = e_x, p_2 = -e_x, c = 0.
/// S(r_2) = -S(r_1), so the off-diagonal blocks of G G^T cancel; the force block is
/// 2 I; the torque block is 2 (|e_x|^2 I - e_x e_x^T) = diag(0, 2, 2). Hence
/// G G^T = diag(2, 2, 2, 0, 2, 2) and the singular values are
/// [sqrt 2 (five times), 0]: no torque about the antipodal axis can be applied
/// with point contacts, so Q_MSV = 0 and Q_VEW = 0, although G has rank 5.
#[test]
fn two_antipodal_contacts_on_unit_sphere() {
    let c = [0.0; 3];
    let contacts = contacts_of(vec![inward([1.0, 0.0, 0.0], c), inward([-1.0, 0.0, 0.0], c)], c);
    let s = sv(&contacts);
    let r2 = 2f64.sqrt();
    assert_close(&s, &[r2, r2, r2, r2, r2, 0.0], TOL);
    let g = grasp_matrix(&contacts);
    assert!(q_msv(&g).unwrap() < 1e-12);
    assert!(q_vew(&g).unwrap() < 1e-12);
    assert_eq!(q_dcc(&contacts), Some(1.0));
}

/// The same two antipodal contacts on a sphere of radius rho centred at c = (1, -2, 3):
/// G G^T = diag(2, 2, 2, 0, 2 rho^2, 2 rho^2), singular values sorted
/// [sqrt 2 x3, sqrt 2 rho x2, 0] for rho < 1.
#[test]
fn antipodal_contacts_scale_the_torque_singular_values_with_the_radius() {
    let c = [1.0, -2.0, 3.0];
    let rho = 0.03;
    let contacts = contacts_of(vec![inward([1.0, -2.0, 3.0 + rho], c), inward([1.0, -2.0, 3.0 - rho], c)], c);
    let r2 = 2f64.sqrt();
    assert_close(&sv(&contacts), &[r2, r2, r2, r2 * rho, r2 * rho, 0.0], TOL);
}

/// Three contacts 120 degrees apart on the unit circle in the xy plane, c = 0.
/// sum_i r_i = 0 so the off-diagonal blocks vanish; the force block is 3 I;
/// sum_i r_i r_i^T = (3/2) diag(1, 1, 0), so the torque block is
/// 3 I - (3/2) diag(1, 1, 0) = diag(3/2, 3/2, 3). Singular values:
/// [sqrt 3 x4, sqrt(3/2) x2]; Q_MSV = sqrt(3/2) > 0 (full rank);
/// Q_VEW = 3^2 * (3/2) = 13.5.
#[test]
fn three_symmetric_contacts_give_full_rank() {
    let c = [0.0; 3];
    let points = (0..3)
        .map(|k| {
            let a = 2.0 * PI * k as f64 / 3.0 + 0.3;
            inward([a.cos(), a.sin(), 0.0], c)
        })
        .collect();
    let contacts = contacts_of(points, c);
    let r3 = 3f64.sqrt();
    let r15 = 1.5f64.sqrt();
    assert_close(&sv(&contacts), &[r3, r3, r3, r3, r15, r15], TOL);
    let g = grasp_matrix(&contacts);
    assert!((q_msv(&g).unwrap() - r15).abs() < TOL);
    assert!((q_vew(&g).unwrap() - 13.5).abs() < 1e-9);
}

/// Four contacts at the vertices of a regular tetrahedron inscribed in a sphere of
/// radius rho, c = 0. sum_i r_i = 0 and sum_i r_i r_i^T = (4 rho^2 / 3) I (a
/// spherical 2-design), so the torque block is 4 rho^2 I - (4 rho^2 / 3) I =
/// (8 rho^2 / 3) I and the force block is 4 I. Singular values: 2 x3 and
/// rho sqrt(8/3) x3. For rho = 0.5: Q_MSV = sqrt(2/3), Q_VEW = 8 (2/3)^(3/2).
#[test]
fn four_tetrahedral_contacts_give_full_rank() {
    let rho = 0.5;
    let k = rho / 3f64.sqrt();
    let c = [0.0; 3];
    let points =
        [[1.0, 1.0, 1.0], [1.0, -1.0, -1.0], [-1.0, 1.0, -1.0], [-1.0, -1.0, 1.0]].map(|v| inward(v.map(|x| x * k), c));
    let contacts = contacts_of(points.to_vec(), c);
    let t = rho * (8f64 / 3.0).sqrt();
    assert_close(&sv(&contacts), &[2.0, 2.0, 2.0, t, t, t], TOL);
    let g = grasp_matrix(&contacts);
    assert!((q_msv(&g).unwrap() - (2f64 / 3.0).sqrt()).abs() < TOL);
    assert!((q_vew(&g).unwrap() - 8.0 * (2f64 / 3.0).powf(1.5)).abs() < 1e-9);
    assert!((q_dcc(&contacts).unwrap() - rho).abs() < 1e-12);
}

#[test]
fn no_contacts_give_zero_quality_and_no_dcc() {
    let contacts = ObjectContacts::default();
    let g = grasp_matrix(&contacts);
    assert_eq!((g.nrows(), g.ncols()), (6, 0));
    assert_eq!(sv(&contacts), [0.0; 6]);
    assert_eq!(q_dcc(&contacts), None);
    let q = GraspQuality::of(&contacts).unwrap();
    assert_eq!((q.q_msv, q.q_vew, q.q_dcc, q.contact_points), (0.0, 0.0, None, 0));
}

/// Column block i of G is [R_i; S(p_i - c) R_i] with R_i = [n t o] from `contact_frame`.
#[test]
fn grasp_matrix_blocks_follow_the_frame_convention() {
    let c = [0.1, 0.2, 0.3];
    let points = vec![contact([0.5, -0.4, 0.9], [0.0, 0.6, -0.8]), contact([-0.3, 0.2, 0.1], [1.0, 0.0, 0.0])];
    let contacts = contacts_of(points.clone(), c);
    let g = grasp_matrix(&contacts);
    assert_eq!((g.nrows(), g.ncols()), (6, 6));
    for (i, p) in points.iter().enumerate() {
        let r = [p.position[0] - c[0], p.position[1] - c[1], p.position[2] - c[2]];
        for (k, axis) in contact_frame(p.normal).iter().enumerate() {
            let m = [r[1] * axis[2] - r[2] * axis[1], r[2] * axis[0] - r[0] * axis[2], r[0] * axis[1] - r[1] * axis[0]];
            let col: Vec<f64> = (0..6).map(|row| g[(row, 3 * i + k)]).collect();
            assert_close(&col, &[axis[0], axis[1], axis[2], m[0], m[1], m[2]], 1e-14);
        }
    }
    // The first column of each block is the normal itself (pointing into the object).
    assert_close(&(0..3).map(|row| g[(row, 0)]).collect::<Vec<_>>(), &[0.0, 0.6, -0.8], 1e-15);
}

#[test]
fn degenerate_normal_falls_back_to_the_world_frame_without_changing_the_measures() {
    assert_eq!(contact_frame([0.0; 3]), [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]);
    let c = [0.0; 3];
    let good = contacts_of(vec![inward([1.0, 0.0, 0.0], c), inward([0.0, 1.0, 0.0], c)], c);
    let mut zero = good.clone();
    zero.points[0].normal = [0.0; 3];
    assert_close(&sv(&zero), &sv(&good), 1e-12);
}

// ---------------------------------------------------------------- errors

#[test]
fn bad_inputs_are_rejected() {
    let wrong_rows = faer::Mat::<f64>::zeros(5, 6);
    assert!(matches!(grasp_singular_values(&wrong_rows), Err(CoreError::Dimension { expected: 6, found: 5, .. })));
    let mut nan = faer::Mat::<f64>::zeros(6, 6);
    nan[(2, 1)] = f64::NAN;
    assert!(matches!(q_msv(&nan), Err(CoreError::NotFinite { index: 8, .. })));

    let c = [0.0; 3];
    let mut contacts = contacts_of(vec![inward([1.0, 0.0, 0.0], c), inward([-1.0, 0.0, 0.0], c)], c);
    contacts.points[1].position[2] = f64::INFINITY;
    assert!(matches!(GraspQuality::of(&contacts), Err(CoreError::NotFinite { index: 5, .. })));
    let mut trace = GraspTrace::new(0.04).unwrap();
    assert!(trace.push(&contacts).is_err());
    assert!(trace.is_empty(), "a failed push leaves the trace unchanged");
    contacts.points[1].position[2] = 0.0;
    contacts.center_of_mass[0] = f64::NAN;
    assert!(matches!(GraspQuality::of(&contacts), Err(CoreError::NotFinite { index: 0, .. })));

    for dt in [0.0, -0.04, f64::NAN, f64::INFINITY] {
        match GraspTrace::new(dt) {
            Err(CoreError::InvalidConfig { key, .. }) => assert_eq!(key, "dt"),
            other => panic!("dt = {dt}: expected InvalidConfig, got {other:?}"),
        }
    }
}

// ---------------------------------------------------------------- properties

/// An independent determinant: Gaussian elimination with partial pivoting.
fn det(mut a: Vec<[f64; 6]>) -> f64 {
    let mut d = 1.0;
    for col in 0..6 {
        let pivot = (col..6).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs())).unwrap();
        if a[pivot][col] == 0.0 {
            return 0.0;
        }
        if pivot != col {
            a.swap(pivot, col);
            d = -d;
        }
        d *= a[col][col];
        for row in col + 1..6 {
            let f = a[row][col] / a[col][col];
            let pivot_row = a[col];
            for (x, p) in a[row].iter_mut().zip(pivot_row).skip(col) {
                *x -= f * p;
            }
        }
    }
    d
}

/// G G^T from the contact positions alone (the identity in the file header),
/// without building G.
fn ggt_from_positions(contacts: &ObjectContacts) -> Vec<[f64; 6]> {
    let mut m = vec![[0.0; 6]; 6];
    let c = contacts.center_of_mass;
    for p in &contacts.points {
        let r = [p.position[0] - c[0], p.position[1] - c[1], p.position[2] - c[2]];
        let s = [[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]];
        let rr = r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
        for i in 0..3 {
            m[i][i] += 1.0;
            for j in 0..3 {
                m[3 + i][j] += s[i][j]; // S
                m[i][3 + j] += s[j][i]; // S^T
                m[3 + i][3 + j] += if i == j { rr } else { 0.0 } - r[i] * r[j];
            }
        }
    }
    m
}

fn arb_vec3(range: f64) -> impl Strategy<Value = [f64; 3]> {
    prop::array::uniform3(-range..range)
}

fn arb_unit() -> impl Strategy<Value = [f64; 3]> {
    arb_vec3(1.0).prop_filter("not too short", |v| v.iter().map(|x| x * x).sum::<f64>() > 1e-2).prop_map(|v| {
        let n = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        v.map(|x| x / n)
    })
}

fn arb_contacts(max: usize) -> impl Strategy<Value = ObjectContacts> {
    (prop::collection::vec((arb_vec3(0.1), arb_unit()), 0..max), arb_vec3(1.0)).prop_map(|(pts, c)| {
        let points =
            pts.into_iter().map(|(r, n)| contact([c[0] + r[0], c[1] + r[1], c[2] + r[2]], n)).collect::<Vec<_>>();
        contacts_of(points, c)
    })
}

/// Rotation matrix of angle `angle` about the unit `axis` (Rodrigues).
fn rotation(axis: [f64; 3], angle: f64) -> [[f64; 3]; 3] {
    let (s, c) = angle.sin_cos();
    let [x, y, z] = axis;
    let t = 1.0 - c;
    [
        [c + x * x * t, x * y * t - z * s, x * z * t + y * s],
        [y * x * t + z * s, c + y * y * t, y * z * t - x * s],
        [z * x * t - y * s, z * y * t + x * s, c + z * z * t],
    ]
}

fn apply(q: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|i| q[i][0] * v[0] + q[i][1] * v[1] + q[i][2] * v[2])
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    /// Rotating the whole grasp about the centre of mass (and then moving it
    /// anywhere) leaves the singular values, Q_MSV, Q_VEW and Q_DCC unchanged:
    /// G' = blockdiag(Q, Q) G blockdiag(R_i^T Q^T R_i'), orthogonal factors.
    #[test]
    fn singular_values_are_invariant_to_rotating_the_grasp(
        contacts in arb_contacts(8),
        axis in arb_unit(),
        angle in -PI..PI,
        shift in arb_vec3(2.0),
    ) {
        let q = rotation(axis, angle);
        let c = contacts.center_of_mass;
        let c2 = [c[0] + shift[0], c[1] + shift[1], c[2] + shift[2]];
        let moved = ObjectContacts {
            points: contacts.points.iter().map(|p| {
                let r = apply(&q, [p.position[0] - c[0], p.position[1] - c[1], p.position[2] - c[2]]);
                contact([c2[0] + r[0], c2[1] + r[1], c2[2] + r[2]], apply(&q, p.normal))
            }).collect(),
            center_of_mass: c2,
            active_touch_sensors: contacts.active_touch_sensors,
        };
        let (a, b) = (GraspQuality::of(&contacts).unwrap(), GraspQuality::of(&moved).unwrap());
        for (x, y) in a.singular_values.iter().zip(&b.singular_values) {
            prop_assert!((x - y).abs() < 1e-9, "{:?} vs {:?}", a.singular_values, b.singular_values);
        }
        prop_assert!((a.q_vew - b.q_vew).abs() < 1e-9);
        match (a.q_dcc, b.q_dcc) {
            (Some(x), Some(y)) => prop_assert!((x - y).abs() < 1e-9),
            (x, y) => prop_assert_eq!(x, y),
        }
    }

    /// Q_VEW (product of singular values via faer's SVD) equals sqrt(det(G G^T))
    /// with G G^T assembled from the positions alone and its determinant taken by
    /// hand-written elimination; G G^T of `grasp_matrix` matches the assembled one.
    #[test]
    fn q_vew_equals_sqrt_det_g_gt(contacts in arb_contacts(8)) {
        let g = grasp_matrix(&contacts);
        let m = ggt_from_positions(&contacts);
        for i in 0..6 {
            for j in 0..6 {
                let gg: f64 = (0..g.ncols()).map(|k| g[(i, k)] * g[(j, k)]).sum();
                prop_assert!((gg - m[i][j]).abs() < 1e-12, "G G^T[{i}][{j}]: {gg} vs {}", m[i][j]);
            }
        }
        let expected = det(m).max(0.0).sqrt();
        let found = q_vew(&g).unwrap();
        prop_assert!((found - expected).abs() < 1e-9 * (1.0 + expected), "{found} vs {expected}");
        prop_assert!(q_msv(&g).unwrap() >= 0.0);
        if contacts.points.len() < 2 {
            prop_assert_eq!(q_msv(&g).unwrap(), 0.0);
        }
    }

    /// The measures do not depend on the contact normals (only on positions).
    #[test]
    fn singular_values_do_not_depend_on_the_normals(
        contacts in arb_contacts(6),
        normals in prop::collection::vec(arb_unit(), 6),
    ) {
        let mut other = contacts.clone();
        for (p, n) in other.points.iter_mut().zip(&normals) {
            p.normal = *n;
        }
        let (a, b) = (sv(&contacts), sv(&other));
        for (x, y) in a.iter().zip(&b) {
            prop_assert!((x - y).abs() < 1e-10);
        }
    }

    /// The contact frame is orthonormal, right-handed and starts with the normal.
    #[test]
    fn contact_frame_is_a_right_handed_orthonormal_basis(n in arb_unit(), len in 0.1f64..10.0) {
        let [a, t, o] = contact_frame(n.map(|x| x * len));
        let dot = |u: [f64; 3], v: [f64; 3]| u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
        for u in [a, t, o] {
            prop_assert!((dot(u, u) - 1.0).abs() < 1e-12);
        }
        prop_assert!(dot(a, t).abs() < 1e-12 && dot(a, o).abs() < 1e-12 && dot(t, o).abs() < 1e-12);
        let cross = [a[1] * t[2] - a[2] * t[1], a[2] * t[0] - a[0] * t[2], a[0] * t[1] - a[1] * t[0]];
        for k in 0..3 {
            prop_assert!((cross[k] - o[k]).abs() < 1e-12);
            prop_assert!((a[k] - n[k]).abs() < 1e-12);
        }
    }

    /// Q_DCC of points on a sphere of radius r about the centre of mass is r.
    #[test]
    fn q_dcc_of_points_on_a_sphere_is_its_radius(
        dirs in prop::collection::vec(arb_unit(), 1..12),
        r in 0.001f64..1.0,
        c in arb_vec3(1.0),
    ) {
        let points = dirs.iter().map(|d| inward([c[0] + r * d[0], c[1] + r * d[1], c[2] + r * d[2]], c)).collect();
        let dcc = q_dcc(&contacts_of(points, c)).unwrap();
        prop_assert!((dcc - r).abs() < 1e-12, "{dcc} vs {r}");
    }
}

// ---------------------------------------------------------------- episode trace

fn quality(contacts: usize, q_msv: f64, q_vew: f64, q_dcc: Option<f64>) -> GraspQuality {
    GraspQuality {
        active_touch_sensors: contacts,
        contact_points: contacts / 2,
        singular_values: [0.0; 6],
        q_msv,
        q_vew,
        q_dcc,
    }
}

/// Q_MSV = [1, 3, 2, 2], Q_VEW = [0, 10, 4, 4], dt = 0.5:
/// |Q'_MSV| = [|3-1|, |2-3|, |2-2|] / 0.5 = [4, 2, 0], mean 2, std sqrt(8/3);
/// |Q'_VEW| = [10, 6, 0] / 0.5 = [20, 12, 0], mean 32/3.
/// Q_DCC is averaged over the 3 steps with contacts only: (0.01 + 0.02 + 0.03) / 3.
#[test]
fn derivative_series_and_summary_of_a_hand_made_trace() {
    let mut trace = GraspTrace::new(0.5).unwrap();
    trace.push_quality(quality(4, 1.0, 0.0, Some(0.01)));
    trace.push_quality(quality(10, 3.0, 10.0, Some(0.02)));
    trace.push_quality(quality(0, 2.0, 4.0, None));
    trace.push_quality(quality(6, 2.0, 4.0, Some(0.03)));
    assert_eq!(trace.len(), 4);
    assert_eq!(trace.dt(), 0.5);
    assert_eq!(trace.contacts(), vec![4, 10, 0, 6]);
    assert_eq!(trace.contact_points(), vec![2, 5, 0, 3]);
    assert_eq!(trace.q_msv(), vec![1.0, 3.0, 2.0, 2.0]);
    assert_eq!(trace.q_dcc(), vec![Some(0.01), Some(0.02), None, Some(0.03)]);
    assert_eq!(trace.dq_msv(), vec![4.0, 2.0, 0.0]);
    assert_eq!(trace.dq_vew(), vec![20.0, 12.0, 0.0]);

    let s = trace.summary().unwrap();
    assert_eq!((s.steps, s.total_contacts, s.total_contact_points), (4, 20, 10));
    assert_close(&[s.q_msv.mean, s.q_vew.mean], &[2.0, 4.5], 1e-15);
    let dq = s.dq_msv.unwrap();
    assert_eq!(dq.n, 3);
    assert_close(&[dq.mean, dq.std], &[2.0, (8f64 / 3.0).sqrt()], 1e-15);
    assert_close(&[s.dq_vew.unwrap().mean], &[32.0 / 3.0], 1e-15);
    let dcc = s.q_dcc.unwrap();
    assert_eq!(dcc.n, 3);
    assert_close(&[dcc.mean], &[0.02], 1e-15);

    trace.clear();
    assert!(trace.is_empty() && trace.summary().is_none());
    trace.push_quality(quality(1, 1.0, 1.0, None));
    let one = trace.summary().unwrap();
    assert_eq!((one.dq_msv, one.dq_vew, one.q_dcc), (None, None, None));
}

/// A real trace: the grasp opens from the 3-contact triad (Q_MSV = sqrt 1.5,
/// Q_VEW = 13.5) to a single contact (both 0) and closes again.
#[test]
fn trace_from_contacts_tracks_grasp_changes() {
    let c = [0.0; 3];
    let triad = contacts_of(
        (0..3)
            .map(|k| {
                let a = 2.0 * PI * k as f64 / 3.0;
                inward([a.cos(), a.sin(), 0.0], c)
            })
            .collect(),
        c,
    );
    let single = contacts_of(vec![triad.points[0]], c);
    let mut trace = GraspTrace::new(0.04).unwrap();
    for contacts in [&triad, &single, &triad] {
        trace.push(contacts).unwrap();
    }
    let d = 1.5f64.sqrt() / 0.04;
    assert_close(&trace.dq_msv(), &[d, d], 1e-9);
    assert_close(&trace.dq_vew(), &[13.5 / 0.04, 13.5 / 0.04], 1e-9);
    let s = trace.summary().unwrap();
    assert_eq!(s.total_contacts, 7);
    assert_close(&[s.q_vew.mean, s.dq_msv.unwrap().std], &[9.0, 0.0], 1e-9);
    assert_close(&[s.q_dcc.unwrap().mean], &[1.0], 1e-12);
}

// ---------------------------------------------------------------- aggregates

fn summary(total_contacts: usize, q_msv: f64, dq: Option<MeanStd>, dcc: Option<f64>) -> EpisodeSummary {
    EpisodeSummary {
        steps: 100,
        total_contacts,
        total_contact_points: total_contacts / 10,
        q_msv: MeanStd { mean: q_msv, std: 1.0, n: 100 },
        q_vew: MeanStd { mean: 2.0 * q_msv, std: 1.0, n: 100 },
        dq_msv: dq,
        dq_vew: dq,
        q_dcc: dcc.map(|m| MeanStd { mean: m, std: 0.0, n: 50 }),
    }
}

/// Across episodes: contacts 7000, 8000, 7842 -> mean 7614, population std
/// sqrt(((-614)^2 + 386^2 + 228^2) / 3) = sqrt(577_976 / 3) = 438.9.
#[test]
fn stability_row_is_mean_and_std_across_episodes() {
    let d1 = MeanStd::from_samples(&[1.0, 3.0]).unwrap();
    let d2 = MeanStd::from_samples(&[5.0, 7.0, 9.0]).unwrap();
    let rows = [
        summary(7000, 1.0, Some(d1), Some(0.004)),
        summary(8000, 2.0, Some(d2), None),
        summary(7842, 3.0, None, Some(0.008)),
    ];
    let row = StabilityRow::from_summaries(&rows).unwrap();
    assert_eq!(row.episodes, 3);
    assert_eq!(row.total_contacts.n, 3);
    assert_close(&[row.total_contacts.mean, row.total_contacts.std], &[7614.0, (577_976f64 / 3.0).sqrt()], 1e-12);
    assert_eq!(format!("{:.0}", row.total_contacts), "7614±439");
    assert_close(&[row.q_msv.mean, row.q_msv.std], &[2.0, (2f64 / 3.0).sqrt()], 1e-12);
    assert_close(&[row.q_vew.mean], &[4.0], 1e-12);
    // Derivatives: across the two episodes that have them (means 2 and 7) ...
    let dq = row.dq_msv.unwrap();
    assert_eq!(dq.n, 2);
    assert_close(&[dq.mean, dq.std], &[4.5, 2.5], 1e-12);
    // ... and pooled over their 5 step differences [1, 3, 5, 7, 9].
    let all = MeanStd::from_samples(&[1.0, 3.0, 5.0, 7.0, 9.0]).unwrap();
    let pooled = row.dq_msv_pooled.unwrap();
    assert_eq!(pooled.n, 5);
    assert_close(&[pooled.mean, pooled.std], &[all.mean, all.std], 1e-12);
    // Q_DCC over the episodes with contacts (shown in mm as in Table I).
    let dcc = row.q_dcc.unwrap();
    assert_eq!(format!("{:.1}", MeanStd { mean: dcc.mean * 1e3, std: dcc.std * 1e3, n: dcc.n }), "6.0±2.0");

    assert!(StabilityRow::from_summaries(&[]).is_none());
    let json = serde_json::to_string(&row).unwrap();
    let back: StabilityRow = serde_json::from_str(&json).unwrap();
    assert_eq!(back, row);
}

#[test]
fn mean_std_formats_like_the_paper() {
    let x = MeanStd { mean: 919.4, std: 145.49, n: 100 };
    assert_eq!(format!("{x:.0}"), "919±145");
    assert_eq!(format!("{:.1}", MeanStd { mean: 6.94, std: 2.36, n: 100 }), "6.9±2.4");
    assert_eq!(format!("{}", MeanStd { mean: 1.5, std: 0.25, n: 2 }), "1.5±0.25");
    assert_eq!(MeanStd::pool(&[]), None);
}

// ---------------------------------------------------------------- failures

/// Table II, egg task: Ours 53 failures, all incomplete (100%, 0 drops);
/// Sparse 37 failures = 24 incomplete (64.9%) + 13 drops (35.1%), over 500 trials.
#[test]
fn failure_counts_give_table_two_columns() {
    let table = |successes: usize, incomplete: usize, drop: usize| -> FailureCounts {
        std::iter::repeat_n(EpisodeOutcome::Success, successes)
            .chain(std::iter::repeat_n(EpisodeOutcome::Failure(FailureType::Incomplete), incomplete))
            .chain(std::iter::repeat_n(EpisodeOutcome::Failure(FailureType::Drop), drop))
            .collect()
    };
    let ours = table(447, 53, 0);
    assert_eq!(ours.episodes, 500);
    let row = ours.row();
    assert_eq!((row.failures, row.incomplete, row.drop), (53, 53, 0));
    assert_eq!((row.incomplete_percent, row.drop_percent), (Some(100.0), Some(0.0)));
    assert_close(&[ours.success_rate().unwrap()], &[447.0 / 500.0], 1e-15);

    let mut sparse = FailureCounts::new();
    sparse.extend(std::iter::repeat_n(EpisodeOutcome::Success, 463));
    for _ in 0..24 {
        sparse.record(EpisodeOutcome::Failure(FailureType::Incomplete));
    }
    for _ in 0..13 {
        sparse.record(EpisodeOutcome::Failure(FailureType::Drop));
    }
    let row = sparse.row();
    assert_eq!((sparse.failures(), row.incomplete, row.drop), (37, 24, 13));
    assert_eq!(format!("{:.1}", row.incomplete_percent.unwrap()), "64.9");
    assert_eq!(format!("{:.1}", row.drop_percent.unwrap()), "35.1");

    let none = table(10, 0, 0).row();
    assert_eq!((none.failures, none.incomplete_percent, none.drop_percent), (0, None, None));
    assert_eq!(FailureCounts::new().success_rate(), None);

    assert_eq!(FailureType::Drop.to_string(), "drop");
    assert_eq!(FailureType::Incomplete.to_string(), "incomplete");
    assert_eq!(serde_json::to_string(&EpisodeOutcome::Failure(FailureType::Drop)).unwrap(), r#"{"failure":"drop"}"#);
    let back: FailureCounts = serde_json::from_str(&serde_json::to_string(&sparse).unwrap()).unwrap();
    assert_eq!(back, sparse);
}
