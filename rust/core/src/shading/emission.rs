//! Emission that varies over a surface (an Image Texture into Emission Color, a
//! procedural into Strength): the material's program runs at the point, the RGB terms
//! are summed and uplifted to a radiance spectrum there (eq. 10, the deferred
//! conversion, as for textured reflectances), both when a path hits the surface and
//! when next-event estimation or a light path samples a point on it.

use super::closure::EmissionTerm;
use super::program::{AttributeRequest, Program, ShadingPoint};
use crate::color::uplift::Uplift;
use crate::spectrum::SampledSpectrum;
use glam::Vec3;
use std::cell::RefCell;
use std::sync::Arc;

pub struct GraphEmission {
    pub program: Program,
    pub terms: Vec<EmissionTerm>,
    pub uplift: Arc<Uplift>,
}

thread_local! {
    static REGS: RefCell<Vec<Vec3>> = const { RefCell::new(Vec::new()) };
}

impl GraphEmission {
    /// The mesh data the program reads.
    pub fn requests(&self) -> &[AttributeRequest] {
        &self.program.attributes
    }

    /// Scene-linear RGB radiance at `sp` (≥ 0, finite).
    pub fn rgb(&self, sp: &ShadingPoint) -> Vec3 {
        REGS.with(|r| {
            let mut regs = r.borrow_mut();
            self.program.run(sp, &mut regs);
            let c = self.terms.iter().fold(Vec3::ZERO, |a, t| a + t.eval(&regs));
            Vec3::select(c.cmpge(Vec3::ZERO) & c.is_finite_mask(), c, Vec3::ZERO)
        })
    }

    /// Radiance spectrum at `sp` on the render's grid.
    pub fn radiance(&self, sp: &ShadingPoint, out: &mut SampledSpectrum) {
        let c = self.rgb(sp);
        self.uplift.illuminant_into(c.to_array(), out.values_mut());
    }
}
