//! Rigid transforms and the forward kinematics of an MJCF body tree.
//!
//! MuJoCo places body `b` with parent `p` at
//!
//! ```text
//! X_b = X_p · (pos_b, quat_b) · Π_j T(p_j) · R(a_j, q_j) · T(−p_j)
//! ```
//!
//! over the body's hinge joints `j` (anchor `p_j`, axis `a_j`, angle `q_j`, all in
//! the body frame), in their declared order. A body with a free joint is placed
//! directly at the pose its free joint holds.

use mjcf_rs::Model;
use mjcf_rs::body::JointType;

use crate::error::EnvError;

/// A rigid transform `x ↦ R x + t`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Iso {
    /// The rotation matrix (rows).
    pub r: [[f64; 3]; 3],
    /// The translation.
    pub t: [f64; 3],
}

impl Iso {
    /// The identity.
    pub const IDENTITY: Self = Self { r: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], t: [0.0; 3] };

    /// The transform of a position and a unit quaternion `[w, x, y, z]` (normalised here).
    #[must_use]
    pub fn from_pose(t: [f64; 3], q: [f64; 4]) -> Self {
        let n = q.iter().map(|v| v * v).sum::<f64>().sqrt();
        let [w, x, y, z] = if n > 0.0 { q.map(|v| v / n) } else { [1.0, 0.0, 0.0, 0.0] };
        let r = [
            [1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - w * z), 2.0 * (x * z + w * y)],
            [2.0 * (x * y + w * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - w * x)],
            [2.0 * (x * z - w * y), 2.0 * (y * z + w * x), 1.0 - 2.0 * (x * x + y * y)],
        ];
        Self { r, t }
    }

    /// The rotation by `angle` about the unit-normalised `axis` through `anchor`.
    #[must_use]
    pub fn rotation_about(axis: [f64; 3], angle: f64, anchor: [f64; 3]) -> Self {
        let n = norm(axis);
        let a = if n > 0.0 { axis.map(|v| v / n) } else { [0.0, 0.0, 1.0] };
        let (s, c) = (angle / 2.0).sin_cos();
        let rot = Self::from_pose([0.0; 3], [c, s * a[0], s * a[1], s * a[2]]);
        let moved = rot.rotate(anchor);
        Self { r: rot.r, t: [anchor[0] - moved[0], anchor[1] - moved[1], anchor[2] - moved[2]] }
    }

    /// `R v`.
    #[must_use]
    pub fn rotate(&self, v: [f64; 3]) -> [f64; 3] {
        self.r.map(|row| row[0] * v[0] + row[1] * v[1] + row[2] * v[2])
    }

    /// `R x + t`.
    #[must_use]
    pub fn apply(&self, x: [f64; 3]) -> [f64; 3] {
        let r = self.rotate(x);
        [r[0] + self.t[0], r[1] + self.t[1], r[2] + self.t[2]]
    }

    /// `self · other` (first `other`, then `self`).
    #[must_use]
    pub fn then(&self, other: &Self) -> Self {
        let mut r = [[0.0; 3]; 3];
        for (i, row) in r.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                *v = (0..3).map(|k| self.r[i][k] * other.r[k][j]).sum();
            }
        }
        Self { r, t: self.apply(other.t) }
    }
}

pub(crate) fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// The transform of an `mjcf_rs` pose.
pub(crate) fn iso_of(pose: &mjcf_rs::Pose) -> Iso {
    let (t, q) = (pose.translation, pose.rotation);
    Iso::from_pose([t.x, t.y, t.z], [q.w, q.x, q.y, q.z])
}

/// One hinge of a body.
#[derive(Debug, Clone)]
struct Hinge {
    /// Index into the `qpos` slice given to [`BodyTree::forward`] (`None`: held at 0).
    qpos: Option<usize>,
    anchor: [f64; 3],
    axis: [f64; 3],
}

#[derive(Debug, Clone)]
struct Node {
    parent: Option<usize>,
    local: Iso,
    hinges: Vec<Hinge>,
    free: bool,
}

/// The body tree of a model, indexed like `Model::bodies` (0 is the world).
#[derive(Debug, Clone)]
pub struct BodyTree {
    nodes: Vec<Node>,
}

impl BodyTree {
    /// Builds the tree; `qpos_index` maps a hinge's name to its index in the
    /// `qpos` given to [`BodyTree::forward`] (unnamed or unmapped hinges stay at 0).
    ///
    /// # Errors
    /// [`EnvError::Model`] for slide or ball joints, or a parent listed after its child.
    pub fn new(model: &Model, qpos_index: impl Fn(&str) -> Option<usize>) -> Result<Self, EnvError> {
        let mut nodes = Vec::with_capacity(model.bodies.len());
        for (i, entry) in model.bodies.iter().enumerate() {
            if entry.parent.is_some_and(|p| p >= i) {
                return Err(EnvError::Model(format!("body {i} is listed before its parent")));
            }
            let mut hinges = Vec::new();
            let mut free = false;
            for joint in &entry.body.joints {
                match joint.type_ {
                    JointType::Hinge => hinges.push(Hinge {
                        qpos: joint.name.as_deref().and_then(&qpos_index),
                        anchor: joint.pos,
                        axis: joint.axis,
                    }),
                    JointType::Free => free = true,
                    other => {
                        let name = joint.name.clone().unwrap_or_default();
                        return Err(EnvError::Model(format!("joint {name}: {other:?} joints are not drawn")));
                    }
                }
            }
            nodes.push(Node { parent: entry.parent, local: iso_of(&entry.body.pose), hinges, free });
        }
        Ok(Self { nodes })
    }

    /// Number of bodies, the world included.
    #[must_use]
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// Whether the tree has no body (not even the world).
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// The world pose of every body for the hinge angles `qpos`; a body with a
    /// free joint gets `free(body)` (its rest pose where that is `None`).
    #[must_use]
    pub fn forward(&self, qpos: &[f64], free: impl Fn(usize) -> Option<Iso>) -> Vec<Iso> {
        let mut world: Vec<Iso> = Vec::with_capacity(self.nodes.len());
        for (i, node) in self.nodes.iter().enumerate() {
            let parent = node.parent.map_or(Iso::IDENTITY, |p| world[p]);
            let rest = parent.then(&node.local);
            let pose = if node.free {
                free(i).unwrap_or(rest)
            } else {
                node.hinges.iter().fold(rest, |x, h| {
                    let q = h.qpos.and_then(|k| qpos.get(k)).copied().unwrap_or(0.0);
                    x.then(&Iso::rotation_about(h.axis, q, h.anchor))
                })
            };
            world.push(pose);
        }
        world
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
        norm([a[0] - b[0], a[1] - b[1], a[2] - b[2]])
    }

    proptest! {
        // Guards the rigidity of every transform the renderer composes: a
        // rotation about any axis through any anchor keeps distances and fixes the anchor.
        #[test]
        fn rotations_about_an_anchor_are_rigid(
            axis in prop::array::uniform3(-1.0f64..1.0), angle in -7.0f64..7.0,
            anchor in prop::array::uniform3(-1.0f64..1.0),
            a in prop::array::uniform3(-1.0f64..1.0), b in prop::array::uniform3(-1.0f64..1.0),
        ) {
            prop_assume!(norm(axis) > 1e-3);
            let x = Iso::rotation_about(axis, angle, anchor);
            prop_assert!((dist(x.apply(a), x.apply(b)) - dist(a, b)).abs() < 1e-9);
            prop_assert!(dist(x.apply(anchor), anchor) < 1e-9);
        }

        // Guards the composition order: (A · B) x = A (B x).
        #[test]
        fn composition_applies_right_to_left(
            qa in prop::array::uniform4(-1.0f64..1.0), qb in prop::array::uniform4(-1.0f64..1.0),
            ta in prop::array::uniform3(-1.0f64..1.0), tb in prop::array::uniform3(-1.0f64..1.0),
            x in prop::array::uniform3(-1.0f64..1.0),
        ) {
            let (a, b) = (Iso::from_pose(ta, qa), Iso::from_pose(tb, qb));
            prop_assert!(dist(a.then(&b).apply(x), a.apply(b.apply(x))) < 1e-9);
        }
    }

    #[test]
    fn a_quarter_turn_about_z_maps_x_to_y() {
        let x = Iso::rotation_about([0.0, 0.0, 2.0], std::f64::consts::FRAC_PI_2, [0.0; 3]);
        assert!(dist(x.apply([1.0, 0.0, 0.0]), [0.0, 1.0, 0.0]) < 1e-12);
    }
}
