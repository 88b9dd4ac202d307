//! Lights at infinity start light paths (light/mod.rs `infinite_light_origin`, pbrt-v4's
//! infinite lights): FORWARD and BIDIRECTIONAL render a uniform world, an importance-
//! sampled HDRI world and a sun with an angle as BACKWARD does (which samples them by
//! next-event estimation and BSDF rays escaping the scene). Statistics over independent
//! seeds; without light paths from these lights FORWARD's image is black but for what
//! the camera sees of the world directly.

mod common;

use common::*;
use polychrome_core::render::{render, Direction, RenderControl, ResolvedSettings};
use polychrome_core::scene::{BsdfDesc, Buffer, SceneDesc, TextureDesc, TextureEncoding, WorldDesc};
use polychrome_core::spectrum::named::SpectrumKind;
use polychrome_core::spectrum::{SpectrumDesc, WavelengthGrid};

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
    add_mesh(
        &mut desc,
        &mut b,
        "floor",
        vec![-3.0, -3.0, 0.0, 3.0, -3.0, 0.0, 3.0, 3.0, 0.0, -3.0, 3.0, 0.0],
        vec![0, 1, 2, 0, 2, 3],
        0,
    );
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
    (0..SEEDS)
        .map(|seed| {
            let s = ResolvedSettings {
                width: W as u32,
                height: H as u32,
                samples,
                max_bounces: 3,
                grid: WavelengthGrid::uniform(16, 380.0, 780.0).unwrap(),
                direction,
                seed,
                ..Default::default()
            };
            let r = render(&scene.0, &scene.1, &s, &RenderControl::new()).expect("render");
            assert_eq!(r.stats.nonfinite_samples, 0);
            r.images.rgba.chunks_exact(4).map(luminance).collect()
        })
        .collect()
}

/// Mean over seeds of each 6×6 block's mean luminance, with its standard error.
fn block_means(images: &[Vec<f64>]) -> Vec<(f64, f64)> {
    let k = 6;
    let mut out = Vec::new();
    for by in 0..H / k {
        for bx in 0..W / k {
            let per_seed: Vec<f64> = images
                .iter()
                .map(|img| {
                    let mut s = 0.0;
                    for y in by * k..(by + 1) * k {
                        for x in bx * k..(bx + 1) * k {
                            s += img[y * W + x];
                        }
                    }
                    s / (k * k) as f64
                })
                .collect();
            let n = per_seed.len() as f64;
            let m = per_seed.iter().sum::<f64>() / n;
            let var = per_seed.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (n - 1.0);
            out.push((m, (var / n).sqrt()));
        }
    }
    out
}

fn assert_same_image(a: &[Vec<f64>], b: &[Vec<f64>], what: &str) {
    let (ma, mb) = (block_means(a), block_means(b));
    let mut worst = 0.0f64;
    for (i, (&(x, sx), &(y, sy))) in ma.iter().zip(&mb).enumerate() {
        let se = (sx * sx + sy * sy).sqrt();
        let z = (x - y).abs() / (se + 1e-3 * y.abs().max(1e-4));
        worst = worst.max(z);
        assert!(z < 5.0, "{what}: block {i}: {x} vs {y} (se {se})");
    }
    let total =
        |m: &[(f64, f64)]| (m.iter().map(|v| v.0).sum::<f64>(), m.iter().map(|v| v.1 * v.1).sum::<f64>().sqrt());
    let ((ta, sa), (tb, sb)) = (total(&ma), total(&mb));
    assert!((ta - tb).abs() < 4.0 * (sa * sa + sb * sb).sqrt() + 2e-3 * tb, "{what}: image {ta} vs {tb}");
    eprintln!("{what}: worst block z {worst:.2}, image {ta:.4} vs {tb:.4}");
}

fn check(scene: (SceneDesc, Vec<Buffer>), what: &str) {
    let bwd = renders(&scene, Direction::Backward, 32);
    let fwd = renders(&scene, Direction::Forward, 16);
    let bid = renders(&scene, Direction::Bidirectional, 16);
    assert_same_image(&fwd, &bwd, &format!("FORWARD vs BACKWARD, {what}"));
    assert_same_image(&bid, &bwd, &format!("BIDIRECTIONAL vs BACKWARD, {what}"));
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
