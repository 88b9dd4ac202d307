//! Scene-building helpers shared by the core's integration tests.
#![allow(dead_code)]

use polychrome_core::scene::{Buffer, MeshDesc, SceneDesc, WorldDesc};
use polychrome_core::spectrum::SpectrumDesc;

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
