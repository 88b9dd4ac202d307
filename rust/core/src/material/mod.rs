//! Materials: a BSDF plus optional emission. Integrators see BSDFs only through the
//! narrow [`Bsdf`] trait, so adding a material never touches an integrator.
//!
//! Conventions: directions are unit vectors in the local shading frame (normal = +z),
//! both pointing away from the surface; `wo` towards the viewer/previous vertex,
//! `wi` towards the light/next vertex.

pub mod catalogue;
pub mod conductor;
pub mod dielectric;
pub mod diffuse;
pub mod dispersion;
pub mod energy;
pub mod energy_tables;
pub mod fresnel;
pub mod layer;
pub mod metallic;
pub mod microfacet;
pub mod mix;
pub mod oren_nayar;
pub mod oriented;
pub mod param;
pub mod principled;
pub mod refraction;
pub mod sheen;
pub mod sheen_ltc;
pub mod subsurface;
#[cfg(test)]
pub mod testing;
pub mod texture;
pub mod thinfilm;
pub mod tinted;
pub mod translucent;

use crate::spectrum::{SampledSpectrum, WavelengthGrid};
use glam::{Vec2, Vec3A};

pub use conductor::{Conductor, Glossy};
pub use dielectric::{Dielectric, RoughDielectric};
pub use diffuse::Diffuse;
pub use dispersion::{IndexOfRefraction, IorDesc};
pub use layer::{Layered, TopLobe};
pub use mix::MixBsdf;
pub use oren_nayar::OrenNayar;
pub use oriented::Oriented;
pub use param::SpectralParam;
pub use principled::{Principled, PrincipledParams};
pub use sheen::Sheen;
pub use texture::{Texture, Wrap};
pub use thinfilm::ThinFilm;
pub use tinted::Tinted;
pub use translucent::Translucent;

/// What an integrator needs to know about a BSDF without evaluating it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BsdfFlags {
    /// Has a non-delta component that next-event estimation can evaluate.
    pub smooth: bool,
    /// Has a delta (perfectly specular) component.
    pub specular: bool,
    /// Its behaviour depends on wavelength in direction (refraction with λ-dependent
    /// index over the render's grid): polychromatic rays must collapse here (eq. 9).
    pub dispersive: bool,
}

/// Per-hit inputs of a BSDF evaluation.
pub struct ShadingContext<'a> {
    pub uv: Vec2,
    pub grid: &'a WavelengthGrid,
    /// Set when the path carries a single wavelength (grid index): monochromatic rays,
    /// or a polychromatic ray after it collapsed at a dispersive surface.
    pub single_wavelength: Option<usize>,
    /// The ray arrived on the side the geometric normal points to (from outside a closed
    /// mesh). The local frame is flipped to the arriving side, so refracting BSDFs need
    /// this to know whether they are entered or left.
    pub front_face: bool,
    /// What the path carries: radiance (camera paths) or importance (light paths).
    /// Refraction scales radiance by 1/η² but not importance (Veach 1997, §5.2).
    pub mode: TransportMode,
    /// What a shading graph reads at this hit (set only for materials with one).
    pub hit: crate::shading::ShadingPoint,
    /// At a dispersive surface of a whole-spectrum path: the uniform number the collapse
    /// (eq. 9: the reflection/refraction choice, then the wavelength) uses instead of the
    /// `uc` it is given, stratified across the pixel's samples (COLLAPSE STRATIFIED).
    pub collapse_u: Option<f32>,
    /// The vertex's shading frame (world ↔ the local directions BSDFs see): lobes with
    /// their own normal ([`Oriented`]) are placed in it when the hit's BSDF is built.
    pub frame: crate::geometry::Frame,
    /// Subsurface lobes walk (`material::subsurface`): set by the walks that follow them
    /// (BACKWARD camera paths, until a path has left one walk); otherwise they act as a
    /// diffuse of their base colour, as Cycles' BSSRDFs after a diffuse ancestor.
    pub subsurface_walk: bool,
    /// Set by a BSDF whose sample entered a subsurface lobe: the medium the path walks
    /// from the sampled (inward) direction. The walk takes it after each scattering.
    pub subsurface: std::cell::Cell<Option<subsurface::SubsurfaceEvent>>,
}

/// Which quantity a path transports, for the non-symmetric scattering of refraction.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TransportMode {
    /// Camera paths (backward tracing).
    #[default]
    Radiance,
    /// Light paths (forward tracing).
    Importance,
}

impl<'a> ShadingContext<'a> {
    /// A context for a camera path (radiance, all wavelengths, front face).
    pub fn new(grid: &'a WavelengthGrid) -> Self {
        Self {
            uv: Vec2::ZERO,
            grid,
            single_wavelength: None,
            front_face: true,
            mode: TransportMode::Radiance,
            hit: Default::default(),
            collapse_u: None,
            frame: crate::geometry::Frame::from_normal(Vec3A::Z),
            subsurface_walk: false,
            subsurface: std::cell::Cell::new(None),
        }
    }
}

/// The outcome of sampling a BSDF.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    pub wi: Vec3A,
    /// Solid-angle pdf of `wi` (for a delta lobe: the lobe's selection probability).
    pub pdf: f32,
    pub specular: bool,
    /// The ray collapsed to this grid wavelength (dispersive surfaces, eq. 9).
    pub collapsed_to: Option<usize>,
}

pub trait Bsdf: Send + Sync {
    fn flags(&self) -> BsdfFlags;
    /// The kinds of lobes it has, as ray-visibility bits (`geometry::visibility`:
    /// DIFFUSE, GLOSSY, TRANSMISSION; Cycles' closure labels): what a ray it scatters, or
    /// a light it is lit by, may be seen as. All three unless a BSDF knows better.
    fn lobe_kinds(&self) -> u8 {
        crate::geometry::visibility::DIFFUSE
            | crate::geometry::visibility::GLOSSY
            | crate::geometry::visibility::TRANSMISSION
    }
    /// `out` = f(wo, wi)·|cos θi| per wavelength; returns the pdf of sampling `wi`.
    fn eval(&self, ctx: &ShadingContext, wo: Vec3A, wi: Vec3A, out: &mut SampledSpectrum) -> f32;
    /// Pdf of sampling `wi` given `wo` (solid angle), for MIS.
    fn pdf(&self, ctx: &ShadingContext, wo: Vec3A, wi: Vec3A) -> f32;
    /// Samples `wi`; multiplies `throughput` by f·|cos θi|/pdf. `beta` is the path's
    /// current throughput before this bounce (dispersive BSDFs choose a wavelength ∝ it).
    /// On None (the path is absorbed) `throughput` may hold anything: callers end the
    /// path (`integrator::scatter` does too) or pass a copy they drop.
    fn sample(
        &self,
        ctx: &ShadingContext,
        wo: Vec3A,
        u: Vec2,
        uc: f32,
        throughput: &mut SampledSpectrum,
    ) -> Option<BsdfSample>;
    /// Directional-hemispherical reflectance seen from the normal, for the albedo pass.
    fn albedo(&self, ctx: &ShadingContext, out: &mut SampledSpectrum);
    /// For the albedo pass seen through mirrors and glass once a path carries one
    /// wavelength (after a dispersive collapse, or monochromatic rays): `out` = the
    /// weight f·|cos θi|/p of the specular event `wo → wi` that [`Bsdf::sample`] chose,
    /// at every grid wavelength, as if each had taken it with its own Fresnel factor,
    /// divided by the probability `p` that `sample` (given `throughput` and `ctx`) gave
    /// that event. False: not known here; the caller weighs by the carried wavelength's
    /// own factor (grey).
    fn specular_weights(
        &self,
        _ctx: &ShadingContext,
        _wo: Vec3A,
        _wi: Vec3A,
        _throughput: &SampledSpectrum,
        _out: &mut SampledSpectrum,
    ) -> bool {
        false
    }
}

/// A BSDF that reflects nothing (emission-only surfaces).
pub struct Black;

impl Bsdf for Black {
    fn lobe_kinds(&self) -> u8 {
        0
    }
    fn flags(&self) -> BsdfFlags {
        BsdfFlags::default()
    }
    fn eval(&self, _: &ShadingContext, _: Vec3A, _: Vec3A, out: &mut SampledSpectrum) -> f32 {
        out.fill(0.0);
        0.0
    }
    fn pdf(&self, _: &ShadingContext, _: Vec3A, _: Vec3A) -> f32 {
        0.0
    }
    fn sample(&self, _: &ShadingContext, _: Vec3A, _: Vec2, _: f32, _: &mut SampledSpectrum) -> Option<BsdfSample> {
        None
    }
    fn albedo(&self, _: &ShadingContext, out: &mut SampledSpectrum) {
        out.fill(0.0);
    }
}

/// A surface: how it scatters and what it emits.
pub struct Material {
    pub name: String,
    pub bsdf: Box<dyn Bsdf>,
    /// Emitted radiance per wavelength (both faces, or the front one when
    /// `one_sided`), if the surface is a light.
    pub emission: Option<SampledSpectrum>,
    /// Emission from the front face only (`MaterialDesc::one_sided`).
    pub one_sided: bool,
    /// Rays pass through after gathering the emission (`MaterialDesc::see_through`).
    pub see_through: bool,
    /// For a material driven by a graph per hit: the mesh data its program reads, by
    /// slot (the walk fills `ShadingContext::hit` only for these materials).
    pub hit_attributes: Option<Vec<crate::shading::program::AttributeRequest>>,
    /// An emission that varies over the surface (a node graph), evaluated at each hit
    /// from `ShadingContext::hit`; `emission` is then None.
    pub graph_emission: Option<std::sync::Arc<crate::shading::emission::GraphEmission>>,
    /// A shading normal from the graph (a linked Normal input), evaluated at each hit
    /// from `ShadingContext::hit`; the walk shades in its frame (`integrator::facing`).
    pub normal: Option<crate::scene::VaryingNormal>,
}
