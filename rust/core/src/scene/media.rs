//! The scene's homogeneous media: built from a material's `volume` description, looked
//! up through a path's [`MediumStack`], and the transmittance of shadow rays through
//! them (docs/media.md).

use super::{Scene, VolumeDesc};
use crate::geometry::{offset_ray_origin, Ray};
use crate::medium::homogeneous::{transmittance, WORLD_INSTANCE};
use crate::medium::{HomogeneousMedium, MediumStack};
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
/// image).
pub fn build_medium(
    kind: &'static str,
    name: &str,
    v: &VolumeDesc,
    spectrum: impl Fn(&SpectrumDesc, SpectrumRole, &str) -> Result<SampledSpectrum>,
) -> Result<Option<HomogeneousMedium>> {
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
    if sigma_a.is_none() && sigma_s.is_none() && emission.is_none() {
        return Ok(None);
    }
    let n = [&sigma_a, &sigma_s, &emission].iter().find_map(|s| s.as_ref().map(|s| s.len())).unwrap_or(0);
    let zero = || SampledSpectrum::zeros(n);
    Ok(Some(HomogeneousMedium::new(
        name,
        sigma_a.unwrap_or_else(zero),
        sigma_s.unwrap_or_else(zero),
        v.anisotropy,
        emission,
    )))
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

    /// The medium of stack entry (instance, material), or (WORLD_INSTANCE, medium).
    fn entry_medium(&self, (i, m): (u32, u32)) -> Option<&HomogeneousMedium> {
        if i == WORLD_INSTANCE {
            return self.media.get(m as usize);
        }
        self.material_medium.get(m as usize).copied().flatten().map(|k| &self.media[k as usize])
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
        let mut any = false;
        for &e in stack.entries() {
            let Some(m) = self.entry_medium(e) else { continue };
            any = true;
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
        let scattering = || stack.entries().iter().filter_map(|&e| self.entry_medium(e)).filter(|m| m.scatters());
        if c.scattering_media <= 1 {
            let m = scattering().next()?;
            weight.fill(1.0);
            return Some(m.phase.sample(d, u));
        }
        let total: f32 = scattering().map(|m| m.sigma_s.sum()).sum();
        let mut pick = uc * total;
        let mut chosen = None;
        for m in scattering() {
            chosen = Some(m);
            pick -= m.sigma_s.sum();
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
        let scattering = || stack.entries().iter().filter_map(|&e| self.entry_medium(e)).filter(|m| m.scatters());
        if c.scattering_media <= 1 {
            let p = scattering().next().map_or(0.0, |m| m.phase.eval(cos));
            out.fill(p);
            return p;
        }
        let total = if total > 0.0 { total } else { scattering().map(|m| m.sigma_s.sum()).sum() };
        out.fill(0.0);
        let mut pdf = 0.0;
        for m in scattering() {
            let p = m.phase.eval(cos);
            pdf += m.sigma_s.sum() / total * p;
            out.add_scaled(&m.sigma_s, p);
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
    ) -> bool {
        tr.fill(1.0);
        let mut ray = *ray;
        for _ in 0..VOLUME_BOUNDS_MAX {
            let hit = self.intersect(&ray);
            let end = hit.map_or(ray.tmax, |h| h.t);
            if self.coefficients(&stack, c) {
                for i in 0..tr.len() {
                    tr.set(i, tr.get(i) * transmittance(c.sigma_t.get(i), end));
                }
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
