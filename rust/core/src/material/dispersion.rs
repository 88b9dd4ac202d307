//! Refractive index models (docs/design.md#dispersion): constant, Cauchy, Sellmeier, Abbe number (as
//! Blender gives it) and named catalogue glasses. A model is evaluated once on the
//! render's grid when the scene is built; bad values (non-finite, below 1, near a
//! Sellmeier pole) are load-time errors that name the material and the wavelength.

use super::catalogue::{self, SellmeierCoefficients};
use crate::spectrum::{SampledSpectrum, WavelengthGrid};
use crate::{Error, Result};
use serde::{Deserialize, Serialize};

/// The Fraunhofer lines of the Abbe number Vd = (nd − 1)/(nF − nC), in nm: the helium d
/// line and the hydrogen F and C lines, as SCHOTT's catalogue and ISO 7944 give them
/// (SCHOTT Technical Information TIE-29, "Refractive Index and Dispersion", its table
/// of spectral lines; the same values in optowiki's table of Fraunhofer lines,
/// https://www.optowiki.info/glossary/prefix:fr/).
/// The only definition: Python (`polychrome.ior.LAMBDA_D`, ...) and the Blender node
/// read these from `_core`.
pub const LAMBDA_D: f64 = 587.5618;
pub const LAMBDA_F: f64 = 486.1327;
pub const LAMBDA_C: f64 = 656.2725;

/// Indices closer than this (over the grid) count as constant: the material does not
/// disperse and never collapses a ray.
pub const DISPERSION_THRESHOLD: f32 = 1e-6;

/// An index of refraction as a scene describes it (JSON: `{"type": "cauchy", ...}`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum IorDesc {
    /// The same index at every wavelength.
    Constant { ior: f64 },
    /// n = A + B/λ² + C/λ⁴, λ in µm.
    Cauchy {
        a: f64,
        b: f64,
        #[serde(default)]
        c: f64,
    },
    /// n² = 1 + Σ B_k λ²/(λ² − C_k), λ in µm, C_k in µm².
    Sellmeier { b: [f64; 3], c: [f64; 3] },
    /// nd at the d line ([`LAMBDA_D`]) and Vd = (nd − 1)/(nF − nC), mapped to the
    /// two-term Cauchy fit of [`abbe_to_cauchy`].
    Abbe { nd: f64, vd: f64 },
    /// A glass of the catalogue (`material::catalogue`), e.g. "N-BK7".
    Named { name: String },
}

impl Default for IorDesc {
    fn default() -> Self {
        IorDesc::Constant { ior: 1.5 }
    }
}

/// The two-term Cauchy coefficients (A, B in µm²) that reproduce `nd` and `vd`.
pub fn abbe_to_cauchy(nd: f64, vd: f64) -> (f64, f64) {
    let um = |l: f64| l * 1e-3;
    let inv2 = |l: f64| 1.0 / (um(l) * um(l));
    let b = (nd - 1.0) / (vd * (inv2(LAMBDA_F) - inv2(LAMBDA_C)));
    let a = nd - b * inv2(LAMBDA_D);
    (a, b)
}

impl IorDesc {
    /// The index at `lambda_nm`, or why it cannot be computed there.
    pub fn index_at(&self, lambda_nm: f64) -> std::result::Result<f64, String> {
        let l = lambda_nm * 1e-3;
        let l2 = l * l;
        let n = match self {
            IorDesc::Constant { ior } => *ior,
            IorDesc::Cauchy { a, b, c } => a + b / l2 + c / (l2 * l2),
            IorDesc::Sellmeier { b, c } => {
                return sellmeier_checked(&SellmeierCoefficients { b: *b, c: *c }, lambda_nm)
            }
            IorDesc::Abbe { nd, vd } => {
                if !(nd.is_finite() && vd.is_finite() && *vd > 0.0) {
                    return Err(format!("Abbe number Vd = {vd} must be positive and finite (nd = {nd})"));
                }
                let (a, b) = abbe_to_cauchy(*nd, *vd);
                a + b / l2
            }
            IorDesc::Named { name } => {
                let m = catalogue::find(name).ok_or_else(|| {
                    let names: Vec<&str> = catalogue::CATALOGUE.iter().map(|m| m.name).collect();
                    format!("unknown glass '{name}' (known: {})", names.join(", "))
                })?;
                return sellmeier_checked(&m.sellmeier, lambda_nm);
            }
        };
        Ok(n)
    }

    /// Whether the description names a fixed index (dispersion-free by construction).
    pub fn is_constant(&self) -> bool {
        matches!(self, IorDesc::Constant { .. })
    }
}

/// Sellmeier index with a pole check: a term whose denominator λ² − C_k is within 0.1 %
/// of λ² is too close to its resonance to be meaningful.
fn sellmeier_pole(c: &SellmeierCoefficients, lambda_nm: f64) -> Option<String> {
    let l = lambda_nm * 1e-3;
    let l2 = l * l;
    (0..3).find(|&k| c.b[k] != 0.0 && (l2 - c.c[k]).abs() < 1e-3 * l2).map(|k| {
        format!(
            "index at λ {lambda_nm:.2} nm is near a Sellmeier pole (term {}: C = {} µm², pole at {:.2} nm)",
            k + 1,
            c.c[k],
            c.c[k].abs().sqrt() * 1e3
        )
    })
}

fn sellmeier_checked(c: &SellmeierCoefficients, lambda_nm: f64) -> std::result::Result<f64, String> {
    let l = lambda_nm * 1e-3;
    let l2 = l * l;
    if let Some(p) = sellmeier_pole(c, lambda_nm) {
        return Err(p);
    }
    let n2 = 1.0 + (0..3).map(|k| c.b[k] * l2 / (l2 - c.c[k])).sum::<f64>();
    if !(n2 >= 0.0) {
        return Err(format!("index at λ {lambda_nm:.2} nm is imaginary (n² = {n2})"));
    }
    Ok(n2.sqrt())
}

/// An index of refraction evaluated on the render's grid.
#[derive(Clone, Debug)]
pub struct IndexOfRefraction {
    /// n(λi) per grid sample.
    pub values: SampledSpectrum,
    /// The index varies over the grid by more than [`DISPERSION_THRESHOLD`].
    pub dispersive: bool,
}

/// An index a material may have: finite, at least 1, at most 10 (errors name the
/// material and the wavelength).
fn check_index(material: &str, n: f64, lambda: f32) -> Result<()> {
    if !n.is_finite() {
        return Err(Error::object("material", material, format!("index {n} at λ {lambda} nm is not finite")));
    }
    if n < 1.0 {
        return Err(Error::object("material", material, format!("index {n:.6} at λ {lambda} nm is below 1")));
    }
    if n > 10.0 {
        return Err(Error::object(
            "material",
            material,
            format!("index {n:.6} at λ {lambda} nm is above 10 (near a pole?)"),
        ));
    }
    Ok(())
}

impl IndexOfRefraction {
    /// Evaluates `desc` on `grid` for material `material` (named in errors).
    pub fn build(desc: &IorDesc, grid: &WavelengthGrid, material: &str) -> Result<Self> {
        // A constant index (every Principled and glass of a Blender scene): one check and
        // a splat, no per-wavelength evaluation (graph materials build it at every hit).
        if let IorDesc::Constant { ior } = desc {
            check_index(material, *ior, grid.lambdas().first().copied().unwrap_or(0.0))?;
            return Ok(Self::constant(grid.len(), *ior as f32));
        }
        // Poles first, over the whole grid (the index is nonsense on both sides of
        // one), then other model errors, then the values.
        if let IorDesc::Sellmeier { b, c } = desc {
            let coeffs = SellmeierCoefficients { b: *b, c: *c };
            for &lambda in grid.lambdas() {
                if let Some(p) = sellmeier_pole(&coeffs, lambda as f64) {
                    return Err(Error::object("material", material, p));
                }
            }
        }
        let raw: Vec<f64> = grid
            .lambdas()
            .iter()
            .map(|&lambda| desc.index_at(lambda as f64))
            .collect::<std::result::Result<_, String>>()
            .map_err(|p| Error::object("material", material, p))?;
        let mut values = Vec::with_capacity(grid.len());
        for (&lambda, &n) in grid.lambdas().iter().zip(&raw) {
            check_index(material, n, lambda)?;
            values.push(n as f32);
        }
        let (lo, hi) = values.iter().fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
        let dispersive = !desc.is_constant() && hi - lo > DISPERSION_THRESHOLD;
        Ok(Self { values: SampledSpectrum::from_slice(&values), dispersive })
    }

    /// A constant index on a grid of `len` samples.
    pub fn constant(len: usize, n: f32) -> Self {
        Self { values: SampledSpectrum::splat(len, n), dispersive: false }
    }

    /// The index at grid sample `i`.
    #[inline]
    pub fn at(&self, i: usize) -> f32 {
        self.values.get(i)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sellmeier_bk7_matches_published_nd() {
        let bk7 = catalogue::find("N-BK7").unwrap();
        let d = IorDesc::Sellmeier { b: bk7.sellmeier.b, c: bk7.sellmeier.c };
        let nd = d.index_at(LAMBDA_D).unwrap();
        assert!((nd - 1.51680).abs() < 2e-5, "{nd}");
        let named = IorDesc::Named { name: "bk7".into() };
        assert_eq!(named.index_at(LAMBDA_D).unwrap(), nd);
        // Data-sheet nF and nC (SCHOTT N-BK7): 1.52238, 1.51432.
        assert!((d.index_at(486.1327).unwrap() - 1.52238).abs() < 2e-5);
        assert!((d.index_at(656.2725).unwrap() - 1.51432).abs() < 2e-5);
    }

    #[test]
    fn abbe_round_trip() {
        for &(nd, vd) in &[(1.5168, 64.17), (1.78472, 25.68), (1.3334, 55.76), (2.4175, 55.3), (1.0001, 90.0)] {
            let d = IorDesc::Abbe { nd, vd };
            let n_d = d.index_at(LAMBDA_D).unwrap();
            let n_f = d.index_at(LAMBDA_F).unwrap();
            let n_c = d.index_at(LAMBDA_C).unwrap();
            assert!((n_d - nd).abs() < 1e-12, "nd {n_d} vs {nd}");
            let v = (n_d - 1.0) / (n_f - n_c);
            assert!((v - vd).abs() < 1e-9 * vd, "Vd {v} vs {vd}");
        }
        assert!(IorDesc::Abbe { nd: 1.5, vd: 0.0 }.index_at(500.0).unwrap_err().contains("Abbe"));
    }

    #[test]
    fn cauchy_formula() {
        let d = IorDesc::Cauchy { a: 1.5, b: 0.004, c: 0.0001 };
        let n = d.index_at(500.0).unwrap();
        assert!((n - (1.5 + 0.004 / 0.25 + 0.0001 / 0.0625)).abs() < 1e-12);
    }

    #[test]
    fn grid_evaluation_reports_poles_and_bad_values() {
        let grid = WavelengthGrid::default();
        // A resonance at 550 nm: C = 0.55² µm².
        let pole = IorDesc::Sellmeier { b: [1.0, 0.0, 0.0], c: [0.55 * 0.55, 0.0, 0.0] };
        let e = IndexOfRefraction::build(&pole, &grid, "Weird Glass").unwrap_err().to_string();
        assert!(e.contains("material 'Weird Glass'") && e.contains("550") && e.contains("pole"), "{e}");
        let low = IorDesc::Constant { ior: 0.9 };
        let e = IndexOfRefraction::build(&low, &grid, "Low").unwrap_err().to_string();
        assert!(e.contains("'Low'") && e.contains("below 1") && e.contains("380"), "{e}");
        let nan = IorDesc::Cauchy { a: f64::NAN, b: 0.0, c: 0.0 };
        assert!(IndexOfRefraction::build(&nan, &grid, "NaN").unwrap_err().to_string().contains("not finite"));
        let unknown = IorDesc::Named { name: "unobtainium".into() };
        let e = IndexOfRefraction::build(&unknown, &grid, "U").unwrap_err().to_string();
        assert!(e.contains("unobtainium") && e.contains("N-BK7"), "{e}");
    }

    #[test]
    fn dispersive_only_when_the_index_varies() {
        let grid = WavelengthGrid::default();
        assert!(!IndexOfRefraction::build(&IorDesc::Constant { ior: 1.5 }, &grid, "c").unwrap().dispersive);
        assert!(!IndexOfRefraction::build(&IorDesc::Cauchy { a: 1.5, b: 0.0, c: 0.0 }, &grid, "c").unwrap().dispersive);
        assert!(IndexOfRefraction::build(&IorDesc::Named { name: "N-BK7".into() }, &grid, "g").unwrap().dispersive);
        assert!(IndexOfRefraction::build(&IorDesc::Abbe { nd: 1.5, vd: 40.0 }, &grid, "a").unwrap().dispersive);
        let json: IorDesc = serde_json::from_str(r#"{"type": "abbe", "nd": 1.5, "vd": 40}"#).unwrap();
        assert_eq!(json, IorDesc::Abbe { nd: 1.5, vd: 40.0 });
        assert!(serde_json::from_str::<IorDesc>(r#"{"type": "constant", "ior": 1.5, "x": 1}"#).is_err());
    }
}
