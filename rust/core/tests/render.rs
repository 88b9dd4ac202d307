//! End-to-end renders checked against closed-form results.

mod common;

use common::*;
use polychrome_core::render::{render, RenderControl, ResolvedSettings};
use polychrome_core::scene::{BsdfDesc, Buffer, LightDesc, MaterialDesc, SceneDesc};
use polychrome_core::spectrum::SpectrumDesc;

fn diffuse(name: &str, albedo: f32, emission: Option<f32>) -> MaterialDesc {
    MaterialDesc {
        name: name.into(),
        bsdf: BsdfDesc::Diffuse { reflectance: SpectrumDesc::constant(albedo) },
        emission: emission.map(SpectrumDesc::constant),
        volume: None,
        one_sided: false,
        see_through: false,
    }
}

/// Furnace: inside a closed surface of uniform emission L and albedo a, every point
/// sees L / (1 − a) (the Neumann series of the rendering equation).
#[test]
fn furnace_sphere_sees_emission_over_one_minus_albedo() {
    let (l, a) = (0.5f32, 0.6f32);
    let mut desc = SceneDesc::default();
    let mut buffers: Vec<Buffer> = Vec::new();
    desc.materials.push(diffuse("furnace", a, Some(l)));
    let (v, t) = uv_sphere([0.0; 3], 2.0, 24, 48);
    add_mesh(&mut desc, &mut buffers, "sphere", v, t, 0);
    let settings = ResolvedSettings { width: 24, height: 24, samples: 16, max_bounces: 200, ..Default::default() };
    let out = render(&desc, &buffers, &settings, &RenderControl::new()).unwrap();
    let (mean, se) = mean_and_standard_error(&out.images.rgba);
    let expected = l as f64 / (1.0 - a as f64);
    assert!((mean - expected).abs() < 4.0 * se + 1e-3, "mean {mean} expected {expected} (se {se})");
    assert!(se < 0.05 * expected, "too noisy to mean anything: se {se}");
    assert_eq!(out.stats.nonfinite_samples, 0);
}

#[test]
fn furnace_with_albedo_one_and_no_emission_is_black_and_finite() {
    let mut desc = SceneDesc::default();
    let mut buffers: Vec<Buffer> = Vec::new();
    desc.materials.push(diffuse("white", 1.0, None));
    let (v, t) = uv_sphere([0.0; 3], 2.0, 12, 24);
    add_mesh(&mut desc, &mut buffers, "sphere", v, t, 0);
    let settings = ResolvedSettings { width: 8, height: 8, samples: 4, max_bounces: 50, ..Default::default() };
    let out = render(&desc, &buffers, &settings, &RenderControl::new()).unwrap();
    assert!(out.images.rgba.chunks_exact(4).all(|p| p[0] == 0.0 && p[1] == 0.0 && p[2] == 0.0 && p[3] == 1.0));
    assert_eq!(out.stats.nonfinite_samples, 0);
}

/// A diffuse plane under a point light: L = ρ/π · I · cos θ / d².
#[test]
fn point_light_on_diffuse_plane_matches_inverse_square_cosine_law() {
    let (rho, intensity, h) = (0.7f32, 3.0f32, 2.0f32);
    let mut desc = SceneDesc::default();
    let mut buffers: Vec<Buffer> = Vec::new();
    desc.materials.push(diffuse("plane", rho, None));
    add_square(&mut desc, &mut buffers, "plane", 4.0, 0);
    desc.lights.push(LightDesc::Point {
        name: "lamp".into(),
        position: [0.0, 0.0, h],
        intensity: SpectrumDesc::constant(intensity),
        radius: 0.0,
        visibility: Default::default(),
        profile: None,
        motion: Vec::new(),
    });
    // Orthographic camera 5 units above looking down −Z, 4 units wide.
    desc.camera = ortho_down(4.0);
    let (w, hh) = (41u32, 41u32);
    let settings = ResolvedSettings { width: w, height: hh, samples: 64, max_bounces: 1, ..Default::default() };
    let out = render(&desc, &buffers, &settings, &RenderControl::new()).unwrap();
    // Equal-energy spectra have Y equal to their value, so compare luminance.
    for &(px, py) in &[(20u32, 20u32), (0, 20), (20, 40), (35, 5)] {
        let x = (px as f32 + 0.5) / w as f32 * 4.0 - 2.0;
        let y = 2.0 - (py as f32 + 0.5) / hh as f32 * 4.0;
        let d2 = x * x + y * y + h * h;
        let cos = h / d2.sqrt();
        let expected = (rho / std::f32::consts::PI * intensity * cos / d2) as f64;
        let i = ((py * w + px) * 4) as usize;
        let got = luminance(&out.images.rgba[i..i + 4]);
        // Pixel jitter averages the falloff over the footprint: a small, bounded bias.
        assert!((got - expected).abs() < 0.01 * expected, "pixel ({px},{py}): {got} vs {expected}");
    }
}

#[test]
fn same_seed_gives_identical_images_on_one_and_two_threads() {
    let mut desc = SceneDesc::default();
    let mut buffers: Vec<Buffer> = Vec::new();
    desc.materials.push(diffuse("grey", 0.5, None));
    desc.materials.push(diffuse("lamp", 0.0, Some(4.0)));
    let (v, t) = uv_sphere([0.0, 0.0, -4.0], 1.0, 12, 24);
    add_mesh(&mut desc, &mut buffers, "ball", v, t, 0);
    let (v, t) = uv_sphere([1.5, 1.5, -3.0], 0.3, 6, 12);
    add_mesh(&mut desc, &mut buffers, "light", v, t, 1);
    let base = ResolvedSettings { width: 20, height: 14, samples: 5, seed: 42, ..Default::default() };
    let one = render(&desc, &buffers, &ResolvedSettings { threads: 1, ..base.clone() }, &RenderControl::new()).unwrap();
    let two = render(&desc, &buffers, &ResolvedSettings { threads: 2, ..base.clone() }, &RenderControl::new()).unwrap();
    assert_eq!(one.images.rgba, two.images.rgba);
    assert!(one.images.rgba.iter().any(|&v| v > 0.0));
    let other = render(&desc, &buffers, &ResolvedSettings { seed: 43, ..base }, &RenderControl::new()).unwrap();
    assert_ne!(one.images.rgba, other.images.rgba);
}

#[test]
fn cancel_before_start_returns_no_samples() {
    let desc = SceneDesc::default();
    let control = RenderControl::new();
    control.cancel();
    let out = render(&desc, &[] as &[Buffer], &ResolvedSettings::default(), &control).unwrap();
    assert_eq!(out.stats.samples_per_pixel, 0);
    assert!(out.stats.cancelled);
}

#[test]
fn bad_mesh_data_names_the_mesh() {
    let mut desc = SceneDesc::default();
    let mut buffers: Vec<Buffer> = Vec::new();
    add_mesh(
        &mut desc,
        &mut buffers,
        "Broken",
        vec![0.0, 0.0, 0.0, 1.0, f32::NAN, 0.0, 0.0, 1.0, 0.0],
        vec![0, 1, 2],
        0,
    );
    let err = render(&desc, &buffers, &ResolvedSettings::default(), &RenderControl::new()).err().unwrap().to_string();
    assert!(err.contains("mesh 'Broken'") && err.contains("vertex 1"), "{err}");
    let mut desc = SceneDesc::default();
    let mut buffers: Vec<Buffer> = Vec::new();
    add_mesh(&mut desc, &mut buffers, "OutOfRange", vec![0.0; 9], vec![0, 1, 7], 0);
    let err = render(&desc, &buffers, &ResolvedSettings::default(), &RenderControl::new()).err().unwrap().to_string();
    assert!(err.contains("mesh 'OutOfRange'") && err.contains("vertex 7"), "{err}");
}

/// A diffuse plane seen from above under a uniform world of radiance L and a sun of
/// irradiance E straight down: L_o = ρ (L + E/π). The world is found by BSDF sampling
/// only (`Scene::nee_distribution`), whose cosine-weighted directions carry exactly ρ L
/// each, and the sun, now the only light sampled, is a delta: BACKWARD renders every
/// pixel at the closed form with no noise. (With the world among the sampled lights the
/// relative pixel spread at 16 spp was 18 %.)
#[test]
fn uniform_world_and_sun_on_a_diffuse_plane_render_without_noise() {
    let (rho, l, e) = (0.5f32, 0.3f32, 2.0f32);
    let mut desc = SceneDesc::default();
    let mut buffers: Vec<Buffer> = Vec::new();
    desc.materials.push(diffuse("plane", rho, None));
    add_square(&mut desc, &mut buffers, "plane", 50.0, 0);
    desc.world = Some(uniform_world(&SpectrumDesc::constant(l)));
    desc.lights.push(sun([0.0, 0.0, -1.0], e, 0.0));
    desc.camera = ortho_down(2.0);
    let settings = ResolvedSettings { width: 8, height: 8, samples: 16, max_bounces: 4, ..Default::default() };
    let out = render(&desc, &buffers, &settings, &RenderControl::new()).unwrap();
    let expected = (rho * (l + e / std::f32::consts::PI)) as f64;
    for p in out.images.rgba.chunks_exact(4) {
        let y = luminance(p);
        assert!((y - expected).abs() < 2e-3 * expected, "pixel {y} vs {expected}");
    }
}
