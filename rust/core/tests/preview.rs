//! Progressive display: previews published into RenderControl while rendering.

mod common;

use common::*;
use polychrome_core::render::{render, RenderControl, ResolvedSettings};
use polychrome_core::scene::{BsdfDesc, Buffer, MaterialDesc, SceneDesc};
use polychrome_core::spectrum::SpectrumDesc;
use std::sync::mpsc;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Inside a closed diffuse sphere of emission L and albedo a every pixel sees L/(1−a).
fn furnace() -> (SceneDesc, Vec<Buffer>, f64) {
    let (l, a) = (0.5f32, 0.6f32);
    let mut desc = SceneDesc::default();
    let mut buffers: Vec<Buffer> = Vec::new();
    desc.materials.push(MaterialDesc {
        name: "furnace".into(),
        bsdf: BsdfDesc::Diffuse { reflectance: SpectrumDesc::constant(a) },
        emission: Some(SpectrumDesc::constant(l)),
        volume: None,
        one_sided: false,
        see_through: false,
    });
    let (v, t) = uv_sphere([0.0; 3], 2.0, 12, 24);
    add_mesh(&mut desc, &mut buffers, "sphere", v, t, 0);
    (desc, buffers, l as f64 / (1.0 - a as f64))
}

/// Polls `control` every millisecond until `stop` says so; returns every distinct preview.
fn watch(control: &RenderControl, stop: &std::sync::atomic::AtomicBool) -> Vec<polychrome_core::render::Preview> {
    let mut seen: Vec<polychrome_core::render::Preview> = Vec::new();
    loop {
        let finished = stop.load(std::sync::atomic::Ordering::Acquire);
        if let Some(p) = control.latest_preview() {
            if seen.last().is_none_or(|q| q.serial != p.serial) {
                seen.push(p);
            }
        }
        if finished {
            return seen;
        }
        std::thread::sleep(Duration::from_millis(1));
    }
}

#[test]
fn previews_arrive_during_the_render_converge_and_the_last_is_the_final_image() {
    let (desc, buffers, expected) = furnace();
    let settings =
        ResolvedSettings { width: 24, height: 24, samples: 400, max_bounces: 100, threads: 2, ..Default::default() };
    let control = RenderControl::with_previews();
    let stop = std::sync::atomic::AtomicBool::new(false);
    let (out, seen) = std::thread::scope(|s| {
        let watcher = s.spawn(|| watch(&control, &stop));
        let out = render(&desc, &buffers, &settings, &control).unwrap();
        stop.store(true, std::sync::atomic::Ordering::Release);
        (out, watcher.join().unwrap())
    });
    let intermediate: Vec<_> = seen.iter().filter(|p| !p.last).collect();
    assert!(!intermediate.is_empty(), "no intermediate preview in {} s", out.stats.seconds);
    eprintln!("{} previews in {} s", seen.len(), out.stats.seconds);
    // Serials and sample counts only grow; the image size is the render's.
    for pair in seen.windows(2) {
        assert!(pair[1].serial > pair[0].serial);
        assert!(pair[1].samples_per_pixel >= pair[0].samples_per_pixel);
    }
    assert!(seen.iter().all(|p| p.width == 24 && p.height == 24 && p.rgba.len() == 24 * 24 * 4));
    // Every snapshot is an unbiased estimate of the closed form with its own sample count.
    for p in &seen {
        let (mean, se) = mean_and_standard_error(&p.rgba);
        assert!(p.rgba.iter().all(|v| v.is_finite()));
        assert!(
            (mean - expected).abs() < 5.0 * se + 2e-3,
            "preview at {} spp: mean {mean}, expected {expected} (se {se})",
            p.samples_per_pixel
        );
    }
    let first = intermediate[0];
    assert!(first.samples_per_pixel < settings.samples, "the first preview comes early");
    // Noise falls as samples accumulate.
    let (_, se_first) = mean_and_standard_error(&first.rgba);
    let last = seen.last().unwrap();
    let (_, se_last) = mean_and_standard_error(&last.rgba);
    assert!(
        se_last < se_first,
        "se {se_first} at {} spp, {se_last} at {} spp",
        first.samples_per_pixel,
        last.samples_per_pixel
    );
    // The last published preview is the final image, bit for bit.
    assert!(last.last);
    assert_eq!(last.samples_per_pixel, out.stats.samples_per_pixel);
    assert_eq!(*last.rgba, out.images.rgba);
    assert_eq!(control.latest_preview().unwrap().serial, last.serial);
}

#[test]
fn no_previews_unless_requested() {
    let (desc, buffers, _) = furnace();
    let settings = ResolvedSettings { width: 8, height: 8, samples: 4, ..Default::default() };
    let control = RenderControl::new();
    render(&desc, &buffers, &settings, &control).unwrap();
    assert!(control.latest_preview().is_none());
}

#[test]
fn cancel_from_another_thread_stops_promptly_and_publishes_what_was_rendered() {
    let (desc, buffers, expected) = furnace();
    let settings = ResolvedSettings {
        width: 32,
        height: 32,
        samples: 1_000_000,
        max_bounces: 100,
        threads: 2,
        ..Default::default()
    };
    let control = Arc::new(RenderControl::with_previews());
    let (tx, rx) = mpsc::channel();
    let worker = {
        let control = control.clone();
        std::thread::spawn(move || {
            let r = render(&desc, &buffers, &settings, &control);
            let _ = tx.send(r);
        })
    };
    // Wait (bounded) for a first preview, then cancel.
    let t0 = Instant::now();
    while control.latest_preview().is_none() {
        assert!(t0.elapsed() < Duration::from_secs(60), "no preview within 60 s");
        std::thread::sleep(Duration::from_millis(2));
    }
    std::thread::sleep(Duration::from_millis(150));
    control.cancel();
    let out = rx.recv_timeout(Duration::from_secs(20)).expect("the render did not stop within 20 s of cancel").unwrap();
    worker.join().unwrap();
    assert!(out.stats.cancelled);
    assert!(out.stats.samples_per_pixel >= 1 && out.stats.samples_per_pixel < 1_000_000);
    let p = control.latest_preview().unwrap();
    assert!(p.last);
    assert_eq!(*p.rgba, out.images.rgba);
    let (mean, se) = mean_and_standard_error(&p.rgba);
    assert!((mean - expected).abs() < 5.0 * se + 2e-3, "mean {mean}, expected {expected} (se {se})");
}
