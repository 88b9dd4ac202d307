//! Homogeneous participating media: the interior of a closed mesh whose material has a
//! volume (docs/media.md). Coefficients are per wavelength, as the render's grid samples
//! them, so Beer–Lambert attenuation `exp(−σt(λ)·d)` is exact per wavelength.
//!
//! Which media a point is in is a [`MediumStack`] carried by the path, as Cycles' volume
//! stack (`volume_stack_enter_exit`, intern/cycles/kernel/integrator/volume_stack.h):
//! crossing a boundary into a mesh adds its (instance, material) entry, leaving removes
//! it, and media that overlap (nested objects) add their coefficients, as Cycles sums the
//! volume closures of every stack entry.

use super::phase::HenyeyGreenstein;
use crate::spectrum::SampledSpectrum;

/// One medium, on the render's grid (coefficients per scene unit of length).
#[derive(Clone, Debug)]
pub struct HomogeneousMedium {
    /// The material it belongs to (messages).
    pub name: String,
    pub sigma_a: SampledSpectrum,
    pub sigma_s: SampledSpectrum,
    /// σa + σs.
    pub sigma_t: SampledSpectrum,
    pub phase: HenyeyGreenstein,
    /// Emitted radiance per unit length (Cycles' volume emission), if any.
    pub emission: Option<SampledSpectrum>,
}

impl HomogeneousMedium {
    /// Builds a medium from validated coefficients: finite, non-negative (the scene
    /// builder reports anything else naming the material).
    pub fn new(
        name: &str,
        sigma_a: SampledSpectrum,
        sigma_s: SampledSpectrum,
        g: f32,
        emission: Option<SampledSpectrum>,
    ) -> Self {
        let mut sigma_t = sigma_a.clone();
        sigma_t.add_assign(&sigma_s);
        Self { name: name.to_string(), sigma_a, sigma_s, sigma_t, phase: HenyeyGreenstein::new(g), emission }
    }

    /// Scatters at some wavelength of the grid.
    pub fn scatters(&self) -> bool {
        !self.sigma_s.is_black()
    }
}

/// Entries a path can be inside at once (Cycles' default volume stack holds 32 only
/// for many objects; nested liquids in glass need a handful).
pub const STACK_SIZE: usize = 8;

/// The instance of the world's medium on a stack (no mesh has it): its entry is
/// (WORLD_INSTANCE, index into the scene's media), which no boundary crossing removes.
pub const WORLD_INSTANCE: u32 = u32::MAX;

/// The media around a point of a path: (instance, material) of every closed mesh with a
/// volume the path entered and has not left. Copy, so path states stay plain values.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MediumStack {
    entries: [(u32, u32); STACK_SIZE],
    len: u8,
}

impl MediumStack {
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
    /// The (instance, material) entries.
    pub fn entries(&self) -> &[(u32, u32)] {
        &self.entries[..self.len as usize]
    }
    /// Adds `entry` unless present or the stack is full (the camera's starting media).
    pub fn push(&mut self, entry: (u32, u32)) {
        if !self.entries().contains(&entry) && (self.len as usize) < STACK_SIZE {
            self.entries[self.len as usize] = entry;
            self.len += 1;
        }
    }
    /// Crossing a boundary of `instance` with `material` (which has a volume): entering
    /// when the path arrived on the front face (from outside a closed mesh), leaving
    /// otherwise. Entering twice or leaving what was never entered changes nothing
    /// (open or doubly wound meshes); a full stack ignores further media.
    pub fn cross(&mut self, instance: u32, material: u32, front_face: bool) {
        let key = (instance, material);
        let pos = self.entries().iter().position(|&e| e == key);
        match (front_face, pos) {
            (true, None) if (self.len as usize) < STACK_SIZE => {
                self.entries[self.len as usize] = key;
                self.len += 1;
            }
            (false, Some(k)) => {
                let n = self.len as usize;
                self.entries.copy_within(k + 1..n, k);
                self.len -= 1;
            }
            _ => {}
        }
    }
}

/// exp(−σ·d) that is 1 for σ = 0 at any d (also ∞) and 0 for σ > 0 at d = ∞.
#[inline]
pub fn transmittance(sigma: f32, d: f32) -> f32 {
    if sigma <= 0.0 {
        1.0
    } else {
        (-sigma * d).exp()
    }
}

/// ∫₀ᵈ exp(−σ·t) dt: the length-weighted emission of a segment, d at σ = 0.
#[inline]
pub fn emission_integral(sigma: f32, d: f32) -> f32 {
    if sigma * d < 1e-4 {
        // Series avoids cancellation in 1 − exp(−x) (and 0/0 at σ = 0).
        d * (1.0 - 0.5 * sigma * d)
    } else {
        -(-sigma * d).exp_m1() / sigma
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stack_enters_leaves_and_ignores_repeats() {
        let mut s = MediumStack::default();
        s.cross(1, 2, true);
        s.cross(1, 2, true);
        s.cross(3, 4, true);
        assert_eq!(s.entries(), &[(1, 2), (3, 4)]);
        s.cross(1, 2, false);
        assert_eq!(s.entries(), &[(3, 4)]);
        s.cross(9, 9, false);
        assert_eq!(s.entries(), &[(3, 4)]);
        s.cross(3, 4, false);
        assert!(s.is_empty());
        for k in 0..20 {
            s.cross(k, 0, true);
        }
        assert_eq!(s.entries().len(), STACK_SIZE);
    }

    #[test]
    fn closed_forms_at_the_extremes() {
        assert_eq!(transmittance(0.0, f32::INFINITY), 1.0);
        assert_eq!(transmittance(1.0, f32::INFINITY), 0.0);
        assert_eq!(transmittance(1e30, 1e-6), 0.0);
        assert!((transmittance(2.0, 0.5) - (-1.0f32).exp()).abs() < 1e-6);
        assert_eq!(emission_integral(0.0, 2.0), 2.0);
        assert!((emission_integral(2.0, 1.0) - (1.0 - (-2.0f32).exp()) / 2.0).abs() < 1e-6);
        assert!((emission_integral(1e30, 1.0) - 1e-30).abs() < 1e-36);
        assert!(emission_integral(1e-8, 1e-3).is_finite());
    }
}
