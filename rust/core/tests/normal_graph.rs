//! A graph's Normal input shades the surface (docs/shading.md, "Normal Map and Bump"):
//! closed forms for a Lambertian plane under a sun whose shading normal is tilted by a
//! Normal Map or by the Bump of a linear height, and no light through the back.

mod common;

use common::*;
use polychrome_core::camera::{CameraDesc, Projection};
use polychrome_core::render::{render, RenderControl, ResolvedSettings};
use polychrome_core::scene::{BsdfDesc, Buffer, SceneDesc};
use serde_json::json;

/// A Diffuse BSDF (grey 0.5) whose Normal is linked from `normal` (nodes before it).
fn diffuse_with_normal(mut nodes: Vec<serde_json::Value>) -> BsdfDesc {
    let mut bsdf = json!({"type": "ShaderNodeBsdfDiffuse", "name": "D", "inputs": {"Color": [0.5, 0.5, 0.5, 1.0]}});
    if !nodes.is_empty() {
        bsdf["inputs"]["Normal"] = json!({"link": [nodes.len() - 1, "Normal"]});
    }
    nodes.push(bsdf);
    let surface = nodes.len() - 1;
    BsdfDesc::Graph(serde_json::from_value(json!({"nodes": nodes, "output": {"surface": [surface, "BSDF"]}})).unwrap())
}

/// Mean luminance of a plane z = 0 under a sun shining along `sun`, seen from above.
fn plane_under_sun(bsdf: BsdfDesc, sun: [f32; 3]) -> f64 {
    let out = render_plane(bsdf, sun, false);
    let (mean, _) = mean_and_standard_error(&out.images.rgba);
    mean
}

/// A plane z = 0 under a sun shining along `sun`, seen straight down from above (or
/// straight up from below) by an orthographic camera, 8², 2 spp.
fn render_plane(bsdf: BsdfDesc, sun_direction: [f32; 3], from_below: bool) -> polychrome_core::render::RenderOutput {
    let mut desc = SceneDesc::default();
    let mut buffers: Vec<Buffer> = Vec::new();
    desc.materials.push(material("plane", bsdf));
    add_square(&mut desc, &mut buffers, "plane", 4.0, 0);
    desc.lights.push(common::sun(sun_direction, 2.0, 0.0));
    desc.camera = CameraDesc {
        projection: Projection::Orthographic,
        ortho_scale: 2.0,
        to_world: if from_below {
            [[1.0, 0.0, 0.0, 0.0], [0.0, -1.0, 0.0, 0.0], [0.0, 0.0, -1.0, -5.0], [0.0, 0.0, 0.0, 1.0]]
        } else {
            [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 5.0], [0.0, 0.0, 0.0, 1.0]]
        },
        ..Default::default()
    };
    let settings = ResolvedSettings { width: 8, height: 8, samples: 2, max_bounces: 1, ..Default::default() };
    let out = render(&desc, &buffers, &settings, &RenderControl::new()).unwrap();
    assert_eq!(out.stats.nonfinite_samples, 0);
    out
}

/// A world-space Normal Map of a constant colour: the unit normal (sin t, 0, cos t).
fn world_normal_map(t: f32) -> Vec<serde_json::Value> {
    let c = [0.5 + 0.5 * t.sin(), 0.5, 0.5 + 0.5 * t.cos(), 1.0];
    vec![json!({"type": "ShaderNodeNormalMap", "name": "NM", "props": {"space": "WORLD"}, "inputs": {"Color": c}})]
}

/// A sun straight down on a Lambertian plane with shading normal tilted by t gives
/// L = ρ/π · E · cos t: the tilted plane over the untilted one is cos t (t < π/4: seen
/// from straight above, a larger tilt would mirror the view below the surface, and the
/// normal is bent back, as in Cycles).
#[test]
fn a_tilted_normal_scales_the_radiance_by_the_cosine() {
    let flat = plane_under_sun(diffuse_with_normal(vec![]), [0.0, 0.0, -1.0]);
    // Untilted: ρ/π · E with the grey 0.5 uplifted (a flat reflectance of 0.5).
    let expected = 0.5 / std::f64::consts::PI * 2.0;
    assert!((flat - expected).abs() < 1e-2 * expected, "flat {flat} vs {expected}");
    for t in [0.3f32, 0.5, 0.75] {
        let tilted = plane_under_sun(diffuse_with_normal(world_normal_map(t)), [0.0, 0.0, -1.0]);
        let ratio = tilted / flat;
        assert!((ratio - f64::from(t.cos())).abs() < 2e-3, "tilt {t}: ratio {ratio} vs cos {}", t.cos());
    }
}

/// Bump of the height h = k·x (Geometry › Position › X × k) at Distance 1 tilts the
/// normal to (−k, 0, 1)/√(1 + k²) (Cycles svm_node_set_bump in the limit): a sun
/// straight down gives cos = 1/√(1 + k²), Invert the same, Strength 0 the flat plane; a
/// sun at 0.5 rad gives n·l, dimmed by Blender 4.5's bump shadowing term.
#[test]
fn bump_of_a_linear_height_tilts_the_normal_by_its_gradient() {
    let flat = plane_under_sun(diffuse_with_normal(vec![]), [0.0, 0.0, -1.0]);
    let k = 0.75f32;
    let bump = |strength: f32, invert: bool| {
        vec![
            json!({"type": "ShaderNodeNewGeometry", "name": "G"}),
            json!({"type": "ShaderNodeSeparateXYZ", "name": "S", "inputs": {"Vector": {"link": [0, "Position"]}}}),
            json!({"type": "ShaderNodeMath", "name": "K", "props": {"operation": "MULTIPLY"},
                   "inputs": {"Value": {"link": [1, "X"]}, "Value_001": k}}),
            json!({"type": "ShaderNodeBump", "name": "B", "props": {"invert": invert},
                   "inputs": {"Strength": strength, "Distance": 1.0, "Height": {"link": [2, "Value"]}}}),
        ]
    };
    let expected = 1.0 / (1.0 + f64::from(k * k)).sqrt();
    for invert in [false, true] {
        let r = plane_under_sun(diffuse_with_normal(bump(1.0, invert)), [0.0, 0.0, -1.0]) / flat;
        assert!((r - expected).abs() < 2e-3, "invert {invert}: ratio {r} vs {expected}");
    }
    // The tilt's direction: a sun from +x (towards −x) lights the normal that leans to −x
    // less than the flat plane, and the inverted bump more.
    let sun = [-0.5f32.sin(), 0.0, -0.5f32.cos()];
    let lean = |invert| plane_under_sun(diffuse_with_normal(bump(1.0, invert)), sun);
    let n = glam::Vec3::new(-k, 0.0, 1.0).normalize();
    let l = glam::Vec3::new(0.5f32.sin(), 0.0, 0.5f32.cos());
    let flat_sun = plane_under_sun(diffuse_with_normal(vec![]), sun);
    // Blender 4.5's bump shadowing term (kernel/closure/bsdf.h): the GGX G1 at the light's
    // angle 0.5 about the smooth normal of α² = tan²θ_d / 8, tan θ_d = k.
    let alpha2 = (f64::from(k * k) / 8.0).min(1.0);
    let g1 = 1.0 / (1.0 + 0.5 * ((1.0 + alpha2 * 0.5f64.tan().powi(2)).sqrt() - 1.0));
    let want = f64::from(n.dot(l) / l.z) * g1;
    assert!((lean(false) / flat_sun - want).abs() < 3e-3, "{} vs {want}", lean(false) / flat_sun);
    let n_inv = glam::Vec3::new(k, 0.0, 1.0).normalize();
    let want_inv = f64::from(n_inv.dot(l) / l.z) * g1;
    assert!((lean(true) / flat_sun - want_inv).abs() < 3e-3, "{} vs {want_inv}", lean(true) / flat_sun);
    let r0 = plane_under_sun(diffuse_with_normal(bump(0.0, false)), [0.0, 0.0, -1.0]) / flat;
    assert!((r0 - 1.0).abs() < 1e-3, "strength 0: {r0}");
}

/// No light leaks: a sun below the plane, with the shading normal tilted towards it
/// (so that the light is above the shading normal's horizon), leaves the top black.
#[test]
fn a_tilted_normal_does_not_let_light_through_the_back() {
    let t = 1.2f32;
    // Light travelling up and towards −x: it comes from below, at 0.45 rad from the
    // horizon, where the tilted normal (sin 1.2, 0, cos 1.2) sees it above its horizon.
    let sun = [-(0.45f32.cos()), 0.0, 0.45f32.sin()];
    let l = plane_under_sun(diffuse_with_normal(world_normal_map(t)), sun);
    assert_eq!(l, 0.0, "light leaked through the plane: {l}");
}

/// The Normal pass is the shading normal the BSDF used, facing the ray, as Cycles' is
/// (surface_shader_average_normal about sd->N, flipped for a back face): a world-space
/// Normal Map of constant tilt t gives (sin t, 0, cos t) at every pixel, the unlinked
/// plane (0, 0, 1) from above and (0, 0, −1) from below.
#[test]
fn the_normal_pass_is_the_perturbed_shading_normal() {
    let pass = |bsdf, from_below| {
        let out = render_plane(bsdf, [0.0, 0.0, -1.0], from_below);
        let n = out.images.normal;
        assert_eq!(n.len(), 8 * 8 * 3);
        n
    };
    let check = |n: &[f32], want: glam::Vec3, what: &str| {
        let worst =
            n.chunks_exact(3).map(|p| (glam::Vec3::from_slice(p) - want).abs().max_element()).fold(0.0, f32::max);
        println!("{what}: worst |pass - n| {worst:e}");
        assert!(worst < 1e-5, "{what}: worst {worst} from {want}");
    };
    for t in [0.3f32, 0.5, 0.75] {
        let n = pass(diffuse_with_normal(world_normal_map(t)), false);
        check(&n, glam::Vec3::new(t.sin(), 0.0, t.cos()), &format!("tilt {t}"));
    }
    check(&pass(diffuse_with_normal(vec![]), false), glam::Vec3::Z, "flat, from above");
    check(&pass(diffuse_with_normal(vec![]), true), -glam::Vec3::Z, "flat, from below");
}

/// A mesh given without tangents gets smooth per-vertex tangents of its UVs with the
/// bitangent's sign (docs/shading.md): on a plane whose UVs are mirrored (u = −x,
/// v = y) a tangent-space Normal Map of colour (0.5 + sin t/2, 0.5, 0.5 + cos t/2)
/// leans along ∂p/∂u = −x and one of (0.5, 0.5 + sin t/2, 0.5 + cos t/2) along
/// ∂p/∂v = +y: the Normal pass is (−sin t, 0, cos t) and (0, sin t, cos t).
#[test]
fn a_mesh_without_tangents_uses_its_uvs_with_the_bitangent_sign() {
    let t = 0.5f32;
    for (c, want) in [
        ([0.5 + 0.5 * t.sin(), 0.5, 0.5 + 0.5 * t.cos(), 1.0], glam::Vec3::new(-t.sin(), 0.0, t.cos())),
        ([0.5, 0.5 + 0.5 * t.sin(), 0.5 + 0.5 * t.cos(), 1.0], glam::Vec3::new(0.0, t.sin(), t.cos())),
    ] {
        let nm = vec![
            json!({"type": "ShaderNodeNormalMap", "name": "NM", "props": {"space": "TANGENT"}, "inputs": {"Color": c}}),
        ];
        let mut desc = SceneDesc::default();
        let mut buffers: Vec<Buffer> = Vec::new();
        desc.materials.push(material("plane", diffuse_with_normal(nm)));
        let s = 4.0;
        let m = add_mesh(
            &mut desc,
            &mut buffers,
            "plane",
            vec![-s, -s, 0.0, s, -s, 0.0, s, s, 0.0, -s, s, 0.0],
            vec![0, 1, 2, 0, 2, 3],
            0,
        );
        buffers.push(Buffer::F32(vec![1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0]));
        desc.meshes[m].uvs = Some(buffers.len() - 1);
        desc.camera = ortho_down(2.0);
        let settings = ResolvedSettings { width: 8, height: 8, samples: 2, max_bounces: 1, ..Default::default() };
        let out = render(&desc, &buffers, &settings, &RenderControl::new()).unwrap();
        let worst = out
            .images
            .normal
            .chunks_exact(3)
            .map(|p| (glam::Vec3::from_slice(p) - want).abs().max_element())
            .fold(0.0, f32::max);
        println!("colour {c:?}: worst |pass - n| {worst:e}");
        assert!(worst < 1e-5, "colour {c:?}: worst {worst} from {want}");
    }
}
