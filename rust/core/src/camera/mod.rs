//! Cameras described the way Blender describes them, so the add-on maps straight on:
//! focal length and sensor size in mm, sensor fit, lens shift in units of the fitted
//! image side, clipping distances along the view axis, pixel aspect, a thin lens for
//! depth of field and Blender's panoramic projections. The camera looks down its local
//! −Z axis with +Y up (Blender's convention). Rays follow Cycles' camera model
//! (intern/cycles/kernel/camera/camera.h and blender/camera.cpp); docs/camera.md lists
//! every feature with its Cycles equivalent.

mod aperture;
mod panorama;

pub use aperture::Aperture;
pub use panorama::{equirectangular_range, Panorama, PanoramaType};

use crate::geometry::motion::TransformMotion;
use crate::geometry::Ray;
use crate::sampling::Rng;
use crate::{Error, Result};
use glam::{Affine3A, Vec2, Vec3A};
use serde::{Deserialize, Serialize};
use std::f32::consts::{FRAC_PI_2, PI};

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
    /// One of Blender's panoramic projections (`panorama_type`).
    Panoramic,
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
    /// Lens shift in units of the fitted image side (Blender's `shift_x`/`shift_y`).
    pub shift_x: f32,
    pub shift_y: f32,
    pub clip_start: f32,
    pub clip_end: f32,
    /// Width / height of one pixel (Blender's `pixel_aspect_x / pixel_aspect_y`).
    pub pixel_aspect: f32,
    /// Thin-lens aperture radius in scene units; 0 is a pinhole (no depth of field).
    pub aperture_radius: f32,
    /// Distance to the plane in focus along the view axis (a sphere for panoramas).
    pub focus_distance: f32,
    /// Diaphragm blades (a polygonal aperture); fewer than 3 is round.
    pub aperture_blades: u32,
    /// Rotation of the blades, radians.
    pub aperture_rotation: f32,
    /// Anamorphic squeeze: the aperture's width is divided by this.
    pub aperture_ratio: f32,
    pub panorama_type: PanoramaType,
    /// Fisheye field of view, radians.
    pub fisheye_fov: f32,
    /// Equisolid fisheye focal length, mm.
    pub fisheye_lens: f32,
    /// Equirectangular limits, radians.
    pub latitude_min: f32,
    pub latitude_max: f32,
    pub longitude_min: f32,
    pub longitude_max: f32,
    /// Polynomial fisheye coefficients k0…k4 (θ = −Σ kᵢ rⁱ, r in mm on the sensor).
    pub fisheye_polynomial: [f32; 5],
    pub central_cylindrical_range_u_min: f32,
    pub central_cylindrical_range_u_max: f32,
    pub central_cylindrical_range_v_min: f32,
    pub central_cylindrical_range_v_max: f32,
    pub central_cylindrical_radius: f32,
    /// Camera → world keys evenly spaced over the shutter (motion blur); empty: the
    /// camera stands at `to_world`.
    pub motion: Vec<[[f32; 4]; 4]>,
    /// How open the shutter is at evenly spaced times from open to close (Blender's
    /// shutter curve); empty: fully open throughout. Times are drawn ∝ this curve.
    pub shutter_curve: Vec<f32>,
    /// Rolling shutter (Cycles' TOP type): rows are exposed from the top down.
    pub rolling_shutter: bool,
    /// Share of the shutter time each row is exposed for (Cycles' rolling shutter
    /// duration: 0 pure rolling, 1 no rolling effect).
    pub rolling_shutter_duration: f32,
}

pub const IDENTITY_ROWS: [[f32; 4]; 4] =
    [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]];

impl Default for CameraDesc {
    /// Blender's default camera lens at the origin looking down −Z, and Blender's
    /// defaults for the panoramic and depth-of-field settings.
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
            pixel_aspect: 1.0,
            aperture_radius: 0.0,
            focus_distance: 10.0,
            aperture_blades: 0,
            aperture_rotation: 0.0,
            aperture_ratio: 1.0,
            panorama_type: PanoramaType::Equirectangular,
            fisheye_fov: PI,
            fisheye_lens: 10.5,
            latitude_min: -FRAC_PI_2,
            latitude_max: FRAC_PI_2,
            longitude_min: -PI,
            longitude_max: PI,
            fisheye_polynomial: [-1.1735144e-5, -0.019988736, -3.3525323e-6, 3.0992753e-6, -2.6064647e-8],
            central_cylindrical_range_u_min: -PI,
            central_cylindrical_range_u_max: PI,
            central_cylindrical_range_v_min: -1.0,
            central_cylindrical_range_v_max: 1.0,
            central_cylindrical_radius: 1.0,
            motion: Vec::new(),
            shutter_curve: Vec::new(),
            rolling_shutter: false,
            rolling_shutter_duration: 0.1,
        }
    }
}

/// Row-major 4×4 (as Blender and numpy write it) → affine transform.
pub fn affine_from_rows(m: &[[f32; 4]; 4]) -> Affine3A {
    Affine3A::from_mat4(glam::Mat4::from_cols_array_2d(m).transpose())
}

#[derive(Clone, Debug)]
enum Kind {
    /// `half`: half extent of the image plane at distance 1 (perspective) or in world
    /// units (orthographic); `shift` in the same units.
    Planar {
        perspective: bool,
        half: Vec2,
        shift: Vec2,
    },
    Panoramic {
        panorama: Panorama,
        shift: Vec2,
    },
}

/// A camera ready to generate rays for an image of `width` × `height` pixels.
#[derive(Clone, Debug)]
pub struct Camera {
    name: String,
    to_world: Affine3A,
    to_camera: Affine3A,
    /// Camera → world over the shutter, when the camera moves.
    motion: Option<TransformMotion>,
    /// How shutter times are drawn; None when nothing in the scene moves (then no time
    /// is drawn and every ray has time 0.5).
    shutter: Option<Shutter>,
    kind: Kind,
    /// The thin lens (None: a pinhole).
    aperture: Option<Aperture>,
    focus_distance: f32,
    shutter_desc: ShutterDesc,
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
        if !positive(desc.pixel_aspect) {
            return Err(bad(format!("pixel aspect {} must be positive", desc.pixel_aspect)));
        }
        if !(desc.aperture_radius.is_finite() && desc.aperture_radius >= 0.0) {
            return Err(bad(format!("aperture radius {} must be zero or positive", desc.aperture_radius)));
        }
        let aperture = (desc.aperture_radius > 0.0)
            .then(|| {
                if !positive(desc.aperture_ratio) || !desc.aperture_rotation.is_finite() {
                    return Err(bad(format!(
                        "aperture ratio {} must be positive and rotation {} finite",
                        desc.aperture_ratio, desc.aperture_rotation
                    )));
                }
                if !positive(desc.focus_distance) {
                    return Err(bad(format!("focus distance {} must be positive", desc.focus_distance)));
                }
                Ok(Aperture {
                    radius: desc.aperture_radius,
                    blades: desc.aperture_blades,
                    rotation: desc.aperture_rotation,
                    ratio: desc.aperture_ratio,
                })
            })
            .transpose()?;
        // Blender's view plane (blender_camera_viewplane): the image's aspect counts
        // the pixel aspect, the sensor spans the fitted side.
        let (xratio, yratio) = (width as f32 * desc.pixel_aspect, height as f32);
        let horizontal = match desc.sensor_fit {
            SensorFit::Auto => xratio > yratio,
            SensorFit::Horizontal => true,
            SensorFit::Vertical => false,
        };
        let sensor = if desc.sensor_fit == SensorFit::Vertical { desc.sensor_height } else { desc.sensor_width };
        let kind = match desc.projection {
            Projection::Perspective | Projection::Orthographic => {
                let perspective = desc.projection == Projection::Perspective;
                // Extent of the fitted image side at distance 1 (perspective) or in world units.
                let fitted = if perspective {
                    if !positive(desc.focal_length) {
                        return Err(bad(format!("focal length {} mm must be positive", desc.focal_length)));
                    }
                    sensor / desc.focal_length
                } else {
                    if !positive(desc.ortho_scale) {
                        return Err(bad(format!("orthographic scale {} must be positive", desc.ortho_scale)));
                    }
                    desc.ortho_scale
                };
                let full = if horizontal {
                    Vec2::new(fitted, fitted * yratio / xratio)
                } else {
                    Vec2::new(fitted * xratio / yratio, fitted)
                };
                // The shift is in units of the fitted side (Cycles' viewplane offset 2·aspect·shift).
                Kind::Planar { perspective, half: full * 0.5, shift: Vec2::new(desc.shift_x, desc.shift_y) * fitted }
            }
            Projection::Panoramic => Kind::Panoramic {
                panorama: Self::panorama(desc, horizontal, sensor, xratio / yratio).map_err(bad)?,
                shift: Vec2::new(desc.shift_x, desc.shift_y),
            },
        };
        if let Some(v) = desc.shutter_curve.iter().find(|v| !(v.is_finite() && **v >= 0.0)) {
            return Err(bad(format!("shutter curve value {v} must be finite and not negative")));
        }
        if !desc.shutter_curve.is_empty() && !desc.shutter_curve.iter().any(|v| *v > 0.0) {
            return Err(bad("the shutter curve is closed everywhere".into()));
        }
        if !(0.0..=1.0).contains(&desc.rolling_shutter_duration) {
            return Err(bad(format!("rolling shutter duration {} must lie in 0…1", desc.rolling_shutter_duration)));
        }
        let shutter_desc = ShutterDesc {
            curve: desc.shutter_curve.clone(),
            rolling: desc.rolling_shutter.then_some(desc.rolling_shutter_duration),
        };
        Ok(Self {
            name: desc.name.clone(),
            shutter_desc,
            to_world,
            to_camera: to_world.inverse(),
            shutter: None,
            motion: if desc.motion.is_empty() {
                None
            } else {
                let keys: Vec<Affine3A> = desc.motion.iter().map(affine_from_rows).collect();
                Some(TransformMotion::new("camera", &desc.name, &keys)?)
            },
            kind,
            aperture,
            // Cycles clamps the focus distance the same way.
            focus_distance: desc.focus_distance.max(1e-5),
            width,
            height,
            clip_start: desc.clip_start,
            clip_end: desc.clip_end,
            forward: to_world.transform_vector3a(-Vec3A::Z).normalize(),
        })
    }

    fn panorama(
        desc: &CameraDesc,
        horizontal: bool,
        sensor: f32,
        aspect: f32,
    ) -> std::result::Result<Panorama, String> {
        let finite = [
            desc.fisheye_fov,
            desc.fisheye_lens,
            desc.latitude_min,
            desc.latitude_max,
            desc.longitude_min,
            desc.longitude_max,
            desc.central_cylindrical_range_u_min,
            desc.central_cylindrical_range_u_max,
            desc.central_cylindrical_range_v_min,
            desc.central_cylindrical_range_v_max,
        ]
        .iter()
        .chain(&desc.fisheye_polynomial)
        .all(|v| v.is_finite());
        if !finite {
            return Err("a panorama setting is not finite".into());
        }
        match desc.panorama_type {
            PanoramaType::FisheyeEquidistant | PanoramaType::FisheyeEquisolid | PanoramaType::FisheyeLensPolynomial
                if !(desc.fisheye_fov > 0.0) =>
            {
                return Err(format!("fisheye field of view {} must be positive", desc.fisheye_fov));
            }
            PanoramaType::FisheyeEquisolid if !(desc.fisheye_lens > 0.0) => {
                return Err(format!("fisheye lens {} mm must be positive", desc.fisheye_lens));
            }
            PanoramaType::CentralCylindrical
                if !(desc.central_cylindrical_radius.is_finite() && desc.central_cylindrical_radius > 0.0) =>
            {
                return Err(format!("cylinder radius {} must be positive", desc.central_cylindrical_radius));
            }
            _ => {}
        }
        let r = desc.central_cylindrical_radius;
        Ok(Panorama {
            kind: desc.panorama_type,
            range: equirectangular_range(
                [desc.longitude_min, desc.longitude_max],
                [desc.latitude_min, desc.latitude_max],
            ),
            fisheye_fov: desc.fisheye_fov,
            fisheye_lens: desc.fisheye_lens,
            // The fisheyes' sensor fitted like the perspective one (blender_camera_sync).
            sensor: if horizontal { Vec2::new(sensor, sensor / aspect) } else { Vec2::new(sensor * aspect, sensor) },
            polynomial: desc.fisheye_polynomial,
            cylinder: [
                -desc.central_cylindrical_range_u_min,
                -desc.central_cylindrical_range_u_max,
                desc.central_cylindrical_range_v_min / r,
                desc.central_cylindrical_range_v_max / r,
            ],
        })
    }

    pub fn width(&self) -> u32 {
        self.width
    }
    pub fn height(&self) -> u32 {
        self.height
    }
    /// World-space viewing direction.
    pub fn forward(&self) -> Vec3A {
        self.forward
    }
    pub fn position(&self) -> Vec3A {
        self.to_world.translation
    }
    /// Something in the scene moves: rays get a shutter time (drawn from the shutter
    /// curve, rows offset by a rolling shutter). Static scenes draw no time.
    pub fn enable_motion_blur(&mut self) {
        self.shutter = Some(Shutter::new(&self.shutter_desc));
    }
    pub fn name(&self) -> &str {
        &self.name
    }
    /// The camera itself moves over the shutter.
    pub fn moves(&self) -> bool {
        self.motion.is_some()
    }
    /// Rays carry shutter times (something in the scene moves).
    pub fn has_motion_blur(&self) -> bool {
        self.shutter.is_some()
    }

    /// A shutter time for a ray of the pixel in full-frame row `row` (0 at the top), or
    /// 0.5 (nothing drawn) when nothing moves. Cycles' `camera_sample`: the time from the
    /// shutter curve's inverse CDF, then the rolling shutter's row offset. The row's time
    /// is the pixel's, not its jittered film position's: Cycles takes `1 − y / height`
    /// of the integer bottom-up row y, which is (row + 1) / height counted from the top,
    /// the same for every sample of the pixel.
    pub fn sample_time(&self, row: u32, rng: &mut Rng) -> f32 {
        match &self.shutter {
            None => 0.5,
            Some(s) => {
                s.sample(rng.uniform(), (row.min(self.height.saturating_sub(1)) + 1) as f32 / self.height as f32)
            }
        }
    }

    /// A shutter time for a light path (light tracing), or 0.5 when nothing moves: from
    /// the shutter curve, without the rolling shutter's row offset (light paths reach
    /// rows only when they connect; docs/camera.md says what this leaves out).
    pub fn sample_light_path_time(&self, rng: &mut Rng) -> f32 {
        match &self.shutter {
            None => 0.5,
            Some(s) => s.sample_curve(rng.uniform()),
        }
    }

    /// The camera has a rolling shutter and something moves.
    pub fn has_rolling_shutter(&self) -> bool {
        self.shutter.as_ref().is_some_and(|s| s.rolling.is_some())
    }

    fn to_world_at(&self, time: f32) -> Affine3A {
        self.motion.as_ref().map_or(self.to_world, |m| m.at(time))
    }

    /// The camera has a lens aperture (depth of field).
    pub fn has_aperture(&self) -> bool {
        self.aperture.is_some()
    }

    /// The depth pass at world point `p`, as Cycles' `camera_z_depth`: distance along the
    /// view axis for perspective and orthographic cameras, distance from the camera for
    /// panoramas.
    pub fn depth(&self, p: Vec3A) -> f32 {
        match self.kind {
            Kind::Planar { .. } => (p - self.position()).dot(self.forward),
            Kind::Panoramic { .. } => (p - self.position()).length(),
        }
    }

    /// The ray through film position (x, y) in pixels, x right and y down from the
    /// top-left corner; None where the projection sees nothing (outside a fisheye's
    /// circle or the mirror ball). Its tmin/tmax are the clip distances: along the view
    /// axis for perspective and orthographic cameras, along the ray for panoramas. A
    /// camera with an aperture draws one lens sample from `rng`; a pinhole draws none.
    pub fn generate_ray(&self, x: f32, y: f32, rng: &mut Rng) -> Option<Ray> {
        self.generate_pixel_ray(x, y, y.max(0.0) as u32, rng)
    }

    /// [`Camera::generate_ray`] for a sample of the pixel in full-frame row `row` (its
    /// rolling-shutter time is the row's, wherever in or around the pixel `y` falls).
    pub fn generate_pixel_ray(&self, x: f32, y: f32, row: u32, rng: &mut Rng) -> Option<Ray> {
        let lens = self.aperture.map(|a| a.sample(rng.uniform2()));
        let time = self.sample_time(row, rng);
        let to_world = self.to_world_at(time);
        let f = self.focus_distance;
        // Origin, direction and the direction's component along the view axis (planar
        // cameras clip against planes), all in camera space.
        let (o, d, axial) = match &self.kind {
            Kind::Planar { perspective, half, shift } => {
                let u = (2.0 * x / self.width as f32 - 1.0) * half.x + shift.x;
                let v = (1.0 - 2.0 * y / self.height as f32) * half.y + shift.y;
                let (o, d) = match (perspective, lens) {
                    (true, None) => (Vec3A::ZERO, Vec3A::new(u, v, -1.0)),
                    // Aim from the lens point at the pinhole ray's point on the focus plane.
                    (true, Some(l)) => {
                        let o = Vec3A::new(l.x, l.y, 0.0);
                        (o, Vec3A::new(u, v, -1.0) * f - o)
                    }
                    (false, None) => (Vec3A::new(u, v, 0.0), -Vec3A::Z),
                    (false, Some(l)) => (Vec3A::new(u + l.x, v + l.y, 0.0), Vec3A::new(-l.x, -l.y, -f)),
                };
                (o, d, -d.z)
            }
            Kind::Panoramic { panorama, shift } => {
                // Cycles' panorama view plane: [0, 1]² over the image, v up, plus the shift.
                let u = x / self.width as f32 + shift.x;
                let v = 1.0 - y / self.height as f32 + shift.y;
                let dir = panorama.direction(u, v)?.normalize();
                let (o, d) = match lens {
                    None => (Vec3A::ZERO, dir),
                    Some(l) => Panorama::thin_lens(dir, l, f),
                };
                let m = panorama.to_camera();
                let d = m * d;
                (m * o, d, d.length())
            }
        };
        let origin = to_world.transform_point3a(o);
        let dw = to_world.transform_vector3a(d);
        let len = dw.length();
        // A local length along the axis of 1 is reached at t = |dw| / axial.
        let scale = len / axial;
        if !(scale.is_finite() && scale > 0.0) {
            return None;
        }
        Some(Ray {
            origin,
            direction: dw / len,
            tmin: self.clip_start * scale,
            tmax: self.clip_end * scale,
            time,
            kind: crate::geometry::visibility::CAMERA,
        })
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
    /// distance 1 (pbrt-v4 PerspectiveCamera::We / SampleWi with a pinhole). For a thin
    /// lens it is the same expression for the ray from the sampled lens point: We gains a
    /// factor 1/(lens area) and the lens point's density cancels it (pbrt-v4
    /// PerspectiveCamera::SampleWi).
    pub importance: f32,
}

impl Camera {
    /// Light tracing can connect to this camera (perspective, with or without a lens).
    pub fn is_perspective(&self) -> bool {
        matches!(self.kind, Kind::Planar { perspective: true, .. })
    }

    /// Connects a world point to the camera as it is at shutter time `time`: a point on
    /// the lens sampled from `rng` (nothing drawn for a pinhole), then
    /// [`Camera::connect_through`].
    pub fn connect(&self, p: Vec3A, time: f32, rng: &mut Rng) -> Option<CameraConnection> {
        if !self.is_perspective() {
            return None;
        }
        let lens = self.aperture.map_or(Vec2::ZERO, |a| a.sample(rng.uniform2()));
        self.connect_through(self.to_world_at(time).transform_point3a(Vec3A::new(lens.x, lens.y, 0.0)), p, time)
    }

    /// Connects world point `p` to the camera (as it is at shutter time `time`) through
    /// `lens_point` (world space, on the lens; the camera's position for a pinhole).
    /// None for orthographic and panoramic cameras, behind the camera, outside the image
    /// or the clip range.
    pub fn connect_through(&self, lens_point: Vec3A, p: Vec3A, time: f32) -> Option<CameraConnection> {
        let Kind::Planar { perspective: true, half, shift } = self.kind else {
            return None;
        };
        let to_camera = match &self.motion {
            None => self.to_camera,
            Some(m) => m.at(time).inverse(),
        };
        let lens = to_camera.transform_point3a(lens_point);
        let local = to_camera.transform_point3a(p);
        let d = local - lens;
        let dw = p - lens_point;
        let distance = dw.length();
        if !(distance > 0.0 && distance.is_finite() && d.z < 0.0) {
            return None;
        }
        let depth = -local.z;
        if depth < self.clip_start || depth > self.clip_end {
            return None;
        }
        // Where the ray lens → p crosses the focus plane, seen from the pinhole (for a
        // pinhole, simply p projected).
        let (u, v) = if self.aperture.is_some() {
            let f = self.focus_distance;
            let focus = lens + d * (f / -d.z);
            (focus.x / f, focus.y / f)
        } else {
            (d.x / -d.z, d.y / -d.z)
        };
        let x = ((u - shift.x) / half.x + 1.0) * 0.5 * self.width as f32;
        let y = (1.0 - (v - shift.y) / half.y) * 0.5 * self.height as f32;
        if !(x >= 0.0 && x < self.width as f32 && y >= 0.0 && y < self.height as f32) {
            return None;
        }
        let cos = -d.z / d.length();
        let area = 4.0 * half.x * half.y;
        let importance = 1.0 / (area * cos * cos * cos * distance * distance);
        importance.is_finite().then_some(CameraConnection {
            raster: Vec2::new(x, y),
            wi: -dw / distance,
            distance,
            importance,
        })
    }
}

/// The camera's shutter settings, kept until the scene says whether anything moves.
#[derive(Clone, Debug)]
struct ShutterDesc {
    curve: Vec<f32>,
    rolling: Option<f32>,
}

/// Draws shutter times.
#[derive(Clone, Debug)]
struct Shutter {
    /// Inverse CDF of the shutter curve at evenly spaced probabilities (None: uniform).
    inverse_cdf: Option<Vec<f32>>,
    /// Rolling shutter duration.
    rolling: Option<f32>,
}

impl Shutter {
    /// Cycles tabulates the inverse CDF of the curve (`util_cdf_inverted`, 256 entries);
    /// so does this, of the curve taken as piecewise linear.
    fn new(d: &ShutterDesc) -> Self {
        let inverse_cdf = (d.curve.len() >= 2 && d.curve.iter().any(|v| *v != d.curve[0])).then(|| {
            let n = d.curve.len() - 1;
            let mut cdf = vec![0.0f64; n + 1];
            for i in 0..n {
                cdf[i + 1] = cdf[i] + 0.5 * (d.curve[i] + d.curve[i + 1]) as f64;
            }
            let total = cdf[n];
            const TABLE: usize = 256;
            (0..TABLE)
                .map(|k| {
                    let target = total * k as f64 / (TABLE - 1) as f64;
                    let i = cdf.partition_point(|&c| c < target).clamp(1, n) - 1;
                    let (a, b) = (d.curve[i] as f64, d.curve[i + 1] as f64);
                    // Solve ∫ of the linear piece from its start = target − cdf[i].
                    let rest = target - cdf[i];
                    let x = if (b - a).abs() < 1e-12 {
                        if a > 0.0 {
                            rest / a
                        } else {
                            0.0
                        }
                    } else {
                        let disc = (a * a + 2.0 * (b - a) * rest).max(0.0);
                        (disc.sqrt() - a) / (b - a)
                    };
                    ((i as f64 + x.clamp(0.0, 1.0)) / n as f64) as f32
                })
                .collect()
        });
        Self { inverse_cdf, rolling: d.rolling }
    }

    /// The time for uniform `u` from the shutter curve alone.
    fn sample_curve(&self, u: f32) -> f32 {
        match &self.inverse_cdf {
            None => u,
            Some(table) => {
                let x = u * (table.len() - 1) as f32;
                let i = (x as usize).min(table.len() - 2);
                table[i] + (table[i + 1] - table[i]) * (x - i as f32)
            }
        }
    }

    /// The time for uniform `u` at the row's time `row` (0 top … 1 bottom). A duration of
    /// 0 gives the row's time exactly (Cycles' special case; the blend gives it too).
    fn sample(&self, u: f32, row: f32) -> f32 {
        let t = self.sample_curve(u);
        match self.rolling {
            None => t,
            // The row's own time plus its share of the exposure (Cycles' blend).
            Some(0.0) => row.clamp(0.0, 1.0),
            Some(d) => (t - 0.5) * d + (row.clamp(0.0, 1.0) - 0.5) * (1.0 - d) + 0.5,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blender_default_lens_field_of_view() {
        // 50 mm on a 36 mm sensor, landscape: horizontal FOV = 2 atan(18/50) = 39.6°.
        let mut rng = Rng::new(0, 0);
        let cam = Camera::new(&CameraDesc::default(), 160, 90).unwrap();
        let r = cam.generate_ray(160.0, 45.0, &mut rng).unwrap();
        let angle = r.direction.x.atan2(-r.direction.z).to_degrees();
        assert!((angle - (18.0f32 / 50.0).atan().to_degrees()).abs() < 1e-3, "{angle}");
        // Portrait with AUTO fit: the sensor width spans the height.
        let cam = Camera::new(&CameraDesc::default(), 90, 160).unwrap();
        let r = cam.generate_ray(45.0, 0.0, &mut rng).unwrap();
        let angle = r.direction.y.atan2(-r.direction.z).to_degrees();
        assert!((angle - (18.0f32 / 50.0).atan().to_degrees()).abs() < 1e-3, "{angle}");
    }

    #[test]
    fn shift_and_clip() {
        let desc = CameraDesc { shift_x: 0.5, clip_start: 2.0, clip_end: 3.0, ..Default::default() };
        let cam = Camera::new(&desc, 100, 100).unwrap();
        let mut rng = Rng::new(0, 0);
        // With shift 0.5 of the fitted side, the left edge of the image looks straight ahead.
        let r = cam.generate_ray(0.0, 50.0, &mut rng).unwrap();
        assert!(r.direction.x.abs() < 1e-6);
        let r = cam.generate_ray(100.0, 0.0, &mut rng).unwrap();
        let depth_min = (r.direction * r.tmin).dot(-Vec3A::Z);
        assert!((depth_min - 2.0).abs() < 1e-5);
        assert!(Camera::new(&CameraDesc { focal_length: 0.0, ..Default::default() }, 10, 10).is_err());
    }

    #[test]
    fn connect_inverts_generate_ray_and_importance_integrates_to_one() {
        let desc = CameraDesc { shift_x: 0.1, ..Default::default() };
        let cam = Camera::new(&desc, 40, 30).unwrap();
        let mut rng = crate::sampling::Rng::new(1, 2);
        let r = cam.generate_ray(13.25, 7.5, &mut rng).unwrap();
        let c = cam.connect(r.at(5.0), 0.5, &mut rng).unwrap();
        assert!((c.raster.x - 13.25).abs() < 1e-3 && (c.raster.y - 7.5).abs() < 1e-3, "{:?}", c.raster);
        assert!((c.wi + r.direction).length() < 1e-5);
        // ∫ We cos dω over the image = 1: a unit sphere of directions, Monte Carlo.
        let n = 200_000;
        let mut sum = 0.0f64;
        for _ in 0..n {
            let w = crate::sampling::uniform_sphere(rng.uniform2());
            if let Some(c) = cam.connect(w, 0.5, &mut rng) {
                sum += (c.importance * c.distance * c.distance) as f64 * 4.0 * std::f64::consts::PI;
            }
        }
        // Σ over pixels of (1/spp)·E[splat] with unit radiance = W·H per unit… per pixel 1.
        assert!((sum / n as f64 - 1.0).abs() < 0.02, "{}", sum / n as f64);
    }

    #[test]
    fn thin_lens_rays_meet_on_the_focus_plane_and_spread_elsewhere() {
        let (r_ap, focus) = (0.05f32, 4.0f32);
        let desc = CameraDesc { aperture_radius: r_ap, focus_distance: focus, shift_y: 0.1, ..Default::default() };
        let cam = Camera::new(&desc, 64, 48).unwrap();
        let pin = Camera::new(&CameraDesc { aperture_radius: 0.0, ..desc.clone() }, 64, 48).unwrap();
        let mut rng = Rng::new(7, 8);
        let p = pin.generate_ray(20.5, 30.5, &mut rng).unwrap();
        let at_depth = |r: &Ray, z: f32| r.at(z / r.direction.dot(-Vec3A::Z));
        let mut max_spread = 0.0f32;
        for _ in 0..2000 {
            let r = cam.generate_ray(20.5, 30.5, &mut rng).unwrap();
            assert!(r.origin.z.abs() < 1e-6 && r.origin.truncate().length() <= r_ap * 1.0001);
            // Every lens ray passes through the pinhole ray's point at the focus depth…
            assert!((at_depth(&r, focus) - at_depth(&p, focus)).length() < 1e-5);
            // …and at depth z lies within R·|1 − z/f| of it (the circle of confusion).
            let spread = (at_depth(&r, 10.0) - at_depth(&p, 10.0)).length();
            assert!(spread <= r_ap * (10.0 / focus - 1.0) * 1.0001);
            max_spread = max_spread.max(spread);
            // The clip distances stay planes along the view axis.
            assert!((r.at(r.tmin).z + desc.clip_start).abs() < 1e-5);
        }
        assert!(max_spread > 0.98 * r_ap * (10.0 / focus - 1.0));
    }

    #[test]
    fn thin_lens_connection_inverts_generate_ray_and_its_importance_integrates_to_one() {
        let desc = CameraDesc { aperture_radius: 0.2, focus_distance: 3.0, aperture_blades: 5, ..Default::default() };
        let cam = Camera::new(&desc, 40, 30).unwrap();
        let mut rng = Rng::new(9, 10);
        for _ in 0..100 {
            let (x, y) = (rng.uniform() * 40.0, rng.uniform() * 30.0);
            let r = cam.generate_ray(x, y, &mut rng).unwrap();
            let c = cam.connect_through(r.origin, r.at(1.0 + 6.0 * rng.uniform()), 0.5).unwrap();
            assert!((c.raster.x - x).abs() < 2e-3 && (c.raster.y - y).abs() < 2e-3, "{:?} vs {x} {y}", c.raster);
        }
        // From any lens point the importance integrates to 1 over the sphere of directions
        // (about 3% of the directions reach the image: 1e6 samples give σ ≈ 0.6%).
        let n = 1_000_000;
        let mut sum = 0.0f64;
        for _ in 0..n {
            let l = cam.aperture.unwrap().sample(rng.uniform2());
            let lens = Vec3A::new(l.x, l.y, 0.0);
            let w = crate::sampling::uniform_sphere(rng.uniform2());
            if let Some(c) = cam.connect_through(lens, lens + w * 2.0, 0.5) {
                sum += (c.importance * c.distance * c.distance) as f64 * 4.0 * std::f64::consts::PI;
            }
        }
        assert!((sum / n as f64 - 1.0).abs() < 0.02, "{}", sum / n as f64);
    }

    #[test]
    fn orthographic_lens_focuses_each_pixel_on_its_own_point() {
        let desc = CameraDesc {
            projection: Projection::Orthographic,
            ortho_scale: 2.0,
            aperture_radius: 0.1,
            focus_distance: 5.0,
            ..Default::default()
        };
        let cam = Camera::new(&desc, 20, 20).unwrap();
        let mut rng = Rng::new(1, 1);
        for _ in 0..100 {
            let r = cam.generate_ray(15.0, 5.0, &mut rng).unwrap();
            let p = r.at(5.0 / r.direction.dot(-Vec3A::Z));
            assert!((p - Vec3A::new(0.5, 0.5, -5.0)).length() < 1e-5, "{p}");
        }
    }

    #[test]
    fn pixel_aspect_widens_the_view_like_a_wider_image() {
        // 100×100 pixels twice as wide as tall see what 200×100 square pixels see.
        let wide = Camera::new(&CameraDesc { shift_x: 0.1, ..Default::default() }, 200, 100).unwrap();
        let cam = Camera::new(&CameraDesc { pixel_aspect: 2.0, shift_x: 0.1, ..Default::default() }, 100, 100).unwrap();
        let mut rng = Rng::new(0, 0);
        for (x, y) in [(0.0, 0.0), (100.0, 50.0), (37.5, 80.0)] {
            let a = cam.generate_ray(x, y, &mut rng).unwrap().direction;
            let b = wide.generate_ray(2.0 * x, y, &mut rng).unwrap().direction;
            assert!((a - b).length() < 1e-6, "{a} {b}");
        }
    }

    #[test]
    fn shift_is_in_units_of_the_fitted_side() {
        // Horizontal fit on a portrait image: the shift counts in image widths.
        let desc = CameraDesc { sensor_fit: SensorFit::Horizontal, shift_x: 0.5, ..Default::default() };
        let cam = Camera::new(&desc, 50, 100).unwrap();
        let r = cam.generate_ray(0.0, 50.0, &mut Rng::new(0, 0)).unwrap();
        assert!(r.direction.x.abs() < 1e-6, "{}", r.direction);
    }

    #[test]
    fn panoramas_clip_along_the_ray_and_report_distance_as_depth() {
        let desc = CameraDesc {
            projection: Projection::Panoramic,
            panorama_type: PanoramaType::FisheyeEquidistant,
            clip_start: 0.5,
            clip_end: 9.0,
            to_world: [[1.0, 0.0, 0.0, 1.0], [0.0, 1.0, 0.0, 2.0], [0.0, 0.0, 1.0, 3.0], [0.0, 0.0, 0.0, 1.0]],
            ..Default::default()
        };
        let cam = Camera::new(&desc, 32, 32).unwrap();
        let mut rng = Rng::new(0, 0);
        let r = cam.generate_ray(3.0, 16.0, &mut rng).unwrap();
        assert!((r.tmin - 0.5).abs() < 1e-6 && (r.tmax - 9.0).abs() < 1e-5);
        assert!((cam.depth(r.at(2.0)) - 2.0).abs() < 1e-5);
        // Outside the fisheye circle: no ray. Light tracing cannot connect to a panorama.
        assert!(cam.generate_ray(0.5, 0.5, &mut rng).is_none());
        assert!(!cam.is_perspective() && cam.connect(Vec3A::new(1.0, 2.0, 0.0), 0.5, &mut rng).is_none());
    }

    #[test]
    fn rolling_shutter_time_is_the_pixel_rows_as_in_cycles() {
        // Cycles: time = 1 − y / height with y the integer bottom-up pixel row, i.e.
        // (r + 1) / height for top-down row r, whatever the sample's jitter.
        let (w, h) = (8, 4);
        let mut rng = Rng::new(3, 0);
        let desc = CameraDesc { rolling_shutter: true, rolling_shutter_duration: 0.0, ..CameraDesc::default() };
        let mut cam = Camera::new(&desc, w, h).unwrap();
        cam.enable_motion_blur();
        for r in 0..h {
            for jitter in [0.0, 0.3, 0.999] {
                let ray = cam.generate_pixel_ray(2.5, r as f32 + jitter, r, &mut rng).unwrap();
                assert_eq!(ray.time, (r + 1) as f32 / h as f32, "row {r} jitter {jitter}");
            }
        }
        // A duration d blends: (t − ½) d + ((r + 1)/H − ½)(1 − d) + ½ over the shutter
        // sample t, so a row's times span d around its own, with their mean there.
        let desc = CameraDesc { rolling_shutter: true, rolling_shutter_duration: 0.2, ..CameraDesc::default() };
        let mut cam = Camera::new(&desc, w, h).unwrap();
        cam.enable_motion_blur();
        let times: Vec<f32> = (0..4000).map(|_| cam.sample_time(0, &mut rng)).collect();
        let centre = (0.25 - 0.5) * 0.8 + 0.5; // row 0 of 4: (0 + 1)/4
        let (lo, hi) = times.iter().fold((1.0f32, 0.0f32), |(a, b), t| (a.min(*t), b.max(*t)));
        assert!(lo >= centre - 0.1 - 1e-6 && hi <= centre + 0.1 + 1e-6 && hi - lo > 0.19, "{lo} {hi}");
        let mean = times.iter().sum::<f32>() / times.len() as f32;
        assert!((mean - centre).abs() < 0.005, "{mean}");
    }
}
