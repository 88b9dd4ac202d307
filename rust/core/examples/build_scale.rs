//! BVH build phases and memory on a displaced grid of N triangles (issue 16), without
//! Python: mesh from flat buffers, then `Accel::build`, timed, with the bytes the BLAS
//! keeps and the peak RSS; then closest-hit rays per second on one thread.
//!
//!     cargo run --release -p polychrome-core --example build_scale -- 10 [repeats] [chunk] [rays]
//!
//! The first argument is millions of triangles; `chunk` (triangles, 0 for none, `-` for
//! the library's own choice) cuts the mesh into chunks of that size; `rays` (1000000 unless
//! given) is the number of closest-hit rays traced after each build.

use polychrome_core::accel::Accel;
use polychrome_core::geometry::{Instance, Mesh, Ray};
use std::time::Instant;

fn rss(field: &str) -> u64 {
    let s = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    s.lines()
        .find(|l| l.starts_with(field))
        .and_then(|l| l.split_whitespace().nth(1))
        .and_then(|v| v.parse::<u64>().ok())
        .map_or(0, |kb| kb * 1024)
}

/// User + system CPU seconds of this process so far (/proc/self/stat, 100 ticks/s).
fn cpu_seconds() -> f64 {
    let s = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let after = s.rsplit(')').next().unwrap_or("");
    let f: Vec<&str> = after.split_whitespace().collect();
    let tick = |i: usize| f.get(i).and_then(|v| v.parse::<f64>().ok()).unwrap_or(0.0);
    (tick(11) + tick(12)) / 100.0
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let millions: f64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(1.0);
    let repeats: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(1);
    let chunk: Option<usize> = args.get(3).and_then(|s| s.parse().ok());
    let rays: usize = args.get(4).and_then(|s| s.parse().ok()).unwrap_or(1_000_000);
    let tris = (millions * 1e6) as usize;
    let n = ((tris as f64 / 2.0).sqrt().ceil() as usize) + 1;
    let mut pos = Vec::with_capacity(n * n * 3);
    for j in 0..n {
        for i in 0..n {
            let (x, y) = (i as f32 / (n - 1) as f32, j as f32 / (n - 1) as f32);
            pos.extend_from_slice(&[x * 2.0 - 1.0, y * 2.0 - 1.0, 0.05 * (12.0 * x).sin() * (9.0 * y).cos()]);
        }
    }
    let mut idx = Vec::with_capacity((n - 1) * (n - 1) * 6);
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            let a = (i + n * j) as u32;
            let n = n as u32;
            idx.extend_from_slice(&[a, a + 1, a + n + 1, a, a + n + 1, a + n]);
        }
    }
    let nt = idx.len() / 3;
    let ids = vec![0u32; nt];
    let base = rss("VmRSS:");
    let t0 = Instant::now();
    let mesh = Mesh::from_buffers("grid", &pos, &idx, None, None, &ids).unwrap();
    let t_mesh = t0.elapsed().as_secs_f64();
    drop((pos, idx, ids));
    let meshes = vec![mesh];
    let instances = vec![Instance::new("grid", 0, glam::Affine3A::IDENTITY).unwrap()];
    let after_mesh = rss("VmRSS:");
    for _ in 0..repeats {
        let (t1, c1) = (Instant::now(), cpu_seconds());
        let accel = match chunk {
            None => Accel::build(&meshes, &instances),
            Some(0) => Accel::build_chunked(&meshes, &instances, usize::MAX, usize::MAX),
            Some(c) => Accel::build_chunked(&meshes, &instances, c, c),
        };
        let (t_bvh, c_bvh) = (t1.elapsed().as_secs_f64(), cpu_seconds() - c1);
        let held = accel.bytes();
        println!(
            "{nt} triangles: mesh {t_mesh:.3} s, BVH {t_bvh:.3} s wall ({:.2} M tri/s), {c_bvh:.2} CPU s ({:.2} M tri per CPU s), accel holds {:.1} B/tri, mesh {:.1} B/tri",
            nt as f64 / t_bvh / 1e6,
            nt as f64 / c_bvh / 1e6,
            held as f64 / nt as f64,
            (after_mesh as f64 - base as f64) / nt as f64,
        );
        // Rays from above the grid to random points on it, as a camera's would be.
        let mut state = 12345u32;
        let mut rnd = || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            state as f32 / u32::MAX as f32
        };
        let (t2, c2, mut found) = (Instant::now(), cpu_seconds(), 0usize);
        for _ in 0..rays {
            let o = glam::Vec3A::new(rnd() * 2.0 - 1.0, rnd() * 2.0 - 3.0, 1.5);
            let d = (glam::Vec3A::new(rnd() * 2.0 - 1.0, rnd() * 2.0 - 1.0, 0.0) - o).normalize();
            found += accel.intersect(&meshes, &instances, &Ray::new(o, d)).is_some() as usize;
        }
        println!(
            "  {:.2} M closest-hit rays/s on one thread, {:.2} M per CPU s ({found} of {rays} hit)",
            rays as f64 / t2.elapsed().as_secs_f64() / 1e6,
            rays as f64 / (cpu_seconds() - c2) / 1e6
        );
    }
    println!(
        "peak RSS {:.1} B/tri ({:.2} GiB)",
        rss("VmHWM:") as f64 / nt as f64,
        rss("VmHWM:") as f64 / (1u64 << 30) as f64
    );
}
