//! Touch sensors: each `robot0:TS_*` site box on its body reads the summed
//! normal force (impulse / dt) of the contact points inside it, averaged over
//! the rapier steps of one env step; every contact of its body, finger on finger
//! included, as MuJoCo's do ([`RapierSettings::touch_every_contact`]), or only
//! the object's.
//!
//! [`RapierSettings::touch_every_contact`]: super::RapierSettings::touch_every_contact

use rapier3d::math::{Pose, Real, Rotation, Vector};
use rapier3d::prelude::*;
use rapier3d_mjcf::MjcfRobot;
use rapier3d_mjcf::mjcf_rs::Model;

use super::super::model::{TouchSensorSite, touch_sensor_sites};
use super::RapierHand;
use super::missing;
use crate::error::EnvError;

/// One touch sensor: a box on a body.
#[derive(Debug, Clone)]
pub(super) struct TouchSite {
    /// Rapier body index in `MjcfRobot::bodies`.
    pub(super) body: usize,
    /// The site's pose in the body frame.
    pub(super) pose: Pose,
    pub(super) half: Vector,
}

/// The touch sensors' names and site boxes on the rapier bodies, in the model's sensor order.
pub(super) fn touch_sites(robot: &MjcfRobot, model: &Model) -> Result<(Vec<String>, Vec<TouchSite>), EnvError> {
    let mut touch_names = Vec::new();
    let mut touch_sites = Vec::new();
    for TouchSensorSite { name, body, site } in touch_sensor_sites(model)? {
        let body_name = model.bodies[body].body.name.clone().unwrap_or_default();
        let body = *robot.body_name_to_idx.get(&body_name).ok_or_else(|| missing("body", &body_name))?;
        let t = site.pose.translation;
        let q = site.pose.rotation;
        touch_sites.push(TouchSite {
            body,
            pose: Pose::from_parts(
                Vector::new(t.x as Real, t.y as Real, t.z as Real),
                Rotation::from_xyzw(q.x as Real, q.y as Real, q.z as Real, q.w as Real).normalize(),
            ),
            half: Vector::new(site.size[0] as Real, site.size[1] as Real, site.size[2] as Real),
        });
        touch_names.push(name);
    }
    Ok((touch_names, touch_sites))
}

impl RapierHand {
    /// Adds the normal forces of this step's contacts to the touch sensors whose
    /// box holds them: every contact of the sensor's body
    /// ([`RapierSettings::touch_every_contact`](super::RapierSettings::touch_every_contact), MuJoCo's rule), or only the object's.
    pub(super) fn accumulate_touch(&mut self) {
        let dt = self.world.integration_parameters.dt;
        let mut hits: Vec<(usize, f64)> = Vec::new();
        let bodies = &self.world.bodies;
        let mut read = |p: Vector, impulse: Real, body: RigidBodyHandle| {
            let (Some(sensors), Some(rb)) = (self.sensors_of_body.get(&body), bodies.get(body)) else { return };
            let local_body = rb.position().inverse_transform_point(p);
            for &i in sensors {
                let s = &self.model.touch_sites[i];
                let q = s.pose.inverse_transform_point(local_body).abs();
                if q.x <= s.half.x && q.y <= s.half.y && q.z <= s.half.z {
                    hits.push((i, f64::from(impulse / dt)));
                }
            }
        };
        if self.settings.touch_every_contact {
            self.for_each_contact(|p, impulse, b1, b2| {
                for body in [b1, b2].into_iter().flatten() {
                    read(p, impulse, body);
                }
            });
        } else {
            self.for_each_object_contact(|p, _n, impulse, other| {
                if let Some(other) = other {
                    read(p, impulse, other);
                }
            });
        }
        for (i, f) in hits {
            self.touch_sum[i] += f;
        }
    }
}
