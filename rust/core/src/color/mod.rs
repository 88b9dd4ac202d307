//! Colour: the CIE 1931 observer integrated on the render's grid, RGB working spaces,
//! and the RGB → spectrum maps (eq. 10) in [`uplift`].

pub mod delta_e;
pub mod rgb_grid;
pub mod space;
pub mod uplift;

use crate::spectrum::named::{self, interpolate};
use crate::spectrum::rgb_channels::RgbChannels;
use crate::spectrum::{tables, WavelengthGrid};
use crate::{Error, Result};

pub use space::RgbSpace;

/// The CIE 1931 2° colour matching functions on a grid, folded with the grid's
/// quadrature weights (eq. 6) and normalised by ∫ȳ so that an equal-energy spectrum
/// of value 1 has Y = 1 on any grid.
#[derive(Clone, Debug)]
pub struct Observer {
    /// x̄(λi)·w_i / Σ ȳ(λj)·w_j, and likewise for y and z.
    pub x: Vec<f32>,
    pub y: Vec<f32>,
    pub z: Vec<f32>,
}

/// x̄, ȳ, z̄ at `lambda` nm, linearly interpolated in the 1 nm CIE table.
pub fn cmf(lambda: f32) -> [f32; 3] {
    let xs = cie_lambdas();
    [
        interpolate(xs, &tables::CIE_X, lambda),
        interpolate(xs, &tables::CIE_Y, lambda),
        interpolate(xs, &tables::CIE_Z, lambda),
    ]
}

fn cie_lambdas() -> &'static [f32] {
    static L: std::sync::OnceLock<Vec<f32>> = std::sync::OnceLock::new();
    L.get_or_init(|| {
        (0..tables::CIE_X.len()).map(|i| tables::CIE_LAMBDA_MIN + tables::CIE_LAMBDA_STEP * i as f32).collect()
    })
}

impl Observer {
    pub fn new(grid: &WavelengthGrid) -> Self {
        if let Some(channels) = grid.rgb() {
            return Self::of_rgb_channels(channels);
        }
        let cmfs: Vec<[f32; 3]> = grid.lambdas().iter().map(|&l| cmf(l)).collect();
        let y_integral: f64 = cmfs.iter().zip(grid.weights()).map(|(c, &w)| c[1] as f64 * w as f64).sum();
        let norm = (1.0 / y_integral) as f32;
        let fold = |k: usize| -> Vec<f32> { cmfs.iter().zip(grid.weights()).map(|(c, &w)| c[k] * w * norm).collect() };
        Self { x: fold(0), y: fold(1), z: fold(2) }
    }

    /// The observer of the RGB method's three-lane grid: lane c contributes column c of
    /// the working space's RGB → XYZ matrix, so the film writes the lanes back unchanged.
    pub fn of_rgb_channels(channels: &RgbChannels) -> Self {
        let m = &channels.rgb_to_xyz;
        let row = |k: usize| (0..3).map(|c| m[k][c] as f32).collect::<Vec<f32>>();
        Self { x: row(0), y: row(1), z: row(2) }
    }

    /// XYZ of the per-wavelength product of two spectra (e.g. reflectance × illuminant),
    /// without allocating the product.
    pub fn xyz_of_product(&self, a: &[f32], b: &[f32]) -> [f64; 3] {
        let mut out = [0.0f64; 3];
        for (i, (&x, &y)) in a.iter().zip(b).enumerate() {
            let v = (x * y) as f64;
            out[0] += v * self.x[i] as f64;
            out[1] += v * self.y[i] as f64;
            out[2] += v * self.z[i] as f64;
        }
        out
    }

    /// XYZ of a spectrum sampled on the grid.
    pub fn xyz(&self, s: &[f32]) -> [f64; 3] {
        let dot = |w: &[f32]| s.iter().zip(w).map(|(&a, &b)| a as f64 * b as f64).sum::<f64>();
        [dot(&self.x), dot(&self.y), dot(&self.z)]
    }
}

/// The grid's D65 (1 at 560 nm), the un-normalised reflectance → RGB rows under D65,
/// `K[c][i] = (xyz_to_rgb · cmf_i·w_i/Σȳw)_c · D65_i`, and Y of D65 (`Σ ȳ_i w_i D65_i/Σȳw`),
/// in f64. A reflectance ρ on the grid has the RGB `K·ρ` seen under D65; the linear uplift
/// (eq. 10) inverts these rows and the RGB method folds spectra with them.
pub fn reflectance_rows(grid: &WavelengthGrid, space: &RgbSpace) -> Result<(Vec<f64>, [Vec<f64>; 3], f64)> {
    let e = named::d65(grid).map_err(|p| Error::setting("wavelengths", format!("D65 on the grid: {p}")))?;
    let obs = Observer::new(grid);
    let n = grid.len();
    let mut k: [Vec<f64>; 3] = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
    let mut y_e = 0.0;
    for i in 0..n {
        let xyz = [obs.x[i] as f64, obs.y[i] as f64, obs.z[i] as f64];
        let rgb = space.xyz_to_rgb(xyz);
        let ei = e[i] as f64;
        for c in 0..3 {
            k[c][i] = rgb[c] * ei;
        }
        y_e += xyz[1] * ei;
    }
    Ok((e.iter().map(|&v| v as f64).collect(), k, y_e))
}
