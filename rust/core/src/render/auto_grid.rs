//! AUTO's wavelength grid: the coarsest uniform grid (8..81 samples) on which every
//! (emitter × reflectance) pair of the scene keeps its colour within [`GRID_TOLERANCE`]
//! ΔE00 of a 1 nm reference, with extra samples at `centre + k·σ` (k = −3..3) around
//! every narrow-band emitter narrower than the grid step, so its colour is not moved to
//! the nearest uniform sample; scenes with RGB data keep a grid the uplift accepts.

use crate::color::delta_e::{de2000, lab};
use crate::color::uplift::{Uplift, UpliftMethod};
use crate::color::{Observer, RgbSpace};
use crate::scene::SceneDesc;
use crate::spectrum::named::{RgbToSpectrum, SpectrumKind, SpectrumRole};
use crate::spectrum::{SpectrumDesc, WavelengthGrid};
use crate::Result;

/// Largest colour error (ΔE00, white at L* = 100) AUTO's grid may make on any
/// emitter × reflectance pair of the scene, against a 1 nm grid.
pub const GRID_TOLERANCE: f64 = 0.3;
/// Uniform grid sizes AUTO tries, coarsest first.
const CANDIDATES: [usize; 8] = [8, 12, 16, 24, 32, 41, 61, 81];

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
#[cfg(test)]
mod tests {
    use super::*;

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
