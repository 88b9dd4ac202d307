//! Making the RGB method's three-lane grid ([`RgbChannels`]) from a spectral reference
//! grid and an RGB working space: reflectances fold with the D65 rows of
//! [`super::reflectance_rows`] (each row normalised so a flat 1 is white), illuminants
//! with the observer's XYZ → RGB.

use super::{reflectance_rows, Observer, RgbSpace};
use crate::spectrum::rgb_channels::RgbChannels;
use crate::spectrum::WavelengthGrid;
use crate::{Error, Result};

impl WavelengthGrid {
    /// The three-lane grid of the RGB method, converting spectra through `reference`.
    pub fn rgb_channels(reference: &WavelengthGrid, space: &RgbSpace) -> Result<WavelengthGrid> {
        let reference = reference.spectral().clone();
        let obs = Observer::new(&reference);
        let illum: [Vec<f64>; 3] = std::array::from_fn(|c| {
            (0..reference.len())
                .map(|i| space.xyz_to_rgb([obs.x[i] as f64, obs.y[i] as f64, obs.z[i] as f64])[c])
                .collect()
        });
        let (_, mut refl, _) = reflectance_rows(&reference, space)?;
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spectrum::named::{NoRgb, SpectrumKind, SpectrumRole};
    use crate::spectrum::SpectrumDesc;

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
