//! Renders a scene description dumped by `bench/profile.py` (JSON with the scene and its
//! buffers) on one thread, for profiling the polychromatic path with perf or callgrind.
//!
//!     cargo build --release -p polychrome-core --example profile_render
//!     perf record -g target/release/examples/profile_render scene.json [spp] [wavelengths]
//!
//! Prints the render seconds and camera paths per second.

use polychrome_core::render::{render, RenderControl, ResolvedSettings};
use polychrome_core::scene::{Buffer, SceneDesc};
use polychrome_core::spectrum::WavelengthGrid;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let path = args.get(1).ok_or("usage: profile_render scene.json [spp] [wavelengths] [size]")?;
    let spp: u32 = args.get(2).map_or(Ok(16), |s| s.parse())?;
    let n: usize = args.get(3).map_or(Ok(41), |s| s.parse())?;
    let size: u32 = args.get(4).map_or(Ok(64), |s| s.parse())?;
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(path)?)?;
    let desc: SceneDesc = serde_json::from_value(v["scene"].clone())?;
    let buffers: Vec<Buffer> = v["buffers"]
        .as_array()
        .ok_or("buffers missing")?
        .iter()
        .map(|b| {
            let data = b["data"].as_array().cloned().unwrap_or_default();
            if b["kind"] == "u32" {
                Buffer::U32(data.iter().map(|x| x.as_u64().unwrap_or(0) as u32).collect())
            } else {
                Buffer::F32(data.iter().map(|x| x.as_f64().unwrap_or(0.0) as f32).collect())
            }
        })
        .collect();
    let settings = ResolvedSettings {
        width: size,
        height: size,
        samples: spp,
        grid: WavelengthGrid::uniform(n, 380.0, 780.0).unwrap(),
        threads: 1,
        seed: 1,
        ..Default::default()
    };
    let out = render(&desc, &buffers, &settings, &RenderControl::new())?;
    let paths = size as f64 * size as f64 * spp as f64;
    println!(
        "{} wavelengths, {}x{} {} spp: render {:.3} s (build {:.3} s), {:.0} camera paths/s on one thread",
        out.stats.wavelengths,
        size,
        size,
        spp,
        out.stats.seconds,
        out.stats.build_seconds,
        paths / (out.stats.seconds - out.stats.build_seconds)
    );
    Ok(())
}
