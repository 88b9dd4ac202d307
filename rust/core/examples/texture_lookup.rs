//! Micro-benchmark of deferred RGB → spectrum conversion (docs/design.md#rgb-data): the cost of one
//! textured reflectance lookup (bilinear RGB fetch + eq. 10 uplift into the grid's
//! samples) against a constant spectrum copy, and of one HDRI radiance lookup.
//!
//!     cargo run --release -p polychrome-core --example texture_lookup [wavelengths]
//!
//! Prints `name ns_per_lookup` lines (best of 5 runs of 4M lookups, one thread). Random
//! uv over a 2048×1024 image (24 MiB) is the cache-miss worst case; the 64×64 texture
//! shows the arithmetic cost alone.

use glam::{Vec2, Vec3A};
use polychrome_core::color::uplift::{Uplift, UpliftMethod};
use polychrome_core::color::RgbSpace;
use polychrome_core::light::ImageEnvironment;
use polychrome_core::material::texture::{Texture, Wrap};
use polychrome_core::material::{ShadingContext, SpectralParam};
use polychrome_core::sampling::Rng;
use polychrome_core::spectrum::{SampledSpectrum, WavelengthGrid};
use std::hint::black_box;
use std::sync::Arc;
use std::time::Instant;

fn best_ns(lookups: usize, mut f: impl FnMut(usize)) -> f64 {
    let mut best = f64::INFINITY;
    for _ in 0..5 {
        let t = Instant::now();
        for i in 0..lookups {
            f(i);
        }
        best = best.min(t.elapsed().as_nanos() as f64 / lookups as f64);
    }
    best
}

fn main() {
    let n: usize = std::env::args().nth(1).and_then(|s| s.parse().ok()).unwrap_or(41);
    let grid = WavelengthGrid::uniform(n, 380.0, 780.0).expect("grid");
    let (w, h) = (2048u32, 1024u32);
    let mut rng = Rng::new(1, 2);
    let pixels: Vec<f32> = (0..w * h * 3).map(|_| rng.uniform()).collect();
    let bytes: Vec<u8> = pixels.iter().map(|v| (v * 255.0) as u8).collect();
    let linear = Arc::new(Texture::from_linear("bench", w, h, 3, &pixels, Wrap::Repeat).expect("texture"));
    let srgb = Arc::new(Texture::from_srgb8("bench8", w, h, 3, &bytes, Wrap::Repeat).expect("texture"));
    let up = Arc::new(Uplift::new(&grid, &RgbSpace::rec709(), UpliftMethod::Linear).expect("uplift"));
    let uvs: Vec<Vec2> = (0..1 << 16).map(|_| rng.uniform2()).collect();
    let dirs: Vec<Vec3A> = (0..1 << 16).map(|_| polychrome_core::sampling::uniform_sphere(rng.uniform2())).collect();
    let lookups = 4_000_000;
    let mut out = SampledSpectrum::zeros(n);
    let mut out2 = SampledSpectrum::zeros(n);
    let mask = uvs.len() - 1;
    let ns = best_ns(lookups, |i| {
        let uv = uvs[i & mask];
        up.reflectance_into([uv.x, uv.y, 0.5], out2.values_mut());
        black_box(&out2);
    });
    println!("uplift_reflectance_only {ns:.2}");
    let ns = best_ns(lookups, |i| {
        black_box(linear.lookup(uvs[i & mask]));
    });
    println!("bilinear_rgb_only {ns:.2}");
    let mut ctx = ShadingContext::new(&grid);
    let constant = SpectralParam::Constant(SampledSpectrum::splat(n, 0.5));
    let tex = SpectralParam::Texture { texture: linear.clone(), uplift: up.clone(), scale: 1.0 };
    let tex8 = SpectralParam::Texture { texture: srgb, uplift: up.clone(), scale: 1.0 };
    let mut run = |name: &str, p: &SpectralParam| {
        let ns = best_ns(lookups, |i| {
            ctx.uv = uvs[i & mask];
            p.evaluate_into(black_box(&ctx), &mut out);
            black_box(&out);
        });
        println!("{name} {ns:.2}");
    };
    run("constant_spectrum", &constant);

    run("texture_linear_f32", &tex);
    run("texture_srgb_u8", &tex8);
    let small =
        Arc::new(Texture::from_linear("small", 64, 64, 3, &pixels[..64 * 64 * 3], Wrap::Repeat).expect("texture"));
    run("texture_linear_f32_64x64", &SpectralParam::Texture { texture: small, uplift: up.clone(), scale: 1.0 });
    let env = ImageEnvironment::new(linear, up, 1.0, 0.3, true);
    let ns = best_ns(lookups, |i| {
        env.radiance_into(dirs[i & mask], &mut out);
        black_box(&out);
    });
    println!("hdri_radiance {ns:.2}");
    println!("wavelengths {n}");
}
