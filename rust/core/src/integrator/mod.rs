//! Integrators: how pixel samples and light paths are estimated.
//!
//! A render's [`Technique`] (one per direction: `path.rs` BACKWARD, `forward.rs`
//! FORWARD, `bidir.rs` BIDIRECTIONAL) is built once by [`from_settings`] around the
//! method's wavelength policy (`wavelengths.rs`), so every method is a policy of the
//! same tracer. Camera and light paths all go through one walk (`walk.rs`) whose
//! per-vertex hooks are the technique's; what a path carries per wavelength is a
//! [`throughput::Throughput`]. Materials, lights and the camera are seen through their
//! narrow traits only.

pub mod bidir;
pub mod forward;
pub mod hero;
pub mod path;
pub mod throughput;
pub mod volume;
pub mod walk;
pub mod wavelengths;

use crate::film::PixelSample;
use crate::render::{Collapse, Direction, Method, ResolvedSettings};
use crate::sampling::Rng;
use crate::scene::Scene;
use crate::spectrum::SampledSpectrum;
use crate::Error;
use walk::Walk;
use wavelengths::{AllWavelengths, OnePerPass, OnePerRay, WavelengthPolicy};

/// A path continued from a surface: the BSDF sample and the ray leaving the surface.
pub struct Scatter {
    pub sample: crate::material::BsdfSample,
    /// World-space direction of the new ray.
    pub wi: glam::Vec3A,
    /// The new ray leaves through the surface (below the geometric normal `ng`).
    pub transmitted: bool,
    pub ray: crate::geometry::Ray,
}

/// Samples the BSDF at vertex `v` (multiplying `throughput` by f·cos/pdf) and builds the
/// ray that continues the path, offset off the surface on the side it leaves from. None
/// when the BSDF absorbs the path or when the sampled direction's side disagrees between
/// the shading and the geometric normal (following it would leak light through the
/// surface). Every path continues through here, so all draw their random numbers alike.
pub fn scatter(
    v: &walk::Vertex,
    ctx: &crate::material::ShadingContext,
    rng: &mut Rng,
    throughput: &mut SampledSpectrum,
) -> Option<Scatter> {
    let u = rng.uniform2();
    let uc = rng.uniform();
    let sample = v.material.bsdf.sample(ctx, v.wo_local, u, uc, throughput)?;
    let wi = v.frame.to_world(sample.wi);
    let transmitted = wi.dot(v.ng) < 0.0;
    if (sample.wi.z * v.wo_local.z < 0.0) != transmitted {
        return None;
    }
    let origin = crate::geometry::offset_ray_origin(v.si.p, if transmitted { -v.ng } else { v.ng });
    let kind = crate::geometry::visibility::of_bsdf_ray(transmitted, sample.specular, v.material.bsdf.lobe_kinds());
    let ray = crate::geometry::Ray::new(origin, wi).with_time(v.si.time).with_kind(kind);
    Some(Scatter { sample, wi, transmitted, ray })
}

/// The side of the surface a connection along world direction `wi` (`wi_local` in the
/// shading frame) leaves from: the normal to offset its shadow ray along, or None when
/// the geometric and the shading normal disagree about it (reflection must be above
/// both, transmission below both, as [`scatter`] requires of sampled directions; this
/// keeps light from leaking through closed opaque meshes while rough glass and
/// translucent surfaces are lit through).
#[inline]
pub fn connection_side(
    ng: glam::Vec3A,
    wo_local: glam::Vec3A,
    wi_local: glam::Vec3A,
    wi: glam::Vec3A,
) -> Option<glam::Vec3A> {
    let transmitted = wi.dot(ng) < 0.0;
    if wi.dot(ng) == 0.0 || (wi_local.z * wo_local.z < 0.0) != transmitted {
        return None;
    }
    Some(if transmitted { -ng } else { ng })
}

/// A hit seen from the side the ray arrived on: surfaces are two-sided, so normals are
/// flipped to face the incoming ray and the shading context learns which face it is.
pub struct Facing<'s> {
    /// Unit direction back along the ray.
    pub wo: glam::Vec3A,
    /// Geometric and shading normals, facing `wo` (`ns`: the Normal pass's).
    pub ng: glam::Vec3A,
    pub ns: glam::Vec3A,
    pub material: &'s crate::material::Material,
    /// The shading frame the BSDF sees directions in: about `ns`, or about `ng` when
    /// the material's closures carry their own normals.
    pub frame: crate::geometry::Frame,
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
    let material = &scene.materials[si.material as usize];
    if let Some(requests) = &material.hit_attributes {
        ctx.hit = scene.shading_point(ray, si, requests);
    }
    let ng = if front { si.ng } else { -si.ng };
    let mut ns = if front { si.ns } else { -si.ns };
    let mut frame_normal = ns;
    if let Some(n) = &material.normal {
        // A graph with linked normals: each closure is shaded about its own normal
        // (material::Oriented, placed by closure::Orient when the hit's BSDF is built),
        // in a frame about ng, so which side a direction is on is decided by ng as in
        // Cycles' bsdf_eval/bsdf_sample. The Normal pass reads the first linked normal,
        // made valid as Cycles makes the specular closures' (ensure_valid_specular_reflection,
        // bsdf_util.h).
        let n = glam::Vec3A::from(n.at(&ctx.hit));
        ns =
            glam::Vec3A::from(crate::shading::vector::ensure_valid_specular_reflection(ng.into(), wo.into(), n.into()));
        frame_normal = ng;
    }
    let frame = crate::geometry::Frame::from_normal(frame_normal);
    ctx.frame = frame;
    Facing { wo, ng, ns, material, frame }
}

/// How pixel samples and light paths are estimated: the direction's technique on the
/// method's wavelength policy. A technique implements the estimates its [`Integrator`]
/// asks for (the other one is never called).
pub trait Technique: Send + Sync {
    /// One camera sample; `rng` is the sample's own stream, the pixel jitter already
    /// drawn. Fills `out` (zeroed by the caller).
    fn camera_sample(
        &self,
        _scene: &Scene,
        _sample: CameraSample,
        _rng: &mut Rng,
        _out: &mut PixelSample,
        _scratch: &mut Scratch,
    ) {
    }
    /// One light path of sample pass `pass` from its own stream `rng`; pushes its splats
    /// (radiance at a pixel, to be divided by the light paths per pixel).
    fn light_path(
        &self,
        _scene: &Scene,
        _pass: u32,
        _rng: &mut Rng,
        _splats: &mut Vec<forward::Splat>,
        _scratch: &mut Scratch,
    ) {
    }
}

/// Which camera sample to take.
#[derive(Clone, Copy, Debug)]
pub struct CameraSample {
    /// Film position in pixels (the pixel's corner plus its jitter).
    pub film: glam::Vec2,
    /// Row-major pixel index.
    pub pixel: u64,
    /// The pixel's full-frame row from the top (its rolling-shutter time).
    pub row: u32,
    /// Sample pass (see [`Integrator::rounds`]).
    pub pass: u32,
}

/// Grid-wide scratch spectra that BSDFs and lights write into, reused across the paths
/// a worker traces.
pub struct Scratch {
    /// BSDF values.
    pub f: SampledSpectrum,
    /// Light radiance.
    pub le: SampledSpectrum,
    /// A single-wavelength path's throughput spread over the grid for `Bsdf::sample`.
    pub tp: SampledSpectrum,
    /// The coefficients of the media around the path's current segment.
    pub medium: crate::scene::media::Coefficients,
    /// The same along a shadow ray.
    pub shadow: crate::scene::media::Coefficients,
    /// A segment's emission, a shadow ray's transmittance, phase weights.
    pub em: SampledSpectrum,
    pub tr: SampledSpectrum,
    pub phase: SampledSpectrum,
    /// Storage of camera paths' throughput and gathered radiance, reused path to path.
    pub spare: throughput::Spare,
    /// The stratum of the sample being traced (set by the driver: camera samples by
    /// pixel and pass, light paths by pass and index), for COLLAPSE STRATIFIED and SPLIT.
    pub strata: Option<crate::sampling::Strata>,
}

impl Scratch {
    pub fn new(n: usize) -> Self {
        let z = || SampledSpectrum::zeros(n);
        Self {
            f: z(),
            le: z(),
            tp: z(),
            medium: crate::scene::media::Coefficients::new(n),
            shadow: crate::scene::media::Coefficients::new(n),
            em: z(),
            tr: z(),
            phase: z(),
            spare: throughput::Spare::default(),
            strata: None,
        }
    }
}

/// A render's estimator, built once by [`from_settings`] (the pattern of pbrt-v4's
/// `Create`), so the driver never looks at the settings per sample.
pub struct Integrator {
    pub technique: Box<dyn Technique>,
    /// Pixel samples trace camera paths (BACKWARD, BIDIRECTIONAL; FORWARD: camera rays
    /// for the alpha of holdouts and a transparent film, and for the environment and
    /// a sun's disk seen directly, when the scene has them).
    pub camera_paths: bool,
    /// Every sample pass also traces one light path per pixel, splatted onto the film
    /// (FORWARD, BIDIRECTIONAL).
    pub light_paths: bool,
    /// How many times the pixel's sample count is taken: 1, or once per grid wavelength
    /// (MONOCHROMATIC_SCENES). A render's sample passes are numbered
    /// `0 .. rounds × samples`.
    pub rounds: u32,
}

/// The integrator for `settings` on `scene` (a scene built for them), or an error naming
/// the setting that does not apply.
pub fn from_settings(scene: &Scene, settings: &ResolvedSettings) -> crate::Result<Integrator> {
    if settings.dispersion_splitting && settings.method != Method::Polychromatic {
        return Err(Error::setting("dispersion_splitting", "applies to the POLYCHROMATIC method only"));
    }
    // dispersion_splitting (into every wavelength) overrides AUTO.
    if settings.dispersion_splitting && !matches!(settings.collapse, Collapse::Auto | Collapse::Energy) {
        return Err(Error::setting(
            "dispersion_splitting",
            format!(
                "splits into every wavelength and cannot be combined with collapse {} (use collapse SPLIT with collapse_k for k wavelengths)",
                settings.collapse.name()
            ),
        ));
    }
    // SPLIT divides a polychromatic ray's energy among k wavelengths; HERO ends its
    // secondary wavelengths at a dispersive surface instead and RGB collapses to one
    // channel, so an explicit SPLIT there would be silently ignored.
    if settings.collapse == Collapse::Split && settings.method != Method::Polychromatic {
        return Err(Error::setting("collapse", "SPLIT applies to the POLYCHROMATIC method only"));
    }
    if settings.method == Method::Rgb && scene.grid.len() != 3 {
        return Err(Error::setting("method", "RGB needs the three-channel grid"));
    }
    if settings.direction == Direction::Forward && !scene.camera.is_perspective() {
        return Err(Error::setting(
            "direction",
            "FORWARD (light tracing) needs a perspective camera: light paths cannot connect to an orthographic or panoramic one",
        ));
    }
    if settings.direction != Direction::Backward && scene.has_media() {
        let m = scene.media.first().map_or("a null surface", |m| m.name.as_str());
        return Err(Error::setting(
            "direction",
            format!(
                "participating media are rendered by BACKWARD only for now ('{m}' has a volume, no surface or transparency)"
            ),
        ));
    }
    let mut integrator = match settings.method {
        Method::Polychromatic | Method::Rgb => with_policy(settings, AllWavelengths),
        Method::MonochromaticRays => with_policy(settings, OnePerRay::new(scene, settings.seed, settings.samples)),
        Method::MonochromaticScenes => with_policy(settings, OnePerPass::new(scene.grid.len(), settings.samples)),
        Method::Hero => with_policy(settings, hero::HeroWavelengths::new(&scene.grid, settings.seed)),
    };
    if settings.direction == Direction::Forward && (scene.has_holdouts() || scene.sees_infinity()) {
        // Light tracing has no camera paths to take the alpha from, nor any that reach
        // what the camera sees at infinity (the environment, a sun's disk): each pixel
        // sample traces its camera ray up to the first surface for them
        // (forward::AlphaPath).
        integrator.camera_paths = true;
    }
    Ok(integrator)
}

/// The direction's technique on wavelengths `policy`.
fn with_policy<P: WavelengthPolicy>(settings: &ResolvedSettings, policy: P) -> Integrator {
    // The wavelength choice at a dispersive surface (eq. 9). Light paths never split.
    let collapse = match settings.collapse {
        Collapse::Auto if settings.dispersion_splitting => Collapse::Energy,
        c => c.resolved(),
    };
    // SPLIT is a POLYCHROMATIC choice (HERO ends its secondary wavelengths at a
    // dispersive surface instead; RGB collapses to one of its three channels).
    let split_k =
        (collapse == Collapse::Split && settings.method == Method::Polychromatic).then_some(settings.collapse_k);
    let split = settings.dispersion_splitting || split_k.is_some();
    let camera = Walk {
        medium_sampling: settings.medium_sampling,
        split_k: split_k.filter(|_| !settings.dispersion_splitting),
        stratified_collapse: collapse == Collapse::Stratified,
        // Subsurface random walks on camera and light paths (bidirectional MIS weighs
        // walked paths by the 0/1 partition: `PathHooks::walked`).
        subsurface: true,
        light_tree: settings.light_tree,
        ..Walk::camera(settings.max_bounces, split)
    };
    let light = Walk {
        stratified_collapse: collapse != Collapse::Energy,
        subsurface: true,
        ..Walk::light(settings.max_bounces)
    };
    let rounds = policy.rounds();
    let backward = path::PathTracing { wavelengths: policy.clone(), walk: camera };
    let forward = |part| forward::LightTracing { wavelengths: policy.clone(), walk: light, part };
    let technique: Box<dyn Technique> = match settings.direction {
        Direction::Backward => Box::new(backward),
        Direction::Forward => Box::new(forward(forward::ForwardPart::All)),
        // MIS needs both sides on the same wavelengths: whole-spectrum paths. The
        // single-wavelength methods keep the 0/1 partition.
        Direction::Bidirectional if matches!(settings.method, Method::Polychromatic | Method::Rgb) => {
            Box::new(bidir::Bidirectional { wavelengths: policy.clone(), camera, light })
        }
        Direction::Bidirectional => {
            Box::new(bidir::Partition { camera: backward, light: forward(forward::ForwardPart::BackwardUnreachable) })
        }
    };
    Integrator {
        technique,
        camera_paths: settings.direction != Direction::Forward,
        light_paths: settings.direction != Direction::Backward,
        rounds,
    }
}
