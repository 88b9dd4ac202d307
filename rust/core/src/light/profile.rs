//! Goniometric light profiles (IES files): a point or spot light's radiant intensity
//! scaled by a table over the directions it emits into, as Cycles' IES Texture node on
//! a light's Emission Strength (kernel/util/ies.h, `kernel_ies_interp`).
//!
//! The table is Cycles' processed form (util/ies.cpp, done by `polychrome.ies` in
//! Python): horizontal angles h ∈ [0, 2π] and vertical angles v ∈ [0, π], both
//! increasing, values row by row per horizontal angle. A direction w leaving the light,
//! taken into the light's local frame (lights shine down their −Z), has v = acos(−w.z)
//! (0 straight down) and h = atan2(w.x, w.y) + π. Values are interpolated by Catmull–Rom
//! splines, first along v in the four nearest rows, then along h; outside the table's
//! range the profile is 0; a table that spans the full circle in h (or reaches a pole in
//! v) wraps there, as Cycles does.

use glam::{Mat3A, Vec3A};
use std::f32::consts::PI;

#[derive(Clone, Debug)]
pub struct Profile {
    h: Vec<f32>,
    v: Vec<f32>,
    /// `values[i * v.len() + j]` at (h[i], v[j]).
    values: Vec<f32>,
    /// World directions → the light's local frame (a rotation).
    to_local: Mat3A,
    /// Mean of the profile over the sphere of directions, for choosing lights by power.
    mean: f32,
}

/// Cycles' `cubic_interp`: Catmull–Rom between b and c, a and d the neighbours.
fn cubic(a: f32, b: f32, c: f32, d: f32, x: f32) -> f32 {
    0.5 * ((((d + 3.0 * (b - c) - a) * x + (2.0 * a - 5.0 * b + 4.0 * c - d)) * x + (c - a)) * x) + b
}

impl Profile {
    /// A profile from its table (see the module's conventions) and the rotation
    /// `to_local` from world to the light's frame. Errors name what is wrong.
    pub fn new(h: Vec<f32>, v: Vec<f32>, values: Vec<f32>, to_local: Mat3A) -> Result<Self, String> {
        if h.len() < 2 || v.len() < 2 {
            return Err(format!(
                "profile needs at least 2 horizontal and 2 vertical angles (has {} and {})",
                h.len(),
                v.len()
            ));
        }
        if values.len() != h.len() * v.len() {
            return Err(format!("profile has {} values for {} × {} angles", values.len(), h.len(), v.len()));
        }
        let increasing = |a: &[f32]| a.windows(2).all(|w| w[1] > w[0]) && a.iter().all(|x| x.is_finite());
        if !increasing(&h) || !increasing(&v) {
            return Err("profile angles must be finite and increasing".into());
        }
        if h[0] < -1e-6 || h[h.len() - 1] > 2.0 * PI + 1e-5 || v[0] < -1e-6 || v[v.len() - 1] > PI + 1e-5 {
            return Err("profile angles must lie in h ∈ [0, 2π], v ∈ [0, π] (radians)".into());
        }
        if let Some(x) = values.iter().find(|x| !(x.is_finite() && **x >= 0.0)) {
            return Err(format!("profile value {x} is not a finite non-negative number"));
        }
        if !to_local.is_finite() {
            return Err("profile orientation is not finite".into());
        }
        let mut p = Self { h, v, values, to_local, mean: 0.0 };
        p.mean = p.sphere_mean();
        Ok(p)
    }

    /// The mean of the profile over all directions (midpoint rule on a fine grid of
    /// equal solid angle: uniform in cos v and in h).
    fn sphere_mean(&self) -> f32 {
        let (nv, nh) = (256, 256);
        let mut sum = 0.0f64;
        for i in 0..nv {
            let cos_v = 1.0 - 2.0 * (i as f32 + 0.5) / nv as f32;
            for k in 0..nh {
                sum += self.lookup((k as f32 + 0.5) / nh as f32 * 2.0 * PI, cos_v.acos()) as f64;
            }
        }
        (sum / (nv * nh) as f64) as f32
    }

    pub fn mean(&self) -> f32 {
        self.mean
    }

    /// The profile along unit world direction `w` leaving the light.
    pub fn eval(&self, w: Vec3A) -> f32 {
        let l = self.to_local * w;
        let v_angle = (-l.z).clamp(-1.0, 1.0).acos();
        let h_angle = l.x.atan2(l.y) + PI;
        self.lookup(h_angle, v_angle)
    }

    fn at(&self, i: usize, j: usize) -> f32 {
        self.values[i * self.v.len() + j]
    }

    /// Catmull–Rom along v in row `i` between v[j] and v[j + 1].
    fn along_v(&self, i: usize, j: usize, t: f32, wrap_low: bool, wrap_high: bool) -> f32 {
        let n = self.v.len();
        let (b, c) = (self.at(i, j), self.at(i, j + 1));
        let a = if j > 0 {
            self.at(i, j - 1)
        } else if wrap_low {
            self.at(i, 1)
        } else {
            b
        };
        let d = if j + 2 < n {
            self.at(i, j + 2)
        } else if wrap_high {
            self.at(i, n - 2)
        } else {
            c
        };
        cubic(a, b, c, d, t)
    }

    /// The table at angles (h, v) in radians, as `kernel_ies_interp`.
    pub fn lookup(&self, h_angle: f32, v_angle: f32) -> f32 {
        let (h, v) = (&self.h, &self.v);
        let (hn, vn) = (h.len(), v.len());
        if !(v_angle >= v[0] && v_angle < v[vn - 1] && h_angle >= h[0] && h_angle < h[hn - 1]) {
            return 0.0;
        }
        let wrap_h = h[0] < 1e-7 && h[hn - 1] > 2.0 * PI - 1e-7;
        let wrap_low = v[0] < 1e-7;
        let wrap_high = v[vn - 1] > PI - 1e-7;
        let i = h.partition_point(|&x| x <= h_angle).clamp(1, hn - 1) - 1;
        let j = v.partition_point(|&x| x <= v_angle).clamp(1, vn - 1) - 1;
        let th = (h_angle - h[i]) / (h[i + 1] - h[i]);
        let tv = (v_angle - v[j]) / (v[j + 1] - v[j]);
        let row = |k: usize| self.along_v(k, j, tv, wrap_low, wrap_high);
        let (b, c) = (row(i), row(i + 1));
        let a = if i > 0 {
            row(i - 1)
        } else if wrap_h {
            row(hn - 2) // the last entry (2π) repeats the first
        } else {
            b
        };
        let d = if i + 2 < hn {
            row(i + 2)
        } else if wrap_h {
            row(1)
        } else {
            b // as Cycles (not c)
        };
        cubic(a, b, c, d, th).max(0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn degrees(a: &[f32]) -> Vec<f32> {
        a.iter().map(|x| x.to_radians()).collect()
    }

    /// A table of a smooth function is interpolated to it (Catmull–Rom reproduces
    /// quadratics exactly): I = 1 + v² − 0.1 h², and 0 outside the table.
    #[test]
    fn catmull_rom_reproduces_a_quadratic_table() {
        let h = degrees(&[0.0, 30.0, 60.0, 90.0, 120.0]);
        let v = degrees(&[0.0, 20.0, 40.0, 60.0, 80.0, 100.0]);
        let f = |h: f32, v: f32| 1.0 + v * v - 0.1 * h * h;
        let values = h.iter().flat_map(|&a| v.iter().map(move |&b| f(a, b))).collect();
        let p = Profile::new(h, v, values, Mat3A::IDENTITY).unwrap();
        for &(a, b) in &[(0.6f32, 0.5f32), (1.0, 1.2), (0.9, 0.4)] {
            assert!((p.lookup(a, b) - f(a, b)).abs() < 1e-4, "{a} {b}: {} vs {}", p.lookup(a, b), f(a, b));
        }
        assert_eq!(p.lookup(2.2, 0.5), 0.0);
        assert_eq!(p.lookup(0.5, 1.8), 0.0);
    }

    /// An isotropic profile of value c over the whole sphere: c in every direction and
    /// mean c; a "cosine" profile max(cos v, 0) straight down has mean 1/4.
    #[test]
    fn isotropic_and_cosine_profiles() {
        let h = degrees(&[0.0, 90.0, 180.0, 270.0, 360.0]);
        let v: Vec<f32> = (0..=36).map(|k| (5.0 * k as f32).to_radians()).collect();
        let flat = Profile::new(h.clone(), v.clone(), vec![2.5; h.len() * v.len()], Mat3A::IDENTITY).unwrap();
        // (v ends at π exactly, where the lookup is out of range: the measure-zero pole.)
        assert!((flat.mean() - 2.5).abs() < 0.02, "{}", flat.mean());
        assert!((flat.eval(Vec3A::new(0.3, -0.4, 0.5).normalize()) - 2.5).abs() < 1e-5);
        let values = h.iter().flat_map(|_| v.iter().map(|&b| b.cos().max(0.0))).collect();
        let cos = Profile::new(h, v, values, Mat3A::IDENTITY).unwrap();
        assert!((cos.mean() - 0.25).abs() < 2e-3, "{}", cos.mean());
        assert!((cos.eval(-Vec3A::Z) - 1.0).abs() < 1e-5);
        let w = Vec3A::new(0.6, 0.0, -0.8);
        assert!((cos.eval(w) - 0.8).abs() < 2e-3, "{}", cos.eval(w));
        assert_eq!(cos.eval(Vec3A::Z), 0.0);
        // Rotated so that the light's −Z points along world +X.
        let to_local = Mat3A::from_rotation_y(std::f32::consts::FRAC_PI_2);
        let turned = Profile { to_local, ..cos };
        assert!((turned.eval(Vec3A::X) - 1.0).abs() < 1e-4, "{}", turned.eval(Vec3A::X));
    }

    #[test]
    fn bad_tables_are_errors() {
        let h = vec![0.0, 1.0];
        let v = vec![0.0, 1.0];
        assert!(Profile::new(h.clone(), v.clone(), vec![1.0; 3], Mat3A::IDENTITY).unwrap_err().contains("values"));
        assert!(Profile::new(h.clone(), v.clone(), vec![1.0, f32::NAN, 1.0, 1.0], Mat3A::IDENTITY).is_err());
        assert!(Profile::new(vec![1.0, 0.5], v, vec![1.0; 4], Mat3A::IDENTITY).unwrap_err().contains("increasing"));
    }
}
