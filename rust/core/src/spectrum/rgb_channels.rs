//! The RGB method's three-lane "grid" (SPEC §3.4): the scene is compiled with RGB
//! values instead of spectra, so materials and lights run unchanged on three lanes.
//!
//! - RGB given by the scene is used as given.
//! - Named or measured spectra are evaluated on the reference spectral grid and
//!   converted: reflectances to their RGB as seen under D65 (normalised so a flat 1 is
//!   (1,1,1)), illuminants to their own RGB (CIE observer → XYZ → the working space),
//!   other curves (indices of refraction) to their values at 620, 540 and 460 nm.
//! - The observer of an RGB grid is the working space's RGB → XYZ matrix, so the film
//!   writes the channels back as linear RGB unchanged.

use super::grid::WavelengthGrid;
use super::named::{interpolate, RgbToSpectrum, SpectrumDesc, SpectrumKind, SpectrumRole};
use crate::color::{Observer, RgbSpace};
use crate::{Error, Result};

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

struct NoRgb;
impl RgbToSpectrum for NoRgb {
    fn convert(&self, _: [f32; 3], _: SpectrumRole) -> Vec<f32> {
        Vec::new()
    }
}

impl WavelengthGrid {
    /// The three-lane grid of the RGB method, converting spectra through `reference`.
    pub fn rgb_channels(reference: &WavelengthGrid, space: &RgbSpace) -> Result<WavelengthGrid> {
        let reference = reference.spectral().clone();
        let obs = Observer::new(&reference);
        let d65 = SpectrumDesc::new(SpectrumKind::D65)
            .evaluate(&reference, SpectrumRole::Illuminant, &NoRgb)
            .map_err(|p| Error::setting("wavelengths", format!("D65 on the grid: {p}")))?;
        let n = reference.len();
        let mut illum: [Vec<f64>; 3] = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
        let mut refl: [Vec<f64>; 3] = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
        for i in 0..n {
            let rgb = space.xyz_to_rgb([obs.x[i] as f64, obs.y[i] as f64, obs.z[i] as f64]);
            for c in 0..3 {
                illum[c][i] = rgb[c];
                refl[c][i] = rgb[c] * d65[i] as f64;
            }
        }
        for row in refl.iter_mut() {
            let sum: f64 = row.iter().sum();
            if !(sum.abs() > 1e-12) {
                return Err(Error::setting(
                    "wavelength_count",
                    "the grid does not cover enough of the visible range for the RGB method",
                ));
            }
            row.iter_mut().for_each(|v| *v /= sum);
        }
        let m = space.rgb_to_xyz;
        let luminance = [m[1][0] as f32, m[1][1] as f32, m[1][2] as f32];
        Ok(WavelengthGrid::from_rgb_channels(
            RgbChannels { reference, reflectance_rows: refl, illuminant_rows: illum, rgb_to_xyz: m },
            luminance,
        ))
    }
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

    /// The observer of the RGB grid: channel c contributes column c of RGB → XYZ.
    pub fn observer(&self) -> Observer {
        let m = &self.rgb_to_xyz;
        let row = |k: usize| (0..3).map(|c| m[k][c] as f32).collect::<Vec<f32>>();
        Observer { x: row(0), y: row(1), z: row(2) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rgb_grid_round_trips_rgb_and_converts_named_spectra() {
        let space = RgbSpace::rec709();
        let g = WavelengthGrid::rgb_channels(&WavelengthGrid::default(), &space).unwrap();
        assert_eq!(g.len(), 3);
        let d = SpectrumDesc::new(SpectrumKind::Rgb { rgb: [0.2, 0.5, 0.9] });
        assert_eq!(d.evaluate(&g, SpectrumRole::Reflectance, &NoRgb).unwrap(), vec![0.2, 0.5, 0.9]);
        // A flat reflectance is grey; D65 of luminance 1 is white (1,1,1).
        let grey = SpectrumDesc::constant(0.5).evaluate(&g, SpectrumRole::Reflectance, &NoRgb).unwrap();
        assert!(grey.iter().all(|c| (c - 0.5).abs() < 1e-5), "{grey:?}");
        let e = SpectrumDesc::new(SpectrumKind::D65).evaluate(&g, SpectrumRole::Illuminant, &NoRgb).unwrap();
        let obs = Observer::new(&g);
        let xyz = obs.xyz(&e);
        let rgb = space.xyz_to_rgb(xyz);
        for c in 0..3 {
            assert!((rgb[c] - e[c] as f64).abs() < 1e-5);
            assert!((e[c] as f64 / xyz[1] - 1.0).abs() < 5e-3, "{e:?} {xyz:?}");
        }
    }
}
