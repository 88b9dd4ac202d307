//! Textures and HDRI environments (docs/design.md#rgb-data): deferred RGB → spectrum conversion checked
//! end to end against closed forms (round trip of an HDRI seen directly, furnace under
//! an image world, identical constant vs 1×1 texture, unbiased importance sampling).

mod common;

use common::*;
use polychrome_core::camera::CameraDesc;
use polychrome_core::material::texture::{srgb_decode, Filter, Texture, Wrap};
use polychrome_core::render::{render, RenderControl, RenderOutput, ResolvedSettings};
use polychrome_core::scene::{
    BsdfDesc, Buffer, LightDesc, MaterialDesc, SceneDesc, TextureDesc, TextureEncoding, WorldDesc,
};
use polychrome_core::spectrum::named::SpectrumKind;
use polychrome_core::spectrum::SpectrumDesc;
use std::f32::consts::PI;

/// Camera at the origin looking along `dir` (Blender convention: looks down its −Z).
fn camera_looking(dir: [f32; 3], focal_length: f32) -> CameraDesc {
    let f = glam::Vec3::from(dir).normalize();
    let right = f.cross(glam::Vec3::Z).normalize();
    let up = right.cross(f);
    let b = -f;
    CameraDesc {
        to_world: [
            [right.x, up.x, b.x, 0.0],
            [right.y, up.y, b.y, 0.0],
            [right.z, up.z, b.z, 0.0],
            [0.0, 0.0, 0.0, 1.0],
        ],
        focal_length,
        ..Default::default()
    }
}

fn world_texture(texture: usize, strength: f32, rotation: f32, importance_sampling: bool) -> WorldDesc {
    WorldDesc { radiance: None, texture: Some(texture), strength, rotation, importance_sampling, volume: None }
}

fn add_texture(desc: &mut SceneDesc, buffers: &mut Vec<Buffer>, name: &str, w: u32, h: u32, rgb: Vec<f32>) -> usize {
    buffers.push(Buffer::F32(rgb));
    desc.textures.push(TextureDesc {
        name: name.into(),
        width: w,
        height: h,
        channels: 3,
        buffer: buffers.len() - 1,
        encoding: TextureEncoding::Linear,
        wrap: Default::default(),
    });
    desc.textures.len() - 1
}

/// World direction at the centre of image coordinates (u, v), Blender's equirectangular
/// mapping in a Z-up world (u = 0.5 − atan2(y, x)/2π, v = 0.5 + elevation/π).
fn direction_of_uv(u: f32, v: f32) -> [f32; 3] {
    let phi = (0.5 - u) * 2.0 * PI;
    let el = (v - 0.5) * PI;
    [el.cos() * phi.cos(), el.cos() * phi.sin(), el.sin()]
}

fn mean_rgb(out: &RenderOutput) -> [f64; 3] {
    let n = (out.width * out.height) as f64;
    let mut m = [0.0; 3];
    for p in out.images.rgba.chunks_exact(4) {
        for c in 0..3 {
            m[c] += p[c] as f64 / n;
        }
    }
    m
}

/// A texel seen directly renders back to its own RGB (the unbounded uplift is exactly
/// reversible), including a texel of 1e6, and the Z rotation turns the lookup.
#[test]
fn hdri_seen_directly_returns_its_rgb() {
    // 32×16 image of 4×4-texel blocks (45° × 45° each); three distinctive blocks.
    let (w, h) = (32u32, 16u32);
    let blocks: [([f32; 3], (u32, u32)); 3] =
        [([1.0e6, 5.0e5, 2.0e5], (1, 1)), ([0.2, 0.5, 0.9], (5, 2)), ([3.0, 0.1, 0.02], (6, 0))];
    let mut rgb = vec![0.05f32; (w * h * 3) as usize];
    for (c, (bx, by)) in blocks {
        for y in by * 4..by * 4 + 4 {
            for x in bx * 4..bx * 4 + 4 {
                let k = 3 * (y * w + x) as usize;
                rgb[k..k + 3].copy_from_slice(&c);
            }
        }
    }
    for &rotation in &[0.0f32, 1.1] {
        for (c, (bx, by)) in blocks {
            let mut desc = SceneDesc::default();
            let mut buffers = Vec::new();
            let t = add_texture(&mut desc, &mut buffers, "sky", w, h, rgb.clone());
            desc.world = Some(world_texture(t, 1.0, rotation, true));
            // Block centre: u = (4bx + 2)/32, v = 1 − (4by + 2)/16.
            let d = direction_of_uv((4 * bx + 2) as f32 / w as f32, 1.0 - (4 * by + 2) as f32 / h as f32);
            // The lookup direction is Rz(rotation)·d: look along Rz(−rotation)·block.
            let (s, co) = (-rotation).sin_cos();
            let d = [co * d[0] - s * d[1], s * d[0] + co * d[1], d[2]];
            // Keep off the poles (the camera's up is +Z).
            desc.camera = camera_looking(d, 600.0);
            let settings = ResolvedSettings { width: 4, height: 4, samples: 2, max_bounces: 0, ..Default::default() };
            let out = render(&desc, &buffers, &settings, &RenderControl::new()).unwrap();
            for p in out.images.rgba.chunks_exact(4) {
                for k in 0..3 {
                    let rel = (p[k] as f64 - c[k] as f64).abs() / c[k] as f64;
                    assert!(rel < 1e-3, "rotation {rotation}, block {c:?}: pixel {p:?}");
                }
            }
            assert_eq!(out.stats.nonfinite_samples, 0);
        }
    }
}

fn white_sphere_scene(world: WorldDesc, textures: Option<(u32, u32, Vec<f32>)>) -> (SceneDesc, Vec<Buffer>) {
    let mut desc = SceneDesc::default();
    let mut buffers = Vec::new();
    desc.materials.push(MaterialDesc {
        name: "white".into(),
        bsdf: BsdfDesc::Diffuse { reflectance: SpectrumDesc::constant(1.0) },
        emission: None,
        volume: None,
        one_sided: false,
        see_through: false,
    });
    if let Some((w, h, rgb)) = textures {
        add_texture(&mut desc, &mut buffers, "env", w, h, rgb);
    }
    let (v, t) = uv_sphere([0.0, 0.0, -5.0], 1.0, 24, 48);
    add_mesh(&mut desc, &mut buffers, "sphere", v, t, 0);
    desc.world = Some(world);
    desc.camera = CameraDesc { focal_length: 120.0, ..Default::default() }; // the sphere fills the view
    (desc, buffers)
}

/// Environment furnace: an albedo-1 diffuse sphere under a uniform world is invisible —
/// every pixel sees the world's radiance — both for the uniform world and for a
/// constant HDRI (image path, importance sampled), within statistical tolerance.
#[test]
fn white_sphere_vanishes_under_a_uniform_world() {
    let c = [0.3f32, 0.6, 0.9];
    let cases = [
        white_sphere_scene(
            world_texture(0, 2.0, 0.4, true),
            Some((8, 4, c.repeat(32).iter().map(|v| v / 2.0).collect())),
        ),
        white_sphere_scene(world_texture(0, 1.0, 0.0, false), Some((8, 4, c.repeat(32)))),
        white_sphere_scene(
            WorldDesc {
                radiance: Some(SpectrumDesc::new(SpectrumKind::Rgb { rgb: c })),
                texture: None,
                strength: 1.0,
                rotation: 0.0,
                importance_sampling: true,
                volume: None,
            },
            None,
        ),
    ];
    for (k, (desc, buffers)) in cases.iter().enumerate() {
        let settings = ResolvedSettings { width: 12, height: 12, samples: 8, max_bounces: 64, ..Default::default() };
        let out = render(desc, buffers, &settings, &RenderControl::new()).unwrap();
        // Every pixel is an estimate of the same value: check the mean per channel
        // against the world's RGB with the pixels' own standard error.
        let n = (out.width * out.height) as f64;
        let m = mean_rgb(&out);
        for ch in 0..3 {
            let var = out.images.rgba.chunks_exact(4).map(|p| (p[ch] as f64 - m[ch]).powi(2)).sum::<f64>() / (n - 1.0);
            let se = (var / n).sqrt();
            assert!(
                (m[ch] - c[ch] as f64).abs() < 5.0 * se + 2e-4 * c[ch] as f64,
                "case {k} channel {ch}: {} vs {} (se {se})",
                m[ch],
                c[ch]
            );
        }
        assert_eq!(out.stats.nonfinite_samples, 0);
    }
}

/// A sun-like HDRI (one small region 10⁵× brighter than the sky) lighting a diffuse
/// plane: importance sampling has the same mean as uniform sampling and a far lower
/// variance at equal sample counts.
#[test]
fn importance_sampling_a_sun_reduces_variance_without_bias() {
    let (w, h) = (64u32, 32u32);
    let mut rgb = vec![0.02f32; (w * h * 3) as usize];
    // 2×2 texels around u = 0.3, elevation ≈ 50°.
    for y in 4..6 {
        for x in 19..21 {
            let k = 3 * (y * w + x) as usize;
            rgb[k..k + 3].copy_from_slice(&[2000.0, 1800.0, 1500.0]);
        }
    }
    let scene = |importance: bool| {
        let mut desc = SceneDesc::default();
        let mut buffers = Vec::new();
        desc.materials.push(MaterialDesc {
            name: "grey".into(),
            bsdf: BsdfDesc::Diffuse { reflectance: SpectrumDesc::constant(0.5) },
            emission: None,
            volume: None,
            one_sided: false,
            see_through: false,
        });
        let s = 50.0;
        add_mesh(
            &mut desc,
            &mut buffers,
            "ground",
            vec![-s, -s, 0.0, s, -s, 0.0, s, s, 0.0, -s, s, 0.0],
            vec![0, 1, 2, 0, 2, 3],
            0,
        );
        let t = add_texture(&mut desc, &mut buffers, "sun", w, h, rgb.clone());
        desc.world = Some(world_texture(t, 1.0, 0.0, importance));
        desc.camera = ortho_down(2.0);
        (desc, buffers)
    };
    let settings = ResolvedSettings { width: 24, height: 24, samples: 4, max_bounces: 1, ..Default::default() };
    let stats = |importance: bool| {
        let (desc, buffers) = scene(importance);
        let out = render(&desc, &buffers, &settings, &RenderControl::new()).unwrap();
        assert_eq!(out.stats.nonfinite_samples, 0);
        let ys: Vec<f64> = out.images.rgba.chunks_exact(4).map(luminance).collect();
        let n = ys.len() as f64;
        let mean = ys.iter().sum::<f64>() / n;
        let var = ys.iter().map(|y| (y - mean).powi(2)).sum::<f64>() / (n - 1.0);
        (mean, var, n)
    };
    let (m_is, v_is, n) = stats(true);
    let (_, v_u, _) = stats(false); // its mean is checked below at more samples
    assert!(v_is * 20.0 < v_u, "importance sampling variance {v_is} not far below uniform {v_u}");
    // Independent reference: direct light on the plane, E = ρ/π ∫ L cos θ dω, by
    // midpoint quadrature over the image's (bilinearly filtered) radiance.
    let tex = Texture::from_linear("sun", w, h, 3, &rgb, Wrap::Repeat).unwrap();
    let (qu, qv) = (1024usize, 512usize);
    let mut e = 0.0f64;
    for j in qv / 2..qv {
        let v = (j as f32 + 0.5) / qv as f32;
        let el = (v - 0.5) * PI;
        // dω = cos(el) dφ d(el) = 2π² cos(el) du dv; cos θ to the normal = sin(el).
        let jac = 2.0 * (PI as f64).powi(2) * (el.cos() * el.sin()) as f64 / (qu * qv) as f64;
        for i in 0..qu {
            let c = tex.lookup_with(
                glam::Vec2::new((i as f32 + 0.5) / qu as f32, v),
                Wrap::Repeat,
                Wrap::Extend,
                Filter::Bilinear,
            );
            e += luminance(&[c[0], c[1], c[2], 1.0]) * jac;
        }
    }
    let expected = 0.5 / PI as f64 * e;
    assert!(
        (m_is - expected).abs() < 5.0 * (v_is / n).sqrt() + 2e-3 * expected,
        "IS mean {m_is} vs closed form {expected}"
    );
    // Uniform sampling converges to the same value: more samples, since it is noisy.
    let (desc, buffers) = scene(false);
    let out = render(&desc, &buffers, &ResolvedSettings { samples: 256, ..settings }, &RenderControl::new()).unwrap();
    let (m_u, se_u) = mean_and_standard_error(&out.images.rgba);
    assert!(
        (m_u - expected).abs() < 5.0 * se_u + 2e-3 * expected,
        "uniform mean {m_u} (se {se_u}) vs closed form {expected}"
    );
}

/// The same colour as a constant RGB reflectance and as a 1×1 texture (linear floats or
/// sRGB bytes) goes through the same uplift code: identical images, bit for bit.
#[test]
fn constant_colour_and_one_texel_texture_render_identically() {
    let base = |reflectance: SpectrumDesc| {
        let mut desc = SceneDesc::default();
        let mut buffers = Vec::new();
        desc.materials.push(MaterialDesc {
            name: "paint".into(),
            bsdf: BsdfDesc::Diffuse { reflectance },
            emission: None,
            volume: None,
            one_sided: false,
            see_through: false,
        });
        let (v, t) = uv_sphere([0.0, 0.0, -4.0], 1.0, 12, 24);
        add_mesh(&mut desc, &mut buffers, "ball", v, t, 0);
        desc.lights.push(LightDesc::Point {
            name: "lamp".into(),
            position: [2.0, 2.0, 0.0],
            intensity: SpectrumDesc::constant(20.0),
            radius: 0.0,
            visibility: Default::default(),
            profile: None,
            motion: Vec::new(),
        });
        (desc, buffers)
    };
    let settings = ResolvedSettings { width: 16, height: 16, samples: 2, seed: 3, ..Default::default() };
    let rgb = [0.8f32, 0.3, 0.1];
    let (d0, b0) = base(SpectrumDesc::new(SpectrumKind::Rgb { rgb }));
    let constant = render(&d0, &b0, &settings, &RenderControl::new()).unwrap();
    let (mut d1, mut b1) = base(SpectrumDesc::new(SpectrumKind::Texture { texture: 0 }));
    add_texture(&mut d1, &mut b1, "one", 1, 1, rgb.to_vec());
    let textured = render(&d1, &b1, &settings, &RenderControl::new()).unwrap();
    assert!(constant.images.rgba.iter().any(|&v| v > 0.0));
    assert_eq!(constant.images.rgba, textured.images.rgba);

    // 8-bit sRGB bytes decode to the same linear value as the constant of that value.
    let bytes = [200u8, 90, 30];
    let (d2, b2) = base(SpectrumDesc::new(SpectrumKind::Rgb { rgb: bytes.map(srgb_decode) }));
    let constant = render(&d2, &b2, &settings, &RenderControl::new()).unwrap();
    let (mut d3, mut b3) = base(SpectrumDesc::new(SpectrumKind::Texture { texture: 0 }));
    b3.push(Buffer::U8(bytes.to_vec()));
    d3.textures.push(TextureDesc {
        name: "byte".into(),
        width: 1,
        height: 1,
        channels: 3,
        buffer: b3.len() - 1,
        encoding: TextureEncoding::Srgb,
        wrap: Default::default(),
    });
    let textured = render(&d3, &b3, &settings, &RenderControl::new()).unwrap();
    assert_eq!(constant.images.rgba, textured.images.rgba);
    assert_eq!(textured.stats.texture_bytes, 3);
}

#[test]
fn texture_errors_name_the_texture_or_material() {
    let mut desc = SceneDesc::default();
    let mut buffers = Vec::new();
    desc.materials.push(MaterialDesc {
        name: "Wood".into(),
        bsdf: BsdfDesc::Diffuse { reflectance: SpectrumDesc::new(SpectrumKind::Texture { texture: 2 }) },
        emission: None,
        volume: None,
        one_sided: false,
        see_through: false,
    });
    let err = render(&desc, &buffers, &ResolvedSettings::default(), &RenderControl::new()).err().unwrap().to_string();
    assert!(err.contains("material 'Wood'") && err.contains("texture 2"), "{err}");

    add_texture(&mut desc, &mut buffers, "Grain", 2, 1, vec![0.1, 0.2, f32::INFINITY, 0.0, 0.0, 0.0]);
    let err = render(&desc, &buffers, &ResolvedSettings::default(), &RenderControl::new()).err().unwrap().to_string();
    assert!(err.contains("texture 'Grain'") && err.contains("non-finite"), "{err}");

    let mut desc = SceneDesc::default();
    buffers.clear();
    buffers.push(Buffer::U32(vec![0, 0, 0]));
    desc.textures.push(TextureDesc {
        name: "Sky".into(),
        width: 1,
        height: 1,
        channels: 3,
        buffer: 0,
        encoding: TextureEncoding::Linear,
        wrap: Default::default(),
    });
    let err = render(&desc, &buffers, &ResolvedSettings::default(), &RenderControl::new()).err().unwrap().to_string();
    assert!(err.contains("texture 'Sky'") && err.contains("float32"), "{err}");

    // A texture where only spectra make sense (a light's intensity) is refused by name.
    let mut desc = SceneDesc::default();
    desc.lights.push(LightDesc::Point {
        name: "Lamp".into(),
        position: [0.0; 3],
        intensity: SpectrumDesc::new(SpectrumKind::Texture { texture: 0 }),
        radius: 0.0,
        visibility: Default::default(),
        profile: None,
        motion: Vec::new(),
    });
    let err =
        render(&desc, &[] as &[Buffer], &ResolvedSettings::default(), &RenderControl::new()).err().unwrap().to_string();
    assert!(err.contains("light 'Lamp'") && err.contains("texture"), "{err}");
}

/// An HDRI texel of 1e6 next to black sky: no NaN or infinity anywhere, and the JSON
/// description parses with defaults (strength 1, rotation 0, importance sampling on).
#[test]
fn extreme_hdri_is_finite_and_description_parses() {
    let json = r#"{"world": {"texture": 0}, "textures": [{"name": "hot", "width": 4, "height": 2, "buffer": 0, "wrap": "EXTEND"}]}"#;
    let desc: SceneDesc = serde_json::from_str(json).unwrap();
    let w = desc.world.as_ref().unwrap();
    assert!(w.strength == 1.0 && w.rotation == 0.0 && w.importance_sampling && w.radiance.is_none());
    let mut rgb = vec![0.0f32; 24];
    rgb[3..6].copy_from_slice(&[1e6, 1e6, 1e6]);
    let mut desc = desc;
    let mut buffers = vec![Buffer::F32(rgb)];
    let (v, t) = uv_sphere([0.0, 0.0, -4.0], 1.0, 12, 24);
    desc.materials.push(MaterialDesc {
        name: "grey".into(),
        bsdf: BsdfDesc::Diffuse { reflectance: SpectrumDesc::constant(0.5) },
        emission: None,
        volume: None,
        one_sided: false,
        see_through: false,
    });
    add_mesh(&mut desc, &mut buffers, "ball", v, t, 0);
    let settings = ResolvedSettings { width: 8, height: 8, samples: 4, ..Default::default() };
    let out = render(&desc, &buffers, &settings, &RenderControl::new()).unwrap();
    assert_eq!(out.stats.nonfinite_samples, 0);
    assert!(out.images.rgba.iter().all(|v| v.is_finite()));
    assert!(out.images.rgba.chunks_exact(4).any(|p| p[0] > 0.0));
}
