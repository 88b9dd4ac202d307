//! The thin lens's aperture: a disk or a regular polygon (the diaphragm's blades),
//! optionally squeezed horizontally (anamorphic bokeh). Sampled uniformly by area, as
//! Cycles samples it (`camera_sample_aperture`, intern/cycles/kernel/camera/camera.h).

use crate::sampling::concentric_disk;
use glam::Vec2;
use std::f32::consts::PI;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aperture {
    /// Radius of the disk, or circumradius of the polygon, in scene units.
    pub radius: f32,
    /// Polygon corners; fewer than 3 is a disk (Cycles' rule).
    pub blades: u32,
    /// Rotation of the polygon in radians, counter-clockwise seen from behind the lens.
    pub rotation: f32,
    /// Anamorphic ratio: the aperture's width is divided by it (Blender's
    /// `dof.aperture_ratio`; 1 is round).
    pub ratio: f32,
}

impl Aperture {
    /// A point on the aperture in the lens plane (x right, y up), uniform by area.
    pub fn sample(&self, u: Vec2) -> Vec2 {
        let unit = if self.blades < 3 { concentric_disk(u) } else { regular_polygon(self.blades, self.rotation, u) };
        Vec2::new(unit.x * self.radius / self.ratio, unit.y * self.radius)
    }

    /// Area of the aperture in scene units².
    pub fn area(&self) -> f32 {
        let unit = if self.blades < 3 {
            PI
        } else {
            let n = self.blades as f32;
            0.5 * n * (2.0 * PI / n).sin()
        };
        unit * self.radius * self.radius / self.ratio
    }
}

/// A uniform point in the regular polygon with `corners` vertices on the unit circle,
/// the first two at `rotation ± π/corners`: one of its `corners` triangles (apex at the
/// centre) chosen by `u.x`, then a uniform point in that triangle.
fn regular_polygon(corners: u32, rotation: f32, u: Vec2) -> Vec2 {
    let n = corners as f32;
    let scaled = u.x * n;
    let k = scaled.floor().min(n - 1.0);
    let s = (scaled - k).clamp(0.0, 1.0);
    // Uniform in the triangle (0, e1, e2): a = √s along the median, t across it.
    let a = s.sqrt();
    let t = u.y;
    let half = PI / n;
    // Vertices of the triangle before rotation: (cos h, ±sin h).
    let local = Vec2::new(a * half.cos(), a * (2.0 * t - 1.0) * half.sin());
    let angle = rotation + k * 2.0 * half;
    Vec2::from_angle(angle).rotate(local)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    /// Is `p` inside the polygon with `n` vertices at `rotation + (2k+1)π/n`?
    fn inside_polygon(p: Vec2, n: u32, rotation: f32) -> bool {
        let half = PI / n as f32;
        (0..n).all(|k| {
            // Edge k's outward normal points at rotation + 2kπ/n, at distance cos(π/n).
            let normal = Vec2::from_angle(rotation + k as f32 * 2.0 * half);
            p.dot(normal) <= half.cos() + 1e-5
        })
    }

    #[test]
    fn polygon_samples_are_uniform_inside_the_polygon() {
        let ap = Aperture { radius: 1.0, blades: 6, rotation: 0.3, ratio: 1.0 };
        let mut rng = Rng::new(3, 4);
        let n = 100_000;
        let mut mean = Vec2::ZERO;
        let mut in_inner = 0usize;
        for _ in 0..n {
            let p = ap.sample(rng.uniform2());
            assert!(inside_polygon(p, 6, 0.3), "{p}");
            mean += p;
            // Fraction inside the concentric polygon scaled by 1/2 must be 1/4 (uniform by area).
            in_inner += inside_polygon(p * 2.0, 6, 0.3) as usize;
        }
        mean /= n as f32;
        assert!(mean.length() < 0.01, "{mean}");
        let frac = in_inner as f32 / n as f32;
        assert!((frac - 0.25).abs() < 0.01, "{frac}");
        // The area formula: hexagon of circumradius 1 = 3√3/2.
        assert!((ap.area() - 1.5 * 3f32.sqrt()).abs() < 1e-5);
    }

    #[test]
    fn anamorphic_ratio_narrows_the_width() {
        let ap = Aperture { radius: 2.0, blades: 0, rotation: 0.0, ratio: 2.0 };
        let mut rng = Rng::new(5, 6);
        let (mut max_x, mut max_y) = (0.0f32, 0.0f32);
        for _ in 0..20_000 {
            let p = ap.sample(rng.uniform2());
            assert!((p.x / 1.0).powi(2) + (p.y / 2.0).powi(2) <= 1.0 + 1e-5);
            max_x = max_x.max(p.x.abs());
            max_y = max_y.max(p.y.abs());
        }
        assert!(max_x > 0.98 && max_x <= 1.0 + 1e-5 && max_y > 1.96, "{max_x} {max_y}");
        assert!((ap.area() - PI * 2.0).abs() < 1e-5);
    }
}
