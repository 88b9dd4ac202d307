//! The light tree (light/tree.rs) against eq. 7's choice by power alone, on a floor lit
//! by many small lights (point and spot lights, one-sided emissive tiles, a dim sun
//! beside the tree): both estimate the same image (every block within its standard
//! errors over independent seeds), and the tree's per-pixel variance is well below the
//! power choice's, since at each point it samples the lights near it.

mod common;

use common::*;
use polychrome_core::render::ResolvedSettings;
use polychrome_core::scene::{BsdfDesc, Buffer, SceneDesc};
use polychrome_core::spectrum::{SpectrumDesc, WavelengthGrid};

const W: usize = 24;
const H: usize = 24;
const SEEDS: u64 = 6;

fn light(json: serde_json::Value) -> polychrome_core::scene::LightDesc {
    serde_json::from_value(json).expect("light description")
}

/// A grey floor 8 wide under a 6×6 grid of lights of varied power at 0.3 to 0.6
/// above it: points, spots aimed down and emissive tiles facing down.
fn stage() -> (SceneDesc, Vec<Buffer>) {
    let mut desc = SceneDesc::default();
    let mut b = Vec::new();
    desc.materials.push(material("grey", BsdfDesc::Diffuse { reflectance: SpectrumDesc::constant(0.6) }));
    add_square(&mut desc, &mut b, "floor", 4.0, 0);
    for i in 0..6 {
        for j in 0..6 {
            let (x, y) = (-3.5 + 1.4 * i as f32, -3.5 + 1.4 * j as f32);
            let z = 0.3 + 0.06 * ((i * 7 + j * 3) % 6) as f32;
            let power = 0.5 + ((i * 5 + j * 11) % 7) as f32 * 0.4;
            let name = format!("lamp{i}{j}");
            match (i + j) % 3 {
                0 => desc.lights.push(light(serde_json::json!({
                    "type": "point", "name": name, "position": [x, y, z],
                    "intensity": {"type": "constant", "value": power * 0.1},
                }))),
                1 => desc.lights.push(light(serde_json::json!({
                    "type": "spot", "name": name, "position": [x, y, z], "direction": [0.2, 0.1, -1.0],
                    "spot_size": 1.6, "intensity": {"type": "constant", "value": power * 0.15},
                }))),
                _ => {
                    let mut m = material(&name, BsdfDesc::Diffuse { reflectance: SpectrumDesc::constant(0.0) });
                    m.emission = Some(SpectrumDesc::constant(power * 0.3));
                    m.one_sided = true;
                    desc.materials.push(m);
                    let m = desc.materials.len() as u32 - 1;
                    let h = 0.08;
                    // Wound clockwise seen from above: the face emits downwards.
                    add_mesh(
                        &mut desc,
                        &mut b,
                        &name,
                        vec![x - h, y - h, z, x - h, y + h, z, x + h, y + h, z, x + h, y - h, z],
                        vec![0, 1, 2, 0, 2, 3],
                        m,
                    );
                }
            }
        }
    }
    desc.lights.push(sun([0.3, 0.2, -1.0], 0.05, 0.0));
    desc.camera = ortho_down(8.0);
    (desc, b)
}

/// Per-seed luminance images with the light tree on or off.
fn renders(scene: &(SceneDesc, Vec<Buffer>), light_tree: bool) -> Vec<Vec<f64>> {
    luminance_renders(scene, SEEDS, |seed| ResolvedSettings {
        width: W as u32,
        height: H as u32,
        // LT_SPP: more samples per pixel for the check in docs/BENCHMARKS.md.
        samples: std::env::var("LT_SPP").ok().and_then(|v| v.parse().ok()).unwrap_or(16),
        max_bounces: 2,
        grid: WavelengthGrid::uniform(8, 380.0, 780.0).unwrap(),
        light_tree,
        seed,
        ..Default::default()
    })
}

#[test]
fn light_tree_renders_the_same_image_with_less_noise() {
    let scene = stage();
    let tree = renders(&scene, true);
    let power = renders(&scene, false);
    assert_same_image(&tree, &power, W, H, 2e-3, "light tree vs power");
    let (vt, vp) = (mean_pixel_variance(&tree), mean_pixel_variance(&power));
    eprintln!("per-pixel variance: tree {vt:.3e}, power {vp:.3e}, ratio {:.3}", vt / vp);
    assert!(vt < 0.7 * vp, "the tree's variance {vt} is not below 0.7 x the power choice's {vp}");
}
