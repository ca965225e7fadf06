//! Drawing the Shadow Hand headless, on the CPU, in pure Rust: no GPU, no
//! display, no MuJoCo — so an episode of either engine can be watched on any
//! machine that builds this crate.
//!
//! A frame is drawn from a [`HandView`] (the 24 joint angles, the object's pose,
//! the goal and the active touch sensors), which both engines give through
//! [`ShadowHand::view`](super::ShadowHand::view). The hand is placed by the
//! forward kinematics of the MJCF body tree ([`kinematics`]):
//!
//! ```text
//! X_b = X_parent · (pos_b, quat_b) · Π_j T(p_j) · R(a_j, q_j) · T(−p_j)
//! ```
//!
//! and its visual meshes (the model's STL files, group 1) are rasterised with a
//! z-buffer and flat Lambert shading under MuJoCo's headlight and the scene's
//! top light, from gymnasium-robotics' camera ([`Camera::gym`]). The object's
//! faces are coloured so that its rotation reads at a glance; the goal is the
//! same object, paler, drawn 0.15 m beside it along `x` as gymnasium-robotics'
//! `_render_callback` does for rotation-only tasks; active touch sensors are
//! drawn as red boxes.

pub mod kinematics;
mod raster;

use std::path::Path;

use mjcf_rs::Model;
use mjcf_rs::body::{Geom, GeomType};
use serde::{Deserialize, Serialize};

pub use self::kinematics::{BodyTree, Iso};
pub use self::raster::{Camera, Canvas, Image, Projector};
use self::raster::{cross, dot};
use super::assets::HandAssets;
use super::model::{HAND_JOINTS, HandObject, NUM_TOUCH, PREFIX, TouchSensorSite, inline_includes, touch_sensor_sites};
use crate::error::EnvError;

/// What a frame shows: the state of the scene after one env step.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HandView {
    /// The 24 hand joint positions in MuJoCo's `qpos` order (rad).
    pub qpos: Vec<f64>,
    /// The object's position (m).
    pub object_position: [f64; 3],
    /// The object's orientation `[w, x, y, z]`.
    pub object_quaternion: [f64; 4],
    /// The goal position (m).
    pub goal_position: [f64; 3],
    /// The goal orientation `[w, x, y, z]`.
    pub goal_quaternion: [f64; 4],
    /// Whether each of the 92 touch sensors is active, in the model's order.
    pub touch_active: Vec<bool>,
}

/// How far beside the object the goal is drawn along `x` (m; gymnasium-robotics' offset).
pub const GOAL_OFFSET_X: f64 = 0.15;

/// Linear RGB in `[0, 1]`.
type Rgb = [f64; 3];

const HAND_COLOR: Rgb = [0.93, 0.93, 0.93];
const TOUCH_COLOR: Rgb = [0.9, 0.1, 0.1];
/// The object's face colours, for the faces facing `+x, −x, +y, −y, +z, −z` of its own frame.
const FACE_COLORS: [Rgb; 6] =
    [[0.85, 0.2, 0.2], [0.2, 0.75, 0.8], [0.25, 0.7, 0.25], [0.75, 0.3, 0.75], [0.25, 0.35, 0.9], [0.95, 0.8, 0.2]];
/// gymnasium-robotics' skybox gradient (`shared_asset.xml`).
const SKY: ([u8; 3], [u8; 3]) = ([112, 217, 143], [117, 222, 148]);

/// Triangles fixed to one body.
#[derive(Debug, Clone)]
struct Part {
    body: usize,
    local: Iso,
    triangles: Vec<[[f64; 3]; 3]>,
    colors: Vec<Rgb>,
}

/// A touch sensor's box on its body.
#[derive(Debug, Clone)]
struct TouchBox {
    body: usize,
    local: Iso,
    half: [f64; 3],
}

/// The drawable model: the body tree, the meshes on each body and the touch
/// sensor boxes. Load it once and draw any number of [`HandView`]s.
#[derive(Debug, Clone)]
pub struct HandScene {
    tree: BodyTree,
    parts: Vec<Part>,
    touch: Vec<TouchBox>,
    object_body: usize,
    target_body: usize,
}

impl HandScene {
    /// Loads the scene of `object` (block or egg, with 92 touch sensors) from the fetched model.
    ///
    /// # Errors
    /// [`EnvError::Model`] or [`EnvError::Io`] when the MJCF or a mesh cannot be read.
    pub fn load(assets: &HandAssets, object: HandObject) -> Result<Self, EnvError> {
        let xml = inline_includes(&assets.scene(object.file_stem()))?;
        let base = assets.hand_dir();
        let model = Model::from_str(&xml, &base).map_err(|e| EnvError::Model(format!("mjcf-rs: {e}")))?;
        Self::from_model(&model, &base)
    }

    /// Builds the scene from a parsed model whose files are relative to `base`.
    ///
    /// # Errors
    /// [`EnvError::Model`] when the model lacks the hand joints, the object, the
    /// target or the 92 touch sensors, or [`EnvError::Io`] for an unreadable mesh.
    pub fn from_model(model: &Model, base: &Path) -> Result<Self, EnvError> {
        let joint_index = |name: &str| HAND_JOINTS.iter().position(|j| name.strip_prefix(PREFIX) == Some(*j));
        let tree = BodyTree::new(model, joint_index)?;
        let body =
            |name: &str| model.body_id_by_name(name).ok_or_else(|| EnvError::Model(format!("no body named {name}")));
        let (object_body, target_body) = (body("object")?, body("target")?);
        let mut parts = Vec::new();
        for (id, entry) in model.bodies.iter().enumerate() {
            for geom in &entry.body.geoms {
                let part = match geom.name.as_deref() {
                    Some("object") if id == object_body => Some(object_part(geom, 1.0)?),
                    Some("target") if id == target_body => Some(object_part(geom, 0.45)?),
                    _ if geom.group == 1 && geom.type_ == GeomType::Mesh => Some(mesh_part(model, base, geom)?),
                    _ => None,
                };
                parts.extend(part.map(|p| Part { body: id, ..p }));
            }
        }
        Ok(Self { tree, parts, touch: touch_boxes(model)?, object_body, target_body })
    }

    /// Number of triangles drawn per frame, touch sensors excluded.
    #[must_use]
    pub fn triangles(&self) -> usize {
        self.parts.iter().map(|p| p.triangles.len()).sum()
    }

    /// Draws `view` from `camera`.
    ///
    /// # Errors
    /// [`EnvError::InvalidConfig`] when `view` does not hold 24 joint positions
    /// and 92 touch flags.
    pub fn render(&self, view: &HandView, camera: &Camera) -> Result<Image, EnvError> {
        check_view(view)?;
        let poses = self.tree.forward(&view.qpos, |body| {
            if body == self.object_body {
                Some(Iso::from_pose(view.object_position, view.object_quaternion))
            } else if body == self.target_body {
                let [x, y, z] = view.goal_position;
                Some(Iso::from_pose([x + GOAL_OFFSET_X, y, z], view.goal_quaternion))
            } else {
                None
            }
        });
        let projector = camera.projector();
        let mut canvas = Canvas::new(camera.width, camera.height, SKY.0, SKY.1);
        for part in &self.parts {
            let pose = poses[part.body].then(&part.local);
            for (t, &color) in part.triangles.iter().zip(&part.colors) {
                draw(&mut canvas, &projector, t.map(|v| pose.apply(v)), color);
            }
        }
        for (b, _) in self.touch.iter().zip(&view.touch_active).filter(|(_, on)| **on) {
            let pose = poses[b.body].then(&b.local);
            for (t, _) in box_triangles(b.half) {
                draw(&mut canvas, &projector, t.map(|v| pose.apply(v)), TOUCH_COLOR);
            }
        }
        Ok(canvas.image)
    }
}

fn check_view(view: &HandView) -> Result<(), EnvError> {
    if view.qpos.len() != HAND_JOINTS.len() {
        let reason = format!("{} joint positions, expected {}", view.qpos.len(), HAND_JOINTS.len());
        return Err(EnvError::InvalidConfig { key: "view.qpos", reason });
    }
    if view.touch_active.len() != NUM_TOUCH {
        let reason = format!("{} touch flags, expected {NUM_TOUCH}", view.touch_active.len());
        return Err(EnvError::InvalidConfig { key: "view.touch_active", reason });
    }
    Ok(())
}

/// Shades and fills one world-space triangle: ambient light plus MuJoCo's
/// headlight (along the view) and the scene's light from above, two-sided.
fn draw(canvas: &mut Canvas, projector: &Projector, t: [[f64; 3]; 3], color: Rgb) {
    let (Some(a), Some(b), Some(c)) = (projector.project(t[0]), projector.project(t[1]), projector.project(t[2]))
    else {
        return;
    };
    let n = cross(sub(t[1], t[0]), sub(t[2], t[0]));
    let len = dot(n, n).sqrt();
    if len == 0.0 {
        return;
    }
    let mut n = n.map(|v| v / len);
    if dot(n, sub(projector.eye, t[0])) < 0.0 {
        n = n.map(|v| -v);
    }
    let forward = projector.axes[2];
    let light = 0.25 + 0.45 * (-dot(n, forward)).max(0.0) + 0.45 * n[2].max(0.0);
    let rgb = color.map(|c| (255.0 * (c * light).min(1.0)).round() as u8);
    canvas.fill_triangle([a, b, c], rgb);
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// The 12 triangles of a box of half-extents `h`, each with its face index
/// (`+x, −x, +y, −y, +z, −z`).
fn box_triangles(h: [f64; 3]) -> Vec<([[f64; 3]; 3], usize)> {
    let mut out = Vec::with_capacity(12);
    for axis in 0..3 {
        let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
        for (side, sign) in [(0, 1.0), (1, -1.0)] {
            let corner = |su: f64, sv: f64| {
                let mut p = [0.0; 3];
                p[axis] = sign * h[axis];
                p[u] = su * h[u];
                p[v] = sv * h[v];
                p
            };
            let q = [corner(-1.0, -1.0), corner(1.0, -1.0), corner(1.0, 1.0), corner(-1.0, 1.0)];
            out.push(([q[0], q[1], q[2]], 2 * axis + side));
            out.push(([q[0], q[2], q[3]], 2 * axis + side));
        }
    }
    out
}

/// The object (or the goal, `opacity < 1` mixing its colours with white): a box
/// with one colour per face, or an ellipsoid coloured by the quadrant of its own
/// `x`-`y` plane.
fn object_part(geom: &Geom, opacity: f64) -> Result<Part, EnvError> {
    let (triangles, colors): (Vec<_>, Vec<Rgb>) = match geom.type_ {
        GeomType::Box => box_triangles(geom.size).into_iter().map(|(t, face)| (t, FACE_COLORS[face])).unzip(),
        GeomType::Ellipsoid => ellipsoid_triangles(geom.size, 24, 12)
            .into_iter()
            .map(|t| {
                let c = [0, 1].map(|k| t[0][k] + t[1][k] + t[2][k]);
                let quadrant = usize::from(c[0] < 0.0) + 2 * usize::from(c[1] < 0.0);
                (t, FACE_COLORS[[0, 2, 4, 5][quadrant]])
            })
            .unzip(),
        other => {
            return Err(EnvError::Model(format!("the object geom is a {other:?}; only box and ellipsoid are drawn")));
        }
    };
    let colors = colors.into_iter().map(|c| c.map(|v| opacity * v + (1.0 - opacity))).collect();
    Ok(Part { body: 0, local: kinematics::iso_of(&geom.pose), triangles, colors })
}

/// A UV ellipsoid of half-axes `h` with `slices` x `stacks` quads.
fn ellipsoid_triangles(h: [f64; 3], slices: usize, stacks: usize) -> Vec<[[f64; 3]; 3]> {
    use std::f64::consts::PI;
    let point = |i: usize, j: usize| {
        let (theta, phi) = (2.0 * PI * i as f64 / slices as f64, PI * j as f64 / stacks as f64);
        [h[0] * phi.sin() * theta.cos(), h[1] * phi.sin() * theta.sin(), h[2] * phi.cos()]
    };
    let mut out = Vec::with_capacity(2 * slices * stacks);
    for i in 0..slices {
        for j in 0..stacks {
            let (a, b, c, d) = (point(i, j), point(i + 1, j), point(i + 1, j + 1), point(i, j + 1));
            out.push([a, b, c]);
            out.push([a, c, d]);
        }
    }
    out
}

/// A visual mesh geom: the STL's triangles, scaled, in the geom's frame.
fn mesh_part(model: &Model, base: &Path, geom: &Geom) -> Result<Part, EnvError> {
    let name = geom.mesh.as_deref().unwrap_or_default();
    let mesh = model.assets.mesh(name).ok_or_else(|| EnvError::Model(format!("no mesh asset named {name}")))?;
    let path =
        model.resolve_mesh_file(mesh, base).ok_or_else(|| EnvError::Model(format!("mesh {name} has no file")))?;
    let bytes = std::fs::read(&path).map_err(|source| EnvError::Io { what: "reading", path: path.clone(), source })?;
    let scene =
        mesh_loader::stl::from_slice(&bytes).map_err(|e| EnvError::Model(format!("mesh {}: {e}", path.display())))?;
    let s = mesh.scale;
    let mut triangles = Vec::new();
    for m in &scene.meshes {
        let vertex = |k: u32| {
            let v = m.vertices[k as usize];
            [f64::from(v[0]) * s[0], f64::from(v[1]) * s[1], f64::from(v[2]) * s[2]]
        };
        triangles.extend(m.faces.iter().map(|f| f.map(vertex)));
    }
    let color = geom.rgba.map_or(HAND_COLOR, |c| [c[0], c[1], c[2]]);
    let colors = vec![color; triangles.len()];
    Ok(Part { body: 0, local: kinematics::iso_of(&geom.pose), triangles, colors })
}

/// The boxes of the 92 `robot0:TS_*` touch sensors, in the model's order (that
/// of [`HandPhysics::touch_names`](super::HandPhysics::touch_names)); a sphere
/// site is drawn as the box around it.
fn touch_boxes(model: &Model) -> Result<Vec<TouchBox>, EnvError> {
    Ok(touch_sensor_sites(model)?
        .into_iter()
        .map(|TouchSensorSite { body, site, .. }| {
            let r = site.size[0];
            let or_r = |v: f64| if v > 0.0 { v } else { r };
            TouchBox { body, local: kinematics::iso_of(&site.pose), half: [r, or_r(site.size[1]), or_r(site.size[2])] }
        })
        .collect())
}
