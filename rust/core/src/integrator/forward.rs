//! Forward stochastic tracing (light tracing): paths start on the lights and every
//! non-specular vertex is connected to the camera and splatted onto the film.
//!
//! - A light is chosen with probability ∝ its spectral power (eq. 7); its emission
//!   sample gives a position and direction. The starting throughput
//!   `Le·|cos|/(pmf·pdf_pos·pdf_dir)` equals the light's spectrum normalised to unit
//!   power times the scene's total power (eq. 8), so every light path carries the same
//!   energy.
//! - At the light itself (area lights) and at every vertex with a smooth BSDF component
//!   the path is connected to the pinhole; the splat is `β·f·|cos θx|·importance` (see
//!   [`crate::camera::CameraConnection`]). A pixel's value is the sum of its splats over
//!   the number of light paths per pixel.
//! - Dispersive surfaces collapse the path to one wavelength exactly as camera paths do.
//! - Environment lights and orthographic cameras are not reachable this way (their
//!   light has no `sample_le`, the camera no pinhole to connect to).

use super::scatter;
use super::{facing, Facing};
use crate::geometry::{offset_ray_origin, Frame, Ray};
use crate::material::{ShadingContext, TransportMode};
use crate::sampling::Rng;
use crate::scene::Scene;
use crate::spectrum::SampledSpectrum;

/// Which light-path contributions a forward pass keeps.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ForwardPart {
    /// Everything (FORWARD direction).
    All,
    /// Only what backward path tracing cannot sample: paths from a delta-position light
    /// whose first scattering vertex is specular (caustics of point lights). Used by the
    /// BIDIRECTIONAL direction, whose other paths come from backward tracing.
    BackwardUnreachable,
}

/// One contribution of a light path to the film.
pub struct Splat {
    pub pixel: u32,
    pub radiance: SampledSpectrum,
}

impl Splat {
    /// The contribution `β · f · scale` of a light-path vertex to one pixel.
    pub fn new(pixel: u32, f: &SampledSpectrum, beta: &SampledSpectrum, scale: f32) -> Self {
        let mut radiance = f.clone();
        radiance.mul_assign(beta);
        radiance.scale(scale);
        Self { pixel, radiance }
    }
}

/// Connects a light-path surface vertex at `p` to the camera (a point on its lens drawn
/// from `rng` when it has one). On success `f`
/// holds f·|cos θ| towards the camera; None when the camera is on the other side of the
/// surface than the path, the BSDF sends nothing that way, or something blocks the view.
#[allow(clippy::too_many_arguments)]
pub fn connect_to_camera(
    scene: &Scene,
    bsdf: &dyn crate::material::Bsdf,
    ctx: &ShadingContext,
    frame: &Frame,
    wo_local: glam::Vec3A,
    p: glam::Vec3A,
    ng: glam::Vec3A,
    f: &mut SampledSpectrum,
    rng: &mut Rng,
) -> Option<crate::camera::CameraConnection> {
    let c = scene.camera.connect(p, rng)?;
    if c.wi.dot(ng) <= 0.0 {
        return None;
    }
    bsdf.eval(ctx, wo_local, frame.to_local(c.wi), f);
    // Aimed from the offset origin at the camera: along c.wi from the unshifted point it
    // missed by the offset (16 units at 1e6) and hit walls behind it.
    if f.is_black() || scene.occluded(&crate::geometry::shadow_ray(p, offset_ray_origin(p, ng), c.wi, c.distance)) {
        return None;
    }
    Some(c)
}

pub struct LightTracer {
    pub max_bounces: u32,
    pub rr_depth: u32,
    pub part: ForwardPart,
}

impl LightTracer {
    /// Traces one light path; pushes its splats (radiance at the pixel, to be divided by
    /// the light paths per pixel).
    /// `wavelength`: monochromatic light paths carry only grid sample `i`, weighted by
    /// `w` (1/its selection probability, or n for one of n whole-image rounds).
    pub fn trace(&self, scene: &Scene, rng: &mut Rng, wavelength: Option<(usize, f32)>, splats: &mut Vec<Splat>) {
        let n = scene.grid.len();
        let Some(l) = scene.light_distribution.sample(rng.uniform()) else {
            return;
        };
        let pmf = scene.light_distribution.pmf(l);
        let (u_pos, u_dir) = (rng.uniform2(), rng.uniform2());
        let mut le = SampledSpectrum::zeros(n);
        let Some(es) = scene.lights[l].sample_le(u_pos, u_dir, &mut le) else {
            return;
        };
        if !(pmf > 0.0 && es.pdf_pos > 0.0 && es.pdf_dir > 0.0) {
            return;
        }
        if let Some((i, w)) = wavelength {
            le.keep_only(i);
            le.scale(w);
        }
        let width = scene.camera.width();
        let pixel_of = |c: &crate::camera::CameraConnection| -> u32 {
            let x = (c.raster.x as u32).min(width - 1);
            let y = (c.raster.y as u32).min(scene.camera.height() - 1);
            y * width + x
        };
        let all = self.part == ForwardPart::All;

        // The light vertex itself, seen by the camera (area lights only).
        if all && !es.delta_position {
            if let (Some(nl), Some(c)) = (es.normal, scene.camera.connect(es.origin, rng)) {
                let cos = nl.dot(c.wi).abs();
                let origin = offset_ray_origin(es.origin, if nl.dot(c.wi) > 0.0 { nl } else { -nl });
                if cos > 0.0
                    // Aimed from the offset origin at the camera: along c.wi from the unshifted
                    // point it missed by the offset (16 units at 1e6) and hit walls behind it.
                    && !scene.occluded(&crate::geometry::shadow_ray(es.origin, origin, c.wi, c.distance))
                {
                    let mut r = le.clone();
                    r.scale(cos * c.importance / (pmf * es.pdf_pos));
                    splats.push(Splat { pixel: pixel_of(&c), radiance: r });
                }
            }
        }

        let cos0 = es.normal.map_or(1.0, |nl| nl.dot(es.direction).abs());
        let mut beta = le;
        beta.scale(cos0 / (pmf * es.pdf_pos * es.pdf_dir));
        let start = match es.normal {
            Some(nl) => offset_ray_origin(es.origin, if nl.dot(es.direction) > 0.0 { nl } else { -nl }),
            None => es.origin,
        };
        let mut ray = Ray::new(start, es.direction);
        let mut ctx = ShadingContext::new(&scene.grid);
        ctx.mode = TransportMode::Importance;
        ctx.single_wavelength = wavelength.map(|(i, _)| i);
        let mut f = SampledSpectrum::zeros(n);
        let mut depth = 0u32; // scattering vertices so far
        while let Some(hit) = scene.intersect(&ray) {
            let si = scene.interaction(&ray, &hit);
            // Surfaces are two-sided: shade on the side the ray arrived from.
            let Facing { wo, ng, ns, material } = facing(scene, &ray, &si, &mut ctx);
            let frame = Frame::from_normal(ns);
            let wo_local = frame.to_local(wo);
            if wo_local.z == 0.0 {
                break;
            }
            let flags = material.bsdf.flags();
            // Connect this vertex to the camera: a path with depth + 1 scattering events.
            if all && flags.smooth && depth < self.max_bounces {
                if let Some(c) =
                    connect_to_camera(scene, material.bsdf.as_ref(), &ctx, &frame, wo_local, si.p, ng, &mut f, rng)
                {
                    splats.push(Splat::new(pixel_of(&c), &f, &beta, c.importance));
                }
            }
            if depth + 1 >= self.max_bounces {
                break;
            }
            let Some(sc) = scatter(material.bsdf.as_ref(), &ctx, &frame, wo_local, si.p, ng, rng, &mut beta) else {
                break;
            };
            if !beta.is_finite() {
                break;
            }
            if let Some(i) = sc.sample.collapsed_to {
                ctx.single_wavelength = Some(i);
            }
            if !all && depth == 0 {
                // Keep only caustic paths of delta lights: specular first vertex.
                if !(es.delta_position && sc.sample.specular) {
                    return;
                }
            }
            ray = sc.ray;
            depth += 1;
            if !all && depth >= 1 {
                // Connect the subsequent smooth vertices to the camera.
                self.connect_unreachable(scene, &ray, &beta, &ctx, depth, splats, &pixel_of, rng);
                return;
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

    /// The rest of a caustic light path (BIDIRECTIONAL): like the main loop, with every
    /// smooth vertex connected to the camera.
    #[allow(clippy::too_many_arguments)]
    fn connect_unreachable(
        &self,
        scene: &Scene,
        ray: &Ray,
        beta: &SampledSpectrum,
        ctx0: &ShadingContext,
        depth0: u32,
        splats: &mut Vec<Splat>,
        pixel_of: &dyn Fn(&crate::camera::CameraConnection) -> u32,
        rng: &mut Rng,
    ) {
        let n = scene.grid.len();
        let mut ray = *ray;
        let mut beta = beta.clone();
        let mut ctx = ShadingContext::new(&scene.grid);
        ctx.mode = TransportMode::Importance;
        ctx.single_wavelength = ctx0.single_wavelength;
        let mut f = SampledSpectrum::zeros(n);
        let mut depth = depth0;
        while let Some(hit) = scene.intersect(&ray) {
            let si = scene.interaction(&ray, &hit);
            // Surfaces are two-sided: shade on the side the ray arrived from.
            let Facing { wo, ng, ns, material } = facing(scene, &ray, &si, &mut ctx);
            let frame = Frame::from_normal(ns);
            let wo_local = frame.to_local(wo);
            if wo_local.z == 0.0 {
                break;
            }
            if material.bsdf.flags().smooth && depth < self.max_bounces {
                if let Some(c) =
                    connect_to_camera(scene, material.bsdf.as_ref(), &ctx, &frame, wo_local, si.p, ng, &mut f, rng)
                {
                    splats.push(Splat::new(pixel_of(&c), &f, &beta, c.importance));
                }
            }
            if depth + 1 >= self.max_bounces {
                break;
            }
            let Some(sc) = scatter(material.bsdf.as_ref(), &ctx, &frame, wo_local, si.p, ng, rng, &mut beta) else {
                break;
            };
            if !beta.is_finite() {
                break;
            }
            if let Some(i) = sc.sample.collapsed_to {
                ctx.single_wavelength = Some(i);
            }
            ray = sc.ray;
            depth += 1;
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
