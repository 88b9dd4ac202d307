//! What a path carries per wavelength, behind one trait so the path walk is written once
//! for every wavelength policy: the whole grid ([`SampledSpectrum`], the paper's
//! polychromatic rays and RGB) or one grid wavelength with a scalar throughput
//! ([`SingleWavelength`]: monochromatic rays and scenes, and every path after it
//! collapsed at a dispersive surface, eq. 9) — and four hero wavelengths
//! ([`super::hero::Hero`]).
//!
//! Materials and lights fill grid-wide spectra either way (the `Bsdf`/`Light` traits are
//! spectral); a single-wavelength path reads the one component it carries and keeps its
//! own arithmetic scalar, so it costs what a scalar path tracer costs.

use super::walk::Vertex;
use super::Scatter;
use crate::material::ShadingContext;
use crate::sampling::Rng;
use crate::spectrum::SampledSpectrum;

/// Grid-wide spectra a worker keeps between paths, so whole-spectrum throughputs need no
/// heap allocation per path ([`Throughput::zero_like_in`], [`Throughput::recycle`]).
#[derive(Debug, Default)]
pub struct Spare(Vec<SampledSpectrum>);

impl Spare {
    /// A spectrum of `len` samples (contents unspecified): a kept one, or a new one.
    pub fn take(&mut self, len: usize) -> SampledSpectrum {
        while let Some(s) = self.0.pop() {
            if s.len() == len {
                return s;
            }
        }
        SampledSpectrum::zeros(len)
    }
    /// Keeps `s` for a later [`Spare::take`].
    pub fn give(&mut self, s: SampledSpectrum) {
        self.0.push(s);
    }
}

/// Per-wavelength path throughput, and radiance gathered on the same wavelengths.
pub trait Throughput: Clone {
    /// Zero on the same wavelengths: the accumulator of what the path gathers.
    fn zero_like(&self) -> Self;
    /// [`Throughput::zero_like`] built in storage from `spare` when it needs any.
    fn zero_like_in(&self, _spare: &mut Spare) -> Self {
        self.zero_like()
    }
    /// Gives the throughput's heap storage (if any) to `spare` for the next path.
    fn recycle(self, _spare: &mut Spare) {}
    /// Whether the path can still carry light after a scattering (finite; for a single
    /// wavelength also positive).
    fn is_alive(&self) -> bool;
    /// Whether `s` (a light's or a BSDF's values) is non-zero on a carried wavelength.
    fn carries(&self, s: &SampledSpectrum) -> bool;
    /// Russian roulette's survival probability: the largest throughput, at most 1.
    fn survival_probability(&self) -> f32;
    /// Divides by the survival probability `q` of a path that survived.
    fn divide_by_survival(&mut self, q: f32);
    fn scale(&mut self, s: f32);
    /// self += β · e · w (emission reached by the path).
    fn add_emitted(&mut self, beta: &Self, e: &SampledSpectrum, w: f32);
    /// self += β · f · le · w / pdf (a light sample); `f` may be overwritten.
    fn add_direct(&mut self, beta: &Self, f: &mut SampledSpectrum, le: &SampledSpectrum, w: f32, pdf: f32);
    /// Adds `v` at grid wavelength `i` (what a single-wavelength continuation gathered).
    fn add_at(&mut self, i: usize, v: f32);
    /// Samples the BSDF at `v` through [`super::scatter`], multiplying the throughput;
    /// `tp` is grid-wide scratch.
    fn scatter(&mut self, v: &Vertex, ctx: &ShadingContext, rng: &mut Rng, tp: &mut SampledSpectrum)
        -> Option<Scatter>;
    /// β · f · s as a grid-wide spectrum (a light-path splat).
    fn times(&self, f: &SampledSpectrum, s: f32) -> SampledSpectrum;
    /// self · s as a grid-wide spectrum of `len` samples.
    fn scaled(&self, len: usize, s: f32) -> SampledSpectrum;
    /// The path carried on at grid wavelength `i` alone, or None if it carries one
    /// wavelength already.
    fn collapse(&self, i: usize) -> Option<SingleWavelength>;
    /// Multiplies a grid-wide spectrum (the albedo pass seen through mirrors and glass)
    /// by this throughput: per wavelength when it carries the whole grid, else by the
    /// mean of what it carries (grey).
    fn weigh_grid(&self, s: &mut SampledSpectrum);
    /// Hero wavelengths: the grid wavelength that carries on alone at a dispersive
    /// surface, where the others end (`hero.rs`). None: the BSDF collapses the path
    /// there (eq. 9), or it carries one wavelength already.
    fn hero(&self) -> Option<usize> {
        None
    }
    /// The wavelengths carried, as lanes (media weigh each lane by its own extinction):
    /// how many, lane `j`'s grid index, its throughput, and setting it.
    fn lanes(&self) -> usize;
    fn lane_index(&self, j: usize) -> usize;
    fn lane(&self, j: usize) -> f32;
    fn set_lane(&mut self, j: usize, v: f32);
}

impl Throughput for SampledSpectrum {
    fn zero_like(&self) -> Self {
        SampledSpectrum::zeros(self.len())
    }
    fn zero_like_in(&self, spare: &mut Spare) -> Self {
        let mut s = spare.take(self.len());
        s.fill(0.0);
        s
    }
    fn recycle(self, spare: &mut Spare) {
        spare.give(self);
    }
    fn is_alive(&self) -> bool {
        self.is_finite()
    }
    fn carries(&self, s: &SampledSpectrum) -> bool {
        !s.is_black()
    }
    fn survival_probability(&self) -> f32 {
        self.max_value().min(1.0)
    }
    fn divide_by_survival(&mut self, q: f32) {
        SampledSpectrum::scale(self, 1.0 / q);
    }
    fn scale(&mut self, s: f32) {
        SampledSpectrum::scale(self, s);
    }
    #[inline]
    fn add_emitted(&mut self, beta: &Self, e: &SampledSpectrum, w: f32) {
        self.add_product(beta, e, w);
    }
    #[inline]
    fn add_direct(&mut self, beta: &Self, f: &mut SampledSpectrum, le: &SampledSpectrum, w: f32, pdf: f32) {
        f.mul_assign(beta);
        self.add_product(f, le, w / pdf);
    }
    fn add_at(&mut self, i: usize, v: f32) {
        self.set(i, self.get(i) + v);
    }
    #[inline]
    fn scatter(
        &mut self,
        v: &Vertex,
        ctx: &ShadingContext,
        rng: &mut Rng,
        _tp: &mut SampledSpectrum,
    ) -> Option<Scatter> {
        super::scatter(v, ctx, rng, self)
    }
    fn times(&self, f: &SampledSpectrum, s: f32) -> SampledSpectrum {
        let mut r = f.clone();
        r.mul_assign(self);
        SampledSpectrum::scale(&mut r, s);
        r
    }
    fn scaled(&self, _len: usize, s: f32) -> SampledSpectrum {
        let mut r = self.clone();
        SampledSpectrum::scale(&mut r, s);
        r
    }
    fn collapse(&self, i: usize) -> Option<SingleWavelength> {
        Some(SingleWavelength { index: i, value: self.get(i) })
    }
    fn weigh_grid(&self, s: &mut SampledSpectrum) {
        s.mul_assign(self);
    }
    fn lanes(&self) -> usize {
        self.len()
    }
    fn lane_index(&self, j: usize) -> usize {
        j
    }
    fn lane(&self, j: usize) -> f32 {
        self.get(j)
    }
    fn set_lane(&mut self, j: usize, v: f32) {
        self.set(j, v);
    }
}

/// One grid wavelength and the path's scalar throughput (or gathered radiance) there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SingleWavelength {
    /// Grid index of the wavelength.
    pub index: usize,
    pub value: f32,
}

impl Throughput for SingleWavelength {
    fn zero_like(&self) -> Self {
        Self { index: self.index, value: 0.0 }
    }
    fn is_alive(&self) -> bool {
        self.value > 0.0 && self.value.is_finite()
    }
    fn carries(&self, s: &SampledSpectrum) -> bool {
        s.get(self.index) > 0.0
    }
    fn survival_probability(&self) -> f32 {
        self.value.min(1.0)
    }
    fn divide_by_survival(&mut self, q: f32) {
        self.value /= q;
    }
    fn scale(&mut self, s: f32) {
        self.value *= s;
    }
    #[inline]
    fn add_emitted(&mut self, beta: &Self, e: &SampledSpectrum, w: f32) {
        self.value += beta.value * e.get(self.index) * w;
    }
    #[inline]
    fn add_direct(&mut self, beta: &Self, f: &mut SampledSpectrum, le: &SampledSpectrum, w: f32, pdf: f32) {
        self.value += beta.value * f.get(self.index) * le.get(self.index) * w / pdf;
    }
    fn add_at(&mut self, _i: usize, v: f32) {
        self.value += v;
    }
    #[inline]
    fn scatter(
        &mut self,
        v: &Vertex,
        ctx: &ShadingContext,
        rng: &mut Rng,
        tp: &mut SampledSpectrum,
    ) -> Option<Scatter> {
        tp.fill(0.0);
        tp.set(self.index, self.value);
        let sc = super::scatter(v, ctx, rng, tp)?;
        self.value = tp.get(self.index);
        Some(sc)
    }
    fn times(&self, f: &SampledSpectrum, s: f32) -> SampledSpectrum {
        let mut r = SampledSpectrum::zeros(f.len());
        r.set(self.index, f.get(self.index) * self.value * s);
        r
    }
    fn scaled(&self, len: usize, s: f32) -> SampledSpectrum {
        let mut r = SampledSpectrum::zeros(len);
        r.set(self.index, self.value * s);
        r
    }
    fn collapse(&self, _i: usize) -> Option<SingleWavelength> {
        None
    }
    fn weigh_grid(&self, s: &mut SampledSpectrum) {
        s.scale(self.value);
    }
    fn lanes(&self) -> usize {
        1
    }
    fn lane_index(&self, _j: usize) -> usize {
        self.index
    }
    fn lane(&self, _j: usize) -> f32 {
        self.value
    }
    fn set_lane(&mut self, _j: usize, v: f32) {
        self.value = v;
    }
}
