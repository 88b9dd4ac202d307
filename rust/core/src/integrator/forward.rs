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
//! - Dispersive surfaces collapse the path to one wavelength (or end its secondary hero
//!   wavelengths) exactly as camera paths do.
//! - Subsurface lobes are walked as on camera paths (`walk.rs`): the light enters the
//!   lobe where it arrives, through the entry interface seen from the light's side, and
//!   the exit's white Lambertian connects to the camera. Cycles' random-walk BSSRDF is
//!   not reciprocal (the entry's 1 − E(μ) and its refraction are taken on the side the
//!   path arrives from, the exit is a plain cosine): light tracing estimates the same
//!   model with the roles of light and view swapped, equal to BACKWARD where the light
//!   and the view see the surface at similar angles (docs/materials.md).
//! - Lights at infinity (uniform and image environments, suns) start their paths as
//!   pbrt-v4's infinite lights: a direction from the light's own distribution, the
//!   origin on a disk of the scene's bounding radius perpendicular to it
//!   (`light::infinite_light_origin`). What the camera sees of them directly — the
//!   environment, or a sun's disk visible to the camera, behind its pixel — no light
//!   path can reach (the pinhole is a point): each pixel sample traces its camera ray
//!   up to the first surface for it ([`AlphaPath`]); a path of one segment, which no
//!   light path produces, so nothing is counted twice.
//! - Orthographic cameras are not reachable this way (no pinhole to connect to).

use super::throughput::Throughput;
use super::walk::{russian_roulette, End, PathHooks, PathState, Vertex, Walk};
use super::wavelengths::{WavelengthPolicy, Wavelengths};
use super::{Scatter, Scratch, Technique};
use crate::camera::CameraConnection;
use crate::geometry::{offset_ray_origin, visibility, Ray};
use crate::light::EmissionSample;
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
    /// (point, spot and parallel sun; not a sphere light or a sun with an angle, which
    /// camera paths reach) whose first scattering vertex is specular (caustics of point
    /// lights). Used by the
    /// BIDIRECTIONAL partition, whose other paths come from backward tracing.
    BackwardUnreachable,
}

/// One contribution of a light path to the film.
pub struct Splat {
    pub pixel: u32,
    pub radiance: SampledSpectrum,
}

/// The pixel a camera connection lands in.
pub fn pixel_of(scene: &Scene, c: &CameraConnection) -> u32 {
    let width = scene.camera.width();
    let x = (c.raster.x as u32).min(width - 1);
    let y = (c.raster.y as u32).min(scene.camera.height() - 1);
    y * width + x
}

/// Connects light-path vertex `v` to the camera (a point on its lens drawn from `rng`
/// when it has one). On success `f` holds f·|cos θ| towards the camera; None when the
/// normals disagree about the camera's side ([`super::connection_side`]), the BSDF
/// sends nothing that way, or something blocks the view.
pub fn connect_to_camera(
    scene: &Scene,
    v: &Vertex,
    ctx: &ShadingContext,
    f: &mut SampledSpectrum,
    rng: &mut Rng,
) -> Option<CameraConnection> {
    // What camera rays pass through, the camera does not see (nor is seen past); a
    // holdout object it sees holds out (black at alpha 0: `AlphaPath`).
    let inst = &scene.instances[v.si.instance as usize];
    if inst.holdout || !visibility::sees(inst.visibility, visibility::CAMERA) {
        return None;
    }
    let c = scene.camera.connect(v.si.p, v.si.time, rng)?;
    let wi_local = v.frame.to_local(c.wi);
    let side = super::connection_side(v.ng, v.wo_local, wi_local, c.wi)?;
    v.material.bsdf.eval(ctx, v.wo_local, wi_local, f);
    // Aimed from the offset origin at the camera: along c.wi from the unshifted point it
    // missed by the offset (16 units at 1e6) and hit walls behind it.
    let origin = offset_ray_origin(v.si.p, side);
    let ray = crate::geometry::shadow_ray(v.si.p, origin, c.wi, c.distance, v.si.time).with_kind(visibility::CAMERA);
    if f.is_black() || scene.occluded(&ray) {
        return None;
    }
    Some(c)
}

/// The start of a light path: the light chosen, its emission sample, the emitted
/// radiance on the path's wavelengths and the throughput leaving the light.
pub struct LightStart<T> {
    pub light: usize,
    /// Selection probability of the light (eq. 7).
    pub pmf: f32,
    pub es: EmissionSample,
    /// Emitted radiance along the ray, divided by the wavelengths' selection probability.
    pub le: T,
    /// `le·|cos|/(pmf·pdf_pos·pdf_dir)` (eq. 8).
    pub beta: T,
    pub state: PathState,
}

/// Chooses a light, samples a ray leaving it and the path's start on wavelengths `wl`;
/// None when no light can start a path.
pub fn start_light_path<W: Wavelengths>(scene: &Scene, wl: &W, rng: &mut Rng) -> Option<LightStart<W::Throughput>> {
    let light = scene.light_distribution.sample(rng.uniform())?;
    let pmf = scene.light_distribution.pmf(light);
    let (u_pos, u_dir) = (rng.uniform2(), rng.uniform2());
    let mut le = SampledSpectrum::zeros(scene.grid.len());
    // One shutter time for the whole light path (motion blur; none drawn when nothing
    // moves); a moving light starts it where it is then.
    let time = scene.camera.sample_light_path_time(rng);
    let es = scene.lights[light].sample_le_at(time, u_pos, u_dir, &mut le)?;
    if !(pmf > 0.0 && es.pdf_pos > 0.0 && es.pdf_dir > 0.0) {
        return None;
    }
    let le = wl.emitted(le);
    let cos0 = es.normal.map_or(1.0, |nl| nl.dot(es.direction).abs());
    let origin = match es.normal {
        Some(nl) => offset_ray_origin(es.origin, if nl.dot(es.direction) > 0.0 { nl } else { -nl }),
        None => es.origin,
    };
    // A light whose radiance depends on the receiver (a spot sphere's falloff from its
    // centre, as Cycles): the factor at the surface the first segment reaches. (A
    // see-through surface or a medium boundary on the way counts as that surface.)
    let first = if scene.lights[light].receiver_dependent() {
        let ray = Ray::new(origin, es.direction).with_time(time);
        let f = scene
            .intersect(&ray)
            .map_or(0.0, |h| scene.lights[light].receiver_factor_at(ray.origin + ray.direction * h.t, time));
        if !(f > 0.0) {
            return None;
        }
        f
    } else {
        1.0
    };
    let mut beta = le.clone();
    beta.scale(first * cos0 / (pmf * es.pdf_pos * es.pdf_dir));
    Some(LightStart {
        light,
        pmf,
        es,
        le,
        beta,
        state: PathState::start(Ray::new(origin, es.direction).with_time(time)),
    })
}

/// The light vertex itself seen by the camera (area lights; a lens point drawn from
/// `rng`): the connection and |cos| at the light towards it, or None when hidden or
/// impossible.
/// `time`: the light path's shutter time.
pub fn light_seen_by_camera(
    scene: &Scene,
    light: usize,
    es: &EmissionSample,
    time: f32,
    rng: &mut Rng,
) -> Option<(CameraConnection, f32)> {
    if es.delta_position || !visibility::sees(scene.light_visibility[light], visibility::CAMERA) {
        return None;
    }
    let c = scene.camera.connect(es.origin, time, rng);
    let (nl, c) = (es.normal?, c?);
    // A one-sided emitter is dark behind: it starts no ray towards the camera there.
    scene.lights[light].pdf_le_at(es.origin, c.wi, time)?;
    let cos = nl.dot(c.wi).abs();
    let origin = offset_ray_origin(es.origin, if nl.dot(c.wi) > 0.0 { nl } else { -nl });
    // Aimed from the offset origin at the camera: along c.wi from the unshifted point it
    // missed by the offset (16 units at 1e6) and hit walls behind it.
    let ray = crate::geometry::shadow_ray(es.origin, origin, c.wi, c.distance, time).with_kind(visibility::CAMERA);
    if cos > 0.0 && !scene.occluded(&ray) {
        Some((c, cos))
    } else {
        None
    }
}

/// A light path's context: importance transport on the path's wavelengths.
pub fn light_context<'s, W: Wavelengths>(scene: &'s Scene, wl: &W) -> ShadingContext<'s> {
    let mut ctx = ShadingContext::new(&scene.grid);
    ctx.mode = TransportMode::Importance;
    ctx.single_wavelength = wl.single();
    ctx
}

/// Walks a light path from `start`, continuing with one wavelength where it collapses.
#[allow(clippy::too_many_arguments)]
pub fn walk_light<T: Throughput, H: PathHooks<T> + PathHooks<super::throughput::SingleWavelength>>(
    scene: &Scene,
    walk: &Walk,
    ctx: &mut ShadingContext,
    start: PathState,
    mut beta: T,
    rng: &mut Rng,
    hooks: &mut H,
    scratch: &mut Scratch,
) {
    match walk.run(scene, ctx, start, &mut beta, rng, hooks, scratch) {
        End::Collapsed { index, state } => {
            let Some(mut b) = beta.collapse(index) else { return };
            // Light paths take Russian roulette at the collapse vertex too.
            if russian_roulette(&mut b, state.depth, walk.rr_depth, rng) {
                walk.run(scene, ctx, state, &mut b, rng, hooks, scratch);
            }
        }
        // Hero wavelengths: the secondary ones end at `v`, the hero scatters there alone.
        End::Terminated { index, vertex: v, state } => {
            let Some(mut b) = beta.collapse(index) else { return };
            ctx.single_wavelength = Some(index);
            let scattered = b.scatter(&v, ctx, rng, &mut scratch.tp);
            let entered = ctx.subsurface.take();
            let Some(sc) = scattered else { return };
            if let Some(ev) = entered {
                // Into a subsurface lobe at the hero wavelength: walk it, go on from the exit.
                let Some((exit, exit_state)) =
                    super::walk::walk_subsurface(scene, ctx, &v, &state, &sc, ev, &mut b, rng)
                else {
                    return;
                };
                <H as PathHooks<super::throughput::SingleWavelength>>::walked(hooks);
                walk.resume(scene, ctx, exit, exit_state, &mut b, rng, hooks, scratch);
                return;
            }
            if !(b.is_alive() && hooks.scattered(scene, ctx, &v, &state, &sc, &b)) {
                return;
            }
            let st = state.after(scene, &v, &sc, ctx.front_face);
            if russian_roulette(&mut b, st.depth, walk.rr_depth, rng) {
                walk.run(scene, ctx, st, &mut b, rng, hooks, scratch);
            }
        }
        End::Done | End::Split { .. } => {}
    }
}

/// The hooks of a light-tracing path: connect smooth vertices to the camera.
struct LightPath<'a> {
    part: ForwardPart,
    /// The path started at a delta-position light (point, spot, parallel sun).
    delta_light: bool,
    splats: &'a mut Vec<Splat>,
}

impl<T: Throughput> PathHooks<T> for LightPath<'_> {
    fn connect(
        &mut self,
        scene: &Scene,
        ctx: &mut ShadingContext,
        v: &Vertex,
        st: &PathState,
        beta: &T,
        rng: &mut Rng,
        scratch: &mut Scratch,
    ) {
        // A vertex at depth d makes a path of d + 1 scattering events.
        let keep = self.part == ForwardPart::All || st.depth >= 1;
        if keep && v.flags.smooth {
            if let Some(c) = connect_to_camera(scene, v, ctx, &mut scratch.f, rng) {
                self.splats.push(Splat { pixel: pixel_of(scene, &c), radiance: beta.times(&scratch.f, c.importance) });
            }
        }
    }
    fn scattered(
        &mut self,
        _scene: &Scene,
        _ctx: &mut ShadingContext,
        _v: &Vertex,
        st: &PathState,
        sc: &Scatter,
        _beta: &T,
    ) -> bool {
        // BIDIRECTIONAL partition: keep only caustic paths of delta lights (specular
        // first vertex); camera paths sample the rest.
        self.part == ForwardPart::All || st.depth > 0 || (self.delta_light && sc.sample.specular)
    }
}

/// FORWARD's pixel samples when the scene has holdouts, a transparent film or lights at
/// infinity: the camera ray alone, through see-through lights, up to the first surface.
/// It takes the alpha as camera paths do (Holdout closures and holdout objects at depth
/// 0, the background with Film > Transparent; `CameraPath::holdout`, `escaped`) and
/// gathers what the ray sees at infinity when it leaves the scene: the environment (as
/// BACKWARD's camera ray, weight 1) and a sun's disk when the sun is visible to the
/// camera. The light paths' splats are the rest of the image, black on a full holdout
/// since its closure reflects nothing and a holdout object is connected to no camera.
struct AlphaPath<'a, T> {
    transparent: f32,
    gathered: &'a mut T,
}

impl<T: Throughput> PathHooks<T> for AlphaPath<'_, T> {
    fn escaped(&mut self, scene: &Scene, st: &PathState, beta: &T, scratch: &mut Scratch) {
        if st.depth != 0 {
            return;
        }
        if scene.film_transparent {
            self.transparent += super::path::mean_throughput(beta);
            return;
        }
        if let Some(env) = &scene.environment {
            let l = env.radiance_along(st.ray.direction, &mut scratch.le);
            self.gathered.add_emitted(beta, l, 1.0);
        }
    }
    /// A sun's disk the camera ray leaves the scene in (sphere lights, at a finite
    /// distance, are the light paths' own vertices: not gathered here).
    fn segment_lights(
        &mut self,
        scene: &Scene,
        st: &PathState,
        end: f32,
        beta: &T,
        rng: &mut Rng,
        scratch: &mut Scratch,
    ) {
        if st.depth != 0 || end.is_finite() {
            return;
        }
        for &l in &scene.hit_lights {
            if !visibility::sees(scene.light_visibility[l], st.ray.kind) {
                continue;
            }
            let Some(t) = scene.lights[l].hit_at(st.ray.origin, st.ray.direction, st.ray.time, &mut scratch.le) else {
                continue;
            };
            if t.is_finite() || !beta.carries(&scratch.le) {
                continue;
            }
            // As camera paths do (path.rs): the media the ray crosses on its way out.
            if !st.media.is_empty() && scene.coefficients(&st.media, &mut scratch.shadow) {
                scene.segment_transmittance(&st.ray, &scratch.shadow, t, &mut scratch.le, rng);
            }
            self.gathered.add_emitted(beta, &scratch.le, 1.0);
        }
    }
    fn holdout(&mut self, weight: f32, beta: &T) -> bool {
        self.transparent += weight * super::path::mean_throughput(beta);
        true
    }
    fn connect(
        &mut self,
        _scene: &Scene,
        _ctx: &mut ShadingContext,
        _v: &Vertex,
        _st: &PathState,
        _beta: &T,
        _rng: &mut Rng,
        _scratch: &mut Scratch,
    ) {
    }
}

/// FORWARD (and the light side of the BIDIRECTIONAL partition): light paths, and for the
/// alpha of holdouts camera rays ([`AlphaPath`]).
pub struct LightTracing<P> {
    pub wavelengths: P,
    pub walk: Walk,
    pub part: ForwardPart,
}

impl<P: WavelengthPolicy> Technique for LightTracing<P> {
    fn camera_sample(
        &self,
        scene: &Scene,
        cs: super::CameraSample,
        rng: &mut Rng,
        out: &mut crate::film::PixelSample,
        scratch: &mut Scratch,
    ) {
        let Some(ray) = scene.camera.generate_pixel_ray(cs.film.x, cs.film.y, cs.row, rng) else { return };
        let wl = self.wavelengths.camera(cs.pixel, cs.pass);
        let mut ctx = ShadingContext::new(&scene.grid);
        ctx.single_wavelength = wl.single();
        let mut beta = wl.unit(scene.grid.len(), &mut scratch.spare);
        let mut gathered = beta.zero_like_in(&mut scratch.spare);
        let mut hooks = AlphaPath { transparent: 0.0, gathered: &mut gathered };
        let walk = Walk::camera(0, false);
        walk.run(scene, &mut ctx, PathState::start_in(ray, scene.camera_media), &mut beta, rng, &mut hooks, scratch);
        out.transparent = hooks.transparent;
        wl.resolve(&gathered, &mut out.radiance);
        gathered.recycle(&mut scratch.spare);
        beta.recycle(&mut scratch.spare);
    }
    fn light_path(&self, scene: &Scene, pass: u32, rng: &mut Rng, splats: &mut Vec<Splat>, scratch: &mut Scratch) {
        let wl = self.wavelengths.light(pass, rng);
        let Some(start) = start_light_path(scene, &wl, rng) else { return };
        if self.part == ForwardPart::All {
            if let Some((c, cos)) = light_seen_by_camera(scene, start.light, &start.es, start.state.ray.time, rng) {
                let radiance = start.le.scaled(scene.grid.len(), cos * c.importance / (start.pmf * start.es.pdf_pos));
                splats.push(Splat { pixel: pixel_of(scene, &c), radiance });
            }
        }
        let mut ctx = light_context(scene, &wl);
        let mut hooks = LightPath { part: self.part, delta_light: start.es.delta_position, splats };
        walk_light(scene, &self.walk, &mut ctx, start.state, start.beta, rng, &mut hooks, scratch);
    }
}
