//! The closure part of a graph (Principled, Diffuse, Glossy, Glass, Refraction,
//! Translucent, Sheen, Emission, Transparent, Mix Shader, Add Shader): every non-closure
//! input they read becomes a parameter, a constant or a register of the program. A
//! graph whose parameters are all constant is lowered to the fixed [`BsdfDesc`], so it
//! is built exactly as the equivalent fixed material.

use super::compile::{Compiler, Value};
use super::desc::InputDesc;
use crate::material::IorDesc;
use crate::scene::{BsdfDesc, MixFactorDesc};
use crate::spectrum::named::SpectrumKind;
use crate::spectrum::SpectrumDesc;
use crate::{Error, Result};
use glam::Vec3;

/// Deepest nesting of Mix/Add Shader nodes (guards the recursion).
const MAX_DEPTH: usize = 64;

/// What the surface emits: an RGB radiance, or a spectral one.
#[derive(Clone, Debug)]
pub enum Emission {
    Rgb(Vec3),
    Spectrum(SpectrumDesc),
}

impl Emission {
    fn scaled(self, s: f32) -> Self {
        match self {
            Emission::Rgb(c) => Emission::Rgb(c * s),
            Emission::Spectrum(mut d) => {
                d.scale *= s;
                Emission::Spectrum(d)
            }
        }
    }
}

/// A constant surface: the fixed description and its emission.
pub struct Lowered {
    pub bsdf: BsdfDesc,
    pub emission: Option<SpectrumDesc>,
}

pub struct Lowering<'c, 'a> {
    pub c: &'c mut Compiler<'a>,
    /// Closure nodes on the current path, for cycles through shader links.
    path: Vec<usize>,
}

fn add_emission(material: &str, a: Option<Emission>, b: Option<Emission>) -> Result<Option<Emission>> {
    Ok(match (a, b) {
        (None, x) | (x, None) => x,
        (Some(Emission::Rgb(x)), Some(Emission::Rgb(y))) => Some(Emission::Rgb(x + y)),
        (Some(Emission::Spectrum(x)), Some(Emission::Spectrum(y))) if x.kind == y.kind => {
            Some(Emission::Spectrum(SpectrumDesc { kind: x.kind, scale: x.scale + y.scale }))
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

impl<'c, 'a> Lowering<'c, 'a> {
    pub fn new(c: &'c mut Compiler<'a>) -> Self {
        Self { c, path: Vec::new() }
    }

    fn non_constant(&self, node: usize, id: &str) -> Error {
        self.c.error(
            node,
            format!("input '{id}' varies over the surface: it needs per-hit evaluation (not yet supported)"),
        )
    }

    /// A constant float input.
    fn float(&mut self, node: usize, id: &str) -> Result<f32> {
        let r = self.c.input_reg(node, id)?;
        self.c.const_of(r).map(|v| v.x).ok_or_else(|| self.non_constant(node, id))
    }

    /// A constant colour input as a spectrum description, clamped to 0..1 when it is a
    /// reflectance (Cycles saturates closure colours' weights the same way).
    fn color(&mut self, node: usize, id: &str, reflectance: bool) -> Result<SpectrumDesc> {
        match self.c.input(node, id)? {
            Value::Spectrum(s) => Ok(s),
            Value::Ior(_) => Err(self.c.error(node, format!("input '{id}': an IOR model on a colour"))),
            Value::Reg(r) => {
                let v = self.c.const_of(r).ok_or_else(|| self.non_constant(node, id))?;
                let v = if reflectance { v.clamp(Vec3::ZERO, Vec3::ONE) } else { v.max(Vec3::ZERO) };
                Ok(SpectrumDesc::new(SpectrumKind::Rgb { rgb: v.to_array() }))
            }
        }
    }

    fn is_white(d: &SpectrumDesc) -> bool {
        matches!(d.kind, SpectrumKind::Rgb { rgb } if rgb == [1.0; 3]) && d.scale == 1.0
            || matches!(d.kind, SpectrumKind::Constant { value } if value * d.scale == 1.0)
    }

    fn ior(&mut self, node: usize, id: &str) -> Result<IorDesc> {
        match self.c.input(node, id)? {
            Value::Ior(d) => Ok(d),
            Value::Spectrum(_) => Err(self.c.error(node, format!("input '{id}': a spectrum on an IOR"))),
            Value::Reg(r) => {
                let v = self.c.const_of(r).ok_or_else(|| self.non_constant(node, id))?.x;
                Ok(IorDesc::Constant { ior: f64::from(v.max(1e-5)) })
            }
        }
    }

    /// Checks that a Normal/Tangent input is unlinked (the default normal).
    fn default_normal(&mut self, node: usize, id: &str) -> Result<()> {
        if self.c.linked(node, id).is_some() {
            return Err(self.non_constant(node, id));
        }
        Ok(())
    }

    /// Warns when an input this build ignores differs from Blender's default.
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
    fn shader_input(&mut self, node: usize, id: &str, depth: usize) -> Result<(BsdfDesc, Option<Emission>)> {
        match self.c.linked(node, id) {
            None => Ok((BsdfDesc::None, None)),
            Some((from, out)) => self.closure(from, out, depth + 1),
        }
    }

    /// Lowers the closure at output `out` of node `node`.
    pub fn closure(&mut self, node: usize, out: &str, depth: usize) -> Result<(BsdfDesc, Option<Emission>)> {
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
                return Ok((BsdfDesc::default(), None));
            }
        }
        self.c.check_inputs(node)?;
        self.path.push(node);
        let r = self.closure_node(node, kind, depth);
        self.path.pop();
        r
    }

    fn closure_node(&mut self, node: usize, kind: &str, depth: usize) -> Result<(BsdfDesc, Option<Emission>)> {
        let material = self.c.material;
        Ok(match kind {
            "ShaderNodeBsdfPrincipled" => {
                self.default_normal(node, "Normal")?;
                for (id, default, what) in [
                    ("Alpha", 1.0, "no transparency yet"),
                    ("Diffuse Roughness", 0.0, "Principled diffuse is Lambertian"),
                    ("Subsurface Weight", 0.0, "no subsurface scattering yet"),
                    ("Anisotropic", 0.0, "no anisotropy yet"),
                    ("Coat Weight", 0.0, "no coat yet"),
                    ("Sheen Weight", 0.0, "no Principled sheen yet"),
                ] {
                    self.ignored(node, id, default, what)?;
                }
                let emission = self.emission(node, "Emission Color", "Emission Strength")?;
                let level = self.float(node, "Specular IOR Level")?.max(0.0);
                if level > 1.0 {
                    self.c.warn(node, format!("Specular IOR Level {level} is clamped to 1"));
                }
                let tint = self.color(node, "Specular Tint", true)?;
                let bsdf = BsdfDesc::Principled {
                    base_color: self.color(node, "Base Color", true)?,
                    metallic: self.float(node, "Metallic")?.clamp(0.0, 1.0),
                    roughness: self.float(node, "Roughness")?.clamp(0.0, 1.0),
                    ior: self.ior(node, "IOR")?,
                    transmission: self.float(node, "Transmission Weight")?.clamp(0.0, 1.0),
                    specular_tint: (!Self::is_white(&tint)).then_some(tint),
                    thin_film_thickness: self.float(node, "Thin Film Thickness")?.clamp(0.0, 100_000.0),
                    thin_film_ior: self.float(node, "Thin Film IOR")?.clamp(1.0, 10.0),
                    specular_ior_level: level.min(1.0),
                };
                (bsdf, emission)
            }
            "ShaderNodeBsdfDiffuse" => {
                self.default_normal(node, "Normal")?;
                let reflectance = self.color(node, "Color", true)?;
                let roughness = self.float(node, "Roughness")?.clamp(0.0, 1.0);
                let bsdf = if roughness > 0.0 {
                    BsdfDesc::RoughDiffuse { reflectance, roughness }
                } else {
                    BsdfDesc::Diffuse { reflectance }
                };
                (bsdf, None)
            }
            "ShaderNodeBsdfAnisotropic" | "ShaderNodeBsdfGlossy" => {
                self.default_normal(node, "Normal")?;
                self.ignored(node, "Anisotropy", 0.0, "no anisotropy yet")?;
                let reflectance = self.color(node, "Color", true)?;
                (BsdfDesc::Glossy { reflectance, roughness: self.float(node, "Roughness")?.clamp(0.0, 1.0) }, None)
            }
            "ShaderNodeBsdfGlass" | "ShaderNodeBsdfRefraction" => {
                self.default_normal(node, "Normal")?;
                if kind == "ShaderNodeBsdfRefraction" {
                    self.c.warn(node, "Refraction BSDF is rendered as Glass (its reflection is kept)");
                }
                let color = self.color(node, "Color", true)?;
                let roughness = self.float(node, "Roughness")?.clamp(0.0, 1.0);
                let ior = self.ior(node, "IOR")?;
                let bsdf = if Self::is_white(&color) {
                    BsdfDesc::Dielectric { ior, roughness }
                } else {
                    self.c.warn(node, "a tinted Glass is rendered as a transmissive Principled (reflection untinted)");
                    BsdfDesc::Principled {
                        base_color: color,
                        metallic: 0.0,
                        roughness,
                        ior,
                        transmission: 1.0,
                        specular_tint: None,
                        thin_film_thickness: 0.0,
                        thin_film_ior: 1.33,
                        specular_ior_level: 0.5,
                    }
                };
                (bsdf, None)
            }
            "ShaderNodeBsdfTranslucent" => {
                self.default_normal(node, "Normal")?;
                (BsdfDesc::Translucent { color: self.color(node, "Color", true)? }, None)
            }
            "ShaderNodeBsdfSheen" => {
                self.default_normal(node, "Normal")?;
                let color = self.color(node, "Color", true)?;
                (BsdfDesc::Sheen { color, roughness: self.float(node, "Roughness")?.clamp(0.0, 1.0) }, None)
            }
            "ShaderNodeEmission" => (BsdfDesc::None, self.emission(node, "Color", "Strength")?),
            "ShaderNodeBsdfTransparent" | "ShaderNodeHoldout" => {
                self.c.warn(node, "is not supported yet; the surface reflects nothing here");
                (BsdfDesc::None, None)
            }
            "ShaderNodeAddShader" => {
                let (a, ea) = self.shader_input(node, "Shader", depth)?;
                let (b, eb) = self.shader_input(node, "Shader_001", depth)?;
                (BsdfDesc::Add { a: Box::new(a), b: Box::new(b) }, add_emission(material, ea, eb)?)
            }
            "ShaderNodeMixShader" => {
                let (factor, factor_from) = self.mix_factor(node)?;
                let (a, ea) = self.shader_input(node, "Shader", depth)?;
                let (b, eb) = self.shader_input(node, "Shader_001", depth)?;
                if factor_from.is_some() && (ea.is_some() || eb.is_some()) {
                    return Err(self.non_constant(node, "Fac"));
                }
                let emission =
                    add_emission(material, ea.map(|e| e.scaled(1.0 - factor)), eb.map(|e| e.scaled(factor)))?;
                (BsdfDesc::Mix { a: Box::new(a), b: Box::new(b), factor, factor_from }, emission)
            }
            _ => {
                self.c.warn(node, "is not a supported shader; it renders as a grey diffuse");
                (BsdfDesc::default(), None)
            }
        })
    }

    fn emission(&mut self, node: usize, color: &str, strength: &str) -> Result<Option<Emission>> {
        let s = self.float(node, strength)?;
        let e = match self.color(node, color, false)? {
            SpectrumDesc { kind: SpectrumKind::Rgb { rgb }, scale } => Emission::Rgb(Vec3::from(rgb) * scale),
            d => Emission::Spectrum(d),
        };
        Ok((s > 0.0).then(|| e.scaled(s)).filter(|e| !matches!(e, Emission::Rgb(c) if *c == Vec3::ZERO)))
    }

    /// A Mix Shader's Fac: a constant, or a Fresnel / Layer Weight node the fixed
    /// material already evaluates per hit (`MixFactor`).
    fn mix_factor(&mut self, node: usize) -> Result<(f32, Option<MixFactorDesc>)> {
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
                        return Ok((0.5, Some(d)));
                    }
                }
            }
        }
        Ok((self.float(node, "Fac")?.clamp(0.0, 1.0), None))
    }
}

/// The surface of a graph as a fixed material, if every parameter is constant.
pub fn lower_surface(c: &mut Compiler, surface: Option<&(usize, String)>) -> Result<Lowered> {
    let Some((node, out)) = surface else { return Ok(Lowered { bsdf: BsdfDesc::None, emission: None }) };
    let mut l = Lowering::new(c);
    let (bsdf, emission) = l.closure(*node, out, 0)?;
    let emission = emission.map(|e| match e {
        Emission::Rgb(c) => SpectrumDesc::new(SpectrumKind::Rgb { rgb: c.to_array() }),
        Emission::Spectrum(d) => d,
    });
    Ok(Lowered { bsdf, emission })
}
