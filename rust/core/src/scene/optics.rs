//! Building the optical materials (glass, metals) and the spot and sun lights from
//! their descriptions: the parts of `Scene::build` owned by issue 4 part A.

use crate::light::{DistantLight, Light, SpotLight};
use crate::material::conductor::{ComplexFresnel, SchlickFresnel};
use crate::material::microfacet::{Ggx, TangentRotation};
use crate::material::{
    Bsdf, Conductor, Dielectric, Glossy, IndexOfRefraction, IorDesc, RoughDielectric, SpectralParam,
};
use crate::spectrum::measured;
use crate::spectrum::named::average_piecewise_linear;
use crate::spectrum::{SampledSpectrum, WavelengthGrid};
use crate::{Error, Result};
use glam::Vec3A;

/// Metals with measured complex indices: accepted names and (η, k) tables.
pub const METALS: &[(&[&str], &[(f32, f32)], &[(f32, f32)])] = &[
    (&["gold", "au"], measured::AU_ETA, measured::AU_K),
    (&["silver", "ag"], measured::AG_ETA, measured::AG_K),
    (&["copper", "cu"], measured::CU_ETA, measured::CU_K),
    (&["aluminium", "aluminum", "al"], measured::AL_ETA, measured::AL_K),
];

fn check_roughness(material: &str, roughness: f32) -> Result<f32> {
    if !(roughness.is_finite() && (0.0..=1.0).contains(&roughness)) {
        return Err(Error::object("material", material, format!("roughness {roughness} must be in 0..1")));
    }
    Ok(roughness)
}

/// (λ nm, value) pairs averaged over each grid cell.
fn resample_table(table: &[(f32, f32)], grid: &WavelengthGrid) -> SampledSpectrum {
    let xs: Vec<f32> = table.iter().map(|p| p.0).collect();
    let ys: Vec<f32> = table.iter().map(|p| p.1).collect();
    let v: Vec<f32> = (0..grid.len())
        .map(|i| {
            let (lo, hi) = grid.cell(i);
            average_piecewise_linear(&xs, &ys, lo, hi)
        })
        .collect();
    SampledSpectrum::from_slice(&v)
}

/// A smooth or rough dielectric (dispersive when its index varies over the grid).
pub fn build_dielectric(material: &str, ior: &IorDesc, roughness: f32, grid: &WavelengthGrid) -> Result<Box<dyn Bsdf>> {
    let roughness = check_roughness(material, roughness)?;
    let ior = IndexOfRefraction::build(ior, grid, material)?;
    let distribution = Ggx::from_roughness(roughness);
    Ok(if distribution.effectively_smooth() {
        Box::new(Dielectric { ior })
    } else {
        Box::new(RoughDielectric::new(ior, distribution))
    })
}

/// Blender's Refraction BSDF: transmission only (`material::refraction`).
pub fn build_refraction(
    material: &str,
    ior: &IorDesc,
    roughness: f32,
    beckmann: bool,
    grid: &WavelengthGrid,
) -> Result<Box<dyn Bsdf>> {
    let roughness = check_roughness(material, roughness)?;
    let ior = IndexOfRefraction::build(ior, grid, material)?;
    Ok(Box::new(crate::material::refraction::Refraction::new(ior, roughness, beckmann)))
}

/// Blender's Metallic BSDF in Physical Conductor mode (`material::metallic`): η and k
/// per wavelength (the node's RGB uplifted), clamped below at 0 as Cycles clamps the RGB
/// (η at least 1e-4: a complex index of 0 has no Fresnel).
pub fn build_metallic(
    material: &str,
    mut eta: SampledSpectrum,
    mut k: SampledSpectrum,
    roughness: f32,
    multiscatter: bool,
) -> Result<Box<dyn Bsdf>> {
    let roughness = check_roughness(material, roughness)?;
    if !(eta.is_finite() && k.is_finite()) {
        return Err(Error::object("material", material, "the conductor's IOR and Extinction must be finite"));
    }
    eta.values_mut().iter_mut().for_each(|v| *v = v.max(1e-4));
    k.values_mut().iter_mut().for_each(|v| *v = v.max(0.0));
    let c = Conductor::new(ComplexFresnel { eta, k }, roughness);
    Ok(if multiscatter { Box::new(crate::material::metallic::MultiscatterConductor::new(c)) } else { Box::new(c) })
}

/// A conductor from a named metal or user (η, k) spectra (already on the grid).
pub fn build_conductor(
    material: &str,
    metal: Option<&str>,
    eta: Option<SampledSpectrum>,
    k: Option<SampledSpectrum>,
    roughness: f32,
    grid: &WavelengthGrid,
) -> Result<Box<dyn Bsdf>> {
    let roughness = check_roughness(material, roughness)?;
    let (eta, k) = match (metal, eta, k) {
        (Some(name), None, None) => {
            let key = name.trim().to_lowercase();
            let Some((_, e, k)) = METALS.iter().find(|(names, _, _)| names.contains(&key.as_str())) else {
                return Err(Error::object(
                    "material",
                    material,
                    format!("unknown metal '{name}' (known: gold, silver, copper, aluminium)"),
                ));
            };
            (resample_table(e, grid), resample_table(k, grid))
        }
        (None, Some(e), Some(k)) => (e, k),
        _ => return Err(Error::object("material", material, "a conductor needs either 'metal' or both 'eta' and 'k'")),
    };
    for i in 0..grid.len() {
        let (e, kk) = (eta.get(i), k.get(i));
        if !(e.is_finite() && kk.is_finite() && e >= 0.0 && kk >= 0.0 && (e > 0.0 || kk > 0.0)) {
            return Err(Error::object(
                "material",
                material,
                format!("complex index {e} + {kk}i at λ {} nm must have η, k ≥ 0, not both 0", grid.lambdas()[i]),
            ));
        }
    }
    Ok(Box::new(Conductor::new(ComplexFresnel { eta, k }, roughness)))
}

/// Blender's Glossy BSDF: GGX with Schlick's Fresnel tinted by `reflectance`.
pub fn build_glossy(material: &str, r: SampledSpectrum, roughness: f32) -> Result<Box<dyn Bsdf>> {
    build_glossy_anisotropic(material, r, roughness, 0.0, 0.0, None)
}

/// Blender's Glossy BSDF with its Anisotropy (−1..1) along `tangent` (in the lobe's
/// shading frame; None: the frame's first axis) turned by `rotation` turns about the
/// normal: Cycles' `svm_node_closure_bsdf` (CLOSURE_BSDF_MICROFACET_GGX_ID and its
/// multiscatter variant, intern/cycles/kernel/svm/closure.h) clamps the anisotropy to
/// ±0.99 and keeps the lobe isotropic below |0.0001|.
pub fn build_glossy_anisotropic(
    material: &str,
    r: SampledSpectrum,
    roughness: f32,
    anisotropy: f32,
    rotation: f32,
    tangent: Option<[f32; 3]>,
) -> Result<Box<dyn Bsdf>> {
    let roughness = check_roughness(material, roughness)?;
    if !anisotropy.is_finite() || !rotation.is_finite() {
        return Err(Error::object(
            "material",
            material,
            format!("glossy anisotropy {anisotropy} and rotation {rotation} must be finite"),
        ));
    }
    if r.max_value() > 1.0 {
        return Err(Error::object(
            "material",
            material,
            format!("reflectance {} exceeds 1 (not energy conserving)", r.max_value()),
        ));
    }
    let glossy = Glossy::new(SchlickFresnel { reflectance: SpectralParam::Constant(r) }, roughness);
    let g = Ggx::glossy_anisotropic(roughness, anisotropy);
    if g.is_isotropic() {
        return Ok(Box::new(glossy));
    }
    let t = TangentRotation::new(tangent.map_or(Vec3A::X, Vec3A::from), rotation);
    Ok(Box::new(glossy.with_distribution(g, t)))
}

fn unit_direction(light: &str, d: [f32; 3]) -> Result<Vec3A> {
    let v = Vec3A::from(d);
    let len = v.length();
    if !(len.is_finite() && len > 0.0) {
        return Err(Error::object("light", light, format!("direction {d:?} must be finite and non-zero")));
    }
    Ok(v / len)
}

/// A spot light; `intensity` already evaluated on the grid.
pub fn build_spot(
    name: &str,
    position: [f32; 3],
    direction: [f32; 3],
    intensity: SampledSpectrum,
    spot_size: f32,
    spot_blend: f32,
    radius: f32,
    profile: Option<crate::light::Profile>,
) -> Result<Box<dyn Light>> {
    let radius = light_radius(name, radius)?;
    let p = Vec3A::from(position);
    if !p.is_finite() {
        return Err(Error::object("light", name, "position is not finite"));
    }
    let d = unit_direction(name, direction)?;
    if !(spot_size.is_finite() && spot_size > 0.0 && spot_size <= std::f32::consts::PI + 1e-6) {
        return Err(Error::object("light", name, format!("spot_size {spot_size} rad must be in (0, π]")));
    }
    if !(spot_blend.is_finite() && (0.0..=1.0).contains(&spot_blend)) {
        return Err(Error::object("light", name, format!("spot_blend {spot_blend} must be in 0..1")));
    }
    Ok(Box::new(SpotLight::new(p, d, intensity, spot_size, spot_blend).with_radius(radius).with_profile(profile)))
}

/// A distant (sun) light; `irradiance` already evaluated on the grid. The scene's
/// bounding sphere comes later ([`Light::preprocess`]).
pub fn build_distant(
    name: &str,
    direction: [f32; 3],
    irradiance: SampledSpectrum,
    angle: f32,
) -> Result<Box<dyn Light>> {
    let direction = unit_direction(name, direction)?;
    if !(angle.is_finite() && (0.0..=std::f32::consts::PI + 1e-6).contains(&angle)) {
        return Err(Error::object("light", name, format!("angle {angle} rad must be in [0, π]")));
    }
    let half_angle = (0.5 * angle).min(std::f32::consts::FRAC_PI_2);
    Ok(Box::new(DistantLight { direction, irradiance, scene_center: Vec3A::ZERO, scene_radius: 1.0, half_angle }))
}

/// A point or spot light's sphere radius: finite and ≥ 0.
pub fn light_radius(name: &str, radius: f32) -> Result<f32> {
    if !(radius.is_finite() && radius >= 0.0) {
        return Err(Error::object("light", name, format!("radius {radius} must be finite and non-negative")));
    }
    Ok(radius)
}
