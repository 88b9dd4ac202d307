//! Scene-building helpers shared by the core's integration tests.
#![allow(dead_code)]

use glam::Vec3A;
use polychrome_core::camera::{CameraDesc, Projection};
use polychrome_core::render::{render, RenderControl, ResolvedSettings};
use polychrome_core::scene::{BsdfDesc, Buffer, LightDesc, MaterialDesc, MeshDesc, SceneDesc, WorldDesc};
use polychrome_core::spectrum::SpectrumDesc;

/// A two-sided material of `bsdf` without emission or volume.
pub fn material(name: &str, bsdf: BsdfDesc) -> MaterialDesc {
    MaterialDesc { name: name.into(), bsdf, emission: None, volume: None, one_sided: false, see_through: false }
}

/// A UV sphere of `radius` around `center` (outward winding), as vertices and triangles.
pub fn uv_sphere(center: [f32; 3], radius: f32, rings: u32, segments: u32) -> (Vec<f32>, Vec<u32>) {
    let mut v = Vec::new();
    let mut t = Vec::new();
    for r in 0..=rings {
        let theta = std::f32::consts::PI * r as f32 / rings as f32;
        for s in 0..=segments {
            let phi = 2.0 * std::f32::consts::PI * s as f32 / segments as f32;
            v.extend_from_slice(&[
                center[0] + radius * theta.sin() * phi.cos(),
                center[1] + radius * theta.sin() * phi.sin(),
                center[2] + radius * theta.cos(),
            ]);
        }
    }
    let row = segments + 1;
    for r in 0..rings {
        for s in 0..segments {
            let a = r * row + s;
            let b = a + row;
            t.extend_from_slice(&[a, b, a + 1, a + 1, b, b + 1]);
        }
    }
    (v, t)
}

/// Adds the square [-half, half]² in the plane z = 0, facing +z, as a mesh.
pub fn add_square(desc: &mut SceneDesc, buffers: &mut Vec<Buffer>, name: &str, half: f32, material: u32) -> usize {
    let s = half;
    add_mesh(
        desc,
        buffers,
        name,
        vec![-s, -s, 0.0, s, -s, 0.0, s, s, 0.0, -s, s, 0.0],
        vec![0, 1, 2, 0, 2, 3],
        material,
    )
}

/// Adds the axis-aligned box [lo, hi] (12 triangles wound outwards) as a mesh.
pub fn add_box(desc: &mut SceneDesc, buffers: &mut Vec<Buffer>, name: &str, lo: [f32; 3], hi: [f32; 3], material: u32) {
    let mut v = Vec::new();
    for z in [lo[2], hi[2]] {
        for y in [lo[1], hi[1]] {
            for x in [lo[0], hi[0]] {
                v.extend_from_slice(&[x, y, z]);
            }
        }
    }
    let faces = [[0u32, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
    let t: Vec<u32> = faces.iter().flat_map(|f| [f[0], f[1], f[2], f[0], f[2], f[3]]).collect();
    add_mesh(desc, buffers, name, v, t, material);
}

/// Adds a mesh to the description, returning its index.
pub fn add_mesh(
    desc: &mut SceneDesc,
    buffers: &mut Vec<Buffer>,
    name: &str,
    v: Vec<f32>,
    t: Vec<u32>,
    material: u32,
) -> usize {
    buffers.push(Buffer::F32(v));
    buffers.push(Buffer::U32(t));
    desc.meshes.push(MeshDesc {
        name: name.into(),
        vertices: buffers.len() - 2,
        triangles: buffers.len() - 1,
        normals: None,
        uvs: None,
        material_ids: None,
        material: Some(material),
        ..Default::default()
    });
    desc.meshes.len() - 1
}

/// Luminance Y of a linear Rec.709 pixel.
pub fn luminance(rgba: &[f32]) -> f64 {
    0.2126 * rgba[0] as f64 + 0.7152 * rgba[1] as f64 + 0.0722 * rgba[2] as f64
}

/// Mean and standard error of the per-pixel luminance.
pub fn mean_and_standard_error(rgba: &[f32]) -> (f64, f64) {
    let ys: Vec<f64> = rgba.chunks_exact(4).map(luminance).collect();
    let n = ys.len() as f64;
    let mean = ys.iter().sum::<f64>() / n;
    let var = ys.iter().map(|y| (y - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, (var / n).sqrt())
}

/// A world of uniform `radiance` from every direction (the description's other fields
/// at their defaults).
pub fn uniform_world(radiance: &SpectrumDesc) -> WorldDesc {
    serde_json::from_value(serde_json::json!({ "radiance": radiance })).expect("world description")
}

/// A sun (distant light) shining along `direction` with irradiance `e` (W/m² per unit
/// spectrum) and angular diameter `angle` (0: a parallel light).
pub fn sun(direction: [f32; 3], e: f32, angle: f32) -> LightDesc {
    LightDesc::Distant {
        name: "sun".into(),
        direction,
        irradiance: SpectrumDesc::constant(e),
        angle,
        visibility: Default::default(),
        motion: Vec::new(),
    }
}

/// An orthographic camera at z = 5 looking down −z, `scale` wide.
pub fn ortho_down(scale: f32) -> CameraDesc {
    CameraDesc {
        projection: Projection::Orthographic,
        ortho_scale: scale,
        to_world: [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 5.0], [0.0, 0.0, 0.0, 1.0]],
        ..Default::default()
    }
}

/// Camera → world rows for a camera at `eye` looking at `target`, world Z up.
pub fn look_at(eye: [f32; 3], target: [f32; 3]) -> [[f32; 4]; 4] {
    let eye = Vec3A::from(eye);
    let f = (Vec3A::from(target) - eye).normalize();
    let r = f.cross(Vec3A::Z).normalize();
    let u = r.cross(f);
    let z = -f;
    [[r.x, u.x, z.x, eye.x], [r.y, u.y, z.y, eye.y], [r.z, u.z, z.z, eye.z], [0.0, 0.0, 0.0, 1.0]]
}

/// Mean over seeds of each k×k block's mean of `w`×`h` per-seed images, with its
/// standard error (from the spread over seeds).
pub fn block_means(images: &[Vec<f64>], w: usize, h: usize, k: usize) -> Vec<(f64, f64)> {
    let mut out = Vec::new();
    for by in 0..h / k {
        for bx in 0..w / k {
            let per_seed: Vec<f64> = images
                .iter()
                .map(|img| {
                    let mut s = 0.0;
                    for y in by * k..(by + 1) * k {
                        for x in bx * k..(bx + 1) * k {
                            s += img[y * w + x];
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

/// Two sets of per-seed `w`×`h` images estimate the same image: every 6×6 block within 5
/// standard errors, the whole image within 4 (plus `total_rel` of it).
pub fn assert_same_image(a: &[Vec<f64>], b: &[Vec<f64>], w: usize, h: usize, total_rel: f64, what: &str) {
    let (ma, mb) = (block_means(a, w, h, 6), block_means(b, w, h, 6));
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
    assert!((ta - tb).abs() < 4.0 * (sa * sa + sb * sb).sqrt() + total_rel * tb, "{what}: image {ta} vs {tb}");
    eprintln!("{what}: worst block z {worst:.2}, image {ta:.4} vs {tb:.4}");
}

/// Luminance images of `scene` rendered with `settings(seed)` for each seed in
/// 0..`seeds`, each render checked free of non-finite samples.
pub fn luminance_renders(
    scene: &(SceneDesc, Vec<Buffer>),
    seeds: u64,
    settings: impl Fn(u64) -> ResolvedSettings,
) -> Vec<Vec<f64>> {
    (0..seeds)
        .map(|seed| {
            let r = render(&scene.0, &scene.1, &settings(seed), &RenderControl::new()).expect("render");
            assert_eq!(r.stats.nonfinite_samples, 0);
            r.images.rgba.chunks_exact(4).map(luminance).collect()
        })
        .collect()
}

/// [`luminance_renders`] of a `w`×`h` image in `direction` with `samples` per pixel,
/// `max_bounces` and 16 wavelengths.
pub fn direction_renders(
    scene: &(SceneDesc, Vec<Buffer>),
    (w, h): (usize, usize),
    seeds: u64,
    direction: polychrome_core::render::Direction,
    samples: u32,
    max_bounces: u32,
) -> Vec<Vec<f64>> {
    luminance_renders(scene, seeds, |seed| ResolvedSettings {
        width: w as u32,
        height: h as u32,
        samples,
        max_bounces,
        grid: polychrome_core::spectrum::WavelengthGrid::uniform(16, 380.0, 780.0).unwrap(),
        direction,
        seed,
        ..Default::default()
    })
}

/// Mean over pixels of the per-pixel variance over seeds.
pub fn mean_pixel_variance(images: &[Vec<f64>]) -> f64 {
    let n = images.len() as f64;
    let pixels = images[0].len();
    (0..pixels)
        .map(|i| {
            let m = images.iter().map(|img| img[i]).sum::<f64>() / n;
            images.iter().map(|img| (img[i] - m).powi(2)).sum::<f64>() / (n - 1.0)
        })
        .sum::<f64>()
        / pixels as f64
}
