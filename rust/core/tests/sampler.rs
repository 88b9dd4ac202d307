//! The SOBOL sampler (docs/methods.md, "Sampler") against a closed form: a Lambertian
//! plane under a sun of angular diameter 10° at 50° from the normal. The sun's disk of
//! directions (half-angle h) has radiance E / (π sin² h), so the plane receives E cos θ₀
//! and looks ρ E cos θ₀ / π; light sampling draws a direction in the cone, and a pixel's
//! spread comes from cos θ varying over it. Stratified draws must keep the mean and cut
//! the pixel spread at 16 samples well below independent sampling's.

mod common;

use common::*;
use polychrome_core::render::{render, RenderControl, ResolvedSettings};
use polychrome_core::sampling::Sampler;
use polychrome_core::scene::{BsdfDesc, Buffer, SceneDesc};
use serde_json::json;

const THETA0: f32 = 50.0 * std::f32::consts::PI / 180.0;
const IRRADIANCE: f32 = 2.0;

/// Per-pixel luminance of the plane, 24², 16 spp.
fn plane_under_sun(sampler: Sampler, seed: u64) -> Vec<f64> {
    let mut desc = SceneDesc::default();
    let mut buffers: Vec<Buffer> = Vec::new();
    let bsdf = json!({"type": "ShaderNodeBsdfDiffuse", "name": "D", "inputs": {"Color": [0.5, 0.5, 0.5, 1.0]}});
    let graph = json!({"nodes": [bsdf], "output": {"surface": [0, "BSDF"]}});
    desc.materials.push(material("plane", BsdfDesc::Graph(serde_json::from_value(graph).unwrap())));
    add_square(&mut desc, &mut buffers, "plane", 4.0, 0);
    desc.lights.push(sun([-THETA0.sin(), 0.0, -THETA0.cos()], IRRADIANCE, 10f32.to_radians()));
    desc.camera = ortho_down(2.0);
    let settings =
        ResolvedSettings { width: 24, height: 24, samples: 16, max_bounces: 1, sampler, seed, ..Default::default() };
    let out = render(&desc, &buffers, &settings, &RenderControl::new()).unwrap();
    assert_eq!(out.stats.nonfinite_samples, 0);
    out.images.rgba.chunks_exact(4).map(luminance).collect()
}

fn mean_and_relative_std(ys: &[f64]) -> (f64, f64) {
    let n = ys.len() as f64;
    let mean = ys.iter().sum::<f64>() / n;
    let var = ys.iter().map(|y| (y - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, var.sqrt() / mean)
}

#[test]
fn sobol_keeps_the_closed_form_and_cuts_the_pixel_spread() {
    let expected = 0.5 * f64::from(IRRADIANCE) * f64::from(THETA0.cos()) / std::f64::consts::PI;
    let (m_ind, s_ind) = mean_and_relative_std(&plane_under_sun(Sampler::Independent, 1));
    let (m_sob, s_sob) = mean_and_relative_std(&plane_under_sun(Sampler::Sobol, 1));
    // Independent pixels: the image mean's standard error is the spread / √576 (a
    // 0.2 % floor for the uplift and film rounding).
    for (m, s, name) in [(m_ind, s_ind, "independent"), (m_sob, s_sob, "sobol")] {
        let tol = (4.0 * s / 24.0).max(2e-3) * expected;
        assert!((m - expected).abs() < tol, "{name}: mean {m} vs {expected} (relative std {s})");
    }
    // Independent sampling's spread is that of cos θ over the cone / √16: to first order
    // in h, cos θ ≈ cos θ₀ − sin θ₀ δ with δ the offset along the tilt, uniform on a disk
    // of radius h (variance h²/4): relative std tan θ₀ · h/2 / 4 ≈ 1.3 %. (The spread's
    // own sampling error over 576 pixels is about 3 %.)
    let h = 5f64.to_radians();
    let closed = f64::from(THETA0.tan()) * h / 2.0 / 4.0;
    assert!((s_ind / closed - 1.0).abs() < 0.15, "independent relative std {s_ind} vs {closed}");
    assert!(s_sob * 3.0 < s_ind, "relative std at 16 spp: sobol {s_sob} vs independent {s_ind}");
    eprintln!("relative std at 16 spp: independent {s_ind:.5}, sobol {s_sob:.5}");
}
