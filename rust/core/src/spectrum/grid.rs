//! The wavelength grid of a render and its quadrature weights.
//!
//! The paper (eq. 6) turns a spectral density into the flux carried at sample i by
//! `P(λi) = φ(λi)·(λ(i+1) − λ(i−1))/2`, with one-sided half intervals at the two ends.
//! [`WavelengthGrid::weights`] is the one place that owns these weights; nothing else
//! may assume a uniform step.

use crate::{Error, Result};

/// Smallest and largest wavelength a grid may use (nm): the range of the CIE tables.
pub const LAMBDA_MIN: f32 = 360.0;
pub const LAMBDA_MAX: f32 = 830.0;
/// Sample counts a grid may have.
pub const MIN_SAMPLES: usize = 4;
pub const MAX_SAMPLES: usize = 401;

#[derive(Clone, Debug, PartialEq)]
pub struct WavelengthGrid {
    lambdas: Vec<f32>,
    weights: Vec<f32>,
    /// Set for the RGB method's three-channel "grid" (see `super::rgb_channels`).
    rgb: Option<Box<super::rgb_channels::RgbChannels>>,
}

impl Default for WavelengthGrid {
    /// 41 samples, 380..780 nm every 10 nm (the paper's grid).
    fn default() -> Self {
        Self::uniform(41, 380.0, 780.0).expect("default grid is valid")
    }
}

impl WavelengthGrid {
    /// `count` samples from `min` to `max` inclusive.
    pub fn uniform(count: usize, min: f32, max: f32) -> Result<Self> {
        if !(MIN_SAMPLES..=MAX_SAMPLES).contains(&count) {
            return Err(Error::setting("wavelength_count", format!("{count} is outside {MIN_SAMPLES}..{MAX_SAMPLES}")));
        }
        if !(min.is_finite() && max.is_finite() && min < max) {
            return Err(Error::setting("wavelength_min", format!("range {min}..{max} nm is empty or not finite")));
        }
        let step = (max as f64 - min as f64) / (count - 1) as f64;
        let lambdas = (0..count).map(|i| (min as f64 + step * i as f64) as f32).collect();
        Self::from_wavelengths(lambdas)
    }

    /// An explicit, strictly ascending list of wavelengths in nm (may be non-uniform).
    pub fn from_wavelengths(lambdas: Vec<f32>) -> Result<Self> {
        let n = lambdas.len();
        if !(MIN_SAMPLES..=MAX_SAMPLES).contains(&n) {
            return Err(Error::setting(
                "wavelengths",
                format!("{n} wavelengths given, need {MIN_SAMPLES}..{MAX_SAMPLES}"),
            ));
        }
        for (i, &l) in lambdas.iter().enumerate() {
            if !l.is_finite() || !(LAMBDA_MIN..=LAMBDA_MAX).contains(&l) {
                return Err(Error::setting(
                    "wavelengths",
                    format!("wavelength {i} = {l} nm is outside {LAMBDA_MIN}..{LAMBDA_MAX} nm"),
                ));
            }
            if i > 0 && l <= lambdas[i - 1] {
                return Err(Error::setting(
                    "wavelengths",
                    format!("not strictly ascending: wavelength {i} = {l} nm follows {} nm", lambdas[i - 1]),
                ));
            }
        }
        let weights = (0..n)
            .map(|i| {
                let lo = lambdas[i.saturating_sub(1)];
                let hi = lambdas[(i + 1).min(n - 1)];
                (hi - lo) * 0.5
            })
            .collect();
        Ok(Self { lambdas, weights, rgb: None })
    }

    /// The RGB method's grid: three lanes R, G, B at 620, 540, 460 nm (the wavelengths a
    /// dispersive surface uses per channel), weights = the channels' luminance.
    pub(crate) fn from_rgb_channels(channels: super::rgb_channels::RgbChannels, luminance: [f32; 3]) -> Self {
        Self { lambdas: vec![620.0, 540.0, 460.0], weights: luminance.to_vec(), rgb: Some(Box::new(channels)) }
    }
    /// The RGB data of an RGB-method grid (None for spectral grids).
    pub fn rgb(&self) -> Option<&super::rgb_channels::RgbChannels> {
        self.rgb.as_deref()
    }
    pub fn is_rgb(&self) -> bool {
        self.rgb.is_some()
    }
    /// The spectral grid behind this one: itself, or an RGB grid's reference grid.
    pub fn spectral(&self) -> &WavelengthGrid {
        self.rgb.as_ref().map_or(self, |c| &c.reference)
    }

    pub fn len(&self) -> usize {
        self.lambdas.len()
    }
    pub fn is_empty(&self) -> bool {
        self.lambdas.is_empty()
    }
    /// Sample wavelengths in nm, ascending.
    pub fn lambdas(&self) -> &[f32] {
        &self.lambdas
    }
    /// Quadrature weight of each sample in nm (eq. 6): density × weight = flux.
    pub fn weights(&self) -> &[f32] {
        &self.weights
    }
    /// The interval of wavelengths sample `i` stands for: from the midpoint with its
    /// left neighbour to the midpoint with its right one, clipped to the grid's ends.
    /// Its width equals `weights()[i]`.
    pub fn cell(&self, i: usize) -> (f32, f32) {
        let n = self.len();
        let lo = if i == 0 { self.lambdas[0] } else { 0.5 * (self.lambdas[i - 1] + self.lambdas[i]) };
        let hi = if i + 1 == n { self.lambdas[n - 1] } else { 0.5 * (self.lambdas[i] + self.lambdas[i + 1]) };
        (lo, hi)
    }
    /// Index of the sample closest to `lambda`.
    pub fn nearest(&self, lambda: f32) -> usize {
        let i = self.lambdas.partition_point(|&l| l < lambda);
        if i == 0 {
            0
        } else if i == self.len() {
            self.len() - 1
        } else if (lambda - self.lambdas[i - 1]) <= (self.lambdas[i] - lambda) {
            i - 1
        } else {
            i
        }
    }
    /// ∫ f dλ over the grid's range, for a function known at the samples.
    pub fn integrate(&self, values: &[f32]) -> f64 {
        values.iter().zip(&self.weights).map(|(&v, &w)| v as f64 * w as f64).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_grid_is_the_papers() {
        let g = WavelengthGrid::default();
        assert_eq!(g.len(), 41);
        assert_eq!(g.lambdas()[0], 380.0);
        assert_eq!(g.lambdas()[40], 780.0);
        assert_eq!(g.weights()[0], 5.0);
        assert_eq!(g.weights()[1], 10.0);
        assert_eq!(g.weights()[40], 5.0);
        let total: f32 = g.weights().iter().sum();
        assert!((total - 400.0).abs() < 1e-3);
    }

    #[test]
    fn weights_are_cell_widths_on_a_non_uniform_grid() {
        let g = WavelengthGrid::from_wavelengths(vec![400.0, 410.0, 430.0, 470.0, 550.0]).unwrap();
        assert_eq!(g.weights(), &[5.0, 15.0, 30.0, 60.0, 40.0]);
        for i in 0..g.len() {
            let (lo, hi) = g.cell(i);
            assert!((hi - lo - g.weights()[i]).abs() < 1e-4);
        }
        // The trapezoid rule is exact for linear functions.
        let f: Vec<f32> = g.lambdas().iter().map(|l| 2.0 * l + 1.0).collect();
        let exact = (550.0f64.powi(2) + 550.0) - (400.0f64.powi(2) + 400.0);
        assert!((g.integrate(&f) - exact).abs() < 1e-6 * exact);
    }

    #[test]
    fn bad_grids_are_rejected_with_the_reason() {
        let e = WavelengthGrid::from_wavelengths(vec![400.0, 500.0, 450.0, 600.0]).unwrap_err();
        assert!(e.to_string().contains("not strictly ascending"), "{e}");
        assert!(WavelengthGrid::uniform(3, 380.0, 780.0).is_err());
        assert!(WavelengthGrid::uniform(402, 380.0, 780.0).is_err());
        assert!(WavelengthGrid::uniform(41, 300.0, 780.0).is_err());
        assert!(WavelengthGrid::uniform(401, 380.0, 780.0).is_ok());
        assert!(WavelengthGrid::from_wavelengths(vec![400.0, f32::NAN, 500.0, 600.0]).is_err());
    }

    #[test]
    fn nearest_sample() {
        let g = WavelengthGrid::default();
        assert_eq!(g.nearest(379.0), 0);
        assert_eq!(g.nearest(554.0), 17);
        assert_eq!(g.nearest(556.0), 18);
        assert_eq!(g.nearest(900.0), 40);
    }
}
