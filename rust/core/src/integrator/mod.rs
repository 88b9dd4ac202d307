//! Integrators: how a camera sample's radiance is estimated. One file per method.

pub mod bidir;
pub mod forward;
pub mod monochromatic;
pub mod path;

use crate::film::PixelSample;
use crate::sampling::Rng;
use crate::scene::Scene;

/// Estimates the radiance arriving through film position (x, y) in pixels.
pub trait Integrator: Sync {
    fn sample(&self, scene: &Scene, x: f32, y: f32, rng: &mut Rng, out: &mut PixelSample);
}

/// A path continued from a surface: the BSDF sample and the ray leaving the surface.
pub struct Scatter {
    pub sample: crate::material::BsdfSample,
    /// World-space direction of the new ray.
    pub wi: glam::Vec3A,
    /// The new ray leaves through the surface (below the geometric normal `ng`).
    pub transmitted: bool,
    pub ray: crate::geometry::Ray,
}

/// Samples `bsdf` at a hit (multiplying `throughput` by f·cos/pdf) and builds the ray
/// that continues the path, offset off the surface on the side it leaves from. `ng` is
/// the geometric normal facing the incoming ray. None when the BSDF absorbs the path or
/// when the sampled direction's side disagrees between the shading and the geometric
/// normal (following it would leak light through the surface). Every integrator
/// continues its paths through here, so they draw their random numbers alike.
#[allow(clippy::too_many_arguments)]
pub fn scatter(
    bsdf: &dyn crate::material::Bsdf,
    ctx: &crate::material::ShadingContext,
    frame: &crate::geometry::Frame,
    wo_local: glam::Vec3A,
    p: glam::Vec3A,
    ng: glam::Vec3A,
    rng: &mut Rng,
    throughput: &mut crate::spectrum::SampledSpectrum,
) -> Option<Scatter> {
    let u = rng.uniform2();
    let uc = rng.uniform();
    let sample = bsdf.sample(ctx, wo_local, u, uc, throughput)?;
    let wi = frame.to_world(sample.wi);
    let transmitted = wi.dot(ng) < 0.0;
    if (sample.wi.z * wo_local.z < 0.0) != transmitted {
        return None;
    }
    let origin = crate::geometry::offset_ray_origin(p, if transmitted { -ng } else { ng });
    Some(Scatter { sample, wi, transmitted, ray: crate::geometry::Ray::new(origin, wi) })
}

/// A hit seen from the side the ray arrived on: surfaces are two-sided, so normals are
/// flipped to face the incoming ray and the shading context learns which face it is.
pub struct Facing<'s> {
    /// Unit direction back along the ray.
    pub wo: glam::Vec3A,
    /// Geometric and shading normals, facing `wo`.
    pub ng: glam::Vec3A,
    pub ns: glam::Vec3A,
    pub material: &'s crate::material::Material,
}

/// Orients a hit towards the incoming ray and points `ctx` at it (uv, face).
pub fn facing<'s>(
    scene: &'s Scene,
    ray: &crate::geometry::Ray,
    si: &crate::scene::SurfaceInteraction,
    ctx: &mut crate::material::ShadingContext,
) -> Facing<'s> {
    let wo = -ray.direction;
    let front = si.ng.dot(wo) >= 0.0;
    ctx.uv = si.uv;
    ctx.front_face = front;
    Facing {
        wo,
        ng: if front { si.ng } else { -si.ng },
        ns: if front { si.ns } else { -si.ns },
        material: &scene.materials[si.material as usize],
    }
}
