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
}

impl PixelSample {
    pub fn new(n: usize) -> Self {
        Self { radiance: SampledSpectrum::zeros(n), depth: 0.0, normal: Vec3A::ZERO, albedo: SampledSpectrum::zeros(n) }
    }
    pub fn reset(&mut self) {
        self.radiance.fill(0.0);
        self.albedo.fill(0.0);
        self.depth = 0.0;
        self.normal = Vec3A::ZERO;
    }
}

/// Accumulated sums for a set of pixels (a tile or the whole image).
#[derive(Clone, Debug)]
pub struct FilmBuffer {
    pub xyz: Vec<[f64; 3]>,
    pub albedo_xyz: Vec<[f64; 3]>,
    pub depth: Vec<f64>,
    pub normal: Vec<[f64; 3]>,
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
            count: vec![0; pixels],
            spectral: spectral_len.map(|n| vec![0.0; pixels * n]),
            nonfinite: 0,
        }
    }

    /// Adds one sample to pixel `i`. `albedo_white` is the spectrum that makes a
    /// reflectance of 1 map to Y = 1 (D65 normalised), so albedo reads as a colour.
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
        if !(s.depth.is_finite() && s.normal.is_finite() && axyz.iter().all(|v| v.is_finite())) {
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
        }
        rgba
    }

    /// Averages and converts to the working space: RGBA (alpha 1), depth, normal, albedo.
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
            rgba[i * 4 + 3] = 1.0;
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
