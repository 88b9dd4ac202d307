//! Thin-film interference: the reflectance of a thin, non-absorbing film (index
//! `n_film`, thickness `d`) on a dielectric or conducting substrate, seen from air,
//! for unpolarised light at one wavelength. This is the Airy summation of the multiply
//! reflected waves inside the film (Born & Wolf, "Principles of Optics", §7.6.1):
//!
//! ```text
//! r = (r01 + r12·e^{2iδ}) / (1 + r01·r12·e^{2iδ}),   δ = 2π/λ · n_film · d · cos θ1
//! ```
//!
//! per polarisation (s, p), with the Fresnel amplitude coefficients `r01` (air → film)
//! and `r12` (film → substrate), and `R = (|r_s|² + |r_p|²)/2`. The substrate may be
//! complex (η + ik), so metals under an oxide film work too. Blender's Principled BSDF
//! calls the inputs "Thin Film Thickness" (nm) and "Thin Film IOR". Evaluated per grid
//! wavelength this is true spectral interference; an RGB renderer can only approximate it.

/// A minimal complex number in double precision.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct C64 {
    pub re: f64,
    pub im: f64,
}

impl C64 {
    pub const fn new(re: f64, im: f64) -> Self {
        Self { re, im }
    }
    pub const fn real(re: f64) -> Self {
        Self { re, im: 0.0 }
    }
    pub fn add(self, o: Self) -> Self {
        Self::new(self.re + o.re, self.im + o.im)
    }
    pub fn sub(self, o: Self) -> Self {
        Self::new(self.re - o.re, self.im - o.im)
    }
    pub fn mul(self, o: Self) -> Self {
        Self::new(self.re * o.re - self.im * o.im, self.re * o.im + self.im * o.re)
    }
    pub fn scale(self, s: f64) -> Self {
        Self::new(self.re * s, self.im * s)
    }
    pub fn norm(self) -> f64 {
        self.re * self.re + self.im * self.im
    }
    pub fn div(self, o: Self) -> Self {
        let d = o.norm();
        Self::new((self.re * o.re + self.im * o.im) / d, (self.im * o.re - self.re * o.im) / d)
    }
    /// Principal square root (non-negative real part).
    pub fn sqrt(self) -> Self {
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
    /// e^{i·self}.
    pub fn exp_i(self) -> Self {
        let m = (-self.im).exp();
        Self::new(m * self.re.cos(), m * self.re.sin())
    }
}

/// Cosine of the refraction angle in a medium of (complex) index `n` for light arriving
/// from air at `cos0`, by Snell's law; the root with non-negative imaginary part of the
/// wave vector keeps evanescent waves decaying.
fn cos_in(n: C64, cos0: f64) -> C64 {
    let sin2 = C64::real(1.0 - cos0 * cos0);
    let c = C64::real(1.0).sub(sin2.div(n.mul(n))).sqrt();
    // n·cos must have Im ≥ 0 (absorbing / evanescent).
    if n.mul(c).im < 0.0 {
        c.scale(-1.0)
    } else {
        c
    }
}

/// Fresnel amplitude reflection coefficients (s, p) from medium i into medium j.
fn amplitudes(ni: C64, ci: C64, nj: C64, cj: C64) -> (C64, C64) {
    let (a, b) = (ni.mul(ci), nj.mul(cj));
    let rs = a.sub(b).div(a.add(b));
    let (c, d) = (nj.mul(ci), ni.mul(cj));
    let rp = c.sub(d).div(c.add(d));
    (rs, rp)
}

/// Reflectance of a film (`n_film`, `thickness_nm`) on a substrate `n_sub + i k_sub`,
/// seen from air at `cos0` (|cos θ|), at wavelength `lambda_nm`. Thickness 0 gives the
/// bare substrate's Fresnel reflectance. Always in 0..=1 (1 at grazing incidence).
pub fn thin_film_reflectance(cos0: f64, lambda_nm: f64, thickness_nm: f64, n_film: f64, n_sub: f64, k_sub: f64) -> f64 {
    let cos0 = cos0.abs().min(1.0);
    if cos0 <= 0.0 {
        return 1.0;
    }
    let n0 = C64::real(1.0);
    let n1 = C64::real(n_film);
    let n2 = C64::new(n_sub, k_sub);
    let c0 = C64::real(cos0);
    let c1 = cos_in(n1, cos0);
    let c2 = cos_in(n2, cos0);
    let (r01s, r01p) = amplitudes(n0, c0, n1, c1);
    let (r12s, r12p) = amplitudes(n1, c1, n2, c2);
    // Phase: 2δ = 4π n1 d cos θ1 / λ (complex when the film wave is evanescent).
    let two_delta = n1.mul(c1).scale(4.0 * std::f64::consts::PI * thickness_nm / lambda_nm);
    let e = two_delta.exp_i();
    let one = C64::real(1.0);
    let airy = |r01: C64, r12: C64| {
        let num = r01.add(r12.mul(e));
        let den = one.add(r01.mul(r12).mul(e));
        num.div(den).norm()
    };
    let r = 0.5 * (airy(r01s, r12s) + airy(r01p, r12p));
    if r.is_finite() {
        r.clamp(0.0, 1.0)
    } else {
        1.0
    }
}

/// A film on top of a specular interface: thickness (nm) and index.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThinFilm {
    pub thickness_nm: f32,
    pub ior: f32,
}

impl ThinFilm {
    /// Films thinner than this (nm) are ignored, as Blender does.
    pub const CUTOFF_NM: f32 = 1e-3;
    pub fn active(&self) -> bool {
        self.thickness_nm > Self::CUTOFF_NM
    }
}

/// Complex index of a metal with normal-incidence reflectance `r` and edge tint `g`
/// (Gulbrandsen 2014, "Artist Friendly Metallic Fresnel", JCGT 3(4)): used to put a
/// thin film on a metal given only by its colour.
pub fn metal_index_from_reflectance(r: f32, g: f32) -> (f64, f64) {
    let r = (r as f64).clamp(0.0, 0.99);
    let g = (g as f64).clamp(0.0, 1.0);
    let sr = r.sqrt();
    let n_min = (1.0 - r) / (1.0 + r);
    let n_max = (1.0 + sr) / (1.0 - sr);
    let n = g * n_min + (1.0 - g) * n_max;
    let k2 = (r * (n + 1.0).powi(2) - (n - 1.0).powi(2)) / (1.0 - r);
    (n, k2.max(0.0).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::fresnel::{fresnel_conductor, fresnel_dielectric_f64};

    /// Reference: the characteristic (transfer) matrix of a single layer (Macleod,
    /// "Thin-Film Optical Filters", §2.2), written independently of the Airy sum:
    /// [B; C] = [[cos δ, i sin δ/η1], [i η1 sin δ, cos δ]]·[1; η2], r = (η0 B − C)/(η0 B + C),
    /// with tilted admittances η = n cos θ (s) and n / cos θ (p). Real indices only.
    fn transfer_matrix_reflectance(theta0: f64, lambda: f64, d: f64, n1: f64, n2: f64) -> f64 {
        let s0 = theta0.sin();
        let c0 = theta0.cos();
        let c1 = (1.0 - (s0 / n1).powi(2)).sqrt();
        let c2 = (1.0 - (s0 / n2).powi(2)).sqrt();
        let delta = 2.0 * std::f64::consts::PI * n1 * d * c1 / lambda;
        let refl = |e0: f64, e1: f64, e2: f64| {
            // B = cos δ + i (sin δ/η1) η2, C = i η1 sin δ + η2 cos δ
            let (br, bi) = (delta.cos(), delta.sin() / e1 * e2);
            let (cr, ci) = (e2 * delta.cos(), e1 * delta.sin());
            let (nr, ni) = (e0 * br - cr, e0 * bi - ci);
            let (dr, di) = (e0 * br + cr, e0 * bi + ci);
            (nr * nr + ni * ni) / (dr * dr + di * di)
        };
        let rs = refl(c0, n1 * c1, n2 * c2);
        let rp = refl(1.0 / c0, n1 / c1, n2 / c2);
        0.5 * (rs + rp)
    }

    #[test]
    fn quarter_wave_film_cancels_reflection_at_its_design_wavelength() {
        let n_sub = 1.5f64;
        let n_film = n_sub.sqrt();
        let lambda0 = 550.0;
        let d = lambda0 / (4.0 * n_film);
        let r = thin_film_reflectance(1.0, lambda0, d, n_film, n_sub, 0.0);
        assert!(r < 1e-10, "quarter-wave AR coating reflects {r}");
        // The bare substrate reflects 4 %.
        assert!((thin_film_reflectance(1.0, lambda0, 0.0, n_film, n_sub, 0.0) - 0.04).abs() < 1e-12);
        // A half-wave film is absent at λ0: bare-substrate reflectance.
        let r_half = thin_film_reflectance(1.0, lambda0, 2.0 * d, n_film, n_sub, 0.0);
        assert!((r_half - 0.04).abs() < 1e-10, "{r_half}");
    }

    #[test]
    fn airy_matches_transfer_matrix_at_other_wavelengths_and_angles() {
        for &(n1, n2, d) in &[
            (1.2247f64, 1.5f64, 112.27f64),
            (1.33, 1.5, 300.0),
            (2.0, 1.5, 250.0),
            (1.38, 2.4, 80.0),
            (1.5, 1.33, 500.0),
        ] {
            for &lambda in &[380.0f64, 450.0, 550.0, 633.0, 780.0] {
                for k in 0..=17 {
                    let theta = k as f64 * 0.05 * std::f64::consts::FRAC_PI_2 * 1.1;
                    let theta = theta.min(1.55);
                    let r = thin_film_reflectance(theta.cos(), lambda, d, n1, n2, 0.0);
                    let t = transfer_matrix_reflectance(theta, lambda, d, n1, n2);
                    assert!((r - t).abs() < 1e-9, "n1 {n1} n2 {n2} d {d} λ {lambda} θ {theta}: Airy {r} vs matrix {t}");
                    assert!((0.0..=1.0).contains(&r));
                }
            }
        }
    }

    #[test]
    fn zero_thickness_is_bare_fresnel_for_dielectrics_and_metals() {
        for k in 0..=10 {
            let c = k as f64 / 10.0;
            let r = thin_film_reflectance(c, 500.0, 0.0, 1.33, 1.5, 0.0);
            let f = if c == 0.0 { 1.0 } else { fresnel_dielectric_f64(c, 1.5) };
            assert!((r - f).abs() < 1e-9, "{r} vs {f}");
            let rm = thin_film_reflectance(c, 500.0, 0.0, 1.4, 0.2, 3.0);
            let fm = fresnel_conductor(c as f32, 0.2, 3.0) as f64;
            assert!((rm - fm).abs() < 1e-5, "{rm} vs {fm}");
        }
    }

    #[test]
    fn gulbrandsen_index_reproduces_reflectance() {
        for &r in &[0.04f32, 0.5, 0.9, 0.95] {
            for &g in &[0.0f32, 0.5, 1.0] {
                let (n, k) = metal_index_from_reflectance(r, g);
                let f = fresnel_conductor(1.0, n as f32, k as f32);
                assert!((f - r).abs() < 1e-4, "r {r} g {g}: {f}");
            }
        }
    }
}
