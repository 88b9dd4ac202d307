//! The RGB method's three-lane "grid" (docs/design.md#rgb-mode): the scene is compiled with RGB
//! values instead of spectra, so materials and lights run unchanged on three lanes.
//!
//! - RGB given by the scene is used as given.
//! - Named or measured spectra are evaluated on the reference spectral grid and
//!   converted: reflectances to their RGB as seen under D65 (normalised so a flat 1 is
//!   (1,1,1)), illuminants to their own RGB (CIE observer → XYZ → the working space),
//!   other curves (indices of refraction) to their values at 620, 540 and 460 nm.
//! - The observer of an RGB grid is the working space's RGB → XYZ matrix, so the film
//!   writes the channels back as linear RGB unchanged.
//!
//! The grid is made from an RGB space in `color::rgb_grid` (colour depends on spectra,
//! not the other way round).

use super::grid::WavelengthGrid;
use super::named::{interpolate, RgbToSpectrum, SpectrumDesc, SpectrumKind, SpectrumRole};

/// Wavelengths the R, G and B lanes stand for at dispersive surfaces (nm).
pub const RGB_LAMBDAS: [f32; 3] = [620.0, 540.0, 460.0];

#[derive(Clone, Debug, PartialEq)]
pub struct RgbChannels {
    /// The spectral grid named spectra are evaluated on before conversion.
    pub reference: WavelengthGrid,
    /// Reflectance → RGB under D65, rows per channel over the reference grid.
    pub reflectance_rows: [Vec<f64>; 3],
    /// Radiance → RGB, rows per channel over the reference grid.
    pub illuminant_rows: [Vec<f64>; 3],
    pub rgb_to_xyz: [[f64; 3]; 3],
}

impl RgbChannels {
    /// The RGB (three lanes) of a spectrum description in `role`.
    pub fn evaluate(
        &self,
        desc: &SpectrumDesc,
        role: SpectrumRole,
        uplift: &dyn RgbToSpectrum,
    ) -> std::result::Result<Vec<f32>, String> {
        let v: Vec<f32> = match &desc.kind {
            SpectrumKind::Rgb { rgb } => {
                if !rgb.iter().all(|c| c.is_finite()) || !desc.scale.is_finite() {
                    return Err(format!("RGB {rgb:?} is not finite"));
                }
                rgb.iter().map(|c| c * desc.scale).collect()
            }
            _ => {
                let s = desc.evaluate(&self.reference, role, uplift)?;
                let fold = |rows: &[Vec<f64>; 3]| -> Vec<f32> {
                    rows.iter()
                        .map(|row| row.iter().zip(&s).map(|(a, &b)| a * b as f64).sum::<f64>() as f32)
                        // Out-of-gamut colours (narrow bands) have negative components: clip.
                        .map(|c| c.max(0.0))
                        .collect()
                };
                match role {
                    SpectrumRole::Reflectance => fold(&self.reflectance_rows).into_iter().map(|c| c.min(1.0)).collect(),
                    SpectrumRole::Illuminant => fold(&self.illuminant_rows),
                    SpectrumRole::Unbounded => {
                        RGB_LAMBDAS.iter().map(|&l| interpolate(self.reference.lambdas(), &s, l)).collect()
                    }
                }
            }
        };
        if role != SpectrumRole::Unbounded {
            if let Some(x) = v.iter().find(|x| **x < 0.0) {
                return Err(format!("RGB component {x} is negative"));
            }
        }
        Ok(v)
    }
}
