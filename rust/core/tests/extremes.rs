//! docs/design.md#extremes in the core: the film's guard sees every method and direction (a light that
//! emits NaN is dropped and counted, never averaged into any pass), and a light
//! distribution over all-zero or non-finite powers picks nothing.

mod common;

use common::*;
use glam::{Vec2, Vec3A};
use polychrome_core::color::RgbSpace;
use polychrome_core::light::{EmissionSample, Light, LightSample, LightTree};
use polychrome_core::render::{render_scene, Direction, Method, RenderControl, ResolvedSettings};
use polychrome_core::sampling::{uniform_sphere, Distribution1D};
use polychrome_core::scene::{BsdfDesc, Buffer, BuildOptions, MaterialDesc, Scene, SceneDesc};
use polychrome_core::spectrum::{SampledSpectrum, SpectrumDesc, WavelengthGrid};

/// A point light whose radiance is NaN at one wavelength (and +∞ at another): a stand-in
/// for any bug that produces a non-finite value anywhere in a path.
struct PoisonLight {
    n: usize,
}

impl PoisonLight {
    fn radiance(&self, le: &mut SampledSpectrum) {
        *le = SampledSpectrum::splat(self.n, 1.0);
        le.set(0, f32::NAN);
        le.set(self.n - 1, f32::INFINITY);
    }
}

impl Light for PoisonLight {
    fn power(&self, _weights: &[f32]) -> f64 {
        1.0
    }
    fn sample_li(&self, p: Vec3A, _u: Vec2, le: &mut SampledSpectrum) -> Option<LightSample> {
        let d = Vec3A::new(0.0, 0.0, 2.0) - p;
        let distance = d.length();
        self.radiance(le);
        Some(LightSample { wi: d / distance, distance, pdf: 1.0, delta: true, part: 0 })
    }
    fn sample_le(&self, _u_pos: Vec2, u_dir: Vec2, le: &mut SampledSpectrum) -> Option<EmissionSample> {
        self.radiance(le);
        Some(EmissionSample {
            origin: Vec3A::new(0.0, 0.0, 2.0),
            direction: uniform_sphere(u_dir),
            normal: None,
            pdf_pos: 1.0,
            pdf_dir: 1.0 / (4.0 * std::f32::consts::PI),
            delta_position: true,
            part: 0,
        })
    }
}

fn floor_scene() -> (SceneDesc, Vec<Buffer>) {
    let mut desc = SceneDesc::default();
    let mut buffers = Vec::new();
    desc.materials.push(MaterialDesc {
        name: "white".into(),
        bsdf: BsdfDesc::Diffuse { reflectance: SpectrumDesc::constant(0.8) },
        emission: None,
        volume: None,
        one_sided: false,
        see_through: false,
    });
    let v = vec![-4.0, -4.0, 0.0, 4.0, -4.0, 0.0, 4.0, 4.0, 0.0, -4.0, 4.0, 0.0];
    add_mesh(&mut desc, &mut buffers, "floor", v, vec![0, 1, 2, 0, 2, 3], 0);
    desc.camera = serde_json::from_value(serde_json::json!({
        "to_world": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 5], [0, 0, 0, 1]],
        "focal_length": 30.0
    }))
    .expect("camera");
    (desc, buffers)
}

#[test]
fn every_method_and_direction_drops_non_finite_samples() {
    let (desc, buffers) = floor_scene();
    let grid = WavelengthGrid::uniform(9, 380.0, 780.0).unwrap();
    let (w, h) = (8, 6);
    for method in [Method::Polychromatic, Method::MonochromaticRays, Method::MonochromaticScenes, Method::Rgb] {
        for direction in [Direction::Backward, Direction::Forward, Direction::Bidirectional] {
            let g = if method == Method::Rgb {
                WavelengthGrid::rgb_channels(&grid, &RgbSpace::rec709()).unwrap()
            } else {
                grid.clone()
            };
            let opts = BuildOptions {
                grid: g.clone(),
                space: RgbSpace::rec709(),
                uplift: Default::default(),
                width: w,
                height: h,
            };
            let mut scene = Scene::build(&desc, &buffers, &opts).unwrap();
            scene.lights = vec![Box::new(PoisonLight { n: g.len() })];
            scene.light_distribution = Distribution1D::new(&[1.0]);
            scene.nee_distribution = Distribution1D::new(&[1.0]);
            scene.light_tree = LightTree::new(&[None], &[1.0]);
            let settings = ResolvedSettings {
                width: w,
                height: h,
                samples: 2,
                method,
                direction,
                grid: WavelengthGrid::uniform(9, 380.0, 780.0).unwrap(),
                spectral_output: true,
                ..Default::default()
            };
            let out = render_scene(&scene, &settings, &RenderControl::new()).unwrap();
            let what = format!("{method:?} {direction:?}");
            // BIDIRECTIONAL's forward part only traces caustic paths (none here), so the
            // poison reaches the film through the backward part there.
            assert!(out.stats.nonfinite_samples > 0, "{what}: the poisoned light was never counted");
            let im = &out.images;
            for (name, pass) in
                [("rgba", &im.rgba), ("depth", &im.depth), ("normal", &im.normal), ("albedo", &im.albedo)]
            {
                assert!(pass.iter().all(|v| v.is_finite()), "{what}: {name} pass has a non-finite value");
            }
            if let Some(s) = &im.spectral {
                assert!(s.iter().all(|v| v.is_finite()), "{what}: spectral pass has a non-finite value");
            }
        }
    }
}

#[test]
fn light_distribution_over_zero_or_non_finite_powers_picks_nothing() {
    for weights in [vec![0.0], vec![0.0, 0.0, 0.0], vec![f64::NAN, 0.0], vec![-1.0, 0.0]] {
        let d = Distribution1D::new(&weights);
        assert!(d.is_empty(), "{weights:?}");
        for u in [0.0, 0.5, 0.999_999] {
            assert_eq!(d.sample(u), None, "{weights:?}");
        }
        assert!((0..weights.len()).all(|i| d.pmf(i) == 0.0), "{weights:?}");
    }
    // A zero-power light beside a real one is never picked.
    let d = Distribution1D::new(&[0.0, 2.0, 0.0]);
    for k in 0..100 {
        assert_eq!(d.sample(k as f32 / 100.0), Some(1));
    }
}
