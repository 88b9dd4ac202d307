//! Fresnel reflectance of smooth interfaces (unpolarised light) and the reflection and
//! refraction of directions. Formulas as in Born & Wolf, "Principles of Optics", §1.5,
//! in the form used by pbrt-v4 (Pharr, Jakob, Humphreys 2023, §9.3 and §9.4).

use glam::Vec3A;

/// Reflectance of a dielectric interface for unpolarised light.
///
/// `cos_i` is the cosine between the incident direction and the normal, positive on the
/// side the normal points to; `eta` is the index on the far side of the normal over the
/// index on the near side (n_inside / n_outside). A negative `cos_i` means the light
/// arrives from the far side, and the relative index is inverted. Returns 1 beyond the
/// critical angle (total internal reflection).
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> f32 {
    fresnel_dielectric_f64(cos_i as f64, eta as f64) as f32
}

/// [`fresnel_dielectric`] in double precision.
pub fn fresnel_dielectric_f64(cos_i: f64, eta: f64) -> f64 {
    let mut cos_i = cos_i.clamp(-1.0, 1.0);
    let mut eta = eta;
    if cos_i < 0.0 {
        eta = 1.0 / eta;
        cos_i = -cos_i;
    }
    let sin2_i = 1.0 - cos_i * cos_i;
    let sin2_t = sin2_i / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).max(0.0).sqrt();
    let denom_par = eta * cos_i + cos_t;
    let denom_perp = cos_i + eta * cos_t;
    if denom_par <= 0.0 || denom_perp <= 0.0 {
        return 1.0; // exactly grazing with cos_t = 0: everything reflects
    }
    let r_par = (eta * cos_i - cos_t) / denom_par;
    let r_perp = (cos_i - eta * cos_t) / denom_perp;
    (0.5 * (r_par * r_par + r_perp * r_perp)).clamp(0.0, 1.0)
}

/// A minimal complex number for the conductor Fresnel equations.
#[derive(Clone, Copy, Debug)]
struct Complex {
    re: f64,
    im: f64,
}

impl Complex {
    fn new(re: f64, im: f64) -> Self {
        Self { re, im }
    }
    fn add(self, o: Self) -> Self {
        Self::new(self.re + o.re, self.im + o.im)
    }
    fn sub(self, o: Self) -> Self {
        Self::new(self.re - o.re, self.im - o.im)
    }
    fn mul(self, o: Self) -> Self {
        Self::new(self.re * o.re - self.im * o.im, self.re * o.im + self.im * o.re)
    }
    fn scale(self, s: f64) -> Self {
        Self::new(self.re * s, self.im * s)
    }
    fn norm(self) -> f64 {
        self.re * self.re + self.im * self.im
    }
    fn div(self, o: Self) -> Self {
        let d = o.norm();
        Self::new((self.re * o.re + self.im * o.im) / d, (self.im * o.re - self.re * o.im) / d)
    }
    /// Principal square root (non-negative real part).
    fn sqrt(self) -> Self {
        let r = self.norm().sqrt();
        if r == 0.0 {
            return Self::new(0.0, 0.0);
        }
        let t1 = (0.5 * (r + self.re.abs())).sqrt();
        let t2 = 0.5 * self.im / t1;
        if self.re >= 0.0 {
            Self::new(t1, t2)
        } else {
            Self::new(t2.abs(), t1.copysign(self.im))
        }
    }
}

/// Reflectance of a conductor with complex index `eta + i k` (relative to the outside
/// medium) for unpolarised light arriving at `cos_i` (its absolute value is used).
pub fn fresnel_conductor(cos_i: f32, eta: f32, k: f32) -> f32 {
    let cos_i = (cos_i.abs() as f64).min(1.0);
    let eta_c = Complex::new(eta as f64, k as f64);
    if eta_c.norm() == 0.0 {
        return 1.0;
    }
    let sin2_i = Complex::new(1.0 - cos_i * cos_i, 0.0);
    let sin2_t = sin2_i.div(eta_c.mul(eta_c));
    let cos_t = Complex::new(1.0, 0.0).sub(sin2_t).sqrt();
    let ci = Complex::new(cos_i, 0.0);
    let r_par = eta_c.scale(cos_i).sub(cos_t).div(eta_c.scale(cos_i).add(cos_t));
    let r_perp = ci.sub(eta_c.mul(cos_t)).div(ci.add(eta_c.mul(cos_t)));
    let r = 0.5 * (r_par.norm() + r_perp.norm());
    if r.is_finite() {
        r.clamp(0.0, 1.0) as f32
    } else {
        1.0
    }
}

/// Schlick's approximation with a coloured normal-incidence reflectance `f0`.
#[inline]
pub fn schlick(cos_i: f32, f0: f32) -> f32 {
    let m = (1.0 - cos_i.abs()).clamp(0.0, 1.0);
    let m2 = m * m;
    f0 + (1.0 - f0) * m2 * m2 * m
}

/// Mirror reflection of `wo` about the normal `n`.
#[inline]
pub fn reflect(wo: Vec3A, n: Vec3A) -> Vec3A {
    -wo + n * (2.0 * wo.dot(n))
}

/// Refraction of `wi` (pointing away from the surface) through a surface of normal `n`
/// with relative index `eta` (far side over near side of `n`, as in
/// [`fresnel_dielectric`]). Returns the transmitted direction and the relative index
/// actually crossed (n_transmitted / n_incident), or None under total internal reflection.
pub fn refract(wi: Vec3A, n: Vec3A, eta: f32) -> Option<(Vec3A, f32)> {
    let mut cos_i = n.dot(wi);
    let mut eta = eta;
    let mut n = n;
    if cos_i < 0.0 {
        eta = 1.0 / eta;
        cos_i = -cos_i;
        n = -n;
    }
    let sin2_i = (1.0 - cos_i * cos_i).max(0.0);
    let sin2_t = sin2_i / (eta * eta);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).max(0.0).sqrt();
    let wt = -wi / eta + n * (cos_i / eta - cos_t);
    Some((wt.normalize_or_zero(), eta))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Transmittance computed independently from the Fresnel transmission amplitudes:
    /// T = (n_t cos_t)/(n_i cos_i) · (t_s² + t_p²)/2 with t_s = 2 n_i cos_i/(n_i cos_i + n_t cos_t),
    /// t_p = 2 n_i cos_i/(n_t cos_i + n_i cos_t).
    fn transmittance(cos_i: f64, n_i: f64, n_t: f64) -> f64 {
        let sin_t = n_i / n_t * (1.0 - cos_i * cos_i).max(0.0).sqrt();
        if sin_t >= 1.0 {
            return 0.0;
        }
        let cos_t = (1.0 - sin_t * sin_t).sqrt();
        let ts = 2.0 * n_i * cos_i / (n_i * cos_i + n_t * cos_t);
        let tp = 2.0 * n_i * cos_i / (n_t * cos_i + n_i * cos_t);
        if cos_i <= 0.0 {
            return 0.0;
        }
        n_t * cos_t / (n_i * cos_i) * 0.5 * (ts * ts + tp * tp)
    }

    #[test]
    fn reflectance_plus_transmittance_is_one_at_every_angle() {
        for &eta in &[1.0001f64, 1.33, 1.5, 2.4, 4.0] {
            for k in 0..=1000 {
                // Include exactly grazing incidence and angles past the critical angle.
                let cos_i = k as f64 / 1000.0;
                for &(n_i, n_t, sign) in &[(1.0, eta, 1.0), (eta, 1.0, -1.0)] {
                    let r = fresnel_dielectric_f64(sign * cos_i, eta);
                    let t = transmittance(cos_i, n_i, n_t);
                    assert!((0.0..=1.0).contains(&r));
                    if cos_i > 1e-6 {
                        assert!((r + t - 1.0).abs() < 1e-9, "eta {eta} n_i {n_i} cos {cos_i}: R {r} T {t}");
                    } else {
                        assert!((r - 1.0).abs() < 1e-9, "grazing must reflect everything: {r}");
                    }
                    // The f32 entry point agrees (away from the critical angle, where
                    // R is infinitely steep and f32 rounding of cos θ dominates).
                    let sin2_t = (1.0 - cos_i * cos_i) * (n_i / n_t).powi(2);
                    if (sin2_t - 1.0).abs() > 1e-2 {
                        let r32 = fresnel_dielectric((sign * cos_i) as f32, eta as f32) as f64;
                        assert!((r32 - r).abs() < 1e-3, "eta {eta} cos {cos_i}: {r32} vs {r}");
                    }
                }
            }
        }
    }

    #[test]
    fn normal_incidence_and_total_internal_reflection() {
        for &n in &[1.0001f64, 1.5, 4.0] {
            let r0 = ((n - 1.0) / (n + 1.0)).powi(2);
            assert!((fresnel_dielectric_f64(1.0, n) - r0).abs() < 1e-12);
            assert!((fresnel_dielectric_f64(-1.0, n) - r0).abs() < 1e-12);
            // From inside: everything reflects beyond the critical angle asin(1/n).
            let crit = (1.0 / n).asin();
            let just_below = (crit - 1e-4).cos();
            let just_above = (crit + 1e-4).cos();
            assert!(fresnel_dielectric_f64(-just_below, n) < 1.0);
            assert_eq!(fresnel_dielectric_f64(-just_above, n), 1.0);
            assert_eq!(fresnel_dielectric_f64(-0.0, n), 1.0);
            let inside = Vec3A::new((1.0 - just_above * just_above).sqrt() as f32, 0.0, -just_above as f32);
            if n > 1.01 {
                assert!(refract(inside, Vec3A::Z, n as f32).is_none());
            }
        }
    }

    #[test]
    fn conductor_normal_incidence_and_limits() {
        for &(n, k) in &[(0.2f32, 3.0f32), (1.5, 0.0), (0.14, 3.697), (2.5, 8.0)] {
            let expected = ((n - 1.0).powi(2) + k * k) / ((n + 1.0).powi(2) + k * k);
            assert!((fresnel_conductor(1.0, n, k) - expected).abs() < 1e-6, "{n} {k}");
            // Grazing: everything reflects.
            assert!((fresnel_conductor(0.0, n, k) - 1.0).abs() < 1e-6);
        }
        // k = 0 is a dielectric.
        for k in 1..=10 {
            let c = k as f32 / 10.0;
            assert!((fresnel_conductor(c, 1.5, 0.0) - fresnel_dielectric(c, 1.5)).abs() < 1e-5);
        }
    }

    #[test]
    fn refraction_follows_snell() {
        let eta = 1.5f32;
        for k in 1..10 {
            let theta = k as f32 * 0.15;
            let wi = Vec3A::new(theta.sin(), 0.0, theta.cos());
            let (wt, etap) = refract(wi, Vec3A::Z, eta).unwrap();
            assert_eq!(etap, eta);
            let sin_t = (wt.x * wt.x + wt.y * wt.y).sqrt();
            assert!((theta.sin() - eta * sin_t).abs() < 1e-5);
            assert!(wt.z < 0.0 && wt.x < 0.0);
            // And back.
            let (back, etap) = refract(wt, Vec3A::Z, eta).unwrap();
            assert!((etap - 1.0 / eta).abs() < 1e-6);
            assert!((back - wi).length() < 1e-5, "{back:?}");
        }
    }
}
