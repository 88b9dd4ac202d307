//! Issue 9 in Rust: which settings the quality preset fills (the unset ones: `None` in
//! Rust, absent or null in JSON; a value given wins), and AUTO's grid for a scene
//! lit by a narrow band only, checked against the band's closed-form energy.

use polychrome_core::render::quality::{auto_grid, resolve};
use polychrome_core::render::{Quality, RenderSettings};
use polychrome_core::scene::SceneDesc;
use polychrome_core::spectrum::named::{NoRgb, SpectrumKind, SpectrumRole};
use polychrome_core::spectrum::{SpectrumDesc, WavelengthGrid};

fn narrow_band_scene(center: f32, width: f32) -> SceneDesc {
    let json = serde_json::json!({
        "camera": {"name": "c", "to_world": [[1,0,0,0],[0,0,-1,-3],[0,1,0,1],[0,0,0,1]]},
        "materials": [
            {"name": "grey", "bsdf": {"type": "diffuse", "reflectance": {"type": "constant", "value": 0.7}}},
            {"name": "lamp", "emission": {"type": "narrow_band", "center": center, "width": width}}
        ],
        "meshes": [], "lights": []
    });
    serde_json::from_value(json).expect("valid description")
}

#[test]
fn unset_settings_come_from_the_preset_and_given_ones_win() {
    // JSON: what is absent (or null) is unset; REFERENCE fills it, the given samples win.
    let s = RenderSettings::from_json(r#"{"quality": "REFERENCE", "samples": 3, "max_bounces": null}"#).unwrap();
    let r = resolve(&s, None).unwrap();
    assert_eq!((r.samples, r.max_bounces, r.noise_threshold), (3, 16, 0.0));
    assert_eq!(r.grid.len(), 81);
    assert!(r.notes.iter().any(|w| w.contains("REFERENCE")), "{:?}", r.notes);
    // Rust: `Some` is given, `None` is the preset's.
    let rust = RenderSettings { quality: Quality::Preview, samples: Some(7), ..Default::default() };
    let r = resolve(&rust, None).unwrap();
    assert_eq!((r.samples, r.max_bounces, r.grid.len(), r.noise_threshold), (7, 4, 16, 0.0));
    let all_given = RenderSettings {
        quality: Quality::Preview,
        samples: Some(7),
        max_bounces: Some(8),
        noise_threshold: Some(0.0),
        wavelength_count: Some(41),
        ..Default::default()
    };
    let r = resolve(&all_given, None).unwrap();
    assert_eq!((r.samples, r.max_bounces, r.grid.len(), r.noise_threshold), (7, 8, 41, 0.0));
    assert!(r.notes.is_empty(), "{:?}", r.notes);
    // Nothing given: AUTO's adaptive maximum and threshold.
    let r = resolve(&RenderSettings::default(), None).unwrap();
    assert_eq!((r.samples, r.noise_threshold), (1024, 1.0));
    assert!(RenderSettings::from_json(r#"{"quality": "ULTRA"}"#).is_err());
    assert!(RenderSettings::from_json(r#"{"noise_threshold": -1}"#).is_err());
    assert!(RenderSettings { noise_threshold: Some(-1.0), ..Default::default() }.resolve(None).is_err());
}

#[test]
fn auto_grid_centres_a_589_nm_band_and_keeps_its_energy() {
    let desc = narrow_band_scene(589.0, 1.0);
    let (lambdas, why) = auto_grid(&desc, 380.0, 780.0, Default::default()).unwrap();
    let grid = WavelengthGrid::from_wavelengths(lambdas.clone()).unwrap();
    assert!(lambdas.iter().any(|&l| (l - 589.0).abs() < 1e-3), "{lambdas:?}");
    assert!(lambdas.len() < 41, "{why:?}");
    let band = SpectrumDesc::new(SpectrumKind::NarrowBand { center: 589.0, width: 1.0 });
    let v = band.evaluate(&grid, SpectrumRole::Illuminant, &NoRgb).unwrap();
    // Closed form: a Gaussian of peak 1 and FWHM 1 nm has area σ√(2π).
    let sigma = 1.0 / (8.0f64 * 2f64.ln()).sqrt();
    let exact = sigma * (2.0 * std::f64::consts::PI).sqrt();
    assert!((grid.integrate(&v) - exact).abs() < 1e-3 * exact);
    // Its energy-weighted mean wavelength is the band's centre (a uniform 41 grid puts
    // it on 590 nm).
    let centroid: f64 =
        v.iter().zip(grid.weights()).zip(grid.lambdas()).map(|((&x, &w), &l)| (x * w * l) as f64).sum::<f64>()
            / grid.integrate(&v);
    assert!((centroid - 589.0).abs() < 0.05, "{centroid}");
    let g41 = WavelengthGrid::default();
    let v41 = band.evaluate(&g41, SpectrumRole::Illuminant, &NoRgb).unwrap();
    let c41: f64 =
        v41.iter().zip(g41.weights()).zip(g41.lambdas()).map(|((&x, &w), &l)| (x * w * l) as f64).sum::<f64>()
            / g41.integrate(&v41);
    assert!((c41 - 589.0).abs() > 0.5, "{c41}");
}
