//! Every light starts light paths that FORWARD and BIDIRECTIONAL weigh as BACKWARD
//! does. Lights at infinity (light/mod.rs `infinite_light_origin`, pbrt-v4's
//! infinite lights): FORWARD and BIDIRECTIONAL render a uniform world, an importance-
//! sampled HDRI world and a sun with an angle as BACKWARD does (which samples them by
//! next-event estimation and BSDF rays escaping the scene). Statistics over independent
//! seeds; without light paths from these lights FORWARD's image is black but for what
//! the camera sees of the world directly.

mod common;

use common::*;
use polychrome_core::render::Direction;
use polychrome_core::scene::{BsdfDesc, Buffer, SceneDesc, TextureDesc, TextureEncoding, WorldDesc};
use polychrome_core::spectrum::named::SpectrumKind;
use polychrome_core::spectrum::SpectrumDesc;

const W: usize = 24;
const H: usize = 24;
const SEEDS: u64 = 6;

/// A grey floor with a red box on it, seen from above at an angle (the floor fills
/// the lower part of the view, the world the upper).
fn stage() -> (SceneDesc, Vec<Buffer>) {
    let mut desc = SceneDesc::default();
    let mut b = Vec::new();
    desc.materials.push(material("grey", BsdfDesc::Diffuse { reflectance: SpectrumDesc::constant(0.6) }));
    desc.materials.push(material(
        "red",
        BsdfDesc::Diffuse {
            reflectance: SpectrumDesc {
                kind: SpectrumKind::Tabulated {
                    wavelengths: vec![380.0, 560.0, 620.0, 780.0],
                    values: vec![0.05, 0.08, 0.9, 0.95],
                },
                scale: 0.8,
            },
        },
    ));
    add_square(&mut desc, &mut b, "floor", 3.0, 0);
    add_box(&mut desc, &mut b, "box", [-0.6, -0.4, 0.0], [0.6, 0.4, 0.9], 1);
    desc.camera.to_world = look_at([0.5, -5.0, 2.5], [0.0, 0.0, 0.4]);
    (desc, b)
}

/// An 16×8 sky: a vertical gradient with one hot cell (importance sampling matters).
fn hdri(desc: &mut SceneDesc, b: &mut Vec<Buffer>) {
    let (w, h) = (16u32, 8u32);
    let mut rgb = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let hot = x == 5 && y == 6;
            let g = 0.2 + 0.1 * y as f32;
            rgb.extend(if hot { [40.0, 36.0, 30.0] } else { [0.6 * g, 0.8 * g, g] });
        }
    }
    b.push(Buffer::F32(rgb));
    desc.textures.push(TextureDesc {
        name: "sky".into(),
        width: w,
        height: h,
        channels: 3,
        buffer: b.len() - 1,
        encoding: TextureEncoding::Linear,
        wrap: Default::default(),
    });
    desc.world = Some(WorldDesc {
        radiance: None,
        texture: Some(desc.textures.len() - 1),
        strength: 1.0,
        rotation: 0.3,
        importance_sampling: true,
        volume: None,
    });
}

/// Per-seed luminance images of one direction.
fn renders(scene: &(SceneDesc, Vec<Buffer>), direction: Direction, samples: u32) -> Vec<Vec<f64>> {
    direction_renders(scene, (W, H), SEEDS, direction, samples, 3)
}

fn check(scene: (SceneDesc, Vec<Buffer>), what: &str) {
    // LP_SCALE=16: 16x the samples, for the checks quoted in docs/methods.md.
    let k: u32 = std::env::var("LP_SCALE").ok().and_then(|v| v.parse().ok()).unwrap_or(1);
    let bwd = renders(&scene, Direction::Backward, 32 * k);
    let fwd = renders(&scene, Direction::Forward, 16 * k);
    let bid = renders(&scene, Direction::Bidirectional, 16);
    assert_same_image(&fwd, &bwd, W, H, 2e-3, &format!("FORWARD vs BACKWARD, {what}"));
    assert_same_image(&bid, &bwd, W, H, 2e-3, &format!("BIDIRECTIONAL vs BACKWARD, {what}"));
}

#[test]
fn forward_and_bidirectional_render_a_uniform_world() {
    let mut scene = stage();
    scene.0.world = Some(uniform_world(&SpectrumDesc::new(SpectrumKind::Rgb { rgb: [0.5, 0.7, 1.0] })));
    check(scene, "uniform world");
}

#[test]
fn forward_and_bidirectional_render_an_hdri_world() {
    let mut scene = stage();
    hdri(&mut scene.0, &mut scene.1);
    check(scene, "HDRI world");
}

#[test]
fn forward_and_bidirectional_render_a_sun_with_an_angle() {
    let mut scene = stage();
    scene.0.lights.push(sun([0.3, 0.5, -0.8], 3.0, 0.2));
    check(scene, "sun of 0.2 rad");
}

/// A light from its JSON description.
fn light(json: serde_json::Value) -> polychrome_core::scene::LightDesc {
    serde_json::from_value(json).expect("light description")
}

/// A sphere light the camera sees (its disk in the upper part of the view): its light
/// paths are strategy C of BIDIRECTIONAL, at every vertex and for its own surface seen
/// by the camera (k = 1), weighed against the camera ray hitting it (A).
#[test]
fn forward_and_bidirectional_render_a_sphere_light_the_camera_sees() {
    let mut scene = stage();
    scene.0.lights.push(light(serde_json::json!({
        "type": "point", "name": "bulb", "position": [0.9, 0.8, 1.6], "radius": 0.35,
        "intensity": {"type": "constant", "value": 3.0}, "visibility": {"camera": true}
    })));
    check(scene, "sphere light seen by the camera");
}

/// A spot light with a radius (Blender's default spot has one): its falloff is the
/// receiver's, seen from the centre, as Cycles (camera paths: `sample_li`, `hit`); light
/// paths scale by it at the point their first segment reaches, so FORWARD and
/// BIDIRECTIONAL render what BACKWARD does (FORWARD was 3.7 % bright when light paths
/// took the falloff along their own direction from the sphere).
#[test]
fn forward_and_bidirectional_render_a_spot_sphere() {
    let mut scene = stage();
    scene.0.lights.push(light(serde_json::json!({
        "type": "spot", "name": "spot", "position": [0.6, -0.9, 1.8], "direction": [-0.3, 0.4, -1.0],
        "spot_size": 0.9, "spot_blend": 0.3, "radius": 0.25, "intensity": {"type": "constant", "value": 4.0}
    })));
    check(scene, "spot light of radius 0.25");
}

/// A sphere light with a profile (an IES file on a Blender point light of some radius):
/// the profile towards the receiver from the centre, in every direction.
#[test]
fn forward_and_bidirectional_render_a_profiled_sphere() {
    let mut scene = stage();
    scene.0.lights.push(light(serde_json::json!({
        "type": "point", "name": "ies", "position": [0.4, -0.6, 1.7], "radius": 0.3,
        "intensity": {"type": "constant", "value": 3.0},
        "profile": {"h_angles": [0.0, 6.0], "v_angles": [0.0, 0.8, 1.6, 3.0],
                    "values": [1.0, 0.7, 0.1, 0.0, 1.0, 0.7, 0.1, 0.0]}
    })));
    check(scene, "profiled sphere light of radius 0.3");
}
