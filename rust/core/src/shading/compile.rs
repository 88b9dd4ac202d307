//! Compiling a node graph: links resolved with Blender's type conversions, cycles
//! detected, nodes emitted in dependency order and only when a closure reads them
//! (dead nodes never reach the program), constants folded as they are emitted.

use super::color::{self, ColorOp, ColorRamp, Curves, CurvesKind, Mix};
use super::desc::{InputDesc, NodeDesc};
use super::fold::fold;
use super::input::Input;
use super::math::{Clamp, MapRange, Math, VectorMath};
use super::program::{AttributeRequest, Convert, Instr, Kernel, Program, Reg};
use super::props::Props;
use super::sockets::{self, Implicit, SocketType};
use super::texture::{Image, Interpolation, ProceduralNode, ProceduralSlot};
use super::vector::{Bump, MappingType, NormalMapSpace, VectorOp};
use crate::material::texture::{Texture, Wrap};
use crate::material::IorDesc;
use crate::procedural::Procedural;
use crate::spectrum::SpectrumDesc;
use crate::{Error, Result};
use glam::Vec3;
use std::sync::Arc;

/// A resolved input: a register (constant or computed), or a spectral constant.
#[derive(Clone, Debug)]
pub enum Value {
    Reg(Reg),
    Spectrum(SpectrumDesc),
    Ior(IorDesc),
}

enum State {
    Todo,
    Busy,
    Done(Vec<Reg>),
}

pub struct Compiler<'a> {
    pub material: &'a str,
    pub nodes: &'a [NodeDesc],
    textures: &'a [Arc<Texture>],
    pub program: Program,
    consts: Vec<Option<Vec3>>,
    state: Vec<State>,
    stack: Vec<usize>,
    pub warnings: Vec<String>,
}

fn is_shader_node(kind: &str) -> bool {
    sockets::spec(kind).is_some_and(|s| s.outputs.iter().any(|o| o.1 == SocketType::Shader))
}

impl<'a> Compiler<'a> {
    pub fn new(material: &'a str, nodes: &'a [NodeDesc], textures: &'a [Arc<Texture>]) -> Self {
        Self {
            material,
            nodes,
            textures,
            program: Program::default(),
            consts: Vec::new(),
            state: nodes.iter().map(|_| State::Todo).collect(),
            stack: Vec::new(),
            warnings: Vec::new(),
        }
    }

    pub fn error(&self, node: usize, msg: impl std::fmt::Display) -> Error {
        let n = &self.nodes[node];
        Error::object("material", self.material, format!("node '{}' ({}): {msg}", n.name, n.kind))
    }

    pub fn warn(&mut self, node: usize, msg: impl std::fmt::Display) {
        let n = &self.nodes[node];
        let w = format!("material '{}': node '{}' ({}): {msg}", self.material, n.name, n.kind);
        if !self.warnings.contains(&w) {
            self.warnings.push(w);
        }
    }

    /// A register holding a constant.
    pub fn konst(&mut self, v: Vec3) -> Reg {
        self.program.init.push(v);
        self.consts.push(Some(v));
        (self.program.init.len() - 1) as Reg
    }

    fn fresh(&mut self) -> Reg {
        self.program.init.push(Vec3::ZERO);
        self.consts.push(None);
        (self.program.init.len() - 1) as Reg
    }

    /// The value of a register when it is a constant.
    pub fn const_of(&self, r: Reg) -> Option<Vec3> {
        self.consts.get(r as usize).copied().flatten()
    }

    /// Emits `kernel` on `ins` (folded when it can be), returning its `n_out` outputs.
    fn emit(&mut self, kernel: Kernel, ins: Vec<Reg>, n_out: usize) -> Vec<Reg> {
        let consts: Vec<Option<Vec3>> = ins.iter().map(|&r| self.const_of(r)).collect();
        if let Some(o) = fold(&kernel, &consts, n_out) {
            return (0..n_out).map(|k| self.konst(o[k])).collect();
        }
        let outs: Vec<Reg> = (0..n_out).map(|_| self.fresh()).collect();
        self.program.ops.push(Instr { kernel, ins, outs: outs.clone() });
        outs
    }

    /// The slot of a per-vertex attribute in the shading point.
    fn attribute(&mut self, node: usize, a: AttributeRequest) -> Result<usize> {
        if let Some(k) = self.program.attributes.iter().position(|x| *x == a) {
            return Ok(k);
        }
        if self.program.attributes.len() >= super::program::MAX_ATTRIBUTES {
            return Err(
                self.error(node, format!("reads more than {} UV maps and attributes", super::program::MAX_ATTRIBUTES))
            );
        }
        self.program.attributes.push(a);
        Ok(self.program.attributes.len() - 1)
    }

    /// Checks that every input the node names exists on it.
    pub fn check_inputs(&self, node: usize) -> Result<()> {
        let n = &self.nodes[node];
        let Some(spec) = sockets::spec(&n.kind) else { return Ok(()) };
        for id in n.inputs.keys() {
            if spec.input(id).is_none() {
                let known: Vec<&str> = spec.inputs.iter().map(|s| s.id).collect();
                return Err(self.error(node, format!("unknown input socket '{id}' (it has {})", known.join(", "))));
            }
        }
        Ok(())
    }

    /// Whether input `id` of `node` is linked.
    pub fn linked(&self, node: usize, id: &str) -> Option<(usize, &'a str)> {
        match self.nodes[node].inputs.get(id) {
            Some(InputDesc::Link { link }) => Some((link.0, link.1.as_str())),
            _ => None,
        }
    }

    /// Input `id` of `node`, converted to the socket's type.
    pub fn input(&mut self, node: usize, id: &str) -> Result<Value> {
        let kind = self.nodes[node].kind.as_str();
        let spec = sockets::spec(kind).ok_or_else(|| self.error(node, "unsupported node"))?;
        let (_, s) = spec.input(id).ok_or_else(|| self.error(node, format!("has no input socket '{id}'")))?;
        let nan = |c: &Self| c.error(node, format!("input '{id}' is not a finite number"));
        match self.nodes[node].inputs.get(id) {
            None => match sockets::implicit(kind, id) {
                Some(imp) => {
                    let k = match imp {
                        Implicit::Uv => Input::Uv,
                        Implicit::Generated => Input::Generated,
                        Implicit::Normal => Input::Normal,
                        Implicit::Tangent => Input::Tangent,
                        Implicit::Incoming => Input::Incoming,
                    };
                    Ok(Value::Reg(self.emit(Kernel::Input(k), vec![], 1)[0]))
                }
                None => Ok(Value::Reg(self.konst(Vec3::from(s.default)))),
            },
            Some(InputDesc::Number(x)) => {
                if !x.is_finite() {
                    return Err(nan(self));
                }
                let v = if s.ty == SocketType::Float { Vec3::new(*x, 0.0, 0.0) } else { Vec3::splat(*x) };
                Ok(Value::Reg(self.konst(v)))
            }
            Some(InputDesc::Array(a)) => {
                if a.iter().any(|x| !x.is_finite()) {
                    return Err(nan(self));
                }
                if !(3..=4).contains(&a.len()) || s.ty == SocketType::Float {
                    return Err(self.error(node, format!("input '{id}': expected a number, got {} numbers", a.len())));
                }
                Ok(Value::Reg(self.konst(Vec3::new(a[0], a[1], a[2]))))
            }
            Some(InputDesc::Spectrum { spectrum }) => {
                if s.ty != SocketType::Color {
                    return Err(self.error(node, format!("input '{id}': a spectrum needs a colour socket")));
                }
                Ok(Value::Spectrum(spectrum.clone()))
            }
            Some(InputDesc::Ior { ior }) => {
                if !id.contains("IOR") {
                    return Err(self.error(node, format!("input '{id}': an IOR model needs an IOR socket")));
                }
                Ok(Value::Ior(ior.clone()))
            }
            Some(InputDesc::Link { link }) => {
                let (from, out) = (link.0, link.1.clone());
                if s.ty == SocketType::Shader {
                    return Err(self.error(node, format!("input '{id}' is a shader socket; link it through closures")));
                }
                let (r, ty) = self.output(node, from, &out)?;
                Ok(Value::Reg(self.convert(r, ty, s.ty)))
            }
        }
    }

    /// Input `id` as a register; a spectral constant there is an error.
    pub fn input_reg(&mut self, node: usize, id: &str) -> Result<Reg> {
        match self.input(node, id)? {
            Value::Reg(r) => Ok(r),
            _ => Err(self.error(node, format!("input '{id}': a spectrum or IOR model is only accepted on a closure"))),
        }
    }

    fn convert(&mut self, r: Reg, from: SocketType, to: SocketType) -> Reg {
        use SocketType::*;
        let c = match (from, to) {
            (Color, Float) => Convert::ColorToFloat,
            (Vector, Float) => Convert::VectorToFloat,
            (Float, Color | Vector) => Convert::FloatToVec,
            _ => return r,
        };
        self.emit(Kernel::Convert(c), vec![r], 1)[0]
    }

    /// Output `out` of node `from`, read by node `by`.
    fn output(&mut self, by: usize, from: usize, out: &str) -> Result<(Reg, SocketType)> {
        if from >= self.nodes.len() {
            return Err(
                self.error(by, format!("links to node {from}, but the material has {} nodes", self.nodes.len()))
            );
        }
        let kind = self.nodes[from].kind.as_str();
        let Some(spec) = sockets::spec(kind) else {
            self.warn(from, "is not supported; its outputs read 0");
            return Ok((self.konst(Vec3::ZERO), SocketType::Vector));
        };
        let (k, ty) = spec.output(out).ok_or_else(|| {
            let known: Vec<&str> = spec.outputs.iter().map(|o| o.0).collect();
            self.error(from, format!("has no output '{out}' (it has {})", known.join(", ")))
        })?;
        if ty == SocketType::Shader {
            return Err(
                self.error(by, format!("reads the shader output of node '{}' as a value", self.nodes[from].name))
            );
        }
        let regs = self.node_outputs(from)?;
        Ok((regs[k], ty))
    }

    fn node_outputs(&mut self, node: usize) -> Result<Vec<Reg>> {
        match &self.state[node] {
            State::Done(r) => return Ok(r.clone()),
            State::Busy => {
                let start = self.stack.iter().position(|&n| n == node).unwrap_or(0);
                let names: Vec<String> =
                    self.stack[start..].iter().map(|&n| format!("'{}'", self.nodes[n].name)).collect();
                return Err(Error::object(
                    "material",
                    self.material,
                    format!("node cycle: {} → '{}'", names.join(" → "), self.nodes[node].name),
                ));
            }
            State::Todo => {}
        }
        self.state[node] = State::Busy;
        self.stack.push(node);
        let regs = self.compile_node(node)?;
        self.stack.pop();
        self.state[node] = State::Done(regs.clone());
        Ok(regs)
    }

    fn compile_node(&mut self, node: usize) -> Result<Vec<Reg>> {
        self.check_inputs(node)?;
        let n = &self.nodes[node];
        let kind = n.kind.as_str();
        if is_shader_node(kind) {
            return Err(self.error(node, "is a closure; it cannot be read as a value"));
        }
        let spec = sockets::spec(kind).expect("checked by output()");
        let p = Props { map: &n.props, material: self.material, node: &n.name };
        let number = |key: &str, default: f32| -> Result<f32> {
            match p.get(key) {
                None => Ok(default),
                Some(v) => v
                    .as_f64()
                    .map(|x| x as f32)
                    .filter(|x| x.is_finite())
                    .ok_or_else(|| p.error(format!("property '{key}' must be a finite number, got {v}"))),
            }
        };
        // Nodes that are constants.
        match kind {
            "ShaderNodeValue" => {
                let v = number("value", 0.5)?;
                return Ok(vec![self.konst(Vec3::new(v, 0.0, 0.0))]);
            }
            "ShaderNodeRGB" => {
                let c = match p.get("color") {
                    None => Vec3::splat(0.5),
                    Some(v) => {
                        let a: Vec<f32> =
                            serde_json::from_value(v.clone()).map_err(|e| p.error(format!("property 'color': {e}")))?;
                        if a.len() < 3 || a.iter().any(|x| !x.is_finite()) {
                            return Err(p.error("property 'color' must be 3 or 4 finite numbers"));
                        }
                        Vec3::new(a[0], a[1], a[2])
                    }
                };
                return Ok(vec![self.konst(c)]);
            }
            _ => {}
        }
        let kernel = match kind {
            "ShaderNodeMath" => Kernel::Math(Math::parse(&p)?),
            "ShaderNodeVectorMath" => Kernel::VectorMath(VectorMath::parse(&p)?),
            "ShaderNodeClamp" => Kernel::Clamp(Clamp::parse(&p)?),
            "ShaderNodeMapRange" => Kernel::MapRange(MapRange::parse(&p)?),
            "ShaderNodeMix" => {
                if p.string("data_type")? == Some("ROTATION") {
                    return Err(p.error("Mix of rotations is not a shading operation"));
                }
                Kernel::Mix(Mix::parse(&p)?)
            }
            "ShaderNodeHueSaturation" => Kernel::Color(ColorOp::HueSaturation),
            "ShaderNodeInvert" => Kernel::Color(ColorOp::Invert),
            "ShaderNodeGamma" => Kernel::Color(ColorOp::Gamma),
            "ShaderNodeBrightContrast" => Kernel::Color(ColorOp::BrightContrast),
            "ShaderNodeRGBToBW" => Kernel::Color(ColorOp::RgbToBw),
            "ShaderNodeSeparateColor" => Kernel::Color(ColorOp::Separate(color::color_mode(&p)?)),
            "ShaderNodeCombineColor" => Kernel::Color(ColorOp::Combine(color::color_mode(&p)?)),
            "ShaderNodeSeparateXYZ" => Kernel::Color(ColorOp::SeparateXyz),
            "ShaderNodeCombineXYZ" => Kernel::Color(ColorOp::CombineXyz),
            "ShaderNodeBlackbody" => Kernel::Color(ColorOp::Blackbody),
            "ShaderNodeWavelength" => Kernel::Color(ColorOp::Wavelength),
            "ShaderNodeValToRGB" => {
                let (ramp, approx) = ColorRamp::parse(&p)?;
                if let Some(a) = approx {
                    self.warn(node, format!("{a} is approximated"));
                }
                Kernel::Ramp(Box::new(ramp))
            }
            "ShaderNodeRGBCurve" => Kernel::Curves(Box::new(Curves::parse(&p, CurvesKind::Rgb)?)),
            "ShaderNodeVectorCurve" => Kernel::Curves(Box::new(Curves::parse(&p, CurvesKind::Vector)?)),
            "ShaderNodeFloatCurve" => Kernel::Curves(Box::new(Curves::parse(&p, CurvesKind::Float)?)),
            "ShaderNodeTexCoord" => Kernel::Input(Input::TexCoord),
            "ShaderNodeUVMap" => {
                let slot = match p.string("uv_map")? {
                    None | Some("") => None,
                    Some(name) => Some(self.attribute(node, AttributeRequest::Uv(name.to_string()))?),
                };
                Kernel::Input(Input::UvMap(slot))
            }
            "ShaderNodeNewGeometry" => {
                self.warn(node, "Pointiness reads 0.5 and Random Per Island 0 (not computed)");
                Kernel::Input(Input::Geometry)
            }
            "ShaderNodeVertexColor" => {
                let name = p.string("layer_name")?.unwrap_or("").to_string();
                Kernel::Input(Input::ColorAttribute(self.attribute(node, AttributeRequest::Color(name))?))
            }
            "ShaderNodeAttribute" => {
                let ty = p.string("attribute_type")?.unwrap_or("GEOMETRY");
                if ty != "GEOMETRY" {
                    self.warn(node, format!("attribute_type {ty} is not supported; reads 0"));
                }
                let name = p.string("attribute_name")?.unwrap_or("").to_string();
                Kernel::Input(Input::Attribute(self.attribute(node, AttributeRequest::Generic(name))?))
            }
            "ShaderNodeTangent" => {
                // Cycles' svm_node_tangent: radial about an object axis, or the UV map's
                // tangent (the mesh's tangents, as the Normal Map node reads them).
                let uv = p.enumeration("direction_type", &[("RADIAL", false), ("UV_MAP", true)], false)?;
                let axis = p.enumeration("axis", &[("X", 0u8), ("Y", 1), ("Z", 2)], 2)?;
                let slot = match p.string("uv_map")? {
                    Some(name) if uv && !name.is_empty() => {
                        Some(self.attribute(node, AttributeRequest::Tangent(name.to_string()))?)
                    }
                    _ => None,
                };
                Kernel::Input(Input::TangentNode { uv_map: uv, axis, slot })
            }
            "ShaderNodeObjectInfo" => Kernel::Input(Input::ObjectInfo),
            "ShaderNodeFresnel" => Kernel::Input(Input::Fresnel),
            "ShaderNodeLayerWeight" => Kernel::Input(Input::LayerWeight),
            "ShaderNodeMapping" => {
                use MappingType::*;
                let t = p.enumeration(
                    "vector_type",
                    &[("POINT", Point), ("TEXTURE", Texture), ("VECTOR", Vector), ("NORMAL", Normal)],
                    Point,
                )?;
                Kernel::Vector(VectorOp::Mapping(t))
            }
            "ShaderNodeNormalMap" => {
                use NormalMapSpace::*;
                let s = p.enumeration(
                    "space",
                    &[
                        ("TANGENT", Tangent),
                        ("OBJECT", Object),
                        ("WORLD", World),
                        ("BLENDER_OBJECT", BlenderObject),
                        ("BLENDER_WORLD", BlenderWorld),
                    ],
                    Tangent,
                )?;
                // Tangent space reads the tangents of its UV map (the mesh's default ones
                // when it names none).
                let slot = match p.string("uv_map")? {
                    Some(name) if s == Tangent && !name.is_empty() => {
                        Some(self.attribute(node, AttributeRequest::Tangent(name.to_string()))?)
                    }
                    _ => None,
                };
                Kernel::Vector(VectorOp::NormalMap(s, slot))
            }
            "ShaderNodeBump" => {
                // The height's derivative from the height program at offset points
                // (vector::Bump); a constant height leaves the Normal input as it is.
                let invert = p.boolean("invert", false)?;
                let strength = self.input_reg(node, "Strength")?;
                let distance = self.input_reg(node, "Distance")?;
                let height = self.input_reg(node, "Height")?;
                let normal = self.input_reg(node, "Normal")?;
                if self.const_of(height).is_some() {
                    return Ok(vec![normal]);
                }
                self.attribute(node, AttributeRequest::Differentials)?;
                let bump = Bump { height: self.program.pruned_for(height), reg: height, invert };
                return Ok(self.emit(Kernel::Bump(Box::new(bump)), vec![strength, distance, normal], 1));
            }
            "ShaderNodeTexImage" | "ShaderNodeTexEnvironment" => Kernel::Image(Box::new(self.image(node, &p)?)),
            k if k.starts_with("ShaderNodeTex") => {
                let props = serde_json::Value::Object(n.props.clone()).to_string();
                let proc = Procedural::from_json(k, &props).map_err(|e| p.error(e))?;
                let names = proc.input_names();
                let slots = spec
                    .inputs
                    .iter()
                    .map(|s| match s.id {
                        "Vector" => ProceduralSlot::Vector,
                        "W" => ProceduralSlot::W,
                        id => names
                            .iter()
                            .position(|(name, _)| *name == id)
                            .map_or(ProceduralSlot::W, |j| ProceduralSlot::Input(j, names[j].1)),
                    })
                    .collect();
                Kernel::Procedural(Box::new(ProceduralNode { node: proc, slots }))
            }
            _ => {
                self.warn(node, "is not supported; its outputs read 0");
                return Ok(spec.outputs.iter().map(|_| self.konst(Vec3::ZERO)).collect());
            }
        };
        let mut ins = Vec::with_capacity(spec.inputs.len());
        for s in spec.inputs {
            if s.id == "Weight" {
                continue;
            }
            ins.push(self.input_reg(node, s.id)?);
        }
        Ok(self.emit(kernel, ins, spec.outputs.len()))
    }

    fn image(&mut self, node: usize, p: &Props) -> Result<Image> {
        let t = p.index("texture")?.ok_or_else(|| p.error("has no 'texture' (an index into the scene's textures)"))?;
        let texture =
            self.textures.get(t).cloned().ok_or_else(|| {
                p.error(format!("texture {t} does not exist (the scene has {})", self.textures.len()))
            })?;
        let environment = self.nodes[node].kind == "ShaderNodeTexEnvironment";
        let interpolation = match p.string("interpolation")?.unwrap_or("Linear") {
            "Closest" => Interpolation::Closest,
            "Linear" => Interpolation::Linear,
            "Cubic" | "Smart" => Interpolation::Cubic,
            other => {
                self.warn(node, format!("{other} interpolation is evaluated as Linear"));
                Interpolation::Linear
            }
        };
        let (wrap, mirror) = match p.string("extension")?.unwrap_or("REPEAT") {
            "REPEAT" => (Wrap::Repeat, false),
            "EXTEND" => (Wrap::Extend, false),
            "CLIP" => (Wrap::Clip, false),
            "MIRROR" => (Wrap::Extend, true),
            other => return Err(p.error(format!("unknown extension '{other}'"))),
        };
        let projection = p.string("projection")?.unwrap_or(if environment { "EQUIRECTANGULAR" } else { "FLAT" });
        let equirectangular = match projection {
            "FLAT" => false,
            "EQUIRECTANGULAR" => true,
            other => {
                self.warn(
                    node,
                    format!(
                        "projection {other} is evaluated as {}",
                        if environment { "EQUIRECTANGULAR" } else { "FLAT" }
                    ),
                );
                environment
            }
        };
        // "associated": the exporter's texture holds colour × alpha as Cycles loads it;
        // the Color output then un-associates when the node's Alpha output is read.
        let alpha_read = self.nodes.iter().any(|n| {
            n.inputs.values().any(|i| matches!(i, InputDesc::Link { link } if link.0 == node && link.1 == "Alpha"))
        });
        let unassociate = !environment && alpha_read && p.boolean("associated", false)?;
        Ok(Image { texture, wrap, mirror, interpolation, equirectangular, unassociate })
    }
}
