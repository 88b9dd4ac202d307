//! The Principled BSDF's subsurface random walk (docs/materials.md#subsurface) through
//! the whole renderer, against closed forms: a white sphere (albedo 1, no absorption)
//! in a white furnace gives back exactly the world (everything that enters leaves, for
//! short and long mean free paths and a chromatic radius); a sphere much larger than
//! its mean free path (radius → 0, a semi-infinite medium) reflects its base colour, the
//! diffuse albedo the single-scattering-albedo fit targets (the Lambertian sphere of the
//! same colour is the reference); light passes through a thin sphere only when it
//! walks; bad radii are rejected naming the material.

mod common;

use common::*;
use polychrome_core::render::{render, Direction, Method, RenderControl, RenderOutput, ResolvedSettings};
use polychrome_core::scene::{BsdfDesc, Buffer, MaterialDesc, SceneDesc};
use polychrome_core::spectrum::{SpectrumDesc, WavelengthGrid};

fn material(name: &str, bsdf: serde_json::Value) -> MaterialDesc {
    let bsdf: BsdfDesc = serde_json::from_value(bsdf).expect("bsdf description");
    MaterialDesc { name: name.into(), bsdf, emission: None, volume: None, one_sided: false, see_through: false }
}

/// Camera at y = −`distance` looking along +y.
fn camera_along_y(desc: &mut SceneDesc, distance: f32, focal_length: f32) {
    desc.camera.to_world =
        [[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, -1.0, -distance], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]];
    desc.camera.focal_length = focal_length;
}

/// A unit sphere of `m` in a uniform white world, seen by a camera of `focal_length`
/// (mm on 36 mm film) at 6 units: 300 keeps every pixel on the sphere, 80 shows it whole.
fn furnace_at(m: MaterialDesc, focal_length: f32) -> (SceneDesc, Vec<Buffer>) {
    let mut desc = SceneDesc::default();
    let mut buffers = Vec::new();
    desc.materials.push(m);
    let (v, t) = uv_sphere([0.0; 3], 1.0, 48, 96);
    add_mesh(&mut desc, &mut buffers, "sphere", v, t, 0);
    desc.world = Some(uniform_world(&SpectrumDesc::constant(1.0)));
    camera_along_y(&mut desc, 6.0, focal_length);
    (desc, buffers)
}

fn furnace(m: MaterialDesc) -> (SceneDesc, Vec<Buffer>) {
    furnace_at(m, 300.0)
}

fn settings(samples: u32) -> ResolvedSettings {
    ResolvedSettings {
        width: 8,
        height: 8,
        samples,
        max_bounces: 64,
        grid: WavelengthGrid::uniform(16, 380.0, 780.0).unwrap(),
        ..Default::default()
    }
}

/// Mean and standard error of channel `c` over the pixels.
fn channel(out: &RenderOutput, c: usize) -> (f64, f64) {
    let v: Vec<f64> = out.images.rgba.chunks_exact(4).map(|p| p[c] as f64).collect();
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0);
    (m, (var / n).sqrt())
}

fn principled_sss(base: [f32; 3], ior: f32, radius: [f32; 3], scale: f32, anisotropy: f32) -> serde_json::Value {
    serde_json::json!({
        "type": "principled",
        "base_color": {"type": "rgb", "rgb": base},
        "roughness": 0.5,
        "ior": {"type": "constant", "ior": ior},
        "subsurface": {"weight": 1.0, "radius": radius, "scale": scale, "anisotropy": anisotropy},
    })
}

/// Albedo 1, no absorption: the walk loses nothing, the exit's Lambertian gives back all
/// that entered, and the specular layer's reflection plus what enters is 1 — the sphere
/// vanishes in the white world, for mean free paths from a tenth of the sphere's radius
/// to its size, a chromatic (spectral) radius, forward scattering, and every method
/// that walks. (With a much shorter mean free path some walks reach Cycles' cap of 256
/// bounces inside and are lost: below.)
#[test]
fn white_furnace_everything_that_enters_leaves() {
    for (radius, scale, g, method) in [
        ([1.0, 1.0, 1.0], 2.0, 0.0, Method::Polychromatic),
        ([1.0, 0.2, 0.1], 10.0, 0.0, Method::Polychromatic),
        ([1.0, 0.5, 0.25], 4.0, 0.6, Method::Hero),
        ([1.0, 0.5, 0.25], 4.0, 0.0, Method::MonochromaticRays),
    ] {
        let (desc, buffers) = furnace(material("wax", principled_sss([1.0; 3], 1.5, radius, scale, g)));
        // The world alone (the equal-energy white in Rec.709) is the closed form.
        let world = SceneDesc { meshes: Vec::new(), ..desc.clone() };
        let world = render(&world, &buffers, &settings(1), &RenderControl::new()).unwrap();
        let out = render(&desc, &buffers, &ResolvedSettings { method, ..settings(64) }, &RenderControl::new()).unwrap();
        assert_eq!(out.stats.nonfinite_samples, 0);
        assert!(out.stats.warnings.is_empty(), "{:?}", out.stats.warnings);
        for c in 0..3 {
            let ((m, se), (w, _)) = (channel(&out, c), channel(&world, c));
            assert!(
                (m - w).abs() < 4.0 * se + 0.01 * w,
                "{method:?} radius {radius:?}×{scale} g {g}: channel {c} {m} ± {se} vs world {w}"
            );
        }
    }
}

/// The bounce cap's cost, as in Cycles: at albedo 1 a mean free path of 1/25 of the
/// sphere's radius (radius 1 × scale 0.5 /(4π)) loses the few walks that wander deep
/// (3.5 % measured); none of the light is made up.
#[test]
fn bounce_cap_loses_a_little_of_a_deep_walk() {
    let (desc, buffers) = furnace(material("wax", principled_sss([1.0; 3], 1.5, [1.0; 3], 0.5, 0.0)));
    let world = SceneDesc { meshes: Vec::new(), ..desc.clone() };
    let world = render(&world, &buffers, &settings(1), &RenderControl::new()).unwrap();
    let out = render(&desc, &buffers, &settings(64), &RenderControl::new()).unwrap();
    for c in 0..3 {
        let ((m, se), (w, _)) = (channel(&out, c), channel(&world, c));
        assert!(m < w + 4.0 * se && m > 0.94 * w, "channel {c}: {m} ± {se} vs world {w}");
    }
}

/// A mean free path far below the sphere's size (a semi-infinite medium) and an
/// index-matched entry with no specular layer: the whole sphere (cosine-weighted
/// incidence over its disk: the diffuse albedo the fit targets) reflects its base colour
/// as the Lambertian sphere of that colour does, within the fit's few percent. The
/// sphere's part of the image is what it adds to a black sphere's.
#[test]
fn tiny_radius_reflects_the_base_colour() {
    let base = [0.8, 0.5, 0.25];
    let mut sss = principled_sss(base, 1.0, [1.0, 0.2, 0.1], 0.002, 0.0);
    sss["specular_ior_level"] = serde_json::json!(0.0);
    let s = ResolvedSettings { width: 16, height: 16, ..settings(64) };
    let (desc, buffers) = furnace_at(material("skin", sss), 80.0);
    let out = render(&desc, &buffers, &s, &RenderControl::new()).unwrap();
    let lambert = serde_json::json!({"type": "diffuse", "reflectance": {"type": "rgb", "rgb": base}});
    let (lambert, _) = furnace_at(material("paint", lambert), 80.0);
    let reference =
        render(&lambert, &buffers, &ResolvedSettings { samples: 16, ..s.clone() }, &RenderControl::new()).unwrap();
    let (black, _) = furnace_at(material("black", serde_json::json!({"type": "none"})), 80.0);
    let black = render(&black, &buffers, &ResolvedSettings { samples: 16, ..s }, &RenderControl::new()).unwrap();
    for c in 0..3 {
        let ((m, se), (r, _), (b, _)) = (channel(&out, c), channel(&reference, c), channel(&black, c));
        let (walked, diffuse) = (m - b, r - b);
        assert!(
            (walked - diffuse).abs() < 0.04 * diffuse + 4.0 * se,
            "channel {c}: walked {walked} ± {se} vs Lambertian {diffuse}"
        );
    }
}

/// A sphere lit only from behind (a large emitter the sphere hides from the camera):
/// walked with a long mean free path, light comes through to the side facing the
/// camera, in BACKWARD and FORWARD (which walks from the lamp's side); as a diffuse
/// (weight 0) that side stays dark.
#[test]
fn light_comes_through_only_when_walked() {
    let (desc, buffers) = back_lit(principled_sss([0.9; 3], 1.4, [1.0; 3], 20.0, 0.0));
    let walked = render(&desc, &buffers, &settings(64), &RenderControl::new()).unwrap();
    let mut diffuse = desc.clone();
    let mut m = principled_sss([0.9; 3], 1.4, [1.0; 3], 20.0, 0.0);
    m["subsurface"]["weight"] = serde_json::json!(0.0);
    diffuse.materials[0] = material("jade", m);
    let diffuse = render(&diffuse, &buffers, &settings(16), &RenderControl::new()).unwrap();
    let forward = render(
        &desc,
        &buffers,
        &ResolvedSettings { direction: Direction::Forward, ..settings(256) },
        &RenderControl::new(),
    )
    .unwrap();
    let lum = |o: &RenderOutput| o.images.rgba.chunks_exact(4).map(luminance).sum::<f64>() / 64.0;
    let (w, d, f) = (lum(&walked), lum(&diffuse), lum(&forward));
    assert!(w > 0.05 && w > 10.0 * d, "walked {w}, diffuse {d}");
    // FORWARD walks from the lit side: the light comes through too, at about a third of
    // BACKWARD's here (0.246 vs 0.755): Cycles' BSSRDF is not reciprocal, and a mean free
    // path longer than the sphere makes the walk nearly ballistic, where the side of
    // the refracting entry (the camera's or the light's) decides where the path exits.
    assert!(f > 0.1 && f > 10.0 * d && f < w, "FORWARD walks too: {f}, BACKWARD {w}, diffuse {d}");
    for out in [&walked, &forward] {
        assert!(out.stats.warnings.is_empty(), "{:?}", out.stats.warnings);
    }
}

/// A unit sphere of `jade` lit only from behind by an emitting slab it hides from the
/// camera (64 pixels, all on the sphere).
fn back_lit(jade: serde_json::Value) -> (SceneDesc, Vec<Buffer>) {
    let mut desc = SceneDesc::default();
    let mut buffers = Vec::new();
    desc.materials.push(material("jade", jade));
    desc.materials.push(MaterialDesc {
        name: "lamp".into(),
        bsdf: BsdfDesc::None,
        emission: Some(SpectrumDesc::constant(4.0)),
        volume: None,
        one_sided: false,
        see_through: false,
    });
    let (v, t) = uv_sphere([0.0; 3], 1.0, 32, 64);
    add_mesh(&mut desc, &mut buffers, "sphere", v, t, 0);
    // An emitting slab at y ∈ [1.5, 1.6], 1.2 wide: behind the sphere, hidden by it.
    let (lo, hi) = ([-0.6f32, 1.5, -0.6], [0.6f32, 1.6, 0.6]);
    let mut vs = Vec::new();
    for k in 0..8 {
        vs.extend_from_slice(&[
            if k & 1 == 0 { lo[0] } else { hi[0] },
            if k & 2 == 0 { lo[1] } else { hi[1] },
            if k & 4 == 0 { lo[2] } else { hi[2] },
        ]);
    }
    let ts = vec![
        0, 2, 3, 0, 3, 1, 4, 5, 7, 4, 7, 6, 0, 1, 5, 0, 5, 4, 2, 6, 7, 2, 7, 3, 0, 4, 6, 0, 6, 2, 1, 3, 7, 1, 7, 5,
    ];
    add_mesh(&mut desc, &mut buffers, "lamp", vs, ts, 1);
    camera_along_y(&mut desc, 6.0, 300.0);
    (desc, buffers)
}

/// NaN or negative radii and scales are rejected with a message naming the material.
#[test]
fn bad_radius_is_rejected_naming_the_material() {
    for (radius, scale) in [([f32::NAN, 0.2, 0.1], 0.1), ([1.0, -0.2, 0.1], 0.1), ([1.0, 0.2, 0.1], -1.0)] {
        let mut m = material("marble", principled_sss([0.8; 3], 1.5, [1.0; 3], 0.1, 0.0));
        if let BsdfDesc::Principled { subsurface: Some(s), .. } = &mut m.bsdf {
            s.radius = radius;
            s.scale = scale;
        }
        let (desc, buffers) = furnace(m);
        let err = render(&desc, &buffers, &settings(1), &RenderControl::new()).err().expect("an error").to_string();
        assert!(err.contains("marble") && err.contains("subsurface"), "{err}");
    }
}

/// A subsurface sphere lit by an emitting box at `angle` (degrees) from the view
/// direction, 3 units from its centre; the camera at 6 units sees it whole.
fn lamp_scene(angle: f32, base: [f32; 3], radius: [f32; 3], scale: f32, roughness: f32) -> (SceneDesc, Vec<Buffer>) {
    let mut desc = SceneDesc::default();
    let mut buffers = Vec::new();
    let mut m = principled_sss(base, 1.4, radius, scale, 0.0);
    m["roughness"] = serde_json::json!(roughness);
    desc.materials.push(material("jade", m));
    desc.materials.push(MaterialDesc {
        name: "lamp".into(),
        bsdf: BsdfDesc::None,
        emission: Some(SpectrumDesc::constant(4.0)),
        volume: None,
        one_sided: false,
        see_through: false,
    });
    let (v, t) = uv_sphere([0.0; 3], 1.0, 32, 64);
    add_mesh(&mut desc, &mut buffers, "sphere", v, t, 0);
    let a = angle.to_radians();
    let c = [3.0 * a.sin(), -3.0 * a.cos(), 0.0];
    add_box(&mut desc, &mut buffers, "lamp", [c[0] - 0.5, c[1] - 0.5, -0.5], [c[0] + 0.5, c[1] + 0.5, 0.5], 1);
    camera_along_y(&mut desc, 6.0, 80.0);
    (desc, buffers)
}

/// Per-channel image means over `seeds` renders, and their standard errors.
fn seeded_means(desc: &SceneDesc, buffers: &[Buffer], s: &ResolvedSettings, seeds: u64) -> [(f64, f64); 3] {
    let runs: Vec<[f64; 3]> = (0..seeds)
        .map(|k| {
            let out =
                render(desc, buffers, &ResolvedSettings { seed: 17 + k, ..s.clone() }, &RenderControl::new()).unwrap();
            assert!(out.stats.warnings.is_empty(), "{:?}", out.stats.warnings);
            assert_eq!(out.stats.nonfinite_samples, 0);
            [0, 1, 2].map(|c| channel(&out, c).0)
        })
        .collect();
    let n = seeds as f64;
    [0, 1, 2].map(|c| {
        let m = runs.iter().map(|r| r[c]).sum::<f64>() / n;
        let var = runs.iter().map(|r| (r[c] - m).powi(2)).sum::<f64>() / (n - 1.0);
        (m, (var / n).sqrt())
    })
}

/// |a − b| within 4 standard errors of the difference plus `rel` of b, per channel.
fn agree(what: &str, a: &[(f64, f64); 3], b: &[(f64, f64); 3], rel: f64) {
    for c in 0..3 {
        let ((ma, sa), (mb, sb)) = (a[c], b[c]);
        let tol = 4.0 * (sa * sa + sb * sb).sqrt() + rel * mb;
        assert!((ma - mb).abs() < tol, "{what}: channel {c} {ma} ± {sa} vs {mb} ± {sb} (tolerance {tol})");
    }
}

/// FORWARD (light tracing) and BIDIRECTIONAL walk the subsurface lobe as BACKWARD does:
/// a chromatic jade sphere lit by an emitting box at 30° and at 90° from the view, each
/// direction's image mean over 6 seeds within 4 standard errors of BACKWARD's plus 3 %
/// (Cycles' BSSRDF is not reciprocal, docs/materials.md: light tracing takes the
/// entry's 1 − E(μ) on the light's side; measured within 2 standard errors, about 3 %
/// at 128/512 spp × 8 seeds). HERO's BIDIRECTIONAL is the 0/1 partition.
#[test]
fn forward_and_bidirectional_walk_as_backward() {
    for angle in [30.0, 90.0] {
        let (desc, buffers) = lamp_scene(angle, [0.8, 0.6, 0.4], [1.0, 0.6, 0.3], 0.5, 0.5);
        let s = |direction, samples, method| ResolvedSettings {
            direction,
            method,
            width: 16,
            height: 16,
            ..settings(samples)
        };
        let backward = seeded_means(&desc, &buffers, &s(Direction::Backward, 64, Method::Polychromatic), 6);
        for (direction, spp, method) in [
            (Direction::Forward, 256, Method::Polychromatic),
            (Direction::Bidirectional, 32, Method::Polychromatic),
            (Direction::Bidirectional, 32, Method::Hero),
        ] {
            let other = seeded_means(&desc, &buffers, &s(direction, spp, method), 6);
            agree(&format!("lamp at {angle}°, {direction:?} {method:?}"), &other, &backward, 0.03);
        }
    }
}

/// After a dispersive surface the path carries one wavelength and still walks: the
/// back-lit thin sphere glows through a dispersive glass slab (POLYCHROMATIC collapses
/// there, HERO ends its secondary wavelengths) as through a non-dispersive one of the
/// same index, and a dispersive sphere (HERO scatters it by the hero wavelength alone,
/// BACKWARD and FORWARD) glows as a non-dispersive one does in the same direction; as a
/// diffuse these stay dark (`light_comes_through_only_when_walked`).
#[test]
fn walks_at_a_single_wavelength_after_a_dispersive_surface() {
    let cauchy = serde_json::json!({"type": "cauchy", "a": 1.45, "b": 0.004});
    let constant = serde_json::json!({"type": "constant", "ior": 1.45 + 0.004 / 0.55f64.powi(2)});
    let (desc, buffers) = back_lit(principled_sss([0.9; 3], 1.4, [1.0; 3], 20.0, 0.0));
    let slab = |ior: &serde_json::Value| {
        let (mut d, mut b) = (desc.clone(), buffers.clone());
        d.materials.push(material("slab", serde_json::json!({"type": "dielectric", "ior": ior})));
        add_box(&mut d, &mut b, "slab", [-1.5, -3.0, -1.5], [1.5, -2.8, 1.5], 2);
        (d, b)
    };
    let sphere = |ior: &serde_json::Value| {
        let mut d = desc.clone();
        let mut m = principled_sss([0.9; 3], 1.4, [1.0; 3], 20.0, 0.0);
        m["ior"] = ior.clone();
        d.materials[0] = material("jade", m);
        d
    };
    let s = |direction, method| ResolvedSettings { direction, method, ..settings(64) };
    let (dispersive, plain) = (slab(&cauchy), slab(&constant));
    for method in [Method::Polychromatic, Method::Hero] {
        let a = seeded_means(&dispersive.0, &dispersive.1, &s(Direction::Backward, method), 4);
        let b = seeded_means(&plain.0, &plain.1, &s(Direction::Backward, method), 4);
        assert!(b[1].0 > 0.02, "{method:?}: the sphere glows through the slab: {b:?}");
        agree(&format!("through a dispersive slab, {method:?}"), &a, &b, 0.03);
    }
    let (dispersive, plain) = (sphere(&cauchy), sphere(&constant));
    for direction in [Direction::Backward, Direction::Forward] {
        let spp = if direction == Direction::Forward { 256 } else { 64 };
        let s = |method| ResolvedSettings { samples: spp, ..s(direction, method) };
        let b = seeded_means(&plain, &buffers, &s(Method::Polychromatic), 4);
        assert!(b[1].0 > 0.05, "{direction:?}: the sphere glows: {b:?}");
        let a = seeded_means(&dispersive, &buffers, &s(Method::Hero), 4);
        agree(&format!("a dispersive sphere, {direction:?} HERO"), &a, &b, 0.03);
    }
}
