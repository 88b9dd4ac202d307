//! Catalogue of named dispersive dielectrics with published Sellmeier
//! coefficients.
//!
//! Every entry cites the publication its coefficients come from, and carries
//! the published `nd` / `Vd` catalogue values, which the tests use as
//! independent references for the coefficients:
//!
//! * `nd`: refractive index at the helium d line, 587.5618 nm;
//! * `Vd = (nd - 1) / (nF - nC)`, with the hydrogen F line 486.1327 nm and
//!   the hydrogen C line 656.2725 nm.
//!
//! All indices are relative to air (the usual catalogue convention), except
//! water, whose source (Daimon & Masumura 2007) gives the absolute index; the
//! difference (a factor n_air ~ 1.00027) is below anything a renderer can show.

/// Sellmeier form: n^2(λ) = 1 + Σ B_k λ² / (λ² − C_k), λ in µm, C_k in µm².
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SellmeierCoefficients {
    pub b: [f64; 3],
    pub c: [f64; 3],
}

/// A named dispersive material.
#[derive(Clone, Copy, Debug)]
pub struct NamedMaterial {
    /// Canonical name, e.g. "N-BK7".
    pub name: &'static str,
    /// Other accepted names (matched like `name` by [`find`]).
    pub aliases: &'static [&'static str],
    pub sellmeier: SellmeierCoefficients,
    /// Where the coefficients come from.
    pub source: &'static str,
    /// Published refractive index at the He d line (`dispersion::LAMBDA_D`).
    pub nd: f64,
    /// Published Abbe number (nd − 1) / (nF − nC).
    pub vd: f64,
}

pub static CATALOGUE: &[NamedMaterial] = &[
    // SCHOTT optical glass data sheet N-BK7 (glass code 517642.251), SCHOTT AG.
    // Sellmeier coefficients, nd = 1.51680 and vd = 64.17 as printed on the data
    // sheet. Valid 0.3..2.5 µm.
    NamedMaterial {
        name: "N-BK7",
        aliases: &["BK7"],
        sellmeier: SellmeierCoefficients {
            b: [1.03961212, 0.231792344, 1.01046945],
            c: [0.00600069867, 0.0200179144, 103.560653],
        },
        source: "SCHOTT optical glass data sheet N-BK7 (517642.251)",
        nd: 1.51680,
        vd: 64.17,
    },
    // I. H. Malitson, "Interspecimen comparison of the refractive index of fused
    // silica", J. Opt. Soc. Am. 55, 1205-1208 (1965), doi:10.1364/JOSA.55.001205.
    // Published as n^2 - 1 = Σ B_k λ² / (λ² − λ_k²) with λ_k = 0.0684043,
    // 0.1162414, 9.896161 µm; C_k = λ_k² below. 20 °C, valid 0.21..3.71 µm.
    // nd = 1.45846 (Malitson's index at 0.5876 µm, as listed by
    // refractiveindex.info); vd = 67.8 (synthetic fused silica Abbe constant
    // 67.8 ± 0.5 in the CVI Melles Griot optical coatings/materials catalogue).
    NamedMaterial {
        name: "Fused Silica",
        aliases: &["SiO2", "fused_silica"],
        sellmeier: SellmeierCoefficients {
            b: [0.6961663, 0.4079426, 0.8974794],
            c: [0.0684043 * 0.0684043, 0.1162414 * 0.1162414, 9.896161 * 9.896161],
        },
        source: "I. H. Malitson, J. Opt. Soc. Am. 55, 1205 (1965)",
        nd: 1.45846,
        vd: 67.8,
    },
    // SCHOTT optical glass data sheet N-SF11 (glass code 785257.322), SCHOTT AG.
    // Sellmeier coefficients, nd = 1.78472 and vd = 25.68 as printed on the data
    // sheet. Valid 0.37..2.5 µm.
    NamedMaterial {
        name: "N-SF11",
        aliases: &["SF11"],
        sellmeier: SellmeierCoefficients {
            b: [1.73759695, 0.313747346, 1.89878101],
            c: [0.013188707, 0.0623068142, 155.23629],
        },
        source: "SCHOTT optical glass data sheet N-SF11 (785257.322)",
        nd: 1.78472,
        vd: 25.68,
    },
    // M. Daimon and A. Masumura, "Measurement of the refractive index of
    // distilled water from the near-infrared region to the ultraviolet region",
    // Appl. Opt. 46, 3811-3820 (2007), doi:10.1364/AO.46.003811; 4-term
    // Sellmeier fit for 20.0 °C (182..1129 nm, absolute index):
    //   B = 5.684027565e-1, 1.726177391e-1, 2.086189578e-2, 1.130748688e-1
    //   C = 5.101829712e-3, 1.821153936e-2, 2.620722293e-2, 1.069792721e1 µm²
    // (coefficients as given in the refractiveindex.info database,
    // data-nk/main/H2O/Daimon-20.0C.yml).
    // Reduced to 3 terms: terms 1 and 4 are kept unchanged; the two close UV
    // terms 2 and 3 are merged into one with B = B2 + B3 and
    // C = (B2 C2 + B3 C3) / (B2 + B3), which preserves the first two orders of
    // their expansion in C/λ². Maximum |Δn| against the 4-term formula is
    // 3.4e-5 over 380..780 nm and 4.5e-5 over 360..830 nm (checked in tests).
    // nd = 1.3334 and vd = 55.76 are the values refractiveindex.info lists for
    // this 20.0 °C data set (cross-check: n_D(589.3 nm, 20 °C) = 1.33299
    // relative to air, i.e. ~1.33336 absolute).
    NamedMaterial {
        name: "Water",
        aliases: &["H2O"],
        sellmeier: SellmeierCoefficients {
            b: [5.684027565e-1, 1.726177391e-1 + 2.086189578e-2, 1.130748688e-1],
            c: [
                5.101829712e-3,
                (1.726177391e-1 * 1.821153936e-2 + 2.086189578e-2 * 2.620722293e-2) / (1.726177391e-1 + 2.086189578e-2),
                1.069792721e1,
            ],
        },
        source: "M. Daimon and A. Masumura, Appl. Opt. 46, 3811 (2007), 20.0 °C, \
                 terms 2 and 3 merged",
        nd: 1.3334,
        vd: 55.76,
    },
    // F. Peter, "Über Brechungsindizes und Absorptionskonstanten des Diamanten
    // zwischen 644 und 226 mμ", Z. Physik 15, 358-368 (1923),
    // doi:10.1007/BF01330487. Two-term Sellmeier
    //   n^2 - 1 = 0.3306 λ²/(λ² − 0.1750²) + 4.3356 λ²/(λ² − 0.1060²)
    // (third term zero). Measured 226..644 nm: the C line (656 nm) and the red
    // end of the visible are a mild extrapolation. nd = 2.4175 and vd = 55.3
    // as listed by refractiveindex.info for this formula (cross-check: the
    // gemmological n_D(589.3 nm) = 2.417).
    NamedMaterial {
        name: "Diamond",
        aliases: &[],
        sellmeier: SellmeierCoefficients { b: [0.3306, 4.3356, 0.0], c: [0.1750 * 0.1750, 0.1060 * 0.1060, 0.0] },
        source: "F. Peter, Z. Physik 15, 358 (1923)",
        nd: 2.4175,
        vd: 55.3,
    },
];

/// Characters ignored when matching names: separators and blanks.
fn is_ignored(c: char) -> bool {
    c == '-' || c == '_' || c.is_whitespace()
}

/// Compares two names case-insensitively, ignoring '-', '_' and whitespace.
fn names_match(a: &str, b: &str) -> bool {
    a.chars()
        .filter(|&c| !is_ignored(c))
        .flat_map(char::to_lowercase)
        .eq(b.chars().filter(|&c| !is_ignored(c)).flat_map(char::to_lowercase))
}

/// Looks a material up by name or alias: case-insensitive, ignoring '-', '_'
/// and spaces (so "bk7", "N-BK7", "n_bk7" and "fused silica" all work).
pub fn find(name: &str) -> Option<&'static NamedMaterial> {
    CATALOGUE.iter().find(|m| names_match(m.name, name) || m.aliases.iter().any(|alias| names_match(alias, name)))
}

/// Refractive index from Sellmeier coefficients at `lambda_nm` (nanometres).
pub fn sellmeier_index(c: &SellmeierCoefficients, lambda_nm: f64) -> f64 {
    let l2 = {
        let l = lambda_nm * 1e-3; // nm -> µm
        l * l
    };
    let n2 = 1.0 + c.b.iter().zip(c.c.iter()).map(|(&b, &ck)| b * l2 / (l2 - ck)).sum::<f64>();
    n2.sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::material::dispersion::{LAMBDA_C, LAMBDA_D, LAMBDA_F};

    fn nd_vd(c: &SellmeierCoefficients) -> (f64, f64) {
        let nd = sellmeier_index(c, LAMBDA_D);
        let nf = sellmeier_index(c, LAMBDA_F);
        let nc = sellmeier_index(c, LAMBDA_C);
        (nd, (nd - 1.0) / (nf - nc))
    }

    #[test]
    fn published_nd_and_vd() {
        for m in CATALOGUE {
            let (nd, vd) = nd_vd(&m.sellmeier);
            assert!((nd - m.nd).abs() < 2e-4, "{}: computed nd {nd:.6}, published {}", m.name, m.nd);
            assert!(((vd - m.vd) / m.vd).abs() < 0.01, "{}: computed Vd {vd:.3}, published {}", m.name, m.vd);
        }
    }

    #[test]
    fn find_by_name_and_alias() {
        assert_eq!(find("bk7").unwrap().name, "N-BK7");
        assert_eq!(find("N-BK7").unwrap().name, "N-BK7");
        assert_eq!(find("n_bk7").unwrap().name, "N-BK7");
        assert_eq!(find("Fused Silica").unwrap().name, "Fused Silica");
        assert_eq!(find("fused_silica").unwrap().name, "Fused Silica");
        assert_eq!(find("FUSEDSILICA").unwrap().name, "Fused Silica");
        assert_eq!(find("sio2").unwrap().name, "Fused Silica");
        assert_eq!(find("sf11").unwrap().name, "N-SF11");
        assert_eq!(find("n-sf11").unwrap().name, "N-SF11");
        assert_eq!(find("water").unwrap().name, "Water");
        assert_eq!(find("DIAMOND").unwrap().name, "Diamond");
        assert!(find("unobtainium").is_none());
        assert!(find("").is_none());
    }

    #[test]
    fn names_are_unambiguous() {
        // No name or alias of one material may match a name or alias of
        // another (within one material, e.g. "fused_silica", it may).
        let keys = |m: &'static NamedMaterial| std::iter::once(m.name).chain(m.aliases.iter().copied());
        for (i, a) in CATALOGUE.iter().enumerate() {
            for b in &CATALOGUE[i + 1..] {
                for ka in keys(a) {
                    for kb in keys(b) {
                        assert!(!names_match(ka, kb), "{ka} and {kb} collide");
                    }
                }
            }
        }
        // Every name and alias finds its own material.
        for m in CATALOGUE {
            for k in keys(m) {
                assert!(std::ptr::eq(find(k).unwrap(), m), "{k}");
            }
        }
    }

    #[test]
    fn water_three_terms_match_published_four_terms() {
        // Daimon & Masumura 2007, 20.0 °C, 4-term Sellmeier as published.
        let b = [5.684027565e-1, 1.726177391e-1, 2.086189578e-2, 1.130748688e-1];
        let c = [5.101829712e-3, 1.821153936e-2, 2.620722293e-2, 1.069792721e1];
        let four = |lambda_nm: f64| {
            let l = lambda_nm * 1e-3;
            let l2 = l * l;
            (1.0 + (0..4).map(|k| b[k] * l2 / (l2 - c[k])).sum::<f64>()).sqrt()
        };
        let water = find("water").unwrap();
        let mut max_err: f64 = 0.0;
        for i in 0..=400 {
            let lambda = 380.0 + i as f64;
            max_err = max_err.max((sellmeier_index(&water.sellmeier, lambda) - four(lambda)).abs());
        }
        assert!(max_err < 1e-4, "max |dn| over 380..780 nm = {max_err:e}");
    }

    #[test]
    fn indices_are_sane_over_visible() {
        for m in CATALOGUE {
            let mut prev = f64::INFINITY;
            for i in 0..=47 {
                let lambda = 360.0 + 10.0 * i as f64;
                let n = sellmeier_index(&m.sellmeier, lambda);
                assert!(n.is_finite() && n > 1.0 && n < 3.0, "{} at {lambda}: {n}", m.name);
                // Normal dispersion: n decreases with wavelength in the visible.
                assert!(n < prev, "{} not decreasing at {lambda}", m.name);
                prev = n;
            }
        }
    }

    #[test]
    fn spot_values() {
        // N-BK7 data sheet: nF = 1.52238, nC = 1.51432 (5 decimals).
        let bk7 = &find("bk7").unwrap().sellmeier;
        assert!((sellmeier_index(bk7, LAMBDA_F) - 1.52238).abs() < 1e-5);
        assert!((sellmeier_index(bk7, LAMBDA_C) - 1.51432).abs() < 1e-5);
    }
}
