//! A Principled-style layered BSDF (Blender's Principled BSDF, its standard material):
//!
//! * **base** (weight (1 − metallic)(1 − transmission)): a Lambertian base of colour ρ
//!   under a dielectric GGX specular layer with Fresnel at the material's IOR (Blender's
//!   default IOR 1.5 → 4 % at normal incidence, roughness 0.5), optionally with a thin
//!   film on the interface (spectral Airy reflectance, [`super::thinfilm`]);
//! * **metal** (weight metallic): GGX reflection with Blender's F82-tint Fresnel (base
//!   colour = F0, specular tint = the tint at ~82°; white tint = Schlick), or, with a
//!   thin film, the Airy reflectance of the film on a conductor whose complex index is
//!   derived from F0 and the tint (Gulbrandsen 2014); when rough, plus the multiply
//!   scattered light of Kulla & Conty 2017 (as Blender's default Multiscatter GGX), so a
//!   white metal reflects everything;
//! * **glass** (weight (1 − metallic)·transmission): the existing smooth or rough
//!   dielectric ([`super::Dielectric`] / [`super::RoughDielectric`], dispersive when the
//!   IOR varies over the grid), its transmission tinted by √ρ at each crossing (Cycles'
//!   Principled: `fresnel->transmission_tint = sqrt(base_color)`, so a closed object seen
//!   through shows ρ), and when rough by Cycles' multi-bounce darkening of the glass's
//!   multiple scattering with F_ss = √ρ: `microfacet_ggx_preserve_energy`
//!   (intern/cycles/kernel/closure/bsdf_microfacet.h) scales the glass closure's weight by
//!   (1 + F_ms·m)/(1 + m), m = (1 − E)/E, F_ms = F_ss·E_avg/(1 − F_ss·(1 − E_avg)), on
//!   top of the dielectric's own 1/E ([`super::RoughDielectric`]), per wavelength at its
//!   own index.
//!
//! **Energy conservation of the base layer (albedo scaling, reciprocal form).** With
//! E(μ) the directional albedo of the specular layer (tabulated per material and per
//! wavelength when the Fresnel term depends on λ, by quadrature of the GGX lobe) and
//! E_avg = 2∫E(μ)μ dμ, the base is
//!
//! ```text
//! f_base(wo, wi) = ρ/π · (1 − E(μo))·(1 − E(μi)) / (1 − E_avg)
//! ```
//!
//! (Kulla & Conty 2017's energy-compensation form). It is symmetric in wo and wi, so
//! forward and backward tracing see the same BSDF, and its albedo seen from wo is exactly
//! ρ·(1 − E(μo)): the directional albedo of the whole layer is E(μo) + ρ(1 − E(μo)) ≤ 1,
//! the same as Cycles' `closure_layering_weight` (which scales the diffuse by
//! 1 − E(μo) only). The base does not see a (1 − F) factor per direction: the specular
//! lobe's own energy loss (single scattering) is given to the base instead, so a white
//! base reflects everything at every angle and roughness (white furnace = 1).
//!
//! The lobes are chosen stochastically in `sample` in proportion to their estimated
//! albedo at wo; a non-delta sample is weighted by the sum of every non-delta lobe over
//! the mixture pdf (so `sample`, `eval` and `pdf` agree for MIS), a delta sample (roughness
//! ≈ 0, smooth glass, dispersive glass) by its own weight over its selection probability.
//! The specular reflection never depends on λ in direction, so the BSDF is dispersive only
//! through its glass lobe.

use super::conductor::MetalFresnel;
use super::dielectric::{relative, view_side};
use super::dispersion::IndexOfRefraction;
use super::energy::{glass_e, glass_e_avg, multiscatter_color};
use super::fresnel::{fresnel_dielectric_f64, reflect};
use super::microfacet::{AnisotropicGgx, Ggx, TangentRotation};
use super::oren_nayar::OrenNayarLobe;
use super::oriented::{bump_shadowing_term, same_event, LobeFrame};
use super::subsurface::SubsurfaceLobe;
use super::thinfilm::{metal_index_from_reflectance, thin_film_reflectance, ThinFilm};
use super::{Bsdf, BsdfFlags, BsdfSample, ShadingContext, SpectralParam};
use crate::sampling::cosine_hemisphere;
use crate::spectrum::{SampledSpectrum, WavelengthGrid};
use glam::{Vec2, Vec3A};
use std::f32::consts::FRAC_1_PI;

/// Number of μ = cos θ entries of a directional-albedo table (μ = 0 … 1 inclusive).
const ALBEDO_MU: usize = 33;
/// Stratified visible-normal samples per table entry (per axis).
const ALBEDO_STRATA: usize = 24;

/// Points at which a Fresnel function is read to key the albedo-table memo.
const KEY_COSINES: [f64; 8] = [0.001, 0.05, 0.13, 0.27, 0.42, 0.6, 0.81, 1.0];
/// Tables kept per thread (the memo is cleared when full).
const MEMO_TABLES: usize = 512;
/// Roughness steps (r = j/(WEIGHT_ROUGH − 1), α = r²) of the shared isotropic weight table.
const WEIGHT_ROUGH: usize = 65;
/// Nodes c_k = k/(WEIGHT_COS − 1) over cos θ_h at which the weight table reads a Fresnel.
const WEIGHT_COS: usize = 129;

thread_local! {
    static ALBEDO_MEMO: std::cell::RefCell<std::collections::HashMap<[u64; 11], Vec<f32>>> =
        std::cell::RefCell::new(std::collections::HashMap::new());
}

/// E(μ) of an isotropic GGX lobe is linear in its Fresnel f: the stratified estimate of
/// `compute_albedo_table` is Σ_s g_s·f(c_s) (g_s = G2/G1 of sample s, c_s = cos θ_h). With
/// f interpolated linearly between nodes c_k, E(μ_i) = Σ_k W[j][i][k]·f(c_k), where W
/// splats each sample's g_s onto its two nearest nodes — the same samples, computed once
/// per process for each of WEIGHT_ROUGH roughnesses (a row when first read). A table
/// then costs WEIGHT_COS Fresnel evaluations and two dot products per μ instead of
/// ALBEDO_MU × ALBEDO_STRATA² microfacet evaluations, which matters when the roughness varies from hit to hit (a
/// metallic-roughness texture: every glTF asset), where the memo below never hits.
/// Cycles likewise reads precomputed E(μ, roughness[, IOR]) tables
/// (intern/cycles/kernel/closure/bsdf_microfacet.h, `microfacet_ggx_preserve_energy`).
fn albedo_weights(j: usize) -> &'static [f32] {
    // One row per roughness, built when first read (a constant roughness builds two).
    static W: [std::sync::OnceLock<Vec<f32>>; WEIGHT_ROUGH] = [const { std::sync::OnceLock::new() }; WEIGHT_ROUGH];
    W[j].get_or_init(|| {
        let (n, k_max) = (ALBEDO_STRATA, (WEIGHT_COS - 1) as f64);
        let mut w = vec![0.0f64; ALBEDO_MU * WEIGHT_COS];
        let r = j as f32 / (WEIGHT_ROUGH - 1) as f32;
        let g = Ggx::isotropic((r * r).max(1e-4));
        for i in 0..ALBEDO_MU {
            let mu = (i as f64 / (ALBEDO_MU - 1) as f64).max(1e-3);
            let wo = Vec3A::new((1.0 - mu * mu).sqrt() as f32, 0.0, mu as f32);
            let g1 = g.g1(wo) as f64;
            let row = &mut w[i * WEIGHT_COS..][..WEIGHT_COS];
            for a in 0..n {
                for b in 0..n {
                    let u = Vec2::new((a as f32 + 0.5) / n as f32, (b as f32 + 0.5) / n as f32);
                    let wm = g.sample_wm(wo, u);
                    let wi = reflect(wo, wm);
                    if wi.z <= 0.0 {
                        continue;
                    }
                    let v = g.g(wo, wi) as f64 / g1 / (n * n) as f64;
                    let x = wo.dot(wm).clamp(0.0, 1.0) as f64 * k_max;
                    let k = (x.floor() as usize).min(WEIGHT_COS - 2);
                    let t = x - k as f64;
                    row[k] += v * (1.0 - t);
                    row[k + 1] += v * t;
                }
            }
        }
        w.into_iter().map(|x| x as f32).collect()
    })
}

/// One Fresnel function's albedo rows, per thread: `f` at the weight table's nodes and
/// E(μ) = W[j]·f for each roughness row j read so far.
struct FresnelRows {
    fk: Vec<f32>,
    rows: Vec<Option<Box<[f32; ALBEDO_MU]>>>,
}

thread_local! {
    // Keyed by `f` at KEY_COSINES. A texture on Base Color or Roughness builds a
    // Principled at every hit with the same Fresnel: its rows are computed once per
    // thread instead of WEIGHT_COS Fresnel evaluations and two 33×129 dot products per hit.
    static FRESNEL_ROWS: std::cell::RefCell<std::collections::HashMap<[u64; 8], FresnelRows>> =
        std::cell::RefCell::new(std::collections::HashMap::new());
}

/// `compute_albedo_table` of an isotropic rough lobe through `albedo_weights`, linear
/// between the two neighbouring roughness rows (α = r²). The rows W[j]·f are memoised
/// per Fresnel function ([`FRESNEL_ROWS`]); the result is the same to the bit.
fn albedo_table_from_weights(alpha: f32, f: &dyn Fn(f64) -> f64) -> Vec<f32> {
    let x = alpha.max(0.0).sqrt().min(1.0) * (WEIGHT_ROUGH - 1) as f32;
    let j = (x.floor() as usize).min(WEIGHT_ROUGH - 2);
    let t = x - j as f32;
    let key = KEY_COSINES.map(|c| f(c).to_bits());
    FRESNEL_ROWS.with(|memo| {
        let mut memo = memo.borrow_mut();
        if memo.len() >= MEMO_TABLES && !memo.contains_key(&key) {
            memo.clear();
        }
        let entry = memo.entry(key).or_insert_with(|| FresnelRows {
            fk: (0..WEIGHT_COS).map(|k| f(k as f64 / (WEIGHT_COS - 1) as f64) as f32).collect(),
            rows: vec![None; WEIGHT_ROUGH],
        });
        for r in [j, j + 1] {
            if entry.rows[r].is_none() {
                let w = albedo_weights(r);
                let mut row = [0.0f32; ALBEDO_MU];
                for (i, e) in row.iter_mut().enumerate() {
                    *e = w[i * WEIGHT_COS..][..WEIGHT_COS].iter().zip(&entry.fk).map(|(a, b)| a * b).sum();
                }
                entry.rows[r] = Some(Box::new(row));
            }
        }
        let (r0, r1) = (entry.rows[j].as_deref().expect("built"), entry.rows[j + 1].as_deref().expect("built"));
        r0.iter().zip(r1).map(|(&a, &b)| ((1.0 - t) * a + t * b).clamp(0.0, 1.0)).collect()
    })
}

/// The directional albedo E(μ) of a GGX reflection lobe with Fresnel `f(cos θ_h)`, for
/// μ = i/(ALBEDO_MU − 1); `smooth` lobes reflect exactly F(μ).
///
/// Isotropic lobes read the shared weight table (`albedo_weights`). Anisotropic ones are
/// memoised per thread: a material whose graph varies per hit (docs/shading.md) builds
/// its Principled at every hit, mostly with the same roughness and index (a texture on
/// Base Color), and a table costs ALBEDO_MU × ALBEDO_STRATA² microfacet evaluations. The
/// key is the roughness, `smooth` and `f` at eight cosines (the Fresnel functions used
/// here are fixed by one or two parameters, which those values tell apart).
fn albedo_table(g: &Ggx, smooth: bool, f: &dyn Fn(f64) -> f64) -> Vec<f32> {
    if smooth {
        return compute_albedo_table(g, smooth, f);
    }
    if g.alpha_x == g.alpha_y {
        return albedo_table_from_weights(g.alpha_x, f);
    }
    let mut key = [0u64; 11];
    key[0] = g.alpha_x.to_bits() as u64;
    key[1] = g.alpha_y.to_bits() as u64;
    key[2] = smooth as u64;
    for (k, &c) in key[3..].iter_mut().zip(&KEY_COSINES) {
        *k = f(c).to_bits();
    }
    if let Some(t) = ALBEDO_MEMO.with(|m| m.borrow().get(&key).cloned()) {
        return t;
    }
    let t = compute_albedo_table(g, smooth, f);
    ALBEDO_MEMO.with(|m| {
        let mut m = m.borrow_mut();
        if m.len() >= MEMO_TABLES {
            m.clear();
        }
        m.insert(key, t.clone());
    });
    t
}

fn compute_albedo_table(g: &Ggx, smooth: bool, f: &dyn Fn(f64) -> f64) -> Vec<f32> {
    (0..ALBEDO_MU)
        .map(|i| {
            let mu = (i as f64 / (ALBEDO_MU - 1) as f64).max(1e-3);
            if smooth {
                return f(mu) as f32;
            }
            let wo = Vec3A::new((1.0 - mu * mu).sqrt() as f32, 0.0, mu as f32);
            let mut acc = 0.0f64;
            let n = ALBEDO_STRATA;
            let g1 = g.g1(wo) as f64;
            for a in 0..n {
                for b in 0..n {
                    let u = Vec2::new((a as f32 + 0.5) / n as f32, (b as f32 + 0.5) / n as f32);
                    let wm = g.sample_wm(wo, u);
                    let wi = reflect(wo, wm);
                    if wi.z <= 0.0 {
                        continue;
                    }
                    // f·cos/pdf of visible-normal sampling = F·G2/G1.
                    acc += f(wo.dot(wm).clamp(0.0, 1.0) as f64) * g.g(wo, wi) as f64 / g1;
                }
            }
            (acc / (n * n) as f64).clamp(0.0, 1.0) as f32
        })
        .collect()
}

/// 2∫E(μ)μ dμ by the trapezoidal rule on the table's μ grid.
fn albedo_average(t: &[f32]) -> f32 {
    let h = 1.0 / (t.len() - 1) as f64;
    let mut s = 0.0f64;
    for i in 0..t.len() - 1 {
        let (m0, m1) = (i as f64 * h, (i + 1) as f64 * h);
        s += 0.5 * h * (t[i] as f64 * m0 + t[i + 1] as f64 * m1);
    }
    (2.0 * s).clamp(0.0, 1.0) as f32
}

#[inline]
fn lookup(t: &[f32], mu: f32) -> f32 {
    let x = mu.abs().clamp(0.0, 1.0) * (t.len() - 1) as f32;
    let i = (x as usize).min(t.len() - 2);
    let f = x - i as f32;
    t[i] * (1.0 - f) + t[i + 1] * f
}

/// Blender's F82-tint Fresnel (Hoffman 2019, as Cycles' `fresnel_f82tint`): Schlick with
/// F0, minus b·μ(1 − μ)^6 chosen so that F(acos 1/7) = tint × Schlick(acos 1/7).
#[inline]
pub fn f82_tint(cos: f32, f0: f32, tint: f32) -> f32 {
    let f = 6.0f32 / 7.0;
    let f5 = f * f * f * f * f;
    let schlick_82 = f0 + (1.0 - f0) * f5;
    let b = schlick_82 * (7.0 / (f5 * f)) * (1.0 - tint);
    let mu = cos.abs().clamp(0.0, 1.0);
    let s = 1.0 - mu;
    let s5 = s * s * s * s * s;
    (f0 + (1.0 - f0) * s5 - b * mu * s5 * s).clamp(0.0, 1.0)
}

/// The metal lobe's Fresnel: F82-tint, or a thin film over the equivalent conductor.
pub struct MetalF82 {
    pub f0: SpectralParam,
    pub tint: SampledSpectrum,
    pub film: Option<ThinFilm>,
}

impl MetalF82 {
    /// Hemispherical average 2∫F(μ)μ dμ of the F82-tint Fresnel per lane, in closed form:
    /// F0 + (1 − F0)/21 − b/126 (a film is ignored here: its metal's F82 average is used).
    fn average_into(&self, ctx: &ShadingContext, out: &mut SampledSpectrum) {
        self.f0.evaluate_into(ctx, out);
        let f = 6.0f32 / 7.0;
        let f5 = f * f * f * f * f;
        for i in 0..out.len() {
            let f0 = out.get(i).clamp(0.0, 1.0);
            let b = (f0 + (1.0 - f0) * f5) * (7.0 / (f5 * f)) * (1.0 - self.tint.get(i));
            out.set(i, (f0 + (1.0 - f0) / 21.0 - b / 126.0).clamp(0.0, 1.0));
        }
    }
}

impl MetalFresnel for MetalF82 {
    fn eval(&self, ctx: &ShadingContext, cos: f32, out: &mut SampledSpectrum) {
        self.f0.evaluate_into(ctx, out);
        let lambdas = ctx.grid.lambdas();
        for i in 0..out.len() {
            let f0 = out.get(i).clamp(0.0, 1.0);
            let v = match self.film {
                Some(film) => {
                    let (n, k) = metal_index_from_reflectance(f0, self.tint.get(i));
                    thin_film_reflectance(
                        cos as f64,
                        lambdas[i] as f64,
                        film.thickness_nm as f64,
                        film.ior as f64,
                        n,
                        k,
                    ) as f32
                }
                None => f82_tint(cos, f0, self.tint.get(i)),
            };
            out.set(i, v);
        }
    }
}

/// Everything needed to build a [`Principled`] (already validated and on the grid).
pub struct PrincipledParams {
    pub base_color: SpectralParam,
    pub metallic: f32,
    pub transmission: f32,
    pub roughness: f32,
    pub ior: IndexOfRefraction,
    /// Blender's "Specular IOR Level": 0.5 keeps `ior`; otherwise the specular layer's F0
    /// is scaled by 2·level (0: no specular reflection), as Cycles does.
    pub specular_ior_level: f32,
    /// Blender's "Specular Tint": the metal's tint at ~82° and the dielectric layer's F0
    /// tint (Cycles' generalized Schlick Fresnel); white for none.
    pub specular_tint: SampledSpectrum,
    pub thin_film: Option<ThinFilm>,
    /// Blender's Diffuse Roughness of the base (0: Lambertian; else Cycles' energy-
    /// preserving Oren–Nayar, `bsdf_oren_nayar_setup` in the Principled branch of
    /// `svm_node_closure_bsdf`).
    pub diffuse_roughness: f32,
    /// The glass lobe (built by the caller from the same IOR and roughness), if
    /// `transmission > 0`.
    pub glass: Option<Box<dyn Bsdf>>,
    /// Blender's Anisotropic (0..1) of the specular and metal lobes (Cycles: alpha_x =
    /// r²/k, alpha_y = r²·k, k = √(1 − 0.9·anisotropic); the glass stays isotropic, as
    /// in `svm_node_closure_bsdf`), along `tangent` (the shading frame's tangent turned
    /// by Anisotropic Rotation).
    pub anisotropic: f32,
    pub tangent: TangentRotation,
}

pub struct Principled {
    base_color: SpectralParam,
    w_base: f32,
    w_metal: f32,
    w_glass: f32,
    /// The specular and metal lobes' distribution and tangent.
    ggx: AnisotropicGgx,
    smooth: bool,
    ior: IndexOfRefraction,
    film: Option<ThinFilm>,
    /// The Specular Tint on the dielectric layer's F0 (None: white).
    spec_tint: Option<SampledSpectrum>,
    /// The base's Oren–Nayar lobe (None: Lambertian, Cycles' cutoff 1e-5).
    diffuse_on: Option<OrenNayarLobe>,
    metal: MetalF82,
    glass: Option<Box<dyn Bsdf>>,
    /// The glass lobe's own index (the specular layer's may be scaled by the level) and
    /// its Blender roughness when rough (None: smooth, no multiple scattering).
    glass_ior: IndexOfRefraction,
    glass_roughness: Option<f32>,
    /// E(μ) of the specular layer: one row, or one per wavelength lane.
    e_table: Vec<Vec<f32>>,
    /// 1/(1 − E_avg) per row (0 when the layer reflects everything).
    inv_one_minus_eavg: Vec<f32>,
    /// Multiple scattering of the rough metal (Kulla & Conty 2017): E(μ) of the GGX lobe
    /// with F = 1, its average and 1/(1 − E_avg) (0 when smooth or nothing is lost).
    ms_table: Vec<f32>,
    ms_e_avg: f32,
    ms_inv: f32,
    /// The subsurface lobe (`super::subsurface`), taking its weight of the base.
    sss: Option<SubsurfaceLobe>,
    /// The lobes' own normals (None: every lobe about the frame's normal).
    frames: Option<Box<PrincipledFrames>>,
}

/// The Principled's lobes about their own normals, in the vertex's frame, as Cycles'
/// `svm_node_closure_bsdf` orients them: the specular, metal, glass and subsurface lobes
/// about the valid Normal (`maybe_ensure_valid_specular_reflection`), the diffuse about
/// the Normal as given, dimmed by the bump shadowing term when that is not the smooth
/// normal. A lobe contributes only to pairs its frame and the vertex's see alike (as
/// [`super::oriented::Oriented`]); the diffuse's energy compensation still reads the
/// specular layer's albedo at the cosines about the specular normal.
#[derive(Clone, Copy, Debug, Default)]
pub struct PrincipledFrames {
    /// The specular lobes' frame (None: the vertex's).
    pub spec: Option<LobeFrame>,
    /// The diffuse lobe's frame (None: the vertex's).
    pub diffuse: Option<LobeFrame>,
    /// The smooth normal `sd->N`, when the diffuse normal is not it ([`bump_shadowing_term`]).
    pub smooth: Option<Vec3A>,
}

/// A pair of directions as the Principled's lobes see it (see [`PrincipledFrames`]).
struct Dirs {
    /// wo and wi in the specular lobes' frame.
    wo: Vec3A,
    wi: Vec3A,
    /// Whether the specular lobes' frame sees the pair as the vertex's does.
    spec: bool,
    /// The pair in the diffuse lobe's frame (on one side of it, seen alike by the vertex's
    /// frame) and the bump shadowing term; None: the diffuse carries nothing.
    diffuse: Option<(Vec3A, Vec3A, f32)>,
}

/// Per-hit spectra: base colour, the metal's Fresnel at wo and its multiple-scattering
/// colour F_ms.
struct HitSpectra {
    rho: SampledSpectrum,
    metal_f: SampledSpectrum,
    fms: SampledSpectrum,
}

/// Selection probabilities of the lobes at one wo.
#[derive(Clone, Copy, Debug, Default)]
struct Lobes {
    spec: f32,
    diffuse: f32,
    metal: f32,
    metal_ms: f32,
    glass: f32,
    /// The subsurface lobe (walked: its share of the base's diffuse albedo).
    sss: f32,
}

impl Principled {
    pub fn new(p: PrincipledParams, grid: &WavelengthGrid) -> Self {
        let distribution = Ggx::principled_anisotropic(p.roughness, p.anisotropic);
        let smooth = distribution.effectively_smooth();
        // Energy compensation of an anisotropic lobe reads the isotropic tables at
        // √√(alpha_x·alpha_y), as Cycles does (an approximation: the anisotropic albedo
        // also depends on the view's azimuth); an isotropic lobe reads its own.
        let table_g = distribution.energy_equivalent();
        let metallic = p.metallic.clamp(0.0, 1.0);
        let transmission = if p.glass.is_some() { p.transmission.clamp(0.0, 1.0) } else { 0.0 };
        let film = p.thin_film.filter(|f| f.active());
        let lanes = grid.len();
        let ior = specular_index(&p.ior, p.specular_ior_level);
        // The Fresnel of the specular layer depends on λ only through a film or a
        // varying index: then one table per lane.
        let spec_tint = (p.specular_tint.len() == lanes && p.specular_tint.values().iter().any(|&t| t != 1.0))
            .then(|| p.specular_tint.clone());
        let per_lane = film.is_some() || (0..lanes).any(|i| ior.at(i) != ior.at(0));
        let rows = if per_lane { lanes } else { 1 };
        let lambdas = grid.lambdas();
        let mut e_table: Vec<Vec<f32>> = (0..rows)
            .map(|i| {
                let n = ior.at(i) as f64;
                let lambda = lambdas[i] as f64;
                let t = spec_tint.as_ref().map(|t| t.get(i) as f64);
                match film {
                    Some(fl) => albedo_table(&table_g, smooth, &|c| {
                        let f = thin_film_reflectance(c, lambda, fl.thickness_nm as f64, fl.ior as f64, n, 0.0);
                        t.map_or(f, |t| tinted_film_fresnel(f, n, t))
                    }),
                    None => albedo_table(&table_g, smooth, &|c| fresnel_dielectric_f64(c, n)),
                }
            })
            .collect();
        if let (Some(t), None) = (&spec_tint, film) {
            // The tinted Fresnel mix(F0·t, 1, s), s = (F − F0)/(1 − F0), is linear in F, so
            // its albedo per lane follows from the untinted one and that of F = 1:
            // E_t = F0·t·E₁ + (1 − F0·t)·(E_F − F0·E₁)/(1 − F0).
            let e1 = albedo_table(&table_g, smooth, &|_| 1.0);
            e_table = (0..lanes)
                .map(|k| {
                    let f0 = dielectric_f0(ior.at(k) as f64) as f32;
                    let ft = f0 * t.get(k);
                    let ef = &e_table[if per_lane { k } else { 0 }];
                    ef.iter()
                        .zip(&e1)
                        .map(|(&e, &one)| {
                            let s = if f0 < 1.0 { ((e - f0 * one) / (1.0 - f0)).max(0.0) } else { 0.0 };
                            (ft * one + (1.0 - ft) * s).clamp(0.0, 1.0)
                        })
                        .collect()
                })
                .collect();
        }
        let inv_one_minus_eavg = e_table
            .iter()
            .map(|t| {
                let d = 1.0 - albedo_average(t);
                if d > 1e-4 {
                    1.0 / d
                } else {
                    0.0
                }
            })
            .collect();
        let (ms_table, ms_e_avg, ms_inv) = if metallic > 0.0 && !smooth {
            let t = albedo_table(&table_g, false, &|_| 1.0);
            let avg = albedo_average(&t);
            let inv = if 1.0 - avg > 1e-4 { 1.0 / (1.0 - avg) } else { 0.0 };
            (t, avg, inv)
        } else {
            (vec![1.0; ALBEDO_MU], 1.0, 0.0)
        };
        Self {
            ms_table,
            ms_e_avg,
            ms_inv,
            metal: MetalF82 { f0: clone_param(&p.base_color), tint: p.specular_tint, film },
            base_color: p.base_color,
            w_base: (1.0 - metallic) * (1.0 - transmission),
            w_metal: metallic,
            w_glass: (1.0 - metallic) * transmission,
            ggx: AnisotropicGgx::new(distribution, p.tangent),
            smooth,
            ior,
            film,
            spec_tint,
            diffuse_on: (p.diffuse_roughness.is_finite() && p.diffuse_roughness >= 1e-5)
                .then(|| OrenNayarLobe::new(p.diffuse_roughness)),
            glass_roughness: p.glass.as_ref().filter(|g| g.flags().smooth && !smooth).map(|_| distribution.roughness()),
            glass_ior: p.ior,
            glass: if transmission > 0.0 { p.glass } else { None },
            e_table,
            inv_one_minus_eavg,
            sss: None,
            frames: None,
        }
    }

    /// With lobes about their own normals (see [`PrincipledFrames`]).
    pub fn with_frames(mut self, f: PrincipledFrames) -> Self {
        self.frames = (f.spec.is_some() || f.diffuse.is_some() || f.smooth.is_some()).then(|| Box::new(f));
        self
    }

    /// The vertex-frame pair `wo`, `wi` as the lobes see it.
    fn dirs(&self, wo: Vec3A, wi: Vec3A) -> Dirs {
        let Some(f) = self.frames.as_deref() else {
            return Dirs { wo, wi, spec: true, diffuse: (wo.z * wi.z > 0.0).then_some((wo, wi, 1.0)) };
        };
        let (so, si, spec) = match &f.spec {
            Some(l) => {
                let (a, b) = (l.view_to_lobe(wo), l.to_lobe(wi));
                (a, b, same_event(wo, wi, a, b))
            }
            None => (wo, wi, true),
        };
        let (a, b) = f.diffuse.map_or((wo, wi), |l| (l.view_to_lobe(wo), l.to_lobe(wi)));
        let diffuse = (a.z * b.z > 0.0 && same_event(wo, wi, a, b)).then(|| {
            let n = f.diffuse.map_or(Vec3A::Z, |l| l.normal());
            (a, b, f.smooth.map_or(1.0, |ns| bump_shadowing_term(ns, n, wi)))
        });
        Dirs { wo: so, wi: si, spec, diffuse }
    }

    /// A specular-frame direction in the vertex's frame.
    #[inline]
    fn spec_to_vertex(&self, v: Vec3A) -> Vec3A {
        match self.frames.as_deref().and_then(|f| f.spec.as_ref()) {
            Some(l) => l.to_vertex(v),
            None => v,
        }
    }

    /// With a subsurface lobe taking `lobe.weight` of the base (Cycles: the BSSRDF
    /// closure gets base colour × Subsurface Weight, the diffuse the rest).
    pub fn with_subsurface(mut self, lobe: Option<SubsurfaceLobe>) -> Self {
        self.sss = lobe.filter(|_| self.w_base > 0.0);
        self
    }

    /// The share of the base that walks at this hit (0 when subsurface lobes act as a
    /// diffuse here: `ShadingContext::subsurface_walk`).
    #[inline]
    fn sss_weight(&self, ctx: &ShadingContext) -> f32 {
        match &self.sss {
            Some(l) if ctx.subsurface_walk => l.weight,
            _ => 0.0,
        }
    }

    #[inline]
    fn row(&self, lane: usize) -> usize {
        if self.e_table.len() == 1 {
            0
        } else {
            lane
        }
    }

    /// Fresnel of the dielectric specular layer at `cos` for lane `i`, with the Specular
    /// Tint as Cycles' `microfacet_fresnel` (GENERALIZED_SCHLICK, exponent < 0: the real
    /// Fresnel F interpolates between F0·tint and 1 as s = (F − F0)/(1 − F0); with a thin
    /// film F·mix(1, tint, s), s = (1 − F)/(1 − F0), its iridescence branch).
    #[inline]
    fn spec_fresnel(&self, ctx: &ShadingContext, cos: f32, i: usize) -> f32 {
        let n = self.ior.at(i) as f64;
        let t = self.spec_tint.as_ref().map(|t| t.get(i) as f64);
        let f = match self.film {
            Some(f) => {
                let r = thin_film_reflectance(
                    cos as f64,
                    ctx.grid.lambdas()[i] as f64,
                    f.thickness_nm as f64,
                    f.ior as f64,
                    n,
                    0.0,
                );
                t.map_or(r, |t| tinted_film_fresnel(r, n, t))
            }
            None => {
                let r = fresnel_dielectric_f64(cos as f64, n);
                t.map_or(r, |t| tinted_fresnel(r, n, t))
            }
        };
        f as f32
    }

    fn spec_fresnel_into(&self, ctx: &ShadingContext, cos: f32, out: &mut SampledSpectrum) {
        if self.e_table.len() == 1 && self.spec_tint.is_none() {
            out.fill(self.spec_fresnel(ctx, cos, 0));
        } else {
            for i in 0..out.len() {
                out.set(i, self.spec_fresnel(ctx, cos, i));
            }
        }
    }

    /// Lobe selection probabilities at `wo` (upper hemisphere), from their albedos
    /// averaged over the lanes (or the path's single lane).
    fn lobes(&self, ctx: &ShadingContext, mu_o: f32, h: &HitSpectra) -> Lobes {
        let (rho, metal_f) = (&h.rho, &h.metal_f);
        // One wavelength, or all of them (a range: no boxed iterator to allocate per call).
        let lanes = match ctx.single_wavelength {
            Some(i) => i..i + 1,
            None => 0..rho.len(),
        };
        let (mut e, mut d, mut m, mut ms, mut count) = (0.0f32, 0.0f32, 0.0f32, 0.0f32, 0.0f32);
        for i in lanes {
            let ei = lookup(&self.e_table[self.row(i)], mu_o);
            e += ei;
            d += rho.get(i).max(0.0) * (1.0 - ei);
            m += metal_f.get(i);
            ms += h.fms.get(i);
            count += 1.0;
        }
        let w_sss = self.sss_weight(ctx);
        let mut l = Lobes {
            spec: self.w_base * e / count,
            diffuse: self.w_base * (1.0 - w_sss) * d / count,
            sss: self.w_base * w_sss * d / count,
            metal: self.w_metal * m / count,
            metal_ms: if self.ms_inv > 0.0 {
                self.w_metal * ms / count * (1.0 - lookup(&self.ms_table, mu_o))
            } else {
                0.0
            },
            glass: if self.glass.is_some() { self.w_glass } else { 0.0 },
        };
        let total = l.spec + l.diffuse + l.metal + l.metal_ms + l.glass + l.sss;
        if !(total > 0.0 && total.is_finite()) {
            return Lobes::default();
        }
        l.spec /= total;
        l.diffuse /= total;
        l.metal /= total;
        l.metal_ms /= total;
        l.glass /= total;
        l.sss /= total;
        l
    }

    /// Sum of the non-delta lobes, f·|cos θi| into `out`, and the mixture pdf.
    fn eval_lobes(
        &self,
        ctx: &ShadingContext,
        lobes: &Lobes,
        h: &HitSpectra,
        d: &Dirs,
        out: &mut SampledSpectrum,
    ) -> f32 {
        out.fill(0.0);
        let rho = &h.rho;
        let mut pdf = 0.0f32;
        let n = out.len();
        let (wo, wi) = (d.wo, d.wi);
        // Diffuse base (what the subsurface lobe leaves of it), about its own normal; its
        // energy compensation reads the specular layer's albedo about the specular normal.
        let w_diffuse = self.w_base * (1.0 - self.sss_weight(ctx));
        if let (true, Some((a, b, shadowing))) = (w_diffuse > 0.0, d.diffuse) {
            // In the upper hemisphere (the base layer is two-sided).
            let (o, i) = if a.z < 0.0 { (Vec3A::new(a.x, a.y, -a.z), Vec3A::new(b.x, b.y, -b.z)) } else { (a, b) };
            let (mu_o, mu_i) = (wo.z.abs(), wi.z.abs());
            // Lambert ρ/π·cos θi, or the Oren–Nayar lobe (ρ·(single + F_ms(ρ)·multi)).
            let on = self.diffuse_on.map(|l| (l, l.terms(o, i)));
            let w = w_diffuse * shadowing;
            for k in 0..n {
                let r = self.row(k);
                let t = &self.e_table[r];
                let rk = rho.get(k);
                let diffuse = match on {
                    None => rk * FRAC_1_PI * i.z,
                    Some((l, (single, multi))) => rk * (single + l.multiscatter(rk) * multi),
                };
                let v = diffuse * (1.0 - lookup(t, mu_o)) * (1.0 - lookup(t, mu_i)) * self.inv_one_minus_eavg[r];
                out.set(k, w * v);
            }
            pdf += lobes.diffuse * i.z * FRAC_1_PI;
        }
        let reflect_side = d.spec && wo.z * wi.z > 0.0;
        if reflect_side {
            // Work in the upper hemisphere (the base layer is two-sided).
            let (o, i) =
                if wo.z < 0.0 { (Vec3A::new(wo.x, wo.y, -wo.z), Vec3A::new(wi.x, wi.y, -wi.z)) } else { (wo, wi) };
            let (mu_o, mu_i) = (o.z, i.z);
            // The rough metal's multiply scattered light (Kulla & Conty 2017):
            // F_ms (1 − E(μo))(1 − E(μi)) / (π (1 − E_avg)), E for F = 1.
            if self.w_metal > 0.0 && self.ms_inv > 0.0 {
                let shape = (1.0 - lookup(&self.ms_table, mu_o))
                    * (1.0 - lookup(&self.ms_table, mu_i))
                    * self.ms_inv
                    * FRAC_1_PI
                    * mu_i;
                out.add_scaled(&h.fms, self.w_metal * shape);
                pdf += lobes.metal_ms * mu_i * FRAC_1_PI;
            }
            if !self.smooth && (self.w_base > 0.0 || self.w_metal > 0.0) {
                let wm = (o + i).normalize_or_zero();
                let c = o.dot(wm);
                if wm != Vec3A::ZERO && c > 0.0 {
                    let g = &self.ggx.distribution;
                    let (ol, il, ml) = (self.ggx.to_lobe(o), self.ggx.to_lobe(i), self.ggx.to_lobe(wm));
                    let s = g.d(ml) * g.g(ol, il) / (4.0 * mu_o);
                    let p = g.d_visible(ol, ml) / (4.0 * c);
                    if s.is_finite() && p.is_finite() {
                        let mut f = SampledSpectrum::zeros(n);
                        if self.w_base > 0.0 {
                            self.spec_fresnel_into(ctx, c, &mut f);
                            out.add_scaled(&f, self.w_base * s);
                        }
                        if self.w_metal > 0.0 {
                            self.metal.eval(ctx, c, &mut f);
                            out.add_scaled(&f, self.w_metal * s);
                        }
                        pdf += (lobes.spec + lobes.metal) * p;
                    }
                }
            }
        }
        if let (true, Some(glass)) = (d.spec, &self.glass) {
            if lobes.glass > 0.0 || self.w_glass > 0.0 {
                let mut f = SampledSpectrum::zeros(n);
                let pg = glass.eval(ctx, wo, wi, &mut f);
                self.glass_tint(ctx, rho, wo, wi, &mut f);
                out.add_scaled(&f, self.w_glass);
                pdf += lobes.glass * pg;
            }
        }
        pdf
    }

    /// Multiplies `f` (the glass lobe's value or weight for wo → wi) per lane by what
    /// the Principled adds to the glass: √ρ on refraction, and when rough Cycles'
    /// darkening (1 + F_ms·m)/(1 + m) of its multiple scattering with F_ss = √ρ, seen
    /// from the view side at each lane's index.
    fn glass_tint(&self, ctx: &ShadingContext, rho: &SampledSpectrum, wo: Vec3A, wi: Vec3A, f: &mut SampledSpectrum) {
        let refracted = wo.z * wi.z < 0.0;
        let common = match ctx.single_wavelength {
            Some(i) => Some(self.glass_ior.at(i)),
            None if !self.glass_ior.dispersive => Some(self.glass_ior.at(0)),
            None => None,
        };
        let mut cached: Option<(f32, f32)> = None;
        for (k, v) in f.values_mut().iter_mut().enumerate() {
            if *v == 0.0 {
                continue;
            }
            let fss = rho.get(k).max(0.0).sqrt();
            let mut t = if refracted { fss } else { 1.0 };
            if let Some(r) = self.glass_roughness {
                if fss < 1.0 {
                    let (e, e_avg) = match (cached, common) {
                        (Some(ea), Some(_)) => ea,
                        _ => {
                            let n = common.unwrap_or_else(|| self.glass_ior.at(k));
                            let (mu, eta) = view_side(ctx, relative(n, ctx), wo, wi);
                            let (e, a) = (glass_e(r, mu, eta), glass_e_avg(r, eta));
                            cached = Some((e, a));
                            (e, a)
                        }
                    };
                    if e > 1e-4 && e < 1.0 {
                        let m = (1.0 - e) / e;
                        t *= (1.0 + multiscatter_color(fss, e_avg) * m) / (1.0 + m);
                    }
                }
            }
            *v *= t;
        }
    }

    /// ρ, the metal's Fresnel at `mu_o` (for lobe selection) and its F_ms.
    fn hit_spectra(&self, ctx: &ShadingContext, mu_o: f32, n: usize) -> HitSpectra {
        let mut rho = SampledSpectrum::zeros(n);
        self.base_color.evaluate_into(ctx, &mut rho);
        let mut metal_f = SampledSpectrum::zeros(n);
        let mut fms = SampledSpectrum::zeros(n);
        if self.w_metal > 0.0 {
            self.metal.eval(ctx, mu_o, &mut metal_f);
            if self.ms_inv > 0.0 {
                // F_ms = F_avg² E_avg / (1 − F_avg (1 − E_avg)): the colour of light
                // that scattered more than once between the microfacets.
                self.metal.average_into(ctx, &mut fms);
                let e = self.ms_e_avg;
                for v in fms.values_mut() {
                    let fa = *v;
                    *v = fa * fa * e / (1.0 - fa * (1.0 - e)).max(1e-6);
                }
            }
        }
        HitSpectra { rho, metal_f, fms }
    }
}

/// F0 = ((n − 1)/(n + 1))² (Cycles' `F0_from_ior`).
#[inline]
fn dielectric_f0(n: f64) -> f64 {
    ((n - 1.0) / (n + 1.0)).powi(2)
}

/// The real dielectric Fresnel `f` at index `n` with its F0 tinted by `t` (Cycles'
/// generalized Schlick with exponent −η): mix(F0·t, 1, saturate((f − F0)/(1 − F0))).
#[inline]
pub fn tinted_fresnel(f: f64, n: f64, t: f64) -> f64 {
    let f0 = dielectric_f0(n);
    if f0 >= 1.0 {
        return f;
    }
    let s = ((f - f0) / (1.0 - f0)).clamp(0.0, 1.0);
    f0 * t + (1.0 - f0 * t) * s
}

/// A thin film's reflectance `f` with the F0 tint `t` (Cycles' iridescence branch of the
/// generalized Schlick Fresnel): f·mix(1, t, saturate((f − 1)/(F0 − 1))).
#[inline]
fn tinted_film_fresnel(f: f64, n: f64, t: f64) -> f64 {
    let f0 = dielectric_f0(n);
    if !(f0 > 1e-5) || f == 1.0 {
        return f;
    }
    let s = ((f - 1.0) / (f0 - 1.0)).clamp(0.0, 1.0);
    f * (1.0 + (t - 1.0) * s)
}

/// The specular layer's index for Blender's Specular IOR Level (Cycles:
/// F0 = F0(ior)·2·level, η = ior_from_F0(F0)); level 0.5 keeps the index.
fn specular_index(ior: &IndexOfRefraction, level: f32) -> IndexOfRefraction {
    if !level.is_finite() || (level - 0.5).abs() < 1e-6 {
        return ior.clone();
    }
    let mut out = ior.clone();
    for v in out.values.values_mut() {
        let n = *v as f64;
        let f0 = ((n - 1.0) / (n + 1.0)).powi(2) * 2.0 * level.max(0.0) as f64;
        let s = f0.min(0.99).sqrt();
        *v = ((1.0 + s) / (1.0 - s)) as f32;
    }
    out
}

fn clone_param(p: &SpectralParam) -> SpectralParam {
    match p {
        SpectralParam::Constant(s) => SpectralParam::Constant(s.clone()),
        SpectralParam::Texture { texture, uplift, scale } => {
            SpectralParam::Texture { texture: texture.clone(), uplift: uplift.clone(), scale: *scale }
        }
    }
}

impl Bsdf for Principled {
    fn flags(&self) -> BsdfFlags {
        let reflective = self.w_base > 0.0 || self.w_metal > 0.0;
        let glass = self.glass.as_ref().map(|g| g.flags()).unwrap_or_default();
        BsdfFlags {
            smooth: self.w_base > 0.0 || (reflective && !self.smooth) || glass.smooth,
            specular: (reflective && self.smooth) || glass.specular,
            dispersive: glass.dispersive,
        }
    }

    fn eval(&self, ctx: &ShadingContext, wo: Vec3A, wi: Vec3A, out: &mut SampledSpectrum) -> f32 {
        let n = out.len();
        let d = self.dirs(wo, wi);
        let mu_o = d.wo.z.abs();
        let h = self.hit_spectra(ctx, mu_o, n);
        let lobes = self.lobes(ctx, mu_o, &h);
        let pdf = self.eval_lobes(ctx, &lobes, &h, &d, out);
        if !(out.is_finite() && pdf.is_finite()) {
            out.fill(0.0);
            return 0.0;
        }
        pdf
    }

    fn pdf(&self, ctx: &ShadingContext, wo: Vec3A, wi: Vec3A) -> f32 {
        let mut f = SampledSpectrum::zeros(ctx.grid.len());
        self.eval(ctx, wo, wi, &mut f)
    }

    fn sample(
        &self,
        ctx: &ShadingContext,
        wo_v: Vec3A,
        u: Vec2,
        uc: f32,
        throughput: &mut SampledSpectrum,
    ) -> Option<BsdfSample> {
        // wo_v, wi_v: the vertex's frame; wo, wi: the specular lobes' (the same without
        // frames).
        let frames = self.frames.as_deref();
        let spec_frame = frames.and_then(|f| f.spec);
        let wo = spec_frame.map_or(wo_v, |l| l.view_to_lobe(wo_v));
        if wo.z == 0.0 {
            return None;
        }
        // A delta direction `wi` of a specular-frame lobe, in the vertex's frame when both
        // frames see it alike.
        let delta = |wi: Vec3A| -> Option<Vec3A> {
            let wi_v = self.spec_to_vertex(wi);
            (spec_frame.is_none() || same_event(wo_v, wi_v, wo, wi)).then_some(wi_v)
        };
        let n = throughput.len();
        let mu_o = wo.z.abs();
        let h = self.hit_spectra(ctx, mu_o, n);
        let lobes = self.lobes(ctx, mu_o, &h);
        let flip = |v: Vec3A| {
            if wo.z < 0.0 {
                Vec3A::new(v.x, v.y, -v.z)
            } else {
                v
            }
        };
        let o = flip(wo);
        let mut c0 = lobes.spec;
        let c_diffuse = lobes.spec + lobes.metal + lobes.diffuse;
        // The sampled direction in the vertex's frame, and whether the diffuse lobe drew it.
        let (wi_v, diffuse) = if uc < c0 {
            if self.smooth {
                // Delta specular reflection off the dielectric layer.
                let wi_v = delta(Vec3A::new(-wo.x, -wo.y, wo.z))?;
                let mut f = SampledSpectrum::zeros(n);
                self.spec_fresnel_into(ctx, mu_o, &mut f);
                f.scale(self.w_base / lobes.spec);
                throughput.mul_assign(&f);
                return Some(BsdfSample { wi: wi_v, pdf: lobes.spec, specular: true, collapsed_to: None });
            }
            let wm = self.ggx.lobe_to_shading(self.ggx.distribution.sample_wm(self.ggx.to_lobe(o), u));
            let wi = reflect(o, wm);
            if wi.z <= 0.0 {
                return None;
            }
            (self.spec_to_vertex(flip(wi)), false)
        } else if uc < {
            c0 += lobes.metal;
            c0
        } {
            if self.smooth {
                let wi_v = delta(Vec3A::new(-wo.x, -wo.y, wo.z))?;
                let mut f = SampledSpectrum::zeros(n);
                self.metal.eval(ctx, mu_o, &mut f);
                f.scale(self.w_metal / lobes.metal);
                throughput.mul_assign(&f);
                return Some(BsdfSample { wi: wi_v, pdf: lobes.metal, specular: true, collapsed_to: None });
            }
            let wm = self.ggx.lobe_to_shading(self.ggx.distribution.sample_wm(self.ggx.to_lobe(o), u));
            let wi = reflect(o, wm);
            if wi.z <= 0.0 {
                return None;
            }
            (self.spec_to_vertex(flip(wi)), false)
        } else if uc < {
            c0 += lobes.diffuse + lobes.metal_ms;
            c0
        } {
            // The diffuse base (about its own normal) and the metal's multiple scattering
            // (about the specular one) are both cosine-sampled.
            let diffuse = uc < c_diffuse;
            let c = cosine_hemisphere(u);
            let frame = if diffuse { frames.and_then(|f| f.diffuse) } else { spec_frame };
            let a = frame.map_or(wo_v, |l| l.view_to_lobe(wo_v));
            let c = if a.z < 0.0 { Vec3A::new(c.x, c.y, -c.z) } else { c };
            (frame.map_or(c, |l| l.to_vertex(c)), diffuse)
        } else if uc < {
            c0 += lobes.sss;
            c0
        } {
            // Into the subsurface medium (pdf 0 towards lights, a delta-like choice
            // weighted by its own selection probability): the base's share ρ·(1 − E(μo))
            // of the lobe; the walk divides ρ out and scatters it back.
            let lobe = self.sss.as_ref()?;
            if !(lobes.sss > 0.0) {
                return None;
            }
            let wi_v = delta(flip(lobe.entry(&self.ggx.distribution, o, u)?))?;
            let w = self.w_base * lobe.weight / lobes.sss;
            let mut f = SampledSpectrum::zeros(n);
            for k in 0..n {
                let rho = h.rho.get(k);
                let rho = if rho.is_finite() { rho.clamp(0.0, 1.0) } else { 0.0 };
                f.set(k, w * rho * (1.0 - lookup(&self.e_table[self.row(k)], mu_o)));
            }
            throughput.mul_assign(&f);
            ctx.subsurface.set(Some(lobe.event(&h.rho)));
            return Some(BsdfSample { wi: wi_v, pdf: lobes.sss, specular: true, collapsed_to: None });
        } else {
            let glass = self.glass.as_ref()?;
            if !(lobes.glass > 0.0) {
                return None;
            }
            let u2 = ((uc - c0) / lobes.glass).clamp(0.0, 0.999_999_9);
            let mut tp = throughput.clone();
            let bs = glass.sample(ctx, wo, u, u2, &mut tp)?;
            if bs.specular || bs.collapsed_to.is_some() {
                // A delta (or wavelength-dependent) direction: weight by this lobe alone.
                let wi_v = delta(bs.wi)?;
                self.glass_tint(ctx, &h.rho, wo, bs.wi, &mut tp);
                tp.scale(self.w_glass / lobes.glass);
                if !tp.is_finite() {
                    return None;
                }
                throughput.copy_from(&tp);
                return Some(BsdfSample { wi: wi_v, pdf: bs.pdf * lobes.glass, ..bs });
            }
            (self.spec_to_vertex(bs.wi), false)
        };
        if wi_v.z * wo_v.z == 0.0 || !wi_v.is_finite() {
            return None;
        }
        let d = self.dirs(wo_v, wi_v);
        // A lobe keeps only the directions its frame and the vertex's see alike (what
        // eval_lobes counts in the mixture pdf).
        if d.wi.z * d.wo.z == 0.0 || !(if diffuse { d.diffuse.is_some() } else { d.spec }) {
            return None;
        }
        let mut f = SampledSpectrum::zeros(n);
        let pdf = self.eval_lobes(ctx, &lobes, &h, &d, &mut f);
        if !(pdf > 0.0 && pdf.is_finite()) || f.is_black() {
            return None;
        }
        f.scale(1.0 / pdf);
        if !f.is_finite() {
            return None;
        }
        throughput.mul_assign(&f);
        Some(BsdfSample { wi: wi_v, pdf, specular: false, collapsed_to: None })
    }

    fn albedo(&self, ctx: &ShadingContext, out: &mut SampledSpectrum) {
        // Seen from the normal: E(1) + ρ(1 − E(1)) for the base, F0 (plus its multiple
        // scattering) for the metal, √ρ (its transmission tint) for the glass.
        let n = out.len();
        let h = self.hit_spectra(ctx, 1.0, n);
        let (rho, mf) = (&h.rho, &h.metal_f);
        let ms = if self.ms_inv > 0.0 { 1.0 - lookup(&self.ms_table, 1.0) } else { 0.0 };
        for k in 0..n {
            let e = lookup(&self.e_table[self.row(k)], 1.0);
            let v = self.w_base * (e + rho.get(k) * (1.0 - e))
                + self.w_metal * (mf.get(k) + h.fms.get(k) * ms)
                + self.w_glass * rho.get(k).max(0.0).sqrt();
            out.set(k, v.clamp(0.0, 1.0));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::{Dielectric, RoughDielectric, TransportMode};
    use crate::sampling::Rng;

    #[test]
    fn memoised_albedo_tables_are_the_computed_ones() {
        // Anisotropic: the memo, exactly the computed tables.
        let g = Ggx { alpha_x: 0.16, alpha_y: 0.3 };
        for n in [1.45, 1.5, 1.45] {
            let f = |c: f64| fresnel_dielectric_f64(c, n);
            assert_eq!(albedo_table(&g, false, &f), compute_albedo_table(&g, false, &f), "n {n}");
        }
        let (a, b) = (
            albedo_table(&g, false, &|c| fresnel_dielectric_f64(c, 1.45)),
            albedo_table(&g, false, &|c| fresnel_dielectric_f64(c, 1.5)),
        );
        assert_ne!(a, b);
        let rougher = albedo_table(&Ggx { alpha_x: 0.25, alpha_y: 0.3 }, false, &|c| fresnel_dielectric_f64(c, 1.45));
        assert_ne!(a, rougher);
    }

    /// The shared weight table (isotropic lobes) against the direct stratified estimate
    /// at roughnesses between its rows, for the Fresnels the Principled uses: dielectric,
    /// F = 1 (metal energy compensation) and a thin film's (fast in cos θ).
    #[test]
    fn weight_table_albedo_matches_the_direct_estimate() {
        let film = |c: f64| thin_film_reflectance(c, 550.0, 800.0, 1.33, 1.5, 0.0);
        let fresnels: [(&str, &dyn Fn(f64) -> f64); 4] = [
            ("n 1.45", &|c| fresnel_dielectric_f64(c, 1.45)),
            ("n 2.4", &|c| fresnel_dielectric_f64(c, 2.4)),
            ("F = 1", &|_| 1.0),
            ("film 800 nm", &film),
        ];
        for r in [0.05f32, 0.137, 0.33, 0.5, 0.777, 0.99] {
            let g = Ggx::from_roughness(r);
            for (what, f) in fresnels {
                let (lut, direct) = (albedo_table(&g, false, f), compute_albedo_table(&g, false, f));
                let err = lut.iter().zip(&direct).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
                assert!(err < 2e-3, "roughness {r}, {what}: max |ΔE| {err}\n{lut:?}\n{direct:?}");
                let (ea, eb) = (albedo_average(&lut), albedo_average(&direct));
                assert!((ea - eb).abs() < 1e-3, "roughness {r}, {what}: E_avg {ea} vs {eb}");
            }
        }
    }

    /// The per-thread rows of [`FRESNEL_ROWS`] give the table the weight rows give
    /// without a memo, to the bit, whatever was read before (other Fresnels and
    /// roughnesses interleaved, the memo cleared when full).
    #[test]
    fn memoised_fresnel_rows_equal_the_unmemoised_table() {
        let unmemoised = |alpha: f32, f: &dyn Fn(f64) -> f64| -> Vec<f32> {
            let fk: Vec<f32> = (0..WEIGHT_COS).map(|k| f(k as f64 / (WEIGHT_COS - 1) as f64) as f32).collect();
            let x = alpha.max(0.0).sqrt().min(1.0) * (WEIGHT_ROUGH - 1) as f32;
            let j = (x.floor() as usize).min(WEIGHT_ROUGH - 2);
            let t = x - j as f32;
            let (w0, w1) = (albedo_weights(j), albedo_weights(j + 1));
            let dot = |w: &[f32], i: usize| -> f32 {
                w[i * WEIGHT_COS..][..WEIGHT_COS].iter().zip(&fk).map(|(a, b)| a * b).sum()
            };
            (0..ALBEDO_MU).map(|i| ((1.0 - t) * dot(w0, i) + t * dot(w1, i)).clamp(0.0, 1.0)).collect()
        };
        let mut rng = crate::sampling::Rng::new(5, 2);
        for k in 0..(2 * MEMO_TABLES + 40) {
            // Mostly a few indices (memo hits), sometimes a new one (a miss, and a clear).
            let n = if k % 2 == 0 { 1.0 + rng.uniform() as f64 } else { [1.33, 1.5, 2.0][k % 3] };
            let alpha = rng.uniform() * rng.uniform();
            let f = |c: f64| fresnel_dielectric_f64(c, n);
            assert_eq!(albedo_table_from_weights(alpha, &f), unmemoised(alpha, &f), "n {n}, alpha {alpha}");
        }
    }

    pub(super) fn principled(
        grid: &WavelengthGrid,
        rho: f32,
        metallic: f32,
        transmission: f32,
        roughness: f32,
        ior: f32,
        film: Option<ThinFilm>,
    ) -> Principled {
        let n = grid.len();
        let ior_v = IndexOfRefraction::constant(n, ior);
        let g = Ggx::from_roughness(roughness);
        let glass: Option<Box<dyn Bsdf>> = if transmission > 0.0 {
            Some(if g.effectively_smooth() {
                Box::new(Dielectric { ior: ior_v.clone() })
            } else {
                Box::new(RoughDielectric::new(ior_v.clone(), g))
            })
        } else {
            None
        };
        Principled::new(
            PrincipledParams {
                base_color: SpectralParam::Constant(SampledSpectrum::splat(n, rho)),
                metallic,
                transmission,
                roughness,
                ior: ior_v,
                specular_ior_level: 0.5,
                specular_tint: SampledSpectrum::splat(n, 1.0),
                thin_film: film,
                diffuse_roughness: 0.0,
                glass,
                anisotropic: 0.0,
                tangent: TangentRotation::default(),
            },
            grid,
        )
    }

    fn dir(theta: f32, phi: f32) -> Vec3A {
        Vec3A::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos())
    }

    /// Sampled albedo (mean of f·cos/pdf) and its standard error, lane 0.
    pub(super) fn sampled_albedo(m: &dyn Bsdf, ctx: &ShadingContext, wo: Vec3A, n: usize, seed: u64) -> (f64, f64) {
        let mut rng = Rng::new(seed, 17);
        let (mut s1, mut s2) = (0.0f64, 0.0f64);
        for _ in 0..n {
            let mut tp = SampledSpectrum::splat(ctx.grid.len(), 1.0);
            if let Some(s) = m.sample(ctx, wo, rng.uniform2(), rng.uniform(), &mut tp) {
                assert!(tp.is_finite() && s.pdf > 0.0 && s.pdf.is_finite(), "{tp:?} {s:?}");
                if !s.specular {
                    let p = m.pdf(ctx, wo, s.wi);
                    assert!((p - s.pdf).abs() <= 2e-3 * s.pdf.max(1.0), "sample pdf {} vs pdf() {p}", s.pdf);
                }
                let v = tp.get(0) as f64;
                s1 += v;
                s2 += v * v;
            }
        }
        let mean = s1 / n as f64;
        (mean, ((s2 / n as f64 - mean * mean).max(0.0) / n as f64).sqrt())
    }

    /// Quadrature of eval over the sphere (lane 0).
    pub(super) fn quadrature_albedo(m: &dyn Bsdf, ctx: &ShadingContext, wo: Vec3A) -> f64 {
        let (nt, np) = (1200, 200);
        let mut q = 0.0f64;
        let mut f = SampledSpectrum::zeros(ctx.grid.len());
        for i in 0..nt {
            let c = -1.0 + 2.0 * (i as f32 + 0.5) / nt as f32;
            let s = (1.0 - c * c).max(0.0).sqrt();
            for j in 0..np {
                let phi = std::f32::consts::TAU * (j as f32 + 0.5) / np as f32;
                m.eval(ctx, wo, Vec3A::new(s * phi.cos(), s * phi.sin(), c), &mut f);
                q += f.get(0) as f64;
            }
        }
        q * 4.0 * std::f64::consts::PI / (nt * np) as f64
    }

    /// White furnace: a white base under the specular layer reflects everything at every
    /// angle and roughness (albedo 1 within the table's quadrature), metals and glass
    /// never exceed 1, and the sampled albedo equals a quadrature of eval.
    #[test]
    fn white_furnace_albedo_at_most_one() {
        let grid = WavelengthGrid::uniform(4, 400.0, 700.0).unwrap();
        for &mode in &[TransportMode::Radiance, TransportMode::Importance] {
            let mut ctx = ShadingContext::new(&grid);
            ctx.mode = mode;
            for &(metallic, transmission) in &[(0.0f32, 0.0f32), (1.0, 0.0), (0.5, 0.0), (0.0, 0.5), (0.3, 0.3)] {
                for &roughness in &[0.0f32, 0.2, 0.5, 1.0] {
                    let m = principled(&grid, 1.0, metallic, transmission, roughness, 1.5, None);
                    for &theta in &[0.0f32, 0.6, 1.1, 1.45] {
                        let wo = dir(theta, 0.4);
                        let (mean, se) = sampled_albedo(
                            &m,
                            &ctx,
                            wo,
                            20_000,
                            (theta.to_bits() as u64) ^ (roughness.to_bits() as u64),
                        );
                        let tol = 4.0 * se + 4e-3;
                        // A rough glass lobe's multiple-scattering compensation is taken
                        // from the camera side (`wi` on light paths, as Cycles' from its
                        // view direction): not reciprocal, so one importance event may
                        // exceed 1 (the image is the same: dielectric.rs tests both modes).
                        let compensated_adjoint =
                            transmission > 0.0 && roughness > 0.0 && mode == TransportMode::Importance;
                        assert!(
                            compensated_adjoint || mean <= 1.0 + tol,
                            "m {metallic} t {transmission} r {roughness} θ {theta}: albedo {mean} ± {se}"
                        );
                        if transmission == 0.0 {
                            // The layer conserves energy exactly with a white base, and a
                            // white metal with its multiple scattering.
                            assert!(
                                (mean - 1.0).abs() < tol,
                                "r {roughness} θ {theta}: white-base albedo {mean} ± {se}"
                            );
                        }
                        if roughness >= 0.5 && mode == TransportMode::Importance {
                            let q = quadrature_albedo(&m, &ctx, wo);
                            assert!(compensated_adjoint || q <= 1.0 + 0.01, "quadrature {q}");
                            assert!((q - mean).abs() < 5.0 * se + 0.015, "m {metallic} t {transmission} r {roughness} θ {theta}: sampled {mean} ± {se} vs quadrature {q}");
                        }
                    }
                }
            }
        }
    }

    /// χ² test of the sampled directions against pdf() over the whole sphere (as the GGX
    /// visible-normal test in `microfacet`), rough lobes only, with failed samples as one
    /// more bin whose expectation is 1 − ∫pdf.
    #[test]
    fn sampling_matches_pdf_chi_square() {
        let grid = WavelengthGrid::uniform(4, 400.0, 700.0).unwrap();
        let ctx = ShadingContext::new(&grid);
        for &(rho, metallic, transmission, roughness, theta_o) in &[
            (0.8f32, 0.0f32, 0.0f32, 0.5f32, 0.5f32),
            (0.3, 0.4, 0.0, 0.3, 1.2),
            (0.6, 0.2, 0.5, 0.6, 0.8),
            (0.0, 0.0, 0.0, 0.4, 0.3),
        ] {
            let m = principled(&grid, rho, metallic, transmission, roughness, 1.5, None);
            crate::material::testing::chi_square(&m, &ctx, dir(theta_o, 0.0), 100_000, theta_o.to_bits() as u64);
        }
    }

    /// A Principled with Anisotropic `aniso` along the tangent (0.6, 0.8, 0) turned by
    /// `turns` (no glass).
    fn anisotropic(
        grid: &WavelengthGrid,
        rho: f32,
        metallic: f32,
        roughness: f32,
        aniso: f32,
        turns: f32,
    ) -> Principled {
        let mut m = principled(grid, rho, metallic, 0.0, roughness, 1.5, None);
        let n = grid.len();
        m = Principled::new(
            PrincipledParams {
                base_color: SpectralParam::Constant(SampledSpectrum::splat(n, rho)),
                metallic,
                transmission: 0.0,
                roughness,
                ior: std::mem::replace(&mut m.ior, IndexOfRefraction::constant(n, 1.5)),
                specular_ior_level: 0.5,
                specular_tint: SampledSpectrum::splat(n, 1.0),
                thin_film: None,
                diffuse_roughness: 0.0,
                glass: None,
                anisotropic: aniso,
                tangent: TangentRotation::new(Vec3A::new(0.6, 0.8, 0.0), turns),
            },
            grid,
        );
        m
    }

    /// Anisotropic specular and metal lobes (Cycles' alpha_x = r²/k, alpha_y = r²·k along
    /// the tangent): with Anisotropic 0 the Principled is the isotropic one exactly; a
    /// white metal and a white dielectric over a white base reflect at most everything,
    /// and exactly what the compensation Cycles uses predicts: the anisotropic lobe's own
    /// albedo (a quadrature of the bare GGX lobe, conductor.rs) plus the isotropic
    /// table's 1 − E(μ) at √√(alpha_x·alpha_y); χ² of sample() against pdf(); reciprocity.
    #[test]
    fn anisotropic_lobes_furnace_chi_square_and_reciprocity() {
        use crate::material::conductor::{Glossy, SchlickFresnel};
        use crate::material::testing::{assert_reciprocal, chi_square, quadrature_albedo};
        let grid = WavelengthGrid::uniform(4, 400.0, 700.0).unwrap();
        let ctx = ShadingContext::new(&grid);
        // Anisotropic 0: bit for bit the isotropic Principled, whatever the tangent.
        let (a, b) = (anisotropic(&grid, 0.7, 0.4, 0.45, 0.0, 0.3), principled(&grid, 0.7, 0.4, 0.0, 0.45, 1.5, None));
        let (mut fa, mut fb) = (SampledSpectrum::zeros(4), SampledSpectrum::zeros(4));
        let mut rng = Rng::new(8, 8);
        for _ in 0..200 {
            let wo = dir(rng.uniform() * 1.5, rng.uniform() * 6.0);
            let wi = dir(rng.uniform() * 1.5, rng.uniform() * 6.0);
            assert_eq!(a.eval(&ctx, wo, wi, &mut fa), b.eval(&ctx, wo, wi, &mut fb));
            assert_eq!(fa.values(), fb.values());
        }
        let white = |r: f32| {
            Glossy::new(SchlickFresnel { reflectance: SpectralParam::Constant(SampledSpectrum::splat(4, 1.0)) }, r)
        };
        for &(metallic, roughness, aniso) in &[(1.0f32, 0.5f32, 1.0f32), (1.0, 0.3, 0.6), (0.0, 0.5, 1.0)] {
            let m = anisotropic(&grid, 1.0, metallic, roughness, aniso, 0.1);
            let g = m.ggx.distribution;
            let lobe = white(roughness).with_distribution(g, m.ggx.tangent);
            let iso = white(g.roughness());
            for &(theta, phi) in &[(0.0f32, 0.0f32), (0.9, 0.3), (1.3, 1.9)] {
                let wo = dir(theta, phi);
                let (mean, se) = sampled_albedo(&m, &ctx, wo, 60_000, 21);
                assert!(mean <= 1.0 + 4.0 * se + 1e-3, "m {metallic} r {roughness} θ {theta}: albedo {mean} ± {se}");
                if metallic == 1.0 {
                    // The metal's single scattering E_aniso(wo) plus its isotropic
                    // multiple-scattering term, which integrates to 1 − E_iso(μo).
                    let expected = 1.0 - (quadrature_albedo(&iso, &ctx, wo, 0) - quadrature_albedo(&lobe, &ctx, wo, 0));
                    assert!(
                        (mean - expected).abs() < 4.0 * se + 0.015,
                        "r {roughness} a {aniso} θ {theta}: albedo {mean} ± {se} vs compensation {expected}"
                    );
                } else {
                    assert!(mean > 0.9, "a white dielectric over a white base keeps most energy: {mean}");
                }
            }
            chi_square(&m, &ctx, dir(0.8, 0.5), 100_000, 12);
        }
        assert_reciprocal(&anisotropic(&grid, 0.6, 0.5, 0.4, 0.8, 0.2), &ctx, 400, 13);
    }

    /// Lobes about their own normals (Cycles: specular about the valid Normal, diffuse
    /// about the Normal as given with the bump shadowing term): with no specular layer
    /// (Specular IOR Level 0) the base is exactly the Diffuse BSDF about the raw normal
    /// with Blender's bump shadowing; with the layer, sample() agrees with pdf() (χ²),
    /// the sampled albedo with a quadrature of eval, and a white base reflects at most
    /// everything.
    #[test]
    fn diffuse_about_the_raw_normal_specular_about_the_valid_one() {
        use crate::material::oriented::{bump_shadowing_term, Oriented};
        use crate::material::testing::chi_square;
        use crate::material::Diffuse;
        let grid = WavelengthGrid::uniform(4, 400.0, 700.0).unwrap();
        let ctx = ShadingContext::new(&grid);
        let tilt = |deg: f32, phi: f32| dir(deg.to_radians(), phi.to_radians());
        let (n_raw, n_valid, smooth) = (tilt(40.0, 10.0), tilt(15.0, 30.0), Vec3A::Z);
        let frames = PrincipledFrames {
            spec: Some(LobeFrame::new(n_valid)),
            diffuse: Some(LobeFrame::new(n_raw)),
            smooth: Some(smooth),
        };
        let mut bare = principled(&grid, 0.6, 0.0, 0.0, 0.5, 1.5, None);
        bare.ior = specular_index(&IndexOfRefraction::constant(4, 1.5), 0.0);
        bare.e_table = vec![vec![0.0; ALBEDO_MU]];
        bare.inv_one_minus_eavg = vec![1.0];
        let bare = bare.with_frames(frames);
        let reference = Oriented::diffuse(
            n_raw,
            Some(smooth),
            Box::new(Diffuse { reflectance: SpectralParam::Constant(SampledSpectrum::splat(4, 0.6)) }),
        );
        let (mut a, mut b) = (SampledSpectrum::zeros(4), SampledSpectrum::zeros(4));
        let mut rng = Rng::new(3, 3);
        let mut dimmed = 0;
        for _ in 0..400 {
            let wo = dir(rng.uniform() * 1.4, rng.uniform() * 6.3);
            let wi = dir(rng.uniform() * 1.57, rng.uniform() * 6.3);
            let (pa, pb) = (bare.eval(&ctx, wo, wi, &mut a), reference.eval(&ctx, wo, wi, &mut b));
            assert!((a.get(0) - b.get(0)).abs() < 1e-6 && (pa - pb).abs() < 1e-5, "{wo} {wi}: {a:?} vs {b:?}");
            dimmed += (bump_shadowing_term(smooth, n_raw, wi) < 0.99 && b.get(0) > 0.0) as usize;
        }
        assert!(dimmed > 20, "the bump shadowing term acts on {dimmed} pairs");
        for (rho, metallic, roughness) in [(0.7f32, 0.0f32, 0.4f32), (1.0, 0.0, 0.3), (0.5, 0.5, 0.6)] {
            let m = principled(&grid, rho, metallic, 0.0, roughness, 1.5, None).with_frames(frames);
            for theta in [0.3f32, 1.1] {
                let wo = dir(theta, 0.4);
                let (mean, se) = sampled_albedo(&m, &ctx, wo, 40_000, 31);
                let q = quadrature_albedo(&m, &ctx, wo);
                assert!((mean - q).abs() < 4.0 * se + 3e-3, "ρ {rho} θ {theta}: sampled {mean} ± {se} vs {q}");
                assert!(mean <= 1.0 + 4.0 * se + 1e-3, "ρ {rho} θ {theta}: {mean}");
            }
            chi_square(&m, &ctx, dir(0.9, 0.4), 100_000, 41);
        }
    }

    /// On a black base the layer reflects ((n − 1)/(n + 1))² at normal incidence.
    #[test]
    fn normal_incidence_specular_on_black_base() {
        let grid = WavelengthGrid::uniform(4, 400.0, 700.0).unwrap();
        let ctx = ShadingContext::new(&grid);
        for &n in &[1.5f32, 1.33, 2.4] {
            let r0 = ((n as f64 - 1.0) / (n as f64 + 1.0)).powi(2);
            // Smooth: a delta lobe whose weight is exactly F(0°).
            let m = principled(&grid, 0.0, 0.0, 0.0, 0.0, n, None);
            let (mean, se) = sampled_albedo(&m, &ctx, Vec3A::Z, 2000, 1);
            assert!((mean - r0).abs() < 1e-5 && se < 1e-6, "n {n}: {mean} vs {r0}");
            // Nearly smooth GGX: the same within the lobe's spread.
            let m = principled(&grid, 0.0, 0.0, 0.0, 0.05, n, None);
            let (mean, se) = sampled_albedo(&m, &ctx, Vec3A::Z, 20_000, 2);
            assert!((mean - r0).abs() < 4.0 * se + 1e-3, "n {n}: rough {mean} ± {se} vs {r0}");
            let mut a = SampledSpectrum::zeros(4);
            m.albedo(&ctx, &mut a);
            assert!((a.get(0) as f64 - r0).abs() < 1e-3, "albedo pass {}", a.get(0));
        }
    }

    /// A thin film on the layer: at normal incidence the sampled reflectance per lane
    /// follows the Airy formula (here a quarter-wave film that cancels 550 nm).
    #[test]
    fn thin_film_layer_reflects_airy_per_wavelength() {
        let grid = WavelengthGrid::uniform(9, 390.0, 710.0).unwrap();
        let ctx = ShadingContext::new(&grid);
        let n_sub = 1.5f32;
        let film = ThinFilm { thickness_nm: 550.0 / (4.0 * n_sub.sqrt()), ior: n_sub.sqrt() };
        let m = principled(&grid, 0.0, 0.0, 0.0, 0.0, n_sub, Some(film));
        let mut tp = SampledSpectrum::splat(9, 1.0);
        let s = m.sample(&ctx, Vec3A::Z, Vec2::new(0.5, 0.5), 0.01, &mut tp).unwrap();
        assert!(s.specular);
        let i550 = grid.nearest(550.0);
        assert!((grid.lambdas()[i550] - 550.0).abs() < 1e-3);
        let mut expected = [0.0f64; 9];
        for k in 0..9 {
            let l = grid.lambdas()[k] as f64;
            expected[k] = thin_film_reflectance(1.0, l, film.thickness_nm as f64, film.ior as f64, n_sub as f64, 0.0);
        }
        let mean_r: f64 = expected.iter().sum::<f64>() / 9.0;
        for k in 0..9 {
            // Weight = F_λ / P(spec lobe) with the lobe chosen with the lane-mean.
            let got = tp.get(k) as f64 * s.pdf as f64;
            assert!((got - expected[k]).abs() < 1e-5, "lane {k}: {got} vs {}", expected[k]);
        }
        assert!(expected[i550] < 1e-6 && mean_r > 0.002, "R(550) {} mean {mean_r}", expected[i550]);
        // The albedo stays ≤ 1 with a white base.
        let m = principled(&grid, 1.0, 0.0, 0.0, 0.4, n_sub, Some(ThinFilm { thickness_nm: 400.0, ior: 1.33 }));
        for &theta in &[0.0f32, 0.8, 1.4] {
            let (mean, se) = sampled_albedo(&m, &ctx, dir(theta, 0.0), 20_000, 5);
            assert!((mean - 1.0).abs() < 4.0 * se + 5e-3, "θ {theta}: {mean} ± {se}");
        }
    }

    /// Specular IOR Level scales the layer's F0 by 2·level (0: no reflection, 1: twice
    /// ((n − 1)/(n + 1))²), seen on a black base at normal incidence.
    #[test]
    fn specular_ior_level_scales_f0() {
        let grid = WavelengthGrid::uniform(4, 400.0, 700.0).unwrap();
        let ctx = ShadingContext::new(&grid);
        for &level in &[0.0f32, 0.25, 0.5, 1.0] {
            let mut m = principled(&grid, 0.0, 0.0, 0.0, 0.0, 1.5, None);
            m.ior = specular_index(&IndexOfRefraction::constant(4, 1.5), level);
            m.e_table =
                vec![albedo_table(&m.ggx.distribution, true, &|c| fresnel_dielectric_f64(c, m.ior.at(0) as f64))];
            let mut tp = SampledSpectrum::splat(4, 1.0);
            let expected = 0.04 * 2.0 * level;
            match m.sample(&ctx, Vec3A::Z, Vec2::new(0.5, 0.5), 0.5, &mut tp) {
                Some(s) => assert!((tp.get(0) * s.pdf - expected).abs() < 1e-5, "level {level}: {}", tp.get(0) * s.pdf),
                None => assert_eq!(expected, 0.0),
            }
        }
    }

    fn tinted(grid: &WavelengthGrid, rho: f32, roughness: f32, ior: f32, tint: &[f32]) -> Principled {
        let n = grid.len();
        let ior_v = IndexOfRefraction::constant(n, ior);
        Principled::new(
            PrincipledParams {
                base_color: SpectralParam::Constant(SampledSpectrum::splat(n, rho)),
                metallic: 0.0,
                transmission: 0.0,
                roughness,
                ior: ior_v,
                specular_ior_level: 0.5,
                specular_tint: SampledSpectrum::from_slice(tint),
                thin_film: None,
                diffuse_roughness: 0.0,
                glass: None,
                anisotropic: 0.0,
                tangent: TangentRotation::default(),
            },
            grid,
        )
    }

    /// Specular Tint on the dielectric layer: at normal incidence a smooth layer over a
    /// black base reflects F0·tint per lane ((n − 1)/(n + 1))²·t (Cycles' generalized
    /// Schlick with F0·tint and F90 = 1), and at grazing incidence it still reflects 1.
    #[test]
    fn specular_tint_scales_f0_per_lane() {
        let grid = WavelengthGrid::uniform(4, 400.0, 700.0).unwrap();
        let ctx = ShadingContext::new(&grid);
        let tint = [1.0f32, 0.5, 0.2, 0.0];
        for &n in &[1.5f32, 2.0] {
            let f0 = ((n - 1.0) / (n + 1.0)).powi(2);
            let m = tinted(&grid, 0.0, 0.0, n, &tint);
            let mut tp = SampledSpectrum::splat(4, 1.0);
            let s = m.sample(&ctx, Vec3A::Z, Vec2::new(0.5, 0.5), 0.01, &mut tp).unwrap();
            assert!(s.specular);
            for (k, t) in tint.iter().enumerate() {
                let got = tp.get(k) * s.pdf;
                assert!((got - f0 * t).abs() < 1e-5, "n {n} lane {k}: {got} vs {}", f0 * t);
            }
            // The layer's albedo pass at normal incidence, from the tinted tables.
            let mut a = SampledSpectrum::zeros(4);
            m.albedo(&ctx, &mut a);
            for (k, t) in tint.iter().enumerate() {
                assert!((a.get(k) - f0 * t).abs() < 2e-3, "albedo lane {k}: {} vs {}", a.get(k), f0 * t);
            }
        }
        // The closed form itself: F0·t at F = F0, 1 at F = 1, linear in F between.
        let f0 = 0.04f64;
        assert!((tinted_fresnel(f0, 1.5, 0.3) - f0 * 0.3).abs() < 1e-9);
        assert!((tinted_fresnel(1.0, 1.5, 0.3) - 1.0).abs() < 1e-9);
        assert!((tinted_fresnel(0.52, 1.5, 1.0) - 0.52).abs() < 1e-9);
    }

    /// A rough tinted layer over a white base stays at most 1 (per lane, every angle),
    /// and over a black base the sampled albedo matches a quadrature of eval per lane.
    #[test]
    fn specular_tint_rough_layer_conserves_energy() {
        let grid = WavelengthGrid::uniform(4, 400.0, 700.0).unwrap();
        let ctx = ShadingContext::new(&grid);
        let tint = [0.1f32, 0.5, 0.9, 1.0];
        let white = tinted(&grid, 1.0, 0.4, 1.5, &tint);
        let black = tinted(&grid, 0.0, 0.4, 1.5, &tint);
        for &th in &[0.2f32, 0.9, 1.3] {
            let wo = dir(th, 0.3);
            let (mean, se) = sampled_albedo(&white, &ctx, wo, 20_000, 3);
            assert!(mean < 1.0 + 4.0 * se + 1e-3, "white base θ {th}: {mean} ± {se}");
            let (mean, se) = sampled_albedo(&black, &ctx, wo, 40_000, 4);
            let q = quadrature_albedo(&black, &ctx, wo);
            assert!((mean - q).abs() < 4.0 * se + 2e-3, "black base θ {th}: {mean} ± {se} vs {q}");
        }
    }

    /// Diffuse Roughness: a white Oren–Nayar base under the specular layer still reflects
    /// everything at every angle (the EON lobe keeps its energy), and with Specular IOR
    /// Level 0 the base is exactly the Oren–Nayar BSDF of the Diffuse node.
    #[test]
    fn rough_diffuse_base_keeps_its_energy() {
        let grid = WavelengthGrid::uniform(4, 400.0, 700.0).unwrap();
        let ctx = ShadingContext::new(&grid);
        for &(sigma, r) in &[(1.0f32, 0.5f32), (0.5, 0.2)] {
            let mut m = principled(&grid, 1.0, 0.0, 0.0, r, 1.5, None);
            m.diffuse_on = Some(OrenNayarLobe::new(sigma));
            for &th in &[0.1f32, 0.8, 1.3] {
                let (mean, se) = sampled_albedo(&m, &ctx, dir(th, 0.2), 40_000, 9);
                assert!((mean - 1.0).abs() < 4.0 * se + 6e-3, "σ {sigma} θ {th}: {mean} ± {se}");
            }
        }
        let mut m = principled(&grid, 0.6, 0.0, 0.0, 0.5, 1.5, None);
        m.ior = specular_index(&IndexOfRefraction::constant(4, 1.5), 0.0);
        m.e_table = vec![vec![0.0; ALBEDO_MU]];
        m.inv_one_minus_eavg = vec![1.0];
        m.diffuse_on = Some(OrenNayarLobe::new(0.8));
        let on = crate::material::OrenNayar::new(SpectralParam::Constant(SampledSpectrum::splat(4, 0.6)), 0.8);
        let (mut a, mut b) = (SampledSpectrum::zeros(4), SampledSpectrum::zeros(4));
        for &(wo, wi) in &[(dir(0.3, 0.0), dir(1.0, 2.0)), (dir(1.2, 0.5), dir(0.4, 0.7))] {
            m.eval(&ctx, wo, wi, &mut a);
            on.eval(&ctx, wo, wi, &mut b);
            assert!((a.get(0) - b.get(0)).abs() < 1e-5 * b.get(0).max(1.0), "{} vs {}", a.get(0), b.get(0));
        }
    }

    #[test]
    fn f82_tint_white_is_schlick() {
        for k in 0..=10 {
            let c = k as f32 / 10.0;
            for &f0 in &[0.0f32, 0.5, 0.95] {
                assert!((f82_tint(c, f0, 1.0) - crate::material::fresnel::schlick(c, f0)).abs() < 1e-6);
            }
        }
        // The tint scales the value at cos θ = 1/7 (≈ 82°).
        let f0 = 0.6;
        let s = crate::material::fresnel::schlick(1.0 / 7.0, f0);
        assert!((f82_tint(1.0 / 7.0, f0, 0.5) - 0.5 * s).abs() < 1e-5);
    }
}
