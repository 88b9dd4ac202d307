//! Environments: the same radiance from every direction (Blender's world colour) or an
//! equirectangular image (HDRI). Both are lights at infinity: next-event estimation
//! samples their directions (`sample_li`), and light paths (FORWARD, BIDIRECTIONAL) start
//! from them as pbrt-v4's infinite lights do (`sample_le`): a direction from the same
//! distribution, the origin uniform on a disk of the scene's bounding radius
//! perpendicular to it ([`super::infinite_light_origin`], given by
//! [`Light::preprocess`]), pdf_pos = 1/(π r²).

use super::{infinite_light_origin, infinite_light_radius, EmissionSample, LeDensity, Light, LightSample};
use crate::sampling::uniform_sphere;
use crate::spectrum::SampledSpectrum;
use glam::{Vec2, Vec3A};
use std::f32::consts::PI;

pub struct UniformEnvironment {
    pub radiance: SampledSpectrum,
    /// A sphere bounding the scene ([`Light::preprocess`]): where light paths start and
    /// the power an infinite light delivers to it.
    pub scene_center: Vec3A,
    pub scene_radius: f32,
}

impl UniformEnvironment {
    pub const PDF: f32 = 1.0 / (4.0 * PI);
}

impl Light for UniformEnvironment {
    fn preprocess(&mut self, center: Vec3A, radius: f32) {
        self.scene_center = center;
        self.scene_radius = radius;
    }
    fn power(&self, weights: &[f32]) -> f64 {
        // Flux through a disk of the scene's radius from every direction: π r² · 4π ∫L.
        let r = infinite_light_radius(self.scene_radius) as f64;
        std::f64::consts::PI * r * r * 4.0 * std::f64::consts::PI * self.radiance.dot(weights) as f64
    }
    fn sample_li(&self, _p: Vec3A, u: Vec2, le: &mut SampledSpectrum) -> Option<LightSample> {
        le.copy_from(&self.radiance);
        Some(LightSample { wi: uniform_sphere(u), distance: f32::INFINITY, pdf: Self::PDF, delta: false, part: 0 })
    }
    fn pdf_li(&self, _p: Vec3A, _wi: Vec3A, _distance: f32) -> f32 {
        Self::PDF
    }
    /// A uniform direction; `le` is the radiance, so `le/(pdf_pos·pdf_dir)` is the flux
    /// through the start disk: π r² · 4π · L, the power.
    fn sample_le(&self, u_pos: Vec2, u_dir: Vec2, le: &mut SampledSpectrum) -> Option<EmissionSample> {
        let r = infinite_light_radius(self.scene_radius);
        let direction = -uniform_sphere(u_dir);
        le.copy_from(&self.radiance);
        Some(EmissionSample {
            origin: infinite_light_origin(self.scene_center, r, direction, u_pos),
            direction,
            normal: None,
            pdf_pos: 1.0 / (PI * r * r),
            pdf_dir: Self::PDF,
            delta_position: false,
            part: 0,
        })
    }
    fn pdf_le(&self, _origin: Vec3A, _dir: Vec3A) -> Option<LeDensity> {
        let r = infinite_light_radius(self.scene_radius);
        Some(LeDensity { pos: 1.0 / (PI * r * r), dir: Self::PDF, cos: 1.0, directional: true })
    }
}

// ---------------------------------------------------------------------------------
// Image (HDRI) environment.

use crate::color::uplift::Uplift;
use crate::material::texture::{Filter, Texture, Wrap};
use std::sync::Arc;

/// Largest resolution of the importance-sampling distribution (cells along u and v):
/// bigger images are averaged into this many cells so the sampling tables stay a few
/// percent of the image's own size.
const MAX_DIST_U: usize = 1024;
const MAX_DIST_V: usize = 512;

/// A piecewise-constant 2D distribution on [0,1]² (pbrt-v3's Distribution2D): a
/// marginal over rows (v) and one conditional per row (u). f32 tables, cdfs with n+1
/// entries.
#[derive(Clone, Debug)]
pub struct Distribution2D {
    nu: usize,
    nv: usize,
    /// Per row: function values (nu) — kept for the pdf.
    func: Vec<f32>,
    /// Per row: cdf (nu + 1).
    cdf: Vec<f32>,
    /// Integral of each row over u ∈ [0,1].
    row_integral: Vec<f32>,
    marginal_cdf: Vec<f32>,
    integral: f32,
}

fn build_cdf(f: &[f32], cdf: &mut [f32]) -> f32 {
    let n = f.len();
    let mut acc = 0.0f64;
    cdf[0] = 0.0;
    for i in 0..n {
        acc += f[i] as f64 / n as f64;
        cdf[i + 1] = acc as f32;
    }
    let total = acc as f32;
    if total > 0.0 {
        for c in cdf.iter_mut() {
            *c /= total;
        }
    } else {
        for (i, c) in cdf.iter_mut().enumerate() {
            *c = i as f32 / n as f32;
        }
    }
    cdf[n] = 1.0;
    total
}

/// Continuous sample of a piecewise-constant 1D distribution: (x in [0,1), cell).
fn sample_cdf(cdf: &[f32], u: f32) -> (f32, usize) {
    let n = cdf.len() - 1;
    let i = cdf.partition_point(|&c| c <= u).saturating_sub(1).min(n - 1);
    let width = cdf[i + 1] - cdf[i];
    let du = if width > 0.0 { ((u - cdf[i]) / width).clamp(0.0, 1.0) } else { 0.5 };
    (((i as f32 + du) / n as f32).min(1.0 - f32::EPSILON), i)
}

impl Distribution2D {
    /// `f` holds nv rows of nu non-negative values.
    pub fn new(f: Vec<f32>, nu: usize, nv: usize) -> Self {
        let mut cdf = vec![0.0; nv * (nu + 1)];
        let mut row_integral = vec![0.0; nv];
        for v in 0..nv {
            row_integral[v] = build_cdf(&f[v * nu..(v + 1) * nu], &mut cdf[v * (nu + 1)..(v + 1) * (nu + 1)]);
        }
        let mut marginal_cdf = vec![0.0; nv + 1];
        let integral = build_cdf(&row_integral, &mut marginal_cdf);
        Self { nu, nv, func: f, cdf, row_integral, marginal_cdf, integral }
    }

    /// A point in [0,1)² and its pdf with respect to area in [0,1]².
    pub fn sample(&self, u: Vec2) -> (Vec2, f32) {
        let (y, v) = sample_cdf(&self.marginal_cdf, u.y);
        let (x, _) = sample_cdf(&self.cdf[v * (self.nu + 1)..(v + 1) * (self.nu + 1)], u.x);
        let p = Vec2::new(x, y);
        (p, self.pdf(p))
    }

    pub fn pdf(&self, p: Vec2) -> f32 {
        if !(self.integral > 0.0) {
            return 1.0;
        }
        let iu = ((p.x * self.nu as f32) as usize).min(self.nu - 1);
        let iv = ((p.y * self.nv as f32) as usize).min(self.nv - 1);
        self.func[iv * self.nu + iu] / self.integral
    }

    pub fn bytes(&self) -> usize {
        4 * (self.func.len() + self.cdf.len() + self.row_integral.len() + self.marginal_cdf.len())
    }
}

/// An equirectangular (latitude–longitude) RGB environment, mapped as Blender's
/// Environment Texture node maps it in a Z-up world, converted to radiance at lookup
/// with `Uplift::illuminant_into` (a texel seen directly renders back to its RGB).
///
/// Mapping: for a world direction `d`, the lookup direction is `Rz(rotation)·d` (the
/// Mapping node's Z rotation, Point type), then `u = 0.5 − atan2(y, x)/2π`,
/// `v = 0.5 + atan2(z, √(x²+y²))/π`; the image's top row is `v = 1` (straight up).
pub struct ImageEnvironment {
    pub texture: Arc<Texture>,
    pub uplift: Arc<Uplift>,
    pub strength: f32,
    /// Radians about +Z.
    pub rotation: f32,
    sin_r: f32,
    cos_r: f32,
    /// A sphere bounding the scene ([`Light::preprocess`]; the unit sphere until then).
    pub scene_center: Vec3A,
    pub scene_radius: f32,
    /// Importance sampling by luminance × sin θ; None samples the sphere uniformly.
    distribution: Option<Distribution2D>,
    /// Solid-angle-weighted mean RGB × strength (the light-selection power's source).
    mean_rgb: [f64; 3],
}

/// A shared light (the scene keeps the image environment both as a light and for
/// lookups on escaped rays).
impl<T: Light + ?Sized> Light for Arc<T> {
    fn power(&self, weights: &[f32]) -> f64 {
        (**self).power(weights)
    }
    fn sample_li(&self, p: Vec3A, u: Vec2, le: &mut SampledSpectrum) -> Option<LightSample> {
        (**self).sample_li(p, u, le)
    }
    fn pdf_li(&self, p: Vec3A, wi: Vec3A, distance: f32) -> f32 {
        (**self).pdf_li(p, wi, distance)
    }
    fn sample_le(&self, u_pos: Vec2, u_dir: Vec2, le: &mut SampledSpectrum) -> Option<super::EmissionSample> {
        (**self).sample_le(u_pos, u_dir, le)
    }
    fn pdf_le(&self, origin: Vec3A, dir: Vec3A) -> Option<super::LeDensity> {
        (**self).pdf_le(origin, dir)
    }
    /// Only while the light is not shared yet (the scene preprocesses a shared light
    /// before it shares it).
    fn preprocess(&mut self, center: Vec3A, radius: f32) {
        if let Some(l) = Arc::get_mut(self) {
            l.preprocess(center, radius);
        }
    }
    fn hittable(&self) -> bool {
        (**self).hittable()
    }
    fn hit(&self, p: Vec3A, wi: Vec3A, le: &mut SampledSpectrum) -> Option<f32> {
        (**self).hit(p, wi, le)
    }
}

const LUMA: [f32; 3] = [0.2126, 0.7152, 0.0722];

impl ImageEnvironment {
    /// Builds the sampling tables. `importance` false samples directions uniformly (for
    /// comparisons and tests).
    pub fn new(texture: Arc<Texture>, uplift: Arc<Uplift>, strength: f32, rotation: f32, importance: bool) -> Self {
        let (w, h) = (texture.width as usize, texture.height as usize);
        // Solid-angle-weighted mean RGB over the sphere (exact sum over texels: each
        // texel row spans a band of elevation).
        let mut mean_rgb = [0.0f64; 3];
        for y in 0..h {
            // Row 0 is the top (v = 1): elevation from +π/2 down to −π/2.
            let e_hi = std::f64::consts::PI * (0.5 - y as f64 / h as f64);
            let e_lo = std::f64::consts::PI * (0.5 - (y + 1) as f64 / h as f64);
            let band = (e_hi.sin() - e_lo.sin()) / 2.0 / w as f64; // fraction of 4π per texel
            for x in 0..w {
                let c = texture.texel(x, y);
                for k in 0..3 {
                    mean_rgb[k] += c[k].max(0.0) as f64 * band;
                }
            }
        }
        let strength = if strength.is_finite() && strength > 0.0 { strength } else { 0.0 };
        for m in &mut mean_rgb {
            *m *= strength as f64;
        }
        let distribution = importance.then(|| {
            let (nu, nv) = (w.min(MAX_DIST_U), h.min(MAX_DIST_V));
            let mut f = vec![0.0f64; nu * nv];
            let mut count = vec![0u32; nu * nv];
            for y in 0..h {
                let iv = (nv - 1) - (y * nv / h); // distribution row 0 is v = 0 (bottom)
                for x in 0..w {
                    let iu = x * nu / w;
                    let c = texture.texel(x, y);
                    let l = LUMA[0] * c[0].max(0.0) + LUMA[1] * c[1].max(0.0) + LUMA[2] * c[2].max(0.0);
                    f[iv * nu + iu] += l as f64;
                    count[iv * nu + iu] += 1;
                }
            }
            let mean = f.iter().sum::<f64>() / (w * h) as f64;
            // A small floor keeps every direction reachable by light sampling (bilinear
            // filtering spreads a texel into its neighbours' cells).
            let floor = 1e-3 * mean;
            // Bilinear filtering spreads every texel into its neighbours' cells: at full
            // resolution each cell takes the largest luminance of its 3×3 neighbourhood
            // (u wraps, v clamps) so the pdf never falls far below the filtered radiance
            // (pbrt-v4's choice); downsampled tables keep the block mean.
            let cell = |iu: usize, iv: usize| -> f64 {
                let k = iv * nu + iu;
                if count[k] > 0 {
                    f[k] / count[k] as f64
                } else {
                    0.0
                }
            };
            let full = nu == w && nv == h;
            let mut func = vec![0.0f32; nu * nv];
            for iv in 0..nv {
                let theta = std::f64::consts::PI * (1.0 - (iv as f64 + 0.5) / nv as f64);
                let sin_theta = theta.sin();
                for iu in 0..nu {
                    let mut v = cell(iu, iv);
                    if full {
                        for dv in [-1i64, 0, 1] {
                            let jv = (iv as i64 + dv).clamp(0, nv as i64 - 1) as usize;
                            for du in [nu - 1, 0, 1] {
                                v = v.max(cell((iu + du) % nu, jv));
                            }
                        }
                    }
                    func[iv * nu + iu] = ((v + floor) * sin_theta) as f32;
                }
            }
            Distribution2D::new(func, nu, nv)
        });
        let (sin_r, cos_r) = rotation.sin_cos();
        Self {
            texture,
            uplift,
            strength,
            rotation,
            sin_r,
            cos_r,
            scene_center: Vec3A::ZERO,
            scene_radius: 1.0,
            distribution,
            mean_rgb,
        }
    }

    /// Bytes held by the texels and the sampling tables.
    pub fn bytes(&self) -> usize {
        self.texture.bytes() + self.distribution.as_ref().map_or(0, |d| d.bytes())
    }

    /// World direction → (u, v) in the image.
    #[inline]
    pub fn direction_to_uv(&self, d: Vec3A) -> Vec2 {
        // Lookup direction = Rz(rotation) · d.
        let x = self.cos_r * d.x - self.sin_r * d.y;
        let y = self.sin_r * d.x + self.cos_r * d.y;
        let u = 0.5 - y.atan2(x) * (0.5 / PI);
        let v = 0.5 + d.z.atan2((x * x + y * y).sqrt()) / PI;
        Vec2::new(u, v)
    }

    /// (u, v) → world direction and the sine of its polar angle.
    #[inline]
    fn uv_to_direction(&self, uv: Vec2) -> (Vec3A, f32) {
        let phi = (0.5 - uv.x) * 2.0 * PI;
        let elevation = (uv.y - 0.5) * PI;
        let (sz, cz) = elevation.sin_cos();
        let (sp, cp) = phi.sin_cos();
        let (x, y) = (cz * cp, cz * sp);
        // Undo the rotation: d = Rz(−rotation) · lookup.
        let d = Vec3A::new(self.cos_r * x + self.sin_r * y, -self.sin_r * x + self.cos_r * y, sz);
        (d, cz)
    }

    /// Radiance arriving along −`d` (from direction `d`) into `out`.
    #[inline]
    pub fn radiance_into(&self, d: Vec3A, out: &mut SampledSpectrum) {
        let uv = self.direction_to_uv(d);
        let rgb = self.texture.lookup_with(uv, Wrap::Repeat, Wrap::Extend, Filter::Bilinear);
        self.uplift.illuminant_into(rgb, out.values_mut());
        if self.strength != 1.0 {
            out.scale(self.strength);
        }
    }

    /// Solid-angle pdf of sampling direction `d`.
    pub fn pdf_direction(&self, d: Vec3A) -> f32 {
        match &self.distribution {
            None => UniformEnvironment::PDF,
            Some(dist) => {
                let uv = self.direction_to_uv(d);
                // (1 − z)(1 + z): no cancellation near the poles, where 1 − z² loses digits.
                let sin_theta = ((1.0 - d.z) * (1.0 + d.z)).max(0.0).sqrt();
                if sin_theta <= 0.0 {
                    return 0.0;
                }
                let uv = Vec2::new(uv.x.rem_euclid(1.0), uv.y.clamp(0.0, 1.0));
                dist.pdf(uv) / (2.0 * PI * PI * sin_theta)
            }
        }
    }
}

impl Light for ImageEnvironment {
    fn power(&self, weights: &[f32]) -> f64 {
        // π r² · 4π · ∫ L̄ dλ, with L̄ the spectrum of the solid-angle mean RGB (exact for
        // the linear uplift, which is linear in RGB).
        let mut s = vec![0.0f32; self.uplift.len()];
        self.uplift.illuminant_into(self.mean_rgb.map(|v| v as f32), &mut s);
        let integral: f64 = s.iter().zip(weights).map(|(&a, &b)| a as f64 * b as f64).sum();
        let r = infinite_light_radius(self.scene_radius) as f64;
        std::f64::consts::PI * r * r * 4.0 * std::f64::consts::PI * integral
    }
    fn preprocess(&mut self, center: Vec3A, radius: f32) {
        self.scene_center = center;
        self.scene_radius = radius;
    }
    fn sample_li(&self, _p: Vec3A, u: Vec2, le: &mut SampledSpectrum) -> Option<LightSample> {
        let (wi, pdf) = match &self.distribution {
            None => (uniform_sphere(u), UniformEnvironment::PDF),
            Some(dist) => {
                let (uv, pdf_uv) = dist.sample(u);
                let (d, sin_theta) = self.uv_to_direction(uv);
                if !(pdf_uv > 0.0) || !(sin_theta > 0.0) {
                    return None;
                }
                (d, pdf_uv / (2.0 * PI * PI * sin_theta))
            }
        };
        if !(pdf > 0.0 && pdf.is_finite()) {
            return None;
        }
        self.radiance_into(wi, le);
        Some(LightSample { wi, distance: f32::INFINITY, pdf, delta: false, part: 0 })
    }
    fn pdf_li(&self, _p: Vec3A, wi: Vec3A, _distance: f32) -> f32 {
        self.pdf_direction(wi)
    }
    /// The direction the light arrives from is drawn as `sample_li` draws it (the
    /// importance map), the ray travels the other way; `le` is the radiance from there.
    fn sample_le(&self, u_pos: Vec2, u_dir: Vec2, le: &mut SampledSpectrum) -> Option<EmissionSample> {
        let ls = self.sample_li(Vec3A::ZERO, u_dir, le)?;
        let r = infinite_light_radius(self.scene_radius);
        let direction = -ls.wi;
        Some(EmissionSample {
            origin: infinite_light_origin(self.scene_center, r, direction, u_pos),
            direction,
            normal: None,
            pdf_pos: 1.0 / (PI * r * r),
            pdf_dir: ls.pdf,
            delta_position: false,
            part: 0,
        })
    }
    fn pdf_le(&self, _origin: Vec3A, dir: Vec3A) -> Option<LeDensity> {
        let r = infinite_light_radius(self.scene_radius);
        let pdf = self.pdf_direction(-dir);
        (pdf > 0.0).then_some(LeDensity { pos: 1.0 / (PI * r * r), dir: pdf, cos: 1.0, directional: true })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distribution_2d_pdf_integrates_to_one_and_matches_samples() {
        let f = vec![1.0, 0.0, 3.0, 2.0, 2.0, 0.5];
        let d = Distribution2D::new(f, 3, 2);
        // ∫ pdf over [0,1]² = mean of pdf over the 6 cells.
        let mut sum = 0.0;
        for iv in 0..2 {
            for iu in 0..3 {
                sum += d.pdf(Vec2::new((iu as f32 + 0.5) / 3.0, (iv as f32 + 0.5) / 2.0)) / 6.0;
            }
        }
        assert!((sum - 1.0).abs() < 1e-5, "{sum}");
        // Sample frequencies per cell follow f.
        let mut hist = [0u32; 6];
        let n = 60_000;
        let mut rng = crate::sampling::Rng::new(5, 1);
        for _ in 0..n {
            let (p, pdf) = d.sample(rng.uniform2());
            assert!(pdf > 0.0);
            hist[((p.y * 2.0) as usize) * 3 + (p.x * 3.0) as usize] += 1;
        }
        let total: f32 = 8.5;
        for (k, &w) in [1.0f32, 0.0, 3.0, 2.0, 2.0, 0.5].iter().enumerate() {
            let expect = w / total;
            let got = hist[k] as f32 / n as f32;
            assert!((got - expect).abs() < 0.01, "cell {k}: {got} vs {expect}");
        }
    }

    /// The light crossing a small disk (radius `a`, normal `n`, centred in the bounding
    /// sphere) from its front, estimated from `sample_le` rays: Σ le/(pdf_pos·pdf_dir)
    /// over the rays that cross it, per ray and per unit area — the irradiance there.
    fn irradiance_from_light_paths(light: &dyn Light, center: Vec3A, n: Vec3A, a: f32, count: u32) -> f64 {
        let mut rng = crate::sampling::Rng::new(11, 3);
        let mut le = SampledSpectrum::zeros(1);
        let mut sum = 0.0f64;
        for _ in 0..count {
            let es = light.sample_le(rng.uniform2(), rng.uniform2(), &mut le).unwrap();
            let cos = -es.direction.dot(n);
            if cos <= 0.0 {
                continue;
            }
            let t = (center - es.origin).dot(n) / -cos;
            let hit = es.origin + es.direction * t;
            if t > 0.0 && (hit - center).length_squared() <= a * a {
                sum += (le.get(0) / (es.pdf_pos * es.pdf_dir)) as f64;
            }
        }
        sum / count as f64 / (std::f64::consts::PI * (a * a) as f64)
    }

    fn uniform(l: f32, center: Vec3A, radius: f32) -> UniformEnvironment {
        let mut env =
            UniformEnvironment { radiance: SampledSpectrum::splat(1, l), scene_center: Vec3A::ZERO, scene_radius: 1.0 };
        env.preprocess(center, radius);
        env
    }

    /// A uniform environment of radiance L: the light paths' irradiance at any plane
    /// through the scene's centre is the closed form π L (their origins cover the
    /// bounding sphere from every direction, with the densities they report), their
    /// flux per path is the light's power π r² · 4π L, and `pdf_le` returns the
    /// densities of every sampled ray.
    #[test]
    fn uniform_environment_light_paths_deliver_pi_l() {
        let (l, center, r) = (1.5f32, Vec3A::new(3.0, -1.0, 2.0), 2.0f32);
        let env = uniform(l, center, r);
        for n in [Vec3A::Z, Vec3A::new(0.6, 0.0, -0.8)] {
            let e = irradiance_from_light_paths(&env, center, n, 0.6, 200_000);
            let closed = std::f64::consts::PI * l as f64;
            assert!((e / closed - 1.0).abs() < 0.03, "n {n}: {e} vs {closed}");
        }
        let power = env.power(&[1.0]);
        let closed = std::f64::consts::PI * (r * r) as f64 * 4.0 * std::f64::consts::PI * l as f64;
        assert!((power / closed - 1.0).abs() < 1e-6);
        let mut rng = crate::sampling::Rng::new(2, 9);
        let mut le = SampledSpectrum::zeros(1);
        for _ in 0..1000 {
            let es = env.sample_le(rng.uniform2(), rng.uniform2(), &mut le).unwrap();
            assert!(((le.get(0) / (es.pdf_pos * es.pdf_dir)) as f64 / power - 1.0).abs() < 1e-5);
            // On the tangent plane on the light's side, within the disk of radius r.
            let o = es.origin - center;
            assert!(
                (o.dot(es.direction) + r).abs() < 1e-4
                    && (o - es.direction * o.dot(es.direction)).length() <= r * 1.0001
            );
            let d = env.pdf_le(es.origin, es.direction).unwrap();
            assert!(d.directional && d.pos == es.pdf_pos && d.dir == es.pdf_dir);
        }
    }

    fn image(pixels: &[f32], w: u32, h: u32, importance: bool) -> ImageEnvironment {
        let grid = crate::spectrum::WavelengthGrid::uniform(8, 380.0, 780.0).unwrap();
        let up = Arc::new(
            Uplift::new(&grid, &crate::color::RgbSpace::rec709(), crate::color::uplift::UpliftMethod::Linear).unwrap(),
        );
        let tex = Arc::new(Texture::from_linear("env", w, h, 3, pixels, Wrap::Repeat).unwrap());
        let mut env = ImageEnvironment::new(tex, up, 1.0, 0.4, importance);
        env.preprocess(Vec3A::new(0.5, 0.0, -1.0), 1.5);
        env
    }

    /// An image environment's `pdf_le` integrates to one over the sphere of directions
    /// (Monte Carlo over uniform directions) and is the density `sample_le` reports for
    /// its own rays, whose origins lie on the start disk; a constant image's light
    /// paths deliver the closed form π L to a plane at the centre, L the radiance seen
    /// along any direction.
    #[test]
    fn image_environment_pdf_le_integrates_to_one_and_light_paths_deliver_pi_l() {
        let mut rng = crate::sampling::Rng::new(4, 1);
        let (w, h) = (16u32, 8u32);
        let pixels: Vec<f32> =
            (0..w * h * 3).map(|i| if i % 7 == 0 { 20.0 * rng.uniform() } else { rng.uniform() }).collect();
        for importance in [true, false] {
            let env = image(&pixels, w, h, importance);
            let count = 400_000;
            let mut integral = 0.0f64;
            for k in 0..count {
                // Stratified in one dimension: a lower-variance uniform-sphere sum.
                let u = Vec2::new((k as f32 + rng.uniform()) / count as f32, rng.uniform());
                let d = crate::sampling::uniform_sphere(u);
                integral += env.pdf_le(Vec3A::ZERO, d).map_or(0.0, |p| p.dir as f64) * 4.0 * std::f64::consts::PI;
            }
            integral /= count as f64;
            assert!((integral - 1.0).abs() < 0.01, "importance {importance}: ∫ pdf_le dω = {integral}");
            let mut le = SampledSpectrum::zeros(8);
            for _ in 0..2000 {
                let es = env.sample_le(rng.uniform2(), rng.uniform2(), &mut le).unwrap();
                let d = env.pdf_le(es.origin, es.direction).unwrap();
                // pdf ∝ 1/sin θ: a direction's z in f32 (ε ≈ 6e-8) moves sin²θ by ~ε near
                // the poles, so the density recomputed from it agrees to 1e-3 + ε/sin²θ.
                let sin2 = (1.0 - es.direction.z) * (1.0 + es.direction.z);
                let tol = 1e-3 + 2e-7 / sin2.max(1e-12);
                assert!((d.dir - es.pdf_dir).abs() <= tol * es.pdf_dir, "{} vs {} (sin²θ {sin2})", d.dir, es.pdf_dir);
                assert!((d.pos - 1.0 / (PI * 1.5 * 1.5)).abs() < 1e-6 && d.pos == es.pdf_pos);
                let o = es.origin - env.scene_center;
                assert!((o.dot(es.direction) + 1.5).abs() < 1e-4);
                // The radiance along the ray is the environment's from where it comes.
                let mut seen = SampledSpectrum::zeros(8);
                env.radiance_into(-es.direction, &mut seen);
                assert!((0..8).all(|i| (seen.get(i) - le.get(i)).abs() <= 1e-5 * seen.get(i).abs().max(1.0)));
            }
        }
        let flat = vec![0.7f32; (w * h * 3) as usize];
        let env = image(&flat, w, h, true);
        let mut l = SampledSpectrum::zeros(8);
        env.radiance_into(Vec3A::X, &mut l);
        let lum = (0..8).map(|i| l.get(i) as f64).sum::<f64>();
        // The irradiance summed over the grid, through a one-lane view of the light.
        struct Lane<'a>(&'a ImageEnvironment);
        impl Light for Lane<'_> {
            fn power(&self, _w: &[f32]) -> f64 {
                0.0
            }
            fn sample_li(&self, _p: Vec3A, _u: Vec2, _le: &mut SampledSpectrum) -> Option<LightSample> {
                None
            }
            fn sample_le(&self, u_pos: Vec2, u_dir: Vec2, le: &mut SampledSpectrum) -> Option<EmissionSample> {
                let mut all = SampledSpectrum::zeros(8);
                let es = self.0.sample_le(u_pos, u_dir, &mut all)?;
                le.set(0, (0..8).map(|i| all.get(i)).sum::<f32>());
                Some(es)
            }
        }
        let e = irradiance_from_light_paths(&Lane(&env), env.scene_center, Vec3A::new(0.0, 0.6, 0.8), 0.8, 1_000_000);
        let closed = std::f64::consts::PI * lum;
        assert!((e / closed - 1.0).abs() < 0.03, "{e} vs {closed}");
    }
}
