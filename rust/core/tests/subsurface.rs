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
/// camera; as a diffuse (FORWARD, which does not walk: warned) that side stays dark.
#[test]
fn light_comes_through_only_when_walked() {
    let mut desc = SceneDesc::default();
    let mut buffers = Vec::new();
    desc.materials.push(material("jade", principled_sss([0.9; 3], 1.4, [1.0; 3], 20.0, 0.0)));
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
    let walked = render(&desc, &buffers, &settings(64), &RenderControl::new()).unwrap();
    let diffuse = render(
        &desc,
        &buffers,
        &ResolvedSettings { direction: Direction::Forward, ..settings(16) },
        &RenderControl::new(),
    )
    .unwrap();
    let lum = |o: &RenderOutput| o.images.rgba.chunks_exact(4).map(luminance).sum::<f64>() / 64.0;
    let (w, d) = (lum(&walked), lum(&diffuse));
    assert!(w > 0.05 && w > 10.0 * d, "walked {w}, diffuse {d}");
    assert!(walked.stats.warnings.is_empty(), "{:?}", walked.stats.warnings);
    assert!(
        diffuse.stats.warnings.iter().any(|m| m.contains("'jade'") && m.contains("subsurface")),
        "{:?}",
        diffuse.stats.warnings
    );
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
