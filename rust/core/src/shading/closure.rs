//! The closure part of a graph (Principled, Diffuse, Glossy, Glass, Refraction,
//! Translucent, Sheen, Emission, Transparent, Mix Shader, Add Shader): every non-closure
//! input they read becomes a parameter, a constant or a register of the program. A
//! graph whose parameters are all constant is lowered to the fixed [`BsdfDesc`], so it
//! is built exactly as the equivalent fixed material.

use super::compile::{Compiler, Value};
use super::desc::InputDesc;
use super::program::Reg;
use crate::material::IorDesc;
use crate::scene::{BsdfDesc, CoatDesc, MixFactorDesc, SheenLayerDesc, SubsurfaceDesc};
use crate::spectrum::named::SpectrumKind;
use crate::spectrum::SpectrumDesc;
use crate::{Error, Result};
use glam::Vec3;

/// Deepest nesting of Mix/Add Shader nodes (guards the recursion).
const MAX_DEPTH: usize = 64;

/// What the surface emits: an RGB radiance, a spectral one, or a sum of RGB terms
/// that vary over the surface (evaluated per hit and uplifted there, docs/shading.md).
#[derive(Clone, Debug)]
pub enum Emission {
    Rgb(Vec3),
    Spectrum(SpectrumDesc),
    Varying(Vec<EmissionTerm>),
}

/// One term of a varying emission: `rgb × colour register × strength register` (a
/// missing register reads 1), clamped to ≥ 0 per hit.
#[derive(Clone, Debug)]
pub struct EmissionTerm {
    pub color: Option<Reg>,
    pub strength: Option<Reg>,
    pub rgb: Vec3,
    /// Mix Shader factors on the way (register, and whether this is the first shader:
    /// weight 1 − Fac), each clamped to 0..1.
    pub weights: Vec<(Reg, bool)>,
}

impl EmissionTerm {
    /// The term's RGB radiance from the program's registers.
    pub fn eval(&self, regs: &[Vec3]) -> Vec3 {
        let c = self.color.map_or(Vec3::ONE, |r| regs[r as usize].max(Vec3::ZERO));
        let mut s = self.strength.map_or(1.0, |r| regs[r as usize].x.max(0.0));
        for &(r, first) in &self.weights {
            let f = regs[r as usize].x.clamp(0.0, 1.0);
            s *= if first { 1.0 - f } else { f };
        }
        (self.rgb * c * s).max(Vec3::ZERO)
    }
}

impl Emission {
    fn scaled(self, s: f32) -> Self {
        match self {
            Emission::Rgb(c) => Emission::Rgb(c * s),
            Emission::Spectrum(mut d) => {
                d.scale *= s;
                Emission::Spectrum(d)
            }
            Emission::Varying(mut t) => {
                for x in &mut t {
                    x.rgb *= s;
                }
                Emission::Varying(t)
            }
        }
    }
}

/// A constant surface: the fixed description and its emission.
pub struct Lowered {
    pub bsdf: BsdfDesc,
    pub emission: Option<SpectrumDesc>,
}

/// A float closure parameter: a constant, or a register clamped to `lo..hi` per hit.
#[derive(Clone, Debug)]
pub enum F {
    C(f32),
    R(Reg, f32, f32),
}

/// A colour closure parameter: a constant spectrum, or an RGB register (clamped to 0..1).
#[derive(Clone, Debug)]
pub enum Col {
    C(SpectrumDesc),
    R(Reg),
}

/// An IOR parameter.
#[derive(Clone, Debug)]
pub enum Ior {
    C(IorDesc),
    R(Reg),
}

/// The Principled BSDF's Coat parameters (see [`CoatDesc`]).
#[derive(Clone, Debug)]
pub struct CoatT {
    pub weight: F,
    pub roughness: F,
    pub ior: F,
    pub tint: Col,
    /// A linked Coat Normal (None: the smooth normal, as Cycles' `sd->N`).
    pub normal: Option<Reg>,
}

/// Where a closure's own normal comes from (Cycles' svm_node_closure_bsdf,
/// intern/cycles/kernel/svm/closure.h): its Normal input's register (None: the smooth
/// normal `sd->N`), and whether it is made valid for specular reflection
/// (`maybe_ensure_valid_specular_reflection`: the Glossy, Glass, Refraction and
/// Translucent closures and the Principled's specular, metal, glass and coat lobes; not
/// Diffuse or Sheen, nor the Principled's diffuse and sheen).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LobeNormal {
    pub reg: Option<Reg>,
    pub valid_reflection: bool,
}

/// What instantiating a template at a hit needs to orient its lobes: the vertex's
/// shading frame (about the geometric normal for materials with lobe normals), the
/// geometric and smooth normals and the incoming direction, all facing the ray as
/// [`super::ShadingPoint`]'s.
#[derive(Clone, Copy, Debug)]
pub struct Orient {
    pub frame: crate::geometry::Frame,
    pub ng: Vec3,
    pub incoming: Vec3,
    pub smooth: Vec3,
}

impl Orient {
    pub fn at(sp: &super::ShadingPoint, frame: crate::geometry::Frame) -> Self {
        Self { frame, ng: sp.true_normal, incoming: sp.incoming, smooth: sp.normal }
    }

    /// A closure's normal before any correction: its register's value normalised, the
    /// smooth normal when unlinked or zero (Cycles' `safe_normalize_fallback(N, sd->N)`).
    fn raw(&self, v: &dyn Fn(Reg) -> Vec3, reg: Option<Reg>) -> Vec3 {
        reg.and_then(|r| v(r).try_normalize()).unwrap_or(self.smooth)
    }

    /// Cycles' `maybe_ensure_valid_specular_reflection` (kernel/closure/bsdf_util.h):
    /// unchanged when equal to the geometric normal, else bent just enough that the
    /// mirror direction of the incoming ray stays above the surface.
    pub fn valid(&self, n: Vec3) -> Vec3 {
        if n == self.ng {
            n
        } else {
            super::vector::ensure_valid_specular_reflection(self.ng, self.incoming, n)
        }
    }

    fn normal(&self, v: &dyn Fn(Reg) -> Vec3, n: LobeNormal) -> Vec3 {
        let raw = self.raw(v, n.reg);
        if n.valid_reflection {
            self.valid(raw)
        } else {
            raw
        }
    }

    /// A Tangent input's value in the vertex's frame (None: no register, or a zero vector).
    fn tangent(&self, v: &dyn Fn(Reg) -> Vec3, reg: Option<Reg>) -> Option<[f32; 3]> {
        let t = v(reg?);
        (t.is_finite() && t.length_squared() > 0.0).then(|| self.frame.to_local(t.into()).to_array())
    }

    /// `n` in the vertex's frame; None when it is the frame's own normal (nothing to orient).
    fn local(&self, n: Vec3) -> Option<[f32; 3]> {
        let l = self.frame.to_local(n.into());
        ((l - glam::Vec3A::Z).length_squared() > 1e-12).then(|| l.to_array())
    }
}

/// The Principled BSDF's Anisotropic (0..1), Anisotropic Rotation (turns) and the
/// Tangent's register.
#[derive(Clone, Debug)]
pub struct AnisoT {
    pub anisotropic: F,
    pub rotation: F,
    pub tangent: Reg,
}

/// The Principled BSDF's Sheen parameters (see [`SheenLayerDesc`]).
#[derive(Clone, Debug)]
pub struct SheenT {
    pub weight: F,
    pub roughness: F,
    pub tint: Col,
}

impl CoatT {
    fn is_const(&self) -> bool {
        self.weight.is_const() && self.roughness.is_const() && self.ior.is_const() && self.tint.is_const()
    }
    fn at(&self, v: &dyn Fn(Reg) -> Vec3) -> Option<CoatDesc> {
        let weight = self.weight.at(v);
        let tint = self.tint.at(v);
        (weight > 0.0).then(|| CoatDesc {
            weight,
            roughness: self.roughness.at(v),
            ior: self.ior.at(v),
            tint: (!is_white(&tint)).then_some(tint),
        })
    }
}

/// The Principled BSDF's Subsurface parameters: the weight may vary per hit, the radius,
/// scale, IOR, anisotropy and method are constants (see [`SubsurfaceDesc`]).
#[derive(Clone, Debug)]
pub struct SubsurfaceT {
    pub weight: F,
    pub desc: SubsurfaceDesc,
}

impl SubsurfaceT {
    fn at(&self, v: &dyn Fn(Reg) -> Vec3) -> Option<SubsurfaceDesc> {
        let weight = self.weight.at(v);
        (weight > 0.0).then(|| SubsurfaceDesc { weight, ..self.desc.clone() })
    }
}

impl SheenT {
    fn is_const(&self) -> bool {
        self.weight.is_const() && self.roughness.is_const() && self.tint.is_const()
    }
    fn at(&self, v: &dyn Fn(Reg) -> Vec3) -> Option<SheenLayerDesc> {
        let weight = self.weight.at(v);
        let tint = self.tint.at(v);
        (weight > 0.0).then(|| SheenLayerDesc {
            weight,
            roughness: self.roughness.at(v),
            tint: (!is_white(&tint)).then_some(tint),
        })
    }
}

/// The probability that a path passes a material's top Transparent BSDF: a constant,
/// or a register of the program (clamped to `lo..hi`, `1 −` it when `invert`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PassProbability {
    Constant(f32),
    Register { reg: Reg, lo: f32, hi: f32, invert: bool },
}

impl PassProbability {
    /// The probability at register values `v`, in 0..1.
    pub fn at(&self, v: &dyn Fn(Reg) -> Vec3) -> f32 {
        let p = match *self {
            PassProbability::Constant(p) => p,
            PassProbability::Register { reg, lo, hi, invert } => {
                let x = v(reg).x.clamp(lo, hi);
                if invert {
                    1.0 - x
                } else {
                    x
                }
            }
        };
        if p.is_finite() {
            p.clamp(0.0, 1.0)
        } else {
            0.0
        }
    }
}

/// The surface's closures with their parameters: what a hit instantiates into a
/// fixed description once the program has run.
// One per material, built when its graph is compiled.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug)]
pub enum Template {
    Fixed(BsdfDesc),
    Principled {
        base_color: Col,
        metallic: F,
        roughness: F,
        ior: Ior,
        transmission: F,
        specular_tint: Col,
        thin_film_thickness: F,
        thin_film_ior: F,
        specular_ior_level: F,
        diffuse_roughness: F,
        /// Anisotropic (None when a constant 0: no tangent is read).
        anisotropy: Option<Box<AnisoT>>,
        coat: Option<CoatT>,
        sheen: Option<SheenT>,
        subsurface: Option<SubsurfaceT>,
        /// A linked Normal (None: the smooth normal).
        normal: Option<Reg>,
    },
    /// A closure about its own normal (every BSDF node but the Principled, which
    /// orients its layers itself).
    Oriented {
        normal: LobeNormal,
        t: Box<Template>,
    },
    Diffuse {
        color: Col,
        roughness: F,
    },
    /// The Glossy BSDF: `anisotropy` −1..1, `rotation` in turns, the Tangent's register
    /// (None when the lobe is isotropic).
    Glossy {
        color: Col,
        roughness: F,
        anisotropy: F,
        rotation: F,
        tangent: Option<Reg>,
    },
    /// White glass: the dielectric; tinted: a transmissive Principled.
    Glass {
        color: Col,
        roughness: F,
        ior: Ior,
    },
    /// Blender's Refraction BSDF: transmission only, tinted by its colour (the closure
    /// weight); `beckmann`: the node's Beckmann distribution (else GGX).
    Refraction {
        color: Col,
        roughness: F,
        ior: Ior,
        beckmann: bool,
    },
    /// Blender's Metallic BSDF in Physical Conductor mode: constant RGB IOR and
    /// Extinction (uplifted per wavelength at build).
    Metallic {
        eta: [f32; 3],
        k: [f32; 3],
        roughness: F,
        multiscatter: bool,
    },
    Translucent {
        color: Col,
    },
    Sheen {
        color: Col,
        roughness: F,
    },
    Mix {
        factor: F,
        factor_from: Option<MixFactorDesc>,
        a: Box<Template>,
        b: Box<Template>,
    },
    Add {
        a: Box<Template>,
        b: Box<Template>,
    },
    /// Blender's Holdout: reflects nothing; its weight makes the pixel transparent
    /// ([`Template::holdout_weight`], the scene's `Holdout`).
    Holdout,
}

impl F {
    fn at(&self, v: &dyn Fn(Reg) -> Vec3) -> f32 {
        match *self {
            F::C(x) => x,
            F::R(r, lo, hi) => v(r).x.clamp(lo, hi),
        }
    }
    /// `at`, with a non-finite value (a NaN from the graph) read as 0.
    fn finite_at(&self, v: &dyn Fn(Reg) -> Vec3) -> f32 {
        let x = self.at(v);
        if x.is_finite() {
            x
        } else {
            0.0
        }
    }
    fn is_const(&self) -> bool {
        matches!(self, F::C(_))
    }
}

impl Col {
    fn at(&self, v: &dyn Fn(Reg) -> Vec3) -> SpectrumDesc {
        match self {
            Col::C(d) => d.clone(),
            Col::R(r) => SpectrumDesc::new(SpectrumKind::Rgb { rgb: v(*r).clamp(Vec3::ZERO, Vec3::ONE).to_array() }),
        }
    }
    fn is_const(&self) -> bool {
        matches!(self, Col::C(_))
    }
}

impl Ior {
    fn at(&self, v: &dyn Fn(Reg) -> Vec3) -> IorDesc {
        match self {
            Ior::C(d) => d.clone(),
            Ior::R(r) => IorDesc::Constant { ior: f64::from(v(*r).x.max(1e-5)) },
        }
    }
}

fn is_white(d: &SpectrumDesc) -> bool {
    matches!(d.kind, SpectrumKind::Rgb { rgb } if rgb == [1.0; 3]) && d.scale == 1.0
        || matches!(d.kind, SpectrumKind::Constant { value } if value * d.scale == 1.0)
}

impl Template {
    /// Splits a top-level Transparent BSDF off (alone, or one side of a Mix whose factor
    /// is a constant or a register, e.g. a textured Principled Alpha): the probability a
    /// path passes, its tint, and the opaque rest (see `BsdfDesc::split_transparent`).
    pub fn split_transparent(&self) -> Option<(PassProbability, SpectrumDesc, Template)> {
        let color_of = |t: &Template| match t {
            Template::Fixed(BsdfDesc::Transparent { color }) => Some(color.clone()),
            _ => None,
        };
        if let Some(c) = color_of(self) {
            return Some((PassProbability::Constant(1.0), c, Template::Fixed(BsdfDesc::None)));
        }
        let Template::Mix { factor, factor_from: None, a, b } = self else { return None };
        let (color, rest, invert) = match (color_of(a), color_of(b)) {
            (Some(c), _) => (c, b, true),
            (None, Some(c)) => (c, a, false),
            _ => return None,
        };
        let p = match *factor {
            F::C(f) => PassProbability::Constant(if invert { 1.0 - f } else { f }),
            F::R(reg, lo, hi) => PassProbability::Register { reg, lo, hi, invert },
        };
        Some((p, color, (**rest).clone()))
    }

    /// Whether a Transparent BSDF is anywhere in the template.
    pub fn has_transparent(&self) -> bool {
        match self {
            Template::Fixed(d) => d.has_transparent(),
            Template::Mix { a, b, .. } | Template::Add { a, b } => a.has_transparent() || b.has_transparent(),
            Template::Oriented { t, .. } => t.has_transparent(),
            _ => false,
        }
    }

    /// Whether a lobe reads a tangent (an anisotropic Principled or Glossy): its hit's
    /// BSDF is then built in the vertex's frame (`Orient`), as for lobe normals.
    pub fn needs_tangent(&self) -> bool {
        match self {
            Template::Principled { anisotropy, .. } => anisotropy.is_some(),
            Template::Glossy { tangent, .. } => tangent.is_some(),
            Template::Mix { a, b, .. } | Template::Add { a, b } => a.needs_tangent() || b.needs_tangent(),
            Template::Oriented { t, .. } => t.needs_tangent(),
            _ => false,
        }
    }

    /// Whether every parameter is a constant.
    pub fn is_constant(&self) -> bool {
        match self {
            Template::Fixed(_) => true,
            Template::Principled {
                base_color,
                metallic,
                roughness,
                ior,
                transmission,
                specular_tint,
                thin_film_thickness,
                thin_film_ior,
                specular_ior_level,
                diffuse_roughness,
                anisotropy,
                coat,
                sheen,
                subsurface,
                normal,
            } => {
                normal.is_none()
                    && anisotropy.is_none()
                    && subsurface.as_ref().is_none_or(|s| s.weight.is_const())
                    && coat.as_ref().is_none_or(|c| c.is_const() && c.normal.is_none())
                    && sheen.as_ref().is_none_or(SheenT::is_const)
                    && base_color.is_const()
                    && specular_tint.is_const()
                    && matches!(ior, Ior::C(_))
                    && [
                        metallic,
                        roughness,
                        transmission,
                        thin_film_thickness,
                        thin_film_ior,
                        specular_ior_level,
                        diffuse_roughness,
                    ]
                    .iter()
                    .all(|f| f.is_const())
            }
            Template::Diffuse { color, roughness } => color.is_const() && roughness.is_const(),
            Template::Glossy { color, roughness, anisotropy, rotation, tangent } => {
                color.is_const()
                    && roughness.is_const()
                    && anisotropy.is_const()
                    && rotation.is_const()
                    && tangent.is_none()
            }
            Template::Sheen { color, roughness } => color.is_const() && roughness.is_const(),
            Template::Glass { color, roughness, ior } => {
                color.is_const() && roughness.is_const() && matches!(ior, Ior::C(_))
            }
            Template::Translucent { color } => color.is_const(),
            Template::Metallic { roughness, .. } => roughness.is_const(),
            Template::Refraction { color, roughness, ior, .. } => {
                color.is_const() && roughness.is_const() && matches!(ior, Ior::C(_))
            }
            Template::Oriented { normal, t } => normal.reg.is_none() && t.is_constant(),
            Template::Mix { factor, a, b, .. } => factor.is_const() && a.is_constant() && b.is_constant(),
            Template::Add { a, b } => a.is_constant() && b.is_constant(),
            Template::Holdout => true,
        }
    }

    /// Whether a Holdout is anywhere in the template.
    pub fn has_holdout(&self) -> bool {
        match self {
            Template::Holdout => true,
            Template::Mix { a, b, .. } | Template::Add { a, b } => a.has_holdout() || b.has_holdout(),
            Template::Oriented { t, .. } => t.has_holdout(),
            _ => false,
        }
    }

    /// Whether a Holdout lies under a Mix Shader whose Fac is a Fresnel or Layer Weight
    /// node (its holdout weight then uses the Mix's 0.5, not the view-dependent factor).
    pub fn holdout_under_view_factor(&self) -> bool {
        match self {
            Template::Mix { factor_from: Some(_), a, b, .. } => a.has_holdout() || b.has_holdout(),
            Template::Mix { a, b, .. } | Template::Add { a, b } => {
                a.holdout_under_view_factor() || b.holdout_under_view_factor()
            }
            Template::Oriented { t, .. } => t.holdout_under_view_factor(),
            _ => false,
        }
    }

    /// The summed weight of the Holdout closures at register values `v`, clamped to
    /// 0..1: Cycles' `surface_shader_apply_holdout` (kernel/integrator/surface_shader.h)
    /// adds up the holdout closures' weights, which Mix Shaders scaled by 1 − Fac and Fac.
    pub fn holdout_weight(&self, v: &dyn Fn(Reg) -> Vec3) -> f32 {
        fn w(t: &Template, v: &dyn Fn(Reg) -> Vec3) -> f32 {
            match t {
                Template::Holdout => 1.0,
                Template::Mix { factor, a, b, .. } => {
                    let f = factor.at(v).clamp(0.0, 1.0);
                    (1.0 - f) * w(a, v) + f * w(b, v)
                }
                Template::Add { a, b } => w(a, v) + w(b, v),
                Template::Oriented { t, .. } => w(t, v),
                _ => 0.0,
            }
        }
        let x = w(self, v);
        if x.is_finite() {
            x.clamp(0.0, 1.0)
        } else {
            0.0
        }
    }

    /// Whether some roughness may be zero at a hit (a delta lobe may appear).
    pub fn may_be_specular(&self) -> bool {
        match self {
            Template::Fixed(_) => false,
            Template::Principled { roughness, transmission, coat, .. } => {
                !roughness.is_const()
                    || !transmission.is_const()
                    || coat.as_ref().is_some_and(|c| !c.roughness.is_const() || !c.weight.is_const())
            }
            Template::Glossy { roughness, anisotropy, .. } => !roughness.is_const() || !anisotropy.is_const(),
            Template::Glass { roughness, .. }
            | Template::Refraction { roughness, .. }
            | Template::Metallic { roughness, .. } => !roughness.is_const(),
            Template::Mix { a, b, .. } | Template::Add { a, b } => a.may_be_specular() || b.may_be_specular(),
            Template::Oriented { t, .. } => t.may_be_specular(),
            _ => false,
        }
    }

    /// The fixed description at register values `v`, its lobes oriented about their own
    /// normals at a hit `o` (None: every lobe about the vertex's normal).
    pub fn instantiate(&self, v: &dyn Fn(Reg) -> Vec3, o: Option<&Orient>) -> BsdfDesc {
        match self {
            Template::Fixed(d) => d.clone(),
            Template::Principled {
                base_color,
                metallic,
                roughness,
                ior,
                transmission,
                specular_tint,
                thin_film_thickness,
                thin_film_ior,
                specular_ior_level,
                diffuse_roughness,
                anisotropy,
                coat,
                sheen,
                subsurface,
                normal,
            } => {
                let tint = specular_tint.at(v);
                let coat_desc = coat.as_ref().and_then(|c| c.at(v));
                let sheen_desc = sheen.as_ref().and_then(|c| c.at(v));
                let normals = o.map(|o| {
                    // Cycles: the specular, metal, glass and subsurface lobes about the
                    // valid Normal, the diffuse about the Normal as given (with the bump
                    // shadowing term when it is not sd->N), the coat about its valid Coat
                    // Normal (sd->N when unlinked), the sheen about
                    // normalize(mix(N, Coat Normal, Coat Weight)) as given.
                    let n = o.raw(v, *normal);
                    let c = o.raw(v, coat.as_ref().and_then(|c| c.normal));
                    let w = coat_desc.as_ref().map_or(0.0, |c| c.weight.clamp(0.0, 1.0));
                    Box::new(crate::scene::PrincipledNormals {
                        base: o.local(o.valid(n)),
                        diffuse: o.local(n),
                        smooth: (n != o.smooth).then(|| o.frame.to_local(o.smooth.into()).to_array()),
                        coat: coat_desc.as_ref().and_then(|_| o.local(o.valid(c))),
                        sheen: sheen_desc
                            .as_ref()
                            .and_then(|_| o.local((n + (c - n) * w).try_normalize().unwrap_or(n))),
                        tangent: o.tangent(v, anisotropy.as_ref().map(|a| a.tangent)),
                    })
                });
                BsdfDesc::Principled {
                    base_color: base_color.at(v),
                    metallic: metallic.at(v),
                    roughness: roughness.at(v),
                    ior: ior.at(v),
                    transmission: transmission.at(v),
                    specular_tint: (!is_white(&tint)).then_some(tint),
                    thin_film_thickness: thin_film_thickness.at(v),
                    thin_film_ior: thin_film_ior.at(v),
                    specular_ior_level: specular_ior_level.at(v),
                    diffuse_roughness: diffuse_roughness.at(v),
                    anisotropic: anisotropy.as_ref().map_or(0.0, |a| a.anisotropic.finite_at(v)),
                    anisotropic_rotation: anisotropy.as_ref().map_or(0.0, |a| a.rotation.finite_at(v)),
                    coat: coat_desc,
                    sheen: sheen_desc,
                    subsurface: subsurface.as_ref().and_then(|s| s.at(v)).map(Box::new),
                    normals,
                }
            }
            Template::Oriented { normal, t } => {
                let mut inner = t.instantiate(v, o);
                let Some(o) = o else { return inner };
                let n = o.normal(v, *normal);
                if let (BsdfDesc::Glossy { tangent: Some(t), .. }, Some(nl)) = (&mut inner, o.local(n)) {
                    // The Glossy's tangent in its own lobe's frame (Cycles builds the
                    // anisotropic frame about the closure's N: make_orthonormals_tangent).
                    let l = crate::material::oriented::LobeFrame::new(glam::Vec3A::from(nl));
                    *t = l.to_lobe(glam::Vec3A::from(*t)).to_array();
                }
                // Cycles dims a diffuse closure bent off the smooth normal towards the
                // smooth surface's horizon (bump_shadowing_term, kernel/closure/bsdf.h).
                let smooth =
                    (!normal.valid_reflection && n != o.smooth).then(|| o.frame.to_local(o.smooth.into()).to_array());
                match o.local(n) {
                    Some(normal) => BsdfDesc::Oriented { normal, bsdf: Box::new(inner), smooth },
                    None => inner,
                }
            }
            Template::Diffuse { color, roughness } => {
                let r = roughness.at(v);
                if r > 0.0 {
                    BsdfDesc::RoughDiffuse { reflectance: color.at(v), roughness: r }
                } else {
                    BsdfDesc::Diffuse { reflectance: color.at(v) }
                }
            }
            Template::Glossy { color, roughness, anisotropy, rotation, tangent } => BsdfDesc::Glossy {
                reflectance: color.at(v),
                roughness: roughness.at(v),
                anisotropy: anisotropy.finite_at(v),
                rotation: rotation.finite_at(v),
                tangent: o.and_then(|o| o.tangent(v, *tangent)),
            },
            Template::Glass { color, roughness, ior } => {
                let c = color.at(v);
                let glass = BsdfDesc::Dielectric { ior: ior.at(v), roughness: roughness.at(v) };
                if is_white(&c) {
                    glass
                } else {
                    // Cycles: the Glass colour is the closure weight (reflection and
                    // transmission alike).
                    BsdfDesc::Tint { color: c, bsdf: Box::new(glass) }
                }
            }
            Template::Refraction { color, roughness, ior, beckmann } => {
                let c = color.at(v);
                let r = BsdfDesc::Refraction { ior: ior.at(v), roughness: roughness.at(v), beckmann: *beckmann };
                if is_white(&c) {
                    r
                } else {
                    BsdfDesc::Tint { color: c, bsdf: Box::new(r) }
                }
            }
            Template::Metallic { eta, k, roughness, multiscatter } => {
                let rgb = |c: &[f32; 3]| SpectrumDesc::new(SpectrumKind::Rgb { rgb: *c });
                BsdfDesc::Metallic { eta: rgb(eta), k: rgb(k), roughness: roughness.at(v), multiscatter: *multiscatter }
            }
            Template::Translucent { color } => BsdfDesc::Translucent { color: color.at(v) },
            Template::Sheen { color, roughness } => BsdfDesc::Sheen { color: color.at(v), roughness: roughness.at(v) },
            Template::Mix { factor, factor_from, a, b } => BsdfDesc::Mix {
                a: Box::new(a.instantiate(v, o)),
                b: Box::new(b.instantiate(v, o)),
                factor: factor.at(v),
                factor_from: factor_from.clone(),
            },
            Template::Add { a, b } => {
                BsdfDesc::Add { a: Box::new(a.instantiate(v, o)), b: Box::new(b.instantiate(v, o)) }
            }
            // What a holdout leaves of the surface: nothing (the scene's Holdout makes
            // the film transparent there when it is).
            Template::Holdout => BsdfDesc::None,
        }
    }
}

pub struct Lowering<'c, 'a> {
    pub c: &'c mut Compiler<'a>,
    /// Closure nodes on the current path, for cycles through shader links.
    path: Vec<usize>,
    /// The linked Normal (and Coat Normal) inputs' registers, in lowering order.
    normals: Vec<Reg>,
}

/// `t` about its own normal `reg` (see [`LobeNormal`]).
fn oriented(t: Template, reg: Option<Reg>, valid_reflection: bool) -> Template {
    Template::Oriented { normal: LobeNormal { reg, valid_reflection }, t: Box::new(t) }
}

fn add_emission(material: &str, a: Option<Emission>, b: Option<Emission>) -> Result<Option<Emission>> {
    Ok(match (a, b) {
        (None, x) | (x, None) => x,
        (Some(Emission::Rgb(x)), Some(Emission::Rgb(y))) => Some(Emission::Rgb(x + y)),
        (Some(Emission::Spectrum(x)), Some(Emission::Spectrum(y))) if x.kind == y.kind => {
            Some(Emission::Spectrum(SpectrumDesc { kind: x.kind, scale: x.scale + y.scale }))
        }
        (Some(Emission::Varying(mut x)), Some(Emission::Varying(y))) => {
            x.extend(y);
            Some(Emission::Varying(x))
        }
        (Some(Emission::Varying(mut x)), Some(Emission::Rgb(c)))
        | (Some(Emission::Rgb(c)), Some(Emission::Varying(mut x))) => {
            x.push(EmissionTerm { color: None, strength: None, rgb: c, weights: Vec::new() });
            Some(Emission::Varying(x))
        }
        _ => {
            return Err(Error::object(
                "material",
                material,
                "cannot add emissions of different kinds (an RGB colour and a spectrum, or two spectra)",
            ))
        }
    })
}

/// `e` weighted by a per-hit Mix Shader factor (None: a spectral emission, which
/// cannot be).
fn weighted(e: Emission, r: Reg, first: bool) -> Option<Emission> {
    let mut terms = match e {
        Emission::Rgb(c) => vec![EmissionTerm { color: None, strength: None, rgb: c, weights: Vec::new() }],
        Emission::Varying(t) => t,
        Emission::Spectrum(_) => return None,
    };
    for t in &mut terms {
        t.weights.push((r, first));
    }
    Some(Emission::Varying(terms))
}

impl<'c, 'a> Lowering<'c, 'a> {
    pub fn new(c: &'c mut Compiler<'a>) -> Self {
        Self { c, path: Vec::new(), normals: Vec::new() }
    }

    fn per_hit_unsupported(&self, node: usize, id: &str, what: &str) -> Error {
        self.c.error(node, format!("input '{id}' varies over the surface, and per-hit {what} is not supported yet"))
    }

    /// A float input clamped to lo..hi (Cycles saturates closure weights the same way).
    fn float(&mut self, node: usize, id: &str, lo: f32, hi: f32) -> Result<F> {
        let r = self.c.input_reg(node, id)?;
        Ok(match self.c.const_of(r) {
            Some(v) => F::C(v.x.clamp(lo, hi)),
            None => F::R(r, lo, hi),
        })
    }

    /// A colour input: constants become spectrum descriptions (reflectances clamped to 0..1).
    fn color(&mut self, node: usize, id: &str) -> Result<Col> {
        match self.c.input(node, id)? {
            Value::Spectrum(s) => Ok(Col::C(s)),
            Value::Ior(_) => Err(self.c.error(node, format!("input '{id}': an IOR model on a colour"))),
            Value::Reg(r) => Ok(match self.c.const_of(r) {
                Some(v) => {
                    Col::C(SpectrumDesc::new(SpectrumKind::Rgb { rgb: v.clamp(Vec3::ZERO, Vec3::ONE).to_array() }))
                }
                None => Col::R(r),
            }),
        }
    }

    fn ior(&mut self, node: usize, id: &str) -> Result<Ior> {
        match self.c.input(node, id)? {
            Value::Ior(d) => Ok(Ior::C(d)),
            Value::Spectrum(_) => Err(self.c.error(node, format!("input '{id}': a spectrum on an IOR"))),
            Value::Reg(r) => Ok(match self.c.const_of(r) {
                Some(v) => Ior::C(IorDesc::Constant { ior: f64::from(v.x.max(1e-5)) }),
                None => Ior::R(r),
            }),
        }
    }

    /// A BSDF's Normal input (`id`): its register when linked, None when the closure
    /// keeps the smooth normal. Each closure is shaded about its own (`Orient`).
    fn normal(&mut self, node: usize, id: &str) -> Result<Option<Reg>> {
        let r = match self.c.linked(node, id) {
            Some(_) => Some(self.c.input_reg(node, id)?),
            None => None,
        };
        self.normals.extend(r);
        Ok(r)
    }

    /// The material's normal for the Normal pass: the first linked one (made valid at
    /// the hit), None when no closure links a normal, and then nothing is oriented.
    fn shading_normal(&mut self) -> Option<Reg> {
        self.normals.first().copied()
    }

    /// A node's enum property `key` through `table` (Blender's spellings); `default`
    /// when absent.
    fn prop<T: Copy>(&self, node: usize, key: &str, table: &[(&str, T)], default: T) -> Result<T> {
        let n = &self.c.nodes[node];
        super::props::Props { map: &n.props, material: self.c.material, node: &n.name }.enumeration(key, table, default)
    }

    /// A vector input's constant value clamped below at 0; a varying one warns and
    /// reads `default` (Blender's).
    fn const_vector(&mut self, node: usize, id: &str, default: [f32; 3]) -> Result<[f32; 3]> {
        let r = self.c.input_reg(node, id)?;
        match self.c.const_of(r) {
            Some(v) if v.is_finite() => Ok(v.max(Vec3::ZERO).to_array()),
            _ => {
                self.c.warn(node, format!("a varying or non-finite {id} is not supported yet; using {default:?}"));
                Ok(default)
            }
        }
    }

    /// Warns when an input this build ignores differs from Blender's default.
    #[allow(dead_code)] // every Principled input is read now; kept for the next unsupported one
    fn ignored(&mut self, node: usize, id: &str, default: f32, what: &str) -> Result<()> {
        if self.c.linked(node, id).is_some() {
            self.c.warn(node, format!("{id} is not supported ({what}); its link is ignored"));
            return Ok(());
        }
        if let Some(InputDesc::Number(x)) = self.c.nodes[node].inputs.get(id) {
            if *x != default {
                self.c.warn(node, format!("{id} {x} is not supported ({what}); using {default}"));
            }
        }
        Ok(())
    }

    /// The closure linked into input `id` of `node` (None: unlinked, nothing).
    fn shader_input(&mut self, node: usize, id: &str, depth: usize) -> Result<(Template, Option<Emission>)> {
        match self.c.linked(node, id) {
            None => Ok((Template::Fixed(BsdfDesc::None), None)),
            Some((from, out)) => self.closure(from, out, depth + 1),
        }
    }

    /// An anisotropic closure's rotation (turns) and Tangent register; nothing is read
    /// for an isotropic one. An unlinked Tangent is Cycles' default (sockets.rs
    /// `Implicit::Tangent`: the radial tangent of Generated coordinates about Z).
    fn tangent_frame(&mut self, node: usize, isotropic: bool, rotation: &str) -> Result<(F, Option<Reg>)> {
        if isotropic {
            return Ok((F::C(0.0), None));
        }
        let r = self.float(node, rotation, f32::NEG_INFINITY, f32::INFINITY)?;
        Ok((r, Some(self.c.input_reg(node, "Tangent")?)))
    }

    /// Lowers the closure at output `out` of node `node`.
    pub fn closure(&mut self, node: usize, out: &str, depth: usize) -> Result<(Template, Option<Emission>)> {
        let nodes = self.c.nodes;
        if node >= nodes.len() {
            return Err(Error::object(
                "material",
                self.c.material,
                format!("output links to node {node}, but the material has {} nodes", nodes.len()),
            ));
        }
        if depth > MAX_DEPTH {
            return Err(self.c.error(node, format!("shaders nested deeper than {MAX_DEPTH}")));
        }
        if self.path.contains(&node) {
            let names: Vec<String> = self.path.iter().map(|&n| format!("'{}'", nodes[n].name)).collect();
            return Err(Error::object(
                "material",
                self.c.material,
                format!("node cycle: {} → '{}'", names.join(" → "), nodes[node].name),
            ));
        }
        let kind = nodes[node].kind.as_str();
        match super::sockets::spec(kind) {
            Some(spec) => {
                let ok = spec.output(out).is_some_and(|o| o.1 == super::sockets::SocketType::Shader);
                if !ok {
                    return Err(self.c.error(node, format!("has no shader output '{out}'")));
                }
            }
            None => {
                self.c.warn(node, "is not a supported shader; it renders as a grey diffuse");
                return Ok((Template::Fixed(BsdfDesc::default()), None));
            }
        }
        self.c.check_inputs(node)?;
        self.path.push(node);
        let r = self.closure_node(node, kind, depth);
        self.path.pop();
        r
    }

    fn closure_node(&mut self, node: usize, kind: &str, depth: usize) -> Result<(Template, Option<Emission>)> {
        let material = self.c.material;
        Ok(match kind {
            "ShaderNodeBsdfPrincipled" => {
                let normal = self.normal(node, "Normal")?;
                let alpha = self.float(node, "Alpha", 0.0, 1.0)?;
                let anisotropic = self.float(node, "Anisotropic", 0.0, 1.0)?;
                let isotropic = matches!(anisotropic, F::C(a) if a <= 0.0);
                let (rotation, tangent) = self.tangent_frame(node, isotropic, "Anisotropic Rotation")?;
                let anisotropy = tangent.map(|tangent| Box::new(AnisoT { anisotropic, rotation, tangent }));
                let emission = self.emission(node, "Emission Color", "Emission Strength")?;
                if let Some(InputDesc::Number(x)) = self.c.nodes[node].inputs.get("Specular IOR Level") {
                    if *x > 1.0 {
                        self.c.warn(node, format!("Specular IOR Level {x} is clamped to 1"));
                    }
                }
                let t = Template::Principled {
                    base_color: self.color(node, "Base Color")?,
                    metallic: self.float(node, "Metallic", 0.0, 1.0)?,
                    roughness: self.float(node, "Roughness", 0.0, 1.0)?,
                    ior: self.ior(node, "IOR")?,
                    transmission: self.float(node, "Transmission Weight", 0.0, 1.0)?,
                    specular_tint: self.color(node, "Specular Tint")?,
                    thin_film_thickness: self.float(node, "Thin Film Thickness", 0.0, 100_000.0)?,
                    thin_film_ior: self.float(node, "Thin Film IOR", 1.0, 10.0)?,
                    specular_ior_level: self.float(node, "Specular IOR Level", 0.0, 1.0)?,
                    diffuse_roughness: self.float(node, "Diffuse Roughness", 0.0, 1.0)?,
                    anisotropy,
                    coat: self.coat(node)?,
                    sheen: self.sheen(node)?,
                    subsurface: self.subsurface(node)?,
                    normal,
                };
                // Alpha: a transparent closure of weight 1 − alpha mixed in (Cycles'
                // svm_node_closure_bsdf, CLOSURE_BSDF_PRINCIPLED_ID: bsdf_transparent_setup
                // with weight·(1 − alpha), the other closures × alpha). A varying alpha
                // (an alpha texture) is a Mix of that register, evaluated per hit.
                let t = if !matches!(alpha, F::C(a) if a >= 1.0) {
                    let white = SpectrumDesc::new(SpectrumKind::Rgb { rgb: [1.0; 3] });
                    Template::Mix {
                        factor: alpha,
                        factor_from: None,
                        a: Box::new(Template::Fixed(BsdfDesc::Transparent { color: white })),
                        b: Box::new(t),
                    }
                } else {
                    t
                };
                (t, emission)
            }
            "ShaderNodeBsdfDiffuse" => {
                let n = self.normal(node, "Normal")?;
                let color = self.color(node, "Color")?;
                let t = Template::Diffuse { color, roughness: self.float(node, "Roughness", 0.0, 1.0)? };
                (oriented(t, n, false), None)
            }
            "ShaderNodeBsdfAnisotropic" | "ShaderNodeBsdfGlossy" => {
                let n = self.normal(node, "Normal")?;
                let color = self.color(node, "Color")?;
                let roughness = self.float(node, "Roughness", 0.0, 1.0)?;
                // Cycles clamps the Glossy's Anisotropy to ±0.99 and keeps the lobe
                // isotropic at |anisotropy| ≤ 1e-4 (svm_node_closure_bsdf).
                let anisotropy = self.float(node, "Anisotropy", -0.99, 0.99)?;
                let isotropic = matches!(anisotropy, F::C(a) if a.abs() <= 1e-4);
                let (rotation, tangent) = self.tangent_frame(node, isotropic, "Rotation")?;
                let t = Template::Glossy { color, roughness, anisotropy, rotation, tangent };
                (oriented(t, n, true), None)
            }
            "ShaderNodeBsdfRefraction" => {
                let n = self.normal(node, "Normal")?;
                let beckmann = self.prop(node, "distribution", &[("BECKMANN", true), ("GGX", false)], true)?;
                let color = self.color(node, "Color")?;
                let roughness = self.float(node, "Roughness", 0.0, 1.0)?;
                let ior = self.ior(node, "IOR")?;
                (oriented(Template::Refraction { color, roughness, ior, beckmann }, n, true), None)
            }
            "ShaderNodeBsdfGlass" => {
                let n = self.normal(node, "Normal")?;
                let color = self.color(node, "Color")?;
                let roughness = self.float(node, "Roughness", 0.0, 1.0)?;
                (oriented(Template::Glass { color, roughness, ior: self.ior(node, "IOR")? }, n, true), None)
            }
            "ShaderNodeSubsurfaceScattering" => {
                // Cycles' CLOSURE_BSSRDF node (svm_node_closure_bsdf): albedo and weight the
                // Color, entry through GGX of alpha = Roughness at the node's IOR, no
                // specular reflection; here a Principled whose base all walks, with no
                // specular layer (Specular IOR Level 0) and roughness √Roughness.
                let normal = self.normal(node, "Normal")?;
                let base_color = self.color(node, "Color")?;
                let r = self.c.input_reg(node, "Roughness")?;
                let rough = match self.c.const_of(r) {
                    Some(v) if v.x.is_finite() => v.x.clamp(0.0, 1.0),
                    _ => {
                        self.c.warn(node, "a varying Roughness is not supported yet; 1 is used");
                        1.0
                    }
                };
                let desc = self.subsurface_inputs(node, "", "falloff")?;
                let white = SpectrumDesc::new(SpectrumKind::Rgb { rgb: [1.0; 3] });
                let t = Template::Principled {
                    base_color,
                    metallic: F::C(0.0),
                    roughness: F::C(rough.sqrt()),
                    ior: Ior::C(IorDesc::Constant { ior: f64::from(desc.ior.max(1.0)) }),
                    transmission: F::C(0.0),
                    specular_tint: Col::C(white),
                    thin_film_thickness: F::C(0.0),
                    thin_film_ior: F::C(1.33),
                    specular_ior_level: F::C(0.0),
                    diffuse_roughness: F::C(0.0),
                    anisotropy: None,
                    coat: None,
                    sheen: None,
                    subsurface: Some(SubsurfaceT { weight: F::C(1.0), desc }),
                    normal,
                };
                (t, None)
            }
            "ShaderNodeBsdfMetallic" => {
                let n = self.normal(node, "Normal")?;
                let roughness = self.float(node, "Roughness", 0.0, 1.0)?;
                self.ignored(node, "Anisotropy", 0.0, "no anisotropy on the Metallic BSDF yet")?;
                let distribution = self.prop(
                    node,
                    "distribution",
                    &[("MULTI_GGX", "MULTI_GGX"), ("GGX", "GGX"), ("BECKMANN", "BECKMANN")],
                    "MULTI_GGX",
                )?;
                let physical =
                    self.prop(node, "fresnel_type", &[("F82", false), ("PHYSICAL_CONDUCTOR", true)], false)?;
                if distribution == "BECKMANN" || (distribution == "GGX" && !physical) {
                    self.c.warn(
                        node,
                        format!("distribution {distribution} is not supported here; it renders as Multiscatter GGX"),
                    );
                }
                if physical {
                    // Cycles clamps the RGB IOR and Extinction below at 0.
                    let eta = self.const_vector(node, "IOR", [2.757, 2.513, 2.231])?;
                    let k = self.const_vector(node, "Extinction", [3.867, 3.404, 3.009])?;
                    let t = Template::Metallic { eta, k, roughness, multiscatter: distribution != "GGX" };
                    (oriented(t, n, true), None)
                } else {
                    // F82 Tint: the Principled's metal lobe (Cycles' svm_node_closure_bsdf,
                    // CLOSURE_BSDF_F82_CONDUCTOR: f0 = saturate(Base Color), f82 =
                    // saturate(Edge Tint), bsdf_microfacet_setup_fresnel_f82_tint).
                    let t = Template::Principled {
                        base_color: self.color(node, "Base Color")?,
                        metallic: F::C(1.0),
                        roughness,
                        ior: Ior::C(IorDesc::Constant { ior: 1.5 }),
                        transmission: F::C(0.0),
                        specular_tint: self.color(node, "Edge Tint")?,
                        thin_film_thickness: F::C(0.0),
                        thin_film_ior: F::C(1.33),
                        specular_ior_level: F::C(0.5),
                        diffuse_roughness: F::C(0.0),
                        anisotropy: None,
                        coat: None,
                        sheen: None,
                        subsurface: None,
                        // The Principled orients its metal lobe about the valid Normal.
                        normal: n,
                    };
                    (t, None)
                }
            }
            "ShaderNodeBsdfTranslucent" => {
                let n = self.normal(node, "Normal")?;
                (oriented(Template::Translucent { color: self.color(node, "Color")? }, n, true), None)
            }
            "ShaderNodeBsdfSheen" => {
                let n = self.normal(node, "Normal")?;
                let color = self.color(node, "Color")?;
                let t = Template::Sheen { color, roughness: self.float(node, "Roughness", 0.0, 1.0)? };
                (oriented(t, n, false), None)
            }
            "ShaderNodeEmission" => (Template::Fixed(BsdfDesc::None), self.emission(node, "Color", "Strength")?),
            "ShaderNodeBsdfTransparent" => {
                let color = match self.color(node, "Color")? {
                    Col::C(d) => d,
                    Col::R(_) => {
                        self.c.warn(node, "a varying Color is not supported yet; the Transparent BSDF is white");
                        SpectrumDesc::new(SpectrumKind::Rgb { rgb: [1.0; 3] })
                    }
                };
                (Template::Fixed(BsdfDesc::Transparent { color }), None)
            }
            "ShaderNodeHoldout" => (Template::Holdout, None),
            "ShaderNodeAddShader" => {
                let (a, ea) = self.shader_input(node, "Shader", depth)?;
                let (b, eb) = self.shader_input(node, "Shader_001", depth)?;
                (Template::Add { a: Box::new(a), b: Box::new(b) }, add_emission(material, ea, eb)?)
            }
            "ShaderNodeMixShader" => {
                let (factor, factor_from) = self.mix_factor(node)?;
                let (a, ea) = self.shader_input(node, "Shader", depth)?;
                let (b, eb) = self.shader_input(node, "Shader_001", depth)?;
                let emission = match (&factor, &factor_from) {
                    (_, _) if ea.is_none() && eb.is_none() => None,
                    (F::C(f), None) => add_emission(material, ea.map(|e| e.scaled(1.0 - f)), eb.map(|e| e.scaled(*f)))?,
                    (F::R(r, _, _), None) => {
                        let (wa, wb) = match (ea.map(|e| weighted(e, *r, true)), eb.map(|e| weighted(e, *r, false))) {
                            (Some(None), _) | (_, Some(None)) => {
                                return Err(self.per_hit_unsupported(node, "Fac", "mixing of a spectral emission"))
                            }
                            (a, b) => (a.flatten(), b.flatten()),
                        };
                        add_emission(material, wa, wb)?
                    }
                    _ => return Err(self.per_hit_unsupported(node, "Fac", "emission")),
                };
                (Template::Mix { a: Box::new(a), b: Box::new(b), factor, factor_from }, emission)
            }
            _ => {
                self.c.warn(node, "is not a supported shader; it renders as a grey diffuse");
                (Template::Fixed(BsdfDesc::default()), None)
            }
        })
    }

    /// The Principled Coat (None when its weight is a constant 0). Cycles clamps the
    /// weight below at 0, the roughness to 0..1 and the IOR below at 1.
    fn coat(&mut self, node: usize) -> Result<Option<CoatT>> {
        let weight = self.float(node, "Coat Weight", 0.0, 1.0)?;
        if matches!(weight, F::C(w) if w <= 0.0) {
            return Ok(None);
        }
        let normal = self.normal(node, "Coat Normal")?;
        Ok(Some(CoatT {
            normal,
            weight,
            roughness: self.float(node, "Coat Roughness", 0.0, 1.0)?,
            ior: self.float(node, "Coat IOR", 1.0, 10.0)?,
            tint: self.color(node, "Coat Tint")?,
        }))
    }

    /// The Principled Subsurface (None when its weight is a constant 0), as Cycles'
    /// `svm_node_closure_bsdf`: radius × scale clamped below at 0, the method from the
    /// node's `subsurface_method` (Christensen–Burley is walked as Random Walk, warned).
    /// Radius, Scale, IOR and Anisotropy are constants here: a link is warned about and
    /// the input's value used.
    fn subsurface(&mut self, node: usize) -> Result<Option<SubsurfaceT>> {
        let weight = self.float(node, "Subsurface Weight", 0.0, 1.0)?;
        if matches!(weight, F::C(w) if !(w > 0.0)) {
            return Ok(None);
        }
        let desc = self.subsurface_inputs(node, "Subsurface ", "subsurface_method")?;
        Ok(Some(SubsurfaceT { weight, desc }))
    }

    /// Radius, Scale, IOR and Anisotropy (input names after `prefix`) and the method
    /// (node property `method`) of a Principled's Subsurface or a Subsurface Scattering
    /// node.
    fn subsurface_inputs(&mut self, node: usize, prefix: &str, method: &str) -> Result<SubsurfaceDesc> {
        let mut desc = SubsurfaceDesc::default();
        let constant = |s: &mut Self, id: &str| -> Result<Option<Vec3>> {
            let r = s.c.input_reg(node, id)?;
            let v = s.c.const_of(r);
            if v.is_none() {
                s.c.warn(node, format!("a varying {id} is not supported yet; its default is used"));
            }
            Ok(v)
        };
        if let Some(r) = constant(self, &format!("{prefix}Radius"))? {
            let raw = r.to_array();
            if raw.iter().any(|x| !(x.is_finite() && *x >= 0.0)) {
                self.c.warn(node, format!("Subsurface Radius {raw:?} is clamped to finite values ≥ 0"));
            }
            desc.radius = raw.map(|x| if x.is_finite() { x.max(0.0) } else { 0.0 });
        }
        if let Some(v) = constant(self, &format!("{prefix}Scale"))? {
            if !(v.x.is_finite() && v.x >= 0.0) {
                self.c.warn(node, format!("Subsurface Scale {} is clamped to 0", v.x));
            }
            desc.scale = if v.x.is_finite() { v.x.max(0.0) } else { 0.0 };
        }
        if let Some(v) = constant(self, &format!("{prefix}IOR"))? {
            desc.ior = if v.x.is_finite() { v.x } else { desc.ior };
        }
        if let Some(v) = constant(self, &format!("{prefix}Anisotropy"))? {
            desc.anisotropy = if v.x.is_finite() { v.x } else { 0.0 };
        }
        let method = self.c.nodes[node].props.get(method).and_then(|m| m.as_str()).unwrap_or("RANDOM_WALK");
        desc.method = match method {
            "RANDOM_WALK_SKIN" => "random_walk_skin".into(),
            "RANDOM_WALK" => "random_walk".into(),
            other => {
                self.c.warn(node, format!("Subsurface Method {other} is rendered as Random Walk"));
                "random_walk".into()
            }
        };
        Ok(desc)
    }

    /// The Principled Sheen (None when its weight is a constant 0).
    fn sheen(&mut self, node: usize) -> Result<Option<SheenT>> {
        let weight = self.float(node, "Sheen Weight", 0.0, 1.0)?;
        if matches!(weight, F::C(w) if w <= 0.0) {
            return Ok(None);
        }
        Ok(Some(SheenT {
            weight,
            roughness: self.float(node, "Sheen Roughness", 0.0, 1.0)?,
            tint: self.color(node, "Sheen Tint")?,
        }))
    }

    fn emission(&mut self, node: usize, color: &str, strength: &str) -> Result<Option<Emission>> {
        let sr = self.c.input_reg(node, strength)?;
        let s = self.c.const_of(sr).map(|v| v.x);
        if s.is_some_and(|s| s <= 0.0) {
            return Ok(None);
        }
        let e = match self.c.input(node, color)? {
            Value::Spectrum(d) => match s {
                Some(_) => Emission::Spectrum(d),
                None => return Err(self.per_hit_unsupported(node, strength, "spectral emission")),
            },
            Value::Ior(_) => return Err(self.c.error(node, format!("input '{color}': an IOR model on a colour"))),
            Value::Reg(r) => match (self.c.const_of(r), s) {
                (Some(v), Some(_)) => Emission::Rgb(v.max(Vec3::ZERO)),
                (Some(v), None) if v.max_element() <= 0.0 => return Ok(None),
                (v, _) => Emission::Varying(vec![EmissionTerm {
                    color: v.is_none().then_some(r),
                    strength: s.is_none().then_some(sr),
                    rgb: v.map_or(Vec3::ONE, |v| v.max(Vec3::ZERO)),
                    weights: Vec::new(),
                }]),
            },
        };
        let e = match s {
            Some(s) => e.scaled(s),
            None => e,
        };
        Ok(Some(e).filter(|e| !matches!(e, Emission::Rgb(c) if *c == Vec3::ZERO)))
    }

    /// A Mix Shader's Fac: a constant or register, or a Fresnel / Layer Weight node the
    /// fixed material already evaluates per hit (`MixFactor`).
    fn mix_factor(&mut self, node: usize) -> Result<(F, Option<MixFactorDesc>)> {
        if let Some((from, out)) = self.c.linked(node, "Fac") {
            let kind = self.c.nodes.get(from).map(|n| n.kind.as_str());
            let view = match (kind, out) {
                (Some("ShaderNodeFresnel"), "Fac") => Some("IOR"),
                (Some("ShaderNodeLayerWeight"), "Fresnel" | "Facing") => Some("Blend"),
                _ => None,
            };
            if let Some(param) = view {
                if self.c.linked(from, "Normal").is_none() {
                    self.c.check_inputs(from)?;
                    let r = self.c.input_reg(from, param)?;
                    if let Some(v) = self.c.const_of(r) {
                        let d = match out {
                            "Fac" => MixFactorDesc::Fresnel { ior: v.x.max(1e-5) },
                            "Fresnel" => MixFactorDesc::LayerWeightFresnel { blend: v.x.clamp(0.0, 1.0) },
                            _ => MixFactorDesc::LayerWeightFacing { blend: v.x.clamp(0.0, 1.0) },
                        };
                        return Ok((F::C(0.5), Some(d)));
                    }
                }
            }
        }
        Ok((self.float(node, "Fac", 0.0, 1.0)?, None))
    }
}

/// The surface of a graph: its closures' template, its constant emission, or the terms
/// of an emission that varies per hit.
pub fn lower_surface(
    c: &mut Compiler,
    surface: Option<&(usize, String)>,
) -> Result<(Template, Option<SpectrumDesc>, Option<Vec<EmissionTerm>>, Option<Reg>)> {
    let Some((node, out)) = surface else { return Ok((Template::Fixed(BsdfDesc::None), None, None, None)) };
    let mut l = Lowering::new(c);
    let (t, emission) = l.closure(*node, out, 0)?;
    let normal = l.shading_normal();
    let (t, e, v) = match emission {
        None => (t, None, None),
        Some(Emission::Rgb(c)) => (t, Some(SpectrumDesc::new(SpectrumKind::Rgb { rgb: c.to_array() })), None),
        Some(Emission::Spectrum(d)) => (t, Some(d), None),
        Some(Emission::Varying(terms)) => (t, None, Some(terms)),
    };
    Ok((t, e, v, normal))
}
