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

/// How pixel samples and light paths are estimated for one render: the direction's
/// technique with the method's wavelength choice, built once by [`from_settings`] (the
/// pattern of pbrt-v4's `Create`), so the driver never looks at the settings per sample.
pub trait Technique: Send + Sync {
    /// Pixel samples trace camera paths (BACKWARD, BIDIRECTIONAL).
    fn traces_camera(&self) -> bool;
    /// Every sample pass also traces one light path per pixel, splatted onto the film
    /// (FORWARD, BIDIRECTIONAL).
    fn traces_light(&self) -> bool;
    /// How many times the pixel's sample count is taken: 1, or once per grid wavelength
    /// (MONOCHROMATIC_SCENES). The render's sample passes are numbered
    /// `0 .. rounds × samples`.
    fn rounds(&self) -> u32;
    /// One camera sample through film position `film` (pixels) of pixel `pixel` in sample
    /// pass `pass`; `rng` is the sample's own stream, the pixel jitter already drawn.
    #[allow(clippy::too_many_arguments)]
    fn camera_sample(
        &self,
        scene: &Scene,
        film: glam::Vec2,
        pixel: u64,
        pass: u32,
        rng: &mut Rng,
        out: &mut PixelSample,
        scratch: &mut monochromatic::Scratch,
    );
    /// One light path of sample pass `pass` from its own stream `rng`; pushes its splats
    /// (radiance at a pixel, to be divided by the light paths per pixel).
    fn light_path(&self, scene: &Scene, pass: u32, rng: &mut Rng, splats: &mut Vec<forward::Splat>);
}

/// The technique for `settings` on `scene` (a scene built for them), or an error naming
/// the setting that does not apply.
pub fn from_settings(scene: &Scene, settings: &crate::render::ResolvedSettings) -> crate::Result<Box<dyn Technique>> {
    use crate::render::{Direction, Method};
    use crate::Error;
    if settings.dispersion_splitting && settings.method != Method::Polychromatic {
        return Err(Error::setting("dispersion_splitting", "applies to the POLYCHROMATIC method only"));
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
    Ok(Box::new(Tracers::new(scene, settings)))
}

/// Every tracer of the earlier driver behind one [`Technique`] (a step of the redesign:
/// the method is still matched per sample here).
struct Tracers {
    method: crate::render::Method,
    backward: bool,
    forward: bool,
    mis: bool,
    samples: u32,
    seed: u64,
    n: usize,
    path: path::PathTracer,
    mono: monochromatic::MonochromaticTracer,
    light: forward::LightTracer,
    mis_camera: bidir::MisPathTracer,
    mis_light: bidir::MisLightTracer,
    lambda_dist: crate::sampling::Distribution1D,
}

impl Tracers {
    fn new(scene: &Scene, settings: &crate::render::ResolvedSettings) -> Self {
        use crate::render::{Direction, Method};
        Self {
            method: settings.method,
            backward: settings.direction != Direction::Forward,
            forward: settings.direction != Direction::Backward,
            // BIDIRECTIONAL with MIS for the whole-spectrum methods (bidir.rs); the
            // monochromatic methods keep the 0/1 partition.
            mis: settings.direction == Direction::Bidirectional
                && matches!(settings.method, Method::Polychromatic | Method::Rgb),
            samples: settings.samples,
            seed: settings.seed,
            n: scene.grid.len(),
            path: path::PathTracer {
                max_bounces: settings.max_bounces,
                dispersion_splitting: settings.dispersion_splitting,
                ..Default::default()
            },
            mono: monochromatic::MonochromaticTracer { max_bounces: settings.max_bounces, ..Default::default() },
            light: forward::LightTracer {
                max_bounces: settings.max_bounces,
                rr_depth: 3,
                part: if settings.direction == Direction::Forward {
                    forward::ForwardPart::All
                } else {
                    forward::ForwardPart::BackwardUnreachable
                },
            },
            mis_camera: bidir::MisPathTracer {
                max_bounces: settings.max_bounces,
                rr_depth: 3,
                dispersion_splitting: settings.dispersion_splitting,
            },
            mis_light: bidir::MisLightTracer { max_bounces: settings.max_bounces, rr_depth: 3 },
            lambda_dist: monochromatic::wavelength_distribution(scene),
        }
    }
}

impl Technique for Tracers {
    fn traces_camera(&self) -> bool {
        self.backward
    }
    fn traces_light(&self) -> bool {
        self.forward
    }
    fn rounds(&self) -> u32 {
        if self.method == crate::render::Method::MonochromaticScenes {
            self.n as u32
        } else {
            1
        }
    }
    fn camera_sample(
        &self,
        scene: &Scene,
        film: glam::Vec2,
        pixel: u64,
        pass: u32,
        rng: &mut Rng,
        ps: &mut PixelSample,
        scratch: &mut monochromatic::Scratch,
    ) {
        use crate::render::Method;
        let (fx, fy) = (film.x, film.y);
        match self.method {
            Method::Polychromatic | Method::Rgb if self.mis => self.mis_camera.sample(scene, fx, fy, rng, ps),
            Method::Polychromatic | Method::Rgb => self.path.sample(scene, fx, fy, rng, ps),
            Method::MonochromaticRays => {
                let lambda =
                    monochromatic::stratified_wavelength(&self.lambda_dist, self.seed, pixel, pass, self.samples);
                let l = self.mono.sample_camera(scene, fx, fy, lambda, rng, ps, scratch);
                ps.radiance.set(lambda, l / self.lambda_dist.pmf(lambda));
            }
            Method::MonochromaticScenes => {
                // Every wavelength gets all samples; averaging n·L over n·spp entries sums
                // the wavelengths.
                let round = (pass / self.samples) as usize;
                let l = self.mono.sample_camera(scene, fx, fy, round, rng, ps, scratch);
                ps.radiance.set(round, l * self.n as f32);
            }
        }
    }
    fn light_path(&self, scene: &Scene, pass: u32, rng: &mut Rng, splats: &mut Vec<forward::Splat>) {
        use crate::render::Method;
        let wavelength = match self.method {
            Method::Polychromatic | Method::Rgb => None,
            Method::MonochromaticRays => {
                let i = self.lambda_dist.sample(rng.uniform()).unwrap_or(0);
                Some((i, 1.0 / self.lambda_dist.pmf(i)))
            }
            Method::MonochromaticScenes => Some(((pass / self.samples) as usize, self.n as f32)),
        };
        if self.mis {
            self.mis_light.trace(scene, rng, splats);
        } else {
            self.light.trace(scene, rng, wavelength, splats);
        }
    }
}
