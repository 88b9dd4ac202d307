//! Spectra a scene can name, and their evaluation on a wavelength grid.
//!
//! Tabulated data (measured spectra, CIE illuminants) are resampled by averaging the
//! piecewise-linear curve over each sample's cell, not by point sampling, so a narrow
//! peak between two grid samples keeps its energy (docs/design.md#spectra).

use super::grid::WavelengthGrid;
use super::tables;
use crate::{Error, Result};
use serde::{Deserialize, Serialize};

/// A spectrum as a scene describes it, independent of the render's grid.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SpectrumDesc {
    #[serde(flatten)]
    pub kind: SpectrumKind,
    /// Multiplies the whole spectrum.
    #[serde(default = "one")]
    pub scale: f32,
}

fn one() -> f32 {
    1.0
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum SpectrumKind {
    /// The same value at every wavelength.
    Constant { value: f32 },
    /// Planck's law at `temperature` kelvin, normalised to 1 at its peak.
    Blackbody { temperature: f32 },
    /// CIE standard illuminant D65, normalised to 1 at 560 nm.
    D65,
    /// CIE standard illuminant A (Planckian, 2856 K), normalised to 1 at 560 nm.
    A,
    /// Equal-energy illuminant E: 1 everywhere.
    E,
    /// CIE fluorescent illuminant F`index` (2, 7 or 11), normalised to 1 at 560 nm.
    Fluorescent { index: u32 },
    /// A Gaussian band of peak 1 around `center` nm with full width at half maximum `width` nm.
    NarrowBand { center: f32, width: f32 },
    /// Measured (wavelength nm, value) pairs, ascending; held constant beyond the ends.
    Tabulated { wavelengths: Vec<f32>, values: Vec<f32> },
    /// Scene RGB, converted by the render's RGB → spectrum map (eq. 10).
    Rgb { rgb: [f32; 3] },
    /// Texture `texture` of the scene's `textures` list, kept RGB and converted at each
    /// hit (docs/design.md#rgb-data). Only parameters that vary over a surface accept it (a diffuse
    /// reflectance); elsewhere it is an error.
    Texture { texture: usize },
}

/// What a spectrum stands for, which decides how RGB converts and what values are legal.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpectrumRole {
    /// A reflectance or transmittance: RGB in [0,1] gives values in [0,1].
    Reflectance,
    /// An emission or radiance: unbounded, non-negative.
    Illuminant,
    /// Any real-valued curve (e.g. an index of refraction).
    Unbounded,
}

/// Converts scene RGB to a spectrum on the render's grid (eq. 10); see `color::uplift`.
pub trait RgbToSpectrum {
    fn convert(&self, rgb: [f32; 3], role: SpectrumRole) -> Vec<f32>;
}

/// For evaluating spectra that hold no RGB (named illuminants, measured curves): an RGB
/// colour evaluated through it gets no values, which [`SpectrumDesc::evaluate`] reports
/// as an error naming the colour.
pub struct NoRgb;
impl RgbToSpectrum for NoRgb {
    fn convert(&self, _: [f32; 3], _: SpectrumRole) -> Vec<f32> {
        Vec::new()
    }
}

/// CIE D65 on `grid` (1 at 560 nm), the white of reflectances and of the RGB spaces.
pub fn d65(grid: &WavelengthGrid) -> std::result::Result<Vec<f32>, String> {
    SpectrumDesc::new(SpectrumKind::D65).evaluate(grid, SpectrumRole::Illuminant, &NoRgb)
}

impl SpectrumDesc {
    pub fn constant(value: f32) -> Self {
        Self { kind: SpectrumKind::Constant { value }, scale: 1.0 }
    }
    pub fn new(kind: SpectrumKind) -> Self {
        Self { kind, scale: 1.0 }
    }

    /// Values on `grid`; checks the description and the result.
    pub fn evaluate(
        &self,
        grid: &WavelengthGrid,
        role: SpectrumRole,
        uplift: &dyn RgbToSpectrum,
    ) -> std::result::Result<Vec<f32>, String> {
        if let Some(channels) = grid.rgb() {
            // The RGB method's three-lane grid: RGB as given, spectra converted.
            return channels.evaluate(self, role, uplift);
        }
        if !self.scale.is_finite() {
            return Err(format!("spectrum scale {} is not finite", self.scale));
        }
        let mut v: Vec<f32> = match &self.kind {
            SpectrumKind::Constant { value } => vec![*value; grid.len()],
            SpectrumKind::Blackbody { temperature } => {
                let t = *temperature;
                if !(t.is_finite() && t > 0.0) {
                    return Err(format!("blackbody temperature {t} K must be positive"));
                }
                let peak = blackbody(2.897_771_9e6 / t as f64, t as f64);
                grid.lambdas().iter().map(|&l| (blackbody(l as f64, t as f64) / peak) as f32).collect()
            }
            SpectrumKind::D65 => {
                let s = 1.0 / 100.0;
                resample_uniform(tables::D65_LAMBDA_MIN, tables::D65_LAMBDA_STEP, &tables::D65, grid, s)
            }
            SpectrumKind::A => {
                // CIE 015: S_A(λ) = 100 (560/λ)^5 (e^(1.435e7/(2848·560)) − 1)/(e^(1.435e7/(2848 λ)) − 1)
                let c = 1.435e7f64 / 2848.0;
                grid.lambdas()
                    .iter()
                    .map(|&l| {
                        let l = l as f64;
                        ((560.0 / l).powi(5) * ((c / 560.0).exp() - 1.0) / ((c / l).exp() - 1.0)) as f32
                    })
                    .collect()
            }
            SpectrumKind::E => vec![1.0; grid.len()],
            SpectrumKind::Fluorescent { index } => {
                let table: &[f32] = match index {
                    2 => &tables::FL2,
                    7 => &tables::FL7,
                    11 => &tables::FL11,
                    _ => return Err(format!("fluorescent illuminant F{index} is not available (2, 7, 11 are)")),
                };
                let at560 = table[((560.0 - tables::FL_LAMBDA_MIN) / tables::FL_LAMBDA_STEP) as usize];
                resample_uniform(tables::FL_LAMBDA_MIN, tables::FL_LAMBDA_STEP, table, grid, 1.0 / at560)
            }
            SpectrumKind::NarrowBand { center, width } => {
                if !(center.is_finite() && width.is_finite() && *width > 0.0) {
                    return Err(format!("narrow band at {center} nm with width {width} nm: width must be positive"));
                }
                narrow_band(*center as f64, *width as f64, grid)
            }
            SpectrumKind::Tabulated { wavelengths, values } => {
                check_table(wavelengths, values)?;
                (0..grid.len())
                    .map(|i| {
                        let (lo, hi) = grid.cell(i);
                        average_piecewise_linear(wavelengths, values, lo, hi)
                    })
                    .collect()
            }
            SpectrumKind::Rgb { rgb } => {
                if !rgb.iter().all(|c| c.is_finite()) {
                    return Err(format!("RGB {rgb:?} is not finite"));
                }
                let v = uplift.convert(*rgb, role);
                if v.len() != grid.len() {
                    return Err(format!("RGB {rgb:?} cannot be converted here (no RGB → spectrum map)"));
                }
                v
            }
            SpectrumKind::Texture { texture } => {
                return Err(format!(
                    "texture {texture} cannot be used here (only a diffuse reflectance or the world accepts a texture)"
                ));
            }
        };
        for x in v.iter_mut() {
            *x *= self.scale;
        }
        if let Some((i, x)) = v.iter().enumerate().find(|(_, x)| !x.is_finite()) {
            return Err(format!("value {x} at {} nm is not finite", grid.lambdas()[i]));
        }
        if role != SpectrumRole::Unbounded {
            if let Some((i, x)) = v.iter().enumerate().find(|(_, x)| **x < 0.0) {
                return Err(format!("value {x} at {} nm is negative", grid.lambdas()[i]));
            }
        }
        Ok(v)
    }
}

/// Planck's law: spectral radiance in W·sr⁻¹·m⁻²·nm⁻¹ at `lambda_nm`, `t` kelvin.
pub fn blackbody(lambda_nm: f64, t: f64) -> f64 {
    const C: f64 = 299_792_458.0;
    const H: f64 = 6.626_070_15e-34;
    const KB: f64 = 1.380_649e-23;
    let l = lambda_nm * 1e-9;
    let le = 2.0 * H * C * C / (l.powi(5) * ((H * C / (l * KB * t)).exp_m1()));
    le * 1e-9
}

fn check_table(wavelengths: &[f32], values: &[f32]) -> std::result::Result<(), String> {
    if wavelengths.len() != values.len() {
        return Err(format!("{} wavelengths but {} values", wavelengths.len(), values.len()));
    }
    if wavelengths.is_empty() {
        return Err("tabulated spectrum is empty".into());
    }
    for i in 0..wavelengths.len() {
        if !wavelengths[i].is_finite() || !values[i].is_finite() {
            return Err(format!("entry {i} ({} nm, {}) is not finite", wavelengths[i], values[i]));
        }
        if i > 0 && wavelengths[i] <= wavelengths[i - 1] {
            return Err(format!("wavelengths not strictly ascending at entry {i} ({} nm)", wavelengths[i]));
        }
    }
    Ok(())
}

/// Mean over [lo, hi] of the piecewise-linear curve through (xs, ys), constant beyond its ends.
pub fn average_piecewise_linear(xs: &[f32], ys: &[f32], lo: f32, hi: f32) -> f32 {
    let n = xs.len();
    if hi <= lo {
        return interpolate(xs, ys, lo);
    }
    // Integrate segment by segment over the breakpoints inside [lo, hi].
    let mut total = 0.0f64;
    let mut a = lo;
    let start = xs.partition_point(|&x| x <= lo);
    let mut k = start;
    loop {
        let b = if k < n { xs[k].min(hi) } else { hi };
        if b > a {
            let ya = interpolate(xs, ys, a) as f64;
            let yb = interpolate(xs, ys, b) as f64;
            total += 0.5 * (ya + yb) * (b - a) as f64;
        }
        a = b;
        if a >= hi || k >= n {
            break;
        }
        k += 1;
    }
    (total / (hi - lo) as f64) as f32
}

/// Linear interpolation through (xs, ys), constant beyond the ends.
pub fn interpolate(xs: &[f32], ys: &[f32], x: f32) -> f32 {
    let n = xs.len();
    if x <= xs[0] {
        return ys[0];
    }
    if x >= xs[n - 1] {
        return ys[n - 1];
    }
    let k = xs.partition_point(|&v| v <= x).clamp(1, n - 1);
    let t = (x - xs[k - 1]) / (xs[k] - xs[k - 1]);
    ys[k - 1] + t * (ys[k] - ys[k - 1])
}

/// Resample a table with a uniform step onto the grid by cell averages.
fn resample_uniform(min: f32, step: f32, table: &[f32], grid: &WavelengthGrid, scale: f32) -> Vec<f32> {
    let xs: Vec<f32> = (0..table.len()).map(|i| min + step * i as f32).collect();
    (0..grid.len())
        .map(|i| {
            let (lo, hi) = grid.cell(i);
            average_piecewise_linear(&xs, table, lo, hi) * scale
        })
        .collect()
}

/// A Gaussian of peak 1, averaged over each cell exactly (via erf) so its energy on
/// the grid is right however narrow it is.
fn narrow_band(center: f64, fwhm: f64, grid: &WavelengthGrid) -> Vec<f32> {
    let sigma = fwhm / (8.0 * std::f64::consts::LN_2).sqrt();
    let cdf = |x: f64| 0.5 * (1.0 + erf((x - center) / (sigma * std::f64::consts::SQRT_2)));
    let area = sigma * (2.0 * std::f64::consts::PI).sqrt();
    (0..grid.len())
        .map(|i| {
            let (lo, hi) = grid.cell(i);
            let (lo, hi) = (lo as f64, hi as f64);
            if hi <= lo {
                return 0.0;
            }
            (area * (cdf(hi) - cdf(lo)) / (hi - lo)) as f32
        })
        .collect()
}

/// Error function, |error| < 1.2e-7 (Numerical Recipes' erfc Chebyshev fit).
pub fn erf(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let r = t
        * (-z * z - 1.265_512_23
            + t * (1.000_023_68
                + t * (0.374_091_96
                    + t * (0.096_784_18
                        + t * (-0.186_288_06
                            + t * (0.278_868_07
                                + t * (-1.135_203_98
                                    + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77)))))))))
            .exp();
    if x >= 0.0 {
        1.0 - r
    } else {
        r - 1.0
    }
}

/// Checked evaluation with the error naming the object that owns the spectrum.
pub fn evaluate_for(
    desc: &SpectrumDesc,
    grid: &WavelengthGrid,
    role: SpectrumRole,
    uplift: &dyn RgbToSpectrum,
    kind: &'static str,
    name: &str,
    what: &str,
) -> Result<Vec<f32>> {
    desc.evaluate(grid, role, uplift).map_err(|p| Error::object(kind, name, format!("{what}: {p}")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rgb_through_no_rgb_map_is_an_error_naming_the_colour() {
        let g = WavelengthGrid::default();
        let err = SpectrumDesc::new(SpectrumKind::Rgb { rgb: [0.1, 0.2, 0.3] })
            .evaluate(&g, SpectrumRole::Reflectance, &NoRgb)
            .unwrap_err();
        assert!(err.contains("[0.1, 0.2, 0.3]") && err.contains("no RGB"), "{err}");
        assert_eq!(d65(&g).unwrap().len(), g.len());
    }

    #[test]
    fn narrow_band_keeps_its_energy_between_samples() {
        let g = WavelengthGrid::default();
        // A 1 nm wide band at 589 nm, between the 580 and 590 samples.
        let d = SpectrumDesc::new(SpectrumKind::NarrowBand { center: 589.0, width: 1.0 });
        let v = d.evaluate(&g, SpectrumRole::Illuminant, &NoRgb).unwrap();
        let sigma = 1.0 / (8.0f64 * 2f64.ln()).sqrt();
        let exact = sigma * (2.0 * std::f64::consts::PI).sqrt();
        assert!((g.integrate(&v) - exact).abs() < 1e-4 * exact);
    }

    #[test]
    fn tabulated_spike_keeps_its_energy() {
        let g = WavelengthGrid::default();
        let d = SpectrumDesc::new(SpectrumKind::Tabulated {
            wavelengths: vec![500.0, 503.0, 504.0, 505.0, 508.0],
            values: vec![0.0, 0.0, 10.0, 0.0, 0.0],
        });
        let v = d.evaluate(&g, SpectrumRole::Illuminant, &NoRgb).unwrap();
        assert!((g.integrate(&v) - 10.0).abs() < 1e-4, "{}", g.integrate(&v));
    }

    #[test]
    fn blackbody_peak_follows_wien() {
        let t = 5000.0;
        let peak = 2.897_771_9e6 / t;
        assert!(blackbody(peak, t) > blackbody(peak - 1.0, t));
        assert!(blackbody(peak, t) > blackbody(peak + 1.0, t));
    }

    #[test]
    fn bad_spectra_are_reported() {
        let g = WavelengthGrid::default();
        let neg = SpectrumDesc::constant(-1.0);
        assert!(neg.evaluate(&g, SpectrumRole::Reflectance, &NoRgb).unwrap_err().contains("negative"));
        assert!(neg.evaluate(&g, SpectrumRole::Unbounded, &NoRgb).is_ok());
        let t = SpectrumDesc::new(SpectrumKind::Tabulated { wavelengths: vec![500.0, 400.0], values: vec![1.0, 1.0] });
        assert!(t.evaluate(&g, SpectrumRole::Reflectance, &NoRgb).unwrap_err().contains("ascending"));
        assert!((erf(0.5) - 0.520_499_877_8).abs() < 2e-7);
    }
}
