//! The driver's contract for distributed rendering: any grouping of sample passes,
//! rendered separately and added, gives the image of the whole render (each pixel
//! sample and light path has its own random stream), for camera paths, light paths and
//! the per-wavelength rounds of MONOCHROMATIC_SCENES.

mod common;

use common::*;
use polychrome_core::material::IorDesc;
use polychrome_core::render::{compile, Direction, Driver, Merge, Method, RenderControl, ResolvedSettings, Timing};
use polychrome_core::scene::{BsdfDesc, Buffer, LightDesc, MaterialDesc, Scene, SceneDesc};
use polychrome_core::spectrum::SpectrumDesc;
use polychrome_core::spectrum::WavelengthGrid;
use std::time::Instant;

/// A closed box with an emissive panel, a point light and a dispersive glass ball.
fn scene_desc() -> (SceneDesc, Vec<Buffer>) {
    let mut desc = SceneDesc::default();
    let mut buffers = Vec::new();
    let diffuse = |name: &str, a: f32, e: Option<f32>| MaterialDesc {
        name: name.into(),
        bsdf: BsdfDesc::Diffuse { reflectance: SpectrumDesc::constant(a) },
        emission: e.map(SpectrumDesc::constant),
        volume: None,
        one_sided: false,
        see_through: false,
    };
    desc.materials.push(diffuse("walls", 0.7, None));
    desc.materials.push(diffuse("lamp", 0.0, Some(4.0)));
    desc.materials.push(MaterialDesc {
        name: "flint".into(),
        bsdf: BsdfDesc::Dielectric { ior: IorDesc::Named { name: "N-SF11".into() }, roughness: 0.0 },
        emission: None,
        volume: None,
        one_sided: false,
        see_through: false,
    });
    let s = 1.0f32;
    let quad =
        |p: [[f32; 3]; 4]| -> (Vec<f32>, Vec<u32>) { (p.iter().flatten().copied().collect(), vec![0, 1, 2, 0, 2, 3]) };
    for (name, q) in [
        ("floor", [[-s, -s, -s], [s, -s, -s], [s, s, -s], [-s, s, -s]]),
        ("ceiling", [[-s, -s, s], [-s, s, s], [s, s, s], [s, -s, s]]),
        ("left", [[-s, -s, -s], [-s, s, -s], [-s, s, s], [-s, -s, s]]),
        ("right", [[s, -s, -s], [s, -s, s], [s, s, s], [s, s, -s]]),
        ("back", [[-s, s, -s], [s, s, -s], [s, s, s], [-s, s, s]]),
        ("front", [[-s, -s, -s], [-s, -s, s], [s, -s, s], [s, -s, -s]]),
    ] {
        let (v, t) = quad(q);
        add_mesh(&mut desc, &mut buffers, name, v, t, 0);
    }
    let l = 0.3f32;
    let (v, t) = quad([[-l, -l, 0.98], [l, -l, 0.98], [l, l, 0.98], [-l, l, 0.98]]);
    add_mesh(&mut desc, &mut buffers, "lamp", v, t, 1);
    let (v, t) = uv_sphere([0.2, 0.3, -0.6], 0.35, 12, 24);
    add_mesh(&mut desc, &mut buffers, "ball", v, t, 2);
    desc.lights.push(LightDesc::Point {
        name: "point".into(),
        position: [-0.5, 0.2, 0.6],
        intensity: SpectrumDesc::constant(0.5),
        radius: 0.0,
        visibility: Default::default(),
        profile: None,
        motion: Vec::new(),
    });
    desc.camera.to_world = [[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, -1.0, -0.95], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]];
    desc.camera.focal_length = 18.0;
    (desc, buffers)
}

fn build(settings: &ResolvedSettings) -> Scene {
    let (desc, buffers) = scene_desc();
    compile(&desc, &buffers, settings).unwrap()
}

/// The whole render through the pass loop, and the same passes rendered as `ranges`
/// (in a different order) and added: the images agree to float rounding of the sums.
fn assert_ranges_add_up(settings: ResolvedSettings, ranges: &[std::ops::Range<u32>]) {
    let scene = build(&settings);
    let driver = Driver::new(&scene, &settings).unwrap();
    let total = driver.sample_passes();
    assert_eq!(ranges.iter().map(|r| r.len() as u32).sum::<u32>(), total, "ranges must cover every pass");
    let control = RenderControl::new();
    let timing = Timing { start: Instant::now(), build_seconds: 0.0, threads: 1 };
    let (film, done) = driver.run(&control, timing.start);
    let whole = driver.output(&film, done, &control, timing);

    let mut merged = driver.new_film();
    for r in ranges.iter().rev() {
        let sums = driver.render_passes(r.clone(), None, &control).expect("not cancelled");
        merged.buffer.merge(&sums);
    }
    let parts = driver.output(&merged, done, &control, timing);

    assert_eq!(whole.stats.total_samples, parts.stats.total_samples);
    assert_eq!(whole.stats.samples_per_pixel, settings.samples);
    let peak = whole.images.rgba.iter().fold(0.0f32, |m, v| m.max(v.abs()));
    assert!(peak > 0.0, "a black image proves nothing");
    for (k, (a, b)) in whole.images.rgba.iter().zip(&parts.images.rgba).enumerate() {
        assert!((a - b).abs() <= 1e-5 * peak, "value {k}: whole render {a}, passes added {b}");
    }
}

#[test]
fn pass_ranges_add_up_to_the_whole_render_backward() {
    let settings = ResolvedSettings {
        width: 20,
        height: 14,
        samples: 7,
        grid: WavelengthGrid::uniform(8, 380.0, 780.0).unwrap(),
        ..Default::default()
    };
    assert_ranges_add_up(settings, &[0..2, 2..3, 3..7]);
}

#[test]
fn pass_ranges_add_up_to_the_whole_render_bidirectional() {
    let settings = ResolvedSettings {
        width: 20,
        height: 14,
        samples: 5,
        grid: WavelengthGrid::uniform(8, 380.0, 780.0).unwrap(),
        direction: Direction::Bidirectional,
        ..Default::default()
    };
    assert_ranges_add_up(settings, &[0..1, 1..5]);
}

#[test]
fn pass_ranges_add_up_across_the_wavelength_rounds_of_monochromatic_scenes() {
    let settings = ResolvedSettings {
        width: 12,
        height: 10,
        samples: 3,
        grid: WavelengthGrid::uniform(4, 380.0, 780.0).unwrap(),
        method: Method::MonochromaticScenes,
        direction: Direction::Forward,
        ..Default::default()
    };
    // 4 wavelengths × 3 samples = 12 passes; ranges straddle the rounds.
    assert_ranges_add_up(settings, &[0..5, 5..6, 6..12]);
}

/// Adaptive sampling across tasks: each group of the pass loop split into tasks (every
/// task inside one half, added in reverse order, as workers may finish) through a
/// [`Merge`] gives the pass loop's image, sample counts and converged pixels.
#[test]
fn adaptive_sampling_split_into_tasks_equals_the_pass_loop() {
    let settings = ResolvedSettings {
        width: 20,
        height: 14,
        samples: 64,
        noise_threshold: 4.0,
        grid: WavelengthGrid::uniform(8, 380.0, 780.0).unwrap(),
        ..Default::default()
    };
    let scene = build(&settings);
    let driver = Driver::new(&scene, &settings).unwrap();
    assert!(driver.adaptive());
    let control = RenderControl::new();
    let timing = Timing { start: Instant::now(), build_seconds: 0.0, threads: 1 };
    let (film, done) = driver.run(&control, timing.start);
    let whole = driver.output(&film, done, &control, timing);
    let converged = whole.stats.converged_pixels;
    assert!(converged > 0 && converged < 20 * 14, "the test needs some pixels stopped early and some not: {converged}");

    let mut merge = Merge::new(&driver);
    for group in driver.groups() {
        if !merge.any_active() {
            break;
        }
        let active = merge.active().map(|a| a.to_vec());
        let mut tasks = Vec::new();
        for (h, half) in merge.halves(group.clone()).into_iter().enumerate() {
            let mid = half.start + half.len() as u32 / 2;
            for r in [half.start..mid, mid..half.end] {
                if !r.is_empty() {
                    tasks.push((driver.render_passes(r, active.as_deref(), &control).unwrap(), h == 0));
                }
            }
        }
        for (sums, first_half) in tasks.iter().rev() {
            merge.add(sums, *first_half);
        }
        merge.end_group(&driver, group.len() as u32);
    }
    let parts = merge.output(&driver, false, &control, timing);

    assert_eq!(whole.stats.total_samples, parts.stats.total_samples);
    assert_eq!(whole.stats.converged_pixels, parts.stats.converged_pixels);
    assert_eq!(whole.stats.samples_per_pixel, parts.stats.samples_per_pixel);
    let peak = whole.images.rgba.iter().fold(0.0f32, |m, v| m.max(v.abs()));
    for (k, (a, b)) in whole.images.rgba.iter().zip(&parts.images.rgba).enumerate() {
        assert!((a - b).abs() <= 1e-5 * peak, "value {k}: pass loop {a}, tasks {b}");
    }
}
