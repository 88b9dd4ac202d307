//! Homogeneous participating media (docs/media.md) against closed forms and against
//! each other: Beer–Lambert per wavelength through slabs (nested, and behind a
//! refractive boundary), a white furnace with scattering albedo 1 and chromatic
//! extinction, the two distance-sampling options against a monochromatic reference, and
//! extreme or invalid coefficients.

mod common;

use common::*;
use polychrome_core::material::IorDesc;
use polychrome_core::render::{render, Direction, MediumSampling, Method, RenderControl, ResolvedSettings};
use polychrome_core::scene::{BsdfDesc, Buffer, DensityGridDesc, InstanceDesc, MaterialDesc, SceneDesc, VolumeDesc};
use polychrome_core::spectrum::named::{NoRgb, SpectrumKind, SpectrumRole};
use polychrome_core::spectrum::{SpectrumDesc, WavelengthGrid};

/// A tabulated spectrum through (λ, value) pairs, times `scale`.
fn tabulated(pairs: &[(f32, f32)], scale: f32) -> SpectrumDesc {
    SpectrumDesc {
        kind: SpectrumKind::Tabulated {
            wavelengths: pairs.iter().map(|p| p.0).collect(),
            values: pairs.iter().map(|p| p.1).collect(),
        },
        scale,
    }
}

fn material(name: &str, bsdf: BsdfDesc, volume: Option<VolumeDesc>) -> MaterialDesc {
    MaterialDesc { name: name.into(), bsdf, emission: None, volume, one_sided: false, see_through: false }
}

fn absorbing(sigma_a: SpectrumDesc) -> VolumeDesc {
    VolumeDesc { absorption: Some(sigma_a), ..Default::default() }
}

/// An axis-aligned box with outward-facing triangles.
fn cuboid(lo: [f32; 3], hi: [f32; 3]) -> (Vec<f32>, Vec<u32>) {
    let mut v = Vec::new();
    for k in 0..8 {
        v.extend_from_slice(&[
            if k & 1 == 0 { lo[0] } else { hi[0] },
            if k & 2 == 0 { lo[1] } else { hi[1] },
            if k & 4 == 0 { lo[2] } else { hi[2] },
        ]);
    }
    // Faces wound counter-clockwise seen from outside.
    let t = vec![
        0, 2, 3, 0, 3, 1, // z = lo
        4, 5, 7, 4, 7, 6, // z = hi
        0, 1, 5, 0, 5, 4, // y = lo
        2, 6, 7, 2, 7, 3, // y = hi
        0, 4, 6, 0, 6, 2, // x = lo
        1, 3, 7, 1, 7, 5, // x = hi
    ];
    (v, t)
}

/// Camera at y = −`distance` looking along +y with a narrow field of view.
fn camera_along_y(desc: &mut SceneDesc, distance: f32, focal_length: f32) {
    desc.camera.to_world =
        [[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, -1.0, -distance], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]];
    desc.camera.focal_length = focal_length;
}

const SIGMA_A: [(f32, f32); 4] = [(380.0, 2.0), (500.0, 0.1), (600.0, 0.8), (780.0, 1.5)];
const SIGMA_B: [(f32, f32); 3] = [(380.0, 0.2), (550.0, 1.2), (780.0, 0.3)];

/// A large emitter at y = 3 behind a slab y ∈ [−0.5, 0.5] of `outer` with, inside it,
/// y ∈ [−0.25, 0.25] of `inner` (nested media add up, as Cycles' volume stack).
fn slab_scene(outer: MaterialDesc, inner: Option<MaterialDesc>) -> (SceneDesc, Vec<Buffer>) {
    let mut desc = SceneDesc::default();
    let mut buffers = Vec::new();
    desc.materials.push(MaterialDesc {
        name: "emitter".into(),
        bsdf: BsdfDesc::None,
        emission: Some(tabulated(&[(380.0, 0.5), (780.0, 2.0)], 1.0)),
        volume: None,
        one_sided: false,
        see_through: false,
    });
    desc.materials.push(outer);
    let (v, t) = cuboid([-50.0, 3.0, -50.0], [50.0, 3.1, 50.0]);
    add_mesh(&mut desc, &mut buffers, "emitter", v, t, 0);
    let (v, t) = cuboid([-5.0, -0.5, -5.0], [5.0, 0.5, 5.0]);
    add_mesh(&mut desc, &mut buffers, "slab", v, t, 1);
    if let Some(inner) = inner {
        desc.materials.push(inner);
        let (v, t) = cuboid([-4.0, -0.25, -4.0], [4.0, 0.25, 4.0]);
        add_mesh(&mut desc, &mut buffers, "inner", v, t, 2);
    }
    camera_along_y(&mut desc, 4.0, 2000.0);
    (desc, buffers)
}

fn settings(n: usize, samples: u32) -> ResolvedSettings {
    ResolvedSettings {
        width: 6,
        height: 6,
        samples,
        max_bounces: 16,
        grid: WavelengthGrid::uniform(n, 380.0, 780.0).unwrap(),
        spectral_output: true,
        ..Default::default()
    }
}

/// The mean spectrum over all pixels, per wavelength, with its standard error.
fn mean_spectrum(spectral: &[f32], n: usize) -> Vec<(f64, f64)> {
    let px = spectral.len() / n;
    (0..n)
        .map(|i| {
            let v: Vec<f64> = (0..px).map(|p| spectral[p * n + i] as f64).collect();
            let m = v.iter().sum::<f64>() / px as f64;
            let var = v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (px as f64 - 1.0).max(1.0);
            (m, (var / px as f64).sqrt())
        })
        .collect()
}

fn lerp_table(pairs: &[(f32, f32)], l: f32) -> f64 {
    let k = pairs.windows(2).position(|w| l <= w[1].0).unwrap_or(pairs.len() - 2);
    let (a, b) = (pairs[k], pairs[k + 1]);
    (a.1 + (b.1 - a.1) * (l - a.0) / (b.0 - a.0)) as f64
}

/// Beer–Lambert, exactly per wavelength: a slab of thickness 1 with no surface, and a
/// nested slab inside it whose coefficients add over its thickness 0.5.
#[test]
fn beer_lambert_through_slabs_per_wavelength() {
    let n = 17;
    let grid = WavelengthGrid::uniform(n, 380.0, 780.0).unwrap();
    let outer = material("ink", BsdfDesc::Null, Some(absorbing(tabulated(&SIGMA_A, 1.0))));
    let inner = material("dye", BsdfDesc::Null, Some(absorbing(tabulated(&SIGMA_B, 1.0))));
    for nested in [false, true] {
        let (desc, buffers) = slab_scene(outer.clone(), nested.then(|| inner.clone()));
        let s = settings(n, 2);
        // Reference spectra through the engine's own resampling of the tables (which
        // integrates over each sample's cell): an emitter alone, and the coefficients.
        let out = render(&desc, &buffers, &s, &RenderControl::new()).unwrap();
        let got = mean_spectrum(out.images.spectral.as_ref().unwrap(), n);
        let sa = tabulated(&SIGMA_A, 1.0).evaluate(&grid, SpectrumRole::Reflectance, &NoRgb).unwrap();
        let sb = tabulated(&SIGMA_B, 1.0).evaluate(&grid, SpectrumRole::Reflectance, &NoRgb).unwrap();
        let le =
            tabulated(&[(380.0, 0.5), (780.0, 2.0)], 1.0).evaluate(&grid, SpectrumRole::Illuminant, &NoRgb).unwrap();
        for i in 0..n {
            let tau = sa[i] as f64 + if nested { 0.5 * sb[i] as f64 } else { 0.0 };
            let expected = le[i] as f64 * (-tau).exp();
            // The narrow view's rays are within 0.7° of the axis (path length +0.01 %).
            assert!(
                (got[i].0 - expected).abs() < 1e-3 * expected,
                "nested {nested}, λ {}: {} vs Beer–Lambert {expected}",
                grid.lambdas()[i],
                got[i].0
            );
        }
        // The closed form is also the tables' own values at the samples to within the
        // cell integration (a sanity check of the reference itself).
        let mid = n / 2;
        assert!((sa[mid] as f64 - lerp_table(&SIGMA_A, grid.lambdas()[mid])).abs() < 0.05);
        assert_eq!(out.stats.nonfinite_samples, 0);
    }
}

/// Absorbing glass: behind a refractive boundary (index 1.5) the medium attenuates, and
/// internal reflections add up to (1−R)²·e^{−τ}/(1 − R²·e^{−2τ}) at normal incidence.
#[test]
fn beer_lambert_behind_a_refractive_boundary() {
    let n = 9;
    let glass = material(
        "tinted glass",
        BsdfDesc::Dielectric { ior: IorDesc::Constant { ior: 1.5 }, roughness: 0.0 },
        Some(absorbing(tabulated(&SIGMA_A, 1.0))),
    );
    let (desc, buffers) = slab_scene(glass, None);
    let out = render(&desc, &buffers, &settings(n, 256), &RenderControl::new()).unwrap();
    let got = mean_spectrum(out.images.spectral.as_ref().unwrap(), n);
    let grid = WavelengthGrid::uniform(n, 380.0, 780.0).unwrap();
    let sa = tabulated(&SIGMA_A, 1.0).evaluate(&grid, SpectrumRole::Reflectance, &NoRgb).unwrap();
    let le = tabulated(&[(380.0, 0.5), (780.0, 2.0)], 1.0).evaluate(&grid, SpectrumRole::Illuminant, &NoRgb).unwrap();
    let r = 0.04f64; // ((1.5 − 1)/(1.5 + 1))²
    for i in 0..n {
        let t = (-(sa[i] as f64)).exp();
        let expected = le[i] as f64 * (1.0 - r).powi(2) * t / (1.0 - r * r * t * t);
        let (m, se) = got[i];
        assert!((m - expected).abs() < 5.0 * se + 2e-3 * expected, "λ {}: {m} ± {se} vs {expected}", grid.lambdas()[i]);
    }
}

/// A sphere of scattering medium (albedo 1 at every wavelength, extinction varying
/// 8× over the spectrum, forward scattering) inside a uniform world: every pixel sees
/// exactly the world's radiance, for both distance-sampling options and every method.
#[test]
fn white_furnace_with_albedo_one() {
    let n = 21;
    let mut desc = SceneDesc::default();
    let mut buffers = Vec::new();
    let volume = VolumeDesc {
        scattering: Some(tabulated(&[(380.0, 4.0), (550.0, 0.5), (780.0, 2.0)], 1.0)),
        anisotropy: 0.4,
        ..Default::default()
    };
    desc.materials.push(material("fog", BsdfDesc::Null, Some(volume)));
    let (v, t) = uv_sphere([0.0; 3], 1.0, 24, 48);
    add_mesh(&mut desc, &mut buffers, "sphere", v, t, 0);
    desc.world = Some(uniform_world(&tabulated(&[(380.0, 0.7), (780.0, 1.3)], 1.0)));
    camera_along_y(&mut desc, 4.0, 50.0);
    let base = ResolvedSettings { max_bounces: 256, spectral_output: false, ..settings(n, 16) };
    let base = ResolvedSettings { width: 12, height: 12, ..base };
    // The world alone (no medium: the sphere is a null surface) is the closed form.
    let mut empty = desc.clone();
    empty.materials[0].volume = None;
    let reference = render(&empty, &buffers, &base, &RenderControl::new()).unwrap();
    let world_rgb: [f64; 3] = std::array::from_fn(|c| reference.images.rgba[c] as f64);
    for (method, sampling) in [
        (Method::Polychromatic, MediumSampling::SpectralMis),
        (Method::Polychromatic, MediumSampling::Collapse),
        (Method::Hero, MediumSampling::SpectralMis),
        (Method::MonochromaticRays, MediumSampling::SpectralMis),
    ] {
        let s = ResolvedSettings { method, medium_sampling: sampling, ..base.clone() };
        let out = render(&desc, &buffers, &s, &RenderControl::new()).unwrap();
        assert_eq!(out.stats.nonfinite_samples, 0);
        for c in 0..3 {
            let v: Vec<f64> = out.images.rgba.chunks_exact(4).map(|p| p[c] as f64).collect();
            let m = v.iter().sum::<f64>() / v.len() as f64;
            let se = (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (v.len() as f64 - 1.0) / v.len() as f64).sqrt();
            assert!(
                (m - world_rgb[c]).abs() < 5.0 * se + 2e-3 * world_rgb[c],
                "{method:?} {sampling:?} channel {c}: {m} ± {se} vs world {}",
                world_rgb[c]
            );
        }
    } // Not vacuous: the same sphere with some absorption is visibly darker.
    let mut grey = desc.clone();
    grey.materials[0].volume.as_mut().unwrap().absorption = Some(SpectrumDesc::constant(0.3));
    let out = render(&grey, &buffers, &base, &RenderControl::new()).unwrap();
    let lum = |rgba: &[f32]| rgba.chunks_exact(4).map(luminance).sum::<f64>();
    assert!(lum(&out.images.rgba) < 0.9 * lum(&reference.images.rgba));
}

/// A chromatic fog cube (absorbing and scattering, both depending on wavelength) on a
/// diffuse floor under an area lamp: spectral MIS and collapse agree with each other and
/// with monochromatic rays (a plain single-wavelength tracer, no spectral weighting).
#[test]
fn distance_sampling_options_agree_with_a_monochromatic_reference() {
    let n = 11;
    let mut desc = SceneDesc::default();
    let mut buffers = Vec::new();
    desc.materials.push(material("floor", BsdfDesc::Diffuse { reflectance: SpectrumDesc::constant(0.7) }, None));
    desc.materials.push(MaterialDesc {
        name: "lamp".into(),
        bsdf: BsdfDesc::None,
        emission: Some(SpectrumDesc::constant(3.0)),
        volume: None,
        one_sided: false,
        see_through: false,
    });
    let volume = VolumeDesc {
        absorption: Some(tabulated(&SIGMA_B, 0.5)),
        scattering: Some(tabulated(&SIGMA_A, 3.0)),
        anisotropy: 0.3,
        emission: None,
        density_grid: None,
    };
    desc.materials.push(material("fog", BsdfDesc::Null, Some(volume)));
    let (v, t) = cuboid([-3.0, -3.0, -1.05], [3.0, 3.0, -1.0]);
    add_mesh(&mut desc, &mut buffers, "floor", v, t, 0);
    let (v, t) = cuboid([-1.0, -1.0, 3.0], [1.0, 1.0, 3.05]);
    add_mesh(&mut desc, &mut buffers, "lamp", v, t, 1);
    let (v, t) = cuboid([-0.7, -0.7, -1.0], [0.7, 0.7, 0.4]);
    add_mesh(&mut desc, &mut buffers, "fog", v, t, 2);
    camera_along_y(&mut desc, 4.0, 50.0);
    let (w, h) = (12usize, 12usize);
    let base = ResolvedSettings {
        width: w as u32,
        height: h as u32,
        max_bounces: 12,
        grid: WavelengthGrid::uniform(n, 380.0, 780.0).unwrap(),
        ..Default::default()
    };
    // Per 6×6 block and channel: the mean of the per-pixel differences of two images and
    // its standard error (the scene's structure cancels, only noise remains).
    let compare = |a: &[f32], b: &[f32]| -> Vec<(f64, f64, f64)> {
        let mut out = Vec::new();
        for q in 0..4 {
            let (qx, qy) = (q % 2, q / 2);
            for c in 0..3 {
                let (mut d, mut level) = (Vec::new(), 0.0);
                for y in qy * h / 2..(qy + 1) * h / 2 {
                    for x in qx * w / 2..(qx + 1) * w / 2 {
                        let i = (y * w + x) * 4 + c;
                        d.push(a[i] as f64 - b[i] as f64);
                        level += b[i] as f64;
                    }
                }
                let k = d.len() as f64;
                let m = d.iter().sum::<f64>() / k;
                let var = d.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (k - 1.0);
                out.push((m, (var / k).sqrt(), level / k));
            }
        }
        out
    };
    let run = |desc: &SceneDesc, method, sampling, samples| {
        let s = ResolvedSettings { method, medium_sampling: sampling, samples, ..base.clone() };
        let out = render(desc, &buffers, &s, &RenderControl::new()).unwrap();
        assert_eq!(out.stats.nonfinite_samples, 0);
        out.images.rgba
    };
    let reference = run(&desc, Method::MonochromaticRays, MediumSampling::SpectralMis, 2048);
    // Not vacuous: without the fog the image differs by far more than the noise.
    let mut clear = desc.clone();
    clear.materials[2].volume = None;
    let clear = run(&clear, Method::Polychromatic, MediumSampling::SpectralMis, 64);
    assert!(compare(&clear, &reference).iter().any(|&(d, _, level)| d.abs() > 0.3 * level));
    for (method, sampling, samples) in [
        (Method::Polychromatic, MediumSampling::SpectralMis, 256),
        (Method::Polychromatic, MediumSampling::Collapse, 1024),
        (Method::Hero, MediumSampling::SpectralMis, 1024),
    ] {
        let got = run(&desc, method, sampling, samples);
        for (k, &(d, se, level)) in compare(&got, &reference).iter().enumerate() {
            assert!(
                d.abs() < 5.0 * se + 1e-3 * level,
                "{method:?} {sampling:?} block value {k}: off by {d} (se {se}, level {level})"
            );
        }
    }
}

/// Density 0 is no medium, 1e30 a black body of absorption or an opaque cloud, with no
/// NaN; a NaN density is an error naming the material; media need BACKWARD.
#[test]
fn extreme_and_invalid_densities() {
    let with = |scale: f32, scattering: bool| {
        let sigma = SpectrumDesc { kind: SpectrumKind::Rgb { rgb: [0.9, 0.5, 0.1] }, scale };
        let volume = if scattering {
            VolumeDesc { scattering: Some(sigma), anisotropy: -0.5, ..Default::default() }
        } else {
            absorbing(sigma)
        };
        slab_scene(material("syrup", BsdfDesc::Null, Some(volume)), None)
    };
    let s = ResolvedSettings { spectral_output: false, ..settings(16, 4) };
    let clear = render(
        &slab_scene(material("air", BsdfDesc::Null, None), None).0,
        &with(0.0, false).1,
        &s,
        &RenderControl::new(),
    )
    .unwrap();
    for scattering in [false, true] {
        let (desc, buffers) = with(0.0, scattering);
        let out = render(&desc, &buffers, &s, &RenderControl::new()).unwrap();
        assert_eq!(out.images.rgba, clear.images.rgba, "density 0 is no medium");
        let (desc, buffers) = with(1e30, scattering);
        let out = render(&desc, &buffers, &s, &RenderControl::new()).unwrap();
        assert_eq!(out.stats.nonfinite_samples, 0);
        assert!(out.images.rgba.iter().all(|v| v.is_finite()));
        // Nothing gets through 1e30 per unit length; scattering at that density comes
        // back out of the front face only.
        let lum = out.images.rgba.chunks_exact(4).map(luminance).sum::<f64>();
        assert!(lum < 1e-6 * clear.images.rgba.chunks_exact(4).map(luminance).sum::<f64>() || scattering);
        let (desc, buffers) = with(f32::NAN, scattering);
        let err =
            render(&desc, &buffers, &s, &RenderControl::new()).err().expect("a NaN density is an error").to_string();
        assert!(err.contains("syrup") && err.contains("volume"), "{err}");
    }
    let (desc, buffers) = with(1.0, false);
    let forward = ResolvedSettings { direction: Direction::Forward, ..s };
    let err =
        render(&desc, &buffers, &forward, &RenderControl::new()).err().expect("FORWARD refuses media").to_string();
    assert!(err.contains("BACKWARD") && err.contains("syrup"), "{err}");
}

/// The slab scene's emitter spectrum, the camera's distance to it (y = −4 → 3) and a
/// table's coefficients on `grid`.
fn on_grid(pairs: &[(f32, f32)], grid: &WavelengthGrid, role: SpectrumRole) -> Vec<f32> {
    tabulated(pairs, 1.0).evaluate(grid, role, &NoRgb).unwrap()
}

/// A camera inside media (Cycles' `integrator_volume_stack_init`): inside an absorbing
/// box y ∈ [−5, 0.8] (4.8 of it towards the emitter), inside the world's absorbing
/// medium (all 7 units to the emitter), and inside both, Beer–Lambert per wavelength.
#[test]
fn camera_inside_media_beer_lambert() {
    let n = 13;
    let grid = WavelengthGrid::uniform(n, 380.0, 780.0).unwrap();
    let le = on_grid(&[(380.0, 0.5), (780.0, 2.0)], &grid, SpectrumRole::Illuminant);
    let sa = on_grid(&SIGMA_A, &grid, SpectrumRole::Reflectance);
    let sb = on_grid(&SIGMA_B, &grid, SpectrumRole::Reflectance);
    for (in_box, in_world) in [(true, false), (false, true), (true, true)] {
        let (mut desc, mut buffers) = slab_scene(material("air", BsdfDesc::Null, None), None);
        if in_box {
            desc.materials.push(material("fog box", BsdfDesc::Null, Some(absorbing(tabulated(&SIGMA_A, 0.5)))));
            let (v, t) = cuboid([-5.0, -5.0, -5.0], [5.0, 0.8, 5.0]);
            let m = desc.materials.len() as u32 - 1;
            add_mesh(&mut desc, &mut buffers, "box", v, t, m);
        }
        if in_world {
            let mut w = uniform_world(&SpectrumDesc::constant(0.0));
            w.volume = Some(absorbing(tabulated(&SIGMA_B, 0.1)));
            desc.world = Some(w);
        }
        let out = render(&desc, &buffers, &settings(n, 2), &RenderControl::new()).unwrap();
        let got = mean_spectrum(out.images.spectral.as_ref().unwrap(), n);
        for i in 0..n {
            let tau = if in_box { 0.5 * sa[i] as f64 * 4.8 } else { 0.0 }
                + if in_world { 0.1 * sb[i] as f64 * 7.0 } else { 0.0 };
            let expected = le[i] as f64 * (-tau).exp();
            assert!(
                (got[i].0 - expected).abs() < 1e-3 * expected,
                "box {in_box}, world {in_world}, λ {}: {} vs Beer–Lambert {expected}",
                grid.lambdas()[i],
                got[i].0
            );
        }
        assert_eq!(out.stats.nonfinite_samples, 0);
    }
}

/// An emissive absorbing slab (thickness 1) in front of nothing: L = Le/σa·(1 − e^{−σa d})
/// per wavelength; and an emissive absorbing world seen to the emitter 7 away, adding its
/// own glow to the attenuated emitter.
#[test]
fn volume_emission_closed_form() {
    let n = 13;
    let grid = WavelengthGrid::uniform(n, 380.0, 780.0).unwrap();
    let le = on_grid(&[(380.0, 0.5), (780.0, 2.0)], &grid, SpectrumRole::Illuminant);
    let sa = on_grid(&SIGMA_A, &grid, SpectrumRole::Reflectance);
    const GLOW: [(f32, f32); 2] = [(380.0, 1.0), (780.0, 0.2)];
    let ge = on_grid(&GLOW, &grid, SpectrumRole::Illuminant);
    let glowing = VolumeDesc { emission: Some(tabulated(&GLOW, 1.0)), ..absorbing(tabulated(&SIGMA_A, 1.0)) };
    for in_world in [false, true] {
        let (mut desc, buffers) = if in_world {
            let (mut desc, buffers) = slab_scene(material("air", BsdfDesc::Null, None), None);
            let mut w = uniform_world(&SpectrumDesc::constant(0.0));
            w.volume = Some(VolumeDesc { absorption: Some(tabulated(&SIGMA_A, 0.2)), ..glowing.clone() });
            desc.world = Some(w);
            (desc, buffers)
        } else {
            slab_scene(material("glow", BsdfDesc::Null, Some(glowing.clone())), None)
        };
        if !in_world {
            desc.materials[0].emission = None; // nothing behind the slab
        }
        let out = render(&desc, &buffers, &settings(n, 2), &RenderControl::new()).unwrap();
        let got = mean_spectrum(out.images.spectral.as_ref().unwrap(), n);
        for i in 0..n {
            let (s, d) = if in_world { (0.2 * sa[i] as f64, 7.0) } else { (sa[i] as f64, 1.0) };
            let t = (-s * d).exp();
            let expected = ge[i] as f64 / s * (1.0 - t) + if in_world { le[i] as f64 * t } else { 0.0 };
            assert!(
                (got[i].0 - expected).abs() < 1e-3 * expected,
                "world {in_world}, λ {}: {} vs Le/σa·(1 − e^(−σa d)) {expected}",
                grid.lambdas()[i],
                got[i].0
            );
        }
    }
}

/// A NaN or negative world volume is an error naming the world.
#[test]
fn invalid_world_volume_is_an_error() {
    for scale in [f32::NAN, -1.0, f32::INFINITY] {
        let (mut desc, buffers) = slab_scene(material("air", BsdfDesc::Null, None), None);
        let mut w = uniform_world(&SpectrumDesc::constant(0.0));
        w.volume = Some(absorbing(SpectrumDesc { kind: SpectrumKind::Constant { value: 1.0 }, scale }));
        desc.world = Some(w);
        let err = render(&desc, &buffers, &settings(5, 1), &RenderControl::new()).err().expect("an error").to_string();
        assert!(err.contains("World") && err.contains("volume absorption"), "{err}");
    }
}

/// A density grid of `dims` over the object-space box lo..hi with voxel values `f(i, j, k)`.
fn density_grid(dims: [u32; 3], lo: [f32; 3], hi: [f32; 3], f: impl Fn(u32, u32, u32) -> f32) -> DensityGridDesc {
    let mut values = Vec::new();
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                values.push(f(i, j, k));
            }
        }
    }
    DensityGridDesc { dims, values, bounds: [lo, hi] }
}

/// Grid media (medium::grid) in a render: the slab of `slab_scene` as an absorbing
/// grid whose density ramps along the view, ρ(y) = k·(y + 0.5) (voxel centres on the
/// line), seen through an instance that moves the slab by +1 in y (the grid is in the
/// mesh's object space): Beer–Lambert of ∫ρ = k/2 per wavelength, by ratio tracking;
/// the same on hero and single-wavelength paths.
#[test]
fn grid_ramp_beer_lambert_through_an_instance() {
    let n = 9;
    let k = 1.6f32;
    let ny = 8u32;
    let grid_desc =
        density_grid([2, ny, 2], [-5.0, -0.5, -5.0], [5.0, 0.5, 5.0], |_, j, _| k * (j as f32 + 0.5) / ny as f32);
    let volume = VolumeDesc { density_grid: Some(grid_desc), ..absorbing(tabulated(&SIGMA_A, 1.0)) };
    let (mut desc, buffers) = slab_scene(material("smoke", BsdfDesc::Null, Some(volume)), None);
    let identity = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]];
    let mut moved = identity;
    moved[1][3] = 1.0;
    desc.instances = Some(vec![
        InstanceDesc { name: "emitter".into(), mesh: 0, transform: identity, ..Default::default() },
        InstanceDesc { name: "slab".into(), mesh: 1, transform: moved, ..Default::default() },
    ]);
    let grid = WavelengthGrid::uniform(n, 380.0, 780.0).unwrap();
    let sa = tabulated(&SIGMA_A, 1.0).evaluate(&grid, SpectrumRole::Reflectance, &NoRgb).unwrap();
    let le = tabulated(&[(380.0, 0.5), (780.0, 2.0)], 1.0).evaluate(&grid, SpectrumRole::Illuminant, &NoRgb).unwrap();
    for method in [Method::Polychromatic, Method::Hero, Method::MonochromaticRays] {
        let s = ResolvedSettings { method, ..settings(n, 256) };
        let out = render(&desc, &buffers, &s, &RenderControl::new()).unwrap();
        assert_eq!(out.stats.nonfinite_samples, 0);
        let got = mean_spectrum(out.images.spectral.as_ref().unwrap(), n);
        for i in 0..n {
            let expected = le[i] as f64 * (-(sa[i] as f64) * k as f64 / 2.0).exp();
            let (m, se) = got[i];
            eprintln!("{method:?} λ {}: {m:.5} ± {se:.5} vs {expected:.5}", grid.lambdas()[i]);
            assert!(
                (m - expected).abs() < 4.0 * se + 2e-3 * expected,
                "{method:?} λ {}: {m} ± {se} vs Beer–Lambert {expected}",
                grid.lambdas()[i]
            );
        }
    }
}

/// A cube of heterogeneous scattering medium (albedo 1 at every wavelength, extinction
/// varying 8× over the spectrum, density varying 0..3 voxel to voxel) inside a uniform
/// world: every pixel sees exactly the world's radiance — delta tracking, the phase
/// functions at the grid's density and ratio-tracked connections together — for both
/// distance-sampling settings (grids never collapse) and every method.
#[test]
fn grid_white_furnace_with_albedo_one() {
    let n = 21;
    let mut desc = SceneDesc::default();
    let mut buffers = Vec::new();
    let grid_desc = density_grid([12, 12, 12], [-1.0; 3], [1.0; 3], |i, j, k| {
        let h = (i.wrapping_mul(73_856_093) ^ j.wrapping_mul(19_349_663) ^ k.wrapping_mul(83_492_791)) % 1000;
        3.0 * (h as f32 / 1000.0).powi(2)
    });
    let volume = VolumeDesc {
        scattering: Some(tabulated(&[(380.0, 4.0), (550.0, 0.5), (780.0, 2.0)], 1.0)),
        anisotropy: 0.4,
        density_grid: Some(grid_desc),
        ..Default::default()
    };
    desc.materials.push(material("smoke", BsdfDesc::Null, Some(volume)));
    let (v, t) = cuboid([-1.0; 3], [1.0; 3]);
    add_mesh(&mut desc, &mut buffers, "cube", v, t, 0);
    desc.world = Some(uniform_world(&tabulated(&[(380.0, 0.7), (780.0, 1.3)], 1.0)));
    camera_along_y(&mut desc, 4.0, 50.0);
    let base = ResolvedSettings { max_bounces: 256, spectral_output: false, ..settings(n, 16) };
    let base = ResolvedSettings { width: 12, height: 12, ..base };
    let mut empty = desc.clone();
    empty.materials[0].volume = None;
    let reference = render(&empty, &buffers, &base, &RenderControl::new()).unwrap();
    let world_rgb: [f64; 3] = std::array::from_fn(|c| reference.images.rgba[c] as f64);
    for (method, sampling) in [
        (Method::Polychromatic, MediumSampling::SpectralMis),
        (Method::Polychromatic, MediumSampling::Collapse),
        (Method::Hero, MediumSampling::SpectralMis),
        (Method::MonochromaticRays, MediumSampling::SpectralMis),
    ] {
        let s = ResolvedSettings { method, medium_sampling: sampling, ..base.clone() };
        let out = render(&desc, &buffers, &s, &RenderControl::new()).unwrap();
        assert_eq!(out.stats.nonfinite_samples, 0);
        for c in 0..3 {
            let v: Vec<f64> = out.images.rgba.chunks_exact(4).map(|p| p[c] as f64).collect();
            let m = v.iter().sum::<f64>() / v.len() as f64;
            let se = (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (v.len() as f64 - 1.0) / v.len() as f64).sqrt();
            eprintln!("{method:?} {sampling:?} channel {c}: {m:.4} ± {se:.4} vs {:.4}", world_rgb[c]);
            assert!(
                (m - world_rgb[c]).abs() < 5.0 * se + 2e-3 * world_rgb[c],
                "{method:?} {sampling:?} channel {c}: {m} ± {se} vs world {}",
                world_rgb[c]
            );
        }
    }
    // Not vacuous: with some absorption the cube is visibly darker.
    let mut grey = desc.clone();
    grey.materials[0].volume.as_mut().unwrap().absorption = Some(SpectrumDesc::constant(0.3));
    let out = render(&grey, &buffers, &base, &RenderControl::new()).unwrap();
    let lum = |rgba: &[f32]| rgba.chunks_exact(4).map(luminance).sum::<f64>();
    eprintln!("absorbing: {:.4} of the world", lum(&out.images.rgba) / lum(&reference.images.rgba));
    assert!(lum(&out.images.rgba) < 0.9 * lum(&reference.images.rgba));
}

/// Invalid grids are errors naming the material: a NaN or negative voxel, a dimension
/// of 0, a voxel count that is not the dims' product, an empty box, a grid with
/// emission or on the world. An all-zero grid is no medium (the image of none).
#[test]
fn invalid_grids_are_errors_naming_the_material() {
    let s = ResolvedSettings { spectral_output: false, ..settings(8, 2) };
    let with = |g: DensityGridDesc| {
        let volume = VolumeDesc { density_grid: Some(g), ..absorbing(SpectrumDesc::constant(1.0)) };
        slab_scene(material("smoke", BsdfDesc::Null, Some(volume)), None)
    };
    let ok = || density_grid([2, 2, 2], [-5.0, -0.5, -5.0], [5.0, 0.5, 5.0], |_, _, _| 1.0);
    let cases: Vec<(DensityGridDesc, &str)> = vec![
        (
            {
                let mut g = ok();
                g.values[3] = f32::NAN;
                g
            },
            "NaN at index 3",
        ),
        (
            {
                let mut g = ok();
                g.values[6] = -1.0;
                g
            },
            "-1 at index 6",
        ),
        (DensityGridDesc { dims: [2, 0, 2], values: vec![], ..ok() }, "> 0"),
        (
            {
                let mut g = ok();
                g.values.pop();
                g
            },
            "7 values",
        ),
        (DensityGridDesc { bounds: [[0.0; 3], [1.0, 1.0, 0.0]], ..ok() }, "bounds"),
    ];
    for (g, what) in cases {
        let (desc, buffers) = with(g);
        let err = render(&desc, &buffers, &s, &RenderControl::new()).err().expect("an invalid grid").to_string();
        eprintln!("{err}");
        assert!(err.contains("smoke") && err.contains(what), "{what}: {err}");
    }
    let (mut desc, buffers) = with(ok());
    desc.materials[1].volume.as_mut().unwrap().emission = Some(SpectrumDesc::constant(1.0));
    let err = render(&desc, &buffers, &s, &RenderControl::new()).err().expect("emission").to_string();
    assert!(err.contains("smoke") && err.contains("emission"), "{err}");
    let (mut desc, buffers) = slab_scene(material("air", BsdfDesc::Null, None), None);
    desc.world = Some(uniform_world(&SpectrumDesc::constant(1.0)));
    desc.world.as_mut().unwrap().volume =
        Some(VolumeDesc { density_grid: Some(ok()), ..absorbing(SpectrumDesc::constant(1.0)) });
    let err = render(&desc, &buffers, &s, &RenderControl::new()).err().expect("world").to_string();
    assert!(err.contains("World") && err.contains("density_grid"), "{err}");
    // All zeros: no medium, exactly the image without one.
    let clear = render(&desc_without_volume(), &buffers, &s, &RenderControl::new()).unwrap();
    let (desc, buffers) = with(density_grid([3, 2, 2], [-5.0, -0.5, -5.0], [5.0, 0.5, 5.0], |_, _, _| 0.0));
    let out = render(&desc, &buffers, &s, &RenderControl::new()).unwrap();
    assert_eq!(out.images.rgba, clear.images.rgba, "an empty grid is no medium");
}

fn desc_without_volume() -> SceneDesc {
    slab_scene(material("air", BsdfDesc::Null, None), None).0
}
