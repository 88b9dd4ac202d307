//! Cameras described the way Blender describes them, so the add-on maps straight on:
//! focal length and sensor size in mm, sensor fit, lens shift in units of the larger
//! image side, clipping distances along the view axis. The camera looks down its
//! local −Z axis with +Y up (Blender's convention).

use crate::geometry::Ray;
use crate::{Error, Result};
use glam::{Affine3A, Vec2, Vec3A};
use serde::{Deserialize, Serialize};

#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "SCREAMING_SNAKE_CASE")]
pub enum SensorFit {
    #[default]
    Auto,
    Horizontal,
    Vertical,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "SCREAMING_SNAKE_CASE")]
pub enum Projection {
    #[default]
    Perspective,
    Orthographic,
}

/// The camera as a scene describes it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CameraDesc {
    pub name: String,
    /// Camera → world, row-major 4×4 (Blender's `matrix_world`).
    pub to_world: [[f32; 4]; 4],
    pub projection: Projection,
    pub focal_length: f32,
    pub sensor_width: f32,
    pub sensor_height: f32,
    pub sensor_fit: SensorFit,
    /// Width of the view for orthographic cameras (Blender's `ortho_scale`).
    pub ortho_scale: f32,
    pub shift_x: f32,
    pub shift_y: f32,
    pub clip_start: f32,
    pub clip_end: f32,
}

pub const IDENTITY_ROWS: [[f32; 4]; 4] =
    [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]];

impl Default for CameraDesc {
    /// Blender's default camera lens at the origin looking down −Z.
    fn default() -> Self {
        Self {
            name: "Camera".into(),
            to_world: IDENTITY_ROWS,
            projection: Projection::Perspective,
            focal_length: 50.0,
            sensor_width: 36.0,
            sensor_height: 24.0,
            sensor_fit: SensorFit::Auto,
            ortho_scale: 7.314,
            shift_x: 0.0,
            shift_y: 0.0,
            clip_start: 0.1,
            clip_end: 1000.0,
        }
    }
}

/// Row-major 4×4 (as Blender and numpy write it) → affine transform.
pub fn affine_from_rows(m: &[[f32; 4]; 4]) -> Affine3A {
    Affine3A::from_mat4(glam::Mat4::from_cols_array_2d(m).transpose())
}

/// A camera ready to generate rays for an image of `width` × `height` pixels.
#[derive(Clone, Debug)]
pub struct Camera {
    to_world: Affine3A,
    projection: Projection,
    /// Half extent of the image plane at distance 1 (perspective) or in world units
    /// (orthographic).
    half: Vec2,
    /// Lens shift in the same units.
    shift: Vec2,
    width: u32,
    height: u32,
    clip_start: f32,
    clip_end: f32,
    forward: Vec3A,
}

impl Camera {
    pub fn new(desc: &CameraDesc, width: u32, height: u32) -> Result<Self> {
        let bad = |p: String| Error::object("camera", &desc.name, p);
        let to_world = affine_from_rows(&desc.to_world);
        if !to_world.is_finite() || to_world.matrix3.determinant().abs() < 1e-12 {
            return Err(bad("transform is not finite or is singular".into()));
        }
        let positive = |v: f32| v.is_finite() && v > 0.0;
        if !(positive(desc.sensor_width) && positive(desc.sensor_height)) {
            return Err(bad(format!("sensor {}×{} mm must be positive", desc.sensor_width, desc.sensor_height)));
        }
        if !(desc.clip_start.is_finite() && desc.clip_start >= 0.0 && desc.clip_end > desc.clip_start) {
            return Err(bad(format!("clip range {}..{} is empty or negative", desc.clip_start, desc.clip_end)));
        }
        if !(desc.shift_x.is_finite() && desc.shift_y.is_finite()) {
            return Err(bad("lens shift is not finite".into()));
        }
        let (w, h) = (width as f32, height as f32);
        let horizontal = match desc.sensor_fit {
            SensorFit::Auto => w >= h,
            SensorFit::Horizontal => true,
            SensorFit::Vertical => false,
        };
        // Extent of the fitted image side at distance 1 (perspective) or in world units.
        let fitted = match desc.projection {
            Projection::Perspective => {
                if !positive(desc.focal_length) {
                    return Err(bad(format!("focal length {} mm must be positive", desc.focal_length)));
                }
                let sensor =
                    if desc.sensor_fit == SensorFit::Vertical { desc.sensor_height } else { desc.sensor_width };
                sensor / desc.focal_length
            }
            Projection::Orthographic => {
                if !positive(desc.ortho_scale) {
                    return Err(bad(format!("orthographic scale {} must be positive", desc.ortho_scale)));
                }
                desc.ortho_scale
            }
        };
        let (full_w, full_h) = if horizontal { (fitted, fitted * h / w) } else { (fitted * w / h, fitted) };
        let largest = full_w.max(full_h);
        Ok(Self {
            to_world,
            projection: desc.projection,
            half: Vec2::new(full_w * 0.5, full_h * 0.5),
            shift: Vec2::new(desc.shift_x * largest, desc.shift_y * largest),
            width,
            height,
            clip_start: desc.clip_start,
            clip_end: desc.clip_end,
            forward: to_world.transform_vector3a(-Vec3A::Z).normalize(),
        })
    }

    pub fn width(&self) -> u32 {
        self.width
    }
    pub fn height(&self) -> u32 {
        self.height
    }
    /// World-space viewing direction, for the depth pass.
    pub fn forward(&self) -> Vec3A {
        self.forward
    }
    pub fn position(&self) -> Vec3A {
        self.to_world.translation
    }

    /// The ray through film position (x, y) in pixels, x right and y down from the
    /// top-left corner. Its tmin/tmax are the clip distances along the view axis.
    pub fn generate_ray(&self, x: f32, y: f32) -> Ray {
        let u = (2.0 * x / self.width as f32 - 1.0) * self.half.x + self.shift.x;
        let v = (1.0 - 2.0 * y / self.height as f32) * self.half.y + self.shift.y;
        let (origin, d) = match self.projection {
            // The local direction has z = −1, so a local depth z is reached at t = z·|d|.
            Projection::Perspective => {
                (self.to_world.translation, self.to_world.transform_vector3a(Vec3A::new(u, v, -1.0)))
            }
            Projection::Orthographic => {
                (self.to_world.transform_point3a(Vec3A::new(u, v, 0.0)), self.to_world.transform_vector3a(-Vec3A::Z))
            }
        };
        let len = d.length();
        Ray { origin, direction: d / len, tmin: self.clip_start * len, tmax: self.clip_end * len }
    }
}

/// A connection from a scene point to the camera (light tracing).
#[derive(Clone, Copy, Debug)]
pub struct CameraConnection {
    /// Film position in pixels (x right, y down from the top-left corner).
    pub raster: Vec2,
    /// Unit direction from the scene point towards the camera.
    pub wi: Vec3A,
    pub distance: f32,
    /// Importance per unit of incident radiance-carrying throughput: the splat of a
    /// light-path vertex is `β · f·|cos θx| · importance`, and a pixel's value is the
    /// sum of its splats divided by the light paths per pixel. For the pinhole this is
    /// `We·|cos θc| / d² = 1 / (A · cos³θc · d²)` with `A` the image-plane area at
    /// distance 1 (pbrt-v4 PerspectiveCamera::We / SampleWi with a pinhole).
    pub importance: f32,
}

impl Camera {
    /// Light tracing can connect to this camera (a pinhole).
    pub fn is_perspective(&self) -> bool {
        self.projection == Projection::Perspective
    }

    /// Connects a world point to the pinhole (perspective cameras only; None for
    /// orthographic ones, behind the camera, outside the image or the clip range).
    pub fn connect(&self, p: Vec3A) -> Option<CameraConnection> {
        if self.projection != Projection::Perspective {
            return None;
        }
        let origin = self.to_world.translation;
        let d = p - origin;
        let distance = d.length();
        if !(distance > 0.0 && distance.is_finite()) {
            return None;
        }
        let local = self.to_world.matrix3.inverse() * d;
        if !(local.z < 0.0) {
            return None;
        }
        let depth = -local.z;
        if depth < self.clip_start || depth > self.clip_end {
            return None;
        }
        let (u, v) = (local.x / depth, local.y / depth);
        let x = ((u - self.shift.x) / self.half.x + 1.0) * 0.5 * self.width as f32;
        let y = (1.0 - (v - self.shift.y) / self.half.y) * 0.5 * self.height as f32;
        if !(x >= 0.0 && x < self.width as f32 && y >= 0.0 && y < self.height as f32) {
            return None;
        }
        let cos = depth / local.length();
        let area = 4.0 * self.half.x * self.half.y;
        let importance = 1.0 / (area * cos * cos * cos * distance * distance);
        importance.is_finite().then_some(CameraConnection {
            raster: Vec2::new(x, y),
            wi: -d / distance,
            distance,
            importance,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blender_default_lens_field_of_view() {
        // 50 mm on a 36 mm sensor, landscape: horizontal FOV = 2 atan(18/50) = 39.6°.
        let cam = Camera::new(&CameraDesc::default(), 160, 90).unwrap();
        let r = cam.generate_ray(160.0, 45.0);
        let angle = r.direction.x.atan2(-r.direction.z).to_degrees();
        assert!((angle - (18.0f32 / 50.0).atan().to_degrees()).abs() < 1e-3, "{angle}");
        // Portrait with AUTO fit: the sensor width spans the height.
        let cam = Camera::new(&CameraDesc::default(), 90, 160).unwrap();
        let r = cam.generate_ray(45.0, 0.0);
        let angle = r.direction.y.atan2(-r.direction.z).to_degrees();
        assert!((angle - (18.0f32 / 50.0).atan().to_degrees()).abs() < 1e-3, "{angle}");
    }

    #[test]
    fn shift_and_clip() {
        let desc = CameraDesc { shift_x: 0.5, clip_start: 2.0, clip_end: 3.0, ..Default::default() };
        let cam = Camera::new(&desc, 100, 100).unwrap();
        // With shift 0.5 of the largest side, the left edge of the image looks straight ahead.
        let r = cam.generate_ray(0.0, 50.0);
        assert!(r.direction.x.abs() < 1e-6);
        let r = cam.generate_ray(100.0, 0.0);
        let depth_min = (r.direction * r.tmin).dot(-Vec3A::Z);
        assert!((depth_min - 2.0).abs() < 1e-5);
        assert!(Camera::new(&CameraDesc { focal_length: 0.0, ..Default::default() }, 10, 10).is_err());
    }

    #[test]
    fn connect_inverts_generate_ray_and_importance_integrates_to_one() {
        let desc = CameraDesc { shift_x: 0.1, ..Default::default() };
        let cam = Camera::new(&desc, 40, 30).unwrap();
        let r = cam.generate_ray(13.25, 7.5);
        let c = cam.connect(r.at(5.0)).unwrap();
        assert!((c.raster.x - 13.25).abs() < 1e-3 && (c.raster.y - 7.5).abs() < 1e-3, "{:?}", c.raster);
        assert!((c.wi + r.direction).length() < 1e-5);
        // ∫ We cos dω over the image = 1: a unit sphere of directions, Monte Carlo.
        let mut rng = crate::sampling::Rng::new(1, 2);
        let n = 200_000;
        let mut sum = 0.0f64;
        for _ in 0..n {
            let w = crate::sampling::uniform_sphere(rng.uniform2());
            if let Some(c) = cam.connect(w) {
                sum += (c.importance * c.distance * c.distance) as f64 * 4.0 * std::f64::consts::PI;
            }
        }
        // Σ over pixels of (1/spp)·E[splat] with unit radiance = W·H per unit… per pixel 1.
        assert!((sum / n as f64 - 1.0).abs() < 0.02, "{}", sum / n as f64);
    }
}
