//! The film: per-pixel sums of spectral radiance folded through the CIE observer into
//! XYZ (f64), optional full spectra, and the auxiliary passes. A sample that is not
//! finite is dropped and counted, never averaged in.

use crate::color::{Observer, RgbSpace};
use crate::spectrum::SampledSpectrum;
use glam::Vec3A;

/// What one camera sample contributes to its pixel.
pub struct PixelSample {
    pub radiance: SampledSpectrum,
    /// Auxiliary values: depth at the first hit, normal and albedo at the first surface
    /// that is not a perfect mirror or glass (zero where the ray escaped).
    pub depth: f32,
    pub normal: Vec3A,
    pub albedo: SampledSpectrum,
    /// How much of the sample the film's alpha loses (Cycles' holdout transparency:
    /// the throughput-weighted holdout weight, and with a transparent film the
    /// background seen directly): the pixel's alpha is 1 − its mean.
    pub transparent: f32,
}

impl PixelSample {
    pub fn new(n: usize) -> Self {
        Self {
            radiance: SampledSpectrum::zeros(n),
            depth: 0.0,
            normal: Vec3A::ZERO,
            albedo: SampledSpectrum::zeros(n),
            transparent: 0.0,
        }
    }
    pub fn reset(&mut self) {
        self.radiance.fill(0.0);
        self.albedo.fill(0.0);
        self.depth = 0.0;
        self.normal = Vec3A::ZERO;
        self.transparent = 0.0;
    }
}

/// f64 lanes of the folds in [`PixelSums`]: independent partial sums the compiler keeps in
/// SIMD registers (a sequential f64 sum cannot be vectorised). Sums and rows are padded
/// like [`SampledSpectrum`]'s storage (a multiple of this), so every loop runs over whole
/// chunks.
const FOLD_LANES: usize = 4;

/// One pixel's sums over consecutive camera samples (the passes a tile renders for it),
/// folded into a [`FilmBuffer`] once by [`PixelSums::fold_into`]: the film's box filter
/// gives every sample of a pixel weight 1, so folding the summed spectrum through the
/// observer is the same linear map as folding each sample (up to f64 rounding), at one
/// fold per pixel instead of per sample. The non-finite guard stays per sample.
#[derive(Clone, Debug)]
pub struct PixelSums {
    n: usize,
    /// Radiance and albedo sums, f64, padded with zeros to whole [`FOLD_LANES`] chunks.
    radiance: Vec<f64>,
    albedo: Vec<f64>,
    /// x̄, ȳ, z̄ (the observer's rows) and x̄·white, ȳ·white, z̄·white, f64, padded alike.
    rows: [Vec<f64>; 6],
    depth: f64,
    normal: [f64; 3],
    transparent: f64,
    count: u32,
    nonfinite: u64,
}

#[inline]
fn dot_lanes(a: &[f64], b: &[f64]) -> f64 {
    let mut acc = [0.0f64; FOLD_LANES];
    for (x, y) in a.chunks_exact(FOLD_LANES).zip(b.chunks_exact(FOLD_LANES)) {
        for k in 0..FOLD_LANES {
            acc[k] += x[k] * y[k];
        }
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3])
}

impl PixelSums {
    /// Sums for spectra on `observer`'s grid; `albedo_white` as in [`FilmBuffer::add`].
    pub fn new(observer: &Observer, albedo_white: &SampledSpectrum) -> Self {
        let n = observer.x.len();
        let m = SampledSpectrum::zeros(n).padded_values().len();
        debug_assert_eq!(m % FOLD_LANES, 0);
        let row = |r: &[f32], w: Option<&[f32]>| -> Vec<f64> {
            let mut v = vec![0.0; m];
            for i in 0..n {
                v[i] = r[i] as f64 * w.map_or(1.0, |w| w[i] as f64);
            }
            v
        };
        let w = Some(albedo_white.values());
        let rows = [
            row(&observer.x, None),
            row(&observer.y, None),
            row(&observer.z, None),
            row(&observer.x, w),
            row(&observer.y, w),
            row(&observer.z, w),
        ];
        Self {
            n,
            radiance: vec![0.0; m],
            albedo: vec![0.0; m],
            rows,
            depth: 0.0,
            normal: [0.0; 3],
            transparent: 0.0,
            count: 0,
            nonfinite: 0,
        }
    }

    /// Adds one sample. A sample with a non-finite radiance, depth, normal or albedo is
    /// dropped and counted (docs/design.md#extremes: no NaN in any pass), as in
    /// [`FilmBuffer::add`].
    #[inline]
    pub fn add(&mut self, s: &PixelSample) {
        // Finite f32 spectra have finite f64 sums and XYZ: the per-sample XYZ check of
        // `FilmBuffer::add` reduces to these.
        if !(s.radiance.is_finite()
            && s.depth.is_finite()
            && s.normal.is_finite()
            && s.albedo.is_finite()
            && s.transparent.is_finite())
        {
            self.nonfinite += 1;
            return;
        }
        // Element by element over the padded storage (the padding is zero on both
        // sides): vectorised as whole f32 → f64 conversions and adds.
        for (d, &v) in self.radiance.iter_mut().zip(s.radiance.padded_values()) {
            *d += v as f64;
        }
        for (d, &v) in self.albedo.iter_mut().zip(s.albedo.padded_values()) {
            *d += v as f64;
        }
        self.depth += s.depth as f64;
        self.normal[0] += s.normal.x as f64;
        self.normal[1] += s.normal.y as f64;
        self.normal[2] += s.normal.z as f64;
        self.transparent += s.transparent as f64;
        self.count += 1;
    }

    /// Adds the sums to pixel `i` of `buf` (radiance and albedo folded to XYZ, the
    /// spectral pass when `buf` keeps one) and resets them for the next pixel.
    pub fn fold_into(&mut self, buf: &mut FilmBuffer, i: usize) {
        buf.nonfinite += self.nonfinite;
        if self.count > 0 {
            let r = &self.rows;
            for k in 0..3 {
                buf.xyz[i][k] += dot_lanes(&self.radiance, &r[k]);
                buf.albedo_xyz[i][k] += dot_lanes(&self.albedo, &r[3 + k]);
                buf.normal[i][k] += self.normal[k];
            }
            buf.depth[i] += self.depth;
            buf.transparent[i] += self.transparent;
            buf.count[i] += self.count;
            if let Some(sp) = &mut buf.spectral {
                let n = self.n;
                for (d, &v) in sp[i * n..(i + 1) * n].iter_mut().zip(&self.radiance) {
                    *d += v;
                }
            }
        }
        self.radiance.fill(0.0);
        self.albedo.fill(0.0);
        self.depth = 0.0;
        self.normal = [0.0; 3];
        self.transparent = 0.0;
        self.count = 0;
        self.nonfinite = 0;
    }
}

/// Accumulated sums for a set of pixels (a tile or the whole image).
#[derive(Clone, Debug)]
pub struct FilmBuffer {
    pub xyz: Vec<[f64; 3]>,
    pub albedo_xyz: Vec<[f64; 3]>,
    pub depth: Vec<f64>,
    pub normal: Vec<[f64; 3]>,
    /// Sums of the samples' [`PixelSample::transparent`]: alpha = 1 − transparent / count.
    pub transparent: Vec<f64>,
    /// Samples that entered each pixel.
    pub count: Vec<u32>,
    /// Per-pixel spectral radiance sums (pixel-major), when requested.
    pub spectral: Option<Vec<f64>>,
    pub nonfinite: u64,
}

impl FilmBuffer {
    pub fn new(pixels: usize, spectral_len: Option<usize>) -> Self {
        Self {
            xyz: vec![[0.0; 3]; pixels],
            albedo_xyz: vec![[0.0; 3]; pixels],
            depth: vec![0.0; pixels],
            normal: vec![[0.0; 3]; pixels],
            transparent: vec![0.0; pixels],
            count: vec![0; pixels],
            spectral: spectral_len.map(|n| vec![0.0; pixels * n]),
            nonfinite: 0,
        }
    }

    /// Adds one sample to pixel `i`, folded to XYZ on its own. `albedo_white` is the
    /// spectrum that makes a reflectance of 1 map to Y = 1 (D65 normalised), so albedo
    /// reads as a colour. The renderer sums a pixel's samples in [`PixelSums`] and folds
    /// once; this per-sample form is its reference (same sums up to f64 rounding).
    pub fn add(&mut self, i: usize, s: &PixelSample, observer: &Observer, albedo_white: &SampledSpectrum) {
        let xyz = observer.xyz(s.radiance.values());
        if !(xyz.iter().all(|v| v.is_finite()) && s.radiance.is_finite()) {
            self.nonfinite += 1;
            return;
        }
        // Folded without a temporary spectrum: this runs once per camera sample.
        let axyz = observer.xyz_of_product(s.albedo.values(), albedo_white.values());
        // The auxiliary passes are guarded too: a NaN depth, normal or albedo would
        // otherwise reach its pass unseen (docs/design.md#extremes: no NaN in any pass).
        if !(s.depth.is_finite()
            && s.normal.is_finite()
            && s.transparent.is_finite()
            && axyz.iter().all(|v| v.is_finite()))
        {
            self.nonfinite += 1;
            return;
        }
        for k in 0..3 {
            self.xyz[i][k] += xyz[k];
            self.albedo_xyz[i][k] += axyz[k];
        }
        self.depth[i] += s.depth as f64;
        self.normal[i][0] += s.normal.x as f64;
        self.normal[i][1] += s.normal.y as f64;
        self.normal[i][2] += s.normal.z as f64;
        self.transparent[i] += s.transparent as f64;
        self.count[i] += 1;
        if let Some(sp) = &mut self.spectral {
            let n = s.radiance.len();
            for (d, &v) in sp[i * n..(i + 1) * n].iter_mut().zip(s.radiance.values()) {
                *d += v as f64;
            }
        }
    }
    /// Adds a light-path splat (radiance at pixel `i`) to the pixel's sums, without
    /// counting a sample: light paths per pixel are counted per pass.
    pub fn add_light(&mut self, i: usize, radiance: &SampledSpectrum, observer: &Observer) {
        let xyz = observer.xyz(radiance.values());
        if !(xyz.iter().all(|v| v.is_finite()) && radiance.is_finite()) {
            self.nonfinite += 1;
            return;
        }
        for k in 0..3 {
            self.xyz[i][k] += xyz[k];
        }
        if let Some(sp) = &mut self.spectral {
            let n = radiance.len();
            for (d, &v) in sp[i * n..(i + 1) * n].iter_mut().zip(radiance.values()) {
                *d += v as f64;
            }
        }
    }

    /// Pixel `i`'s alpha: 1 − its mean transparency, in 0..1 (1 with no samples).
    pub fn alpha(&self, i: usize) -> f32 {
        if self.count[i] == 0 {
            return 1.0;
        }
        let a = 1.0 - self.transparent[i] / self.count[i] as f64;
        if a.is_finite() {
            a.clamp(0.0, 1.0) as f32
        } else {
            1.0
        }
    }

    /// Adds another buffer of the same pixels (sums of other samples): buffers of
    /// different sample passes merge exactly this way.
    pub fn merge(&mut self, other: &FilmBuffer) {
        assert_eq!(self.count.len(), other.count.len(), "film buffers of different sizes");
        for i in 0..self.count.len() {
            for k in 0..3 {
                self.xyz[i][k] += other.xyz[i][k];
                self.albedo_xyz[i][k] += other.albedo_xyz[i][k];
                self.normal[i][k] += other.normal[i][k];
            }
            self.depth[i] += other.depth[i];
            self.transparent[i] += other.transparent[i];
            self.count[i] += other.count[i];
        }
        if let (Some(dst), Some(src)) = (&mut self.spectral, &other.spectral) {
            for (d, s) in dst.iter_mut().zip(src) {
                *d += s;
            }
        }
        self.nonfinite += other.nonfinite;
    }
}

/// The image being rendered.
pub struct Film {
    pub width: u32,
    pub height: u32,
    pub buffer: FilmBuffer,
    pub spectral_len: Option<usize>,
}

/// Final pixel arrays, row 0 at the top.
pub struct FilmImages {
    pub rgba: Vec<f32>,
    pub depth: Vec<f32>,
    pub normal: Vec<f32>,
    pub albedo: Vec<f32>,
    pub spectral: Option<Vec<f32>>,
}

impl Film {
    pub fn new(width: u32, height: u32, spectral_len: Option<usize>) -> Self {
        Self { width, height, buffer: FilmBuffer::new((width * height) as usize, spectral_len), spectral_len }
    }

    /// Adds a tile's sums (pixels `rect` of the image, row-major inside the tile).
    pub fn merge_tile(&mut self, x0: u32, y0: u32, w: u32, h: u32, tile: &FilmBuffer) {
        for ty in 0..h {
            for tx in 0..w {
                let t = (ty * w + tx) as usize;
                let i = ((y0 + ty) * self.width + x0 + tx) as usize;
                let b = &mut self.buffer;
                for k in 0..3 {
                    b.xyz[i][k] += tile.xyz[t][k];
                    b.albedo_xyz[i][k] += tile.albedo_xyz[t][k];
                    b.normal[i][k] += tile.normal[t][k];
                }
                b.depth[i] += tile.depth[t];
                b.transparent[i] += tile.transparent[t];
                b.count[i] += tile.count[t];
                if let (Some(dst), Some(src), Some(n)) = (&mut b.spectral, &tile.spectral, self.spectral_len) {
                    for k in 0..n {
                        dst[i * n + k] += src[t * n + k];
                    }
                }
            }
        }
        self.buffer.nonfinite += tile.nonfinite;
    }

    /// Only the RGBA image of [`Film::images`] (the same conversion), for previews.
    pub fn rgba(&self, space: &RgbSpace) -> Vec<f32> {
        let b = &self.buffer;
        let mut rgba = vec![1.0f32; b.count.len() * 4];
        for (i, px) in rgba.chunks_exact_mut(4).enumerate() {
            let inv = if b.count[i] > 0 { 1.0 / b.count[i] as f64 } else { 0.0 };
            let rgb = space.xyz_to_rgb(b.xyz[i].map(|v| v * inv));
            for k in 0..3 {
                px[k] = rgb[k] as f32;
            }
            px[3] = b.alpha(i);
        }
        rgba
    }

    /// Averages and converts to the working space: RGBA (alpha 1 − the mean holdout
    /// transparency, [`PixelSample::transparent`]), depth, normal, albedo.
    pub fn images(&self, space: &RgbSpace) -> FilmImages {
        let px = (self.width * self.height) as usize;
        let b = &self.buffer;
        let mut rgba = vec![0.0f32; px * 4];
        let mut depth = vec![0.0f32; px];
        let mut normal = vec![0.0f32; px * 3];
        let mut albedo = vec![0.0f32; px * 3];
        for i in 0..px {
            let inv = if b.count[i] > 0 { 1.0 / b.count[i] as f64 } else { 0.0 };
            let rgb = space.xyz_to_rgb(b.xyz[i].map(|v| v * inv));
            let alb = space.xyz_to_rgb(b.albedo_xyz[i].map(|v| v * inv));
            for k in 0..3 {
                rgba[i * 4 + k] = rgb[k] as f32;
                albedo[i * 3 + k] = alb[k] as f32;
            }
            rgba[i * 4 + 3] = b.alpha(i);
            depth[i] = (b.depth[i] * inv) as f32;
            let n = Vec3A::new(b.normal[i][0] as f32, b.normal[i][1] as f32, b.normal[i][2] as f32).normalize_or_zero();
            normal[i * 3..i * 3 + 3].copy_from_slice(&[n.x, n.y, n.z]);
        }
        let spectral = match (&b.spectral, self.spectral_len) {
            (Some(s), Some(n)) => Some(
                (0..px * n)
                    .map(|j| {
                        let c = b.count[j / n];
                        if c > 0 {
                            (s[j] / c as f64) as f32
                        } else {
                            0.0
                        }
                    })
                    .collect(),
            ),
            _ => None,
        };
        FilmImages { rgba, depth, normal, albedo, spectral }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;
    use crate::spectrum::WavelengthGrid;

    /// Summing a pixel's samples and folding once gives the per-sample fold's sums (up to
    /// f64 rounding), the same counts and dropped samples, and the same spectral pass.
    #[test]
    fn folding_once_per_pixel_equals_folding_every_sample() {
        let grid = WavelengthGrid::uniform(41, 380.0, 780.0).unwrap();
        let observer = Observer::new(&grid);
        let n = grid.len();
        let white = SampledSpectrum::from_slice(&(0..n).map(|i| 0.5 + i as f32 / n as f32).collect::<Vec<_>>());
        let mut rng = Rng::for_sample(7, 0, 0);
        let (mut per_sample, mut per_pixel) = (FilmBuffer::new(4, Some(n)), FilmBuffer::new(4, Some(n)));
        let mut sums = PixelSums::new(&observer, &white);
        let mut ps = PixelSample::new(n);
        for px in 0..4 {
            for k in 0..16 {
                ps.reset();
                for i in 0..n {
                    ps.radiance.set(i, 10.0 * rng.uniform() / (1.0 - rng.uniform()).max(1e-3));
                    ps.albedo.set(i, rng.uniform());
                }
                ps.depth = 3.0 * rng.uniform();
                ps.transparent = rng.uniform();
                ps.normal = Vec3A::new(rng.uniform(), rng.uniform(), 1.0).normalize();
                // Non-finite samples of every kind, in pixels 1 and 3.
                match (px, k) {
                    (1, 3) => ps.radiance.set(5, f32::NAN),
                    (1, 9) => ps.radiance.set(0, f32::INFINITY),
                    (3, 0) => ps.albedo.set(2, f32::NAN),
                    (3, 4) => ps.depth = f32::NAN,
                    (3, 5) => ps.normal.y = f32::INFINITY,
                    _ => {}
                }
                per_sample.add(px, &ps, &observer, &white);
                sums.add(&ps);
            }
            sums.fold_into(&mut per_pixel, px);
        }
        assert_eq!(per_sample.count, per_pixel.count);
        assert_eq!(per_pixel.count, vec![16, 14, 16, 13]);
        assert_eq!(per_sample.nonfinite, 5);
        assert_eq!(per_pixel.nonfinite, 5);
        let close = |a: f64, b: f64, tol: f64| (a - b).abs() <= tol * a.abs().max(b.abs()).max(1e-30);
        for px in 0..4 {
            for k in 0..3 {
                assert!(close(per_sample.xyz[px][k], per_pixel.xyz[px][k], 1e-12), "xyz {px} {k}");
                // The per-sample albedo fold multiplies in f32 before widening.
                assert!(close(per_sample.albedo_xyz[px][k], per_pixel.albedo_xyz[px][k], 1e-6), "albedo {px} {k}");
                assert!(close(per_sample.normal[px][k], per_pixel.normal[px][k], 1e-12));
            }
            assert!(close(per_sample.depth[px], per_pixel.depth[px], 1e-12));
            assert!(close(per_sample.transparent[px], per_pixel.transparent[px], 1e-12));
        }
        // A pixel's samples are consecutive and the tile buffer starts at zero: the spectral
        // pass is bit-for-bit the same sums.
        assert_eq!(per_sample.spectral, per_pixel.spectral);
    }
}
