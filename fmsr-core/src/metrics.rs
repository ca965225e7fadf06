//! Grasp-stability measures of the paper's section IV.C (eqs. 16-18, Tables I and II;
//! docs/design.md sections 5 and 3.9).
//!
//! The measures are computed from the contacts between the hand and the object
//! at one step ([`ObjectContacts`], read out by an environment that implements
//! [`crate::ContactReadout`]), accumulated over an episode ([`GraspTrace`]) and
//! aggregated over the episodes of a test set ([`StabilityRow`], [`FailureCounts`]).
//!
//! # The grasp matrix (point contact with friction)
//!
//! Following Prattichizzo & Trinkle (*Springer Handbook of Robotics*, ch. 28,
//! "Grasping"), a point contact with friction transmits a force `f_i` in `R^3`
//! and no moment. Contact `i` sits at `p_i`; the object's centre of mass is `c`.
//! Its contact frame has the columns
//!
//! ```text
//! R_i = [ n_i  t_i  o_i ]      (3 x 3, orthonormal, det R_i = +1)
//! ```
//!
//! where `n_i` is the unit contact normal pointing **into** the object (as
//! [`ContactPoint::normal`] is given) and `t_i`, `o_i` are two tangents built
//! deterministically from `n_i` by [`contact_frame`]. A contact force written in
//! this frame, `f_i = R_i [f_n, f_t, f_o]^T` (with `f_n >= 0` pressing on the
//! object), produces the wrench on the object
//!
//! ```text
//! w_i = [ force  ]  =  [        R_i        ] [f_n]
//!       [ torque ]     [ S(p_i - c) R_i    ] [f_t]  =  G_i lambda_i
//!                                            [f_o]
//! ```
//!
//! with `S(r)` the cross-product matrix (`S(r) x = r × x`) and torques taken
//! about the centre of mass. Stacking the `n` contacts,
//!
//! ```text
//! G = [ G_1  G_2  ...  G_n ]      (6 x 3n),      w = G lambda.
//! ```
//!
//! ([`grasp_matrix`]). Lengths are in metres and forces are unit-free
//! directions, so the force rows are dimensionless and the torque rows are in
//! metres; the absolute size of `Q_MSV` and `Q_VEW` therefore depends on the
//! length unit (the paper does not say which unit or scaling gave the
//! magnitudes of its Table I, so compare the measures between policies, not
//! with the paper's numbers).
//!
//! **Frame invariance.** Because `R_i R_i^T = I`,
//!
//! ```text
//! G G^T = sum_i [ I        S(r_i)^T         ]      r_i = p_i - c,
//!               [ S(r_i)   S(r_i) S(r_i)^T  ]      S(r) S(r)^T = |r|^2 I - r r^T,
//! ```
//!
//! which depends only on the contact positions relative to `c`: the singular
//! values of `G`, hence `Q_MSV` and `Q_VEW`, do not depend on the normals nor on
//! the choice of tangents, and they are invariant to any rigid motion of the
//! whole grasp (object and contacts together). The contact normal force
//! ([`ContactPoint::normal_force`]) does not enter the grasp matrix either: every
//! listed contact counts, whatever its force.
//!
//! # The measures
//!
//! With `sigma_1 >= sigma_2 >= ... >= sigma_6 >= 0` the six singular values of
//! `G` (when `G` has fewer than 6 columns, i.e. with fewer than 2 contacts, the
//! missing ones are 0; [`grasp_singular_values`]):
//!
//! ```text
//! Q_MSV = sigma_min(G) = sigma_6                                       (eq. 16)
//! Q_VEW = sqrt(det(G G^T)) = sigma_1 sigma_2 ... sigma_6               (eq. 17)
//! Q_DCC = (1/n) sum_{i=1}^{n} |p_i - c|                                (eq. 18)
//! ```
//!
//! `Q_MSV` ([`q_msv`]) is the distance of the grasp from a singular
//! configuration, where some wrench cannot be produced; `Q_VEW` ([`q_vew`]) is the
//! volume of the wrench ellipsoid, the global contribution of all contacts; both
//! are larger for better grasps and are 0 with fewer than 2 contacts. `Q_DCC`
//! ([`q_dcc`]) measures the compactness of the grasp (smaller is firmer); it is
//! undefined (`None`) with no contacts.
//!
//! The derivatives are per-step finite differences over the env step duration
//! `dt` ([`GraspTrace::new`]), taken in absolute value (Table I reports
//! `|Q'|`):
//!
//! ```text
//! |Q'_MSV|_t = |Q_MSV,t - Q_MSV,t-1| / dt,     t = 1 .. T-1,
//! |Q'_VEW|_t = |Q_VEW,t - Q_VEW,t-1| / dt.
//! ```
//!
//! # Tables I and II
//!
//! An episode's [`EpisodeSummary`] holds Table I's per-episode quantities: total
//! contacts (the sum over steps of the number of active touch sensors, the
//! measure that "can be directly read from the tactile sensors"), mean `Q_MSV`
//! and `Q_VEW` over all steps (a step with fewer than 2 contacts counts with 0),
//! mean and standard deviation of `|Q'_MSV|` and `|Q'_VEW|`, and mean `Q_DCC` over
//! the steps that have contacts. [`StabilityRow`] aggregates the summaries of a
//! test set into "mean ± std across episodes" cells that print like the paper's
//! `7614±331` ([`MeanStd`]'s `Display` honours a precision: `{:.0}`).
//!
//! Unsuccessful episodes are classified as [`FailureType::Drop`] (the object left
//! the hand) or [`FailureType::Incomplete`] (it stayed in the hand but did not
//! reach the goal): the environment reports a drop at each step
//! ([`crate::spec::StepInfo::dropped`]), and [`classify`] gives the outcome
//! (docs/design.md 3.9).
//! [`FailureCounts`] counts outcomes and gives Table II's columns
//! ([`FailureRow`]).
//!
//! All standard deviations are population standard deviations (divide by `n`,
//! NumPy's default).
//!
//! # Example
//!
//! ```
//! use fmsr_core::metrics::{GraspTrace, StabilityRow};
//! use fmsr_core::prelude::{ContactPoint, ObjectContacts};
//!
//! // Three contacts 120 degrees apart on the unit circle in the xy plane.
//! let points = (0..3)
//!     .map(|k| {
//!         let a = 2.0 * std::f64::consts::PI * k as f64 / 3.0;
//!         let p = [a.cos(), a.sin(), 0.0];
//!         ContactPoint { position: p, normal: [-p[0], -p[1], 0.0], normal_force: 1.0 }
//!     })
//!     .collect();
//! let contacts = ObjectContacts { points, center_of_mass: [0.0; 3], active_touch_sensors: 5 };
//!
//! let mut trace = GraspTrace::new(0.04).unwrap();
//! trace.push(&contacts).unwrap();
//! trace.push(&contacts).unwrap();
//! let summary = trace.summary().unwrap();
//! assert_eq!(summary.total_contacts, 10);
//! assert!((summary.q_msv.mean - 1.5f64.sqrt()).abs() < 1e-9);
//! assert!((summary.q_vew.mean - 13.5).abs() < 1e-9);
//! assert!(summary.dq_msv.unwrap().mean.abs() < 1e-9);
//!
//! let row = StabilityRow::from_summaries(&[summary]).unwrap();
//! assert_eq!(format!("{:.0}", row.total_contacts), "10±0");
//! ```

use std::fmt;

use faer::Mat;
use serde::{Deserialize, Serialize};

use crate::env::{ContactPoint, ObjectContacts};
use crate::error::CoreError;

/// Number of rows of the grasp matrix: the dimension of a wrench (force, torque).
pub const WRENCH_DIM: usize = 6;

/// Number of columns of one contact's block of the grasp matrix (point contact
/// with friction: a 3-D force, no moment).
pub const CONTACT_DIM: usize = 3;

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn scale(a: [f64; 3], s: f64) -> [f64; 3] {
    [a[0] * s, a[1] * s, a[2] * s]
}

fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

/// The contact frame `[n, t, o]` of a contact whose normal is `normal`,
/// returned as its three columns (unit vectors).
///
/// Construction (deterministic):
///
/// 1. `n = normal / |normal|`.
/// 2. The helper axis `e_k` is the world axis with the smallest `|n_k|` (the
///    lowest `k` on ties), so that it is far from parallel to `n`.
/// 3. `t = (e_k - (e_k . n) n) / |e_k - (e_k . n) n|`, the helper axis projected on
///    the tangent plane.
/// 4. `o = n × t`, so that `(n, t, o)` is right-handed (`det R = +1`).
///
/// A normal that is zero or not finite gives the world frame
/// `[e_x, e_y, e_z]`; this does not change any measure, which are all
/// independent of the frame (see the [module docs](self)).
///
/// ```
/// use fmsr_core::metrics::contact_frame;
///
/// let [n, t, o] = contact_frame([0.0, 0.0, 2.0]);
/// assert_eq!(n, [0.0, 0.0, 1.0]);
/// assert_eq!(t, [1.0, 0.0, 0.0]);
/// assert_eq!(o, [0.0, 1.0, 0.0]);
/// ```
pub fn contact_frame(normal: [f64; 3]) -> [[f64; 3]; 3] {
    let len = norm(normal);
    if !(len.is_finite() && len > 0.0) {
        return [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    }
    let n = scale(normal, 1.0 / len);
    let mut k = 0;
    for j in 1..3 {
        if n[j].abs() < n[k].abs() {
            k = j;
        }
    }
    let mut e = [0.0; 3];
    e[k] = 1.0;
    let t = sub(e, scale(n, dot(e, n)));
    // |t|^2 = 1 - n_k^2 >= 2/3 because n_k^2 <= 1/3.
    let t = scale(t, 1.0 / norm(t));
    let o = cross(n, t);
    [n, t, o]
}

/// The grasp matrix `G` (6 x 3n) of the contacts, point contact with friction.
///
/// Column block `i` (columns `3i .. 3i+3`) is
///
/// ```text
/// G_i = [ R_i            ]      R_i = [n_i t_i o_i]  (contact_frame),
///       [ S(p_i - c) R_i ]      c   = contacts.center_of_mass,
/// ```
///
/// so that `G_i [f_n, f_t, f_o]^T` is the wrench (force; torque about `c`) that the
/// contact force with normal component `f_n` and tangential components
/// `f_t, f_o` exerts on the object. Rows 0-2 are the force, rows 3-5 the torque
/// (world coordinates). With no contacts `G` is 6 x 0.
///
/// Non-finite positions are not checked here; they give non-finite entries,
/// which [`grasp_singular_values`] rejects.
///
/// ```
/// use fmsr_core::metrics::grasp_matrix;
/// use fmsr_core::prelude::{ContactPoint, ObjectContacts};
///
/// let contact = ContactPoint { position: [1.0, 0.0, 0.0], normal: [-1.0, 0.0, 0.0], normal_force: 2.0 };
/// let contacts = ObjectContacts { points: vec![contact], center_of_mass: [0.0; 3], active_touch_sensors: 1 };
/// let g = grasp_matrix(&contacts);
/// assert_eq!((g.nrows(), g.ncols()), (6, 3));
/// // A push along the normal (-x) at (1, 0, 0): force (-1, 0, 0), no torque about the centre.
/// let col: Vec<f64> = (0..6).map(|r| g[(r, 0)]).collect();
/// assert_eq!(col, vec![-1.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
/// ```
pub fn grasp_matrix(contacts: &ObjectContacts) -> Mat<f64> {
    let c = contacts.center_of_mass;
    let blocks: Vec<[[f64; 6]; 3]> = contacts
        .points
        .iter()
        .map(|p| {
            let r = sub(p.position, c);
            contact_frame(p.normal).map(|axis| {
                let m = cross(r, axis);
                [axis[0], axis[1], axis[2], m[0], m[1], m[2]]
            })
        })
        .collect();
    Mat::from_fn(WRENCH_DIM, CONTACT_DIM * blocks.len(), |row, col| blocks[col / CONTACT_DIM][col % CONTACT_DIM][row])
}

/// The six singular values `sigma_1 >= ... >= sigma_6 >= 0` of a grasp matrix
/// (SVD with faer), the missing ones set to 0 when `G` has fewer than 6 columns.
///
/// Errors: [`CoreError::Dimension`] if `G` does not have 6 rows,
/// [`CoreError::NotFinite`] if an entry is NaN or infinite (index in
/// column-major order), [`CoreError::Svd`] if the SVD does not converge.
///
/// ```
/// use fmsr_core::metrics::grasp_singular_values;
///
/// let g = faer::Mat::<f64>::from_fn(6, 6, |i, j| if i == j { (i + 1) as f64 } else { 0.0 });
/// let s = grasp_singular_values(&g).unwrap();
/// assert!((s[0] - 6.0).abs() < 1e-12 && (s[5] - 1.0).abs() < 1e-12);
/// ```
pub fn grasp_singular_values(g: &Mat<f64>) -> Result<[f64; WRENCH_DIM], CoreError> {
    if g.nrows() != WRENCH_DIM {
        return Err(CoreError::Dimension { what: "grasp matrix rows", expected: WRENCH_DIM, found: g.nrows() });
    }
    for j in 0..g.ncols() {
        for i in 0..WRENCH_DIM {
            if !g[(i, j)].is_finite() {
                return Err(CoreError::NotFinite { what: "grasp matrix (column-major)", index: j * WRENCH_DIM + i });
            }
        }
    }
    let mut out = [0.0; WRENCH_DIM];
    if g.ncols() == 0 {
        return Ok(out);
    }
    let values =
        g.singular_values().map_err(|_| CoreError::Svd { what: "grasp matrix", rows: g.nrows(), cols: g.ncols() })?;
    for (o, v) in out.iter_mut().zip(values) {
        *o = v.max(0.0);
    }
    // faer returns them sorted nonincreasing; keep that guarantee explicit.
    out.sort_by(|a, b| b.total_cmp(a));
    Ok(out)
}

/// `Q_MSV = sigma_min(G)` (eq. 16): the smallest of the six singular values of the
/// grasp matrix, 0 with fewer than 2 contacts. Errors as [`grasp_singular_values`].
///
/// ```
/// use fmsr_core::metrics::{grasp_matrix, q_msv};
/// use fmsr_core::prelude::{ContactPoint, ObjectContacts};
///
/// // One contact: G is 6 x 3, rank 3, so sigma_6 = 0.
/// let c = ContactPoint { position: [0.0, 0.0, 0.03], normal: [0.0, 0.0, -1.0], normal_force: 1.0 };
/// let contacts = ObjectContacts { points: vec![c], center_of_mass: [0.0; 3], active_touch_sensors: 1 };
/// assert_eq!(q_msv(&grasp_matrix(&contacts)).unwrap(), 0.0);
/// ```
pub fn q_msv(g: &Mat<f64>) -> Result<f64, CoreError> {
    Ok(msv_of(&grasp_singular_values(g)?))
}

/// Eq. 16 on the singular values (descending): the smallest.
fn msv_of(singular_values: &[f64; WRENCH_DIM]) -> f64 {
    singular_values[WRENCH_DIM - 1]
}

/// `Q_VEW = sqrt(det(G G^T)) = sigma_1 sigma_2 ... sigma_6` (eq. 17): the volume
/// of the wrench ellipsoid (up to the constant of the unit ball), 0 with fewer
/// than 2 contacts. Errors as [`grasp_singular_values`].
///
/// ```
/// use fmsr_core::metrics::q_vew;
///
/// let g = faer::Mat::<f64>::from_fn(6, 6, |i, j| if i == j { 2.0 } else { 0.0 });
/// assert!((q_vew(&g).unwrap() - 64.0).abs() < 1e-9);
/// ```
pub fn q_vew(g: &Mat<f64>) -> Result<f64, CoreError> {
    Ok(vew_of(&grasp_singular_values(g)?))
}

/// Eq. 17 on the singular values: their product.
fn vew_of(singular_values: &[f64; WRENCH_DIM]) -> f64 {
    singular_values.iter().product()
}

/// `Q_DCC = (1/n) sum_i |p_i - c|` (eq. 18): the mean distance (m) from the contact
/// positions to the object's centre of mass; `None` when there are no contacts.
///
/// ```
/// use fmsr_core::metrics::q_dcc;
/// use fmsr_core::prelude::{ContactPoint, ObjectContacts};
///
/// let at = |x: f64| ContactPoint { position: [x, 0.0, 0.0], normal: [1.0, 0.0, 0.0], normal_force: 1.0 };
/// let contacts = ObjectContacts { points: vec![at(0.01), at(-0.03)], center_of_mass: [0.0; 3], active_touch_sensors: 2 };
/// assert!((q_dcc(&contacts).unwrap() - 0.02).abs() < 1e-15);
/// assert_eq!(q_dcc(&ObjectContacts::default()), None);
/// ```
pub fn q_dcc(contacts: &ObjectContacts) -> Option<f64> {
    if contacts.points.is_empty() {
        return None;
    }
    let c = contacts.center_of_mass;
    let sum: f64 = contacts.points.iter().map(|p| norm(sub(p.position, c))).sum();
    Some(sum / contacts.points.len() as f64)
}

/// Checks that the centre of mass and every contact's position and normal are finite.
fn check_contacts(contacts: &ObjectContacts) -> Result<(), CoreError> {
    if let Some(index) = contacts.center_of_mass.iter().position(|v| !v.is_finite()) {
        return Err(CoreError::NotFinite { what: "object centre of mass", index });
    }
    let flat = |f: fn(&ContactPoint) -> [f64; 3]| contacts.points.iter().flat_map(f).position(|v| !v.is_finite());
    if let Some(index) = flat(|p| p.position) {
        return Err(CoreError::NotFinite { what: "contact positions (x, y, z per contact)", index });
    }
    if let Some(index) = flat(|p| p.normal) {
        return Err(CoreError::NotFinite { what: "contact normals (x, y, z per contact)", index });
    }
    Ok(())
}

/// All measures of one step, computed with one SVD.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct GraspQuality {
    /// Number of active touch sensors ([`ObjectContacts::active_touch_sensors`]),
    /// the paper's "number of contact points".
    pub active_touch_sensors: usize,
    /// Number of contact points in the contact read-out (columns of `G` / 3).
    pub contact_points: usize,
    /// The six singular values of `G`, nonincreasing.
    pub singular_values: [f64; WRENCH_DIM],
    /// `Q_MSV` (eq. 16).
    pub q_msv: f64,
    /// `Q_VEW` (eq. 17).
    pub q_vew: f64,
    /// `Q_DCC` (eq. 18, m); `None` with no contacts.
    pub q_dcc: Option<f64>,
}

impl GraspQuality {
    /// The measures of one step's contacts.
    ///
    /// Errors: [`CoreError::NotFinite`] for a non-finite centre of mass, contact
    /// position or normal; [`CoreError::Svd`] if the SVD does not converge.
    ///
    /// ```
    /// use fmsr_core::metrics::GraspQuality;
    /// use fmsr_core::prelude::ObjectContacts;
    ///
    /// let q = GraspQuality::of(&ObjectContacts::default()).unwrap();
    /// assert_eq!((q.contact_points, q.q_msv, q.q_vew, q.q_dcc), (0, 0.0, 0.0, None));
    /// ```
    pub fn of(contacts: &ObjectContacts) -> Result<Self, CoreError> {
        check_contacts(contacts)?;
        let singular_values = grasp_singular_values(&grasp_matrix(contacts))?;
        Ok(Self {
            active_touch_sensors: contacts.active_touch_sensors,
            contact_points: contacts.points.len(),
            singular_values,
            q_msv: msv_of(&singular_values),
            q_vew: vew_of(&singular_values),
            q_dcc: q_dcc(contacts),
        })
    }
}

/// A mean and a (population) standard deviation over `n` samples. `Display`
/// prints `mean±std`, both with the formatter's precision if one is given:
/// `format!("{:.0}", x)` gives `7614±331`, `format!("{:.1}", x)` gives `6.9±2.4`.
///
/// ```
/// use fmsr_core::metrics::MeanStd;
///
/// let x = MeanStd::from_samples(&[1.0, 3.0]).unwrap();
/// assert_eq!((x.mean, x.std, x.n), (2.0, 1.0, 2));
/// assert_eq!(format!("{x:.1}"), "2.0±1.0");
/// assert_eq!(MeanStd::from_samples(&[]), None);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MeanStd {
    /// The mean.
    pub mean: f64,
    /// The population standard deviation, `sqrt((1/n) sum (x - mean)^2)`.
    pub std: f64,
    /// The number of samples.
    pub n: usize,
}

impl MeanStd {
    /// Mean and population standard deviation of `samples`; `None` if empty.
    pub fn from_samples(samples: &[f64]) -> Option<Self> {
        if samples.is_empty() {
            return None;
        }
        let n = samples.len();
        let mean = samples.iter().sum::<f64>() / n as f64;
        let var = samples.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / n as f64;
        Some(Self { mean, std: var.sqrt(), n })
    }

    /// The mean and standard deviation of the union of the sample sets that the
    /// `parts` describe (exact, from their means, deviations and counts):
    /// `N = sum n_j`, `M = sum n_j m_j / N`, `S^2 = sum n_j (s_j^2 + (m_j - M)^2) / N`.
    /// `None` if the parts hold no samples.
    ///
    /// ```
    /// use fmsr_core::metrics::MeanStd;
    ///
    /// let a = MeanStd::from_samples(&[1.0, 2.0]).unwrap();
    /// let b = MeanStd::from_samples(&[4.0, 5.0, 9.0]).unwrap();
    /// let all = MeanStd::from_samples(&[1.0, 2.0, 4.0, 5.0, 9.0]).unwrap();
    /// let pooled = MeanStd::pool(&[a, b]).unwrap();
    /// assert!((pooled.mean - all.mean).abs() < 1e-12 && (pooled.std - all.std).abs() < 1e-12);
    /// ```
    pub fn pool(parts: &[MeanStd]) -> Option<Self> {
        let n: usize = parts.iter().map(|p| p.n).sum();
        if n == 0 {
            return None;
        }
        let mean = parts.iter().map(|p| p.n as f64 * p.mean).sum::<f64>() / n as f64;
        let var = parts.iter().map(|p| p.n as f64 * (p.std * p.std + (p.mean - mean) * (p.mean - mean))).sum::<f64>()
            / n as f64;
        Some(Self { mean, std: var.sqrt(), n })
    }
}

impl fmt::Display for MeanStd {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match f.precision() {
            Some(p) => write!(f, "{:.*}±{:.*}", p, self.mean, p, self.std),
            None => write!(f, "{}±{}", self.mean, self.std),
        }
    }
}

/// The measures of one episode, one [`GraspQuality`] per env step.
///
/// ```
/// use fmsr_core::metrics::GraspTrace;
/// use fmsr_core::prelude::{ContactPoint, ObjectContacts};
///
/// let at = |p: [f64; 3]| ContactPoint { position: p, normal: [0.0, 0.0, 1.0], normal_force: 1.0 };
/// let mut trace = GraspTrace::new(0.04).unwrap();
/// trace.push(&ObjectContacts::default()).unwrap(); // no contact: Q = 0, no Q_DCC
/// trace.push(&ObjectContacts {
///     points: vec![at([1.0, 0.0, 0.0]), at([-1.0, 0.0, 0.0])],
///     center_of_mass: [0.0; 3],
///     active_touch_sensors: 4,
/// })
/// .unwrap();
/// assert_eq!(trace.contacts(), vec![0, 4]);
/// assert_eq!(trace.q_dcc(), vec![None, Some(1.0)]);
/// assert_eq!(trace.dq_msv().len(), 1);
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GraspTrace {
    dt: f64,
    steps: Vec<GraspQuality>,
}

impl GraspTrace {
    /// An empty trace for an environment whose step lasts `dt` seconds (0.04 s
    /// for the Shadow Hand envs: 20 substeps of 0.002 s). The derivatives are
    /// differences between consecutive pushed steps divided by `dt`; if you push
    /// only every k-th step, pass `k * dt`; pass 1 to get per-step differences.
    ///
    /// Errors: [`CoreError::InvalidConfig`] (key `dt`) unless `dt` is finite and positive.
    pub fn new(dt: f64) -> Result<Self, CoreError> {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(CoreError::InvalidConfig {
                key: "dt".into(),
                reason: format!("the env step duration must be finite and positive, got {dt}"),
            });
        }
        Ok(Self { dt, steps: Vec::new() })
    }

    /// The step duration given to [`GraspTrace::new`].
    pub fn dt(&self) -> f64 {
        self.dt
    }

    /// Computes and appends the measures of one step's contacts. Errors as
    /// [`GraspQuality::of`]; on error the trace is unchanged.
    pub fn push(&mut self, contacts: &ObjectContacts) -> Result<&GraspQuality, CoreError> {
        let q = GraspQuality::of(contacts)?;
        self.steps.push(q);
        Ok(&self.steps[self.steps.len() - 1])
    }

    /// Appends measures computed elsewhere.
    pub fn push_quality(&mut self, quality: GraspQuality) {
        self.steps.push(quality);
    }

    /// Removes all steps (keeps `dt`), to reuse the trace for a new episode.
    pub fn clear(&mut self) {
        self.steps.clear();
    }

    /// The per-step measures, in order.
    pub fn steps(&self) -> &[GraspQuality] {
        &self.steps
    }

    /// Number of steps pushed.
    pub fn len(&self) -> usize {
        self.steps.len()
    }

    /// Whether no step has been pushed.
    pub fn is_empty(&self) -> bool {
        self.steps.is_empty()
    }

    /// Per-step number of contacts: active touch sensors (Fig. 4's contact plot).
    pub fn contacts(&self) -> Vec<usize> {
        self.steps.iter().map(|s| s.active_touch_sensors).collect()
    }

    /// Per-step number of contact points of the contact read-out.
    pub fn contact_points(&self) -> Vec<usize> {
        self.steps.iter().map(|s| s.contact_points).collect()
    }

    /// Per-step `Q_MSV` (eq. 16).
    pub fn q_msv(&self) -> Vec<f64> {
        self.steps.iter().map(|s| s.q_msv).collect()
    }

    /// Per-step `Q_VEW` (eq. 17).
    pub fn q_vew(&self) -> Vec<f64> {
        self.steps.iter().map(|s| s.q_vew).collect()
    }

    /// Per-step `Q_DCC` (eq. 18), `None` at steps without contacts.
    pub fn q_dcc(&self) -> Vec<Option<f64>> {
        self.steps.iter().map(|s| s.q_dcc).collect()
    }

    /// `|Q'_MSV|_t = |Q_MSV,t - Q_MSV,t-1| / dt` for `t = 1 .. len-1` (length `len - 1`,
    /// empty with fewer than 2 steps).
    pub fn dq_msv(&self) -> Vec<f64> {
        abs_derivative(&self.q_msv(), self.dt)
    }

    /// `|Q'_VEW|_t = |Q_VEW,t - Q_VEW,t-1| / dt` for `t = 1 .. len-1`.
    pub fn dq_vew(&self) -> Vec<f64> {
        abs_derivative(&self.q_vew(), self.dt)
    }

    /// The episode's Table I quantities; `None` if the trace is empty.
    pub fn summary(&self) -> Option<EpisodeSummary> {
        if self.steps.is_empty() {
            return None;
        }
        let dcc: Vec<f64> = self.steps.iter().filter_map(|s| s.q_dcc).collect();
        Some(EpisodeSummary {
            steps: self.steps.len(),
            total_contacts: self.steps.iter().map(|s| s.active_touch_sensors).sum(),
            total_contact_points: self.steps.iter().map(|s| s.contact_points).sum(),
            q_msv: MeanStd::from_samples(&self.q_msv())?,
            q_vew: MeanStd::from_samples(&self.q_vew())?,
            dq_msv: MeanStd::from_samples(&self.dq_msv()),
            dq_vew: MeanStd::from_samples(&self.dq_vew()),
            q_dcc: MeanStd::from_samples(&dcc),
        })
    }
}

fn abs_derivative(series: &[f64], dt: f64) -> Vec<f64> {
    series.windows(2).map(|w| (w[1] - w[0]).abs() / dt).collect()
}

/// Table I's quantities for one episode ([`GraspTrace::summary`]). Means and
/// standard deviations are over the steps of the episode.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct EpisodeSummary {
    /// Number of steps.
    pub steps: usize,
    /// Sum over the steps of the number of active touch sensors (Table I's
    /// "Total Contact").
    pub total_contacts: usize,
    /// Sum over the steps of the number of contact points of the read-out.
    pub total_contact_points: usize,
    /// `Q_MSV` over all steps (0 at steps with fewer than 2 contacts).
    pub q_msv: MeanStd,
    /// `Q_VEW` over all steps (0 at steps with fewer than 2 contacts).
    pub q_vew: MeanStd,
    /// `|Q'_MSV|` over the `steps - 1` differences; `None` with fewer than 2 steps.
    pub dq_msv: Option<MeanStd>,
    /// `|Q'_VEW|` over the `steps - 1` differences; `None` with fewer than 2 steps.
    pub dq_vew: Option<MeanStd>,
    /// `Q_DCC` (m) over the steps that have contacts; `None` if none has.
    pub q_dcc: Option<MeanStd>,
}

/// One row of Table I's stability columns, aggregated over the episodes of a
/// test set: each cell is the mean ± std **across episodes** of the per-episode
/// value ([`EpisodeSummary`]), so `total_contacts` prints like `7614±331`.
///
/// The paper does not say whether the ± of `|Q'|` is across episodes or over all
/// steps; both are given: `dq_msv` / `dq_vew` are across the episodes' means,
/// `dq_msv_pooled` / `dq_vew_pooled` are over every step difference of every
/// episode ([`MeanStd::pool`]).
///
/// ```
/// use fmsr_core::metrics::{EpisodeSummary, MeanStd, StabilityRow};
///
/// let episode = |contacts: usize, msv: f64| EpisodeSummary {
///     steps: 100,
///     total_contacts: contacts,
///     total_contact_points: contacts,
///     q_msv: MeanStd { mean: msv, std: 0.0, n: 100 },
///     q_vew: MeanStd { mean: 1.0, std: 0.0, n: 100 },
///     dq_msv: None,
///     dq_vew: None,
///     q_dcc: None,
/// };
/// let row = StabilityRow::from_summaries(&[episode(7283, 0.5), episode(7945, 1.5)]).unwrap();
/// assert_eq!(format!("{:.0}", row.total_contacts), "7614±331");
/// assert_eq!(format!("{:.1}", row.q_msv), "1.0±0.5");
/// assert_eq!(row.q_dcc, None);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct StabilityRow {
    /// Number of episodes aggregated.
    pub episodes: usize,
    /// Total contacts per episode.
    pub total_contacts: MeanStd,
    /// Total contact points (of the read-out) per episode.
    pub total_contact_points: MeanStd,
    /// Mean `Q_MSV` per episode.
    pub q_msv: MeanStd,
    /// Mean `Q_VEW` per episode.
    pub q_vew: MeanStd,
    /// Mean `|Q'_MSV|` per episode (episodes with at least 2 steps); `None` if none.
    pub dq_msv: Option<MeanStd>,
    /// Mean `|Q'_VEW|` per episode (episodes with at least 2 steps); `None` if none.
    pub dq_vew: Option<MeanStd>,
    /// `|Q'_MSV|` over all step differences of all episodes.
    pub dq_msv_pooled: Option<MeanStd>,
    /// `|Q'_VEW|` over all step differences of all episodes.
    pub dq_vew_pooled: Option<MeanStd>,
    /// Mean `Q_DCC` (m) per episode (episodes with contacts); `None` if none.
    pub q_dcc: Option<MeanStd>,
}

impl StabilityRow {
    /// Aggregates episode summaries; `None` if `summaries` is empty.
    pub fn from_summaries(summaries: &[EpisodeSummary]) -> Option<Self> {
        let across = |f: &dyn Fn(&EpisodeSummary) -> Option<f64>| -> Option<MeanStd> {
            MeanStd::from_samples(&summaries.iter().filter_map(f).collect::<Vec<_>>())
        };
        let pooled = |f: &dyn Fn(&EpisodeSummary) -> Option<MeanStd>| -> Option<MeanStd> {
            MeanStd::pool(&summaries.iter().filter_map(f).collect::<Vec<_>>())
        };
        Some(Self {
            episodes: summaries.len(),
            total_contacts: across(&|s| Some(s.total_contacts as f64))?,
            total_contact_points: across(&|s| Some(s.total_contact_points as f64))?,
            q_msv: across(&|s| Some(s.q_msv.mean))?,
            q_vew: across(&|s| Some(s.q_vew.mean))?,
            dq_msv: across(&|s| s.dq_msv.map(|d| d.mean)),
            dq_vew: across(&|s| s.dq_vew.map(|d| d.mean)),
            dq_msv_pooled: pooled(&|s| s.dq_msv),
            dq_vew_pooled: pooled(&|s| s.dq_vew),
            q_dcc: across(&|s| s.q_dcc.map(|d| d.mean)),
        })
    }
}

/// How an unsuccessful episode failed (paper Fig. 2, docs/design.md 3.9).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FailureType {
    /// The object fell off the hand (its centre fell below the palm by more
    /// than a margin, or left the safe region by a large distance).
    Drop,
    /// The object stayed in the hand but did not reach the goal in time.
    Incomplete,
}

impl fmt::Display for FailureType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Drop => "drop",
            Self::Incomplete => "incomplete",
        })
    }
}

/// The outcome of one test episode ([`classify`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EpisodeOutcome {
    /// The object turned and held: the final goal distance under the
    /// threshold, and never dropped.
    Success,
    /// Dropped at some step, or not turned into the goal.
    Failure(FailureType),
}

/// The outcome of a test episode (Table II): a drop if the object was dropped
/// at any step, else success when the final goal distance is below
/// `threshold`, else incomplete. An object turned into the goal but dropped
/// on the way is a drop: success is an object turned and held.
///
/// ```
/// use fmsr_core::metrics::{EpisodeOutcome, FailureType, classify};
/// assert_eq!(classify(0.1, 0.4, false), EpisodeOutcome::Success);
/// assert_eq!(classify(0.1, 0.4, true), EpisodeOutcome::Failure(FailureType::Drop));
/// assert_eq!(classify(1.0, 0.4, true), EpisodeOutcome::Failure(FailureType::Drop));
/// assert_eq!(classify(1.0, 0.4, false), EpisodeOutcome::Failure(FailureType::Incomplete));
/// ```
#[must_use]
pub fn classify(final_distance: f32, threshold: f32, dropped: bool) -> EpisodeOutcome {
    if dropped {
        EpisodeOutcome::Failure(FailureType::Drop)
    } else if final_distance < threshold {
        EpisodeOutcome::Success
    } else {
        EpisodeOutcome::Failure(FailureType::Incomplete)
    }
}

/// Counts of episode outcomes, for the success rate and Table II.
///
/// ```
/// use fmsr_core::metrics::{EpisodeOutcome, FailureCounts, FailureType};
///
/// let mut outcomes = vec![EpisodeOutcome::Success; 439];
/// outcomes.extend(vec![EpisodeOutcome::Failure(FailureType::Incomplete); 60]);
/// outcomes.push(EpisodeOutcome::Failure(FailureType::Drop));
/// let counts: FailureCounts = outcomes.into_iter().collect();
/// let row = counts.row();
/// assert_eq!((row.failures, row.incomplete, row.drop), (61, 60, 1));
/// assert_eq!(format!("{:.1}%", row.incomplete_percent.unwrap()), "98.4%");
/// assert_eq!(format!("{:.1}%", row.drop_percent.unwrap()), "1.6%");
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct FailureCounts {
    /// Episodes recorded.
    pub episodes: usize,
    /// Successful episodes.
    pub successes: usize,
    /// Failures of type [`FailureType::Incomplete`].
    pub incomplete: usize,
    /// Failures of type [`FailureType::Drop`].
    pub drop: usize,
}

impl FailureCounts {
    /// No episodes yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Counts one episode.
    pub fn record(&mut self, outcome: EpisodeOutcome) {
        self.episodes += 1;
        match outcome {
            EpisodeOutcome::Success => self.successes += 1,
            EpisodeOutcome::Failure(FailureType::Incomplete) => self.incomplete += 1,
            EpisodeOutcome::Failure(FailureType::Drop) => self.drop += 1,
        }
    }

    /// Unsuccessful episodes (`incomplete + drop`).
    pub fn failures(&self) -> usize {
        self.incomplete + self.drop
    }

    /// Fraction of successful episodes in `[0, 1]`; `None` with no episodes.
    pub fn success_rate(&self) -> Option<f64> {
        (self.episodes > 0).then(|| self.successes as f64 / self.episodes as f64)
    }

    /// Table II's columns.
    pub fn row(&self) -> FailureRow {
        let failures = self.failures();
        let percent = |k: usize| (failures > 0).then(|| 100.0 * k as f64 / failures as f64);
        FailureRow {
            failures,
            incomplete: self.incomplete,
            incomplete_percent: percent(self.incomplete),
            drop: self.drop,
            drop_percent: percent(self.drop),
        }
    }
}

impl Extend<EpisodeOutcome> for FailureCounts {
    fn extend<I: IntoIterator<Item = EpisodeOutcome>>(&mut self, iter: I) {
        for outcome in iter {
            self.record(outcome);
        }
    }
}

impl FromIterator<EpisodeOutcome> for FailureCounts {
    fn from_iter<I: IntoIterator<Item = EpisodeOutcome>>(iter: I) -> Self {
        let mut counts = Self::new();
        counts.extend(iter);
        counts
    }
}

/// One row of Table II: number of failures, and how many (and what percentage of
/// the failures) were incomplete and drops. The percentages are `None` when there
/// are no failures.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FailureRow {
    /// Number of failures ("# of F").
    pub failures: usize,
    /// Incomplete failures.
    pub incomplete: usize,
    /// Incomplete failures, percent of the failures.
    pub incomplete_percent: Option<f64>,
    /// Drops.
    pub drop: usize,
    /// Drops, percent of the failures.
    pub drop_percent: Option<f64>,
}
