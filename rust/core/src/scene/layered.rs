//! The one BSDF builder: every material's BSDF is built here from its description —
//! a fixed description from the scene, a node graph folded to constants at load
//! (`CompiledMaterial::constant_surface`), and the description a varying graph
//! instantiates at each hit (`shading::bsdf::GraphBsdf`) — recursively: a Mix or Add
//! may hold any BSDF description, including another Mix or a Principled
//! (docs/shading.md, "One builder").

use super::{BsdfDesc, BuildUplift, MixFactorDesc};
use crate::color::uplift::Uplift;
use crate::material::microfacet::TangentRotation;
use crate::material::mix::MixFactor;
use crate::material::oriented::LobeFrame;
use crate::material::principled::{Principled, PrincipledFrames, PrincipledParams};
use crate::material::{
    Black, Bsdf, Diffuse, IndexOfRefraction, Layered, MixBsdf, OrenNayar, Oriented, Sheen, SpectralParam, Texture,
    ThinFilm, Tinted, TopLobe, Translucent,
};
use crate::spectrum::named::{SpectrumKind, SpectrumRole};
use crate::spectrum::{SampledSpectrum, SpectrumDesc, WavelengthGrid};
use crate::{Error, Result};
use glam::Vec3A;
use std::sync::Arc;

/// Deepest nesting of Mix/Add accepted (guards against runaway descriptions).
const MAX_DEPTH: usize = 32;

/// What building a BSDF needs from the scene being built.
pub(super) struct BsdfBuild<'a> {
    pub grid: &'a WavelengthGrid,
    pub rgb: &'a BuildUplift<'a>,
    pub textures: &'a [Arc<Texture>],
    pub uplift: Option<&'a Arc<Uplift>>,
}

impl BsdfBuild<'_> {
    fn spectrum(&self, d: &SpectrumDesc, role: SpectrumRole, material: &str, what: &str) -> Result<SampledSpectrum> {
        Ok(SampledSpectrum::from_slice(&self.rgb.evaluate(d, self.grid, role, "material", material, what)?))
    }

    /// A reflectance in 0..1: a constant spectrum or an RGB texture converted per hit.
    fn reflectance(&self, d: &SpectrumDesc, material: &str, what: &str) -> Result<SpectralParam> {
        if let SpectrumKind::Texture { texture: t } = d.kind {
            let texture = self.textures.get(t).ok_or_else(|| {
                Error::object(
                    "material",
                    material,
                    format!("{what}: texture {t} does not exist ({} textures)", self.textures.len()),
                )
            })?;
            let Some(up) = self.uplift else {
                return Err(Error::object(
                    "material",
                    material,
                    format!(
                        "{what}: texture '{}' cannot be used on this wavelength grid (no RGB → spectrum map)",
                        texture.name
                    ),
                ));
            };
            let scale = d.scale;
            if !(scale.is_finite() && (0.0..=1.0).contains(&scale)) {
                return Err(Error::object(
                    "material",
                    material,
                    format!("{what}: texture scale {scale} must be in 0..1 (energy conserving)"),
                ));
            }
            return Ok(SpectralParam::Texture { texture: texture.clone(), uplift: up.clone(), scale });
        }
        let r = self.spectrum(d, SpectrumRole::Reflectance, material, what)?;
        if r.max_value() > 1.0 {
            return Err(Error::object(
                "material",
                material,
                format!("{what} {} exceeds 1 (not energy conserving)", r.max_value()),
            ));
        }
        if !r.is_finite() || r.values().iter().any(|&v| v < 0.0) {
            return Err(Error::object("material", material, format!("{what} must be finite and non-negative")));
        }
        Ok(SpectralParam::Constant(r))
    }
}

impl BsdfBuild<'_> {
    /// A constant reflectance in 0..1, white when absent (layer tints).
    fn optional_reflectance(&self, d: Option<&SpectrumDesc>, material: &str, what: &str) -> Result<SpectralParam> {
        match d {
            Some(d) if matches!(d.kind, SpectrumKind::Texture { .. }) => {
                Err(Error::object("material", material, format!("{what}: a texture is not supported here")))
            }
            Some(d) => self.reflectance(d, material, what),
            None => Ok(SpectralParam::Constant(SampledSpectrum::splat(self.grid.len(), 1.0))),
        }
    }
}

fn unit_weight(material: &str, what: &str, v: f32) -> Result<f32> {
    if !(v.is_finite() && (0.0..=1.0).contains(&v)) {
        return Err(Error::object("material", material, format!("{what} {v} must be in 0..1")));
    }
    Ok(v)
}

/// The Principled's subsurface lobe from its description (validated, naming the
/// material): the RGB radius × scale becomes a mean free path per grid wavelength through
/// the scene's RGB → spectrum map (the reflectance map of radius/max, times max, so it is
/// positive at every wavelength); `ior` is the Principled's own (Random Walk's entry).
fn subsurface_lobe(
    b: &BsdfBuild,
    material: &str,
    d: &super::SubsurfaceDesc,
    ior: &IndexOfRefraction,
) -> Result<Option<crate::material::subsurface::SubsurfaceLobe>> {
    use crate::material::subsurface::{SubsurfaceLobe, SubsurfaceMethod};
    let weight = unit_weight(material, "subsurface weight", d.weight)?;
    if d.radius.iter().any(|r| !(r.is_finite() && *r >= 0.0)) {
        return Err(Error::object(
            "material",
            material,
            format!("subsurface radius {:?} must be finite and non-negative", d.radius),
        ));
    }
    if !(d.scale.is_finite() && d.scale >= 0.0) {
        return Err(Error::object(
            "material",
            material,
            format!("subsurface scale {} must be finite and non-negative", d.scale),
        ));
    }
    if !d.ior.is_finite() || !d.anisotropy.is_finite() {
        return Err(Error::object(
            "material",
            material,
            format!("subsurface ior {} and anisotropy {} must be finite", d.ior, d.anisotropy),
        ));
    }
    let method = match d.method.as_str() {
        "random_walk" => SubsurfaceMethod::RandomWalk,
        "random_walk_skin" => SubsurfaceMethod::RandomWalkSkin,
        m => {
            return Err(Error::object(
                "material",
                material,
                format!("subsurface method '{m}' is not one of random_walk, random_walk_skin"),
            ))
        }
    };
    let n = b.grid.len();
    let peak = d.radius.iter().fold(0.0f32, |a, &r| a.max(r));
    let radius = if peak > 0.0 {
        let rgb = d.radius.map(|r| r / peak);
        let desc = SpectrumDesc::new(SpectrumKind::Rgb { rgb });
        let mut s = b.spectrum(&desc, SpectrumRole::Reflectance, material, "subsurface radius")?;
        s.scale(peak * d.scale);
        s
    } else {
        SampledSpectrum::zeros(n)
    };
    // Random Walk enters through the Principled's IOR (Cycles' `bssrdf->ior = eta`), one
    // index for every wavelength (the walk is shared): their mean.
    let entry_ior = match method {
        SubsurfaceMethod::RandomWalk => (0..n).map(|i| ior.at(i)).sum::<f32>() / n.max(1) as f32,
        SubsurfaceMethod::RandomWalkSkin => d.ior,
    };
    Ok(SubsurfaceLobe::new(weight, radius, d.anisotropy, entry_ior, method))
}

/// Builds any BSDF description: every material of `Scene::build` (fixed or folded)
/// and every per-hit BSDF of a varying graph, with the same validation for all.
pub(super) fn build_bsdf(b: &BsdfBuild, material: &str, d: &BsdfDesc) -> Result<Box<dyn Bsdf>> {
    build_at(b, material, d, 0)
}

fn build_at(b: &BsdfBuild, material: &str, d: &BsdfDesc, depth: usize) -> Result<Box<dyn Bsdf>> {
    if depth > MAX_DEPTH {
        return Err(Error::object("material", material, format!("mix/add shaders nested deeper than {MAX_DEPTH}")));
    }
    Ok(match d {
        BsdfDesc::Diffuse { reflectance } => {
            Box::new(Diffuse { reflectance: b.reflectance(reflectance, material, "reflectance")? })
        }
        BsdfDesc::None | BsdfDesc::Null | BsdfDesc::Transparent { .. } => Box::new(Black),
        BsdfDesc::Dielectric { ior, roughness } => super::optics::build_dielectric(material, ior, *roughness, b.grid)?,
        BsdfDesc::Refraction { ior, roughness, beckmann } => {
            super::optics::build_refraction(material, ior, *roughness, *beckmann, b.grid)?
        }
        BsdfDesc::Metallic { eta, k, roughness, multiscatter } => {
            let eta = b.spectrum(eta, SpectrumRole::Unbounded, material, "eta")?;
            let k = b.spectrum(k, SpectrumRole::Unbounded, material, "k")?;
            super::optics::build_metallic(material, eta, k, *roughness, *multiscatter)?
        }
        BsdfDesc::Conductor { metal, eta, k, roughness } => {
            let eta = eta.as_ref().map(|d| b.spectrum(d, SpectrumRole::Unbounded, material, "eta")).transpose()?;
            let k = k.as_ref().map(|d| b.spectrum(d, SpectrumRole::Unbounded, material, "k")).transpose()?;
            super::optics::build_conductor(material, metal.as_deref(), eta, k, *roughness, b.grid)?
        }
        BsdfDesc::Glossy { reflectance, roughness, anisotropy, rotation, tangent } => {
            super::optics::build_glossy_anisotropic(
                material,
                b.spectrum(reflectance, SpectrumRole::Reflectance, material, "reflectance")?,
                *roughness,
                *anisotropy,
                *rotation,
                *tangent,
            )?
        }
        BsdfDesc::Principled {
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
            anisotropic,
            anisotropic_rotation,
            coat,
            sheen,
            subsurface,
            normals,
        } => {
            let base_color = b.reflectance(base_color, material, "base_color")?;
            let metallic = unit_weight(material, "metallic", *metallic)?;
            let transmission = unit_weight(material, "transmission", *transmission)?;
            let specular_ior_level = unit_weight(material, "specular_ior_level", *specular_ior_level)?;
            let roughness = unit_weight(material, "roughness", *roughness)?;
            let index = IndexOfRefraction::build(ior, b.grid, material)?;
            let n = b.grid.len();
            let specular_tint = match specular_tint {
                Some(t) => {
                    let s = b.spectrum(t, SpectrumRole::Reflectance, material, "specular_tint")?;
                    if !s.is_finite() || s.max_value() > 1.0 || s.values().iter().any(|&v| v < 0.0) {
                        return Err(Error::object("material", material, "specular_tint must lie in 0..1"));
                    }
                    s
                }
                None => SampledSpectrum::splat(n, 1.0),
            };
            let (d_nm, n_film) = (*thin_film_thickness, *thin_film_ior);
            if !(d_nm.is_finite() && (0.0..=100_000.0).contains(&d_nm)) {
                return Err(Error::object(
                    "material",
                    material,
                    format!("thin_film_thickness {d_nm} nm must be in 0..100000"),
                ));
            }
            if !(n_film.is_finite() && (1.0..=10.0).contains(&n_film)) {
                return Err(Error::object("material", material, format!("thin_film_ior {n_film} must be in 1..10")));
            }
            let thin_film = Some(ThinFilm { thickness_nm: d_nm, ior: n_film }).filter(|f| f.active());
            let sss = match subsurface {
                Some(d) => subsurface_lobe(b, material, d, &index)?,
                None => None,
            };
            let glass = if transmission > 0.0 {
                Some(super::optics::build_dielectric(material, ior, roughness, b.grid)?)
            } else {
                None
            };
            let n = normals.as_deref().cloned().unwrap_or_default();
            if !anisotropic.is_finite() || !anisotropic_rotation.is_finite() {
                return Err(Error::object(
                    "material",
                    material,
                    format!("anisotropic {anisotropic} and anisotropic_rotation {anisotropic_rotation} must be finite"),
                ));
            }
            // The tangent in the frame the lobes are evaluated in (about the base normal
            // when it is oriented); Cycles turns it about N by Anisotropic Rotation × 2π.
            let t = n.tangent.map_or(Vec3A::X, |t| match n.base {
                Some(nb) => LobeFrame::new(Vec3A::from(nb)).to_lobe(Vec3A::from(t)),
                None => Vec3A::from(t),
            });
            let mut out: Box<dyn Bsdf> = Box::new(
                Principled::new(
                    PrincipledParams {
                        base_color,
                        metallic,
                        transmission,
                        roughness,
                        ior: index,
                        specular_ior_level,
                        specular_tint,
                        thin_film,
                        diffuse_roughness: unit_weight(material, "diffuse_roughness", *diffuse_roughness)?,
                        glass,
                        anisotropic: anisotropic.clamp(0.0, 1.0),
                        tangent: TangentRotation::new(t, *anisotropic_rotation),
                    },
                    b.grid,
                )
                .with_subsurface(sss)
                .with_frames(PrincipledFrames {
                    spec: n.base.map(|b| LobeFrame::new(Vec3A::from(b))),
                    diffuse: n.diffuse.map(|d| LobeFrame::new(Vec3A::from(d))),
                    smooth: n.smooth.map(Vec3A::from),
                }),
            );
            // Cycles' svm_node_closure_bsdf (CLOSURE_BSDF_PRINCIPLED_ID) stacks the coat over
            // everything else, then the sheen over the coat.
            if let Some(c) = coat {
                let weight = unit_weight(material, "coat weight", c.weight)?;
                let roughness = unit_weight(material, "coat roughness", c.roughness)?;
                if !(c.ior.is_finite() && (1.0..=10.0).contains(&c.ior)) {
                    return Err(Error::object("material", material, format!("coat ior {} must be in 1..10", c.ior)));
                }
                if weight > 0.0 {
                    let tint = b.optional_reflectance(c.tint.as_ref(), material, "coat tint")?;
                    let top = TopLobe::coat(weight, roughness, c.ior, tint);
                    out = Box::new(Layered::new(top, out).with_top_normal(n.coat.map(Vec3A::from)));
                }
            }
            if let Some(sh) = sheen {
                let weight = unit_weight(material, "sheen weight", sh.weight)?;
                let roughness = unit_weight(material, "sheen roughness", sh.roughness)?;
                if weight > 0.0 {
                    let tint = b.optional_reflectance(sh.tint.as_ref(), material, "sheen tint")?;
                    let top = TopLobe::sheen(weight, tint, roughness);
                    out = Box::new(Layered::new(top, out).with_top_normal(n.sheen.map(Vec3A::from)));
                }
            }
            out
        }
        BsdfDesc::Mix { a, b: second, factor, factor_from } => {
            let f = unit_weight(material, "mix factor", *factor)?;
            let factor = match factor_from {
                None => MixFactor::Constant(f),
                Some(MixFactorDesc::Fresnel { ior }) => {
                    if !(ior.is_finite() && *ior >= 0.0) {
                        return Err(Error::object(
                            "material",
                            material,
                            format!("mix factor: Fresnel ior {ior} must be finite and non-negative"),
                        ));
                    }
                    MixFactor::Fresnel { ior: *ior }
                }
                Some(MixFactorDesc::LayerWeightFresnel { blend }) => MixFactor::LayerWeightFresnel {
                    blend: unit_weight(material, "mix factor: layer weight blend", *blend)?,
                },
                Some(MixFactorDesc::LayerWeightFacing { blend }) => MixFactor::LayerWeightFacing {
                    blend: unit_weight(material, "mix factor: layer weight blend", *blend)?,
                },
            };
            Box::new(MixBsdf::mix_with(
                build_at(b, material, a, depth + 1)?,
                build_at(b, material, second, depth + 1)?,
                factor,
            ))
        }
        BsdfDesc::Add { a, b: second } => {
            Box::new(MixBsdf::add(build_at(b, material, a, depth + 1)?, build_at(b, material, second, depth + 1)?))
        }
        BsdfDesc::RoughDiffuse { reflectance, roughness } => Box::new(OrenNayar::new(
            b.reflectance(reflectance, material, "reflectance")?,
            unit_weight(material, "roughness", *roughness)?,
        )),
        BsdfDesc::Tint { color, bsdf } => Box::new(Tinted {
            color: b.reflectance(color, material, "color")?,
            inner: build_at(b, material, bsdf, depth + 1)?,
        }),
        BsdfDesc::Translucent { color } => Box::new(Translucent { color: b.reflectance(color, material, "color")? }),
        BsdfDesc::Sheen { color, roughness } => Box::new(Sheen {
            color: b.reflectance(color, material, "color")?,
            roughness: unit_weight(material, "roughness", *roughness)?,
        }),
        BsdfDesc::Oriented { normal, bsdf, smooth } => Box::new(Oriented::diffuse(
            Vec3A::from(*normal),
            smooth.map(Vec3A::from),
            build_at(b, material, bsdf, depth + 1)?,
        )),
        BsdfDesc::Graph(_) => {
            return Err(Error::object("material", material, "a node graph cannot be nested inside a mix or add shader"))
        }
    })
}
