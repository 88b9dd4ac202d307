//! The one path walk that camera and light paths share (the shape of pbrt-v4's
//! `RandomWalk` and of Mitsuba 3's path integrator): intersect → orient the hit → let
//! the technique gather and connect there → sample the BSDF → Russian roulette, until
//! the path escapes, is absorbed or ends.
//!
//! What differs between techniques lives in [`PathHooks`]: camera paths gather emission
//! and connect to lights (next-event estimation with MIS), light paths connect to the
//! camera and splat, bidirectional MIS records the vertices it weighs. Where a
//! whole-spectrum path meets a dispersive surface the walk returns to its caller
//! ([`End::Collapsed`], [`End::Split`]), which carries on with one wavelength per path
//! (eq. 9) — with the same or other hooks. Inside media (docs/media.md) each segment
//! is a free flight first (`volume.rs`): it may scatter the path in the medium (a
//! medium vertex, connected by [`PathHooks::connect_medium`]) or collapse it (eq. 9);
//! null surfaces (a medium's boundary) are passed straight through.

use super::throughput::Throughput;
use super::volume::{self, Flight};
use super::{facing, Facing, Scatter, Scratch};
use crate::geometry::{offset_ray_origin, Frame, Ray};
use crate::material::subsurface::SubsurfaceEvent;
use crate::material::{BsdfFlags, Material, ShadingContext};
use crate::medium::{Boundary, MediumStack, SubsurfaceMedium};
use crate::render::MediumSampling;
use crate::sampling::Rng;
use crate::scene::media::VOLUME_BOUNDS_MAX;
use crate::scene::{Scene, SurfaceInteraction};
use crate::spectrum::SampledSpectrum;
use glam::Vec3A;

/// Where a path is: the ray it follows and what MIS needs of the vertex it left.
#[derive(Clone, Copy, Debug)]
pub struct PathState {
    pub ray: Ray,
    /// The last scattering was specular (or `ray` is the camera ray): no MIS on what the
    /// ray hits.
    pub specular: bool,
    /// Solid-angle pdf of the last BSDF sample, for MIS on emission hit next.
    pub prev_pdf: f32,
    /// The vertex `ray` left.
    pub prev_p: Vec3A,
    /// Scattering events so far.
    pub depth: u32,
    /// The media `ray` travels in.
    pub media: MediumStack,
    /// Distance from `prev_p` to `ray`'s origin (null surfaces passed on the way), for
    /// the light pdf of emission that `ray` reaches.
    pub traveled: f32,
}

impl PathState {
    /// A path starting along `ray` (from the camera or a light) outside every medium;
    /// [`Self::start_in`] inside some.
    pub fn start(ray: Ray) -> Self {
        Self {
            ray,
            specular: true,
            prev_pdf: 0.0,
            prev_p: ray.origin,
            depth: 0,
            media: MediumStack::default(),
            traveled: 0.0,
        }
    }

    /// A path starting along `ray` inside `media` (the camera's: [`Scene::camera_media`]).
    pub fn start_in(ray: Ray, media: MediumStack) -> Self {
        Self { media, ..Self::start(ray) }
    }

    /// The state after the BSDF at `v` (reached with `self`) was sampled (`sc`): a
    /// transmitted path enters or leaves the medium of `v`'s material (`front_face`: it
    /// arrived from outside).
    pub fn after(&self, scene: &Scene, v: &Vertex, sc: &Scatter, front_face: bool) -> Self {
        let mut media = self.media;
        if sc.transmitted && scene.material_medium.get(v.si.material as usize).is_some_and(|m| m.is_some()) {
            media.cross(v.si.instance, v.si.material, front_face);
        }
        PathState {
            ray: sc.ray,
            specular: sc.sample.specular,
            prev_pdf: sc.sample.pdf,
            prev_p: v.si.p,
            depth: self.depth + 1,
            media,
            traveled: 0.0,
        }
    }
}

/// A scattering point inside a medium, as the hooks see it.
#[derive(Clone, Copy, Debug)]
pub struct MediumVertex {
    pub p: Vec3A,
    /// Unit direction back along the arriving ray.
    pub wo: Vec3A,
    pub time: f32,
}

/// A surface vertex as the hooks see it: the hit oriented towards the arriving ray.
#[derive(Clone, Copy)]
pub struct Vertex<'s> {
    pub si: SurfaceInteraction,
    /// Unit direction back along the arriving ray.
    pub wo: Vec3A,
    /// Geometric and shading normals, facing `wo`.
    pub ng: Vec3A,
    pub ns: Vec3A,
    pub material: &'s Material,
    /// The shading frame about `ns`, and `wo` in it.
    pub frame: Frame,
    pub wo_local: Vec3A,
    pub flags: BsdfFlags,
}

/// Why [`Walk::run`] returned.
pub enum End<'s> {
    /// The path is finished: escaped, absorbed, terminated or at its bounce limit.
    Done,
    /// The BSDF collapsed the path to grid wavelength `index` (eq. 9; the throughput
    /// keeps that sample only, already divided by its probability). Continue it from
    /// `state` with that wavelength's [`super::throughput::SingleWavelength`].
    Collapsed { index: usize, state: PathState },
    /// Dispersion splitting: the path reached dispersive `vertex` (with `state`, before
    /// sampling there). Continue one single-wavelength sub-path per wavelength.
    Split { vertex: Vertex<'s>, state: PathState },
    /// Hero wavelengths: the path reached dispersive `vertex` (before sampling there),
    /// where its secondary wavelengths end. Continue the hero, grid wavelength `index`,
    /// alone from `vertex` ([`Throughput::collapse`]), scattering it there.
    Terminated { index: usize, vertex: Vertex<'s>, state: PathState },
}

/// What a technique does at the steps of a walk. Every method sees the throughput
/// `beta` of the path so far (up to, not including, the vertex's own scattering).
pub trait PathHooks<T: Throughput> {
    /// The path left the scene along `st.ray`.
    fn escaped(&mut self, _scene: &Scene, _st: &PathState, _beta: &T, _scratch: &mut Scratch) {}
    /// The path reached `v`: emission, first-hit passes. Draws no random numbers.
    fn reached(
        &mut self,
        _scene: &Scene,
        _ctx: &mut ShadingContext,
        _v: &Vertex,
        _st: &PathState,
        _beta: &T,
        _scratch: &mut Scratch,
    ) {
    }
    /// Russian roulette ended the path: in expectation what it would have gathered on is
    /// carried by the paths that survived (divided by their survival probability).
    fn rouletted(&mut self) {}
    /// The path, with only transparent bounces so far, reached Holdout closures of
    /// summed weight `weight` (0..1; the scene's `Holdout`). True when the hooks applied
    /// it (camera paths: the pixel's alpha), and then a full holdout ends the path.
    fn holdout(&mut self, _weight: f32, _beta: &T) -> bool {
        false
    }
    /// The path entered a subsurface lobe at the vertex it last reached and left the
    /// mesh at the exit vertex it goes on from (`subsurface_exit`). The walk between has
    /// no density the other direction could evaluate: bidirectional MIS weighs what
    /// follows by the 0/1 partition of dispersive paths.
    fn walked(&mut self) {}
    /// The path passed through see-through emitter `v` (`Material::see_through`, a
    /// light's surface): gather its emission; the ray goes on behind it. Draws no random
    /// numbers.
    fn passed_emitter(&mut self, _scene: &Scene, _ctx: &mut ShadingContext, _v: &Vertex, _st: &PathState, _beta: &T) {}
    /// Connects `v` to a light (camera paths: next-event estimation) or to the camera
    /// (light paths); may draw random numbers.
    #[allow(clippy::too_many_arguments)]
    fn connect(
        &mut self,
        scene: &Scene,
        ctx: &mut ShadingContext,
        v: &Vertex,
        st: &PathState,
        beta: &T,
        rng: &mut Rng,
        scratch: &mut Scratch,
    );
    /// The BSDF at `v` was sampled (`sc`; `beta` now includes it; a collapse has set
    /// `ctx.single_wavelength` already). Records the vertex; false ends the path.
    fn scattered(
        &mut self,
        _scene: &Scene,
        _ctx: &mut ShadingContext,
        _v: &Vertex,
        _st: &PathState,
        _sc: &Scatter,
        _beta: &T,
    ) -> bool {
        true
    }
    /// The segment `st.ray` travels, up to distance `end` (the next surface; infinite
    /// when it leaves the scene), may reach lights that are no geometry
    /// ([`Scene::hit_lights`]: sphere lights on the way, a sun's disk when it escapes).
    /// Called once per segment, before its free flight in media. Draws random numbers
    /// only in grid media (their ratio-tracking transmittance).
    fn segment_lights(
        &mut self,
        _scene: &Scene,
        _st: &PathState,
        _end: f32,
        _beta: &T,
        _rng: &mut Rng,
        _scratch: &mut Scratch,
    ) {
    }
    /// The segment `st.ray` travels emits `e` (per grid lane, already integrated over
    /// the segment's transmittance) towards its start.
    fn medium_emission(&mut self, _scene: &Scene, _st: &PathState, _beta: &T, _e: &SampledSpectrum) {}
    /// Connects medium vertex `mv` inside `st.media` to a light (camera paths);
    /// `scratch.medium` holds the media's coefficients there.
    #[allow(clippy::too_many_arguments)]
    fn connect_medium(
        &mut self,
        _scene: &Scene,
        _ctx: &mut ShadingContext,
        _mv: &MediumVertex,
        _st: &PathState,
        _beta: &T,
        _rng: &mut Rng,
        _scratch: &mut Scratch,
    ) {
    }
}

/// How far a walk goes.
#[derive(Clone, Copy, Debug)]
pub struct Walk {
    /// Scattering events after which a path ends (0: direct emission only).
    pub max_bounces: u32,
    /// Bounces before Russian roulette may end a path.
    pub rr_depth: u32,
    /// A vertex scatters only below this depth: `max_bounces` for camera paths (the next
    /// vertex's emission still counts), one less for light paths (a light-path vertex at
    /// depth d connects to the camera as a path of d + 1 scattering events).
    pub scatter_below: u32,
    /// Deterministic mode: stop at the first dispersive surface of a whole-spectrum
    /// path ([`End::Split`]) instead of letting the BSDF collapse it.
    pub split_dispersion: bool,
    /// With `split_dispersion`: continue `k` wavelengths stratified over the energy CDF
    /// (each weighted 1/(k·p)) instead of every wavelength (COLLAPSE SPLIT).
    pub split_k: Option<u32>,
    /// The BSDF's collapse draws its uniform number from [`Scratch::strata`] (the
    /// sample's stratum, dimension = the vertex's depth) instead of the path's random
    /// stream (COLLAPSE STRATIFIED).
    pub stratified_collapse: bool,
    /// How whole-spectrum paths sample distances in scattering media.
    pub medium_sampling: MediumSampling,
    /// Subsurface lobes are walked (`medium::random_walk`) by camera and light paths
    /// alike, until a path has left one walk; else they act as a diffuse of their base
    /// colour.
    pub subsurface: bool,
    /// Camera paths take their light samples from the light tree (the point's own
    /// choice) instead of eq. 7's choice ∝ power alone (`light::tree`).
    pub light_tree: bool,
}

/// Bounces before Russian roulette may end a path.
pub const RR_DEPTH: u32 = 3;

impl Walk {
    /// Camera paths of `max_bounces` scattering events.
    pub fn camera(max_bounces: u32, split_dispersion: bool) -> Self {
        Self {
            max_bounces,
            rr_depth: RR_DEPTH,
            scatter_below: max_bounces,
            split_dispersion,
            split_k: None,
            stratified_collapse: false,
            medium_sampling: MediumSampling::default(),
            subsurface: false,
            light_tree: true,
        }
    }
    /// Light paths whose camera connections have at most `max_bounces` scattering events.
    pub fn light(max_bounces: u32) -> Self {
        Self {
            max_bounces,
            rr_depth: RR_DEPTH,
            scatter_below: max_bounces.saturating_sub(1),
            split_dispersion: false,
            split_k: None,
            stratified_collapse: false,
            medium_sampling: MediumSampling::default(),
            subsurface: false,
            light_tree: true,
        }
    }

    /// Walks a path from `st` with throughput `beta` (updated as it goes).
    #[allow(clippy::too_many_arguments)]
    pub fn run<'s, T: Throughput, H: PathHooks<T>>(
        &self,
        scene: &'s Scene,
        ctx: &mut ShadingContext,
        st: PathState,
        beta: &mut T,
        rng: &mut Rng,
        hooks: &mut H,
        scratch: &mut Scratch,
    ) -> End<'s> {
        if !self.subsurface {
            ctx.subsurface_walk = false;
        } else if st.depth == 0 {
            ctx.subsurface_walk = true;
        }
        self.walk_from(scene, ctx, st, None, beta, rng, hooks, scratch)
    }

    /// Goes on from the exit vertex `v` of a subsurface walk (reached with `st`, as
    /// [`subsurface_exit`] returns them) that a single-wavelength continuation entered
    /// outside [`Self::run`]: `v` connects and scatters as a walk's exit in `run` does.
    #[allow(clippy::too_many_arguments)]
    pub fn resume<'s, T: Throughput, H: PathHooks<T>>(
        &self,
        scene: &'s Scene,
        ctx: &mut ShadingContext,
        v: Vertex<'s>,
        st: PathState,
        beta: &mut T,
        rng: &mut Rng,
        hooks: &mut H,
        scratch: &mut Scratch,
    ) -> End<'s> {
        ctx.subsurface_walk = false;
        self.walk_from(scene, ctx, st, Some(v), beta, rng, hooks, scratch)
    }

    #[allow(clippy::too_many_arguments)]
    fn walk_from<'s, T: Throughput, H: PathHooks<T>>(
        &self,
        scene: &'s Scene,
        ctx: &mut ShadingContext,
        mut st: PathState,
        mut start: Option<Vertex<'s>>,
        beta: &mut T,
        rng: &mut Rng,
        hooks: &mut H,
        scratch: &mut Scratch,
    ) -> End<'s> {
        let media = scene.has_media();
        let mut crossings = 0;
        loop {
            let mut v = match start.take() {
                Some(v) => v,
                None => {
                    let hit = scene.intersect(&st.ray);
                    let d = hit.as_ref().map_or(f32::INFINITY, |h| h.t);
                    let in_medium = media && !st.media.is_empty() && scene.coefficients(&st.media, &mut scratch.medium);
                    // Grid media: spectral tracking over every carried lane, never a collapse.
                    let grids = in_medium && scratch.medium.grid_count > 0;
                    if in_medium && !grids && ctx.single_wavelength.is_none() {
                        let c = &scratch.medium;
                        if let Some(index) = volume::collapse(c, beta, self.medium_sampling, scene.grid.weights(), rng)
                        {
                            ctx.single_wavelength = Some(index);
                            return End::Collapsed { index, state: st };
                        }
                    }
                    if !scene.hit_lights.is_empty() {
                        // Before the flight changes beta: what the segment reaches of them is
                        // weighted by the media's transmittance up to them.
                        hooks.segment_lights(scene, &st, d, beta, rng, scratch);
                    }
                    if in_medium {
                        if scratch.medium.emits {
                            volume::segment_emission(&scratch.medium, d, &mut scratch.em);
                            hooks.medium_emission(scene, &st, beta, &scratch.em);
                        }
                        let flight = if grids {
                            scene.fly_grids(&st.ray, &scratch.medium, d, beta, rng, &mut scratch.tr)
                        } else {
                            volume::fly(&scratch.medium, d, beta, rng)
                        };
                        match flight {
                            Flight::Absorbed => return End::Done,
                            Flight::Through => {}
                            Flight::Scattered { t } => {
                                let p = st.ray.at(t);
                                if grids {
                                    // The coefficients there: the phase functions and the
                                    // connection see the grids' density at p.
                                    scene.coefficients_at(&st.media, p, st.ray.time, &mut scratch.medium);
                                }
                                let mv = MediumVertex { p, wo: -st.ray.direction, time: st.ray.time };
                                if st.depth >= self.max_bounces {
                                    return End::Done;
                                }
                                rng.start_vertex();
                                hooks.connect_medium(scene, ctx, &mv, &st, beta, rng, scratch);
                                if st.depth >= self.scatter_below {
                                    return End::Done;
                                }
                                let (u, uc) = (rng.uniform2(), rng.uniform());
                                let Some((wi, pdf)) = scene.sample_phase(
                                    &st.media,
                                    &scratch.medium,
                                    st.ray.direction,
                                    u,
                                    uc,
                                    &mut scratch.phase,
                                ) else {
                                    return End::Done;
                                };
                                if scratch.medium.scattering_media > 1 {
                                    for j in 0..beta.lanes() {
                                        beta.set_lane(j, beta.lane(j) * scratch.phase.get(beta.lane_index(j)));
                                    }
                                }
                                st = PathState {
                                    ray: Ray::new(p, wi).with_time(st.ray.time),
                                    specular: false,
                                    prev_pdf: pdf,
                                    prev_p: p,
                                    depth: st.depth + 1,
                                    media: st.media,
                                    traveled: 0.0,
                                };
                                if !beta.is_alive() {
                                    return End::Done;
                                }
                                if !russian_roulette(beta, st.depth, self.rr_depth, rng) {
                                    hooks.rouletted();
                                    return End::Done;
                                }
                                continue;
                            }
                        }
                    }
                    let Some(hit) = hit else {
                        hooks.escaped(scene, &st, beta, scratch);
                        return End::Done;
                    };
                    let si = scene.interaction(&st.ray, &hit);
                    if scene.materials[si.material as usize].see_through {
                        // A light's surface as Cycles has it: its emission is gathered and the ray
                        // carries on behind it (a transparent bounce, no scattering).
                        crossings += 1;
                        if crossings > VOLUME_BOUNDS_MAX {
                            return End::Done;
                        }
                        let Facing { wo, ng, ns, material, frame } = facing(scene, &st.ray, &si, ctx);
                        let v = Vertex {
                            si,
                            wo,
                            ng,
                            ns,
                            material,
                            frame,
                            wo_local: frame.to_local(wo),
                            flags: material.bsdf.flags(),
                        };
                        hooks.passed_emitter(scene, ctx, &v, &st, beta);
                        let front = si.ng.dot(st.ray.direction) < 0.0;
                        let origin = offset_ray_origin(si.p, if front { -si.ng } else { si.ng });
                        st.traveled += (origin - st.ray.origin).length();
                        st.ray = Ray { origin, tmin: 0.0, tmax: f32::INFINITY, ..st.ray };
                        continue;
                    }
                    if media && scene.null_surface[si.material as usize] {
                        // A medium's boundary with no surface: pass straight through (no bounce,
                        // as Cycles' volume-only surfaces), entering or leaving the medium.
                        crossings += 1;
                        if crossings > VOLUME_BOUNDS_MAX {
                            return End::Done;
                        }
                        let front = si.ng.dot(st.ray.direction) < 0.0;
                        if scene.material_medium[si.material as usize].is_some() {
                            st.media.cross(si.instance, si.material, front);
                        }
                        let origin = offset_ray_origin(si.p, if front { -si.ng } else { si.ng });
                        st.traveled += (origin - st.ray.origin).length();
                        st.ray = Ray { origin, tmin: 0.0, tmax: f32::INFINITY, ..st.ray };
                        continue;
                    }
                    if let Some(pt) = scene.pass_through[si.material as usize].as_ref().filter(|_| media) {
                        // Stochastic transparency (Cycles' transparent closure): pass straight on
                        // with the Transparent BSDF's weight, tinted; else shade the opaque rest,
                        // whose weight 1 − p this choice cancels.
                        let p = pt.probability_at(scene, &st.ray, &si);
                        if p >= 1.0 || (p > 0.0 && rng.uniform() < p) {
                            crossings += 1;
                            if crossings > VOLUME_BOUNDS_MAX {
                                return End::Done;
                            }
                            for j in 0..beta.lanes() {
                                let v = beta.lane(j) * pt.tint.get(beta.lane_index(j));
                                beta.set_lane(j, v);
                            }
                            if !beta.is_alive() {
                                return End::Done;
                            }
                            let front = si.ng.dot(st.ray.direction) < 0.0;
                            let origin = offset_ray_origin(si.p, if front { -si.ng } else { si.ng });
                            st.traveled += (origin - st.ray.origin).length();
                            st.ray = Ray { origin, tmin: 0.0, tmax: f32::INFINITY, ..st.ray };
                            continue;
                        }
                    }
                    if st.depth == 0 {
                        // A holdout object holds out wholly (Cycles' `surface_shader_apply_holdout`
                        // on SD_OBJECT_HOLDOUT_MASK: weight 1, its transparency passed above kept).
                        let w = if scene.instances[si.instance as usize].holdout {
                            1.0
                        } else {
                            scene.holdout[si.material as usize]
                                .as_ref()
                                .map_or(0.0, |h| h.weight_at(scene, &st.ray, &si))
                        };
                        if w > 0.0 && hooks.holdout(w, beta) && w >= 1.0 {
                            return End::Done;
                        }
                    }
                    // Surfaces are two-sided: shade on the side the ray arrived from.
                    let Facing { wo, ng, ns, material, frame } = facing(scene, &st.ray, &si, ctx);
                    let v = Vertex {
                        si,
                        wo,
                        ng,
                        ns,
                        material,
                        frame,
                        wo_local: frame.to_local(wo),
                        flags: material.bsdf.flags(),
                    };
                    hooks.reached(scene, ctx, &v, &st, beta, scratch);
                    if st.depth >= self.max_bounces || v.wo_local.z == 0.0 {
                        return End::Done;
                    }
                    v
                }
            };
            // The vertex, then the exit of each subsurface walk it (or its exit) enters.
            loop {
                // Stratified draws line up vertex by vertex across a pixel's samples.
                rng.start_vertex();
                hooks.connect(scene, ctx, &v, &st, beta, rng, scratch);
                if st.depth >= self.scatter_below {
                    return End::Done;
                }
                if v.flags.dispersive && ctx.single_wavelength.is_none() {
                    if self.split_dispersion {
                        return End::Split { vertex: v, state: st };
                    }
                    if let Some(index) = beta.hero() {
                        return End::Terminated { index, vertex: v, state: st };
                    }
                    if self.stratified_collapse {
                        ctx.collapse_u = scratch.strata.map(|s| s.uniform(st.depth));
                    }
                }
                let scattered = beta.scatter(&v, ctx, rng, &mut scratch.tp);
                ctx.collapse_u = None;
                let entered = ctx.subsurface.take();
                let Some(sc) = scattered else {
                    return End::Done;
                };
                if !beta.is_alive() {
                    return End::Done;
                }
                if let Some(ev) = entered {
                    // Into a subsurface lobe: walk to where the path leaves the mesh and go on
                    // from a white Lambertian there, at the same depth (Cycles counts the
                    // BSSRDF bounce once, at the exit's BSDF sample). Later subsurface lobes
                    // act as a diffuse (Cycles' PATH_RAY_DIFFUSE_ANCESTOR). Light paths walk
                    // the same way from the light's side.
                    let Some((exit, exit_state)) = walk_subsurface(scene, ctx, &v, &st, &sc, ev, beta, rng) else {
                        return End::Done;
                    };
                    hooks.walked();
                    v = exit;
                    st = exit_state;
                    continue;
                }
                let collapsed = sc.sample.collapsed_to.filter(|_| ctx.single_wavelength.is_none());
                if let Some(i) = collapsed {
                    ctx.single_wavelength = Some(i);
                }
                if !hooks.scattered(scene, ctx, &v, &st, &sc, beta) {
                    return End::Done;
                }
                st = st.after(scene, &v, &sc, ctx.front_face);
                if let Some(index) = collapsed {
                    return End::Collapsed { index, state: st };
                }
                if !russian_roulette(beta, st.depth, self.rr_depth, rng) {
                    hooks.rouletted();
                    return End::Done;
                }
                break;
            }
        }
    }
}

/// The mesh around a subsurface walk: the entered instance alone (Cycles'
/// `scene_intersect_local` on the entry's object), its first ray from the entry point
/// itself, not seeing the entry triangle (Cycles' `ray.self.prim`; an offset origin
/// would start the walk a sizeable fraction of a short mean free path deep).
struct MeshBoundary<'s> {
    scene: &'s Scene,
    instance: u32,
    triangle: u32,
    time: f32,
}

impl Boundary for MeshBoundary<'_> {
    type Hit = (crate::accel::Hit, Ray);
    fn intersect(&mut self, origin: Vec3A, dir: Vec3A, tmax: f32, first: bool) -> Option<(f32, Self::Hit)> {
        let ray = Ray::segment(origin, dir, tmax).with_time(self.time);
        let h = self.scene.intersect_instance(&ray, self.instance, first.then_some(self.triangle))?;
        Some((h.t, (h, ray)))
    }
}

/// [`subsurface_exit`] for a path that is to go on from the exit: None also when the
/// walk left nothing of the path or no side to shade at the exit. Later subsurface lobes on
/// the path act as a diffuse (`ctx.subsurface_walk` cleared).
#[allow(clippy::too_many_arguments)]
pub fn walk_subsurface<'s, T: Throughput>(
    scene: &'s Scene,
    ctx: &mut ShadingContext,
    v: &Vertex<'s>,
    st: &PathState,
    sc: &Scatter,
    ev: SubsurfaceEvent,
    beta: &mut T,
    rng: &mut Rng,
) -> Option<(Vertex<'s>, PathState)> {
    let exit = subsurface_exit(scene, ctx, v, st, sc, ev, beta, rng);
    ctx.subsurface_walk = false;
    exit.filter(|(exit, _)| beta.is_alive() && exit.wo_local.z != 0.0)
}

/// The random walk of the subsurface lobe `ev` that the BSDF at `v` (reached with `st`)
/// entered along `sc`: every lane of `beta` walks the same path
/// (`medium::random_walk`, spectral MIS over the lanes) inside `v`'s instance. Returns the
/// exit vertex, shaded by the scene's white Lambertian about the exit's normal and seen
/// from outside along the walk's last direction (Cycles' `subsurface_scatter` and
/// `subsurface_shader_data_setup`), with the state arriving there; None when the walk
/// is absorbed or finds no way out.
#[allow(clippy::too_many_arguments)]
fn subsurface_exit<'s, T: Throughput>(
    scene: &'s Scene,
    ctx: &mut ShadingContext,
    v: &Vertex<'s>,
    st: &PathState,
    sc: &Scatter,
    ev: SubsurfaceEvent,
    beta: &mut T,
    rng: &mut Rng,
) -> Option<(Vertex<'s>, PathState)> {
    let lanes = beta.lanes();
    let (mut tp, mut albedo, mut mfp) =
        (SampledSpectrum::zeros(lanes), SampledSpectrum::zeros(lanes), SampledSpectrum::zeros(lanes));
    for j in 0..lanes {
        let i = beta.lane_index(j);
        tp.set(j, beta.lane(j));
        albedo.set(j, ev.albedo.get(i));
        mfp.set(j, ev.mfp.get(i));
    }
    let medium = SubsurfaceMedium::from_albedo(&albedo, &mfp, ev.anisotropy, &mut tp);
    let mut boundary = MeshBoundary { scene, instance: v.si.instance, triangle: v.si.triangle, time: v.si.time };
    let exit = medium.walk(&mut boundary, v.si.p, v.ns, sc.wi, rng, &mut tp)?;
    for j in 0..lanes {
        beta.set_lane(j, tp.get(j));
    }
    let (hit, ray) = exit.hit;
    let si = scene.interaction(&ray, &hit);
    let arrive = Ray::new(si.p + exit.direction, -exit.direction).with_time(v.si.time);
    let Facing { wo, ng, ns, frame, .. } = facing(scene, &arrive, &si, ctx);
    let material = &scene.subsurface_exit;
    let exit_v = Vertex { si, wo, ng, ns, material, frame, wo_local: frame.to_local(wo), flags: material.bsdf.flags() };
    let state = PathState {
        ray: arrive,
        specular: false,
        prev_pdf: 0.0,
        prev_p: v.si.p,
        depth: st.depth,
        media: st.media,
        traveled: 0.0,
    };
    Some((exit_v, state))
}

/// Russian roulette after `depth` scattering events: from `rr_depth` on, a path survives
/// with probability min(1, max β) and is divided by it. False: the path ends.
pub fn russian_roulette<T: Throughput>(beta: &mut T, depth: u32, rr_depth: u32, rng: &mut Rng) -> bool {
    if depth < rr_depth {
        return true;
    }
    let q = beta.survival_probability();
    if q <= 0.0 || rng.uniform() >= q {
        return false;
    }
    beta.divide_by_survival(q);
    true
}
