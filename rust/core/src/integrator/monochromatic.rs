//! Single-wavelength backward path tracing: the path carries one grid wavelength and a
//! scalar throughput. Used by the monochromatic-rays method (one wavelength per camera
//! sample), the monochromatic-scenes method (one whole image per wavelength), and by the
//! polychromatic tracer once a path has collapsed at a dispersive surface (eq. 9) or
//! been split there (deterministic mode).
//!
//! Materials and lights still fill grid-wide spectra (the `Bsdf`/`Light` traits are
//! spectral); the tracer only reads the one component it carries and keeps all of its
//! own arithmetic scalar. BSDFs see `ShadingContext.single_wavelength = Some(λ)`.

use super::scatter;
use super::{facing, Facing};
use crate::film::PixelSample;
use crate::geometry::{offset_ray_origin, Frame, Ray};
use crate::material::ShadingContext;
use crate::sampling::{power_heuristic, Distribution1D, Rng};
use crate::scene::Scene;
use crate::spectrum::SampledSpectrum;
use glam::Vec3A;

/// Where a path is when a monochromatic continuation takes it over.
#[derive(Clone, Copy, Debug)]
pub struct PathState {
    pub ray: Ray,
    /// The last scattering was specular (or this is the camera ray): no MIS on emission.
    pub specular: bool,
    /// Solid-angle pdf of the last BSDF sample, for MIS on emission hit next.
    pub prev_pdf: f32,
    pub prev_p: Vec3A,
    /// Scattering events so far.
    pub depth: u32,
}

/// Grid-wide scratch spectra the traits write into.
pub struct Scratch {
    f: SampledSpectrum,
    le: SampledSpectrum,
    tp: SampledSpectrum,
}

impl Scratch {
    pub fn new(n: usize) -> Self {
        Self { f: SampledSpectrum::zeros(n), le: SampledSpectrum::zeros(n), tp: SampledSpectrum::zeros(n) }
    }
}

#[derive(Clone, Copy, Debug)]
pub struct MonochromaticTracer {
    pub max_bounces: u32,
    pub rr_depth: u32,
}

impl Default for MonochromaticTracer {
    fn default() -> Self {
        Self { max_bounces: 8, rr_depth: 3 }
    }
}

impl MonochromaticTracer {
    /// Radiance at grid wavelength `lambda` through film position (x, y). Fills the
    /// auxiliary passes of `aux` (not its radiance) at the first hit.
    pub fn sample_camera(
        &self,
        scene: &Scene,
        x: f32,
        y: f32,
        lambda: usize,
        rng: &mut Rng,
        aux: &mut PixelSample,
        s: &mut Scratch,
    ) -> f32 {
        let Some(ray) = scene.camera.generate_ray(x, y, rng) else {
            return 0.0; // outside the lens (fisheye, mirror ball): black
        };
        let st = PathState { ray, specular: true, prev_pdf: 0.0, prev_p: ray.origin, depth: 0 };
        self.trace(scene, lambda, 1.0, st, rng, Some(aux), s)
    }

    /// Continues a path at wavelength `lambda` with scalar throughput `beta`; returns the
    /// radiance it gathers (already multiplied by `beta`).
    #[allow(clippy::too_many_arguments)]
    /// Deterministic (splitting) mode at a dispersive surface: instead of collapsing to
    /// one wavelength (eq. 9), continue one scalar sub-path per wavelength that still
    /// carries energy, and add each sub-path's radiance to its own lane of `radiance`.
    /// `ctx` is left set to the last wavelength; callers end the polychromatic path here.
    #[allow(clippy::too_many_arguments)]
    pub fn split_per_wavelength(
        &self,
        scene: &Scene,
        bsdf: &dyn crate::material::Bsdf,
        ctx: &mut ShadingContext,
        frame: &Frame,
        wo_local: Vec3A,
        p: Vec3A,
        ng: Vec3A,
        beta: &SampledSpectrum,
        depth: u32,
        rng: &mut Rng,
        radiance: &mut SampledSpectrum,
    ) {
        let n = beta.len();
        let mut scratch = Scratch::new(n);
        let mut tp = SampledSpectrum::zeros(n);
        for i in 0..n {
            let b = beta.get(i);
            if !(b > 0.0) {
                continue;
            }
            ctx.single_wavelength = Some(i);
            tp.fill(0.0);
            tp.set(i, b);
            let Some(sc) = scatter(bsdf, ctx, frame, wo_local, p, ng, rng, &mut tp) else { continue };
            let st = PathState {
                ray: sc.ray,
                specular: sc.sample.specular,
                prev_pdf: sc.sample.pdf,
                prev_p: p,
                depth: depth + 1,
            };
            let l = self.trace(scene, i, tp.get(i), st, rng, None, &mut scratch);
            radiance.set(i, radiance.get(i) + l);
        }
    }

    pub fn trace(
        &self,
        scene: &Scene,
        lambda: usize,
        mut beta: f32,
        st: PathState,
        rng: &mut Rng,
        mut aux: Option<&mut PixelSample>,
        s: &mut Scratch,
    ) -> f32 {
        let PathState { mut ray, mut specular, mut prev_pdf, mut prev_p, mut depth } = st;
        let mut ctx = ShadingContext::new(&scene.grid);
        ctx.single_wavelength = Some(lambda);
        let mut radiance = 0.0f32;
        if !(beta > 0.0 && beta.is_finite()) {
            return 0.0;
        }
        loop {
            let Some(hit) = scene.intersect(&ray) else {
                if let Some(env) = &scene.environment {
                    let w = if specular {
                        1.0
                    } else {
                        let pl = scene.light_distribution.pmf(env.light)
                            * scene.lights[env.light].pdf_li(prev_p, ray.direction, f32::INFINITY);
                        power_heuristic(prev_pdf, pl)
                    };
                    radiance += beta * env.radiance_at(ray.direction, lambda) * w;
                }
                break;
            };
            let si = scene.interaction(&ray, &hit);
            // Surfaces are two-sided: shade on the side the ray arrived from.
            let Facing { wo, ng, ns, material } = facing(scene, &ray, &si, &mut ctx);
            if let Some(out) = aux.take() {
                if depth == 0 {
                    out.depth = scene.camera.depth(si.p);
                    out.normal = si.ns;
                    ctx.single_wavelength = None;
                    material.bsdf.albedo(&ctx, &mut out.albedo);
                    ctx.single_wavelength = Some(lambda);
                }
            }
            if let Some(emission) = &material.emission {
                let w = if specular {
                    1.0
                } else {
                    match scene.triangle_light(si.instance, si.triangle) {
                        Some(l) => {
                            let pl =
                                scene.light_distribution.pmf(l) * scene.lights[l].pdf_li(prev_p, ray.direction, si.t);
                            power_heuristic(prev_pdf, pl)
                        }
                        None => 1.0,
                    }
                };
                radiance += beta * emission.get(lambda) * w;
            }
            if depth >= self.max_bounces {
                break;
            }
            let frame = Frame::from_normal(ns);
            let wo_local = frame.to_local(wo);
            if wo_local.z == 0.0 {
                break;
            }
            let flags = material.bsdf.flags();
            if flags.smooth {
                if let Some(l) = scene.light_distribution.sample(rng.uniform()) {
                    let pmf = scene.light_distribution.pmf(l);
                    let u = rng.uniform2();
                    if let Some(ls) = scene.lights[l].sample_li(si.p, u, &mut s.le) {
                        let le = s.le.get(lambda);
                        if le > 0.0 && ls.wi.dot(ng) > 0.0 {
                            let wi_local = frame.to_local(ls.wi);
                            let bsdf_pdf = material.bsdf.eval(&ctx, wo_local, wi_local, &mut s.f);
                            let f = s.f.get(lambda);
                            if f > 0.0 {
                                let origin = offset_ray_origin(si.p, ng);
                                // Aimed from the offset origin at the light point, stopping
                                // short of it (robust far from the origin: 1e6 units).
                                if !scene.occluded(&crate::geometry::shadow_ray(si.p, origin, ls.wi, ls.distance)) {
                                    let light_pdf = pmf * ls.pdf;
                                    let w = if ls.delta { 1.0 } else { power_heuristic(light_pdf, bsdf_pdf) };
                                    radiance += beta * f * le * w / light_pdf;
                                }
                            }
                        }
                    }
                }
            }
            s.tp.fill(0.0);
            s.tp.set(lambda, beta);
            let Some(sc) = scatter(material.bsdf.as_ref(), &ctx, &frame, wo_local, si.p, ng, rng, &mut s.tp) else {
                break;
            };
            beta = s.tp.get(lambda);
            if !(beta > 0.0 && beta.is_finite()) {
                break;
            }
            specular = sc.sample.specular;
            prev_pdf = sc.sample.pdf;
            prev_p = si.p;
            ray = sc.ray;
            depth += 1;
            if depth >= self.rr_depth {
                let q = beta.min(1.0);
                if q <= 0.0 || rng.uniform() >= q {
                    break;
                }
                beta /= q;
            }
        }
        radiance
    }
}

/// How monochromatic rays pick their wavelength: half uniform, half ∝ the observer's
/// x̄+ȳ+z̄ folded with the grid weights, so every wavelength keeps a probability ≥ 1/(2n)
/// (the spectrum stays unbiased at every sample) while visible ones are sampled more.
pub fn wavelength_distribution(scene: &Scene) -> Distribution1D {
    let n = scene.grid.len();
    let o = &scene.observer;
    let cmf: Vec<f64> = (0..n).map(|i| (o.x[i].abs() + o.y[i].abs() + o.z[i].abs()) as f64).collect();
    let total: f64 = cmf.iter().sum();
    let w: Vec<f64> =
        cmf.iter().map(|c| 0.5 / n as f64 + if total > 0.0 { 0.5 * c / total } else { 0.5 / n as f64 }).collect();
    Distribution1D::new(&w)
}

/// The stratified wavelength choice of sample `s` of `count` in a pixel: a rotated
/// lattice (per-pixel random offset, Cranley–Patterson) through the inverse CDF, so a
/// pixel's samples cover the grid and each one is marginally distributed as `dist`.
pub fn stratified_wavelength(dist: &Distribution1D, seed: u64, pixel: u64, s: u32, count: u32) -> usize {
    let mut r = Rng::new(seed ^ 0x6d6f_6e6f_6368_726f, pixel);
    let offset = r.uniform();
    let u = (offset + s as f32 / count.max(1) as f32).fract();
    dist.sample(u.min(0.999_999_9)).unwrap_or(0)
}
