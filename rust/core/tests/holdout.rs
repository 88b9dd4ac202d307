//! Blender's Holdout (docs/materials.md#holdout): closed forms for the Combined pass's
//! alpha and colour of a plane seen straight down by an orthographic camera, half of
//! it a holdout, under a uniform white world, as Cycles has it
//! (`integrate_surface_holdout`, kernel/integrator/shade_surface.h): the holdout's alpha
//! is 1 − its weight and it adds no light, with Film > Transparent or without (Cycles'
//! camera rays always carry PATH_RAY_TRANSPARENT_BACKGROUND; measured in Blender 4.5);
//! a transparent film's background has alpha 0.

mod common;

use common::*;
use polychrome_core::camera::{CameraDesc, Projection};
use polychrome_core::render::{render, Method, RenderControl, RenderOutput, ResolvedSettings};
use polychrome_core::scene::{BsdfDesc, Buffer, MaterialDesc, SceneDesc};
use polychrome_core::spectrum::SpectrumDesc;
use serde_json::json;

const W: u32 = 8;

fn graph(nodes: Vec<serde_json::Value>, surface: usize, out: &str) -> BsdfDesc {
    BsdfDesc::Graph(serde_json::from_value(json!({"nodes": nodes, "output": {"surface": [surface, out]}})).unwrap())
}

fn holdout() -> BsdfDesc {
    graph(vec![json!({"type": "ShaderNodeHoldout", "name": "H"})], 0, "Holdout")
}

/// A Mix Shader of a Holdout (first) and a grey 0.5 Diffuse (second) at `fac`: a number,
/// or None for Fac = the hit's world x (Geometry › Position › X, clamped to 0..1 by the Mix).
fn mixed(fac: Option<f32>) -> BsdfDesc {
    let mut nodes = vec![
        json!({"type": "ShaderNodeHoldout", "name": "H"}),
        json!({"type": "ShaderNodeBsdfDiffuse", "name": "D", "inputs": {"Color": [0.5, 0.5, 0.5, 1.0]}}),
    ];
    let fac = match fac {
        Some(f) => json!(f),
        None => {
            nodes.push(json!({"type": "ShaderNodeNewGeometry", "name": "G"}));
            nodes.push(
                json!({"type": "ShaderNodeSeparateXYZ", "name": "S", "inputs": {"Vector": {"link": [2, "Position"]}}}),
            );
            json!({"link": [3, "X"]})
        }
    };
    nodes.push(json!({"type": "ShaderNodeMixShader", "name": "M",
        "inputs": {"Fac": fac, "Shader": {"link": [0, "Holdout"]}, "Shader_001": {"link": [1, "BSDF"]}}}));
    let n = nodes.len() - 1;
    graph(nodes, n, "Shader")
}

fn grey() -> BsdfDesc {
    BsdfDesc::Diffuse { reflectance: SpectrumDesc::constant(0.5) }
}

/// The plane z = 0 over x ∈ [−1, 1] (the whole 8×8 image, the camera's ortho scale 2):
/// `left` on x < 0, `right` on x > 0, under a white world of radiance 1 (the plane
/// alone: a Lambertian ρ reflects ρ), or only `left` (x > 0 shows the world).
fn render_halves(left: BsdfDesc, right: Option<BsdfDesc>, transparent: bool, method: Method) -> RenderOutput {
    let mut desc = SceneDesc { film_transparent: transparent, ..Default::default() };
    let mut buffers: Vec<Buffer> = Vec::new();
    let material = |name: &str, bsdf| MaterialDesc {
        name: name.into(),
        bsdf,
        emission: None,
        volume: None,
        one_sided: false,
        see_through: false,
    };
    let rect = |x0: f32, x1: f32| vec![x0, -2.0, 0.0, x1, -2.0, 0.0, x1, 2.0, 0.0, x0, 2.0, 0.0];
    desc.materials.push(material("left", left));
    add_mesh(&mut desc, &mut buffers, "left", rect(-2.0, 0.0), vec![0, 1, 2, 0, 2, 3], 0);
    if let Some(r) = right {
        desc.materials.push(material("right", r));
        add_mesh(&mut desc, &mut buffers, "right", rect(0.0, 2.0), vec![0, 1, 2, 0, 2, 3], 1);
    }
    desc.world = Some(uniform_world(&SpectrumDesc::constant(1.0)));
    desc.camera = CameraDesc {
        projection: Projection::Orthographic,
        ortho_scale: 2.0,
        to_world: [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 5.0], [0.0, 0.0, 0.0, 1.0]],
        ..Default::default()
    };
    let settings = ResolvedSettings { width: W, height: W, samples: 16, max_bounces: 2, method, ..Default::default() };
    let out = render(&desc, &buffers, &settings, &RenderControl::new()).unwrap();
    assert_eq!(out.stats.nonfinite_samples, 0);
    out
}

/// Mean alpha and luminance over the columns `cols` of every row.
fn columns(out: &RenderOutput, cols: std::ops::Range<u32>) -> (f64, f64) {
    let rgba = &out.images.rgba;
    let (mut a, mut y, mut n) = (0.0, 0.0, 0.0);
    for row in 0..W {
        for c in cols.clone() {
            let p = &rgba[((row * W + c) * 4) as usize..][..4];
            a += p[3] as f64;
            y += luminance(p);
            n += 1.0;
        }
    }
    (a / n, y / n)
}

#[test]
fn a_holdout_is_transparent_and_black_with_a_transparent_film() {
    for method in [Method::Polychromatic, Method::MonochromaticRays, Method::Hero] {
        let out = render_halves(holdout(), Some(grey()), true, method);
        let (a_hold, y_hold) = columns(&out, 0..W / 2);
        let (a_grey, y_grey) = columns(&out, W / 2..W);
        assert_eq!(a_hold, 0.0, "{method:?}");
        assert_eq!(y_hold, 0.0, "{method:?}");
        assert_eq!(a_grey, 1.0, "{method:?}");
        // Lambertian 0.5 under a uniform world of 1 (one bounce): 0.5, the world seen
        // nowhere directly.
        assert!((y_grey - 0.5).abs() < 0.02, "{method:?}: grey half {y_grey}");
    }
}

#[test]
fn a_holdout_is_transparent_with_an_opaque_film_too() {
    let out = render_halves(holdout(), Some(grey()), false, Method::Polychromatic);
    assert_eq!(columns(&out, 0..W / 2), (0.0, 0.0));
    assert_eq!(columns(&out, W / 2..W).0, 1.0);
}

#[test]
fn a_half_holdout_mix_has_alpha_one_half_and_half_the_light() {
    let out = render_halves(mixed(Some(0.5)), Some(grey()), true, Method::Polychromatic);
    let (a, y) = columns(&out, 0..W / 2);
    // Alpha is exact: every camera path reaches the holdout with throughput 1.
    assert!((a - 0.5).abs() < 1e-6, "alpha {a}");
    assert!((y - 0.25).abs() < 0.01, "luminance {y} vs 0.5 · 0.5");
    // Opaque film: the same.
    let out = render_halves(mixed(Some(0.5)), Some(grey()), false, Method::Polychromatic);
    let (a, y) = columns(&out, 0..W / 2);
    assert!((a - 0.5).abs() < 1e-6, "alpha {a}");
    assert!((y - 0.25).abs() < 0.01, "luminance {y}");
}

#[test]
fn a_varying_holdout_weight_is_evaluated_per_hit() {
    // Fac = x on the whole plane: holdout weight 1 − x (clamped), alpha x per pixel
    // (linear over a pixel: its mean is the pixel centre's x), 0 on x < 0.
    let out = render_halves(mixed(None), Some(mixed(None)), true, Method::Polychromatic);
    let rgba = &out.images.rgba;
    for c in 0..W {
        let x = -1.0 + (c as f64 + 0.5) * 2.0 / W as f64;
        let expected = x.clamp(0.0, 1.0);
        for row in 0..W {
            let a = rgba[((row * W + c) * 4 + 3) as usize] as f64;
            assert!((a - expected).abs() < 0.03, "column {c} row {row}: alpha {a} vs {expected}");
        }
    }
}

#[test]
fn a_transparent_film_shows_the_background_at_alpha_zero() {
    // Only the left half has geometry: the right shows the world, which the
    // transparent film leaves out (alpha 0, black) while it still lights the plane.
    let out = render_halves(grey(), None, true, Method::Polychromatic);
    assert_eq!(columns(&out, W / 2..W), (0.0, 0.0));
    let (a, y) = columns(&out, 0..W / 2);
    assert_eq!(a, 1.0);
    assert!((y - 0.5).abs() < 0.02, "lit by the world: {y}");
    // Opaque: the world at radiance 1, alpha 1.
    let out = render_halves(grey(), None, false, Method::Polychromatic);
    let (a, y) = columns(&out, W / 2..W);
    assert_eq!(a, 1.0);
    assert!((y - 1.0).abs() < 0.01, "world {y}");
}
