//! Wavelength policies: which wavelengths each path carries and how its estimate is
//! weighted. The spectral methods are policies of one tracer:
//!
//! | method | policy | a path carries |
//! | --- | --- | --- |
//! | POLYCHROMATIC, RGB | [`AllWavelengths`] | every sample of the grid (RGB: three channels) |
//! | MONOCHROMATIC_RAYS | [`OnePerRay`] | one grid wavelength, stratified over a pixel's samples |
//! | MONOCHROMATIC_SCENES | [`OnePerPass`] | the wavelength of the current round, one round per grid sample |
//!
//! A policy of k stratified continuous hero wavelengths (Wilkie et al. 2014) is one more
//! [`WavelengthPolicy`] whose [`Wavelengths`] carry a k-lane [`Throughput`].

use super::throughput::{SingleWavelength, Spare, Throughput};
use crate::sampling::{Distribution1D, Rng};
use crate::scene::Scene;
use crate::spectrum::SampledSpectrum;

/// The wavelengths one path carries, with the weight of its estimate (pbrt-v4's
/// `SampledWavelengths`).
pub trait Wavelengths: Copy {
    type Throughput: Throughput;
    /// Throughput 1 on these wavelengths: where camera paths start. A throughput with
    /// heap storage takes it from `spare` when it holds a buffer (see
    /// [`Throughput::recycle`]), so camera paths allocate nothing.
    fn unit(&self, grid_len: usize, spare: &mut Spare) -> Self::Throughput;
    /// Emitted radiance `le` on these wavelengths divided by their selection probability:
    /// where light paths start.
    fn emitted(&self, le: SampledSpectrum) -> Self::Throughput;
    /// The one grid wavelength BSDFs evaluate (`ShadingContext::single_wavelength`), if
    /// the path carries one.
    fn single(&self) -> Option<usize>;
    /// Writes what a camera path gathered, divided by the selection probability, into a
    /// pixel sample's (zeroed) grid-wide radiance.
    fn resolve(&self, gathered: &Self::Throughput, out: &mut SampledSpectrum);
}

/// Chooses the wavelengths of every camera sample and light path of a render.
pub trait WavelengthPolicy: Clone + Send + Sync + 'static {
    type Wavelengths: Wavelengths;
    /// How many times the pixel's sample count is taken (see
    /// [`super::Integrator::rounds`]).
    fn rounds(&self) -> u32;
    /// The wavelengths of pixel `pixel`'s camera sample in sample pass `pass`.
    fn camera(&self, pixel: u64, pass: u32) -> Self::Wavelengths;
    /// The wavelengths of a light path of sample pass `pass` (may draw from its stream).
    fn light(&self, pass: u32, rng: &mut Rng) -> Self::Wavelengths;
}

/// Every wavelength of the grid.
#[derive(Clone, Copy, Debug)]
pub struct AllOfGrid;

impl Wavelengths for AllOfGrid {
    type Throughput = SampledSpectrum;
    fn unit(&self, grid_len: usize, spare: &mut Spare) -> SampledSpectrum {
        let mut s = spare.take(grid_len);
        s.fill(1.0);
        s
    }
    fn emitted(&self, le: SampledSpectrum) -> SampledSpectrum {
        le
    }
    fn single(&self) -> Option<usize> {
        None
    }
    fn resolve(&self, gathered: &SampledSpectrum, out: &mut SampledSpectrum) {
        out.copy_from(gathered);
    }
}

/// One grid wavelength, its estimate weighted by `scale / pdf`.
#[derive(Clone, Copy, Debug)]
pub struct OneOfGrid {
    pub index: usize,
    /// MONOCHROMATIC_RAYS: 1; MONOCHROMATIC_SCENES: the grid size (each of n rounds'
    /// images holds n·L at its wavelength, so averaging over all rounds sums them).
    pub scale: f32,
    /// Probability of choosing this wavelength (MONOCHROMATIC_SCENES: 1, every round
    /// takes its own).
    pub pdf: f32,
}

impl Wavelengths for OneOfGrid {
    type Throughput = SingleWavelength;
    fn unit(&self, _grid_len: usize, _spare: &mut Spare) -> SingleWavelength {
        SingleWavelength { index: self.index, value: 1.0 }
    }
    fn emitted(&self, le: SampledSpectrum) -> SingleWavelength {
        SingleWavelength { index: self.index, value: le.get(self.index) * (self.scale / self.pdf) }
    }
    fn single(&self) -> Option<usize> {
        Some(self.index)
    }
    fn resolve(&self, gathered: &SingleWavelength, out: &mut SampledSpectrum) {
        out.set(self.index, gathered.value * self.scale / self.pdf);
    }
}

/// POLYCHROMATIC and RGB: whole-spectrum paths.
#[derive(Clone, Copy, Debug, Default)]
pub struct AllWavelengths;

impl WavelengthPolicy for AllWavelengths {
    type Wavelengths = AllOfGrid;
    fn rounds(&self) -> u32 {
        1
    }
    fn camera(&self, _pixel: u64, _pass: u32) -> AllOfGrid {
        AllOfGrid
    }
    fn light(&self, _pass: u32, _rng: &mut Rng) -> AllOfGrid {
        AllOfGrid
    }
}

/// MONOCHROMATIC_RAYS: every path carries one wavelength, stratified over a pixel's
/// samples (camera paths) or drawn at random (light paths), from [`wavelength_distribution`].
#[derive(Clone, Debug)]
pub struct OnePerRay {
    dist: Distribution1D,
    seed: u64,
    /// Camera samples per pixel: the strata.
    samples: u32,
}

impl OnePerRay {
    pub fn new(scene: &Scene, seed: u64, samples: u32) -> Self {
        Self { dist: wavelength_distribution(scene), seed, samples }
    }
    fn chosen(&self, index: usize) -> OneOfGrid {
        OneOfGrid { index, scale: 1.0, pdf: self.dist.pmf(index) }
    }
}

impl WavelengthPolicy for OnePerRay {
    type Wavelengths = OneOfGrid;
    fn rounds(&self) -> u32 {
        1
    }
    fn camera(&self, pixel: u64, pass: u32) -> OneOfGrid {
        self.chosen(stratified_wavelength(&self.dist, self.seed, pixel, pass, self.samples))
    }
    fn light(&self, _pass: u32, rng: &mut Rng) -> OneOfGrid {
        self.chosen(self.dist.sample(rng.uniform()).unwrap_or(0))
    }
}

/// MONOCHROMATIC_SCENES: the whole image once per grid wavelength; round r (sample
/// passes `r·samples .. (r+1)·samples`) carries wavelength r.
#[derive(Clone, Copy, Debug)]
pub struct OnePerPass {
    grid_len: usize,
    samples: u32,
}

impl OnePerPass {
    pub fn new(grid_len: usize, samples: u32) -> Self {
        Self { grid_len, samples }
    }
    fn round(&self, pass: u32) -> OneOfGrid {
        OneOfGrid { index: (pass / self.samples) as usize, scale: self.grid_len as f32, pdf: 1.0 }
    }
}

impl WavelengthPolicy for OnePerPass {
    type Wavelengths = OneOfGrid;
    fn rounds(&self) -> u32 {
        self.grid_len as u32
    }
    fn camera(&self, _pixel: u64, pass: u32) -> OneOfGrid {
        self.round(pass)
    }
    fn light(&self, pass: u32, _rng: &mut Rng) -> OneOfGrid {
        self.round(pass)
    }
}

/// How monochromatic rays pick their wavelength: half uniform, half ∝ the observer's
/// x̄+ȳ+z̄ folded with the grid weights, so every wavelength keeps a probability ≥ 1/(2n)
/// (the spectrum stays unbiased at every sample) while visible ones are sampled more.
pub fn wavelength_distribution(scene: &Scene) -> Distribution1D {
    let n = scene.grid.len();
    let o = &scene.observer;
    let cmf: Vec<f64> = (0..n).map(|i| (o.x[i].abs() + o.y[i].abs() + o.z[i].abs()) as f64).collect();
    let total: f64 = cmf.iter().sum();
    let w: Vec<f64> =
        cmf.iter().map(|c| 0.5 / n as f64 + if total > 0.0 { 0.5 * c / total } else { 0.5 / n as f64 }).collect();
    Distribution1D::new(&w)
}

/// The stratified wavelength choice of sample `s` of `count` in a pixel: a rotated
/// lattice (per-pixel random offset, Cranley–Patterson) through the inverse CDF, so a
/// pixel's samples cover the grid and each one is marginally distributed as `dist`.
pub fn stratified_wavelength(dist: &Distribution1D, seed: u64, pixel: u64, s: u32, count: u32) -> usize {
    let mut r = Rng::new(seed ^ 0x6d6f_6e6f_6368_726f, pixel);
    let offset = r.uniform();
    let u = (offset + s as f32 / count.max(1) as f32).fract();
    dist.sample(u.min(0.999_999_9)).unwrap_or(0)
}
