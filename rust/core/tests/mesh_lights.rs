//! Emission that varies over a mesh (a node graph) is one `MeshLight` per instance and
//! material: a triangle chosen by a cdf of cheap power estimates, the radiance evaluated
//! at the sampled point (light/mesh.rs, docs/shading.md). Checked against closed forms:
//! the light-selection power of a half-black textured emitter (eq. 7), the irradiance
//! it gives a point above it (the configuration factor of a parallel rectangle), and
//! the image it lights against the same lamp cut into an emitting and a black half with
//! constant materials (BACKWARD, BIDIRECTIONAL and FORWARD).

mod common;

use common::*;
use glam::{Vec2, Vec3A};
use polychrome_core::color::uplift::UpliftMethod;
use polychrome_core::color::RgbSpace;
use polychrome_core::render::Direction;
use polychrome_core::scene::{BsdfDesc, Buffer, BuildOptions, MaterialDesc, Scene, SceneDesc, TextureDesc};
use polychrome_core::spectrum::{SampledSpectrum, SpectrumDesc, WavelengthGrid};
use serde_json::json;

/// A lamp material: a 2×1 texture (left texel black, right texel `rgb`, Closest) into an
/// Emission shader of `strength`.
fn textured_lamp(strength: f32) -> MaterialDesc {
    serde_json::from_value(json!({
        "name": "textured lamp",
        "nodes": [
            {"type": "ShaderNodeTexImage", "name": "T", "props": {"texture": 0, "interpolation": "Closest"}},
            {"type": "ShaderNodeEmission", "name": "E", "inputs": {"Color": {"link": [0, "Color"]}, "Strength": strength}}
        ],
        "output": {"surface": [1, "Emission"]}
    }))
    .unwrap()
}

fn constant_lamp(rgb: [f32; 3], strength: f32) -> MaterialDesc {
    MaterialDesc {
        name: "constant lamp".into(),
        bsdf: BsdfDesc::None,
        emission: Some(SpectrumDesc {
            kind: polychrome_core::spectrum::named::SpectrumKind::Rgb { rgb },
            scale: strength,
        }),
        volume: None,
        one_sided: false,
        see_through: false,
    }
}

fn add_texture(desc: &mut SceneDesc, buffers: &mut Vec<Buffer>, rgb: [f32; 3]) {
    buffers.push(Buffer::F32(vec![0.0, 0.0, 0.0, rgb[0], rgb[1], rgb[2]]));
    desc.textures.push(TextureDesc {
        name: "half black".into(),
        width: 2,
        height: 1,
        channels: 3,
        buffer: buffers.len() - 1,
        encoding: Default::default(),
        wrap: Default::default(),
    });
}

/// An n × n grid of quads over the rectangle `origin + u·du + v·dv`, (u, v) ∈ [0, 1]²,
/// with UVs (u, v); returns the mesh index.
#[allow(clippy::too_many_arguments)]
fn grid_quad(
    desc: &mut SceneDesc,
    buffers: &mut Vec<Buffer>,
    name: &str,
    origin: [f32; 3],
    du: [f32; 3],
    dv: [f32; 3],
    n: u32,
    material: u32,
) -> usize {
    let (o, du, dv) = (Vec3A::from(origin), Vec3A::from(du), Vec3A::from(dv));
    let (mut v, mut uv, mut t) = (Vec::new(), Vec::new(), Vec::new());
    for j in 0..=n {
        for i in 0..=n {
            let (a, b) = (i as f32 / n as f32, j as f32 / n as f32);
            let p = o + du * a + dv * b;
            v.extend_from_slice(&[p.x, p.y, p.z]);
            uv.extend_from_slice(&[a, b]);
        }
    }
    for j in 0..n {
        for i in 0..n {
            let a = j * (n + 1) + i;
            t.extend_from_slice(&[a, a + 1, a + n + 2, a, a + n + 2, a + n + 1]);
        }
    }
    let m = add_mesh(desc, buffers, name, v, t, material);
    buffers.push(Buffer::F32(uv));
    desc.meshes[m].uvs = Some(buffers.len() - 1);
    m
}

fn build(desc: &SceneDesc, buffers: &[Buffer]) -> Scene {
    let opts = BuildOptions {
        grid: WavelengthGrid::default(),
        space: RgbSpace::rec709(),
        uplift: UpliftMethod::Linear,
        width: 8,
        height: 8,
    };
    Scene::build(desc, buffers, &opts).expect("scene builds")
}

/// The light-selection power (eq. 7) of a unit-square emitter whose texture is black on
/// one half is half that of the same emitter without the black half: π·A·∫L against
/// 2π·A·∫L (both faces), on a quad of 2 triangles (8 × 8 stratified estimates each) and
/// on one of 8192 (one estimate at each centroid).
#[test]
fn a_half_black_textured_emitter_gets_half_the_selection_power() {
    let rgb = [0.9, 0.6, 0.3];
    for n in [1u32, 64] {
        let mut desc = SceneDesc::default();
        let mut b = Vec::new();
        add_texture(&mut desc, &mut b, rgb);
        desc.materials.push(textured_lamp(2.0));
        desc.materials.push(constant_lamp(rgb, 2.0));
        grid_quad(&mut desc, &mut b, "textured", [0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], n, 0);
        grid_quad(&mut desc, &mut b, "uniform", [0.0, 0.0, 3.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], n, 1);
        let scene = build(&desc, &b);
        let w = scene.grid.weights();
        let mut l = SampledSpectrum::zeros(scene.grid.len());
        scene.uplift.as_ref().unwrap().illuminant_into(rgb.map(|c| 2.0 * c), l.values_mut());
        let uniform_closed = 2.0 * std::f64::consts::PI * l.dot(w) as f64; // A = 1
        let textured = scene.lights[scene.triangle_light(0, 0).unwrap()].power(w);
        let uniform: f64 = (0..2 * n * n).map(|t| scene.lights[scene.triangle_light(1, t).unwrap()].power(w)).sum();
        // One light for the whole textured mesh, one per triangle for the constant one.
        assert_eq!(scene.lights.len(), 1 + 2 * (n * n) as usize);
        assert!((uniform / uniform_closed - 1.0).abs() < 1e-4, "n {n}: uniform {uniform} vs {uniform_closed}");
        let ratio = textured / uniform_closed;
        assert!((ratio - 0.5).abs() < 0.02, "n {n}: textured/uniform power {ratio}, want 0.5");
        let pmf = scene.light_distribution.pmf(scene.triangle_light(0, 0).unwrap()) as f64;
        assert!((pmf - 1.0 / 3.0).abs() < 0.01, "n {n}: selection probability {pmf}, want 1/3");
    }
}

/// Irradiance at a point a height h above a corner of a uniform Lambertian rectangle a × b
/// parallel to the receiver: E = L/2·[X/√(1+X²)·atan(Y/√(1+X²)) + Y/√(1+Y²)·atan(X/√(1+Y²))],
/// X = a/h, Y = b/h (the differential-to-rectangle configuration factor times πL).
fn corner_irradiance(l: f64, a: f64, b: f64, h: f64) -> f64 {
    let (x, y) = (a / h, b / h);
    let (sx, sy) = ((1.0 + x * x).sqrt(), (1.0 + y * y).sqrt());
    0.5 * l * (x / sx * (y / sx).atan() + y / sy * (x / sy).atan())
}

/// Next-event estimation from a mesh light is unbiased: the mean of L·cos/pdf over its
/// samples at a point above the lit half's corner is the closed-form irradiance, and
/// `pdf_li_part` reproduces each sample's pdf.
#[test]
fn sampling_a_textured_mesh_light_gives_the_closed_form_irradiance() {
    let rgb = [1.0, 1.0, 1.0];
    for n in [1u32, 16] {
        let mut desc = SceneDesc::default();
        let mut b = Vec::new();
        add_texture(&mut desc, &mut b, rgb);
        desc.materials.push(textured_lamp(1.0));
        grid_quad(&mut desc, &mut b, "textured", [0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], n, 0);
        let scene = build(&desc, &b);
        let w = scene.grid.weights();
        let mut l = SampledSpectrum::zeros(scene.grid.len());
        scene.uplift.as_ref().unwrap().illuminant_into(rgb, l.values_mut());
        let light = &scene.lights[scene.triangle_light(0, 0).unwrap()];
        let (h, p) = (0.5f32, Vec3A::new(0.5, 0.0, 0.5));
        let mut le = SampledSpectrum::zeros(scene.grid.len());
        let (count, mut sum, mut sum2) = (200_000u32, 0.0f64, 0.0f64);
        let mut rng = polychrome_core::sampling::Rng::for_sample(1, 2, 3);
        for _ in 0..count {
            let u = Vec2::new(rng.uniform(), rng.uniform());
            let Some(ls) = light.sample_li(p, u, &mut le) else { continue };
            let back = light.pdf_li_part(ls.part, p, ls.wi, ls.distance);
            assert!((back / ls.pdf - 1.0).abs() < 1e-4, "pdf_li_part {back} vs sample pdf {}", ls.pdf);
            let v = le.dot(w) as f64 * (-ls.wi.z).max(0.0) as f64 / ls.pdf as f64;
            sum += v;
            sum2 += v * v;
        }
        let mean = sum / count as f64;
        let se = ((sum2 / count as f64 - mean * mean) / count as f64).sqrt();
        let want = corner_irradiance(l.dot(w) as f64, 0.5, 1.0, h as f64);
        assert!((mean - want).abs() < 4.0 * se + 1e-3 * want, "n {n}: E {mean} ± {se} vs closed form {want}");
    }
}

const W: usize = 20;
const H: usize = 20;
const SEEDS: u64 = 5;

/// A diffuse floor lit by a lamp whose left half is black, above it facing down; the
/// camera sees the floor only. `split`: the lamp as two constant halves.
fn lamp_scene(split: bool) -> (SceneDesc, Vec<Buffer>) {
    let mut desc = SceneDesc::default();
    let mut b = Vec::new();
    let rgb = [0.9, 0.7, 0.5];
    desc.materials.push(MaterialDesc {
        name: "floor".into(),
        bsdf: BsdfDesc::Diffuse { reflectance: SpectrumDesc::constant(0.8) },
        emission: None,
        volume: None,
        one_sided: false,
        see_through: false,
    });
    let (o, du, dv) = ([-0.5f32, -0.5, 1.0], [1.0f32, 0.0, 0.0], [0.0f32, 1.0, 0.0]);
    if split {
        desc.materials.push(constant_lamp(rgb, 20.0));
        desc.materials.push(MaterialDesc {
            name: "black".into(),
            bsdf: BsdfDesc::None,
            emission: None,
            volume: None,
            one_sided: false,
            see_through: false,
        });
        grid_quad(&mut desc, &mut b, "lamp left", o, [0.5, 0.0, 0.0], dv, 1, 2);
        grid_quad(&mut desc, &mut b, "lamp right", [0.0, -0.5, 1.0], [0.5, 0.0, 0.0], dv, 1, 1);
    } else {
        add_texture(&mut desc, &mut b, rgb);
        desc.materials.push(textured_lamp(20.0));
        grid_quad(&mut desc, &mut b, "lamp", o, du, dv, 4, 1);
    }
    grid_quad(&mut desc, &mut b, "floor", [-2.0, -2.0, 0.0], [4.0, 0.0, 0.0], [0.0, 4.0, 0.0], 1, 0);
    // Between the lamp and the floor, looking straight down (the lamp is behind it).
    desc.camera.to_world = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.9], [0.0, 0.0, 0.0, 1.0]];
    desc.camera.focal_length = 18.0;
    (desc, b)
}

fn renders(scene: &(SceneDesc, Vec<Buffer>), direction: Direction, samples: u32) -> Vec<Vec<f64>> {
    direction_renders(scene, (W, H), SEEDS, direction, samples, 3)
}

/// Mean over seeds of each 5×5 block's luminance and its standard error.
fn block_means(images: &[Vec<f64>]) -> Vec<(f64, f64)> {
    let k = 5;
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

/// The textured lamp (one mesh light, per-point radiance, its own pdfs in the MIS
/// weights) lights the floor as the lamp cut into constant halves does, with every
/// technique that reaches the floor from the lamp.
#[test]
fn a_textured_lamp_lights_the_floor_as_its_constant_halves_do() {
    let (textured, split) = (lamp_scene(false), lamp_scene(true));
    for (direction, samples) in [(Direction::Backward, 16), (Direction::Bidirectional, 8), (Direction::Forward, 16)] {
        let (a, b) =
            (block_means(&renders(&textured, direction, samples)), block_means(&renders(&split, direction, samples)));
        let lit = b.iter().map(|v| v.0).fold(0.0, f64::max);
        assert!(lit > 0.0, "{direction:?}: the floor is dark");
        for (i, (&(x, sx), &(y, sy))) in a.iter().zip(&b).enumerate() {
            let se = (sx * sx + sy * sy).sqrt();
            assert!(
                (x - y).abs() < 5.0 * se + 0.01 * lit,
                "{direction:?} block {i}: textured {x} vs halves {y} (se {se})"
            );
        }
        let (ta, tb) = (a.iter().map(|v| v.0).sum::<f64>(), b.iter().map(|v| v.0).sum::<f64>());
        eprintln!("{direction:?}: image {ta:.4} (textured) vs {tb:.4} (halves)");
        assert!((ta / tb - 1.0).abs() < 0.03, "{direction:?}: image {ta} vs {tb}");
    }
}
