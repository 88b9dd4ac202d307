//! Polychromatic backward path tracing (the paper's method 3, camera side): every path
//! carries the whole sampled spectrum; next-event estimation and BSDF sampling are
//! combined with multiple importance sampling (power heuristic); Russian roulette on
//! the largest throughput over the grid.

use super::monochromatic::{MonochromaticTracer, PathState, Scratch};
use super::scatter;
use super::Integrator;
use super::{facing, Facing};
use crate::film::PixelSample;
use crate::geometry::{offset_ray_origin, Frame};
use crate::material::ShadingContext;
use crate::sampling::{power_heuristic, Rng};
use crate::scene::Scene;
use crate::spectrum::SampledSpectrum;

pub struct PathTracer {
    /// Scattering events after which a path ends (0: direct emission only).
    pub max_bounces: u32,
    /// Bounces before Russian roulette may end a path.
    pub rr_depth: u32,
    /// Deterministic mode at dispersive surfaces: instead of collapsing to one
    /// wavelength chosen ∝ energy (eq. 9), continue one monochromatic sub-path per
    /// wavelength that still carries energy.
    pub dispersion_splitting: bool,
}

impl Default for PathTracer {
    fn default() -> Self {
        Self { max_bounces: 8, rr_depth: 3, dispersion_splitting: false }
    }
}

impl PathTracer {
    fn mono(&self) -> MonochromaticTracer {
        MonochromaticTracer { max_bounces: self.max_bounces, rr_depth: self.rr_depth }
    }
}

impl Integrator for PathTracer {
    fn sample(&self, scene: &Scene, x: f32, y: f32, rng: &mut Rng, out: &mut PixelSample) {
        let n = scene.grid.len();
        let Some(mut ray) = scene.camera.generate_ray(x, y, rng) else {
            return; // outside the lens (fisheye, mirror ball): black
        };
        let mut beta = SampledSpectrum::splat(n, 1.0);
        let mut f = SampledSpectrum::zeros(n);
        let mut le = SampledSpectrum::zeros(n);
        let radiance = &mut out.radiance;
        let mut ctx = ShadingContext::new(&scene.grid);
        let mut specular = true; // the camera ray counts as specular: no MIS on what it sees
        let mut prev_pdf = 0.0f32;
        let mut prev_p = ray.origin;
        let mut depth = 0u32;
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
                    let l = env.radiance_along(ray.direction, &mut le);
                    radiance.add_product(&beta, l, w);
                }
                break;
            };
            let si = scene.interaction(&ray, &hit);
            // Surfaces are two-sided: shade on the side the ray arrived from.
            let Facing { wo, ng, ns, material } = facing(scene, &ray, &si, &mut ctx);
            if depth == 0 {
                out.depth = scene.camera.depth(si.p);
                out.normal = si.ns;
                material.bsdf.albedo(&ctx, &mut out.albedo);
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
                radiance.add_product(&beta, emission, w);
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

            // Next-event estimation: one light chosen ∝ its spectral power (eq. 7).
            if flags.smooth {
                if let Some(l) = scene.light_distribution.sample(rng.uniform()) {
                    let pmf = scene.light_distribution.pmf(l);
                    let u = rng.uniform2();
                    if let Some(ls) = scene.lights[l].sample_li(si.p, u, &mut le) {
                        let wi_local = frame.to_local(ls.wi);
                        let bsdf_pdf = material.bsdf.eval(&ctx, wo_local, wi_local, &mut f);
                        let same_side = ls.wi.dot(ng) > 0.0;
                        if !f.is_black() && same_side {
                            let origin = offset_ray_origin(si.p, ng);
                            // Aimed from the offset origin at the light point, stopping short (robust at 1e6 units).
                            if !scene.occluded(&crate::geometry::shadow_ray(si.p, origin, ls.wi, ls.distance)) {
                                let light_pdf = pmf * ls.pdf;
                                let w = if ls.delta { 1.0 } else { power_heuristic(light_pdf, bsdf_pdf) };
                                f.mul_assign(&beta);
                                radiance.add_product(&f, &le, w / light_pdf);
                            }
                        }
                    }
                }
            }

            // Deterministic (splitting) mode: one monochromatic sub-path per wavelength.
            if self.dispersion_splitting && flags.dispersive && ctx.single_wavelength.is_none() {
                self.mono().split_per_wavelength(
                    scene,
                    material.bsdf.as_ref(),
                    &mut ctx,
                    &frame,
                    wo_local,
                    si.p,
                    ng,
                    &beta,
                    depth,
                    rng,
                    radiance,
                );
                break;
            }

            // Continue the path by sampling the BSDF.
            let Some(sc) = scatter(material.bsdf.as_ref(), &ctx, &frame, wo_local, si.p, ng, rng, &mut beta) else {
                break;
            };
            if !beta.is_finite() {
                break;
            }
            let bs = sc.sample;
            specular = bs.specular;
            prev_pdf = bs.pdf;
            prev_p = si.p;
            ray = sc.ray;
            depth += 1;
            if let Some(i) = bs.collapsed_to {
                if ctx.single_wavelength.is_none() {
                    // Collapsed (eq. 9): the BSDF chose wavelength i and divided by its
                    // probability; carry on as a scalar monochromatic path.
                    let st = PathState { ray, specular, prev_pdf, prev_p, depth };
                    let l = self.mono().trace(scene, i, beta.get(i), st, rng, None, &mut Scratch::new(n));
                    radiance.set(i, radiance.get(i) + l);
                    break;
                }
                ctx.single_wavelength = Some(i);
            }

            if depth >= self.rr_depth {
                let q = beta.max_value().min(1.0);
                if q <= 0.0 || rng.uniform() >= q {
                    break;
                }
                beta.scale(1.0 / q);
            }
        }
    }
}
