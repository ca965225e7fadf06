//! The small physics interface the Shadow Hand task is written against, so
//! that a MuJoCo backend reuses the task code and only the physics differs.

use fmsr_core::env::ObjectContacts;

/// A Shadow Hand scene (24 hand joints, 20 position actuators, 92 touch
/// sensors, one free object) driven by the task in [`super::ShadowHand`].
///
/// Quaternions are `[w, x, y, z]` (MuJoCo's order); positions in metres, in
/// the world frame of the MJCF model.
pub trait HandPhysics {
    /// The model's timestep, the length of one substep (s; 0.002).
    fn timestep(&self) -> f64;

    /// The `ctrlrange` of each of the 20 actuators, in the model's order.
    fn ctrl_range(&self) -> &[[f64; 2]];

    /// The names of the 92 touch sensors (`robot0:TS_*`), in the model's order.
    fn touch_names(&self) -> &[String];

    /// Puts the scene back into the model's initial state: hand joints at
    /// `qpos0`, everything at rest, controls at zero.
    fn reset(&mut self);

    /// Places the object (zero velocity).
    fn set_object_pose(&mut self, position: [f64; 3], quaternion: [f64; 4]);

    /// Sets the 20 actuator controls (clamped to `ctrlrange`, like MuJoCo's `ctrllimited`).
    fn set_ctrl(&mut self, ctrl: &[f64]);

    /// Advances the model's time by `substeps` x [`HandPhysics::timestep`] (a
    /// backend may cover that time with fewer, longer steps of its own). The touch
    /// readings afterwards are those of this interval.
    fn step(&mut self, substeps: usize);

    /// The 24 hand joint positions in MuJoCo's `qpos` order.
    fn hand_qpos(&self, out: &mut [f64]);

    /// The 24 hand joint velocities in MuJoCo's `qvel` order.
    fn hand_qvel(&self, out: &mut [f64]);

    /// The object's position and orientation `[w, x, y, z]`.
    fn object_pose(&self) -> ([f64; 3], [f64; 4]);

    /// The object's free-joint velocity as MuJoCo lays it out: linear velocity in
    /// the world frame, angular velocity in the object's frame.
    fn object_qvel(&self) -> [f64; 6];

    /// The 92 touch readings (N): the mean over the last [`HandPhysics::step`]'s
    /// substeps of the contact normal force inside each sensor's box.
    fn touch(&self) -> &[f64];

    /// The palm centre in the world frame (for the `safe_region` feature).
    fn palm_center(&self) -> [f64; 3];

    /// The object's contacts with the hand at the end of the last step.
    fn object_contacts(&self) -> ObjectContacts;
}
