//! Backward path tracing (camera paths): every vertex gathers the emission the path
//! reaches and one light sample (next-event estimation, a light chosen ∝ its spectral
//! power, eq. 7); the two are combined with multiple importance sampling. How they are
//! weighted is a [`CameraMis`]: the power heuristic of the two strategies
//! ([`PowerHeuristic`], BACKWARD) or the three-strategy weights of BIDIRECTIONAL
//! (`bidir.rs`). Lights that are no geometry but have an extent (a sun's disk, a sphere
//! light) are reached by every segment of the path ([`PathHooks::segment_lights`]) and
//! weighted as emitters are. Whole-spectrum paths that collapse at a dispersive surface (eq. 9) or
//! split there continue as single-wavelength paths with the power heuristic.

use super::throughput::{SingleWavelength, Throughput};
use super::walk::{russian_roulette, End, MediumVertex, PathHooks, PathState, Vertex, Walk};
use super::wavelengths::{WavelengthPolicy, Wavelengths};
use super::{CameraSample, Scatter, Scratch, Technique};
use crate::film::PixelSample;
use crate::geometry::{offset_ray_origin, shadow_ray, visibility};
use crate::light::{LightChoice, LightSample};
use crate::material::ShadingContext;
use crate::sampling::{power_heuristic, Rng};
use crate::scene::Scene;
use crate::spectrum::SampledSpectrum;
use glam::{Vec2, Vec3A};

/// A light sample taken at a vertex (next-event estimation).
#[derive(Clone, Copy, Debug)]
pub struct DirectSample {
    /// The light and its selection probability (eq. 7).
    pub light: usize,
    pub pmf: f32,
    pub ls: LightSample,
    /// The sample's direction in the vertex's shading frame, and the BSDF's pdf of it.
    pub wi_local: Vec3A,
    pub bsdf_pdf: f32,
}

/// How a camera path weights the two ways it finds light. Methods draw no random numbers.
pub trait CameraMis {
    /// At the first hit `v` (depth 0) of the camera ray `st.ray`.
    fn first_hit(&mut self, _scene: &Scene, _v: &Vertex, _st: &PathState) {}
    /// Weight of emission reached at `v` by the path's last BSDF sample.
    fn emission(&mut self, scene: &Scene, v: &Vertex, st: &PathState) -> f32;
    /// Weight of the environment (light `env`) reached by the path escaping along `st.ray`.
    fn escape(&mut self, scene: &Scene, st: &PathState, env: usize) -> f32;
    /// Weight of light `light` that is no geometry (a sun's disk, a sphere light:
    /// [`Scene::hit_lights`]) reached along `st.ray` at `distance` from `st.prev_p`
    /// (infinite for a sun).
    fn reached_light(&mut self, scene: &Scene, st: &PathState, light: usize, distance: f32) -> f32;
    /// At `v`, before it connects and scatters.
    fn vertex(&mut self, _v: &Vertex) {}
    /// Where light samples come from (eq. 7's choice ∝ power), as the weights count them.
    fn nee_lights<'s>(&self, scene: &'s Scene) -> LightChoice<'s> {
        LightChoice::Power(&scene.light_distribution)
    }
    /// Weight of light sample `d` taken at `v`.
    fn direct(&mut self, scene: &Scene, ctx: &mut ShadingContext, v: &Vertex, d: &DirectSample) -> f32;
    /// The BSDF at `v` was sampled.
    fn scattered(&mut self, _ctx: &mut ShadingContext, _v: &Vertex, _st: &PathState, _sc: &Scatter) {}
    /// The path went through a subsurface walk ([`PathHooks::walked`]).
    fn walked(&mut self) {}
}

/// Veach's power heuristic between BSDF sampling and light sampling, the light chosen
/// ∝ power or by the light tree ([`Walk::light_tree`]).
#[derive(Clone, Copy, Debug, Default)]
pub struct PowerHeuristic {
    pub light_tree: bool,
}

impl PowerHeuristic {
    /// For paths of `walk`.
    pub fn of(walk: &Walk) -> Self {
        Self { light_tree: walk.light_tree }
    }
    /// The probability that a light sample taken at `p` chooses light `l`.
    #[inline]
    fn light_pmf(&self, scene: &Scene, p: Vec3A, l: usize) -> f32 {
        self.nee_lights(scene).pmf(p, l)
    }
}

impl CameraMis for PowerHeuristic {
    fn emission(&mut self, scene: &Scene, v: &Vertex, st: &PathState) -> f32 {
        if st.specular {
            return 1.0;
        }
        match scene.triangle_light(v.si.instance, v.si.triangle) {
            Some(l) => {
                let pl = self.light_pmf(scene, st.prev_p, l)
                    * scene.lights[l].pdf_li_part_at(
                        v.si.triangle,
                        st.prev_p,
                        st.ray.direction,
                        st.traveled + v.si.t,
                        st.ray.time,
                    );
                power_heuristic(st.prev_pdf, pl)
            }
            None => 1.0,
        }
    }
    fn escape(&mut self, scene: &Scene, st: &PathState, env: usize) -> f32 {
        self.reached_light(scene, st, env, f32::INFINITY)
    }
    /// The power heuristic with the light-sampling pdf of the point reached, as Cycles
    /// weighs lights a BSDF ray hits (kernel/integrator/shade_light.h,
    /// shade_background.h: `light_sample_mis_weight_forward`). The pdfs are those of
    /// directions, the same for every wavelength: one weight per path.
    fn reached_light(&mut self, scene: &Scene, st: &PathState, light: usize, distance: f32) -> f32 {
        if st.specular {
            return 1.0;
        }
        let pl = self.light_pmf(scene, st.prev_p, light)
            * scene.lights[light].pdf_li_at(st.prev_p, st.ray.direction, distance, st.ray.time);
        power_heuristic(st.prev_pdf, pl)
    }
    fn nee_lights<'s>(&self, scene: &'s Scene) -> LightChoice<'s> {
        if self.light_tree {
            LightChoice::Tree(&scene.light_tree)
        } else {
            LightChoice::Power(&scene.nee_distribution)
        }
    }
    fn direct(&mut self, _scene: &Scene, _ctx: &mut ShadingContext, _v: &Vertex, d: &DirectSample) -> f32 {
        if d.ls.delta {
            1.0
        } else {
            power_heuristic(d.pmf * d.ls.pdf, d.bsdf_pdf)
        }
    }
}

/// The auxiliary passes of a pixel sample: depth at the first hit; normal and albedo at
/// the first surface that is not a perfect mirror or glass, seen through those with the
/// albedo weighted by the path's throughput (their Fresnel reflectance/transmittance),
/// as Open Image Denoise expects and Cycles writes its denoising passes
/// (intern/cycles/kernel/film/denoising_passes.h). A chain of such surfaces that leaves
/// the scene gives zero, as an escaped camera ray; one that Russian roulette ends gives
/// zero albedo too (the survivors, divided by their survival probability, carry its
/// share: keeping the first hit's glass albedo there added ~0.1 % white behind a glass
/// slab); one cut by the bounce limit keeps the first hit's values.
///
/// Through a dispersive glass the path goes on with one wavelength (eq. 9) and the chain
/// with it: from there the albedo is weighted by [`FirstHit::weight`], each wavelength's
/// own Fresnel factors along the carried wavelength's direction
/// ([`crate::material::Bsdf::specular_weights`]), so the pass keeps its colour and is
/// not divided by the collapse's lane probability. The same holds for paths that carry
/// one wavelength from the camera on (monochromatic methods).
pub struct FirstHit<'a> {
    pub depth: &'a mut f32,
    pub normal: &'a mut Vec3A,
    pub albedo: &'a mut SampledSpectrum,
    /// Once the path carries one wavelength: the chain's grid-wide weight.
    weight: Option<SampledSpectrum>,
    /// The grid-wide throughput arriving at the dispersive vertex being scattered.
    before: Option<SampledSpectrum>,
    /// The grid index the path carries (with `weight`) and its throughput there after
    /// the last update, so factors other than the BSDF's (roulette, media) follow it grey.
    lane: usize,
    last: f32,
}

impl<'a> FirstHit<'a> {
    pub fn new(depth: &'a mut f32, normal: &'a mut Vec3A, albedo: &'a mut SampledSpectrum) -> Self {
        Self { depth, normal, albedo, weight: None, before: None, lane: 0, last: 0.0 }
    }

    /// The path carries grid wavelength `lane` alone with throughput `value`, the chain
    /// weighing `weight`.
    fn carry(&mut self, weight: SampledSpectrum, lane: usize, value: f32) {
        self.weight = Some(weight);
        self.lane = lane;
        self.last = value;
    }

    /// After the specular event `sc` at `v` (`before`: the grid-wide throughput arriving
    /// there; `ctx` as `sample` saw it): the chain's weight is `before` times each
    /// wavelength's own factor of the event, or the carried one's (`grey`) if unknown.
    fn weigh_event(
        &self,
        ctx: &ShadingContext,
        v: &Vertex,
        sc: &Scatter,
        before: &SampledSpectrum,
        grey: f32,
    ) -> SampledSpectrum {
        let mut w = SampledSpectrum::zeros(before.len());
        if v.material.bsdf.specular_weights(ctx, v.wo_local, sc.sample.wi, before, &mut w) {
            w.mul_assign(before);
        } else {
            w = before.clone();
            w.scale(grey);
        }
        w
    }

    /// The carried wavelength's throughput in `beta`, if it carries it.
    fn carried<T: Throughput>(&self, beta: &T) -> Option<f32> {
        (0..beta.lanes()).find(|&j| beta.lane_index(j) == self.lane).map(|j| beta.lane(j))
    }
}

/// The hooks of a camera path: gathers into `gathered` what it reaches, weighted by `mis`.
pub struct CameraPath<'a, 'b, T, M> {
    pub mis: M,
    pub gathered: &'a mut T,
    pub first_hit: Option<FirstHit<'b>>,
    /// What the film's alpha loses ([`crate::film::PixelSample::transparent`]).
    pub transparent: f32,
}

/// The mean throughput over the wavelengths a path carries (Cycles' `average` of the
/// RGB throughput, for the alpha of holdouts and a transparent film's background).
pub(super) fn mean_throughput<T: Throughput>(beta: &T) -> f32 {
    let n = beta.lanes();
    let sum: f32 = (0..n).map(|j| beta.lane(j)).sum();
    if n > 0 && sum.is_finite() {
        sum / n as f32
    } else {
        0.0
    }
}

impl<T: Throughput, M: CameraMis> PathHooks<T> for CameraPath<'_, '_, T, M> {
    fn escaped(&mut self, scene: &Scene, st: &PathState, beta: &T, scratch: &mut Scratch) {
        if let Some(out) = self.first_hit.take() {
            // Out through mirrors and glass: nothing seen, as a ray that escapes at once.
            out.albedo.fill(0.0);
            *out.normal = Vec3A::ZERO;
        }
        if scene.film_transparent && st.depth == 0 {
            // Cycles' transparent background (integrate_background): the film shows
            // nothing there, its alpha drops by the path's throughput.
            self.transparent += mean_throughput(beta);
            return;
        }
        if let Some(env) = &scene.environment {
            let w = self.mis.escape(scene, st, env.light);
            let l = env.radiance_along(st.ray.direction, &mut scratch.le);
            self.gathered.add_emitted(beta, l, w);
        }
    }

    /// A sun's disk or a sphere light on the segment, when the ray's kind sees it
    /// (camera rays only with the light's camera visibility), attenuated by the media
    /// the segment crosses up to it.
    fn segment_lights(
        &mut self,
        scene: &Scene,
        st: &PathState,
        end: f32,
        beta: &T,
        rng: &mut Rng,
        scratch: &mut Scratch,
    ) {
        for &l in &scene.hit_lights {
            if !visibility::sees(scene.light_visibility[l], st.ray.kind) {
                continue;
            }
            let Some(t) = scene.lights[l].hit_at(st.ray.origin, st.ray.direction, st.ray.time, &mut scratch.le) else {
                continue;
            };
            // A sphere before the next surface; a sun only when the path leaves the scene.
            let reached = if t.is_finite() { t < end } else { end.is_infinite() };
            if !reached || !beta.carries(&scratch.le) {
                continue;
            }
            if !st.media.is_empty() && scene.coefficients(&st.media, &mut scratch.shadow) {
                scene.segment_transmittance(&st.ray, &scratch.shadow, t, &mut scratch.le, rng);
            }
            let w = self.mis.reached_light(scene, st, l, st.traveled + t);
            self.gathered.add_emitted(beta, &scratch.le, w);
        }
    }

    fn reached(
        &mut self,
        scene: &Scene,
        ctx: &mut ShadingContext,
        v: &Vertex,
        st: &PathState,
        beta: &T,
        scratch: &mut Scratch,
    ) {
        if let Some(out) = &mut self.first_hit {
            if st.depth == 0 {
                *out.depth = scene.camera.depth(v.si.p);
            }
            if out.weight.is_some() {
                // What changed the carried wavelength since the last vertex (roulette,
                // media) weighs the chain alike.
                if let Some(now) = out.carried(beta) {
                    if out.last > 0.0 && now != out.last {
                        let f = now / out.last;
                        if let Some(w) = &mut out.weight {
                            w.scale(f);
                        }
                    }
                    out.last = now;
                }
            }
            // The first hit, and after perfect mirrors and glass the first other surface.
            if st.depth == 0 || v.flags.smooth || !v.flags.specular {
                // The shading normal the BSDF used (a Normal Map's or Bump's, made valid),
                // facing the ray, as Cycles' Normal pass: the closures' average normal
                // (surface_shader_average_normal, kernel/film/data_passes.h) about sd->N,
                // which shader_setup_from_ray flips for a back face.
                *out.normal = v.ns;
                // The albedo pass is grid-wide whatever the path carries.
                let single = ctx.single_wavelength.take();
                v.material.bsdf.albedo(ctx, out.albedo);
                ctx.single_wavelength = single;
                if st.depth > 0 {
                    match &out.weight {
                        Some(w) => out.albedo.mul_assign(w),
                        None => beta.weigh_grid(out.albedo),
                    }
                }
            }
            if v.flags.smooth || !v.flags.specular {
                self.first_hit = None;
            } else if v.flags.dispersive && ctx.single_wavelength.is_none() {
                // Where the path may collapse: keep the grid-wide throughput arriving.
                let mut b = SampledSpectrum::splat(scene.grid.len(), 1.0);
                beta.weigh_grid(&mut b);
                out.before = Some(b);
            } else {
                out.before = None;
            }
        }
        if st.depth == 0 {
            self.mis.first_hit(scene, v, st);
        }
        let front = ctx.front_face || !v.material.one_sided;
        if let Some(emission) = v.material.emission.as_ref().filter(|_| front) {
            let w = self.mis.emission(scene, v, st);
            self.gathered.add_emitted(beta, emission, w);
        } else if let Some(g) = &v.material.graph_emission {
            g.radiance(&ctx.hit, &mut scratch.le);
            let w = self.mis.emission(scene, v, st);
            self.gathered.add_emitted(beta, &scratch.le, w);
        }
    }

    fn rouletted(&mut self) {
        if let Some(out) = self.first_hit.take() {
            out.albedo.fill(0.0);
        }
    }

    fn holdout(&mut self, weight: f32, beta: &T) -> bool {
        self.transparent += weight * mean_throughput(beta);
        true
    }

    fn walked(&mut self) {
        self.mis.walked();
    }

    fn passed_emitter(&mut self, scene: &Scene, ctx: &mut ShadingContext, v: &Vertex, st: &PathState, beta: &T) {
        if st.depth == 0 {
            self.mis.first_hit(scene, v, st);
        }
        if let Some(emission) = v.material.emission.as_ref().filter(|_| ctx.front_face || !v.material.one_sided) {
            let w = self.mis.emission(scene, v, st);
            self.gathered.add_emitted(beta, emission, w);
        }
    }

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
        self.mis.vertex(v);
        if !v.flags.smooth {
            return;
        }
        // Next-event estimation: one light chosen ∝ its spectral power (eq. 7).
        let Some((l, pmf)) = self.mis.nee_lights(scene).sample(v.si.p, rng.uniform()) else {
            return;
        };
        let u = rng.uniform2();
        let Some(ls) = scene.lights[l].sample_li_at(v.si.p, v.si.time, u, &mut scratch.le) else {
            return;
        };
        if !beta.carries(&scratch.le) {
            return;
        }
        let wi_local = v.frame.to_local(ls.wi);
        let Some(side) = super::connection_side(v.ng, v.wo_local, wi_local, ls.wi) else {
            return;
        };
        // A light that the kinds of lobes lit along this connection do not see (its ray
        // visibility) lights nothing here.
        let kinds = crate::geometry::visibility::of_connection(side.dot(v.ng) < 0.0, v.material.bsdf.lobe_kinds());
        let mask = scene.light_visibility.get(l).copied().unwrap_or(crate::geometry::visibility::ALL);
        if !crate::geometry::visibility::sees(mask, kinds) {
            return;
        }
        let bsdf_pdf = v.material.bsdf.eval(ctx, v.wo_local, wi_local, &mut scratch.f);
        if !beta.carries(&scratch.f) {
            return;
        }
        // Aimed from the offset origin at the light point, stopping short of it (robust
        // far from the origin: 1e6 units).
        let origin = offset_ray_origin(v.si.p, side);
        let ray = shadow_ray(v.si.p, origin, ls.wi, ls.distance, v.si.time);
        if scene.has_media() {
            // Through media: attenuated per wavelength; a transmitted connection crosses
            // this vertex's own boundary.
            let mut media = st.media;
            if side.dot(v.ng) < 0.0 && scene.material_medium[v.si.material as usize].is_some() {
                media.cross(v.si.instance, v.si.material, ctx.front_face);
            }
            if !scene.shadow_transmittance(&ray, media, &mut scratch.shadow, &mut scratch.tr, rng) {
                return;
            }
            scratch.f.mul_assign(&scratch.tr);
        } else if scene.occluded(&ray) {
            return;
        }
        let w = self.mis.direct(scene, ctx, v, &DirectSample { light: l, pmf, ls, wi_local, bsdf_pdf });
        self.gathered.add_direct(beta, &mut scratch.f, &scratch.le, w, pmf * ls.pdf);
    }

    fn scattered(
        &mut self,
        _scene: &Scene,
        ctx: &mut ShadingContext,
        v: &Vertex,
        st: &PathState,
        sc: &Scatter,
        beta: &T,
    ) -> bool {
        self.mis.scattered(ctx, v, st, sc);
        if let Some(out) = &mut self.first_hit {
            // A specular vertex of the aux chain (any other one ended it).
            if let Some(before) = out.before.take() {
                if let Some(i) = sc.sample.collapsed_to {
                    // Collapsed here (eq. 9): every wavelength takes the sampled event
                    // with its own factor (the event's probability as sample saw it, with
                    // the whole spectrum), along the chosen wavelength's direction.
                    let single = ctx.single_wavelength.take();
                    let w = out.weigh_event(ctx, v, sc, &before, 1.0);
                    ctx.single_wavelength = single;
                    let value = (0..beta.lanes()).find(|&j| beta.lane_index(j) == i).map_or(0.0, |j| beta.lane(j));
                    out.carry(w, i, value);
                }
            } else if let Some(w) = out.weight.take() {
                // A later specular vertex of a single-wavelength chain.
                let now = out.carried(beta).unwrap_or(0.0);
                let grey = if out.last > 0.0 { now / out.last } else { 0.0 };
                let w = out.weigh_event(ctx, v, sc, &w, grey);
                out.carry(w, out.lane, now);
            }
        }
        true
    }

    fn medium_emission(&mut self, _scene: &Scene, _st: &PathState, beta: &T, e: &SampledSpectrum) {
        self.gathered.add_emitted(beta, e, 1.0);
    }

    /// Next-event estimation from a medium vertex: the phase function in place of the
    /// BSDF (f = pdf = phase value), the shadow ray attenuated by the media it crosses,
    /// the power heuristic against phase sampling.
    fn connect_medium(
        &mut self,
        scene: &Scene,
        _ctx: &mut ShadingContext,
        mv: &MediumVertex,
        st: &PathState,
        beta: &T,
        rng: &mut Rng,
        scratch: &mut Scratch,
    ) {
        let Some((l, pmf)) = self.mis.nee_lights(scene).sample(mv.p, rng.uniform()) else {
            return;
        };
        let u = rng.uniform2();
        let Some(ls) = scene.lights[l].sample_li_at(mv.p, mv.time, u, &mut scratch.le) else {
            return;
        };
        if !beta.carries(&scratch.le) {
            return;
        }
        let cos = (-mv.wo).dot(ls.wi);
        let phase_pdf = scene.phase_eval(&st.media, &scratch.medium, cos, &mut scratch.f, 0.0);
        if !(phase_pdf > 0.0) {
            return;
        }
        let ray = shadow_ray(mv.p, mv.p, ls.wi, ls.distance, mv.time);
        if !scene.shadow_transmittance(&ray, st.media, &mut scratch.shadow, &mut scratch.tr, rng) {
            return;
        }
        scratch.f.mul_assign(&scratch.tr);
        let w = if ls.delta { 1.0 } else { power_heuristic(pmf * ls.pdf, phase_pdf) };
        self.gathered.add_direct(beta, &mut scratch.f, &scratch.le, w, pmf * ls.pdf);
    }
}

/// One camera sample through film position `film` on wavelengths `wl`, weighted by `mis`:
/// fills `out` (radiance and first-hit passes).
#[allow(clippy::too_many_arguments)]
pub fn trace_camera<W: Wavelengths, M: CameraMis>(
    scene: &Scene,
    walk: &Walk,
    film: Vec2,
    row: u32,
    wl: W,
    mis: M,
    rng: &mut Rng,
    out: &mut PixelSample,
    scratch: &mut Scratch,
) {
    let PixelSample { radiance, depth, normal, albedo, transparent } = out;
    let mut ctx = ShadingContext::new(&scene.grid);
    ctx.single_wavelength = wl.single();
    let Some(ray) = scene.camera.generate_pixel_ray(film.x, film.y, row, rng) else {
        return; // outside the lens (fisheye, mirror ball): black
    };
    // Throughput and gathered radiance live in the worker's spare spectra: no heap
    // allocation per camera path.
    let mut beta = wl.unit(scene.grid.len(), &mut scratch.spare);
    let mut gathered = beta.zero_like_in(&mut scratch.spare);
    let start = PathState::start_in(ray, scene.camera_media);
    let mut aux = FirstHit::new(depth, normal, albedo);
    if let Some(i) = wl.single() {
        // One wavelength from the camera on: the chain is weighed grid-wide from here.
        let mut unit = SampledSpectrum::splat(scene.grid.len(), 1.0);
        unit.scale(beta.lane(0));
        aux.carry(unit, i, beta.lane(0));
    }
    let mut hooks = CameraPath { mis, gathered: &mut gathered, first_hit: Some(aux), transparent: 0.0 };
    let end = walk.run(scene, &mut ctx, start, &mut beta, rng, &mut hooks, scratch);
    *transparent = hooks.transparent;
    // The aux chain goes on through a dispersive surface with the single wavelength.
    let aux = hooks.first_hit.take();
    continue_single_wavelength(scene, walk, end, &mut ctx, &beta, &mut gathered, aux, rng, scratch);
    wl.resolve(&gathered, radiance);
    gathered.recycle(&mut scratch.spare);
    beta.recycle(&mut scratch.spare);
}

/// Carries a whole-spectrum camera path on past a dispersive surface with one wavelength
/// per path (power-heuristic MIS), adding what each gathers at its wavelength; `aux`,
/// the first-hit passes' chain if it reached the dispersive surface, goes on with it.
#[allow(clippy::too_many_arguments)]
fn continue_single_wavelength<T: Throughput>(
    scene: &Scene,
    walk: &Walk,
    end: End,
    ctx: &mut ShadingContext,
    beta: &T,
    gathered: &mut T,
    aux: Option<FirstHit>,
    rng: &mut Rng,
    scratch: &mut Scratch,
) {
    match end {
        End::Done => {}
        // Collapsed (eq. 9): the BSDF chose wavelength `index` and divided by its probability.
        End::Collapsed { index, state } => {
            if let Some(b) = beta.collapse(index) {
                let aux = aux.filter(|a| a.weight.is_some());
                let l = trace_single(scene, walk, state, None, ctx.subsurface_walk, b, aux, rng, scratch);
                gathered.add_at(index, l);
            }
        }
        // Deterministic (splitting) mode: one sub-path per wavelength that still carries
        // energy, each scattering the vertex at its own wavelength. The aux chain follows
        // the sub-path of the most energy (β·quadrature weight), drawing nothing random.
        End::Split { vertex: v, state } if walk.split_k.is_some() => {
            let k = walk.split_k.unwrap_or(1);
            split_k(scene, walk, k, ctx, &v, &state, beta, gathered, aux, rng, scratch);
        }
        End::Split { vertex: v, state } => {
            let weights = scene.grid.weights();
            let follow = (0..scene.grid.len())
                .filter_map(|i| beta.collapse(i).map(|b| (i, b.value * weights[i])))
                .filter(|&(_, e)| e > 0.0)
                .max_by(|a, b| a.1.total_cmp(&b.1))
                .map(|(i, _)| i);
            let mut aux = aux;
            for i in 0..scene.grid.len() {
                let Some(b) = beta.collapse(i) else { return };
                if !(b.value > 0.0) {
                    continue;
                }
                let a = if Some(i) == follow { aux.take() } else { None };
                let l = scatter_single(scene, walk, ctx, &v, &state, b, false, a, rng, scratch);
                gathered.add_at(i, l);
            }
        }
        // Hero wavelengths: the secondary ones end here, the hero carries on alone.
        End::Terminated { index, vertex: v, state } => {
            if let Some(b) = beta.collapse(index) {
                let l = scatter_single(scene, walk, ctx, &v, &state, b, true, aux, rng, scratch);
                gathered.add_at(index, l);
            }
        }
    }
}

/// COLLAPSE SPLIT at dispersive vertex `v` (reached with `state`, whole-spectrum
/// throughput `beta`): `k` sub-paths, sub-path j taking the lane where u_j = (j + ξ)/k
/// falls in the CDF of the arriving energy e_i = β_i·w_i (w: quadrature weights), each
/// weighted by 1/(k·p_i) with p_i = e_i/Σe. Each u_j is uniform on its stratum, so
/// Σ_j f(i_j)/(k·p(i_j)) has expectation ∫₀¹ f(i(u))/p(i(u)) du = Σ_i f_i: unbiased, with
/// duplicates allowed. ξ is the sample's stratified number (dimension above the bounce
/// dimensions), so the k·spp choices of a pixel are stratified together. The first-hit
/// passes follow the first sub-path.
#[allow(clippy::too_many_arguments)]
fn split_k<T: Throughput>(
    scene: &Scene,
    walk: &Walk,
    k: u32,
    ctx: &mut ShadingContext,
    v: &Vertex,
    state: &PathState,
    beta: &T,
    gathered: &mut T,
    aux: Option<FirstHit>,
    rng: &mut Rng,
    scratch: &mut Scratch,
) {
    let weights = scene.grid.weights();
    let energy: Vec<f32> =
        (0..scene.grid.len()).map(|i| beta.collapse(i).map_or(0.0, |b| b.value.max(0.0) * weights[i])).collect();
    let total: f32 = energy.iter().sum();
    let Some(last) = energy.iter().rposition(|&e| e > 0.0) else { return };
    if !total.is_finite() {
        return;
    }
    let xi = match scratch.strata {
        Some(s) => s.uniform(SPLIT_DIMENSION),
        None => rng.uniform(),
    };
    let mut aux = aux;
    let (mut lane, mut acc) = (0usize, 0.0f32);
    for j in 0..k {
        let target = (j as f32 + xi) / k as f32 * total;
        // The lane whose CDF interval holds target (the u_j ascend: one pass over the
        // lanes; zero-energy lanes are never chosen, rounding falls on the last one).
        while lane < last && (energy[lane] <= 0.0 || acc + energy[lane] <= target) {
            acc += energy[lane];
            lane += 1;
        }
        let Some(mut b) = beta.collapse(lane) else { return };
        b.value *= total / (k as f32 * energy[lane]);
        let l = scatter_single(scene, walk, ctx, v, state, b, false, aux.take(), rng, scratch);
        gathered.add_at(lane, l);
    }
}

/// The stratified dimension of COLLAPSE SPLIT's offset (bounce dimensions are depths).
const SPLIT_DIMENSION: u32 = 1 << 16;

/// The radiance gathered by a single-wavelength camera path that scatters at `v` (reached
/// with `state`) on its wavelength and continues from there; `roulette`: Russian
/// roulette after that scattering as at every other vertex (not for splitting, which is
/// deterministic at the split).
#[allow(clippy::too_many_arguments)]
fn scatter_single(
    scene: &Scene,
    walk: &Walk,
    ctx: &mut ShadingContext,
    v: &Vertex,
    state: &PathState,
    mut b: SingleWavelength,
    roulette: bool,
    aux: Option<FirstHit>,
    rng: &mut Rng,
    scratch: &mut Scratch,
) -> f32 {
    ctx.single_wavelength = Some(b.index);
    let arriving = b.value;
    let scattered = b.scatter(v, ctx, rng, &mut scratch.tp);
    let entered = ctx.subsurface.take();
    let Some(sc) = scattered else {
        return 0.0;
    };
    if let Some(ev) = entered {
        // Into a subsurface lobe, at this wavelength: walk it and go on from the exit as
        // `Walk::run` does (no roulette at the entry). The next sub-path of a split sees
        // `ctx` unchanged: the walk state goes to this one's own context.
        let walking = ctx.subsurface_walk;
        let exit = super::walk::walk_subsurface(scene, ctx, v, state, &sc, ev, &mut b, rng);
        ctx.subsurface_walk = walking;
        let Some((exit, exit_state)) = exit else {
            return 0.0;
        };
        // The aux chain ended at this (non-specular) vertex already.
        return trace_single(scene, walk, exit_state, Some(exit), false, b, None, rng, scratch);
    }
    // The aux chain (its grid-wide throughput kept where it reached `v`) takes the
    // event with every wavelength's own factor at this wavelength's probability.
    let aux = aux.and_then(|mut a| {
        let before = a.before.take()?;
        let grey = if arriving > 0.0 { b.value / arriving } else { 0.0 };
        let w = a.weigh_event(ctx, v, &sc, &before, grey);
        a.carry(w, b.index, b.value);
        Some(a)
    });
    let st = state.after(scene, v, &sc, ctx.front_face);
    if roulette && !russian_roulette(&mut b, st.depth, walk.rr_depth, rng) {
        if let Some(a) = aux {
            a.albedo.fill(0.0); // as CameraPath::rouletted
        }
        return 0.0;
    }
    trace_single(scene, walk, st, None, ctx.subsurface_walk, b, aux, rng, scratch)
}

/// The radiance a single-wavelength camera path from `st` with throughput `beta`
/// gathers (already multiplied by `beta`), going on with the aux chain `first_hit`. It
/// has its own shading context: the vertex a split continues from keeps its own for the
/// next wavelength. `exit`: the path goes on from this exit of a subsurface walk (as
/// [`Walk::resume`]); `walking`: subsurface lobes still walk (the path has left none).
#[allow(clippy::too_many_arguments)]
fn trace_single<'s>(
    scene: &'s Scene,
    walk: &Walk,
    st: PathState,
    exit: Option<Vertex<'s>>,
    walking: bool,
    mut beta: SingleWavelength,
    first_hit: Option<FirstHit>,
    rng: &mut Rng,
    scratch: &mut Scratch,
) -> f32 {
    if !beta.is_alive() {
        return 0.0;
    }
    let mut ctx = ShadingContext::new(&scene.grid);
    ctx.single_wavelength = Some(beta.index);
    ctx.subsurface_walk = walking && walk.subsurface;
    let mut gathered = beta.zero_like();
    let mut hooks = CameraPath { mis: PowerHeuristic::of(walk), gathered: &mut gathered, first_hit, transparent: 0.0 };
    match exit {
        Some(v) => {
            ctx.uv = v.si.uv;
            ctx.frame = v.frame;
            walk.resume(scene, &mut ctx, v, st, &mut beta, rng, &mut hooks, scratch)
        }
        None => walk.run(scene, &mut ctx, st, &mut beta, rng, &mut hooks, scratch),
    };
    gathered.value
}

/// BACKWARD: camera paths only.
pub struct PathTracing<P> {
    pub wavelengths: P,
    pub walk: Walk,
}

impl<P: WavelengthPolicy> Technique for PathTracing<P> {
    fn camera_sample(
        &self,
        scene: &Scene,
        cs: CameraSample,
        rng: &mut Rng,
        out: &mut PixelSample,
        scratch: &mut Scratch,
    ) {
        let wl = self.wavelengths.camera(cs.pixel, cs.pass);
        trace_camera(scene, &self.walk, cs.film, cs.row, wl, PowerHeuristic::of(&self.walk), rng, out, scratch);
    }
}
