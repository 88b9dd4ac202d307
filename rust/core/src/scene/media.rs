//! The scene's media: built from a material's `volume` description (homogeneous, or a
//! density grid: `medium::grid`), looked up through a path's [`MediumStack`], free
//! flights through grid media, and the transmittance of shadow rays (docs/media.md).

use super::{Scene, VolumeDesc};
use crate::geometry::{offset_ray_origin, Ray};
use crate::integrator::throughput::Throughput;
use crate::integrator::volume::Flight;
use crate::medium::grid::{self, Base, Placed};
use crate::medium::homogeneous::{transmittance, STACK_SIZE, WORLD_INSTANCE};
use crate::medium::{GridMedium, HomogeneousMedium, MediumStack};
use crate::sampling::Rng;
use crate::spectrum::named::SpectrumRole;
use crate::spectrum::{SampledSpectrum, SpectrumDesc};
use crate::{Error, Result};
use glam::{Vec2, Vec3A};

/// Boundaries of null surfaces a ray may cross before it counts as blocked (Cycles'
/// VOLUME_BOUNDS_MAX, intern/cycles/kernel/integrator/intersect_volume_stack.h).
pub const VOLUME_BOUNDS_MAX: usize = 1024;

/// The medium of material (or world, `kind`) `name`, or None when it neither absorbs, scatters nor emits.
/// `spectrum` evaluates a description on the render's grid. Coefficients that are not
/// finite or negative are an error naming the material (a NaN density never reaches an
/// image). With a `density_grid` also the grid medium (its coefficients at density 1
/// are the homogeneous one's); a grid that is invalid (dims of 0, voxels NaN,
/// infinite or negative, a wrong count, an empty box), on the world, or with
/// emission is an error naming the material.
pub fn build_medium(
    kind: &'static str,
    name: &str,
    v: &VolumeDesc,
    spectrum: impl Fn(&SpectrumDesc, SpectrumRole, &str) -> Result<SampledSpectrum>,
) -> Result<Option<(HomogeneousMedium, Option<GridMedium>)>> {
    let coefficient = |d: &Option<SpectrumDesc>, role, what: &str| -> Result<Option<SampledSpectrum>> {
        let Some(d) = d else { return Ok(None) };
        let s = spectrum(d, role, &format!("volume {what}"))?;
        if let Some(bad) = s.values().iter().find(|x| !(x.is_finite() && **x >= 0.0)) {
            return Err(Error::object(
                kind,
                name,
                format!("volume {what} {bad} (scale {}) must be finite and non-negative", d.scale),
            ));
        }
        Ok(Some(s).filter(|s| !s.is_black()))
    };
    let sigma_a = coefficient(&v.absorption, SpectrumRole::Reflectance, "absorption")?;
    let sigma_s = coefficient(&v.scattering, SpectrumRole::Reflectance, "scattering")?;
    let emission = coefficient(&v.emission, SpectrumRole::Illuminant, "emission")?;
    if !v.anisotropy.is_finite() {
        return Err(Error::object(kind, name, format!("volume anisotropy {} must be finite", v.anisotropy)));
    }
    let n = [&sigma_a, &sigma_s, &emission].iter().find_map(|s| s.as_ref().map(|s| s.len())).unwrap_or(0);
    let zero = || SampledSpectrum::zeros(n);
    let (none, sigma_a, sigma_s) = (
        sigma_a.is_none() && sigma_s.is_none() && emission.is_none(),
        sigma_a.unwrap_or_else(zero),
        sigma_s.unwrap_or_else(zero),
    );
    // A grid is validated even when the coefficients are 0: a NaN voxel is a broken file.
    let grid = match &v.density_grid {
        None => None,
        Some(_) if kind == "world" => {
            return Err(Error::object(kind, name, "a volume density_grid needs a mesh around it (not on the world)"))
        }
        Some(_) if emission.is_some() => {
            return Err(Error::object(kind, name, "volume emission with a density_grid is not supported"))
        }
        Some(g) => {
            let [lo, hi] = g.bounds.map(Vec3A::from_array);
            let dims = g.dims.map(|d| d as usize);
            let grid =
                GridMedium::new(name, dims, g.values.clone(), lo, hi, sigma_a.clone(), sigma_s.clone(), v.anisotropy)
                    .map_err(|e| Error::object(kind, name, e))?;
            Some(grid)
        }
    };
    if none || grid.as_ref().is_some_and(|g| g.max_density() == 0.0) {
        return Ok(None);
    }
    Ok(Some((HomogeneousMedium::new(name, sigma_a, sigma_s, v.anisotropy, emission), grid)))
}

/// A flight when a grid medium on the stack cannot be placed (no such instance): the
/// homogeneous media alone.
fn volume_fly_fallback<T: Throughput>(c: &Coefficients, d: f32, beta: &mut T, rng: &mut Rng) -> Flight {
    crate::integrator::volume::fly(c, d, beta, rng)
}

/// The summed coefficients of the media around a point (one stack), per grid lane.
#[derive(Clone, Debug)]
pub struct Coefficients {
    pub sigma_t: SampledSpectrum,
    pub sigma_s: SampledSpectrum,
    pub emission: SampledSpectrum,
    pub scatters: bool,
    pub emits: bool,
    /// Media on the stack that scatter (for the phase function).
    pub scattering_media: usize,
    /// Grid media on the stack, (instance, index into the scene's media): not in the
    /// sums above, which are the homogeneous media's, until [`Scene::coefficients_at`]
    /// adds them at a point.
    pub grids: [(u32, u32); STACK_SIZE],
    pub grid_count: usize,
    /// Per stack entry, the factor of its σs at the point the phase functions are
    /// evaluated: a grid medium's density there, 1 for a homogeneous medium.
    pub scale: [f32; STACK_SIZE],
}

impl Coefficients {
    pub fn new(n: usize) -> Self {
        Self {
            sigma_t: SampledSpectrum::zeros(n),
            sigma_s: SampledSpectrum::zeros(n),
            emission: SampledSpectrum::zeros(n),
            scatters: false,
            emits: false,
            scattering_media: 0,
            grids: [(0, 0); STACK_SIZE],
            grid_count: 0,
            scale: [1.0; STACK_SIZE],
        }
    }
}

impl Scene {
    /// Any material has a medium or no surface: paths track media and shadow rays pass
    /// null surfaces.
    #[inline]
    pub fn has_media(&self) -> bool {
        self.has_media
    }

    /// The index into `media` of stack entry (instance, material), or (WORLD_INSTANCE, medium).
    fn entry_index(&self, (i, m): (u32, u32)) -> Option<u32> {
        if i == WORLD_INSTANCE {
            return Some(m).filter(|&m| (m as usize) < self.media.len());
        }
        self.material_medium.get(m as usize).copied().flatten()
    }

    /// The medium of stack entry (instance, material), or (WORLD_INSTANCE, medium).
    fn entry_medium(&self, e: (u32, u32)) -> Option<&HomogeneousMedium> {
        self.entry_index(e).map(|k| &self.media[k as usize])
    }

    /// Grid medium `k` of instance `instance` on `ray`: the ray in the instance's object
    /// space at the ray's time, with the same parameter t.
    fn placed(&self, (instance, k): (u32, u32), origin: Vec3A, dir: Vec3A, time: f32) -> Option<Placed<'_>> {
        let grid = self.medium_grid.get(k as usize)?.as_ref()?;
        let inst = self.instances.get(instance as usize)?;
        let to_object = match &inst.motion {
            Some(m) => m.at(time).inverse(),
            None => inst.to_object,
        };
        Some(Placed { grid, o: to_object.transform_point3a(origin), dir: to_object.transform_vector3a(dir) })
    }

    /// The grid media of `c` (from [`Self::coefficients`]) placed on a ray.
    fn placed_grids<'s>(&'s self, c: &Coefficients, ray: &Ray, out: &mut [Option<Placed<'s>>; STACK_SIZE]) -> usize {
        let mut n = 0;
        for &e in &c.grids[..c.grid_count] {
            if let Some(p) = self.placed(e, ray.origin, ray.direction, ray.time) {
                out[n] = Some(p);
                n += 1;
            }
        }
        n
    }

    /// A free flight along `ray` over 0 ≤ t < `d` inside media `c` that include grid
    /// media (`medium::grid::fly`, the homogeneous media of the stack as its base).
    /// `scratch`: a grid-wide spectrum.
    pub fn fly_grids<T: Throughput>(
        &self,
        ray: &Ray,
        c: &Coefficients,
        d: f32,
        beta: &mut T,
        rng: &mut Rng,
        scratch: &mut SampledSpectrum,
    ) -> Flight {
        let mut slots = [None; STACK_SIZE];
        let n = self.placed_grids(c, ray, &mut slots);
        let Some(first) = slots[0] else { return volume_fly_fallback(c, d, beta, rng) };
        let mut placed = [first; STACK_SIZE];
        for (p, s) in placed.iter_mut().zip(&slots).take(n) {
            *p = s.expect("placed");
        }
        let base = Base { sigma_t: &c.sigma_t, sigma_s: &c.sigma_s };
        grid::fly(&placed[..n], d, Some(base), beta, rng, scratch)
    }

    /// The media of `stack` at point `p` (time `time`) into `out`: the homogeneous
    /// media's sums plus every grid medium's coefficients times its density at `p`, and
    /// the per-entry σs factors the phase functions use there.
    pub fn coefficients_at(&self, stack: &MediumStack, p: Vec3A, time: f32, out: &mut Coefficients) -> bool {
        let any = self.coefficients(stack, out);
        for (k, &e) in stack.entries().iter().enumerate() {
            let Some(idx) = self.entry_index(e) else { continue };
            let Some(pl) = self.placed((e.0, idx), p, Vec3A::ZERO, time) else { continue };
            let rho = pl.grid.density(pl.o);
            out.scale[k] = rho;
            if rho > 0.0 {
                out.sigma_t.add_scaled(&pl.grid.sigma_t, rho);
                if !pl.grid.sigma_s.is_black() {
                    out.sigma_s.add_scaled(&pl.grid.sigma_s, rho);
                    out.scatters = true;
                    out.scattering_media += 1;
                }
            }
        }
        any
    }

    /// Multiplies `tr` (per grid lane) by the transmittance of the media of `c` along
    /// `ray` over 0 ≤ t < `d`: Beer–Lambert for the homogeneous media, ratio tracking
    /// (an unbiased estimate) for grid media.
    pub fn segment_transmittance(&self, ray: &Ray, c: &Coefficients, d: f32, tr: &mut SampledSpectrum, rng: &mut Rng) {
        for i in 0..tr.len() {
            tr.set(i, tr.get(i) * transmittance(c.sigma_t.get(i), d));
        }
        if c.grid_count == 0 || tr.is_black() {
            return;
        }
        let mut slots = [None; STACK_SIZE];
        let n = self.placed_grids(c, ray, &mut slots);
        let Some(first) = slots[0] else { return };
        let mut placed = [first; STACK_SIZE];
        for (p, s) in placed.iter_mut().zip(&slots).take(n) {
            *p = s.expect("placed");
        }
        grid::transmittance(&placed[..n], d, None, tr, rng);
    }

    /// The media inside which `stack` is, summed into `out` (Cycles adds the volume
    /// closures of all stack entries). False: no medium (vacuum).
    pub fn coefficients(&self, stack: &MediumStack, out: &mut Coefficients) -> bool {
        out.sigma_t.fill(0.0);
        out.sigma_s.fill(0.0);
        out.emission.fill(0.0);
        out.scatters = false;
        out.emits = false;
        out.scattering_media = 0;
        out.grid_count = 0;
        out.scale = [1.0; STACK_SIZE];
        let mut any = false;
        for &e in stack.entries() {
            let Some(k) = self.entry_index(e) else { continue };
            any = true;
            if self.medium_grid[k as usize].is_some() {
                out.grids[out.grid_count] = (e.0, k);
                out.grid_count += 1;
                continue;
            }
            let m = &self.media[k as usize];
            out.sigma_t.add_assign(&m.sigma_t);
            if m.scatters() {
                out.sigma_s.add_assign(&m.sigma_s);
                out.scatters = true;
                out.scattering_media += 1;
            }
            if let Some(em) = &m.emission {
                out.emission.add_assign(em);
                out.emits = true;
            }
        }
        any
    }

    /// The phase function at a scattering point inside `stack` for travel direction
    /// `d`: samples a new direction and returns it with its pdf, writing into `weight`
    /// the per-lane factor phase/pdf (1 inside one scattering medium; with several, each
    /// lane's phase is the σs-weighted mixture of theirs, sampled by a medium chosen ∝
    /// its spectrum-summed σs).
    pub fn sample_phase(
        &self,
        stack: &MediumStack,
        c: &Coefficients,
        d: Vec3A,
        u: Vec2,
        uc: f32,
        weight: &mut SampledSpectrum,
    ) -> Option<(Vec3A, f32)> {
        // (medium, its σs factor at the point): grid media by their density there.
        let scattering = || {
            stack
                .entries()
                .iter()
                .zip(c.scale)
                .filter_map(|(&e, s)| self.entry_medium(e).map(|m| (m, s)))
                .filter(|(m, s)| m.scatters() && *s > 0.0)
        };
        if c.scattering_media <= 1 {
            let (m, _) = scattering().next()?;
            weight.fill(1.0);
            return Some(m.phase.sample(d, u));
        }
        let total: f32 = scattering().map(|(m, s)| s * m.sigma_s.sum()).sum();
        let mut pick = uc * total;
        let mut chosen = None;
        for (m, s) in scattering() {
            chosen = Some(m);
            pick -= s * m.sigma_s.sum();
            if pick < 0.0 {
                break;
            }
        }
        let (wi, _) = chosen?.phase.sample(d, u);
        let pdf = self.phase_eval(stack, c, d.dot(wi), weight, total);
        if !(pdf > 0.0) {
            return None;
        }
        weight.scale(1.0 / pdf);
        Some((wi, pdf))
    }

    /// Per-lane phase value at `cos` into `out` and the sampling pdf of
    /// [`Self::sample_phase`] (`total`: the media's summed σs over the grid; 0 computes it).
    pub fn phase_eval(
        &self,
        stack: &MediumStack,
        c: &Coefficients,
        cos: f32,
        out: &mut SampledSpectrum,
        total: f32,
    ) -> f32 {
        // (medium, its σs factor at the point): grid media by their density there.
        let scattering = || {
            stack
                .entries()
                .iter()
                .zip(c.scale)
                .filter_map(|(&e, s)| self.entry_medium(e).map(|m| (m, s)))
                .filter(|(m, s)| m.scatters() && *s > 0.0)
        };
        if c.scattering_media <= 1 {
            let p = scattering().next().map_or(0.0, |(m, _)| m.phase.eval(cos));
            out.fill(p);
            return p;
        }
        let total = if total > 0.0 { total } else { scattering().map(|(m, s)| s * m.sigma_s.sum()).sum() };
        out.fill(0.0);
        let mut pdf = 0.0;
        for (m, s) in scattering() {
            let p = m.phase.eval(cos);
            pdf += s * m.sigma_s.sum() / total * p;
            out.add_scaled(&m.sigma_s, s * p);
        }
        for i in 0..out.len() {
            let s = c.sigma_s.get(i);
            out.set(i, if s > 0.0 { out.get(i) / s } else { 0.0 });
        }
        pdf
    }

    /// The media a path starting at `p` is inside (the camera's, Cycles'
    /// `integrator_volume_stack_init` in kernel/integrator/intersect_volume_stack.h): the
    /// world's medium, and every closed mesh with a medium whose first crossing along a
    /// fixed ray from `p` (+Z, as Cycles) leaves it — a back face, not entered on the way.
    pub fn media_at(&self, p: Vec3A, time: f32) -> MediumStack {
        let mut stack = MediumStack::default();
        if let Some(k) = self.world_medium {
            stack.push((WORLD_INSTANCE, k));
        }
        if !self.material_medium.iter().any(Option::is_some) {
            return stack;
        }
        let mut entered: Vec<(u32, u32)> = Vec::new();
        let mut ray = Ray::new(p, Vec3A::Z).with_time(time);
        for _ in 0..VOLUME_BOUNDS_MAX {
            let Some(h) = self.intersect(&ray) else { break };
            let si = self.interaction(&ray, &h);
            let key = (si.instance, si.material);
            let front = si.ng.dot(ray.direction) < 0.0;
            if self.material_medium[si.material as usize].is_some() && !entered.contains(&key) {
                if front {
                    entered.push(key);
                } else {
                    stack.push(key);
                    entered.push(key); // counted once
                }
            }
            let origin = offset_ray_origin(si.p, if front { -si.ng } else { si.ng });
            ray = Ray { origin, tmin: 0.0, tmax: f32::INFINITY, ..ray };
        }
        stack
    }

    /// Transmittance per grid lane along `ray` (up to `ray.tmax`) starting inside
    /// `stack`, into `tr`: shadow rays pass null surfaces (a medium's boundary), entering
    /// and leaving media, and are blocked by any other surface — also glass, as without
    /// media (no caustics through shadow rays). False: blocked.
    pub fn shadow_transmittance(
        &self,
        ray: &Ray,
        mut stack: MediumStack,
        c: &mut Coefficients,
        tr: &mut SampledSpectrum,
        rng: &mut Rng,
    ) -> bool {
        tr.fill(1.0);
        let mut ray = *ray;
        for _ in 0..VOLUME_BOUNDS_MAX {
            let hit = self.intersect(&ray);
            let end = hit.map_or(ray.tmax, |h| h.t);
            if self.coefficients(&stack, c) {
                self.segment_transmittance(&ray, c, end, tr, rng);
                if tr.is_black() {
                    return false;
                }
            }
            let Some(h) = hit else { return true };
            let si = self.interaction(&ray, &h);
            let m = si.material as usize;
            let front = si.ng.dot(ray.direction) < 0.0;
            if let Some(pt) = &self.pass_through[m] {
                // Stochastic transparency, in expectation: × probability × tint.
                let p = pt.probability_at(self, &ray, &si);
                for i in 0..tr.len() {
                    tr.set(i, tr.get(i) * p * pt.tint.get(i));
                }
                if tr.is_black() {
                    return false;
                }
            } else if !self.null_surface[m] {
                return false;
            } else if self.material_medium[m].is_some() {
                stack.cross(si.instance, si.material, front);
            }
            let origin = offset_ray_origin(si.p, if front { -si.ng } else { si.ng });
            let left = ray.tmax - h.t;
            ray = Ray { origin, tmin: 0.0, tmax: left, ..ray };
        }
        false
    }
}
