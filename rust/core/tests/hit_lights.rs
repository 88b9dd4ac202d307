//! Suns with an angle and sphere lights reached by camera and BSDF rays (Cycles'
//! `distant_light_intersect`, `point_light_intersect`) and combined with light sampling
//! by MIS, checked against closed forms: a sun's disk in a mirror, the irradiance of a
//! diffuse plane (the two MIS halves add up to E·ρ/π), a rough glossy plane against a
//! next-event-only estimate, camera visibility.

mod common;

use common::*;
use glam::Vec3A;
use polychrome_core::camera::CameraDesc;
use polychrome_core::color::uplift::UpliftMethod;
use polychrome_core::color::RgbSpace;
use polychrome_core::geometry::visibility::LightVisibilityDesc;
use polychrome_core::geometry::Frame;
use polychrome_core::material::ShadingContext;
use polychrome_core::render::{render, Direction, Method, RenderControl, ResolvedSettings};
use polychrome_core::sampling::Rng;
use polychrome_core::scene::{BsdfDesc, Buffer, BuildOptions, LightDesc, Scene, SceneDesc};
use polychrome_core::spectrum::{SampledSpectrum, SpectrumDesc, WavelengthGrid};
use std::f32::consts::PI;

/// [`common::sun`] of half-angle `half_angle`, with `visibility`.
fn sun(direction: [f32; 3], e: f32, half_angle: f32, visibility: LightVisibilityDesc) -> LightDesc {
    let mut light = common::sun(direction, e, 2.0 * half_angle);
    if let LightDesc::Distant { visibility: v, .. } = &mut light {
        *v = visibility;
    }
    light
}

/// A pinhole at height `z` looking down −z (`up`: looking up +z instead), focal length
/// `f` mm on the default 36 mm sensor.
fn pinhole(z: f32, f: f32, up: bool) -> CameraDesc {
    let s = if up { -1.0 } else { 1.0 };
    CameraDesc {
        focal_length: f,
        to_world: [[1.0, 0.0, 0.0, 0.0], [0.0, s, 0.0, 0.0], [0.0, 0.0, s, z], [0.0, 0.0, 0.0, 1.0]],
        ..Default::default()
    }
}

/// The pixels of a w×w image whose pinhole ray (tan of the half field `a`) lies within
/// angle `h` of the view axis, and those clearly outside (edge pixels left out), with
/// the ray's angle from the axis.
fn disk_pixels(w: u32, a: f32, h: f32) -> (Vec<(usize, f32)>, Vec<usize>) {
    let radius = h.tan() / a * w as f32 * 0.5;
    let (mut inside, mut outside) = (Vec::new(), Vec::new());
    for py in 0..w {
        for px in 0..w {
            let (dx, dy) = (px as f32 + 0.5 - w as f32 * 0.5, py as f32 + 0.5 - w as f32 * 0.5);
            let r = (dx * dx + dy * dy).sqrt();
            let i = (py * w + px) as usize;
            if r < radius - 0.75 {
                inside.push((i, (r / (w as f32 * 0.5) * a).atan()));
            } else if r > radius + 0.75 {
                outside.push(i);
            }
        }
    }
    (inside, outside)
}

/// A perfect mirror (Glossy, roughness 0, reflectance R) under a pinhole looking
/// straight down at it reflects a sun of half-angle h straight overhead: the camera ray
/// at angle θ from the axis reflects at θ from the zenith, so the pixels with θ < h read
/// L·F(θ) with L = E/(π sin² h) and F Schlick's R + (1 − R)(1 − cos θ)⁵, the others 0;
/// and the image mean is L·R times the disk's share π tan² h / (2a)² of the film (a the
/// tangent of the half field; F − R < 1e-6 here). Every method and direction that
/// traces camera paths agrees (a deterministic mirror path: MIS weight 1).
#[test]
fn a_mirror_shows_the_suns_disk() {
    let (e, h, refl) = (3.0f32, 0.2f32, 0.8f32);
    let mut desc = SceneDesc::default();
    let mut buffers = Vec::new();
    desc.materials.push(material(
        "mirror",
        BsdfDesc::Glossy {
            reflectance: SpectrumDesc::constant(refl),
            roughness: 0.0,
            anisotropy: 0.0,
            rotation: 0.0,
            tangent: None,
        },
    ));
    add_square(&mut desc, &mut buffers, "mirror", 50.0, 0);
    desc.lights.push(sun([0.0, 0.0, -1.0], e, h, Default::default()));
    let f = 45.0;
    let a = 18.0 / f;
    desc.camera = pinhole(4.0, f, false);
    let w = 48u32;
    let l = e / (PI * h.sin().powi(2));
    let (inside, outside) = disk_pixels(w, a, h);
    assert!(inside.len() > 300 && outside.len() > 1000, "{} {}", inside.len(), outside.len());
    for direction in [Direction::Backward, Direction::Bidirectional] {
        let settings =
            ResolvedSettings { width: w, height: w, samples: 16, max_bounces: 4, direction, ..Default::default() };
        let out = render(&desc, &buffers, &settings, &RenderControl::new()).unwrap();
        assert_eq!(out.stats.nonfinite_samples, 0);
        let px = |i: usize| luminance(&out.images.rgba[i * 4..i * 4 + 4]);
        for &(i, theta) in &inside {
            let expected = (l * (refl + (1.0 - refl) * (1.0 - theta.cos()).powi(5))) as f64;
            assert!((px(i) - expected).abs() < 2e-3 * expected, "{direction:?} pixel {i}: {} vs {expected}", px(i));
        }
        for &i in &outside {
            assert_eq!(px(i), 0.0, "{direction:?} pixel {i} is outside the disk");
        }
        let n = (w * w) as f64;
        let mean = (0..(w * w) as usize).map(px).sum::<f64>() / n;
        let closed = (l * refl) as f64 * std::f64::consts::PI * (h.tan() as f64).powi(2) / (2.0 * a as f64).powi(2);
        assert!((mean / closed - 1.0).abs() < 0.01, "{direction:?}: image mean {mean} vs {closed}");
    }
}

/// Looking straight up at a sun of half-angle h: its disk shows only to a camera the
/// light's visibility names (Cycles' `visible_camera`, off by default).
#[test]
fn the_camera_sees_the_sun_only_when_visible_to_it() {
    let (e, h) = (2.0f32, 0.2f32);
    let f = 45.0;
    let a = 18.0 / f;
    let w = 32u32;
    let l = (e / (PI * h.sin().powi(2))) as f64;
    let (inside, outside) = disk_pixels(w, a, h);
    for camera in [false, true] {
        let mut desc = SceneDesc::default();
        let mut buffers = Vec::new();
        desc.materials.push(material("floor", BsdfDesc::Diffuse { reflectance: SpectrumDesc::constant(0.5) }));
        // Something to bound the scene, behind the camera.
        add_square(&mut desc, &mut buffers, "floor", 1.0, 0);
        let vis = LightVisibilityDesc { camera, ..Default::default() };
        desc.lights.push(sun([0.0, 0.0, -1.0], e, h, vis));
        desc.camera = pinhole(1.0, f, true);
        let settings = ResolvedSettings { width: w, height: w, samples: 4, max_bounces: 2, ..Default::default() };
        let out = render(&desc, &buffers, &settings, &RenderControl::new()).unwrap();
        let px = |i: usize| luminance(&out.images.rgba[i * 4..i * 4 + 4]);
        for &(i, _) in &inside {
            let expected = if camera { l } else { 0.0 };
            assert!((px(i) - expected).abs() <= 1e-3 * l, "camera {camera}: pixel {i} {} vs {expected}", px(i));
        }
        assert!(outside.iter().all(|&i| px(i) == 0.0));
    }
}

/// Mean of the image's luminance over `expected` per pixel (`expected(px, py)`), and its
/// standard error.
fn mean_ratio(rgba: &[f32], w: u32, expected: impl Fn(u32, u32) -> f64) -> (f64, f64) {
    let r: Vec<f64> =
        (0..w * w).map(|i| luminance(&rgba[i as usize * 4..i as usize * 4 + 4]) / expected(i % w, i / w)).collect();
    let n = r.len() as f64;
    let m = r.iter().sum::<f64>() / n;
    let var = r.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0);
    (m, (var / n).sqrt())
}

/// A diffuse plane (albedo ρ) under a sun of half-angle h at angle α from the zenith
/// (α + h ≤ π/2) receives E cos α and reads ρ/π·E cos α: the light-sampling half and
/// the BSDF rays that escape into the disk add up to it (counting both in full would
/// overshoot by the share of cosine-sampled rays that reach the disk, 20 % for h = 0.5
/// overhead). Every method.
#[test]
fn a_diffuse_plane_under_a_wide_sun_has_the_irradiance() {
    let (rho, e) = (0.5f32, 2.0f32);
    for &(alpha, h) in &[(0.0f32, 0.5f32), (0.6, 0.4), (0.2, 0.02)] {
        let mut desc = SceneDesc::default();
        let mut buffers = Vec::new();
        desc.materials.push(material("plane", BsdfDesc::Diffuse { reflectance: SpectrumDesc::constant(rho) }));
        add_square(&mut desc, &mut buffers, "plane", 4.0, 0);
        desc.lights.push(sun([alpha.sin(), 0.0, -alpha.cos()], e, h, Default::default()));
        desc.camera = ortho_down(2.0);
        let expected = (rho / PI * e * alpha.cos()) as f64;
        for method in [Method::Polychromatic, Method::Hero, Method::MonochromaticRays] {
            let settings =
                ResolvedSettings { width: 8, height: 8, samples: 32, max_bounces: 1, method, ..Default::default() };
            let out = render(&desc, &buffers, &settings, &RenderControl::new()).unwrap();
            let (m, se) = mean_ratio(&out.images.rgba, 8, |_, _| expected);
            assert!((m - 1.0).abs() < 4.0 * se + 2e-3, "α {alpha} h {h} {method:?}: {m} ± {se}");
        }
    }
}

/// A diffuse plane under a sphere light (radius r, intensity I, centre at height d): a
/// sphere wholly above the plane lights it as the point at its centre does, E = I d/D³
/// at distance D from the centre, whatever r; the plane reads ρ/π·E with MIS between the
/// sphere's cone samples and the cosine-sampled rays that hit the sphere.
#[test]
fn a_diffuse_plane_under_a_sphere_light_has_the_irradiance() {
    let (rho, intensity, d) = (0.5f32, 3.0f32, 1.5f32);
    for r in [0.05f32, 0.8, 1.4] {
        let mut desc = SceneDesc::default();
        let mut buffers = Vec::new();
        desc.materials.push(material("plane", BsdfDesc::Diffuse { reflectance: SpectrumDesc::constant(rho) }));
        add_square(&mut desc, &mut buffers, "plane", 4.0, 0);
        desc.lights.push(LightDesc::Point {
            name: "sphere".into(),
            position: [0.0, 0.0, d],
            intensity: SpectrumDesc::constant(intensity),
            radius: r,
            visibility: Default::default(),
            profile: None,
            motion: Vec::new(),
        });
        let (w, scale) = (8u32, 1.0f32);
        desc.camera = ortho_down(scale);
        let expected = |px: u32, py: u32| {
            let x = ((px as f32 + 0.5) / w as f32 - 0.5) * scale;
            let y = ((py as f32 + 0.5) / w as f32 - 0.5) * scale;
            let dd = (x * x + y * y + d * d).sqrt();
            (rho / PI * intensity * d / dd.powi(3)) as f64
        };
        let settings = ResolvedSettings { width: w, height: w, samples: 64, max_bounces: 1, ..Default::default() };
        let out = render(&desc, &buffers, &settings, &RenderControl::new()).unwrap();
        let (m, se) = mean_ratio(&out.images.rgba, w, expected);
        // 2e-3: the falloff varies over a pixel (its mean is not the centre's value).
        assert!((m - 1.0).abs() < 4.0 * se + 3e-3, "r {r}: {m} ± {se}");
    }
}

fn build(desc: &SceneDesc, buffers: &[Buffer]) -> Scene {
    let opts = BuildOptions {
        grid: WavelengthGrid::default(),
        space: RgbSpace::rec709(),
        uplift: UpliftMethod::Linear,
        width: 8,
        height: 8,
    };
    Scene::build(desc, buffers, &opts).unwrap()
}

/// A rough white Glossy plane seen straight down by an orthographic camera under a sun
/// of half-angle h near its highlight: the render (MIS of the sun's cone samples and the
/// GGX samples that escape into the disk) equals a next-event-only estimate of the same
/// reflected radiance, the mean of f·cos·L/pdf over the sun's own light samples,
/// computed here from the light and the BSDF.
#[test]
fn a_rough_glossy_plane_agrees_with_next_event_only() {
    for &(roughness, alpha, h) in &[(0.3f32, 0.15f32, 0.15f32), (0.15, 0.05, 0.05), (0.5, 0.4, 0.3)] {
        let mut desc = SceneDesc::default();
        let mut buffers = Vec::new();
        desc.materials.push(material(
            "glossy",
            BsdfDesc::Glossy {
                reflectance: SpectrumDesc::constant(1.0),
                roughness,
                anisotropy: 0.0,
                rotation: 0.0,
                tangent: None,
            },
        ));
        add_square(&mut desc, &mut buffers, "plane", 4.0, 0);
        desc.lights.push(sun([alpha.sin(), 0.0, -alpha.cos()], 1.0, h, Default::default()));
        desc.camera = ortho_down(2.0);

        let scene = build(&desc, &buffers);
        let ctx = ShadingContext::new(&scene.grid);
        let frame = Frame::from_normal(Vec3A::Z);
        let mut rng = Rng::new(5, 3);
        let (mut le, mut f) = (SampledSpectrum::zeros(scene.grid.len()), SampledSpectrum::zeros(scene.grid.len()));
        let n = 400_000;
        let mut sum = 0.0f64;
        for _ in 0..n {
            let ls = scene.lights[0].sample_li(Vec3A::ZERO, rng.uniform2(), &mut le).unwrap();
            scene.materials[0].bsdf.eval(&ctx, Vec3A::Z, frame.to_local(ls.wi), &mut f);
            sum += (f.get(0) * le.get(0) / ls.pdf) as f64;
        }
        let reference = sum / n as f64;

        let settings = ResolvedSettings { width: 8, height: 8, samples: 64, max_bounces: 1, ..Default::default() };
        let out = render(&desc, &buffers, &settings, &RenderControl::new()).unwrap();
        let (m, se) = mean_ratio(&out.images.rgba, 8, |_, _| reference);
        assert!((m - 1.0).abs() < 4.0 * se + 5e-3, "roughness {roughness} α {alpha} h {h}: {m} ± {se}");
    }
}

/// A sun of half-angle h straight overhead through a horizontal glass slab onto a
/// diffuse floor, seen obliquely past the slab: a slab keeps directions, so the floor
/// under it receives ∫ L T(θ) cos θ dω over the disk, T = (1 − R)/(1 + R) with all the
/// internal reflections (R Fresnel's unpolarised reflectance at θ), and reads ρ/π times
/// that. A caustic: camera paths find it by BSDF rays through the glass that leave in
/// the disk (a parallel sun's belongs to light tracing, dielectric.rs); every direction
/// agrees with the closed form.
#[test]
fn a_suns_caustic_through_a_glass_slab_is_found_by_every_direction() {
    use polychrome_core::material::IorDesc;
    let (rho, e, n, h) = (0.8f32, 1.0f32, 1.5f64, 0.3f32);
    let mut desc = SceneDesc::default();
    let mut buffers = Vec::new();
    desc.materials.push(material("floor", BsdfDesc::Diffuse { reflectance: SpectrumDesc::constant(rho) }));
    desc.materials.push(material("slab", BsdfDesc::Dielectric { ior: IorDesc::Constant { ior: n }, roughness: 0.0 }));
    add_square(&mut desc, &mut buffers, "floor", 3.0, 0);
    add_box(&mut desc, &mut buffers, "slab", [-1.5, -2.0, 1.0], [1.5, 2.0, 1.3], 1);
    desc.lights.push(sun([0.0, 0.0, -1.0], e, h, Default::default()));
    desc.camera =
        CameraDesc { focal_length: 120.0, to_world: look_at([4.0, 0.0, 2.0], [0.0; 3]), ..Default::default() };
    // Fresnel's unpolarised reflectance at incidence cos ci from outside.
    let fresnel = |ci: f64| {
        let st2 = (1.0 - ci * ci) / (n * n);
        let ct = (1.0 - st2).sqrt();
        let rs = ((ci - n * ct) / (ci + n * ct)).powi(2);
        let rp = ((n * ci - ct) / (n * ci + ct)).powi(2);
        0.5 * (rs + rp)
    };
    let steps = 2000;
    let l = e as f64 / (std::f64::consts::PI * (h as f64).sin().powi(2));
    let irradiance: f64 = (0..steps)
        .map(|k| {
            let theta = (k as f64 + 0.5) / steps as f64 * h as f64;
            let r = fresnel(theta.cos());
            l * (1.0 - r) / (1.0 + r) * theta.cos() * theta.sin() * 2.0 * std::f64::consts::PI * h as f64 / steps as f64
        })
        .sum();
    let expected = rho as f64 / std::f64::consts::PI * irradiance;
    for (direction, samples) in [(Direction::Backward, 256), (Direction::Forward, 64), (Direction::Bidirectional, 256)]
    {
        let settings =
            ResolvedSettings { width: 16, height: 16, samples, max_bounces: 16, direction, ..Default::default() };
        let out = render(&desc, &buffers, &settings, &RenderControl::new()).unwrap();
        assert_eq!(out.stats.nonfinite_samples, 0);
        // The central 8×8 pixels see the floor within |x| < 0.5 (all under the slab).
        let ys: Vec<f64> = (4..12)
            .flat_map(|y| (4..12).map(move |x| (x, y)))
            .map(|(x, y)| luminance(&out.images.rgba[((y * 16 + x) * 4) as usize..][..4]))
            .collect();
        let m = ys.iter().sum::<f64>() / ys.len() as f64;
        let se = (ys.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (ys.len() as f64 - 1.0) / ys.len() as f64).sqrt();
        assert!((m - expected).abs() < 4.0 * se + 0.01 * expected, "{direction:?}: {m} ± {se} vs {expected}");
        assert!(se < 0.1 * expected, "{direction:?}: too noisy: {se}");
    }
}
