//! Quality presets and what AUTO chooses per scene (issue 9).
//!
//! `quality` fills every setting the user did not set explicitly: `samples`,
//! `max_bounces`, `noise_threshold` and the wavelength grid. "Explicitly set" is known
//! from the settings' JSON (a key present is explicit, see
//! [`RenderSettings::from_json`]); a `RenderSettings` built in Rust has `explicit: None`,
//! meaning every field is explicit, so Rust callers keep exactly what they wrote.
//!
//! AUTO models only what the scene requires:
//! - the wavelength grid is the coarsest uniform grid (8..81 samples) on which every
//!   (emitter × reflectance) pair of the scene keeps its colour within [`GRID_TOLERANCE`]
//!   ΔE00 of a 1 nm reference, with extra samples at `centre + k·σ` (k = −3..3) around
//!   every narrow-band emitter narrower than the grid step, so its colour is not moved to
//!   the nearest uniform sample; scenes with RGB data keep a grid the uplift accepts;
//! - adaptive sampling with a per-pixel error target (ΔE): a pixel stops when the
//!   estimated CIELAB difference of its mean from the converged value is below
//!   `noise_threshold` (see [`pixel_error`]);
//! - no wavelength-collapse machinery runs where nothing disperses (a non-dispersive BSDF
//!   never reports `collapsed_to`); the reason list says whether the scene disperses.

use super::{Method, RenderSettings};
use crate::color::uplift::{Uplift, UpliftMethod};
use crate::color::{Observer, RgbSpace};
use crate::scene::SceneDesc;
use crate::spectrum::named::{RgbToSpectrum, SpectrumKind, SpectrumRole};
use crate::spectrum::{SpectrumDesc, WavelengthGrid};
use crate::Result;
use serde::{Deserialize, Serialize};

/// Speed against accuracy; explicit settings override what a preset fills in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "SCREAMING_SNAKE_CASE")]
pub enum Quality {
    /// Chosen per scene: scene-fitted wavelength grid, adaptive sampling to ΔE 1.
    #[default]
    Auto,
    /// Fast look: 16 wavelengths, ≤ 32 spp stopping at ΔE 3, 4 bounces.
    Preview,
    /// Fixed: the paper's 41-sample grid, 256 spp, 8 bounces, no adaptive stop.
    Final,
    /// Converged reference: 81 wavelengths, 2048 spp, 16 bounces, no adaptive stop.
    Reference,
}

/// What a preset sets for the fields left to it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Preset {
    /// Samples per pixel (the maximum when adaptive).
    pub samples: u32,
    /// Target per-pixel ΔE; 0 is no adaptive stop.
    pub noise_threshold: f32,
    pub max_bounces: u32,
    /// Uniform grid size; None: fitted to the scene (AUTO).
    pub wavelength_count: Option<usize>,
}

impl Quality {
    /// The setting's value as written in JSON, Python, the CLI and Blender.
    pub fn name(self) -> &'static str {
        match self {
            Quality::Auto => "AUTO",
            Quality::Preview => "PREVIEW",
            Quality::Final => "FINAL",
            Quality::Reference => "REFERENCE",
        }
    }
    pub fn preset(self) -> Preset {
        match self {
            Quality::Auto => Preset { samples: 1024, noise_threshold: 1.0, max_bounces: 8, wavelength_count: None },
            Quality::Preview => {
                Preset { samples: 32, noise_threshold: 3.0, max_bounces: 4, wavelength_count: Some(16) }
            }
            Quality::Final => Preset { samples: 256, noise_threshold: 0.0, max_bounces: 8, wavelength_count: Some(41) },
            Quality::Reference => {
                Preset { samples: 2048, noise_threshold: 0.0, max_bounces: 16, wavelength_count: Some(81) }
            }
        }
    }
}

/// Largest colour error (ΔE00, white at L* = 100) AUTO's grid may make on any
/// emitter × reflectance pair of the scene, against a 1 nm grid.
pub const GRID_TOLERANCE: f64 = 0.3;
/// Uniform grid sizes AUTO tries, coarsest first.
const CANDIDATES: [usize; 8] = [8, 12, 16, 24, 32, 41, 61, 81];
/// Samples a pixel takes before the adaptive test may stop it.
pub const ADAPTIVE_MIN_SAMPLES: u32 = 16;

/// The settings the render runs with: `settings` with every non-explicit field filled
/// by its quality preset (and, for AUTO, from the scene `desc`), plus the reasons.
pub fn resolve(settings: &RenderSettings, desc: Option<&SceneDesc>) -> Result<(RenderSettings, Vec<String>)> {
    let mut s = settings.clone();
    let mut why = Vec::new();
    if settings.explicit.is_none() {
        return Ok((s, why));
    }
    let q = settings.quality;
    let p = q.preset();
    let free = |k: &str| !settings.is_explicit(k);
    if free("samples") {
        s.samples = p.samples;
        why.push(format!(
            "samples {} ({} preset{})",
            p.samples,
            q.name(),
            if p.noise_threshold > 0.0 { ", the maximum per pixel" } else { "" }
        ));
    }
    if free("max_bounces") {
        s.max_bounces = p.max_bounces;
    }
    if free("noise_threshold") {
        // An explicit sample count is a request for that many samples: no early stop
        // unless noise_threshold is given too.
        s.noise_threshold = if free("samples") { p.noise_threshold } else { 0.0 };
        if s.noise_threshold > 0.0 {
            why.push(format!(
                "adaptive: a pixel stops at estimated ΔE00 ≤ {} after ≥ {ADAPTIVE_MIN_SAMPLES} samples",
                p.noise_threshold
            ));
        } else if p.noise_threshold > 0.0 {
            why.push("adaptive off: samples set explicitly (set noise_threshold too for adaptive sampling)".into());
        }
    }
    if s.noise_threshold > 0.0 && !adaptive_supported(&s) {
        why.push(format!("adaptive sampling off: {:?} {:?} renders fixed sample counts", s.method, s.direction));
    }
    if free("wavelengths") && free("wavelength_count") {
        match (p.wavelength_count, desc) {
            (Some(n), _) => {
                s.wavelengths = None;
                s.wavelength_count = n;
                why.push(format!("{n} uniform wavelengths ({} preset)", q.name()));
            }
            (None, Some(d)) if s.method != Method::Rgb => {
                let (lambdas, reasons) = auto_grid(d, s.wavelength_min, s.wavelength_max, s.uplift)?;
                s.wavelengths = Some(lambdas);
                why.extend(reasons);
            }
            (None, Some(_)) => why.push("RGB method: the 41-sample grid only converts named spectra".into()),
            (None, None) => why.push("prebuilt scene: its grid is kept".into()),
        }
    }
    Ok((s, why))
}

/// Whether adaptive sampling applies: camera paths only (light paths are not per pixel),
/// and not image-per-wavelength rendering.
pub fn adaptive_supported(s: &RenderSettings) -> bool {
    s.direction == super::Direction::Backward && s.method != Method::MonochromaticScenes
}

/// A spectrum of the scene and whether it emits.
struct Found {
    spectrum: SpectrumDesc,
    emitter: bool,
}

/// What the scene description holds that decides the grid.
#[derive(Default)]
struct Holds {
    /// RGB data (RGB spectra or textures): judged through a fixed set of RGB colours, so
    /// the same colour given as RGB or as a one-texel texture gets the same grid.
    rgb: bool,
    /// A dielectric whose index varies with wavelength.
    dispersive: bool,
}

fn collect(v: &serde_json::Value, key: &str, out: &mut Vec<Found>, holds: &mut Holds) {
    match v {
        serde_json::Value::Object(m) => {
            if m.contains_key("type") {
                if let Ok(sd) = serde_json::from_value::<SpectrumDesc>(v.clone()) {
                    let emitter = matches!(key, "emission" | "intensity" | "irradiance" | "radiance");
                    let ignored = matches!(key, "eta" | "k" | "ior" | "index");
                    if matches!(sd.kind, SpectrumKind::Texture { .. } | SpectrumKind::Rgb { .. }) {
                        holds.rgb |= !ignored;
                    } else if !ignored {
                        out.push(Found { spectrum: sd, emitter });
                    }
                    return;
                }
            }
            if m.get("type").and_then(|t| t.as_str()) == Some("dielectric") {
                let constant = match m.get("ior") {
                    None => true,
                    Some(serde_json::Value::Number(_)) => true,
                    Some(serde_json::Value::Object(o)) => o.get("type").and_then(|t| t.as_str()) == Some("constant"),
                    Some(_) => false,
                };
                holds.dispersive |= !constant;
            }
            for (k, x) in m {
                collect(x, k, out, holds);
            }
        }
        serde_json::Value::Array(a) => a.iter().for_each(|x| collect(x, key, out, holds)),
        _ => {}
    }
}

struct Flat;
impl RgbToSpectrum for Flat {
    fn convert(&self, rgb: [f32; 3], _: SpectrumRole) -> Vec<f32> {
        vec![(rgb[0] + rgb[1] + rgb[2]) / 3.0; 1]
    }
}

fn lab(xyz: [f64; 3]) -> [f64; 3] {
    const W: [f64; 3] = [0.950_47, 1.0, 1.088_83];
    let f = |t: f64| {
        if t > 216.0 / 24389.0 {
            t.cbrt()
        } else {
            (24389.0 / 27.0 * t + 16.0) / 116.0
        }
    };
    let (fx, fy, fz) = (f(xyz[0] / W[0]), f(xyz[1] / W[1]), f(xyz[2] / W[2]));
    [116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)]
}

/// CIEDE2000 (Sharma, Wu & Dalal 2005) between two CIELAB colours.
pub fn de2000(l1: [f64; 3], l2: [f64; 3]) -> f64 {
    use std::f64::consts::PI;
    let (c1, c2) = (l1[1].hypot(l1[2]), l2[1].hypot(l2[2]));
    let cm = 0.5 * (c1 + c2);
    let g = 0.5 * (1.0 - (cm.powi(7) / (cm.powi(7) + 25f64.powi(7))).sqrt());
    let (a1, a2) = ((1.0 + g) * l1[1], (1.0 + g) * l2[1]);
    let (c1, c2) = (a1.hypot(l1[2]), a2.hypot(l2[2]));
    let hue = |b: f64, a: f64| {
        if a == 0.0 && b == 0.0 {
            0.0
        } else {
            b.atan2(a).rem_euclid(2.0 * PI)
        }
    };
    let (h1, h2) = (hue(l1[2], a1), hue(l2[2], a2));
    let dl = l2[0] - l1[0];
    let dc = c2 - c1;
    let dh = if c1 * c2 == 0.0 {
        0.0
    } else {
        let d = h2 - h1;
        if d > PI {
            d - 2.0 * PI
        } else if d < -PI {
            d + 2.0 * PI
        } else {
            d
        }
    };
    let dhh = 2.0 * (c1 * c2).sqrt() * (dh / 2.0).sin();
    let lm = 0.5 * (l1[0] + l2[0]);
    let cm = 0.5 * (c1 + c2);
    let hm = if c1 * c2 == 0.0 {
        h1 + h2
    } else if (h1 - h2).abs() <= PI {
        0.5 * (h1 + h2)
    } else if h1 + h2 < 2.0 * PI {
        0.5 * (h1 + h2 + 2.0 * PI)
    } else {
        0.5 * (h1 + h2 - 2.0 * PI)
    };
    let t = 1.0 - 0.17 * (hm - PI / 6.0).cos() + 0.24 * (2.0 * hm).cos() + 0.32 * (3.0 * hm + PI / 30.0).cos()
        - 0.20 * (4.0 * hm - 63f64.to_radians()).cos();
    let dtheta = 30f64.to_radians() * (-((hm.to_degrees() - 275.0) / 25.0).powi(2)).exp();
    let rc = 2.0 * (cm.powi(7) / (cm.powi(7) + 25f64.powi(7))).sqrt();
    let sl = 1.0 + 0.015 * (lm - 50.0).powi(2) / (20.0 + (lm - 50.0).powi(2)).sqrt();
    let sc = 1.0 + 0.045 * cm;
    let sh = 1.0 + 0.015 * cm * t;
    let rt = -(2.0 * dtheta).sin() * rc;
    let (x, y, z) = (dl / sl, dc / sc, dhh / sh);
    (x * x + y * y + z * z + rt * y * z).max(0.0).sqrt()
}

/// Spectra evaluated on one grid: emitters and reflectances.
struct OnGrid {
    observer: Observer,
    emitters: Vec<Vec<f32>>,
    reflectances: Vec<Vec<f32>>,
}

fn on_grid(grid: &WavelengthGrid, found: &[Found], rgb_samples: &[[f32; 3]], uplift: UpliftMethod) -> Option<OnGrid> {
    let up = Uplift::new(grid, &RgbSpace::rec709(), uplift).ok();
    let needs_uplift = !rgb_samples.is_empty();
    if needs_uplift && up.is_none() {
        return None;
    }
    let conv: &dyn RgbToSpectrum = match &up {
        Some(u) => u,
        None => &Flat,
    };
    let mut emitters = Vec::new();
    let mut reflectances = vec![vec![1.0; grid.len()]];
    for f in found {
        let role = if f.emitter { SpectrumRole::Illuminant } else { SpectrumRole::Unbounded };
        let v = f.spectrum.evaluate(grid, role, conv).ok()?;
        if f.emitter {
            emitters.push(v);
        } else {
            reflectances.push(v);
        }
    }
    for &rgb in rgb_samples {
        reflectances.push(conv.convert(rgb, SpectrumRole::Reflectance));
    }
    if emitters.is_empty() {
        // No named emitter (e.g. only an HDRI): judge reflectances under D65.
        emitters.push(SpectrumDesc::new(SpectrumKind::D65).evaluate(grid, SpectrumRole::Illuminant, conv).ok()?);
    }
    Some(OnGrid { observer: Observer::new(grid), emitters, reflectances })
}

/// Largest ΔE00 between the colours of every emitter × reflectance pair on `a` and on
/// the reference `r`, each pair normalised so the emitter alone has Y = 1.
fn max_error(a: &OnGrid, r: &OnGrid) -> f64 {
    let mut worst = 0.0f64;
    for (ea, er) in a.emitters.iter().zip(&r.emitters) {
        let ya = a.observer.xyz(ea)[1];
        let yr = r.observer.xyz(er)[1];
        if !(ya > 0.0 && yr > 0.0) {
            continue;
        }
        for (ra, rr) in a.reflectances.iter().zip(&r.reflectances) {
            let pa: Vec<f32> = ea.iter().zip(ra).map(|(e, x)| e * x).collect();
            let pr: Vec<f32> = er.iter().zip(rr).map(|(e, x)| e * x).collect();
            // Normalised by the reference emitter's luminance: an energy error shows.
            let xa = a.observer.xyz(&pa).map(|v| v / yr);
            let xr = r.observer.xyz(&pr).map(|v| v / yr);
            worst = worst.max(de2000(lab(xa), lab(xr)));
        }
    }
    worst
}

/// Narrow bands (centre, σ) of the scene's emitters.
fn narrow_bands(found: &[Found]) -> Vec<(f32, f32)> {
    found
        .iter()
        .filter(|f| f.emitter)
        .filter_map(|f| match f.spectrum.kind {
            SpectrumKind::NarrowBand { center, width } if center.is_finite() && width > 0.0 => {
                Some((center, width / (8.0 * std::f32::consts::LN_2).sqrt()))
            }
            _ => None,
        })
        .collect()
}

/// A uniform grid of `n` samples on [min, max] with samples at c + k·σ (k = −3..3)
/// around each narrow band narrower than the grid step (uniform samples within 3.5σ of
/// the centre dropped).
fn refined(n: usize, min: f32, max: f32, bands: &[(f32, f32)]) -> Vec<f32> {
    let step = (max - min) / (n - 1) as f32;
    let mut l: Vec<f32> = (0..n).map(|i| min + step * i as f32).collect();
    for &(c, sigma) in bands {
        if 2.355 * sigma >= 2.0 * step || c < min || c > max {
            continue;
        }
        let sigma = sigma.max(0.02);
        l.retain(|&x| (x - c).abs() > 3.5 * sigma || x == min || x == max);
        for k in -3..=3 {
            let x = c + k as f32 * sigma;
            if x > min && x < max {
                l.push(x);
            }
        }
    }
    l.sort_by(|a, b| a.total_cmp(b));
    l.dedup_by(|a, b| (*a - *b).abs() < 0.01);
    l.truncate(crate::spectrum::grid::MAX_SAMPLES);
    l
}

/// AUTO's grid for a scene: the coarsest candidate within [`GRID_TOLERANCE`], refined
/// around narrow-band emitters, and the reasons.
pub fn auto_grid(desc: &SceneDesc, min: f32, max: f32, uplift: UpliftMethod) -> Result<(Vec<f32>, Vec<String>)> {
    let v =
        serde_json::to_value(desc).map_err(|e| crate::Error::setting("quality", format!("scene description: {e}")))?;
    let mut found = Vec::new();
    let mut holds = Holds::default();
    collect(&v, "", &mut found, &mut holds);
    // RGB data stands for arbitrary RGB: judge a few saturated colours.
    let rgb_samples: Vec<[f32; 3]> =
        if holds.rgb { vec![[0.8, 0.1, 0.1], [0.1, 0.8, 0.1], [0.1, 0.1, 0.8], [0.8, 0.8, 0.1]] } else { Vec::new() };
    let bands = narrow_bands(&found);
    let mut why = Vec::new();
    let n_ref =
        (((max - min) as usize) + 1).clamp(crate::spectrum::grid::MIN_SAMPLES, crate::spectrum::grid::MAX_SAMPLES);
    let fallback = || WavelengthGrid::uniform(41, min, max).map(|g| g.lambdas().to_vec());
    let reference = WavelengthGrid::uniform(n_ref, min, max)?;
    let Some(r) = on_grid(&reference, &found, &rgb_samples, uplift) else {
        why.push("grid: 41 uniform (the scene's spectra could not be judged on a 1 nm grid)".into());
        return Ok((fallback()?, why));
    };
    let mut best: Option<(Vec<f32>, f64, usize)> = None;
    // Dispersion spreads the wavelengths apart in space: a coarse grid would show as
    // separate coloured copies (banding) instead of a continuous spread.
    let floor = if holds.dispersive { 41 } else { 0 };
    for n in CANDIDATES.into_iter().filter(|&n| n >= floor) {
        let lambdas = refined(n, min, max, &bands);
        let Ok(g) = WavelengthGrid::from_wavelengths(lambdas.clone()) else {
            continue;
        };
        let Some(a) = on_grid(&g, &found, &rgb_samples, uplift) else {
            continue;
        };
        let err = max_error(&a, &r);
        if err <= GRID_TOLERANCE {
            best = Some((lambdas, err, n));
            break;
        }
        best = match best {
            Some(b) if b.1 <= err => Some(b),
            _ => Some((lambdas, err, n)),
        };
    }
    let Some((lambdas, err, n)) = best else {
        why.push("grid: 41 uniform (no candidate grid could be built)".into());
        return Ok((fallback()?, why));
    };
    why.push(format!(
        "grid: {} wavelengths ({} uniform{}): largest emitter×reflectance colour error {:.2} ΔE00 vs 1 nm{}",
        lambdas.len(),
        n,
        if bands.is_empty() { String::new() } else { format!(" + 7 around each of {} narrow band(s)", bands.len()) },
        err,
        if err > GRID_TOLERANCE { format!(" (above the {GRID_TOLERANCE} target even at 81)") } else { String::new() },
    ));
    if holds.dispersive {
        why.push("dispersive glass: at least 41 wavelengths, and wavelength collapse (eq. 9) at it".into());
    } else {
        why.push("nothing disperses: no path ever collapses to one wavelength".into());
    }
    if holds.rgb {
        why.push(format!("RGB data: the grid keeps the {uplift:?} uplift valid"));
    }
    Ok((lambdas, why))
}

/// Estimated ΔE00 of a pixel's mean from its converged value, from the sums of its
/// first half of samples `a` (count `na`) and of all samples `all` (count `n`): the two
/// halves' means differ by twice the full mean's error in distribution (A − B has 4× the
/// variance of the mean), so half their CIEDE2000 difference is one draw of the pixel's
/// error. CIELAB uses a D65 white of Y = 1, as `polychrome.colordiff.image_delta_e`.
pub fn pixel_error(a: [f64; 3], na: u32, all: [f64; 3], n: u32) -> f64 {
    if na == 0 || n <= na {
        return f64::INFINITY;
    }
    let ma = a.map(|v| v / na as f64);
    let mb = [0, 1, 2].map(|k| (all[k] - a[k]) / (n - na) as f64);
    let e = 0.5 * de2000(lab(ma), lab(mb));
    if e.is_finite() {
        e
    } else {
        f64::INFINITY
    }
}

/// After a pass: refreshes the error estimate of every active pixel and stops those
/// whose 3×3 neighbourhood's mean estimate is within `threshold` and whose own is within
/// twice it (one estimate is a single noisy draw; the neighbourhood averages nine). `ready`: enough samples for a decision.
#[allow(clippy::too_many_arguments)]
pub fn update_active(
    active: &mut [bool],
    err: &mut [f64],
    half: &[[f64; 3]],
    half_count: &[u32],
    all: &[[f64; 3]],
    count: &[u32],
    w: u32,
    h: u32,
    threshold: f64,
    ready: bool,
) {
    for i in 0..active.len() {
        if active[i] {
            err[i] = pixel_error(half[i], half_count[i], all[i], count[i]);
        }
    }
    if !ready {
        return;
    }
    let (w, h) = (w as i64, h as i64);
    let stop: Vec<usize> = (0..active.len())
        .filter(|&i| active[i])
        .filter(|&i| {
            let (x, y) = (i as i64 % w, i as i64 / w);
            let (mut sum, mut k) = (0.0f64, 0u32);
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let (nx, ny) = (x + dx, y + dy);
                    if nx >= 0 && ny >= 0 && nx < w && ny < h {
                        sum += err[(ny * w + nx) as usize];
                        k += 1;
                    }
                }
            }
            sum / k as f64 <= threshold && err[i] <= 2.0 * threshold
        })
        .collect();
    for i in stop {
        active[i] = false;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pixel_error_is_half_the_halves_difference() {
        let x = [0.2, 0.3, 0.25];
        assert_eq!(pixel_error([0.2, 0.3, 0.25], 1, [0.4, 0.6, 0.5], 2), 0.0);
        let e = pixel_error(x, 1, [0.4, 0.62, 0.5], 2);
        let expected = 0.5 * de2000(lab(x), lab([0.2, 0.32, 0.25]));
        assert!((e - expected).abs() < 1e-12 && e > 0.0);
        assert!(pixel_error(x, 0, x, 0).is_infinite());
    }

    #[test]
    fn ciede2000_matches_sharma_2005() {
        // Pairs 1, 7 and 17 of Sharma, Wu & Dalal's test data.
        assert!((de2000([50.0, 2.6772, -79.7751], [50.0, 0.0, -82.7485]) - 2.0425).abs() < 1e-4);
        assert!((de2000([50.0, 0.0, 0.0], [50.0, -1.0, 2.0]) - 2.3669).abs() < 1e-4);
        assert!((de2000([50.0, 2.5, 0.0], [73.0, 25.0, -18.0]) - 27.1492).abs() < 1e-4);
    }

    #[test]
    fn refinement_brackets_a_narrow_band() {
        // σ = 1 nm: samples at 586..592 every nm replace the uniform ones within 3.5σ.
        let l = refined(41, 380.0, 780.0, &[(589.0, 1.0)]);
        let near: Vec<f32> = l.iter().copied().filter(|x| (x - 589.0).abs() < 3.5).collect();
        assert_eq!(near, vec![586.0, 587.0, 588.0, 589.0, 590.0, 591.0, 592.0]);
        assert!(l.contains(&580.0) && l.contains(&600.0));
        assert!(l.windows(2).all(|w| w[0] < w[1]));
        // A band wider than two grid steps needs no refinement.
        assert_eq!(refined(41, 380.0, 780.0, &[(589.0, 10.0)]).len(), 41);
    }
}
