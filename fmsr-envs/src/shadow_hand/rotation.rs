//! The goal distance of the rotation tasks and the orientation measures of
//! the test records (docs/design.md 4.1).
//!
//! Orientations are unit quaternions `q = [w, x, y, z]`. The **full angle**
//! between two orientations is the angle of the rotation that takes one to
//! the other, the geodesic distance on SO(3):
//!
//! ```text
//! d(q_a, q_b) = 2 atan2(|v|, |w|),   [w, v] = q_a * conj(q_b),   d in [0, pi]
//! ```
//!
//! gymnasium-robotics' `manipulate.py` (`_goal_distance`, rotation goals,
//! rotate-Z tasks included) computes `2 arccos(clip(w, -1, 1))` of the same
//! product. That is this angle when `w >= 0`; when `w < 0` (`q_a` and `q_b`
//! on opposite hemispheres of the double cover, `q` and `-q` being one
//! orientation) gym's value is `2 pi - d`, so the same physical orientation
//! can be at 0 or at `2 pi` from its goal depending on the sign of MuJoCo's
//! quaternion. We take `|w|`: the distance is a function of the orientations
//! alone. Where gym's value is below `pi` the two agree exactly, so every
//! success (0.1 or 0.4 rad) gym counts is one here; gym also counts as
//! failures some objects that are at the goal (docs/design.md 4.1). The
//! `atan2` form, in `f64`, keeps its precision near 0, where `arccos` loses
//! it (the `w` of an error of 1e-3 rad is `1 - 1.25e-7`, two `f32` steps below 1).
//!
//! The **gym angle** (`GoalDistance::Gym`) is gymnasium-robotics' formula
//! itself, `2 arccos(clip(w, -1, 1))` of `q_a * conj(q_b)` (in `f64`), over
//! `[0, 2 pi]`: it tells `q` from `-q`. It is a distance between quaternions,
//! not orientations, so under it the task keeps the engine's quaternion as it
//! is (MuJoCo's `qpos` is continuous along the motion and never flips sign):
//! an object turned the short way across yaw = `+-pi` to the goal's
//! orientation reaches `-q_goal`, `2 pi` away. The object must be turned the
//! direct way, as the paper's eq. 10 (`R1 = -|z_t - z_g|`) says.
//!
//! The **yaw error** (`GoalDistance::Yaw`) compares the rotations about Z
//! alone, wrapped to `[0, pi]`: the distance of every record made before
//! the full-angle task (CHANGELOG). It is blind to a tilted or fallen object.
//!
//! The **tilt** is the angle between the object's own Z axis and the world's:
//! 0 for an upright object, `pi / 2` for one on its side.

use serde::{Deserialize, Serialize};

/// How the rotation tasks measure the distance between the achieved and the
/// desired orientation: for the dense reward R1 (paper eq. 10), HER's
/// relabelled rewards, training success and test success.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum GoalDistance {
    /// The full angle between the two orientations, in `[0, pi]`: gym's
    /// measure with `q` and `-q` taken as one orientation (the default).
    #[default]
    Full,
    /// gymnasium-robotics' `_goal_distance` exactly, `2 arccos(w)` over
    /// `[0, 2 pi]`, with the engine's quaternion sign kept in the
    /// observation, the achieved goal and the records (the paper's stack).
    Gym,
    /// The difference of the rotations about Z alone: records made before
    /// the full-angle task, kept so that they can be reproduced.
    Yaw,
}

impl GoalDistance {
    /// The distance between the orientations `a` and `b` (`[w, x, y, z]`), in
    /// `[0, pi]` (`[0, 2 pi]` for [`GoalDistance::Gym`]).
    ///
    /// ```
    /// use fmsr_envs::shadow_hand::GoalDistance;
    /// let upright = [1.0, 0.0, 0.0, 0.0];
    /// let on_its_side = [0.5f32.sqrt(), 0.5f32.sqrt(), 0.0, 0.0]; // pi/2 about X
    /// assert!(GoalDistance::Yaw.between(&on_its_side, &upright) < 1e-6);
    /// assert!((GoalDistance::Full.between(&on_its_side, &upright) - std::f32::consts::FRAC_PI_2).abs() < 1e-6);
    /// let flipped = [-1.0, 0.0, 0.0, 0.0]; // the upright orientation, the other sign
    /// assert!(GoalDistance::Full.between(&flipped, &upright) < 1e-6);
    /// assert!((GoalDistance::Gym.between(&flipped, &upright) - std::f32::consts::TAU).abs() < 1e-6);
    /// ```
    #[must_use]
    pub fn between(self, a: &[f32], b: &[f32]) -> f32 {
        match self {
            Self::Full => full_angle(a, b),
            Self::Gym => gym_angle(a, b),
            Self::Yaw => yaw_error(a, b),
        }
    }

    /// The name in configs and records: `"full"`, `"gym"` or `"yaw"`.
    #[must_use]
    pub fn key(self) -> &'static str {
        match self {
            Self::Full => "full",
            Self::Gym => "gym",
            Self::Yaw => "yaw",
        }
    }

    /// Every distance, in the order of [`GoalDistance::key`]'s list.
    pub const ALL: [Self; 3] = [Self::Full, Self::Gym, Self::Yaw];

    /// Whether the task keeps the engine's quaternion sign in observations
    /// and achieved goals (only [`GoalDistance::Gym`] tells the two signs
    /// apart; the others see `w >= 0`).
    #[must_use]
    pub fn keeps_sign(self) -> bool {
        self == Self::Gym
    }
}

fn quat(q: &[f32]) -> [f64; 4] {
    [q[0], q[1], q[2], q[3]].map(f64::from)
}

/// The angle of the rotation between the orientations `a` and `b`
/// (`[w, x, y, z]`, any norm), in `[0, pi]`: `q` and `-q` are the same orientation.
#[must_use]
pub fn full_angle(a: &[f32], b: &[f32]) -> f32 {
    let ([w1, x1, y1, z1], [w2, x2, y2, z2]) = (quat(a), quat(b));
    // q_a * conj(q_b): w = q_a . q_b, v = w2 v1 - w1 v2 - v1 x v2.
    let w = w1 * w2 + x1 * x2 + y1 * y2 + z1 * z2;
    let v = [
        w2 * x1 - w1 * x2 - (y1 * z2 - z1 * y2),
        w2 * y1 - w1 * y2 - (z1 * x2 - x1 * z2),
        w2 * z1 - w1 * z2 - (x1 * y2 - y1 * x2),
    ];
    let s = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    (2.0 * s.atan2(w.abs())) as f32
}

/// gymnasium-robotics' `_goal_distance` for rotation goals:
/// `2 arccos(clip(w, -1, 1))` of `q_a * conj(q_b)` (`[w, x, y, z]`), in
/// `[0, 2 pi]`, computed in `f64` as gym computes it. `w` of the product is
/// the dot product of the two quaternions.
#[must_use]
pub fn gym_angle(a: &[f32], b: &[f32]) -> f32 {
    let ([w1, x1, y1, z1], [w2, x2, y2, z2]) = (quat(a), quat(b));
    let w = w1 * w2 + x1 * x2 + y1 * y2 + z1 * z2;
    (2.0 * w.clamp(-1.0, 1.0).acos()) as f32
}

/// The rotation angle about Z of `q` (`[w, x, y, z]`): yaw, in `[-pi, pi]`.
/// In `f32`, as every record of the yaw distance was computed.
#[must_use]
pub fn yaw(q: &[f32]) -> f32 {
    let (w, x, y, z) = (q[0], q[1], q[2], q[3]);
    (2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z))
}

/// `|yaw(a) - yaw(b)|` wrapped to `[0, pi]` (in `f32`, bit for bit the
/// distance of the records older than the full-angle task).
#[must_use]
pub fn yaw_error(a: &[f32], b: &[f32]) -> f32 {
    let d = (yaw(a) - yaw(b)).rem_euclid(std::f32::consts::TAU);
    d.min(std::f32::consts::TAU - d)
}

/// The angle between the object's Z axis, turned by `q` (`[w, x, y, z]`, unit),
/// and the world's Z axis, in `[0, pi]`.
#[must_use]
pub fn tilt(q: &[f32]) -> f32 {
    let [w, x, y, z] = quat(q);
    // The third column of the rotation matrix of q.
    let (cx, cy, cz) = (2.0 * (x * z + w * y), 2.0 * (y * z - w * x), 1.0 - 2.0 * (x * x + y * y));
    cx.hypot(cy).atan2(cz) as f32
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn axis_angle(axis: [f64; 3], angle: f64) -> [f32; 4] {
        let n = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt();
        let s = (angle / 2.0).sin() / n;
        [(angle / 2.0).cos(), axis[0] * s, axis[1] * s, axis[2] * s].map(|v| v as f32)
    }

    fn mul(a: [f32; 4], b: [f32; 4]) -> [f32; 4] {
        let [w1, x1, y1, z1] = a;
        let [w2, x2, y2, z2] = b;
        [
            w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
            w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
            w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
        ]
    }

    // Guards the reason the full angle exists: an egg at the goal's yaw but
    // lying on its side is far from an upright goal; the yaw error calls it
    // a success (measured on the shipped egg policy: 31 yaw successes, 2 by
    // the full angle).
    #[test]
    fn a_tilted_object_at_the_right_yaw_is_not_at_the_goal() {
        let goal = axis_angle([0.0, 0.0, 1.0], 0.7);
        let on_its_side = mul(goal, axis_angle([1.0, 0.0, 0.0], 1.2));
        assert!(yaw_error(&on_its_side, &goal) < 0.4, "the yaw error does not see the tilt");
        assert!((full_angle(&on_its_side, &goal) - 1.2).abs() < 1e-5);
        assert!((tilt(&on_its_side) - 1.2).abs() < 1e-5);
        assert!(GoalDistance::Full.between(&on_its_side, &goal) > 0.4);
    }

    // Guards the double cover: q and -q are one orientation (gym's
    // `2 arccos(w)` would put them 2 pi apart), and turning across yaw = pi
    // the short way is a short distance.
    #[test]
    fn the_sign_of_a_quaternion_does_not_move_it() {
        let q = axis_angle([0.3, -0.2, 0.9], 2.0);
        assert!(full_angle(&q, &q.map(|v| -v)) < 1e-6);
        let (a, b) = (axis_angle([0.0, 0.0, 1.0], 3.0), axis_angle([0.0, 0.0, 1.0], -3.0));
        assert!((full_angle(&a, &b) - (std::f32::consts::TAU - 6.0)).abs() < 1e-5);
        assert!((yaw_error(&a, &b) - (std::f32::consts::TAU - 6.0)).abs() < 1e-5);
    }

    // Guards gym's double cover (the paper's stack): the goal's orientation
    // reached with the other quaternion sign, as MuJoCo's continuous `qpos`
    // arrives there after turning the short way across yaw = pi, is 2 pi
    // away; reached the direct way, it is at 0.
    #[test]
    fn gym_tells_the_two_signs_apart() {
        let goal = axis_angle([0.0, 0.0, 1.0], 3.0);
        // From yaw -3.0 turned by -0.283 (the short way) the quaternion reaches
        // yaw -3.283 = 3.0 - 2 pi: the goal's orientation, the other sign.
        let short_way = axis_angle([0.0, 0.0, 1.0], 3.0 - std::f64::consts::TAU);
        assert!(full_angle(&short_way, &goal) < 1e-5);
        assert!((gym_angle(&short_way, &goal) - std::f32::consts::TAU).abs() < 1e-5);
        assert!(gym_angle(&goal, &goal) < 1e-3);
        assert!(GoalDistance::Gym.keeps_sign() && !GoalDistance::Full.keeps_sign());
    }

    proptest! {
        // gym's angle is the full angle where the product's w >= 0, and
        // 2 pi less it otherwise.
        #[test]
        fn gym_angle_is_the_full_angle_or_its_complement(
            ax in -1.0f64..1.0, ay in -1.0f64..1.0, az in 0.1f64..1.0, angle in 0.05f64..6.2,
            bx in -1.0f64..1.0, by in -1.0f64..1.0, bz in -1.0f64..1.0, b_angle in -3.1f64..3.1,
        ) {
            let b = axis_angle([bx, by, bz + 1.5], b_angle);
            let a = mul(axis_angle([ax, ay, az], angle), b);
            let (g, f) = (gym_angle(&a, &b), full_angle(&a, &b));
            prop_assert!((g - angle as f32).abs() < 1e-3, "{} vs {}", g, angle);
            let w: f32 = a.iter().zip(&b).map(|(x, y)| x * y).sum();
            let expected = if w >= 0.0 { f } else { std::f32::consts::TAU - f };
            prop_assert!((g - expected).abs() < 1e-3, "{} vs {}", g, expected);
            prop_assert!((0.0..=std::f32::consts::TAU + 1e-6).contains(&g));
        }

        // The full angle is the angle of the rotation that takes one orientation
        // to the other: symmetric, the same for either sign of either
        // quaternion, in [0, pi].
        #[test]
        fn full_angle_is_the_rotation_between(
            ax in -1.0f64..1.0, ay in -1.0f64..1.0, az in 0.1f64..1.0, angle in 0.0f64..3.1,
            bx in -1.0f64..1.0, by in -1.0f64..1.0, bz in -1.0f64..1.0, b_angle in -3.1f64..3.1,
        ) {
            let r = axis_angle([ax, ay, az], angle);
            let b = axis_angle([bx, by, bz + 1.5], b_angle);
            let a = mul(r, b);
            let d = full_angle(&a, &b);
            prop_assert!((d - angle as f32).abs() < 1e-4, "{} vs {}", d, angle);
            prop_assert!((full_angle(&b, &a) - d).abs() < 1e-5);
            prop_assert!((full_angle(&a.map(|v| -v), &b) - d).abs() < 1e-5);
            prop_assert!((0.0..=std::f32::consts::PI + 1e-6).contains(&d));
        }

        #[test]
        fn about_z_the_two_distances_agree(a in -3.1f64..3.1, b in -3.1f64..3.1) {
            let (qa, qb) = (axis_angle([0.0, 0.0, 1.0], a), axis_angle([0.0, 0.0, 1.0], b));
            prop_assert!((full_angle(&qa, &qb) - yaw_error(&qa, &qb)).abs() < 1e-4);
            prop_assert!(tilt(&qa) < 1e-4);
        }
    }
}
