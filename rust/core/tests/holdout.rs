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
use polychrome_core::render::{render, Direction, Method, RenderControl, RenderOutput, ResolvedSettings};
use polychrome_core::scene::{BsdfDesc, Buffer, InstanceDesc, MaterialDesc, SceneDesc};
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

/// The halves of [`render_halves`] lit by a sun straight down of irradiance 3 (no
/// world: FORWARD's light paths start from lights only) and seen by a perspective
/// camera 5 above (a 50 mm lens frames ±1.8), in `direction`; `holdout_object`: the
/// left half's instance is a holdout object (Cycles' Object › Visibility › Holdout);
/// `right`: the grey right half is there (else the background shows).
fn render_lit(
    left: BsdfDesc,
    holdout_object: bool,
    right: bool,
    transparent: bool,
    direction: Direction,
) -> RenderOutput {
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
    desc.materials.push(material("right", grey()));
    add_mesh(&mut desc, &mut buffers, "left", rect(-2.0, 0.0), vec![0, 1, 2, 0, 2, 3], 0);
    let identity = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]];
    let mut instances = vec![InstanceDesc {
        name: "left".into(),
        mesh: 0,
        transform: identity,
        holdout: holdout_object,
        ..Default::default()
    }];
    if right {
        add_mesh(&mut desc, &mut buffers, "right", rect(0.0, 2.0), vec![0, 1, 2, 0, 2, 3], 1);
        instances.push(InstanceDesc { name: "right".into(), mesh: 1, transform: identity, ..Default::default() });
    }
    desc.instances = Some(instances);
    desc.lights.push(sun([0.0, 0.0, -1.0], 3.0, 0.0));
    desc.camera = CameraDesc {
        to_world: [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 5.0], [0.0, 0.0, 0.0, 1.0]],
        ..Default::default()
    };
    let samples = if direction == Direction::Forward { 256 } else { 16 };
    let settings = ResolvedSettings { width: W, height: W, samples, max_bounces: 2, direction, ..Default::default() };
    let out = render(&desc, &buffers, &settings, &RenderControl::new()).unwrap();
    assert_eq!(out.stats.nonfinite_samples, 0);
    assert!(out.stats.warnings.is_empty(), "{:?}", out.stats.warnings);
    out
}

/// Mean luminance of columns `cols` and its standard error over their pixels.
fn columns_se(out: &RenderOutput, cols: std::ops::Range<u32>) -> (f64, f64) {
    let ys: Vec<f64> = (0..W)
        .flat_map(|row| cols.clone().map(move |c| (row * W + c) as usize))
        .map(|i| luminance(&out.images.rgba[i * 4..][..4]))
        .collect();
    let n = ys.len() as f64;
    let m = ys.iter().sum::<f64>() / n;
    let var = ys.iter().map(|y| (y - m).powi(2)).sum::<f64>() / (n - 1.0);
    (m, (var / n).sqrt())
}

/// The grey half under the sun: ρE/π.
const LIT: f64 = 0.5 * 3.0 / std::f64::consts::PI;

/// An object holdout (Cycles' SD_OBJECT_HOLDOUT_MASK) holds out whatever its material:
/// alpha exactly 0 and black where the camera sees it, with an opaque or a transparent
/// film, in BACKWARD and in FORWARD (whose pixel samples then trace camera rays for the
/// alpha; its light paths connect nothing on the holdout to the camera); the grey half
/// keeps alpha 1 and ρE/π.
#[test]
fn an_object_holdout_is_transparent_and_black_backward_and_forward() {
    for direction in [Direction::Backward, Direction::Forward, Direction::Bidirectional] {
        for transparent in [false, true] {
            let out = render_lit(grey(), true, true, transparent, direction);
            // Columns away from the seam (x = 0 falls on a pixel edge).
            let (a_hold, y_hold) = columns(&out, 0..W / 2);
            assert_eq!((a_hold, y_hold), (0.0, 0.0), "{direction:?} transparent {transparent}");
            assert_eq!(columns(&out, W / 2..W).0, 1.0, "{direction:?}");
            let (y, se) = columns_se(&out, W / 2..W);
            assert!((y - LIT).abs() < 4.0 * se + 0.02 * LIT, "{direction:?}: grey half {y} ± {se} vs {LIT}");
        }
    }
    // Not a holdout: the left half is the grey plane.
    let out = render_lit(grey(), false, true, false, Direction::Forward);
    assert_eq!(columns(&out, 0..W / 2).0, 1.0);
    let (y, se) = columns_se(&out, 0..W / 2);
    assert!((y - LIT).abs() < 4.0 * se + 0.02 * LIT, "grey left half {y} ± {se}");
}

/// FORWARD takes the alpha of Holdout closures as BACKWARD: a full holdout alpha 0 and
/// black, a Mix at Fac 0.5 alpha 0.5 exactly with half the diffuse's light (its
/// closure weight on the light paths' camera connections).
#[test]
fn holdout_closures_in_forward() {
    let out = render_lit(holdout(), false, true, false, Direction::Forward);
    assert_eq!(columns(&out, 0..W / 2), (0.0, 0.0));
    assert_eq!(columns(&out, W / 2..W).0, 1.0);
    let out = render_lit(mixed(Some(0.5)), false, true, true, Direction::Forward);
    let (a, _) = columns(&out, 0..W / 2);
    assert!((a - 0.5).abs() < 1e-6, "alpha {a}");
    let (y, se) = columns_se(&out, 0..W / 2);
    assert!((y - 0.5 * LIT).abs() < 4.0 * se + 0.02 * LIT, "mix half {y} ± {se} vs {}", 0.5 * LIT);
}

/// FORWARD with Film > Transparent: the background the camera sees (no right half
/// here) has alpha 0, the plane alpha 1; with an opaque film alpha 1 everywhere.
#[test]
fn a_transparent_film_in_forward_leaves_the_background_at_alpha_zero() {
    let out = render_lit(grey(), false, false, true, Direction::Forward);
    assert_eq!(columns(&out, W / 2..W), (0.0, 0.0));
    assert_eq!(columns(&out, 0..W / 2).0, 1.0);
    let out = render_lit(grey(), false, false, false, Direction::Forward);
    assert_eq!(columns(&out, 0..W).0, 1.0);
}
