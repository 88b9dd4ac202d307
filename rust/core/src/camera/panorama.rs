//! Panoramic projections, each the mapping Cycles uses (intern/cycles/kernel/camera/
//! projection.h, `panorama_to_direction`; axes from `blender_camera_matrix` in
//! intern/cycles/blender/camera.cpp), written from those formulas.
//!
//! Every mapping takes the film position (u, v) of the view plane — [0, 1]² over the
//! image plus the lens shift, v up — to a direction in Cycles' panorama space, where
//! +x looks ahead and +z is up (the mirror ball looks down −y instead). The fixed
//! rotation/reflection [`Panorama::to_camera`] turns that into Blender's camera space
//! (−Z ahead, +Y up), so an equirectangular camera looking along the world's +X sees
//! the centre of an equirectangular environment texture in the middle of the image.

use glam::{Mat3A, Vec2, Vec3A};
use serde::{Deserialize, Serialize};
use std::f32::consts::FRAC_PI_2;

/// Blender's `Camera.panorama_type`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "SCREAMING_SNAKE_CASE")]
pub enum PanoramaType {
    #[default]
    Equirectangular,
    EquiangularCubemapFace,
    Mirrorball,
    FisheyeEquidistant,
    FisheyeEquisolid,
    FisheyeLensPolynomial,
    CentralCylindrical,
}

/// A panoramic projection with its parameters resolved for one image.
#[derive(Clone, Debug)]
pub struct Panorama {
    pub kind: PanoramaType,
    /// Equirectangular: φ = range[0]·u + range[1], θ = range[2]·v + range[3] (Cycles'
    /// `equirectangular_range` from the latitude/longitude limits).
    pub range: [f32; 4],
    /// Field of view of the fisheyes, radians.
    pub fisheye_fov: f32,
    /// Focal length of the equisolid fisheye, mm.
    pub fisheye_lens: f32,
    /// Sensor extent in mm fitted to the image (equisolid and polynomial fisheyes).
    pub sensor: Vec2,
    /// Polynomial fisheye: θ = −(k0 + k1 r + k2 r² + k3 r³ + k4 r⁴), r in mm.
    pub polynomial: [f32; 5],
    /// Central cylindrical: θ = mix(c0, c1, u), height z = mix(c2, c3, v) — Cycles'
    /// `central_cylindrical_range`: (−u_min, −u_max, v_min/radius, v_max/radius).
    pub cylinder: [f32; 4],
}

/// Longitude/latitude limits (radians) → Cycles' `equirectangular_range`.
pub fn equirectangular_range(longitude: [f32; 2], latitude: [f32; 2]) -> [f32; 4] {
    [longitude[0] - longitude[1], -longitude[0], latitude[0] - latitude[1], -latitude[0] + FRAC_PI_2]
}

impl Panorama {
    /// Panorama space → Blender camera space.
    pub fn to_camera(&self) -> Mat3A {
        if self.kind == PanoramaType::Mirrorball {
            // (x, y, z) → (x, z, y): the ball looks down −y, which becomes −Z.
            Mat3A::from_cols(Vec3A::X, Vec3A::Z, Vec3A::Y)
        } else {
            // (x, y, z) → (−y, z, −x): +x (ahead) becomes −Z, +z (up) becomes +Y.
            Mat3A::from_cols(-Vec3A::Z, -Vec3A::X, Vec3A::Y)
        }
    }

    /// The direction (panorama space, not normalised) seen at film position (u, v);
    /// None outside the lens (fisheye circle, mirror ball disk, beyond the field of view).
    pub fn direction(&self, u: f32, v: f32) -> Option<Vec3A> {
        let d = match self.kind {
            PanoramaType::Equirectangular => {
                let phi = self.range[0] * u + self.range[1];
                let theta = self.range[2] * v + self.range[3];
                Vec3A::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos())
            }
            PanoramaType::EquiangularCubemapFace => {
                let a = ((0.5 - u) * FRAC_PI_2).tan();
                let b = ((v - 0.5) * FRAC_PI_2).tan();
                Vec3A::new(1.0, a, b)
            }
            PanoramaType::Mirrorball => {
                // The point of a unit ball seen at (u, v) by an orthographic view down +y,
                // and the view ray reflected there.
                let (x, z) = (2.0 * u - 1.0, 2.0 * v - 1.0);
                if x * x + z * z > 1.0 {
                    return None;
                }
                let n = Vec3A::new(x, -(1.0 - x * x - z * z).max(0.0).sqrt(), z);
                let i = Vec3A::new(0.0, -1.0, 0.0);
                2.0 * n.dot(i) * n - i
            }
            PanoramaType::FisheyeEquidistant => {
                let (x, y) = ((u - 0.5) * 2.0, (v - 0.5) * 2.0);
                let r = (x * x + y * y).sqrt();
                if r > 1.0 {
                    return None;
                }
                fisheye(r * self.fisheye_fov * 0.5, x, y, r)
            }
            PanoramaType::FisheyeEquisolid => {
                let (x, y) = ((u - 0.5) * self.sensor.x, (v - 0.5) * self.sensor.y);
                let r = (x * x + y * y).sqrt();
                if r > 2.0 * self.fisheye_lens * (self.fisheye_fov * 0.25).sin() {
                    return None;
                }
                fisheye(2.0 * (r / (2.0 * self.fisheye_lens)).min(1.0).asin(), x, y, r)
            }
            PanoramaType::FisheyeLensPolynomial => {
                let (x, y) = ((u - 0.5) * self.sensor.x, (v - 0.5) * self.sensor.y);
                let r = (x * x + y * y).sqrt();
                let k = &self.polynomial;
                let theta = -(k[0] + r * (k[1] + r * (k[2] + r * (k[3] + r * k[4]))));
                if theta.abs() > 0.5 * self.fisheye_fov {
                    return None;
                }
                fisheye(theta, x, y, r)
            }
            PanoramaType::CentralCylindrical => {
                let theta = self.cylinder[0] + u * (self.cylinder[1] - self.cylinder[0]);
                let z = self.cylinder[2] + v * (self.cylinder[3] - self.cylinder[2]);
                Vec3A::new(theta.cos(), theta.sin(), z)
            }
        };
        (d.is_finite() && d != Vec3A::ZERO).then_some(d)
    }

    /// Depth of field for a panorama (Cycles' `camera_sample_panorama`): the origin moves
    /// to `lens` in the plane perpendicular to the view direction `d` (unit, panorama
    /// space), the direction aims at the point at `focus` along `d` (a sphere of focus).
    pub fn thin_lens(d: Vec3A, lens: Vec2, focus: f32) -> (Vec3A, Vec3A) {
        let mut u = Vec3A::X - d.x * d;
        if u.length_squared() < 1e-12 {
            // Looking straight along x: any perpendicular axis will do.
            u = Vec3A::Y - d.y * d;
        }
        let u = u.normalize();
        let v = d.cross(u);
        let origin = u * lens.x + v * lens.y;
        (origin, (d * focus - origin).normalize())
    }
}

/// The fisheyes' common last step: polar angle θ off the +x axis, azimuth from the film
/// offset (x, y) at radius r.
fn fisheye(theta: f32, x: f32, y: f32, r: f32) -> Vec3A {
    let (cos_phi, sin_phi) = if r > 0.0 { (x / r, y / r) } else { (1.0, 0.0) };
    Vec3A::new(theta.cos(), -cos_phi * theta.sin(), sin_phi * theta.sin())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f32::consts::PI;

    fn pano(kind: PanoramaType) -> Panorama {
        Panorama {
            kind,
            range: equirectangular_range([-PI, PI], [-FRAC_PI_2, FRAC_PI_2]),
            fisheye_fov: PI,
            fisheye_lens: 10.5,
            sensor: Vec2::new(36.0, 36.0),
            polynomial: [0.0, -0.1, 0.0, 0.0, 0.0],
            cylinder: [PI, -PI, -1.0, 1.0],
        }
    }

    fn camera_dir(p: &Panorama, u: f32, v: f32) -> Vec3A {
        (p.to_camera() * p.direction(u, v).unwrap()).normalize()
    }

    #[test]
    fn every_type_looks_ahead_at_the_centre_and_up_above_it() {
        for kind in [
            PanoramaType::Equirectangular,
            PanoramaType::EquiangularCubemapFace,
            PanoramaType::Mirrorball,
            PanoramaType::FisheyeEquidistant,
            PanoramaType::FisheyeEquisolid,
            PanoramaType::FisheyeLensPolynomial,
            PanoramaType::CentralCylindrical,
        ] {
            let p = pano(kind);
            let c = camera_dir(&p, 0.5, 0.5);
            assert!((c - Vec3A::new(0.0, 0.0, -1.0)).length() < 1e-5, "{kind:?} centre {c}");
            let up = camera_dir(&p, 0.5, 0.6);
            assert!(up.y > 0.0 && up.x.abs() < 1e-5, "{kind:?} up {up}");
            let right = camera_dir(&p, 0.6, 0.5);
            assert!(right.x > 0.0 && right.y.abs() < 1e-5, "{kind:?} right {right}");
        }
    }

    #[test]
    fn equirectangular_covers_the_sphere_and_respects_ranges() {
        let p = pano(PanoramaType::Equirectangular);
        // Left edge looks backwards, top straight up, bottom straight down.
        assert!((camera_dir(&p, 0.0, 0.5) - Vec3A::Z).length() < 1e-5);
        assert!((camera_dir(&p, 0.25, 0.5) + Vec3A::X).length() < 1e-5);
        assert!((camera_dir(&p, 0.3, 1.0) - Vec3A::Y).length() < 1e-5);
        assert!((camera_dir(&p, 0.3, 0.0) + Vec3A::Y).length() < 1e-5);
        // A 90°×45° window around the view axis.
        let q = Panorama { range: equirectangular_range([-PI / 4.0, PI / 4.0], [0.0, PI / 4.0]), ..p };
        let corner = camera_dir(&q, 1.0, 1.0);
        let (lon, lat) = (corner.x.atan2(-corner.z), corner.y.asin());
        assert!((lon - PI / 4.0).abs() < 1e-5 && (lat - PI / 4.0).abs() < 1e-5, "{lon} {lat}");
    }

    #[test]
    fn fisheyes_follow_their_radial_laws() {
        // Equidistant: angle off-axis grows linearly with radius to fov/2 at the rim.
        let p = pano(PanoramaType::FisheyeEquidistant);
        let d = camera_dir(&p, 0.75, 0.5);
        assert!((d.dot(-Vec3A::Z).acos() - PI / 4.0).abs() < 1e-5);
        assert!(p.direction(0.9, 0.9).is_none());
        // Equisolid: r = 2 f sin(θ/2).
        let p = pano(PanoramaType::FisheyeEquisolid);
        let r = 0.25 * 36.0;
        let d = camera_dir(&p, 0.75, 0.5);
        assert!((d.dot(-Vec3A::Z).acos() - 2.0 * (r / (2.0 * 10.5f32)).asin()).abs() < 1e-5);
        // Mirror ball: the rim of the disk looks straight back.
        let p = pano(PanoramaType::Mirrorball);
        let d = camera_dir(&p, 0.5, 1.0 - 1e-7);
        assert!(d.z > 0.99, "{d}");
    }

    #[test]
    fn panorama_thin_lens_focuses_on_the_sphere() {
        let d = Vec3A::new(0.3, -0.5, 0.8).normalize();
        let (o, w) = Panorama::thin_lens(d, Vec2::new(0.01, -0.02), 3.0);
        assert!(o.dot(d).abs() < 1e-6 && (o.length() - 0.05f32.sqrt() * 0.1).abs() < 1e-5);
        // The ray passes through the in-focus point d·3.
        let t = (d * 3.0 - o).length();
        assert!((o + w * t - d * 3.0).length() < 1e-5);
    }
}
