//! Point lights with a goniometric (IES) profile, end to end: a diffuse plane under a
//! point light whose profile is cos^k of the angle from straight down reads
//! L = ρ/π · I cos^k θ · cos θ / d² (closed form), also when the light is turned so that
//! its −Z points sideways, and light choice follows the profile's mean.

mod common;

use common::*;
use polychrome_core::render::{render, RenderControl, ResolvedSettings};
use polychrome_core::scene::{BsdfDesc, LightDesc, ProfileDesc, SceneDesc};
use polychrome_core::spectrum::SpectrumDesc;

/// The processed table of I(v) = cos^k v (v from the light's −Z, 0 beyond 90°) over
/// the full circle of h, every 2.5°.
fn cos_power(k: i32, to_local: [[f32; 3]; 3]) -> ProfileDesc {
    let v: Vec<f32> = (0..=72).map(|j| (2.5 * j as f32).to_radians()).collect();
    let h: Vec<f32> = (0..=8).map(|i| (45.0 * i as f32).to_radians()).collect();
    let values = h.iter().flat_map(|_| v.iter().map(|&a| a.cos().max(0.0).powi(k))).collect();
    ProfileDesc { h_angles: h, v_angles: v, values, to_local }
}

fn plane_under(profile: ProfileDesc, position: [f32; 3]) -> Vec<f32> {
    let mut desc = SceneDesc::default();
    let mut buffers = Vec::new();
    desc.materials.push(material("plane", BsdfDesc::Diffuse { reflectance: SpectrumDesc::constant(0.7) }));
    add_square(&mut desc, &mut buffers, "plane", 4.0, 0);
    desc.lights.push(LightDesc::Point {
        name: "lamp".into(),
        position,
        intensity: SpectrumDesc::constant(3.0),
        radius: 0.0,
        visibility: Default::default(),
        profile: Some(profile),
        motion: Vec::new(),
    });
    desc.camera = ortho_down(4.0);
    let settings = ResolvedSettings { width: 21, height: 21, samples: 16, max_bounces: 1, ..Default::default() };
    render(&desc, &buffers, &settings, &RenderControl::new()).unwrap().images.rgba
}

/// Pixel (px, py) of the 21² image over [−2, 2]²: its centre on the plane.
fn centre(px: u32, py: u32) -> (f32, f32) {
    ((px as f32 + 0.5) / 21.0 * 4.0 - 2.0, 2.0 - (py as f32 + 0.5) / 21.0 * 4.0)
}

#[test]
fn a_cosine_power_profile_lights_a_plane_as_its_closed_form() {
    let (rho, i0, h, k) = (0.7f32, 3.0f32, 1.5f32, 3);
    let identity = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let rgba = plane_under(cos_power(k, identity), [0.0, 0.0, h]);
    for (px, py) in [(10u32, 10u32), (14, 10), (17, 5), (3, 12), (19, 19)] {
        let (x, y) = centre(px, py);
        let d2 = x * x + y * y + h * h;
        let cos = h / d2.sqrt();
        let expected = (rho / std::f32::consts::PI * i0 * cos.powi(k) * cos / d2) as f64;
        let got = luminance(&rgba[((py * 21 + px) * 4) as usize..][..4]);
        // Pixel jitter averages the falloff over the footprint (0.19 units).
        assert!((got - expected).abs() < 0.03 * expected, "({px},{py}): {got} vs {expected}");
    }
}

/// The light at (−1.5, 0, 0.5) turned so that its −Z points along world +X (rows of the
/// world → light rotation): the plane is lit only where x > −1.5, brightest beyond it.
#[test]
fn the_profile_turns_with_the_light() {
    let (rho, i0, k) = (0.7f32, 3.0f32, 4);
    // Local −Z = world +X, local +X = world +Z, local +Y = world +Y.
    let to_local = [[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]];
    let p = [-1.5f32, 0.0, 0.5];
    let rgba = plane_under(cos_power(k, to_local), p);
    for (px, py) in [(12u32, 10u32), (16, 10), (19, 6), (2, 10), (5, 3)] {
        let (x, y) = centre(px, py);
        let d = glam::Vec3::new(x - p[0], y - p[1], -p[2]);
        let w = d.normalize();
        let along = w.x.max(0.0).powi(k); // cos of the angle from the light's −Z (+X)
        let expected = (rho / std::f32::consts::PI * i0 * along * (p[2] / d.length()) / d.length_squared()) as f64;
        let got = luminance(&rgba[((py * 21 + px) * 4) as usize..][..4]);
        assert!((got - expected).abs() < 0.04 * expected + 1e-4, "({px},{py}): {got} vs {expected}");
    }
}

#[test]
fn a_bad_profile_is_an_error_naming_the_light() {
    let mut bad = cos_power(1, [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]);
    bad.values.pop();
    let mut desc = SceneDesc::default();
    desc.lights.push(LightDesc::Point {
        name: "Odd Lamp".into(),
        position: [0.0, 0.0, 1.0],
        intensity: SpectrumDesc::constant(1.0),
        radius: 0.0,
        visibility: Default::default(),
        profile: Some(bad),
        motion: Vec::new(),
    });
    let e =
        render(&desc, &[] as &[polychrome_core::scene::Buffer], &ResolvedSettings::default(), &RenderControl::new())
            .err()
            .unwrap()
            .to_string();
    assert!(e.contains("Odd Lamp") && e.contains("values"), "{e}");
}
