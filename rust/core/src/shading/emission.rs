//! Emission that varies over a surface (an Image Texture into Emission Color, a
//! procedural into Strength): the material's program runs at the point, the RGB terms
//! are summed and uplifted to a radiance spectrum there (eq. 10, the deferred
//! conversion, as for textured reflectances), both when a path hits the surface and
//! when next-event estimation or a light path samples a point on it.

use super::closure::EmissionTerm;
use super::program::{AttributeRequest, Program, ShadingPoint};
use crate::color::uplift::Uplift;
use crate::spectrum::SampledSpectrum;
use glam::{Vec2, Vec3};
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

/// A triangle of a varying emitter, for light sampling: the shading points at its three
/// corners (the program reads their barycentric blend at a sampled point).
pub struct TriangleEmitter {
    pub emission: Arc<GraphEmission>,
    pub corners: [ShadingPoint; 3],
}

impl TriangleEmitter {
    /// The shading point at barycentrics (b1, b2), seen along `incoming` (unit, from the
    /// point towards the viewer).
    pub fn point(&self, b1: f32, b2: f32, incoming: Vec3) -> ShadingPoint {
        let [c0, c1, c2] = &self.corners;
        let b0 = 1.0 - b1 - b2;
        let l3 = |a: Vec3, b: Vec3, c: Vec3| a * b0 + b * b1 + c * b2;
        let mut sp = *c0;
        sp.position = l3(c0.position, c1.position, c2.position);
        sp.object_position = l3(c0.object_position, c1.object_position, c2.object_position);
        sp.generated = l3(c0.generated, c1.generated, c2.generated);
        let n = l3(c0.normal, c1.normal, c2.normal).normalize_or(c0.true_normal);
        let ng = c0.true_normal;
        let backfacing = ng.dot(incoming) < 0.0;
        let flip = |v: Vec3| if backfacing { -v } else { v };
        sp.normal = flip(n);
        sp.true_normal = flip(ng);
        let t = l3(c0.tangent, c1.tangent, c2.tangent);
        sp.tangent = (t - sp.normal * sp.normal.dot(t)).normalize_or(c0.tangent);
        sp.incoming = incoming;
        sp.backfacing = backfacing;
        sp.uv = c0.uv * b0 + c1.uv * b1 + c2.uv * b2;
        sp.parametric = Vec2::new(b1, b2);
        for k in 0..sp.attributes.len() {
            sp.attributes[k] =
                std::array::from_fn(|i| c0.attributes[k][i] * b0 + c1.attributes[k][i] * b1 + c2.attributes[k][i] * b2);
        }
        sp
    }

    pub fn radiance(&self, b1: f32, b2: f32, incoming: Vec3, out: &mut SampledSpectrum) {
        self.emission.radiance(&self.point(b1, b2, incoming), out);
    }

    /// The light-selection estimate: the triangle's mean radiance over `n × n`
    /// stratified points (seen from the front).
    pub fn mean_radiance(&self, n: usize, out: &mut SampledSpectrum) {
        let mut sum = Vec3::ZERO;
        let mut count: f32 = 0.0;
        let incoming = self.corners[0].true_normal;
        for i in 0..n {
            for j in 0..n {
                let (u, v) = ((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                // Square → triangle (uniform), as the light sampler does.
                let su = u.sqrt();
                let (b1, b2) = (su * (1.0 - v), su * v);
                sum += self.emission.rgb(&self.point(b1, b2, incoming));
                count += 1.0;
            }
        }
        let mean = sum / count.max(1.0);
        self.emission.uplift.illuminant_into(mean.to_array(), out.values_mut());
    }
}
