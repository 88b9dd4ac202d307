//! A lobe with its own shading normal: Cycles gives every closure its own `N` (the BSDF
//! node's Normal input, the Principled Coat Normal; intern/cycles/kernel/svm/closure.h),
//! so the lobes of one material may be oriented differently. [`Oriented`] evaluates its
//! inner BSDF in a frame about its normal `n`, given in the caller's shading frame; the
//! caller's frame (the vertex's, built about the geometric normal for such materials)
//! decides which side of the surface a direction is on, as Cycles' `bsdf_eval` /
//! `bsdf_sample` decide by `Ng` (kernel/closure/bsdf.h). A direction the lobe calls a
//! reflection but the surface a transmission (or the reverse) carries nothing, so no
//! light leaks through the surface whatever the lobe's normal.

use super::{Bsdf, BsdfFlags, BsdfSample, ShadingContext};
use crate::geometry::Frame;
use crate::spectrum::SampledSpectrum;
use glam::{Vec2, Vec3A};

/// The least cosine of the view direction about a lobe normal: a raw (uncorrected)
/// normal may tilt away from the viewer (a strong normal map at a silhouette). Cycles'
/// diffuse and sheen closures then still reflect (they read only the light direction's
/// cosine); lifting the view just above the lobe's horizon gives the Lambertian lobe
/// exactly that.
const MIN_VIEW_COS: f32 = 1e-4;

/// A frame about a lobe's normal inside the vertex's shading frame.
#[derive(Clone, Copy, Debug)]
pub struct LobeFrame {
    frame: Frame,
}

impl LobeFrame {
    /// `n`: the lobe's unit normal in the vertex's shading frame (facing the viewer's
    /// side, `n.z > 0` for a valid one).
    pub fn new(n: Vec3A) -> Self {
        Self { frame: Frame::from_normal(n.try_normalize().unwrap_or(Vec3A::Z)) }
    }

    /// The lobe's normal in the vertex's frame.
    pub fn normal(&self) -> Vec3A {
        self.frame.n
    }

    /// A vertex-frame direction in the lobe's frame.
    #[inline]
    pub fn to_lobe(&self, v: Vec3A) -> Vec3A {
        self.frame.to_local(v)
    }

    /// The view direction `wo` in the lobe's frame, lifted above its horizon when the
    /// vertex sees it from above and the lobe's normal tilts away (see [`MIN_VIEW_COS`]).
    #[inline]
    pub fn view_to_lobe(&self, wo: Vec3A) -> Vec3A {
        let w = self.frame.to_local(wo);
        if wo.z > 0.0 && w.z < MIN_VIEW_COS {
            let t = Vec2::new(w.x, w.y);
            let s = (1.0 - MIN_VIEW_COS * MIN_VIEW_COS).sqrt() / t.length().max(f32::MIN_POSITIVE);
            Vec3A::new(w.x * s, w.y * s, MIN_VIEW_COS)
        } else {
            w
        }
    }

    #[inline]
    pub fn to_vertex(&self, v: Vec3A) -> Vec3A {
        self.frame.to_world(v)
    }
}

/// Whether a pair is on the same side (reflection) or opposite sides (transmission) in
/// both frames.
#[inline]
pub fn same_event(wo: Vec3A, wi: Vec3A, wo_l: Vec3A, wi_l: Vec3A) -> bool {
    (wi.z * wo.z < 0.0) == (wi_l.z * wo_l.z < 0.0) && wi.z != 0.0 && wi_l.z != 0.0
}

/// A BSDF evaluated about its own normal (see the module documentation).
pub struct Oriented {
    pub frame: LobeFrame,
    pub inner: Box<dyn Bsdf>,
    /// For a diffuse lobe (Diffuse, Sheen): the smooth normal `sd->N` in the vertex's
    /// frame, for Cycles' bump shadowing term ([`bump_shadowing_term`]).
    pub smooth: Option<Vec3A>,
}

impl Oriented {
    pub fn new(n: Vec3A, inner: Box<dyn Bsdf>) -> Self {
        Self { frame: LobeFrame::new(n), inner, smooth: None }
    }

    /// A diffuse lobe about `n` whose smooth normal is `smooth`.
    pub fn diffuse(n: Vec3A, smooth: Option<Vec3A>, inner: Box<dyn Bsdf>) -> Self {
        Self { smooth, ..Self::new(n, inner) }
    }

    #[inline]
    fn shadowing(&self, wi: Vec3A) -> f32 {
        self.smooth.map_or(1.0, |ns| bump_shadowing_term(ns, self.frame.normal(), wi))
    }
}

/// Cycles' `bump_shadowing_term` (Blender 4.5, intern/cycles/kernel/closure/bsdf.h, from
/// Conty Estevez, Lecocq and Stein 2019, "A Microfacet-Based Shadowing Function to Solve
/// the Bump Terminator Problem"), which `bsdf_eval` and `bsdf_sample` apply to a diffuse
/// closure whose normal `n` is not the smooth normal `ns`: 0 for light `i` on the other
/// side of the smooth surface than `n` expects, else the GGX shadowing G1(cos θ_i about
/// `ns`) of a roughness α² = min(tan²θ_d/8, 1) set by the bend θ_d between `n` and `ns`.
/// (Blender 4.4 and older used Chiang, Li and Burley's 2019 smoothstep instead.)
pub fn bump_shadowing_term(ns: Vec3A, n: Vec3A, i: Vec3A) -> f32 {
    let (cos_nsi, cos_nsn, cos_ni) = (ns.dot(i), ns.dot(n), n.dot(i));
    if cos_nsi * cos_nsn * cos_ni < 0.0 {
        return 0.0;
    }
    let (cos_i, cos_d) = (cos_nsi.abs(), cos_nsn.abs());
    if cos_d >= 1.0 || cos_i >= 1.0 {
        return 1.0;
    }
    if cos_i < 1e-6 {
        return 0.0;
    }
    let alpha2 = (0.125 * (1.0 / (cos_d * cos_d) - 1.0)).clamp(0.0, 1.0);
    let lambda = 0.5 * ((1.0 + alpha2 * (1.0 / (cos_i * cos_i) - 1.0).max(0.0)).sqrt() - 1.0);
    1.0 / (1.0 + lambda)
}

impl Bsdf for Oriented {
    fn flags(&self) -> BsdfFlags {
        self.inner.flags()
    }
    fn lobe_kinds(&self) -> u8 {
        self.inner.lobe_kinds()
    }
    fn eval(&self, ctx: &ShadingContext, wo: Vec3A, wi: Vec3A, out: &mut SampledSpectrum) -> f32 {
        let (a, b) = (self.frame.view_to_lobe(wo), self.frame.to_lobe(wi));
        if !same_event(wo, wi, a, b) {
            out.fill(0.0);
            return 0.0;
        }
        let pdf = self.inner.eval(ctx, a, b, out);
        if self.smooth.is_some() {
            out.scale(self.shadowing(wi));
        }
        pdf
    }
    fn pdf(&self, ctx: &ShadingContext, wo: Vec3A, wi: Vec3A) -> f32 {
        let (a, b) = (self.frame.view_to_lobe(wo), self.frame.to_lobe(wi));
        if !same_event(wo, wi, a, b) {
            return 0.0;
        }
        self.inner.pdf(ctx, a, b)
    }
    fn sample(
        &self,
        ctx: &ShadingContext,
        wo: Vec3A,
        u: Vec2,
        uc: f32,
        throughput: &mut SampledSpectrum,
    ) -> Option<BsdfSample> {
        let a = self.frame.view_to_lobe(wo);
        // In place: on None the throughput is the caller's to drop (`Bsdf::sample`), so
        // no copy of it (a heap spectrum) per sample.
        let s = self.inner.sample(ctx, a, u, uc, throughput)?;
        let wi = self.frame.to_vertex(s.wi);
        if !same_event(wo, wi, a, s.wi) {
            return None;
        }
        if self.smooth.is_some() {
            let k = self.shadowing(wi);
            if k <= 0.0 {
                return None;
            }
            throughput.scale(k);
        }
        Some(BsdfSample { wi, ..s })
    }
    fn albedo(&self, ctx: &ShadingContext, out: &mut SampledSpectrum) {
        self.inner.albedo(ctx, out)
    }
    fn specular_weights(
        &self,
        ctx: &ShadingContext,
        wo: Vec3A,
        wi: Vec3A,
        throughput: &SampledSpectrum,
        out: &mut SampledSpectrum,
    ) -> bool {
        self.inner.specular_weights(ctx, self.frame.view_to_lobe(wo), self.frame.to_lobe(wi), throughput, out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::{Diffuse, SpectralParam};
    use crate::spectrum::WavelengthGrid;

    #[test]
    fn a_tilted_mirror_reflects_about_its_own_normal() {
        let grid = WavelengthGrid::uniform(4, 400.0, 700.0).unwrap();
        let ctx = ShadingContext::new(&grid);
        let mirror = crate::scene::optics::build_glossy("m", SampledSpectrum::splat(4, 1.0), 0.0).unwrap();
        let n = Vec3A::new(0.3, -0.1, 1.0).normalize();
        let o = Oriented::new(n, mirror);
        let wo = Vec3A::new(-0.2, 0.4, 1.0).normalize();
        let mut tp = SampledSpectrum::splat(4, 1.0);
        let s = o.sample(&ctx, wo, Vec2::new(0.3, 0.6), 0.5, &mut tp).expect("a mirror reflects");
        let r = 2.0 * wo.dot(n) * n - wo;
        assert!((s.wi - r).length() < 1e-5, "{} vs mirror about n {r}", s.wi);
        assert!(s.specular);
    }

    #[test]
    fn a_reflection_below_the_surface_carries_nothing() {
        let grid = WavelengthGrid::uniform(4, 400.0, 700.0).unwrap();
        let ctx = ShadingContext::new(&grid);
        let d = Box::new(Diffuse { reflectance: SpectralParam::Constant(SampledSpectrum::splat(4, 0.8)) });
        // A normal tilted 60° along x: part of its hemisphere lies below the surface.
        let n = Vec3A::new(60f32.to_radians().sin(), 0.0, 60f32.to_radians().cos());
        let o = Oriented::new(n, d);
        let wo = Vec3A::new(0.5, 0.0, 0.8).normalize();
        let below = Vec3A::new(0.9, 0.0, -0.2).normalize();
        let mut f = SampledSpectrum::zeros(4);
        assert_eq!(o.eval(&ctx, wo, below, &mut f), 0.0);
        assert_eq!(f.max_value(), 0.0);
        // Above both: the Lambertian about n, cos taken about n.
        let wi = Vec3A::new(0.6, 0.0, 0.5).normalize();
        o.eval(&ctx, wo, wi, &mut f);
        assert!((f.get(0) - 0.8 / std::f32::consts::PI * wi.dot(n)).abs() < 1e-6, "{}", f.get(0));
        // Every sample is on the viewer's side of the surface.
        for k in 0..64 {
            let u = Vec2::new((k as f32 + 0.5) / 64.0, ((k * 37) % 64) as f32 / 64.0 + 0.005);
            let mut tp = SampledSpectrum::splat(4, 1.0);
            if let Some(s) = o.sample(&ctx, wo, u, 0.5, &mut tp) {
                assert!(s.wi.z > 0.0, "{}", s.wi);
            }
        }
    }

    fn white(n: usize) -> SpectralParam {
        SpectralParam::Constant(SampledSpectrum::splat(n, 1.0))
    }

    fn mirror_about(wo: Vec3A, n: Vec3A) -> Vec3A {
        2.0 * wo.dot(n) * n - wo
    }

    /// A smooth coat about a tilted Coat Normal over a mirror base about another normal:
    /// every sample is the mirror direction about one of the two, and both occur.
    #[test]
    fn a_tilted_coat_reflects_about_its_normal_and_the_base_about_its_own() {
        use crate::material::{Layered, TopLobe};
        let grid = WavelengthGrid::uniform(4, 400.0, 700.0).unwrap();
        let ctx = ShadingContext::new(&grid);
        let (nb, nc) = (Vec3A::new(-0.25, 0.05, 1.0).normalize(), Vec3A::new(0.3, 0.2, 1.0).normalize());
        let base = crate::scene::optics::build_glossy("m", SampledSpectrum::splat(4, 1.0), 0.0).unwrap();
        let coat = TopLobe::coat(1.0, 0.0, 1.5, white(4));
        let m = Layered::new(coat, Box::new(Oriented::new(nb, base))).with_top_normal(Some(nc));
        let wo = Vec3A::new(0.35, -0.3, 1.0).normalize();
        let (rc, rb) = (mirror_about(wo, nc), mirror_about(wo, nb));
        let mut seen = [0; 2];
        for k in 0..200 {
            let mut tp = SampledSpectrum::splat(4, 1.0);
            let s = m.sample(&ctx, wo, Vec2::new(0.4, 0.7), (k as f32 + 0.5) / 200.0, &mut tp).expect("reflects");
            assert!(s.specular && tp.is_finite());
            if (s.wi - rc).length() < 1e-5 {
                seen[0] += 1;
            } else if (s.wi - rb).length() < 1e-5 {
                seen[1] += 1;
            } else {
                panic!("{} is neither the coat's mirror {rc} nor the base's {rb}", s.wi);
            }
        }
        assert!(seen[0] > 0 && seen[1] > 0, "{seen:?}");
    }

    /// White furnace with lobes about their own normals, tilted up to 35° from the
    /// surface's: a Mix of a white rough glossy and a white diffuse, and a white coat
    /// over a white diffuse, each about its own normal, reflect at most everything (what a
    /// tilted lobe sends below the surface is lost, never gained), the sampled albedo
    /// equals a quadrature of eval, and sample() agrees with pdf().
    #[test]
    fn white_furnace_holds_with_lobes_about_their_own_normals() {
        use crate::material::testing::{quadrature_albedo, sampled_albedo};
        use crate::material::{Layered, MixBsdf, TopLobe};
        let grid = WavelengthGrid::uniform(4, 400.0, 700.0).unwrap();
        let ctx = ShadingContext::new(&grid);
        let diffuse = || Box::new(Diffuse { reflectance: white(4) }) as Box<dyn Bsdf>;
        let tilt = |deg: f32, phi: f32| {
            let (t, p) = (deg.to_radians(), phi.to_radians());
            Vec3A::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
        };
        let glossy = crate::scene::optics::build_glossy("g", SampledSpectrum::splat(4, 1.0), 0.4).unwrap();
        let mix = MixBsdf::mix(
            Box::new(Oriented::new(tilt(35.0, 0.0), glossy)),
            Box::new(Oriented::new(tilt(20.0, 120.0), diffuse())),
            0.5,
        );
        let coated =
            Layered::new(TopLobe::coat(1.0, 0.2, 1.5, white(4)), Box::new(Oriented::new(tilt(25.0, 200.0), diffuse())))
                .with_top_normal(Some(tilt(30.0, 60.0)));
        for (name, m) in [("mix", &mix as &dyn Bsdf), ("coat", &coated)] {
            for (k, cos) in [1.0f32, 0.7, 0.35, 0.1].into_iter().enumerate() {
                let wo = crate::material::testing::dir(cos, 0.8);
                let (a, se) = sampled_albedo(m, &ctx, wo, 20_000, 7 + k as u64, 0);
                assert!(a <= 1.0 + 4.0 * se + 1e-3, "{name} at cos {cos}: albedo {a} ± {se}");
                if k == 1 {
                    let q = quadrature_albedo(m, &ctx, wo, 0);
                    assert!((a - q).abs() <= 4.0 * se + 0.01, "{name}: sampled {a} ± {se} vs quadrature {q}");
                }
            }
        }
    }

    /// Blender 4.5's term: 0 for light behind the smooth surface (seen from the bent
    /// normal's side), 1 about the smooth normal itself, and between the GGX G1 of
    /// α² = tan²θ_d/8 at the light's cosine about the smooth normal.
    #[test]
    fn bump_shadowing_term_is_blender_45s() {
        let ns = Vec3A::Z;
        let n = Vec3A::new(0.5, 0.0, 0.75f32.sqrt());
        assert_eq!(bump_shadowing_term(ns, ns, Vec3A::new(0.3, 0.1, 0.9).normalize()), 1.0);
        assert_eq!(bump_shadowing_term(ns, n, Vec3A::new(0.9, 0.0, -0.1).normalize()), 0.0);
        // cos θ_d = √3/2: tan² = 1/3, α² = 1/24; light at cos θ_i = 0.6 about ns.
        let i = Vec3A::new(0.8, 0.0, 0.6);
        let (a2, t2) = (1.0f64 / 24.0, 1.0f64 / 0.36 - 1.0);
        let g1 = 1.0 / (1.0 + 0.5 * ((1.0 + a2 * t2).sqrt() - 1.0));
        let t = bump_shadowing_term(ns, n, i) as f64;
        assert!((t - g1).abs() < 1e-6 && t < 1.0, "{t} vs {g1}");
        // Grazing light is dimmed more, and the term is the same for the light on the
        // other side of the bend.
        let low = bump_shadowing_term(ns, n, Vec3A::new(0.99, 0.0, 0.141).normalize());
        assert!(low < t as f32 && low > 0.0, "{low}");
        let mirrored = bump_shadowing_term(ns, n, Vec3A::new(-0.8, 0.0, 0.6));
        assert!((mirrored as f64 - g1).abs() < 1e-6, "{mirrored}");
    }
}
