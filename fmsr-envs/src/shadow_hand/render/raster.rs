//! A perspective camera and a z-buffered triangle rasteriser on the CPU.

use serde::{Deserialize, Serialize};

use super::kinematics::norm;

/// An 8-bit RGB image, rows top to bottom.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Image {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// `3 * width * height` bytes, `[r, g, b]` per pixel.
    pub rgb: Vec<u8>,
}

impl Image {
    /// An image filled with one colour.
    #[must_use]
    pub fn filled(width: usize, height: usize, color: [u8; 3]) -> Self {
        Self { width, height, rgb: color.repeat(width * height) }
    }

    /// The pixel at column `x`, row `y`.
    ///
    /// # Panics
    /// If `(x, y)` lies outside the image.
    #[must_use]
    pub fn pixel(&self, x: usize, y: usize) -> [u8; 3] {
        assert!(x < self.width && y < self.height, "pixel ({x}, {y}) outside {}x{}", self.width, self.height);
        let i = 3 * (y * self.width + x);
        [self.rgb[i], self.rgb[i + 1], self.rgb[i + 2]]
    }

    /// The image shrunk by an integer `factor`, each pixel the mean of a
    /// `factor` x `factor` block (anti-aliasing of a frame drawn `factor` times larger).
    ///
    /// ```
    /// use fmsr_envs::shadow_hand::render::Image;
    /// let mut big = Image::filled(4, 2, [0, 0, 0]);
    /// big.rgb[..3].copy_from_slice(&[200, 100, 40]);
    /// let small = big.downsample(2);
    /// assert_eq!((small.width, small.height, small.pixel(0, 0)), (2, 1, [50, 25, 10]));
    /// ```
    #[must_use]
    pub fn downsample(&self, factor: usize) -> Self {
        let f = factor.max(1);
        let (width, height) = (self.width / f, self.height / f);
        let mut out = Self::filled(width, height, [0; 3]);
        for y in 0..height {
            for x in 0..width {
                for c in 0..3 {
                    let sum: usize = (0..f * f)
                        .map(|k| usize::from(self.rgb[3 * ((y * f + k / f) * self.width + x * f + k % f) + c]))
                        .sum();
                    out.rgb[3 * (y * width + x) + c] = (sum as f64 / (f * f) as f64).round() as u8;
                }
            }
        }
        out
    }

    /// The images side by side (the tallest sets the height; the rest is `fill`).
    #[must_use]
    pub fn hstack(images: &[&Image], fill: [u8; 3]) -> Self {
        let width = images.iter().map(|i| i.width).sum();
        let height = images.iter().map(|i| i.height).max().unwrap_or(0);
        let mut out = Self::filled(width, height, fill);
        let mut x0 = 0;
        for image in images {
            for y in 0..image.height {
                let src = &image.rgb[3 * y * image.width..3 * (y + 1) * image.width];
                let dst = 3 * (y * width + x0);
                out.rgb[dst..dst + src.len()].copy_from_slice(src);
            }
            x0 += image.width;
        }
        out
    }
}

/// A pinhole camera looking at `lookat` from `distance`, MuJoCo's free-camera
/// parametrisation: the view direction is
/// `(cos e cos a, cos e sin a, sin e)` for azimuth `a` and elevation `e` (degrees),
/// with `z` up.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Camera {
    /// The point looked at (m, world frame).
    pub lookat: [f64; 3],
    /// Distance of the eye from `lookat` (m).
    pub distance: f64,
    /// Azimuth (degrees).
    pub azimuth: f64,
    /// Elevation (degrees; negative looks down).
    pub elevation: f64,
    /// Vertical field of view (degrees).
    pub fovy: f64,
    /// Image width (pixels).
    pub width: usize,
    /// Image height (pixels).
    pub height: usize,
}

impl Camera {
    /// gymnasium-robotics' default view of the hand environments
    /// (`DEFAULT_CAMERA_CONFIG` of `hand_env.py`: distance 0.5, azimuth 55°,
    /// elevation −25°, lookat `(1, 0.96, 0.14)`) with MuJoCo's default 45° field of view.
    ///
    /// ```
    /// let camera = fmsr_envs::shadow_hand::render::Camera::gym(320, 240);
    /// assert_eq!((camera.width, camera.height, camera.distance), (320, 240, 0.5));
    /// ```
    #[must_use]
    pub fn gym(width: usize, height: usize) -> Self {
        Self { lookat: [1.0, 0.96, 0.14], distance: 0.5, azimuth: 55.0, elevation: -25.0, fovy: 45.0, width, height }
    }

    /// The eye position and the orthonormal `(right, up, forward)` axes.
    #[must_use]
    pub fn frame(&self) -> ([f64; 3], [[f64; 3]; 3]) {
        let (a, e) = (self.azimuth.to_radians(), self.elevation.to_radians());
        let f = [e.cos() * a.cos(), e.cos() * a.sin(), e.sin()];
        let eye = [0, 1, 2].map(|i| self.lookat[i] - self.distance * f[i]);
        let r = cross(f, [0.0, 0.0, 1.0]);
        let n = norm(r);
        let r = r.map(|v| v / n);
        let u = cross(r, f);
        (eye, [r, u, f])
    }

    /// The projector of this camera (cached eye and axes).
    #[must_use]
    pub fn projector(&self) -> Projector {
        let (eye, axes) = self.frame();
        let focal = self.height as f64 / 2.0 / (self.fovy.to_radians() / 2.0).tan();
        Projector { eye, axes, focal, cx: self.width as f64 / 2.0, cy: self.height as f64 / 2.0 }
    }
}

pub(crate) fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

pub(crate) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Nearest depth drawn (m): triangles with a vertex closer than this are skipped.
const NEAR: f64 = 0.01;

/// World points to pixels.
#[derive(Debug, Clone, Copy)]
pub struct Projector {
    /// The eye.
    pub eye: [f64; 3],
    /// `(right, up, forward)`.
    pub axes: [[f64; 3]; 3],
    focal: f64,
    cx: f64,
    cy: f64,
}

impl Projector {
    /// `(column, row, 1 / depth)` of a world point in front of the camera.
    #[must_use]
    pub fn project(&self, p: [f64; 3]) -> Option<[f64; 3]> {
        let d = [p[0] - self.eye[0], p[1] - self.eye[1], p[2] - self.eye[2]];
        let z = dot(d, self.axes[2]);
        if z < NEAR {
            return None;
        }
        let (x, y) = (dot(d, self.axes[0]), dot(d, self.axes[1]));
        Some([self.cx + self.focal * x / z, self.cy - self.focal * y / z, 1.0 / z])
    }
}

/// An image with a depth buffer, for drawing triangles.
#[derive(Debug, Clone)]
pub struct Canvas {
    /// The colours.
    pub image: Image,
    /// `1 / depth` per pixel (0: nothing drawn).
    inv_depth: Vec<f64>,
}

impl Canvas {
    /// A canvas with a vertical gradient background from `top` to `bottom`.
    #[must_use]
    pub fn new(width: usize, height: usize, top: [u8; 3], bottom: [u8; 3]) -> Self {
        let mut image = Image::filled(width, height, top);
        for y in 0..height {
            let s = y as f64 / height.max(2).saturating_sub(1) as f64;
            let c = [0, 1, 2].map(|i| (f64::from(top[i]) * (1.0 - s) + f64::from(bottom[i]) * s).round() as u8);
            for x in 0..width {
                image.rgb[3 * (y * width + x)..3 * (y * width + x) + 3].copy_from_slice(&c);
            }
        }
        Self { image, inv_depth: vec![0.0; width * height] }
    }

    /// Fills the triangle of projected vertices (`column, row, 1/depth`), keeping
    /// at each pixel the nearest surface drawn so far.
    pub fn fill_triangle(&mut self, v: [[f64; 3]; 3], color: [u8; 3]) {
        let area = edge(v[0], v[1], v[2]);
        if area.abs() < 1e-12 {
            return;
        }
        let (w, h) = (self.image.width as f64, self.image.height as f64);
        let lo = |k: usize, max: f64| v.iter().map(|p| p[k]).fold(f64::INFINITY, f64::min).floor().clamp(0.0, max);
        let hi = |k: usize, max: f64| v.iter().map(|p| p[k]).fold(f64::NEG_INFINITY, f64::max).ceil().clamp(0.0, max);
        let (x0, x1, y0, y1) = (lo(0, w) as usize, hi(0, w) as usize, lo(1, h) as usize, hi(1, h) as usize);
        for y in y0..y1 {
            for x in x0..x1 {
                let p = [x as f64 + 0.5, y as f64 + 0.5, 0.0];
                let b = [edge(v[1], v[2], p) / area, edge(v[2], v[0], p) / area, edge(v[0], v[1], p) / area];
                if b.iter().any(|&b| b < 0.0) {
                    continue;
                }
                let z = b[0] * v[0][2] + b[1] * v[1][2] + b[2] * v[2][2];
                let i = y * self.image.width + x;
                if z > self.inv_depth[i] {
                    self.inv_depth[i] = z;
                    self.image.rgb[3 * i..3 * i + 3].copy_from_slice(&color);
                }
            }
        }
    }
}

/// Twice the signed area of `(a, b, p)` in the image plane.
fn edge(a: [f64; 3], b: [f64; 3], p: [f64; 3]) -> f64 {
    (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
}

#[cfg(test)]
mod tests {
    use super::*;

    // Guards the camera convention: the point looked at is the image centre, and
    // a point above it is drawn higher (a smaller row).
    #[test]
    fn the_lookat_point_is_the_image_centre() {
        let camera = Camera::gym(320, 240);
        let p = camera.projector();
        let c = p.project(camera.lookat).unwrap();
        assert!((c[0] - 160.0).abs() < 1e-9 && (c[1] - 120.0).abs() < 1e-9);
        let above = p.project([camera.lookat[0], camera.lookat[1], camera.lookat[2] + 0.05]).unwrap();
        assert!(above[1] < c[1]);
        assert!(p.project(p.eye).is_none(), "the eye itself is behind the near plane");
    }

    // Guards the rasteriser: a triangle covers its inside only, and the nearer of
    // two overlapping triangles wins whatever the drawing order.
    #[test]
    fn the_nearer_triangle_wins_and_the_outside_stays_clear() {
        let tri = |z: f64| [[2.0, 2.0, z], [18.0, 2.0, z], [2.0, 18.0, z]];
        for order in [[0.5, 2.0], [2.0, 0.5]] {
            let mut canvas = Canvas::new(20, 20, [0; 3], [0; 3]);
            for z in order {
                canvas.fill_triangle(tri(z), if z > 1.0 { [255, 0, 0] } else { [0, 0, 255] });
            }
            assert_eq!(canvas.image.pixel(4, 4), [255, 0, 0]);
            assert_eq!(canvas.image.pixel(17, 17), [0, 0, 0]);
        }
    }

    #[test]
    fn hstack_places_images_side_by_side() {
        let (a, b) = (Image::filled(2, 1, [1, 1, 1]), Image::filled(1, 2, [2, 2, 2]));
        let s = Image::hstack(&[&a, &b], [9, 9, 9]);
        assert_eq!((s.width, s.height), (3, 2));
        assert_eq!((s.pixel(1, 0), s.pixel(2, 1), s.pixel(0, 1)), ([1; 3], [2; 3], [9; 3]));
    }
}
