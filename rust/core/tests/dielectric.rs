//! Glass, metals and the spot light, end to end: scenes built from descriptions and
//! checked against closed forms computed here (Snell's law with the Sellmeier index,
//! furnace invariance, the inverse-square law).

mod common;

use common::*;
use glam::{Vec2, Vec3A};
use polychrome_core::camera::CameraDesc;
use polychrome_core::color::uplift::UpliftMethod;
use polychrome_core::color::RgbSpace;
use polychrome_core::geometry::{offset_ray_origin, Frame, Ray};
use polychrome_core::material::{IorDesc, ShadingContext};
use polychrome_core::render::{render, RenderControl, ResolvedSettings};
use polychrome_core::scene::{BsdfDesc, Buffer, BuildOptions, LightDesc, MaterialDesc, Scene, SceneDesc, WorldDesc};
use polychrome_core::spectrum::{SpectrumDesc, WavelengthGrid};

fn glass(name: &str, ior: IorDesc) -> MaterialDesc {
    material(name, BsdfDesc::Dielectric { ior, roughness: 0.0 })
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

/// N-BK7 by its Sellmeier formula, written out here (SCHOTT data sheet coefficients).
fn bk7_index(lambda_nm: f64) -> f64 {
    let b = [1.03961212, 0.231792344, 1.01046945];
    let c = [0.00600069867, 0.0200179144, 103.560653];
    let l2 = (lambda_nm * 1e-3).powi(2);
    (1.0 + (0..3).map(|k| b[k] * l2 / (l2 - c[k])).sum::<f64>()).sqrt()
}

/// An equilateral prism (apex angle 60°) with its apex up along +z, extruded along y.
fn prism() -> (Vec<f32>, Vec<u32>) {
    let h = 3f32.sqrt() / 2.0; // side 1
    let tri = [[-0.5f32, 0.0], [0.5, 0.0], [0.0, h]]; // (x, z)
    let mut v = Vec::new();
    for &y in &[-2.0f32, 2.0] {
        for p in &tri {
            v.extend_from_slice(&[p[0], y, p[1]]);
        }
    }
    // Vertices: 0..3 at y = −2, 3..6 at y = +2. Side quads and end caps.
    let mut t = vec![0, 1, 4, 0, 4, 3, 1, 2, 5, 1, 5, 4, 2, 0, 3, 2, 3, 5, 0, 2, 1, 3, 4, 5];
    // Wind outwards (the glass's outside is where the geometric normal points).
    for tri in t.chunks_exact_mut(3) {
        tri.swap(1, 2);
    }
    (v, t)
}

/// Follows one ray through the scene's BSDFs at one wavelength, always choosing
/// refraction (uc = 1−), and returns the direction after `interfaces` refractions.
fn trace_refracted(scene: &Scene, mut ray: Ray, lane: usize, interfaces: usize) -> Vec3A {
    let n = scene.grid.len();
    let mut ctx = ShadingContext::new(&scene.grid);
    ctx.single_wavelength = Some(lane);
    for k in 0..interfaces {
        let hit = scene.intersect(&ray).unwrap_or_else(|| panic!("interface {k} missed"));
        let si = scene.interaction(&ray, &hit);
        let wo = -ray.direction;
        let front = si.ng.dot(wo) >= 0.0;
        let ng = if front { si.ng } else { -si.ng };
        ctx.front_face = front;
        let frame = Frame::from_normal(ng);
        let mut tp = polychrome_core::spectrum::SampledSpectrum::splat(n, 1.0);
        let bsdf = &scene.materials[si.material as usize].bsdf;
        let bs = bsdf.sample(&ctx, frame.to_local(wo), Vec2::splat(0.5), 0.999_999, &mut tp).expect("sample");
        assert!(bs.collapsed_to.is_none(), "a single-wavelength ray cannot collapse again");
        let wi = frame.to_world(bs.wi);
        assert!(wi.dot(ng) < 0.0, "interface {k}: expected refraction, got reflection (TIR?)");
        ray = Ray::new(offset_ray_origin(si.p, -ng), wi);
    }
    ray.direction
}

#[test]
fn prism_deviation_follows_snell_with_the_sellmeier_index() {
    let mut desc = SceneDesc::default();
    let mut buffers = Vec::new();
    desc.materials.push(glass("BK7 prism", IorDesc::Named { name: "N-BK7".into() }));
    let (v, t) = prism();
    add_mesh(&mut desc, &mut buffers, "prism", v, t, 0);
    let scene = build(&desc, &buffers);
    assert!(scene.materials[0].bsdf.flags().dispersive);
    // Enter the left face (normal at −30° from −x towards +z) at incidence θ1 = 50°.
    let apex = 60f64.to_radians();
    let theta1 = 50f64.to_radians();
    let n_left = Vec3A::new(-(apex / 2.0).cos() as f32, 0.0, (apex / 2.0).sin() as f32);
    // Incoming direction: rotate −n_left by θ1 about y, upwards into the face.
    let (s, c) = (theta1.sin() as f32, theta1.cos() as f32);
    let tangent = Vec3A::new(n_left.z, 0.0, -n_left.x); // in-plane, along the face, pointing up-right
    let dir = (-n_left * c + tangent * s).normalize();
    let target = Vec3A::new(-0.25, 0.0, 0.25 * 3f32.sqrt()); // middle of the left face
    let origin = target - dir * 3.0;
    let mut deviations = Vec::new();
    for &lambda in &[450.0f32, 550.0, 650.0] {
        let lane = scene.grid.nearest(lambda);
        assert_eq!(scene.grid.lambdas()[lane], lambda);
        let out = trace_refracted(&scene, Ray::new(origin, dir), lane, 2);
        let got = dir.dot(out).clamp(-1.0, 1.0).acos() as f64;
        // Closed form: θ2 = asin(sin θ1 / n), θ3 = A − θ2, θ4 = asin(n sin θ3), δ = θ1 + θ4 − A.
        let n = bk7_index(lambda as f64);
        let theta2 = (theta1.sin() / n).asin();
        let theta4 = (n * (apex - theta2).sin()).asin();
        let expected = theta1 + theta4 - apex;
        assert!((got - expected).abs() < 2e-4, "λ {lambda}: deviation {got:.6} rad, Snell {expected:.6} rad");
        // The ray leaves in the xz plane, bent towards the base (downwards).
        assert!(out.y.abs() < 1e-5 && out.z < dir.z);
        deviations.push(got);
    }
    // Normal dispersion: blue bends most.
    assert!(deviations[0] > deviations[1] && deviations[1] > deviations[2], "{deviations:?}");
}

fn furnace_scene(ior: IorDesc, roughness: f32) -> (SceneDesc, Vec<Buffer>) {
    let mut desc = SceneDesc::default();
    let mut buffers = Vec::new();
    desc.materials.push(material("glass", BsdfDesc::Dielectric { ior, roughness }));
    let (v, t) = uv_sphere([0.0, 0.0, 0.0], 1.0, 24, 48);
    add_mesh(&mut desc, &mut buffers, "ball", v, t, 0);
    let world: WorldDesc =
        serde_json::from_value(serde_json::json!({"radiance": {"type": "constant", "value": 1.0}})).unwrap();
    desc.world = Some(world);
    desc.camera = ortho_down(1.6);
    (desc, buffers)
}

/// A glass ball in a uniform white world: glass neither creates nor absorbs light,
/// so every pixel sees the world's radiance, whatever the index or its dispersion.
#[test]
fn glass_ball_in_a_white_furnace_is_invisible() {
    for (ior, roughness) in [
        (IorDesc::Constant { ior: 1.5 }, 0.0f32),
        (IorDesc::Named { name: "N-SF11".into() }, 0.0),
        (IorDesc::Constant { ior: 1.5 }, 0.4),
        (IorDesc::Abbe { nd: 1.6, vd: 30.0 }, 0.4),
    ] {
        let (desc, buffers) = furnace_scene(ior.clone(), roughness);
        let settings = ResolvedSettings { width: 12, height: 12, samples: 32, max_bounces: 64, ..Default::default() };
        let out = render(&desc, &buffers, &settings, &RenderControl::new()).unwrap();
        assert_eq!(out.stats.nonfinite_samples, 0);
        let (mean, se) = mean_and_standard_error(&out.images.rgba);
        if roughness == 0.0 {
            assert!((mean - 1.0).abs() < 5.0 * se + 0.01, "{ior:?}: mean luminance {mean} (se {se})");
        } else {
            // Single-scattering microfacets lose the energy of light that would scatter
            // between facets (several per cent per interface inside glass at grazing
            // angles), so a rough ball is slightly darker but never brighter.
            assert!(mean < 1.0 + 5.0 * se && mean > 0.75, "{ior:?} r {roughness}: mean luminance {mean} (se {se})");
        }
        // And no tint: the image stays neutral (E's chromaticity) on average.
        let px = out.images.rgba.chunks_exact(4).count() as f64;
        let avg = |c: usize| out.images.rgba.chunks_exact(4).map(|p| p[c] as f64).sum::<f64>() / px;
        let (r, g, b) = (avg(0), avg(1), avg(2));
        let e = {
            let (d0, _) = furnace_scene(IorDesc::Constant { ior: 1.0 }, 0.0);
            let mut d = d0;
            d.meshes.clear();
            let o = render(
                &d,
                &[] as &[Buffer],
                &ResolvedSettings { width: 2, height: 2, samples: 1, ..Default::default() },
                &RenderControl::new(),
            )
            .unwrap();
            (o.images.rgba[0] as f64, o.images.rgba[1] as f64, o.images.rgba[2] as f64)
        };
        // Compare chromaticity (ratios), which the rough glass's energy loss keeps;
        // collapsed paths carry one wavelength each, so the tolerance follows the
        // per-channel standard errors.
        let se_of = |c: usize, m: f64| {
            (out.images.rgba.chunks_exact(4).map(|p| (p[c] as f64 - m).powi(2)).sum::<f64>() / (px - 1.0) / px).sqrt()
        };
        let (se_r, se_g, se_b) = (se_of(0, r), se_of(1, g), se_of(2, b));
        for (x, se_x, want) in [(r, se_r, e.0 / e.1), (b, se_b, e.2 / e.1)] {
            let tol = 5.0 * (se_x * se_x + want * want * se_g * se_g).sqrt() + 0.02 * want * g;
            assert!((x - want * g).abs() < tol, "{ior:?}: rgb ({r}, {g}, {b}) vs world ({:?})", e);
        }
    }
}

#[test]
fn constant_index_never_collapses_and_dispersive_glass_does() {
    let mut desc = SceneDesc::default();
    desc.materials.push(glass("crown", IorDesc::Constant { ior: 1.5 }));
    desc.materials.push(glass("flat cauchy", IorDesc::Cauchy { a: 1.5, b: 0.0, c: 0.0 }));
    desc.materials.push(glass("flint", IorDesc::Named { name: "N-SF11".into() }));
    desc.materials.push(material(
        "rough flint",
        BsdfDesc::Dielectric { ior: IorDesc::Abbe { nd: 1.7, vd: 30.0 }, roughness: 0.3 },
    ));
    let scene = build(&desc, &[]);
    let n = scene.grid.len();
    let mut ctx = ShadingContext::new(&scene.grid);
    let mut rng = polychrome_core::sampling::Rng::new(1, 1);
    for (m, dispersive) in scene.materials.iter().zip([false, false, true, true]) {
        assert_eq!(m.bsdf.flags().dispersive, dispersive, "{}", m.name);
        let mut collapses = 0;
        for k in 0..2000 {
            ctx.front_face = k % 2 == 0;
            let theta = rng.uniform() * 1.5;
            let wo = Vec3A::new(theta.sin(), 0.0, theta.cos());
            let mut tp = polychrome_core::spectrum::SampledSpectrum::splat(n, 1.0);
            if let Some(s) = m.bsdf.sample(&ctx, wo, rng.uniform2(), rng.uniform(), &mut tp) {
                assert!(tp.is_finite());
                if s.collapsed_to.is_some() {
                    collapses += 1;
                    assert_eq!(tp.values().iter().filter(|&&v| v != 0.0).count(), 1);
                }
            }
        }
        if dispersive {
            assert!(collapses > 500, "{}: {collapses} collapses", m.name);
        } else {
            assert_eq!(collapses, 0, "{}", m.name);
        }
    }
}

#[test]
fn bad_glass_and_metals_are_reported_by_name() {
    let cases = [
        (
            BsdfDesc::Dielectric {
                ior: IorDesc::Sellmeier { b: [1.0, 0.0, 0.0], c: [0.5 * 0.5, 0.0, 0.0] },
                roughness: 0.0,
            },
            "pole",
        ),
        (BsdfDesc::Dielectric { ior: IorDesc::Constant { ior: 0.5 }, roughness: 0.0 }, "below 1"),
        (BsdfDesc::Dielectric { ior: IorDesc::Constant { ior: 1.5 }, roughness: f32::NAN }, "roughness"),
        (BsdfDesc::Conductor { metal: Some("mithril".into()), eta: None, k: None, roughness: 0.1 }, "mithril"),
        (BsdfDesc::Conductor { metal: None, eta: Some(SpectrumDesc::constant(0.2)), k: None, roughness: 0.1 }, "both"),
    ];
    for (bsdf, needle) in cases {
        let mut desc = SceneDesc::default();
        desc.materials.push(material("Odd One", bsdf));
        let opts = BuildOptions {
            grid: WavelengthGrid::default(),
            space: RgbSpace::rec709(),
            uplift: UpliftMethod::Linear,
            width: 8,
            height: 8,
        };
        let e = Scene::build(&desc, &[] as &[Buffer], &opts).err().expect("must fail").to_string();
        assert!(e.contains("material 'Odd One'") && e.contains(needle), "{e}");
    }
}

/// A diffuse plane under a spot light pointing down: inside the cone
/// L = ρ/π · I cos θ / d², outside it nothing.
#[test]
fn spot_light_on_a_plane_is_inverse_square_inside_and_black_outside() {
    let (rho, intensity, h) = (0.7f32, 3.0f32, 2.0f32);
    let mut desc = SceneDesc::default();
    let mut buffers = Vec::new();
    desc.materials.push(material("plane", BsdfDesc::Diffuse { reflectance: SpectrumDesc::constant(rho) }));
    add_square(&mut desc, &mut buffers, "plane", 4.0, 0);
    // Cone of full angle 60°: radius h·tan 30° ≈ 1.155 on the plane; no blend.
    desc.lights.push(LightDesc::Spot {
        name: "spot".into(),
        position: [0.0, 0.0, h],
        direction: [0.0, 0.0, -1.0],
        intensity: SpectrumDesc::constant(intensity),
        spot_size: 60f32.to_radians(),
        spot_blend: 0.0,
        radius: 0.0,
        visibility: Default::default(),
        profile: None,
        motion: Vec::new(),
    });
    desc.camera = ortho_down(4.0);
    let (w, hh) = (41u32, 41u32);
    let settings = ResolvedSettings { width: w, height: hh, samples: 16, max_bounces: 1, ..Default::default() };
    let out = render(&desc, &buffers, &settings, &RenderControl::new()).unwrap();
    let radius = h * 30f32.to_radians().tan();
    let mut inside = 0;
    let mut outside = 0;
    for py in 0..hh {
        for px in 0..w {
            let x = (px as f32 + 0.5) / w as f32 * 4.0 - 2.0;
            let y = 2.0 - (py as f32 + 0.5) / hh as f32 * 4.0;
            let r = (x * x + y * y).sqrt();
            let i = ((py * w + px) * 4) as usize;
            let got = luminance(&out.images.rgba[i..i + 4]);
            let pixel = 4.0 / w as f32;
            if r < radius - pixel {
                let d2 = r * r + h * h;
                let expected = (rho / std::f32::consts::PI * intensity * (h / d2.sqrt()) / d2) as f64;
                // Pixel jitter (16 samples) averages the falloff over the footprint.
                assert!((got - expected).abs() < 0.025 * expected, "({px},{py}) r {r}: {got} vs {expected}");
                inside += 1;
            } else if r > radius + pixel {
                assert_eq!(got, 0.0, "({px},{py}) r {r} is outside the cone");
                outside += 1;
            }
        }
    }
    assert!(inside > 200 && outside > 200, "{inside} {outside}");
}

/// A sun on a plane: L = ρ/π · E cos θ.
#[test]
fn sun_on_a_plane_gives_irradiance_times_cosine() {
    let (rho, e) = (0.5f32, 2.0f32);
    let mut desc = SceneDesc::default();
    let mut buffers = Vec::new();
    desc.materials.push(material("plane", BsdfDesc::Diffuse { reflectance: SpectrumDesc::constant(rho) }));
    add_square(&mut desc, &mut buffers, "plane", 4.0, 0);
    let theta = 0.6f32;
    desc.lights.push(sun([theta.sin(), 0.0, -theta.cos()], e, 0.0));
    desc.camera = ortho_down(2.0);
    let settings = ResolvedSettings { width: 8, height: 8, samples: 4, max_bounces: 1, ..Default::default() };
    let out = render(&desc, &buffers, &settings, &RenderControl::new()).unwrap();
    let expected = (rho / std::f32::consts::PI * e * theta.cos()) as f64;
    for p in out.images.rgba.chunks_exact(4) {
        assert!((luminance(p) - expected).abs() < 1e-3 * expected, "{} vs {expected}", luminance(p));
    }
}

/// Gold and a white glossy surface under a uniform world: a white Glossy BSDF with
/// roughness 0 is a perfect mirror (sees the world exactly); gold is darker in blue.
#[test]
fn metals_in_a_uniform_world() {
    for (bsdf, check) in [
        (
            BsdfDesc::Glossy {
                reflectance: SpectrumDesc::constant(1.0),
                roughness: 0.0,
                anisotropy: 0.0,
                rotation: 0.0,
                tangent: None,
            },
            0,
        ),
        (BsdfDesc::Conductor { metal: Some("gold".into()), eta: None, k: None, roughness: 0.3 }, 1),
    ] {
        let (mut desc, buffers) = furnace_scene(IorDesc::Constant { ior: 1.5 }, 0.0);
        desc.materials[0] = material("metal", bsdf);
        let settings = ResolvedSettings { width: 8, height: 8, samples: 8, max_bounces: 16, ..Default::default() };
        let out = render(&desc, &buffers, &settings, &RenderControl::new()).unwrap();
        assert_eq!(out.stats.nonfinite_samples, 0);
        let (mean, se) = mean_and_standard_error(&out.images.rgba);
        if check == 0 {
            assert!((mean - 1.0).abs() < 1e-3 + 4.0 * se, "mirror: {mean}");
        } else {
            assert!(mean < 0.95 && mean > 0.3, "gold: {mean}");
            let centre = ((4 * 8 + 4) * 4) as usize;
            let p = &out.images.rgba[centre..centre + 4];
            assert!(p[0] > p[2] * 1.3, "gold must be yellow: {p:?}");
        }
    }
}

/// A sun shining straight down through a horizontal glass slab onto a diffuse floor,
/// seen obliquely past the slab. Under the slab the floor receives E·(1 − R)/(1 + R)
/// (normal incidence, all internal reflections), a caustic path (delta light →
/// specular) that only forward tracing samples: FORWARD and BIDIRECTIONAL must give
/// L = ρ/π·E·T there, BACKWARD (NEE blocked by the glass) black.
#[test]
fn sun_through_a_glass_slab_is_found_by_forward_tracing() {
    use polychrome_core::render::Direction;
    let (rho, e, n) = (0.8f32, 1.0f32, 1.5f32);
    let mut desc = SceneDesc::default();
    let mut buffers = Vec::new();
    desc.materials.push(material("floor", BsdfDesc::Diffuse { reflectance: SpectrumDesc::constant(rho) }));
    desc.materials.push(glass("slab", IorDesc::Constant { ior: n as f64 }));
    add_square(&mut desc, &mut buffers, "floor", 2.0, 0);
    add_box(&mut desc, &mut buffers, "slab", [-1.5, -2.0, 1.0], [1.5, 2.0, 1.3], 1);
    desc.lights.push(sun([0.0, 0.0, -1.0], e, 0.0));
    // Perspective camera at (4, 0, 2) looking at the origin, +z up: its line of sight to
    // the floor near the origin passes beside the slab.
    desc.camera =
        CameraDesc { focal_length: 120.0, to_world: look_at([4.0, 0.0, 2.0], [0.0; 3]), ..Default::default() };
    let r = ((n - 1.0) / (n + 1.0)).powi(2);
    let expected = (rho / std::f32::consts::PI * e * (1.0 - r) / (1.0 + r)) as f64;
    for direction in [Direction::Backward, Direction::Forward, Direction::Bidirectional] {
        let settings =
            ResolvedSettings { width: 16, height: 16, samples: 64, max_bounces: 16, direction, ..Default::default() };
        let out = render(&desc, &buffers, &settings, &RenderControl::new()).unwrap();
        assert_eq!(out.stats.nonfinite_samples, 0);
        // The central 8×8 pixels see the floor within |x| < 0.5 (all under the slab).
        let ys: Vec<f64> = (4..12)
            .flat_map(|y| (4..12).map(move |x| (x, y)))
            .map(|(x, y)| luminance(&out.images.rgba[((y * 16 + x) * 4) as usize..][..4]))
            .collect();
        let m = ys.iter().sum::<f64>() / ys.len() as f64;
        let se = (ys.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (ys.len() as f64 - 1.0) / ys.len() as f64).sqrt();
        match direction {
            Direction::Backward => assert!(m < 0.02 * expected, "backward cannot find the caustic: {m}"),
            _ => assert!((m - expected).abs() < 5.0 * se + 0.02 * expected, "{direction:?}: {m} ± {se} vs {expected}"),
        }
    }
}

/// docs/design.md#extremes: grazing incidence, total internal reflection, indices 1.0001 and 4.0, the
/// grid's end wavelengths: every BSDF returns finite values (or no sample) from both
/// faces, and `eval`/`pdf` never produce NaN.
#[test]
fn extremes_give_finite_results() {
    let mut desc = SceneDesc::default();
    for (k, ior) in
        [IorDesc::Constant { ior: 1.0001 }, IorDesc::Constant { ior: 4.0 }, IorDesc::Named { name: "Diamond".into() }]
            .into_iter()
            .enumerate()
    {
        for roughness in [0.0f32, 0.05, 0.5, 1.0] {
            desc.materials.push(material(
                &format!("glass {k} {roughness}"),
                BsdfDesc::Dielectric { ior: ior.clone(), roughness },
            ));
        }
    }
    for roughness in [0.0f32, 0.05, 1.0] {
        desc.materials
            .push(material("gold", BsdfDesc::Conductor { metal: Some("gold".into()), eta: None, k: None, roughness }));
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
    }
    let scene = build(&desc, &[]);
    let n = scene.grid.len();
    let mut rng = polychrome_core::sampling::Rng::new(77, 1);
    let mut f = polychrome_core::spectrum::SampledSpectrum::zeros(n);
    for m in &scene.materials {
        for front in [true, false] {
            for single in [None, Some(0), Some(n - 1)] {
                let mut ctx = ShadingContext::new(&scene.grid);
                ctx.front_face = front;
                ctx.single_wavelength = single;
                for &cos in &[1.0f32, 0.5, 1e-3, 1e-7, 0.0] {
                    let wo = Vec3A::new((1.0 - cos * cos).sqrt(), 0.0, cos);
                    for _ in 0..200 {
                        let mut tp = polychrome_core::spectrum::SampledSpectrum::splat(n, 1.0);
                        if let Some(s) = m.bsdf.sample(&ctx, wo, rng.uniform2(), rng.uniform(), &mut tp) {
                            assert!(
                                tp.is_finite() && s.pdf.is_finite() && s.pdf >= 0.0 && s.wi.is_finite(),
                                "{} cos {cos}: {:?}",
                                m.name,
                                s
                            );
                            assert!(tp.values().iter().all(|&v| v >= 0.0));
                            let p = m.bsdf.eval(&ctx, wo, s.wi, &mut f);
                            assert!(p.is_finite() && f.is_finite(), "{}", m.name);
                        }
                        let wi = polychrome_core::sampling::uniform_sphere(rng.uniform2());
                        let p = m.bsdf.eval(&ctx, wo, wi, &mut f);
                        assert!(
                            p.is_finite() && p >= 0.0 && f.is_finite() && m.bsdf.pdf(&ctx, wo, wi).is_finite(),
                            "{}",
                            m.name
                        );
                    }
                }
            }
        }
    }
}
