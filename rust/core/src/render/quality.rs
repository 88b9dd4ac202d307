//! Quality presets: what `quality` fills in for every setting the user did not set.
//!
//! `quality` fills `samples`, `max_bounces`, `noise_threshold` and the wavelength grid
//! when they are unset (`None` in [`RenderSettings`]: absent or null in JSON); a value
//! given always wins. [`resolve`] turns the settings into the [`ResolvedSettings`] the
//! renderer takes.
//!
//! AUTO models only what the scene requires: the wavelength grid fitted to the scene's
//! spectra ([`super::auto_grid`]) and adaptive sampling to a per-pixel error target
//! ([`super::adaptive`]). No wavelength-collapse machinery runs where nothing disperses
//! (a non-dispersive BSDF never reports `collapsed_to`); the reason list says whether
//! the scene disperses.

use super::adaptive::{adaptive_supported, ADAPTIVE_MIN_SAMPLES};
use super::settings::{Filled, RenderSettings, ResolvedSettings};
use super::Method;
use crate::scene::SceneDesc;
use crate::spectrum::WavelengthGrid;
use crate::Result;
use serde::{Deserialize, Serialize};

pub use super::auto_grid::{auto_grid, GRID_TOLERANCE};

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
            Quality::Final => Preset {
                samples: 256,
                noise_threshold: 0.0,
                max_bounces: 8,
                wavelength_count: Some(PAPER_WAVELENGTH_COUNT),
            },
            Quality::Reference => {
                Preset { samples: 2048, noise_threshold: 0.0, max_bounces: 16, wavelength_count: Some(81) }
            }
        }
    }
}

/// The grid when there is nothing to fit it to (AUTO without a scene; the RGB method,
/// whose grid only converts named spectra): the paper's 41 samples.
pub const PAPER_WAVELENGTH_COUNT: usize = 41;

/// The settings the render runs with: `settings` validated, with every unset field
/// filled by its quality preset (and, for AUTO, from the scene `desc`), the grid built,
/// and the reasons in `notes`.
pub fn resolve(settings: &RenderSettings, desc: Option<&SceneDesc>) -> Result<ResolvedSettings> {
    settings.validate()?;
    super::settings::check_region(settings)?;
    let s = settings;
    let q = s.quality;
    let p = q.preset();
    let mut why = Vec::new();
    let samples = s.samples.unwrap_or_else(|| {
        why.push(format!(
            "samples {} ({} preset{})",
            p.samples,
            q.name(),
            if p.noise_threshold > 0.0 { ", the maximum per pixel" } else { "" }
        ));
        p.samples
    });
    let max_bounces = s.max_bounces.unwrap_or(p.max_bounces);
    let noise_threshold = s.noise_threshold.unwrap_or_else(|| {
        // An explicit sample count is a request for that many samples: no early stop
        // unless noise_threshold is given too.
        let t = if s.samples.is_none() { p.noise_threshold } else { 0.0 };
        if t > 0.0 {
            why.push(format!(
                "adaptive: a pixel stops at estimated ΔE00 ≤ {} after ≥ {ADAPTIVE_MIN_SAMPLES} samples",
                p.noise_threshold
            ));
        } else if p.noise_threshold > 0.0 {
            why.push("adaptive off: samples set explicitly (set noise_threshold too for adaptive sampling)".into());
        }
        t
    });
    if noise_threshold > 0.0 && !adaptive_supported(s.method, s.direction) {
        why.push(format!("adaptive sampling off: {:?} {:?} renders fixed sample counts", s.method, s.direction));
    }
    let uniform = |n| WavelengthGrid::uniform(n, s.wavelength_min, s.wavelength_max);
    let grid = match (&s.wavelengths, s.wavelength_count) {
        (Some(list), _) => WavelengthGrid::from_wavelengths(list.clone())?,
        (None, Some(n)) => uniform(n)?,
        (None, None) => match (p.wavelength_count, desc) {
            (Some(n), _) => {
                why.push(format!("{n} uniform wavelengths ({} preset)", q.name()));
                uniform(n)?
            }
            (None, Some(d)) if s.method != Method::Rgb => {
                let (lambdas, reasons) = auto_grid(d, s.wavelength_min, s.wavelength_max, s.uplift)?;
                why.extend(reasons);
                WavelengthGrid::from_wavelengths(lambdas)?
            }
            (None, Some(_)) => {
                why.push("RGB method: the 41-sample grid only converts named spectra".into());
                uniform(PAPER_WAVELENGTH_COUNT)?
            }
            (None, None) => {
                why.push("no scene description to fit the grid to: 41 uniform wavelengths".into());
                uniform(PAPER_WAVELENGTH_COUNT)?
            }
        },
    };
    Ok(s.assemble(Filled { samples, noise_threshold, max_bounces }, grid, why))
}
