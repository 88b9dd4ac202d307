//! The five methods and three directions (docs/design.md#methods) against closed forms and against
//! each other: furnaces (L/(1−a), white furnace), a lit box rendered every way, a
//! test-only dispersive BSDF for the collapse (eq. 9) and splitting logic, determinism.

mod common;

use common::*;
use glam::{Vec2, Vec3A};
use polychrome_core::color::{Observer, RgbSpace};
use polychrome_core::material::{Bsdf, BsdfFlags, BsdfSample, ShadingContext};
use polychrome_core::render::{
    render, render_scene, Collapse, Direction, Method, RenderControl, RenderSettings, ResolvedSettings,
};
use polychrome_core::sampling::cosine_hemisphere;
use polychrome_core::scene::{BsdfDesc, Buffer, BuildOptions, MaterialDesc, Scene, SceneDesc};
use polychrome_core::spectrum::named::{NoRgb, SpectrumKind, SpectrumRole};
use polychrome_core::spectrum::{SampledSpectrum, SpectrumDesc, WavelengthGrid};

fn diffuse(name: &str, reflectance: SpectrumDesc, emission: Option<SpectrumDesc>) -> MaterialDesc {
    MaterialDesc {
        name: name.into(),
        bsdf: BsdfDesc::Diffuse { reflectance },
        emission,
        volume: None,
        one_sided: false,
        see_through: false,
    }
}

/// A uniform world of `radiance` (through JSON, as every front end builds it).
fn furnace_scene(l: f32, a: f32) -> (SceneDesc, Vec<Buffer>) {
    let mut desc = SceneDesc::default();
    let mut buffers = Vec::new();
    desc.materials.push(diffuse("furnace", SpectrumDesc::constant(a), Some(SpectrumDesc::constant(l))));
    let (v, t) = uv_sphere([0.0; 3], 2.0, 24, 48);
    add_mesh(&mut desc, &mut buffers, "sphere", v, t, 0);
    (desc, buffers)
}

/// A closed box (inward-facing walls of different spectral reflectances) with a small
/// emissive quad under the ceiling; the camera inside looks at the back wall.
fn box_scene() -> (SceneDesc, Vec<Buffer>) {
    let mut desc = SceneDesc::default();
    let mut buffers = Vec::new();
    let refl = |kind| SpectrumDesc { kind, scale: 0.8 };
    desc.materials.push(diffuse("white", SpectrumDesc::constant(0.75), None));
    desc.materials.push(diffuse(
        "red",
        refl(SpectrumKind::Tabulated {
            wavelengths: vec![380.0, 560.0, 620.0, 780.0],
            values: vec![0.05, 0.08, 0.9, 0.95],
        }),
        None,
    ));
    desc.materials.push(diffuse("green", refl(SpectrumKind::NarrowBand { center: 530.0, width: 80.0 }), None));
    desc.materials.push(diffuse(
        "lamp",
        SpectrumDesc::constant(0.0),
        Some(SpectrumDesc { kind: SpectrumKind::Blackbody { temperature: 4000.0 }, scale: 8.0 }),
    ));
    let s = 1.0f32;
    let quad =
        |p: [[f32; 3]; 4]| -> (Vec<f32>, Vec<u32>) { (p.iter().flatten().copied().collect(), vec![0, 1, 2, 0, 2, 3]) };
    // Floor z=-1, ceiling z=1, walls x=±1, back y=1, front y=-1 (behind the camera).
    let (v, t) = quad([[-s, -s, -s], [s, -s, -s], [s, s, -s], [-s, s, -s]]);
    add_mesh(&mut desc, &mut buffers, "floor", v, t, 0);
    let (v, t) = quad([[-s, -s, s], [-s, s, s], [s, s, s], [s, -s, s]]);
    add_mesh(&mut desc, &mut buffers, "ceiling", v, t, 0);
    let (v, t) = quad([[-s, -s, -s], [-s, s, -s], [-s, s, s], [-s, -s, s]]);
    add_mesh(&mut desc, &mut buffers, "left", v, t, 1);
    let (v, t) = quad([[s, -s, -s], [s, -s, s], [s, s, s], [s, s, -s]]);
    add_mesh(&mut desc, &mut buffers, "right", v, t, 2);
    let (v, t) = quad([[-s, s, -s], [s, s, -s], [s, s, s], [-s, s, s]]);
    add_mesh(&mut desc, &mut buffers, "back", v, t, 0);
    let (v, t) = quad([[-s, -s, -s], [-s, -s, s], [s, -s, s], [s, -s, -s]]);
    add_mesh(&mut desc, &mut buffers, "front", v, t, 0);
    let l = 0.3f32;
    let (v, t) = quad([[-l, -l, 0.98], [l, -l, 0.98], [l, l, 0.98], [-l, l, 0.98]]);
    add_mesh(&mut desc, &mut buffers, "lamp", v, t, 3);
    // Camera at y = −0.95 looking along +y (Blender: local −Z → world +y, local +Y → +z).
    desc.camera.to_world = [[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, -1.0, -0.95], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]];
    desc.camera.focal_length = 18.0;
    (desc, buffers)
}

/// Mean of each RGB channel over all pixels and its standard error.
fn channel_means(rgba: &[f32]) -> [(f64, f64); 3] {
    std::array::from_fn(|c| {
        let v: Vec<f64> = rgba.chunks_exact(4).map(|p| p[c] as f64).collect();
        let n = v.len() as f64;
        let m = v.iter().sum::<f64>() / n;
        let var = v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0);
        (m, (var / n).sqrt())
    })
}

/// Means over the four image quadrants of each channel (12 numbers) with standard errors.
fn quadrant_means(rgba: &[f32], w: usize, h: usize) -> Vec<(f64, f64)> {
    let mut out = Vec::new();
    for q in 0..4 {
        let (qx, qy) = (q % 2, q / 2);
        let mut px = Vec::new();
        for y in qy * h / 2..(qy + 1) * h / 2 {
            for x in qx * w / 2..(qx + 1) * w / 2 {
                let i = (y * w + x) * 4;
                px.extend_from_slice(&rgba[i..i + 4]);
            }
        }
        out.extend(channel_means(&px));
    }
    out
}

/// A furnace whose object vanishes: every channel's mean over the image equals the
/// environment `env` through the CIE observer on `grid` (or as RGB on an RGB grid), within
/// five standard errors plus `rel` of the value; and no sample is non-finite.
fn assert_image_is_the_environment(
    images: &[f32],
    nonfinite: u64,
    env: &SpectrumDesc,
    grid: &WavelengthGrid,
    rel: f64,
    what: &str,
) {
    let env_values = env.evaluate(grid, SpectrumRole::Illuminant, &NoRgb).unwrap();
    let expected = RgbSpace::rec709().xyz_to_rgb(Observer::new(grid).xyz(&env_values));
    let means = channel_means(images);
    for c in 0..3 {
        let (m, se) = means[c];
        assert!(
            (m - expected[c]).abs() < 5.0 * se + rel * expected[c].abs(),
            "{what} channel {c}: {m} vs {} (se {se})",
            expected[c]
        );
    }
    assert_eq!(nonfinite, 0, "{what}");
}

fn assert_close(a: &[(f64, f64)], b: &[(f64, f64)], what: &str) {
    for (k, (&(ma, sa), &(mb, sb))) in a.iter().zip(b).enumerate() {
        let se = (sa * sa + sb * sb).sqrt();
        assert!((ma - mb).abs() < 5.0 * se + 2e-3 * mb.abs().max(1e-3), "{what}: value {k}: {ma} vs {mb} (se {se})");
    }
}

#[test]
fn furnace_forward_and_bidirectional_see_emission_over_one_minus_albedo() {
    let (l, a) = (0.5f32, 0.6f32);
    let (desc, buffers) = furnace_scene(l, a);
    let expected = l as f64 / (1.0 - a as f64);
    for direction in [Direction::Forward, Direction::Bidirectional] {
        for method in [Method::Polychromatic, Method::MonochromaticRays, Method::Hero] {
            // Monochromatic and hero light paths are not stratified per pixel: more of them.
            let samples = if method == Method::Polychromatic { 16 } else { 64 };
            let settings = ResolvedSettings {
                width: 16,
                height: 16,
                samples,
                max_bounces: 200,
                method,
                direction,
                ..Default::default()
            };
            let out = render(&desc, &buffers, &settings, &RenderControl::new()).unwrap();
            let (mean, se) = mean_and_standard_error(&out.images.rgba);
            assert!(
                (mean - expected).abs() < 5.0 * se + 2e-3,
                "{direction:?} {method:?}: mean {mean} expected {expected} (se {se})"
            );
            assert!(se < 0.05 * expected, "{direction:?} {method:?}: too noisy: se {se}");
            assert_eq!(out.stats.nonfinite_samples, 0);
        }
    }
}

#[test]
fn furnace_monochromatic_scenes_and_rgb_match_the_closed_form() {
    let (l, a) = (0.5f32, 0.6f32);
    let (desc, buffers) = furnace_scene(l, a);
    let expected = l as f64 / (1.0 - a as f64);
    for (method, n) in [(Method::MonochromaticScenes, 8usize), (Method::Rgb, 41)] {
        let settings = ResolvedSettings {
            width: 12,
            height: 12,
            samples: 8,
            max_bounces: 200,
            method,
            grid: WavelengthGrid::uniform(n, 380.0, 780.0).unwrap(),
            ..Default::default()
        };
        let control = RenderControl::new();
        let out = render(&desc, &buffers, &settings, &control).unwrap();
        let (mean, se) = mean_and_standard_error(&out.images.rgba);
        assert!((mean - expected).abs() < 5.0 * se + 2e-3, "{method:?}: mean {mean} expected {expected} (se {se})");
        let (done, total) = control.progress();
        assert_eq!(done, total);
        let per_image = 12 * 12 * 8;
        assert_eq!(total, if method == Method::MonochromaticScenes { per_image * n as u64 } else { per_image });
    }
}

/// Each (method, direction, samples) case renders `desc` at 16² (21 wavelengths, 6
/// bounces) with quadrant means equal to polychromatic BACKWARD's at 256 spp within
/// noise, and no non-finite sample.
fn assert_cases_agree_with_polychromatic_backward(
    desc: &SceneDesc,
    buffers: &[Buffer],
    cases: &[(Method, Direction, u32)],
) {
    let (w, h) = (16usize, 16usize);
    let base = ResolvedSettings {
        width: w as u32,
        height: h as u32,
        max_bounces: 6,
        grid: WavelengthGrid::uniform(21, 380.0, 780.0).unwrap(),
        ..Default::default()
    };
    let reference =
        render(desc, buffers, &ResolvedSettings { samples: 256, ..base.clone() }, &RenderControl::new()).unwrap();
    let reference = quadrant_means(&reference.images.rgba, w, h);
    assert!(reference.iter().all(|&(m, _)| m > 0.0));
    for &(method, direction, samples) in cases {
        let out = render(
            desc,
            buffers,
            &ResolvedSettings { method, direction, samples, ..base.clone() },
            &RenderControl::new(),
        )
        .unwrap();
        assert_eq!(out.stats.nonfinite_samples, 0);
        assert_close(&quadrant_means(&out.images.rgba, w, h), &reference, &format!("{method:?} {direction:?}"));
    }
}

#[test]
fn every_method_and_direction_agrees_with_polychromatic_backward_on_a_lit_box() {
    let (desc, buffers) = box_scene();
    let cases = [
        (Method::MonochromaticRays, Direction::Backward, 128),
        (Method::MonochromaticScenes, Direction::Backward, 16),
        (Method::Polychromatic, Direction::Forward, 128),
        (Method::Polychromatic, Direction::Bidirectional, 64),
        (Method::MonochromaticRays, Direction::Forward, 256),
        (Method::Hero, Direction::Backward, 128),
        (Method::Hero, Direction::Forward, 256),
        (Method::Hero, Direction::Bidirectional, 128),
    ];
    assert_cases_agree_with_polychromatic_backward(&desc, &buffers, &cases);
}

/// The lit box with its lamp replaced by a sphere light (reached by BSDF rays and MIS-
/// weighted against its cone samples) beside a smooth glass ball; light paths start on
/// the sphere. Every direction and method agrees with polychromatic BACKWARD (the
/// caustic's closed form: hit_lights.rs).
#[test]
fn every_method_and_direction_agrees_under_a_sphere_light_over_glass() {
    let (mut desc, mut buffers) = box_scene();
    desc.meshes.retain(|m| m.name != "lamp");
    desc.lights.push(polychrome_core::scene::LightDesc::Point {
        name: "sphere".into(),
        position: [0.2, 0.4, 0.5],
        intensity: SpectrumDesc { kind: SpectrumKind::Blackbody { temperature: 4000.0 }, scale: 1.5 },
        radius: 0.2,
        visibility: Default::default(),
        profile: None,
        motion: Vec::new(),
    });
    desc.materials.push(MaterialDesc {
        name: "glass".into(),
        bsdf: BsdfDesc::Dielectric { ior: polychrome_core::material::IorDesc::Constant { ior: 1.5 }, roughness: 0.0 },
        emission: None,
        volume: None,
        one_sided: false,
        see_through: false,
    });
    let (v, t) = uv_sphere([0.1, 0.4, -0.7], 0.3, 16, 32);
    let glass = desc.materials.len() as u32 - 1;
    add_mesh(&mut desc, &mut buffers, "ball", v, t, glass);
    let cases = [
        (Method::MonochromaticRays, Direction::Backward, 128),
        (Method::Polychromatic, Direction::Forward, 128),
        (Method::Polychromatic, Direction::Bidirectional, 64),
        (Method::Hero, Direction::Backward, 128),
        (Method::Hero, Direction::Bidirectional, 128),
    ];
    assert_cases_agree_with_polychromatic_backward(&desc, &buffers, &cases);
}

#[test]
fn bidirectional_with_a_panorama_uses_the_camera_strategies_alone() {
    // Light paths cannot reach a panoramic camera: BIDIRECTIONAL must still converge to
    // BACKWARD (its MIS weights give the camera strategies the whole path).
    let (mut desc, buffers) = box_scene();
    desc.camera.projection = polychrome_core::camera::Projection::Panoramic;
    desc.camera.to_world[1][3] = 0.0; // the middle of the box
    let (w, h) = (16usize, 8usize);
    let base = ResolvedSettings {
        width: w as u32,
        height: h as u32,
        max_bounces: 4,
        grid: WavelengthGrid::uniform(8, 380.0, 780.0).unwrap(),
        ..Default::default()
    };
    let reference =
        render(&desc, &buffers, &ResolvedSettings { samples: 256, ..base.clone() }, &RenderControl::new()).unwrap();
    let out = render(
        &desc,
        &buffers,
        &ResolvedSettings { direction: Direction::Bidirectional, samples: 128, ..base.clone() },
        &RenderControl::new(),
    )
    .unwrap();
    assert_close(&block_means(&out.images.rgba, w, h, 4), &block_means(&reference.images.rgba, w, h, 4), "panorama");
}

/// Means of each channel over `b`×`b` pixel blocks, with standard errors.
fn block_means(rgba: &[f32], w: usize, h: usize, b: usize) -> Vec<(f64, f64)> {
    let mut out = Vec::new();
    for by in (0..h).step_by(b) {
        for bx in (0..w).step_by(b) {
            let mut px = Vec::new();
            for y in by..(by + b).min(h) {
                for x in bx..(bx + b).min(w) {
                    let i = (y * w + x) * 4;
                    px.extend_from_slice(&rgba[i..i + 4]);
                }
            }
            out.extend(channel_means(&px));
        }
    }
    out
}

#[test]
fn light_tracing_through_a_thin_lens_agrees_with_camera_paths() {
    // The lit box far out of focus (focus 0.3 in front of a back wall at 1.95; the lamp
    // blurred over about six pixels): light paths connect through a sampled lens point with
    // the thin lens's importance; 4×4-pixel blocks must match the camera-path image.
    let (mut desc, buffers) = box_scene();
    desc.camera.aperture_radius = 0.3;
    desc.camera.focus_distance = 0.3;
    desc.camera.aperture_blades = 6;
    desc.camera.aperture_ratio = 1.5;
    let (w, h) = (16usize, 16usize);
    let base = ResolvedSettings {
        width: w as u32,
        height: h as u32,
        max_bounces: 4,
        grid: WavelengthGrid::uniform(8, 380.0, 780.0).unwrap(),
        ..Default::default()
    };
    let reference =
        render(&desc, &buffers, &ResolvedSettings { samples: 512, ..base.clone() }, &RenderControl::new()).unwrap();
    let reference = block_means(&reference.images.rgba, w, h, 4);
    for (direction, samples) in [(Direction::Forward, 256), (Direction::Bidirectional, 128)] {
        let out =
            render(&desc, &buffers, &ResolvedSettings { direction, samples, ..base.clone() }, &RenderControl::new())
                .unwrap();
        assert_eq!(out.stats.nonfinite_samples, 0);
        assert_close(&block_means(&out.images.rgba, w, h, 4), &reference, &format!("thin lens {direction:?}"));
    }
}

#[test]
fn same_seed_gives_identical_images_on_one_and_two_threads_for_every_method() {
    let (desc, buffers) = box_scene();
    for (method, direction) in [
        (Method::MonochromaticRays, Direction::Backward),
        (Method::MonochromaticScenes, Direction::Backward),
        (Method::Polychromatic, Direction::Forward),
        (Method::Rgb, Direction::Bidirectional),
        (Method::Hero, Direction::Backward),
        (Method::Hero, Direction::Forward),
    ] {
        let base = ResolvedSettings {
            width: 20,
            height: 14,
            samples: 3,
            seed: 7,
            method,
            direction,
            grid: WavelengthGrid::uniform(8, 380.0, 780.0).unwrap(),
            ..Default::default()
        };
        let one =
            render(&desc, &buffers, &ResolvedSettings { threads: 1, ..base.clone() }, &RenderControl::new()).unwrap();
        let two =
            render(&desc, &buffers, &ResolvedSettings { threads: 2, ..base.clone() }, &RenderControl::new()).unwrap();
        assert_eq!(one.images.rgba, two.images.rgba, "{method:?} {direction:?}");
        assert!(one.images.rgba.iter().any(|&v| v > 0.0));
    }
}

/// A test-only dispersive BSDF: a white (albedo 1) cosine reflector that, like a
/// dispersive dielectric, must collapse a polychromatic path to one wavelength (eq. 9):
/// the wavelength is chosen ∝ the path's energy (throughput × grid weight), the
/// throughput becomes that sample divided by its probability, and the sampled direction
/// depends on the wavelength (rotated about the normal by an angle ∝ λ).
struct TestDispersive;

impl Bsdf for TestDispersive {
    fn flags(&self) -> BsdfFlags {
        BsdfFlags { smooth: false, specular: true, dispersive: true }
    }
    fn eval(&self, _: &ShadingContext, _: Vec3A, _: Vec3A, out: &mut SampledSpectrum) -> f32 {
        out.fill(0.0);
        0.0
    }
    fn pdf(&self, _: &ShadingContext, _: Vec3A, _: Vec3A) -> f32 {
        0.0
    }
    fn sample(
        &self,
        ctx: &ShadingContext,
        wo: Vec3A,
        u: Vec2,
        uc: f32,
        throughput: &mut SampledSpectrum,
    ) -> Option<BsdfSample> {
        let i = match ctx.single_wavelength {
            Some(i) => {
                throughput.keep_only(i);
                i
            }
            None => {
                let w = ctx.grid.weights();
                let energy: Vec<f32> = (0..throughput.len()).map(|k| throughput.get(k).max(0.0) * w[k]).collect();
                let total: f32 = energy.iter().sum();
                if !(total > 0.0) {
                    return None;
                }
                let mut acc = 0.0;
                let mut i = energy.len() - 1;
                for (k, e) in energy.iter().enumerate() {
                    acc += e / total;
                    if uc < acc {
                        i = k;
                        break;
                    }
                }
                let p = energy[i] / total;
                if !(p > 0.0) {
                    return None;
                }
                throughput.keep_only(i);
                throughput.scale(1.0 / p);
                i
            }
        };
        let d = cosine_hemisphere(u);
        let angle = ctx.grid.lambdas()[i] * 0.05;
        let (s, c) = angle.sin_cos();
        let mut wi = Vec3A::new(c * d.x - s * d.y, s * d.x + c * d.y, d.z);
        if wo.z < 0.0 {
            wi.z = -wi.z;
        }
        Some(BsdfSample { wi, pdf: 1.0, specular: true, collapsed_to: Some(i) })
    }
    fn albedo(&self, _: &ShadingContext, out: &mut SampledSpectrum) {
        out.fill(1.0);
    }
}

/// White furnace with dispersion: an albedo-1 dispersive sphere inside a uniform,
/// strongly coloured environment is invisible, whatever the method: every pixel sees the
/// environment's colour. Proves the collapse weight (and splitting) is unbiased.
#[test]
fn dispersive_white_sphere_vanishes_in_a_uniform_environment_in_every_method() {
    let mut desc = SceneDesc::default();
    let mut buffers = Vec::new();
    desc.materials.push(diffuse("glass", SpectrumDesc::constant(1.0), None));
    let (v, t) = uv_sphere([0.0, 0.0, -4.0], 1.5, 16, 32);
    add_mesh(&mut desc, &mut buffers, "ball", v, t, 0);
    let env = SpectrumDesc { kind: SpectrumKind::Blackbody { temperature: 2500.0 }, scale: 1.0 };
    desc.world = Some(uniform_world(&env));
    let (w, h) = (12u32, 12u32);
    let grid = WavelengthGrid::uniform(21, 380.0, 780.0).unwrap();
    for (method, splitting) in [
        (Method::Polychromatic, false),
        (Method::Polychromatic, true),
        (Method::MonochromaticRays, false),
        (Method::MonochromaticScenes, false),
        (Method::Rgb, false),
        (Method::Hero, false),
    ] {
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
        scene.materials[0].bsdf = Box::new(TestDispersive);
        let samples = if method == Method::MonochromaticScenes { 8 } else { 64 };
        let settings = ResolvedSettings {
            width: w,
            height: h,
            samples,
            max_bounces: 64,
            method,
            dispersion_splitting: splitting,
            grid: WavelengthGrid::uniform(21, 380.0, 780.0).unwrap(),
            ..Default::default()
        };
        let out = render_scene(&scene, &settings, &RenderControl::new()).unwrap();
        let what = format!("{method:?} split={splitting}");
        assert_image_is_the_environment(&out.images.rgba, out.stats.nonfinite_samples, &env, &g, 2e-3, &what);
    }
}

/// docs/design.md#why-spectral (a): a narrow-band red light on a green sphere. RGB mode multiplies RGBs and
/// gets a very different colour from the spectral product.
#[test]
fn rgb_mode_differs_from_spectral_under_narrow_band_light() {
    let mut desc = SceneDesc::default();
    let mut buffers = Vec::new();
    let green = SpectrumDesc { kind: SpectrumKind::NarrowBand { center: 540.0, width: 60.0 }, scale: 0.9 };
    desc.materials.push(diffuse("green", green, None));
    desc.world = Some(uniform_world(&SpectrumDesc {
        kind: SpectrumKind::NarrowBand { center: 610.0, width: 20.0 },
        scale: 1.0,
    }));
    let (v, t) = uv_sphere([0.0, 0.0, -4.0], 3.0, 16, 32);
    add_mesh(&mut desc, &mut buffers, "ball", v, t, 0);
    let base = ResolvedSettings { width: 8, height: 8, samples: 16, max_bounces: 1, ..Default::default() };
    let spectral = render(&desc, &buffers, &base, &RenderControl::new()).unwrap();
    let rgb =
        render(&desc, &buffers, &ResolvedSettings { method: Method::Rgb, ..base }, &RenderControl::new()).unwrap();
    // Centre pixel: the spectral product of a 610 nm band and a 540 nm reflectance is
    // far dimmer than RGB's red × green-channel product predicts, and differently hued.
    let i = (4 * 8 + 4) * 4;
    let s = &spectral.images.rgba[i..i + 3];
    let r = &rgb.images.rgba[i..i + 3];
    assert!(s.iter().chain(r).all(|v| v.is_finite()));
    let ys = luminance(&spectral.images.rgba[i..i + 4]);
    let yr = luminance(&rgb.images.rgba[i..i + 4]);
    assert!((ys - yr).abs() > 0.3 * ys.max(yr), "spectral {s:?} vs rgb {r:?}");
}

#[test]
fn bad_combinations_are_reported_as_settings() {
    let (desc, buffers) = furnace_scene(0.5, 0.5);
    let s = ResolvedSettings {
        width: 4,
        height: 4,
        samples: 1,
        method: Method::MonochromaticRays,
        dispersion_splitting: true,
        ..Default::default()
    };
    let err = render(&desc, &buffers, &s, &RenderControl::new()).err().unwrap().to_string();
    assert!(err.contains("dispersion_splitting"), "{err}");
    let json = r#"{"method": "MONOCHROMATIC_SCENES", "direction": "BIDIRECTIONAL", "dispersion_splitting": false}"#;
    let parsed = RenderSettings::from_json(json).unwrap();
    assert_eq!((parsed.method, parsed.direction), (Method::MonochromaticScenes, Direction::Bidirectional));
}

fn glass(name: &str) -> MaterialDesc {
    serde_json::from_value(serde_json::json!({
        "name": name,
        "bsdf": { "type": "dielectric", "ior": { "type": "named", "name": "N-SF11" } }
    }))
    .expect("dielectric description")
}

/// Glass furnace: a dispersive dense-flint sphere (part A's dielectric) in a uniform,
/// coloured environment is invisible in every backward method, with collapse (eq. 9)
/// or splitting.
#[test]
fn dispersive_glass_sphere_vanishes_in_a_uniform_environment() {
    let mut desc = SceneDesc::default();
    let mut buffers = Vec::new();
    desc.materials.push(glass("flint"));
    let (v, t) = uv_sphere([0.0, 0.0, -4.0], 1.5, 24, 48);
    add_mesh(&mut desc, &mut buffers, "ball", v, t, 0);
    let env = SpectrumDesc { kind: SpectrumKind::Blackbody { temperature: 2500.0 }, scale: 1.0 };
    desc.world = Some(uniform_world(&env));
    for (method, splitting, samples) in [
        (Method::Polychromatic, false, 64),
        (Method::Polychromatic, true, 16),
        (Method::MonochromaticRays, false, 64),
        (Method::MonochromaticScenes, false, 4),
        (Method::Rgb, false, 64),
        (Method::Hero, false, 64),
    ] {
        let settings = ResolvedSettings {
            width: 12,
            height: 12,
            samples,
            max_bounces: 64,
            method,
            dispersion_splitting: splitting,
            grid: WavelengthGrid::uniform(21, 380.0, 780.0).unwrap(),
            ..Default::default()
        };
        let out = render(&desc, &buffers, &settings, &RenderControl::new()).unwrap();
        let g = settings.grid.clone();
        let g = if method == Method::Rgb { WavelengthGrid::rgb_channels(&g, &RgbSpace::rec709()).unwrap() } else { g };
        let what = format!("{method:?} split={splitting}");
        assert_image_is_the_environment(&out.images.rgba, out.stats.nonfinite_samples, &env, &g, 5e-3, &what);
    }
}

/// The glass furnace with the other wavelength choices at the collapse (setting
/// `collapse`): STRATIFIED and SPLIT (k = 3, and k = 40 above the grid's 21) keep the
/// dispersive sphere invisible against the environment's colour, backward and
/// bidirectional (whose light paths collapse stratified).
#[test]
fn every_collapse_strategy_keeps_the_glass_furnace_at_the_closed_form() {
    let mut desc = SceneDesc::default();
    let mut buffers = Vec::new();
    desc.materials.push(glass("flint"));
    let (v, t) = uv_sphere([0.0, 0.0, -4.0], 1.5, 24, 48);
    add_mesh(&mut desc, &mut buffers, "ball", v, t, 0);
    let env = SpectrumDesc { kind: SpectrumKind::Blackbody { temperature: 2500.0 }, scale: 1.0 };
    desc.world = Some(uniform_world(&env));
    for (collapse, k, direction, samples) in [
        (Collapse::Stratified, 4, Direction::Backward, 64),
        (Collapse::Split, 3, Direction::Backward, 32),
        (Collapse::Split, 40, Direction::Backward, 4),
        (Collapse::Stratified, 4, Direction::Bidirectional, 32),
        (Collapse::Split, 3, Direction::Bidirectional, 16),
    ] {
        let settings = ResolvedSettings {
            width: 12,
            height: 12,
            samples,
            max_bounces: 64,
            collapse,
            collapse_k: k,
            direction,
            grid: WavelengthGrid::uniform(21, 380.0, 780.0).unwrap(),
            ..Default::default()
        };
        let out = render(&desc, &buffers, &settings, &RenderControl::new()).unwrap();
        let what = format!("{collapse:?} k={k} {direction:?}");
        assert_image_is_the_environment(
            &out.images.rgba,
            out.stats.nonfinite_samples,
            &env,
            &settings.grid,
            5e-3,
            &what,
        );
    }
}

/// A dispersive glass ball inside the emissive furnace sphere: still L/(1−a) for the
/// camera, in the forward and bidirectional directions too (light paths refract through
/// the glass in importance mode).
#[test]
fn glass_ball_inside_a_furnace_is_invisible_forward_and_backward() {
    let (l, a) = (0.5f32, 0.6f32);
    let (mut desc, mut buffers) = furnace_scene(l, a);
    desc.materials.push(glass("flint"));
    let (v, t) = uv_sphere([0.0, 0.6, -0.3], 0.6, 16, 32);
    add_mesh(&mut desc, &mut buffers, "ball", v, t, 1);
    // Camera inside the furnace looking at the ball.
    desc.camera.to_world = [[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, -1.0, -1.2], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]];
    let expected = l as f64 / (1.0 - a as f64);
    // Light tracing cannot see through glass from a pinhole (camera → specular vertex
    // paths are backward-only), so for FORWARD a second ball sits behind the camera
    // where it only redirects light; the others see a ball in the middle of the view.
    let mut behind = desc.clone();
    let mut behind_buffers = buffers.clone();
    behind.meshes.pop();
    behind_buffers.truncate(behind_buffers.len() - 2);
    let (v, t) = uv_sphere([0.0, -1.65, 0.0], 0.3, 16, 32);
    add_mesh(&mut behind, &mut behind_buffers, "ball", v, t, 1);
    for (method, direction, samples) in [
        (Method::Polychromatic, Direction::Backward, 32),
        (Method::Polychromatic, Direction::Forward, 32),
        (Method::Polychromatic, Direction::Bidirectional, 32),
        (Method::MonochromaticRays, Direction::Backward, 32),
        (Method::Hero, Direction::Backward, 32),
        (Method::Hero, Direction::Forward, 64),
    ] {
        let (desc, buffers) =
            if direction == Direction::Forward { (&behind, &behind_buffers) } else { (&desc, &buffers) };
        let settings = ResolvedSettings {
            width: 12,
            height: 12,
            samples,
            max_bounces: 200,
            method,
            direction,
            grid: WavelengthGrid::uniform(21, 380.0, 780.0).unwrap(),
            ..Default::default()
        };
        let out = render(desc, buffers, &settings, &RenderControl::new()).unwrap();
        let (mean, se) = mean_and_standard_error(&out.images.rgba);
        assert!(
            (mean - expected).abs() < 5.0 * se + 5e-3,
            "{method:?} {direction:?}: mean {mean} expected {expected} (se {se})"
        );
        assert_eq!(out.stats.nonfinite_samples, 0);
    }
}

/// A point light between a diffuse floor and a smooth silver mirror: the mirror's
/// caustic (light → specular → floor → camera) is unreachable backward. BIDIRECTIONAL
/// adds it from light paths and must agree with FORWARD (which the camera-visible floor
/// makes complete here); BACKWARD alone is visibly darker.
#[test]
fn bidirectional_adds_the_point_light_caustic_that_backward_misses() {
    let mut desc = SceneDesc::default();
    let mut buffers = Vec::new();
    desc.materials.push(diffuse("floor", SpectrumDesc::constant(0.8), None));
    desc.materials.push(
        serde_json::from_value(serde_json::json!({"name": "mirror", "bsdf": {"type": "conductor", "metal": "silver"}}))
            .unwrap(),
    );
    let s = 2.0f32;
    add_mesh(
        &mut desc,
        &mut buffers,
        "floor",
        vec![-s, -s, 0.0, s, -s, 0.0, s, s, 0.0, -s, s, 0.0],
        vec![0, 1, 2, 0, 2, 3],
        0,
    );
    add_mesh(
        &mut desc,
        &mut buffers,
        "mirror",
        vec![-s, -s, 2.0, -s, s, 2.0, s, s, 2.0, s, -s, 2.0],
        vec![0, 1, 2, 0, 2, 3],
        1,
    );
    desc.lights.push(serde_json::from_value(serde_json::json!({"type": "point", "name": "lamp", "position": [0.0, 0.0, 1.0], "intensity": {"type": "constant", "value": 2.0}})).unwrap());
    // Camera at (0, −3, 0.8) looking at the origin (Blender convention, −Z forward).
    let m = look_at([0.0, -3.0, 0.8], [0.0, 0.0, 0.0]);
    desc.camera.to_world = m;
    let (w, h) = (16usize, 16usize);
    let base = ResolvedSettings {
        width: w as u32,
        height: h as u32,
        max_bounces: 2,
        grid: WavelengthGrid::uniform(16, 380.0, 780.0).unwrap(),
        ..Default::default()
    };
    let fwd = render(
        &desc,
        &buffers,
        &ResolvedSettings { direction: Direction::Forward, samples: 64, ..base.clone() },
        &RenderControl::new(),
    )
    .unwrap();
    let bid = render(
        &desc,
        &buffers,
        &ResolvedSettings { direction: Direction::Bidirectional, samples: 32, ..base.clone() },
        &RenderControl::new(),
    )
    .unwrap();
    let bwd = render(
        &desc,
        &buffers,
        &ResolvedSettings { direction: Direction::Backward, samples: 32, ..base.clone() },
        &RenderControl::new(),
    )
    .unwrap();
    let (f, b, k) = (
        quadrant_means(&fwd.images.rgba, w, h),
        quadrant_means(&bid.images.rgba, w, h),
        quadrant_means(&bwd.images.rgba, w, h),
    );
    assert_close(&b, &f, "bidirectional vs forward");
    let total = |q: &[(f64, f64)]| q.iter().map(|v| v.0).sum::<f64>();
    assert!(total(&k) < 0.85 * total(&b), "backward {} should miss the caustic ({} with it)", total(&k), total(&b));
}

#[test]
fn forward_needs_a_perspective_camera_and_time_limited_mono_scenes_say_so() {
    let (mut desc, buffers) = furnace_scene(0.5, 0.5);
    desc.camera.projection = polychrome_core::camera::Projection::Orthographic;
    let s = ResolvedSettings { width: 4, height: 4, samples: 1, direction: Direction::Forward, ..Default::default() };
    let err = render(&desc, &buffers, &s, &RenderControl::new()).err().unwrap().to_string();
    assert!(err.contains("direction") && err.contains("perspective"), "{err}");
    desc.camera.projection = polychrome_core::camera::Projection::Panoramic;
    let err = render(&desc, &buffers, &s, &RenderControl::new()).err().unwrap().to_string();
    assert!(err.contains("direction") && err.contains("panoramic"), "{err}");
    let (desc, buffers) = furnace_scene(0.5, 0.5);
    let s = ResolvedSettings {
        width: 8,
        height: 8,
        samples: 64,
        method: Method::MonochromaticScenes,
        time_limit: 1e-9,
        ..Default::default()
    };
    let out = render(&desc, &buffers, &s, &RenderControl::new()).unwrap();
    assert!(out.stats.time_limited && out.stats.incomplete_spectrum);
    let s = ResolvedSettings { samples: 2, time_limit: 0.0, ..s };
    assert!(!render(&desc, &buffers, &s, &RenderControl::new()).unwrap().stats.incomplete_spectrum);
}

/// A lamp seen through one rough dielectric interface (a frosted pane with the lamp
/// on its far side): every path to the camera crosses it by rough refraction, which
/// next-event estimation (camera paths) and the camera connection (light paths) must
/// follow to the other side of the surface. FORWARD, BIDIRECTIONAL and BACKWARD then
/// agree; before, light tracing saw nothing through the pane and camera paths lost the
/// share MIS gave the missing connection.
#[test]
fn rough_transmission_is_connected_through_in_every_direction() {
    let mut desc = SceneDesc::default();
    let mut buffers = Vec::new();
    desc.materials.push(
        serde_json::from_value(serde_json::json!({"name": "frosted",
            "bsdf": {"type": "dielectric", "ior": {"type": "constant", "ior": 1.5}, "roughness": 0.4}}))
        .unwrap(),
    );
    desc.materials.push(diffuse("lamp", SpectrumDesc::constant(0.0), Some(SpectrumDesc::constant(2.0))));
    let quad = |z: f32, s: f32| -> (Vec<f32>, Vec<u32>) {
        (vec![-s, -s, z, s, -s, z, s, s, z, -s, s, z], vec![0, 1, 2, 0, 2, 3])
    };
    let (v, t) = quad(0.0, 1.0);
    add_mesh(&mut desc, &mut buffers, "pane", v, t, 0);
    let (v, t) = quad(-0.4, 0.5);
    add_mesh(&mut desc, &mut buffers, "lamp", v, t, 1);
    desc.camera.to_world = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 2.0], [0.0, 0.0, 0.0, 1.0]];
    let base = ResolvedSettings {
        width: 16,
        height: 16,
        max_bounces: 8,
        grid: WavelengthGrid::uniform(9, 400.0, 700.0).unwrap(),
        ..Default::default()
    };
    let mean = |direction, samples| {
        let out =
            render(&desc, &buffers, &ResolvedSettings { direction, samples, ..base.clone() }, &RenderControl::new())
                .unwrap();
        assert_eq!(out.stats.nonfinite_samples, 0);
        mean_and_standard_error(&out.images.rgba).0
    };
    let backward = mean(Direction::Backward, 128);
    assert!(backward > 0.05, "the lamp shows through the pane: {backward}");
    for (direction, samples) in [(Direction::Forward, 512), (Direction::Bidirectional, 128)] {
        let m = mean(direction, samples);
        assert!((m - backward).abs() < 0.03 * backward, "{direction:?}: image mean {m} vs BACKWARD {backward}");
    }
}

/// HERO against the whole grid where the wavelengths matter most: the camera looks
/// through a dispersive N-SF11 prism at the edge of a strip light of CIE F11 (a line
/// spectrum) and at a white floor the strip lights. Both converge to the grid's
/// quadrature, so 4×4-pixel block means of HERO (BACKWARD, and BIDIRECTIONAL with the
/// partition) must match a 512-spp POLYCHROMATIC image within their standard errors.
#[test]
fn hero_agrees_with_polychromatic_through_a_prism_under_a_line_spectrum_light() {
    let mut desc = SceneDesc::default();
    let mut buffers = Vec::new();
    desc.materials.push(diffuse("floor", SpectrumDesc::constant(0.8), None));
    desc.materials.push(diffuse(
        "panel",
        SpectrumDesc::constant(0.0),
        Some(SpectrumDesc { kind: SpectrumKind::Fluorescent { index: 11 }, scale: 4.0 }),
    ));
    desc.materials.push(glass("flint"));
    let quad =
        |p: [[f32; 3]; 4]| -> (Vec<f32>, Vec<u32>) { (p.iter().flatten().copied().collect(), vec![0, 1, 2, 0, 2, 3]) };
    let (v, t) = quad([[-3.0, -1.0, -1.0], [3.0, -1.0, -1.0], [3.0, 6.0, -1.0], [-3.0, 6.0, -1.0]]);
    add_mesh(&mut desc, &mut buffers, "floor", v, t, 0);
    // An emissive strip across the back, its top edge seen through the prism: each
    // wavelength sees the edge elsewhere (a rainbow fringe).
    let (v, t) = quad([[-4.0, 5.0, -1.0], [-4.0, 5.0, 0.3], [4.0, 5.0, 0.3], [4.0, 5.0, -1.0]]);
    add_mesh(&mut desc, &mut buffers, "panel", v, t, 1);
    // A 20° prism along x between camera and strip, apex up: it deviates rays down by
    // about 16° (N-SF11) and spreads them by about 1° over the visible range.
    let (x0, x1) = (-1.5f32, 1.5f32);
    let tri = [[1.7f32, -0.6], [2.1, -0.6], [1.9, 0.53]]; // (y, z)
    let mut pv = Vec::new();
    for x in [x0, x1] {
        for [y, z] in tri {
            pv.extend_from_slice(&[x, y, z]);
        }
    }
    let pt = vec![0, 2, 1, 3, 4, 5, 0, 1, 4, 0, 4, 3, 1, 2, 5, 1, 5, 4, 2, 0, 3, 2, 3, 5];
    add_mesh(&mut desc, &mut buffers, "prism", pv, pt, 2);
    desc.camera.to_world = [[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, -1.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]];
    desc.camera.focal_length = 30.0;
    let (w, h) = (16usize, 16usize);
    let base = ResolvedSettings {
        width: w as u32,
        height: h as u32,
        max_bounces: 8,
        grid: WavelengthGrid::uniform(41, 380.0, 780.0).unwrap(),
        ..Default::default()
    };
    let reference =
        render(&desc, &buffers, &ResolvedSettings { samples: 512, ..base.clone() }, &RenderControl::new()).unwrap();
    let reference = block_means(&reference.images.rgba, w, h, 4);
    assert!(reference.iter().filter(|&&(m, _)| m > 1e-3).count() > 16, "the view is mostly dark");
    for (direction, samples) in [(Direction::Backward, 256), (Direction::Bidirectional, 256)] {
        let out = render(
            &desc,
            &buffers,
            &ResolvedSettings { method: Method::Hero, direction, samples, ..base.clone() },
            &RenderControl::new(),
        )
        .unwrap();
        assert_eq!(out.stats.nonfinite_samples, 0);
        assert_close(&block_means(&out.images.rgba, w, h, 4), &reference, &format!("HERO {direction:?}"));
    }
}
