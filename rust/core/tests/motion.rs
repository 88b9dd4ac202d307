//! Motion blur against closed forms: an emissive square moving at constant velocity
//! over the shutter, seen straight on by an orthographic camera, smears into a
//! trapezoid — time-averaged coverage at x is |[x − w/2, x + w/2] ∩ path| / D for a
//! square of width w whose centre travels D — whatever moves it: the instance's
//! transform, its vertices (a deforming mesh) or the camera (the other way). Light
//! tracing through a moving camera agrees with camera paths.

mod common;

use common::*;
use polychrome_core::camera::Projection;
use polychrome_core::render::{render, Direction, RenderControl, ResolvedSettings};
use polychrome_core::scene::{BsdfDesc, Buffer, InstanceDesc, LightDesc, MaterialDesc, SceneDesc};
use polychrome_core::spectrum::SpectrumDesc;
use polychrome_core::spectrum::WavelengthGrid;

const W: u32 = 64;
const H: u32 = 4;
/// The view is 8 units wide: 1/8 unit per pixel.
const VIEW: f32 = 8.0;

fn translation(x: f32, z: f32) -> [[f32; 4]; 4] {
    [[1.0, 0.0, 0.0, x], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, z], [0.0, 0.0, 0.0, 1.0]]
}

/// A unit-wide, 4-unit-tall emissive square at z = −5 (object space centred on x = 0),
/// an orthographic camera at the origin looking down −z.
fn square_scene() -> (SceneDesc, Vec<Buffer>) {
    let mut desc = SceneDesc::default();
    let mut buffers = Vec::new();
    desc.materials.push(MaterialDesc {
        name: "glow".into(),
        bsdf: BsdfDesc::None,
        emission: Some(SpectrumDesc::constant(1.0)),
        volume: None,
        one_sided: false,
        see_through: false,
    });
    let v = vec![-0.5, -2.0, 0.0, 0.5, -2.0, 0.0, 0.5, 2.0, 0.0, -0.5, 2.0, 0.0];
    add_mesh(&mut desc, &mut buffers, "square", v, vec![0, 1, 2, 0, 2, 3], 0);
    desc.instances = Some(vec![InstanceDesc {
        name: "square".into(),
        mesh: 0,
        transform: translation(0.0, -5.0),
        ..Default::default()
    }]);
    desc.camera.projection = Projection::Orthographic;
    desc.camera.ortho_scale = VIEW;
    (desc, buffers)
}

fn grid8() -> WavelengthGrid {
    WavelengthGrid::uniform(8, 380.0, 780.0).unwrap()
}

fn settings(samples: u32) -> ResolvedSettings {
    ResolvedSettings { width: W, height: H, samples, grid: grid8(), max_bounces: 0, seed: 7, ..Default::default() }
}

/// Mean luminance of each column.
fn columns(desc: &SceneDesc, buffers: &[Buffer], s: &ResolvedSettings) -> Vec<f64> {
    let out = render(desc, buffers, s, &RenderControl::new()).expect("render");
    let w = out.width as usize;
    let mut col = vec![0.0; w];
    for (i, px) in out.images.rgba.chunks_exact(4).enumerate() {
        col[i % w] += luminance(px) / out.height as f64;
    }
    col
}

/// Time-averaged coverage of the pixel column whose centre is at x, for a square of
/// width 1 whose centre moves uniformly from `a` to `b` over the shutter. Piecewise
/// linear with kinks on pixel edges here, so the pixel mean is the centre value.
fn smear(x: f64, a: f64, b: f64) -> f64 {
    let (lo, hi) = (a.min(b), a.max(b));
    let d = hi - lo;
    ((x + 0.5).min(hi) - (x - 0.5).max(lo)).max(0.0) / d
}

fn column_x(i: usize) -> f64 {
    (i as f64 + 0.5) * (VIEW / W as f32) as f64 - VIEW as f64 / 2.0
}

/// The plateau radiance of the static square, then each column of `desc` against the
/// trapezoid (a, b): per-column error within `tol` of the plateau, and the total
/// (the energy over the row) within 1 %.
fn check_smear(desc: &SceneDesc, buffers: &[Buffer], a: f64, b: f64, tol: f64) {
    let (still, still_buffers) = square_scene();
    let plateau = columns(&still, &still_buffers, &settings(16))[W as usize / 2];
    assert!(plateau > 0.1, "static square radiance {plateau}");
    let col = columns(desc, buffers, &settings(256));
    let mut worst = (0.0f64, 0usize);
    for (i, v) in col.iter().enumerate() {
        let want = smear(column_x(i), a, b);
        let e = (v / plateau - want).abs();
        if e > worst.0 {
            worst = (e, i);
        }
    }
    assert!(worst.0 < tol, "column {} off by {:.3} of the plateau: {col:?}", worst.1, worst.0);
    let total: f64 = col.iter().sum::<f64>() / plateau;
    // The square's own width in columns: motion spreads the light, it keeps its amount.
    let want = W as f64 / VIEW as f64;
    assert!((total - want).abs() < 0.01 * want, "energy {total} columns, want {want}");
    // The wrong trapezoid (half the travel) is told apart.
    let half = col.iter().enumerate().map(|(i, v)| (v / plateau - smear(column_x(i), a / 2.0, b / 2.0)).abs());
    assert!(half.fold(0.0, f64::max) > 3.0 * tol);
}

#[test]
fn a_moving_instance_smears_into_the_closed_form_trapezoid() {
    let (mut desc, buffers) = square_scene();
    // Three keys (Cycles' default motion steps) from x = −1 to x = +1.
    let inst = &mut desc.instances.as_mut().unwrap()[0];
    inst.motion = vec![translation(-1.0, -5.0), translation(0.0, -5.0), translation(1.0, -5.0)];
    check_smear(&desc, &buffers, -1.0, 1.0, 0.08);
}

#[test]
fn a_rotating_instance_keeps_its_radius() {
    // A square spinning half a turn about the view axis: at every time its centre is at
    // the origin, so the centre pixels see it throughout, and a point at radius 1.8
    // (beyond the half-width 0.5 but inside the half-height 2) is covered for the share
    // of the turn the long side points at it: 2·asin(0.5/1.8)/π per half turn of π.
    let (mut desc, buffers) = square_scene();
    let rot = |a: f32| -> [[f32; 4]; 4] {
        let (s, c) = a.sin_cos();
        [[c, -s, 0.0, 0.0], [s, c, 0.0, 0.0], [0.0, 0.0, 1.0, -5.0], [0.0, 0.0, 0.0, 1.0]]
    };
    let inst = &mut desc.instances.as_mut().unwrap()[0];
    inst.motion = (0..=4).map(|k| rot(std::f32::consts::PI * k as f32 / 4.0)).collect();
    let (still, still_buffers) = square_scene();
    let plateau = columns(&still, &still_buffers, &settings(16))[W as usize / 2];
    let s =
        ResolvedSettings { width: 64, height: 64, samples: 64, grid: grid8(), max_bounces: 0, ..Default::default() };
    let out = render(&desc, &buffers, &s, &RenderControl::new()).unwrap();
    // Mean over the ring of pixels at radius ≈ 1.8 units (14.4 pixels).
    let (mut sum, mut n) = (0.0, 0);
    for (i, px) in out.images.rgba.chunks_exact(4).enumerate() {
        let (x, y) = ((i % 64) as f64 + 0.5 - 32.0, (i / 64) as f64 + 0.5 - 32.0);
        let r = (x * x + y * y).sqrt() / 8.0;
        if (r - 1.8).abs() < 0.04 {
            sum += luminance(px) / plateau;
            n += 1;
        }
    }
    let want = 2.0 * (0.5f64 / 1.8).asin() / std::f64::consts::PI;
    assert!(n > 20 && (sum / n as f64 - want).abs() < 0.03, "ring coverage {} want {want}", sum / n as f64);
}

#[test]
fn a_deforming_mesh_smears_like_a_moving_one() {
    let (mut desc, mut buffers) = square_scene();
    let key = |dx: f32| -> Vec<f32> {
        vec![-0.5 + dx, -2.0, 0.0, 0.5 + dx, -2.0, 0.0, 0.5 + dx, 2.0, 0.0, -0.5 + dx, 2.0, 0.0]
    };
    // Two keys: x from −0.5 to +1.5.
    for dx in [-0.5, 1.5] {
        buffers.push(Buffer::F32(key(dx)));
        desc.meshes[0].motion_vertices.push(buffers.len() - 1);
    }
    check_smear(&desc, &buffers, -0.5, 1.5, 0.08);
}

#[test]
fn a_moving_camera_smears_the_other_way() {
    let (mut desc, buffers) = square_scene();
    // The camera travels from x = +1 to x = −1: the square crosses its view from −1 to +1.
    desc.camera.motion = vec![translation(1.0, 0.0), translation(-1.0, 0.0)];
    check_smear(&desc, &buffers, -1.0, 1.0, 0.08);
}

#[test]
fn motion_keys_are_checked() {
    let (mut desc, mut buffers) = square_scene();
    desc.instances.as_mut().unwrap()[0].motion = vec![translation(0.0, -5.0)];
    let e = render(&desc, &buffers, &settings(1), &RenderControl::new()).err().expect("one key is no motion");
    assert!(e.to_string().contains("square") && e.to_string().contains("2 keys"), "{e}");
    let (mut desc, _) = square_scene();
    buffers.push(Buffer::F32(vec![0.0; 9]));
    desc.meshes[0].motion_vertices = vec![buffers.len() - 1, buffers.len() - 1];
    let e = render(&desc, &buffers, &settings(1), &RenderControl::new()).err().expect("wrong vertex count");
    assert!(e.to_string().contains("square") && e.to_string().contains("4 vertices"), "{e}");
}

/// A grey diffuse square lit by a point light, seen by a perspective camera that moves
/// sideways over the shutter: light paths connect to the camera where it is at their
/// own time, and agree with camera paths column by column.
#[test]
fn light_tracing_through_a_moving_camera_agrees_with_camera_paths() {
    let mut desc = SceneDesc::default();
    let mut buffers = Vec::new();
    desc.materials.push(MaterialDesc {
        name: "grey".into(),
        bsdf: BsdfDesc::Diffuse { reflectance: SpectrumDesc::constant(0.7) },
        emission: None,
        volume: None,
        one_sided: false,
        see_through: false,
    });
    let v = vec![-0.5, -2.0, -5.0, 0.5, -2.0, -5.0, 0.5, 2.0, -5.0, -0.5, 2.0, -5.0];
    add_mesh(&mut desc, &mut buffers, "square", v, vec![0, 1, 2, 0, 2, 3], 0);
    desc.lights.push(LightDesc::Point {
        name: "lamp".into(),
        position: [0.0, 0.0, -1.0],
        intensity: SpectrumDesc::constant(20.0),
        radius: 0.0,
        visibility: Default::default(),
        profile: None,
        motion: Vec::new(),
    });
    desc.camera.focal_length = 35.0;
    desc.camera.motion = vec![translation(1.0, 0.0), translation(-1.0, 0.0)];
    let s = |direction, samples| ResolvedSettings {
        width: 32,
        height: 4,
        samples,
        grid: grid8(),
        direction,
        max_bounces: 1,
        ..Default::default()
    };
    // Columns in pairs (light paths are few per pixel).
    let pairs = |c: Vec<f64>| -> Vec<f64> { c.chunks(2).map(|p| p[0] + p[1]).collect() };
    let back = pairs(columns(&desc, &buffers, &s(Direction::Backward, 256)));
    let fwd = pairs(columns(&desc, &buffers, &s(Direction::Forward, 4096)));
    let peak = back.iter().cloned().fold(0.0, f64::max);
    assert!(peak > 0.1);
    // A blurred square: some columns partly covered.
    assert!(back.iter().filter(|v| **v > 0.1 * peak && **v < 0.8 * peak).count() >= 3, "{back:?}");
    for (i, (b, f)) in back.iter().zip(&fwd).enumerate() {
        assert!((b - f).abs() < 0.08 * peak, "columns {i}: backward {b} forward {f}\n{back:?}\n{fwd:?}");
    }
    // The camera taken as standing still gives a sharp square the comparison sees.
    desc.camera.motion.clear();
    let sharp = pairs(columns(&desc, &buffers, &s(Direction::Backward, 64)));
    assert!(sharp.iter().zip(&back).any(|(a, b)| (a - b).abs() > 0.3 * peak), "{sharp:?}");
}

/// The luminance image (`size` × `size`, one bounce, no warning) of a lit-floor scene.
fn lit_floor(desc: &SceneDesc, buffers: &[Buffer], direction: Direction, samples: u32, size: u32) -> Vec<f64> {
    let s = ResolvedSettings {
        width: size,
        height: size,
        samples,
        grid: grid8(),
        direction,
        max_bounces: 1,
        ..Default::default()
    };
    let out = render(desc, buffers, &s, &RenderControl::new()).expect("render");
    assert!(out.stats.warnings.is_empty(), "{:?}", out.stats.warnings);
    out.images.rgba.chunks_exact(4).map(luminance).collect()
}

/// Light → world rows of a sun turned by `theta` about +x from pointing down (its −Z
/// then travels along (0, sin θ, −cos θ)).
fn sun_key(theta: f32) -> [[f32; 4]; 4] {
    let (s, c) = theta.sin_cos();
    [[1.0, 0.0, 0.0, 0.0], [0.0, c, -s, 0.0], [0.0, s, c, 0.0], [0.0, 0.0, 0.0, 1.0]]
}

/// A sun turning uniformly from θ0 to θ1 (from the vertical) over the shutter lights a
/// white-ish diffuse floor with the time average of E cos θ: the mean image is the
/// overhead sun's times (sin θ1 − sin θ0)/(θ1 − θ0), in every direction (light paths
/// start from the sun where it is at their time), for a parallel sun and one with an
/// angle (its disk reached by BSDF rays, with MIS). The sun at the frame is 11 % off.
#[test]
fn a_turning_sun_lights_the_floor_with_its_time_average() {
    let floor = |sun: LightDesc| {
        let mut desc = SceneDesc::default();
        let mut buffers = Vec::new();
        desc.materials.push(material("floor", BsdfDesc::Diffuse { reflectance: SpectrumDesc::constant(0.5) }));
        add_square(&mut desc, &mut buffers, "floor", 3.0, 0);
        desc.lights.push(sun);
        // Looking straight down from z = 6 (light paths need a perspective camera).
        desc.camera.to_world = translation(0.0, 6.0);
        (desc, buffers)
    };
    // Light paths (FORWARD) find the 64 pixels with more noise: more samples.
    let mean = |desc: &SceneDesc, buffers: &[Buffer], direction, samples| {
        lit_floor(desc, buffers, direction, samples, 8).iter().sum::<f64>() / 64.0
    };
    let (t0, t1) = (-0.2f32, 1.4f32);
    let want_ratio = ((t1.sin() - t0.sin()) / (t1 - t0)) as f64;
    for angle in [0.0f32, 0.1] {
        let (still, b) = floor(sun([0.0, 0.0, -1.0], 3.0, angle));
        let overhead = mean(&still, &b, Direction::Backward, 64);
        assert!(overhead > 0.1, "overhead sun: {overhead}");
        let mut turning = sun([0.0, 0.6f32.sin(), -0.6f32.cos()], 3.0, angle);
        if let LightDesc::Distant { motion, .. } = &mut turning {
            *motion = vec![sun_key(t0), sun_key(0.6), sun_key(t1)];
        }
        let (desc, b) = floor(turning);
        for (direction, samples) in
            [(Direction::Backward, 256), (Direction::Forward, 2048), (Direction::Bidirectional, 512)]
        {
            let ratio = mean(&desc, &b, direction, samples) / overhead;
            assert!(
                (ratio - want_ratio).abs() < 0.01 * want_ratio,
                "{direction:?}, sun angle {angle}: {ratio} of the overhead sun, want {want_ratio}"
            );
        }
        let (frame, b) = floor(sun([0.0, 0.6f32.sin(), -0.6f32.cos()], 3.0, angle));
        let at_frame = mean(&frame, &b, Direction::Backward, 64) / overhead;
        assert!((at_frame - want_ratio).abs() > 0.08 * want_ratio, "the frame's sun {at_frame} is told apart");
    }
}

/// A small emissive square sliding 2 units at height 1 over a diffuse floor (its
/// instance keys translate and turn it: a rigid motion) is a light carried by its keys:
/// next-event estimation and light paths find it where it is at their time. The
/// motion-blurred image equals the mean of 8 still renders with the square where it
/// stands at the middle of each eighth of the shutter (the time average, by the
/// midpoint rule; these use the still emitter's well-tested light), in BACKWARD and
/// FORWARD (which renders it now, with no warning).
#[test]
fn a_rigidly_moving_emitter_is_a_light_at_its_time() {
    let place = |x: f32, turn: f32| {
        let (s, c) = turn.sin_cos();
        [[c, -s, 0.0, x], [s, c, 0.0, 0.0], [0.0, 0.0, 1.0, 1.0], [0.0, 0.0, 0.0, 1.0]]
    };
    let scene = |motion: Vec<[[f32; 4]; 4]>, at: [[f32; 4]; 4]| {
        let mut desc = SceneDesc::default();
        let mut buffers = Vec::new();
        desc.materials.push(material("floor", BsdfDesc::Diffuse { reflectance: SpectrumDesc::constant(0.5) }));
        let mut glow = material("glow", BsdfDesc::None);
        glow.emission = Some(SpectrumDesc::constant(4.0));
        desc.materials.push(glow);
        add_square(&mut desc, &mut buffers, "floor", 3.0, 0);
        add_square(&mut desc, &mut buffers, "glow", 0.25, 1);
        let identity = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]];
        desc.instances = Some(vec![
            InstanceDesc { name: "floor".into(), mesh: 0, transform: identity, ..Default::default() },
            InstanceDesc { name: "glow".into(), mesh: 1, transform: at, motion, ..Default::default() },
        ]);
        // Looking straight down from z = 6 (light paths need a perspective camera).
        desc.camera.to_world = translation(0.0, 6.0);
        (desc, buffers)
    };
    let image =
        |desc: &SceneDesc, buffers: &[Buffer], direction, samples| lit_floor(desc, buffers, direction, samples, 16);
    // 4 × 4 blocks of 16 × 16 pixels.
    let blocks = |img: &[f64]| -> Vec<f64> {
        (0..16)
            .map(|b| (0..16).map(|i| img[((b / 4) * 4 + i / 4) * 16 + (b % 4) * 4 + i % 4]).sum::<f64>() / 16.0)
            .collect()
    };
    let keys = vec![place(-1.0, 0.0), place(0.0, 0.4), place(1.0, 0.8)];
    let (moving, b) = scene(keys, place(0.0, 0.4));
    let mut still = vec![0.0; 16];
    let nstill = 8;
    for i in 0..nstill {
        // Where the keys put it at t = (i + 0.5)/8: x and the turn lerp linearly.
        let t = (i as f32 + 0.5) / nstill as f32;
        let (desc, b) = scene(Vec::new(), place(-1.0 + 2.0 * t, 0.8 * t));
        for (s, v) in still.iter_mut().zip(blocks(&image(&desc, &b, Direction::Backward, 64))) {
            *s += v / nstill as f64;
        }
    }
    let peak = still.iter().cloned().fold(0.0, f64::max);
    assert!(peak > 0.05, "{still:?}");
    for (direction, samples) in [(Direction::Backward, 2048), (Direction::Forward, 2048)] {
        let got = blocks(&image(&moving, &b, direction, samples));
        for (k, (g, w)) in got.iter().zip(&still).enumerate() {
            assert!(
                (g - w).abs() < 0.03 * peak,
                "{direction:?} block {k}: {g} vs the still renders' mean {w}\n{got:?}\n{still:?}"
            );
        }
        let (tg, tw) = (got.iter().sum::<f64>(), still.iter().sum::<f64>());
        assert!((tg - tw).abs() < 0.01 * tw, "{direction:?}: image {tg} vs {tw}");
    }
}
