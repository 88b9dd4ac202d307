//! HERO: four hero wavelengths per path (Wilkie et al. 2014, "Hero Wavelength Spectral
//! Sampling"; what pbrt-v4 and Mitsuba 3 do), as one more wavelength policy of the tracer.
//!
//! - **Sampling.** The hero wavelength λ0 = F⁻¹(u) is drawn from pbrt-v4's visible-range
//!   density p(λ) ∝ sech²(0.0072·(λ − 538 nm)), truncated to the grid's range; the
//!   others are λj = F⁻¹(frac(u + j/4)), so the four are stratified in the density's CDF.
//!   A pixel's camera samples take u = offset + φ₂(s)/4 (φ₂ the base-2 radical inverse
//!   of the sample number, the offset random per pixel), so the wavelengths of any first
//!   samples of a pixel are stratified together; light paths draw u from their stream.
//! - **Evaluation on the grid.** Materials, lights and indices of refraction are known on
//!   the render's wavelength grid, so each continuous λj is carried at one of the two grid
//!   samples around it, chosen with the weights of linear interpolation (stochastic
//!   rounding). A lane lands on grid sample i with probability P(i) = ∫ p(λ)·hatᵢ(λ) dλ
//!   (hatᵢ: the tent of linear interpolation at sample i) and its estimate is divided by
//!   4·P(i), which makes HERO unbiased for the grid's own quadrature: it converges to the
//!   image the whole-grid methods converge to, on any grid. On a 1 nm grid (401 samples,
//!   the resolution of the CIE tables) that is the continuous integral of the scene data.
//! - **Spectral MIS.** All lanes have the same marginal P and a path's directions do not
//!   depend on its wavelengths (a BSDF chooses its lobe from the four lanes together), so
//!   the balance heuristic over the lanes gives each the weight 1/4 — the 4 in 4·P(i).
//!   Where the direction does depend on the wavelength, at a dispersive refraction (a
//!   delta direction per wavelength), the other lanes' density of the sampled direction
//!   is zero, so their weight is zero and the hero's one: the secondary wavelengths end
//!   there (pbrt-v4's `TerminateSecondary`) and the hero continues alone with four times
//!   its lane's weight. What the four lanes gathered before that vertex is kept.
//!
//! Materials and lights still fill grid-wide spectra, so a hero path costs what a
//! whole-grid path costs in shading; its own arithmetic is four scalars.

use super::throughput::{SingleWavelength, Throughput};
use super::walk::Vertex;
use super::wavelengths::{WavelengthPolicy, Wavelengths};
use super::Scatter;
use crate::material::ShadingContext;
use crate::sampling::Rng;
use crate::spectrum::{SampledSpectrum, WavelengthGrid};

/// Wavelengths per hero path (pbrt-v4's `NSpectrumSamples`, Mitsuba 3's spectral variants).
pub const HERO_LANES: usize = 4;

/// pbrt-v4's visible-wavelength density (`VisibleWavelengthsPDF`): ∝ sech²(A·(λ − C)).
const VISIBLE_A: f64 = 0.0072;
const VISIBLE_CENTER_NM: f64 = 538.0;

/// Seeds of the camera samples' lattice offsets and roundings, apart from other streams.
const LATTICE_SALT: u64 = 0x6865_726f_6c61_7474;
const ROUNDING_SALT: u64 = 0x6865_726f_726f_756e;

/// The visible-range density truncated to `[lo, hi]` nm, sampled through its CDF
/// (tanh is the integral of sech²).
#[derive(Clone, Copy, Debug)]
pub struct VisibleDensity {
    lo: f64,
    hi: f64,
    t_lo: f64,
    t_hi: f64,
}

impl VisibleDensity {
    pub fn new(lo_nm: f32, hi_nm: f32) -> Self {
        let t = |l: f64| (VISIBLE_A * (l - VISIBLE_CENTER_NM)).tanh();
        let (lo, hi) = (lo_nm as f64, hi_nm as f64);
        Self { lo, hi, t_lo: t(lo), t_hi: t(hi) }
    }
    /// λ = F⁻¹(u) in nm, `u` in [0, 1).
    pub fn sample(&self, u: f32) -> f64 {
        let t = self.t_lo + u as f64 * (self.t_hi - self.t_lo);
        (VISIBLE_CENTER_NM + t.atanh() / VISIBLE_A).clamp(self.lo, self.hi)
    }
    /// p(λ) in 1/nm.
    pub fn pdf(&self, lambda: f64) -> f64 {
        let c = (VISIBLE_A * (lambda - VISIBLE_CENTER_NM)).cosh();
        VISIBLE_A / (c * c * (self.t_hi - self.t_lo))
    }
}

/// P(i) = ∫ p(λ)·hatᵢ(λ) dλ for every sample of `lambdas`: the probability that a
/// wavelength drawn from `density` and rounded to a neighbouring sample with the linear
/// interpolation weights lands on sample i (Simpson's rule, 64 panels per interval).
pub fn rounding_probabilities(density: &VisibleDensity, lambdas: &[f32]) -> Vec<f64> {
    const PANELS: usize = 64;
    let mut p = vec![0.0f64; lambdas.len()];
    for k in 0..lambdas.len() - 1 {
        let (a, b) = (lambdas[k] as f64, lambdas[k + 1] as f64);
        let h = (b - a) / PANELS as f64;
        let (mut to_a, mut to_b) = (0.0, 0.0);
        for s in 0..=PANELS {
            let x = a + h * s as f64;
            let simpson = if s == 0 || s == PANELS {
                1.0
            } else if s % 2 == 1 {
                4.0
            } else {
                2.0
            };
            let f = simpson * density.pdf(x) * h / 3.0;
            let t = (x - a) / (b - a);
            to_a += f * (1.0 - t);
            to_b += f * t;
        }
        p[k] += to_a;
        p[k + 1] += to_b;
    }
    p
}

/// HERO's policy: the density, the grid it rounds to and the per-sample lane weights.
#[derive(Clone, Debug)]
pub struct HeroWavelengths {
    density: VisibleDensity,
    lambdas: Vec<f32>,
    /// 1/(4·P(i)) for every grid sample i.
    lane_weight: Vec<f32>,
    seed: u64,
}

impl HeroWavelengths {
    pub fn new(grid: &WavelengthGrid, seed: u64) -> Self {
        let lambdas = grid.lambdas().to_vec();
        let density = VisibleDensity::new(lambdas[0], lambdas[lambdas.len() - 1]);
        let lane_weight = rounding_probabilities(&density, &lambdas)
            .iter()
            .map(|&p| (1.0 / (HERO_LANES as f64 * p)) as f32)
            .collect();
        Self { density, lambdas, lane_weight, seed }
    }

    /// The grid sample a continuous `lambda` is carried at: one of its two neighbours,
    /// the upper one with probability (λ − λlo)/(λhi − λlo) (`r` uniform in [0, 1)).
    pub fn round(&self, lambda: f64, r: f32) -> usize {
        let n = self.lambdas.len();
        let hi = self.lambdas.partition_point(|&l| (l as f64) < lambda).clamp(1, n - 1);
        let (a, b) = (self.lambdas[hi - 1] as f64, self.lambdas[hi] as f64);
        if (r as f64) < (lambda - a) / (b - a) {
            hi
        } else {
            hi - 1
        }
    }

    /// The four lanes of CDF position `u`, each rounded with a number from `rng`.
    pub fn lanes(&self, u: f32, rng: &mut Rng) -> HeroSet {
        let mut index = [0u32; HERO_LANES];
        let mut weight = [0.0f32; HERO_LANES];
        for j in 0..HERO_LANES {
            let uj = (u + j as f32 / HERO_LANES as f32).fract();
            let i = self.round(self.density.sample(uj), rng.uniform());
            index[j] = i as u32;
            weight[j] = self.lane_weight[i];
        }
        HeroSet { index, weight }
    }
}

impl WavelengthPolicy for HeroWavelengths {
    type Wavelengths = HeroSet;
    fn rounds(&self) -> u32 {
        1
    }
    fn camera(&self, pixel: u64, pass: u32) -> HeroSet {
        // Sample s at offset + φ₂(s)/4 (φ₂: the base-2 radical inverse) and the lanes at
        // + j/4: any first S samples of a pixel spread their wavelengths evenly over each
        // quarter of the CDF — also when a time limit or adaptive sampling stops early.
        let offset = Rng::new(self.seed ^ LATTICE_SALT, pixel).uniform();
        let radical_inverse = (pass.reverse_bits() as f64 / 4_294_967_296.0) as f32;
        let u = (offset + radical_inverse / HERO_LANES as f32).fract();
        let mut set = self.lanes(u, &mut Rng::for_sample(self.seed ^ ROUNDING_SALT, pixel, pass as u64));
        // The hero (lane 0, the one that continues past a dispersive surface) takes each
        // quarter in turn: otherwise a pixel's dispersed light would all come from the one
        // quarter of the spectrum its offset starts.
        let k = pass as usize % HERO_LANES;
        set.index.rotate_left(k);
        set.weight.rotate_left(k);
        set
    }
    fn light(&self, _pass: u32, rng: &mut Rng) -> HeroSet {
        let u = rng.uniform();
        self.lanes(u, rng)
    }
}

/// The four grid samples a hero path carries, and each lane's weight 1/(4·P(i)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HeroSet {
    /// Grid index of each lane; lane 0 is the hero.
    pub index: [u32; HERO_LANES],
    pub weight: [f32; HERO_LANES],
}

impl Wavelengths for HeroSet {
    type Throughput = Hero;
    fn unit(&self, _grid_len: usize, _spare: &mut super::throughput::Spare) -> Hero {
        Hero { set: *self, values: [1.0; HERO_LANES], alone: 0.0 }
    }
    fn emitted(&self, le: SampledSpectrum) -> Hero {
        let values = std::array::from_fn(|j| le.get(self.index[j] as usize) * self.weight[j]);
        Hero { set: *self, values, alone: 0.0 }
    }
    fn single(&self) -> Option<usize> {
        None
    }
    fn resolve(&self, gathered: &Hero, out: &mut SampledSpectrum) {
        for j in 0..HERO_LANES {
            let i = self.index[j] as usize;
            out.set(i, out.get(i) + gathered.values[j] * self.weight[j]);
        }
        let i = self.index[0] as usize;
        out.set(i, out.get(i) + gathered.alone * self.weight[0]);
    }
}

/// A hero path's throughput (or what it gathered) on its four lanes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hero {
    pub set: HeroSet,
    pub values: [f32; HERO_LANES],
    /// Gathered only: what the hero gathered alone after the secondary lanes ended
    /// (already including the factor 4 of [`Throughput::collapse`]).
    pub alone: f32,
}

impl Hero {
    #[inline]
    fn at(&self, j: usize, s: &SampledSpectrum) -> f32 {
        s.get(self.set.index[j] as usize)
    }
}

impl Throughput for Hero {
    fn zero_like(&self) -> Self {
        Self { set: self.set, values: [0.0; HERO_LANES], alone: 0.0 }
    }
    fn is_alive(&self) -> bool {
        self.values.iter().all(|v| v.is_finite()) && self.values.iter().any(|&v| v > 0.0)
    }
    fn carries(&self, s: &SampledSpectrum) -> bool {
        (0..HERO_LANES).any(|j| self.at(j, s) > 0.0)
    }
    fn survival_probability(&self) -> f32 {
        self.values.iter().copied().fold(0.0f32, f32::max).min(1.0)
    }
    fn divide_by_survival(&mut self, q: f32) {
        self.values.iter_mut().for_each(|v| *v /= q);
    }
    fn scale(&mut self, s: f32) {
        self.values.iter_mut().for_each(|v| *v *= s);
    }
    #[inline]
    fn add_emitted(&mut self, beta: &Self, e: &SampledSpectrum, w: f32) {
        for j in 0..HERO_LANES {
            self.values[j] += beta.values[j] * self.at(j, e) * w;
        }
    }
    #[inline]
    fn add_direct(&mut self, beta: &Self, f: &mut SampledSpectrum, le: &SampledSpectrum, w: f32, pdf: f32) {
        for j in 0..HERO_LANES {
            self.values[j] += beta.values[j] * self.at(j, f) * self.at(j, le) * w / pdf;
        }
    }
    fn add_at(&mut self, i: usize, v: f32) {
        debug_assert_eq!(i, self.set.index[0] as usize, "only the hero continues alone");
        self.alone += v;
    }
    fn scatter(
        &mut self,
        v: &Vertex,
        ctx: &ShadingContext,
        rng: &mut Rng,
        tp: &mut SampledSpectrum,
    ) -> Option<Scatter> {
        // The BSDF multiplies 1 on the four lanes by f·cos/pdf and weighs its lobe choice
        // by the lanes together: one direction density for all four.
        tp.fill(0.0);
        for &i in &self.set.index {
            tp.set(i as usize, 1.0);
        }
        let sc = super::scatter(v, ctx, rng, tp)?;
        for j in 0..HERO_LANES {
            self.values[j] *= self.at(j, tp);
        }
        Some(sc)
    }
    fn times(&self, f: &SampledSpectrum, s: f32) -> SampledSpectrum {
        let mut r = SampledSpectrum::zeros(f.len());
        for j in 0..HERO_LANES {
            let i = self.set.index[j] as usize;
            r.set(i, r.get(i) + self.values[j] * f.get(i) * s);
        }
        r
    }
    fn weigh_grid(&self, s: &mut SampledSpectrum) {
        s.scale(self.values.iter().sum::<f32>() / HERO_LANES as f32);
    }
    fn scaled(&self, len: usize, s: f32) -> SampledSpectrum {
        let mut r = SampledSpectrum::zeros(len);
        for j in 0..HERO_LANES {
            let i = self.set.index[j] as usize;
            r.set(i, r.get(i) + self.values[j] * s);
        }
        r
    }
    /// The hero alone at its grid sample, standing for all four lanes (the secondary
    /// ones ended: spectral MIS at a dispersive surface).
    fn collapse(&self, i: usize) -> Option<SingleWavelength> {
        (i == self.set.index[0] as usize)
            .then(|| SingleWavelength { index: i, value: self.values[0] * HERO_LANES as f32 })
    }
    fn hero(&self) -> Option<usize> {
        Some(self.set.index[0] as usize)
    }
    fn lanes(&self) -> usize {
        HERO_LANES
    }
    fn lane_index(&self, j: usize) -> usize {
        self.set.index[j] as usize
    }
    fn lane(&self, j: usize) -> f32 {
        self.values[j]
    }
    fn set_lane(&mut self, j: usize, v: f32) {
        self.values[j] = v;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rounding_probabilities_sum_to_one_and_match_sampled_frequencies() {
        let grid = WavelengthGrid::uniform(41, 380.0, 780.0).unwrap();
        let hero = HeroWavelengths::new(&grid, 1);
        let p = rounding_probabilities(&hero.density, grid.lambdas());
        assert!((p.iter().sum::<f64>() - 1.0).abs() < 1e-9, "{}", p.iter().sum::<f64>());
        // The density's own closed form: P(λ ≤ 538) = (0 − t_lo)/(t_hi − t_lo).
        let d = &hero.density;
        let below: f64 = (0..10_000).map(|k| d.pdf(380.0 + 158.0 * (k as f64 + 0.5) / 10_000.0)).sum::<f64>() * 0.0158;
        assert!((below - (-d.t_lo) / (d.t_hi - d.t_lo)).abs() < 1e-6);
        // Frequencies of sample-then-round against P(i).
        let mut rng = Rng::new(7, 0);
        let n = 400_000;
        let mut count = vec![0u32; grid.len()];
        for _ in 0..n / HERO_LANES {
            let u = rng.uniform();
            for &i in &hero.lanes(u, &mut rng).index {
                count[i as usize] += 1;
            }
        }
        for (i, (&c, &pi)) in count.iter().zip(&p).enumerate() {
            let expected = pi * n as f64;
            assert!((c as f64 - expected).abs() < 5.0 * expected.sqrt() + 1.0, "sample {i}: {c} vs {expected}");
        }
    }

    #[test]
    fn a_pixels_lanes_are_stratified_in_the_cdf() {
        let grid = WavelengthGrid::uniform(401, 380.0, 780.0).unwrap();
        let samples = 8;
        let hero = HeroWavelengths::new(&grid, 3);
        // The first 4·8 lanes of one pixel: one in each of the 32 equal-probability strata
        // of the density (rounding moves a lane by less than one 1 nm step).
        let mut strata: Vec<usize> = (0..samples)
            .flat_map(|s| hero.camera(5, s).index)
            .map(|i| {
                let l = grid.lambdas()[i as usize] as f64;
                let t = (VISIBLE_A * (l - VISIBLE_CENTER_NM)).tanh();
                let f = (t - hero.density.t_lo) / (hero.density.t_hi - hero.density.t_lo);
                ((f * 32.0) as usize).min(31)
            })
            .collect();
        strata.sort();
        strata.dedup();
        assert!(strata.len() >= 28, "{} of 32 strata", strata.len());
    }
}
