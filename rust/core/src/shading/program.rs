//! A material's compiled program: a flat list of typed ops over one register file (in
//! the spirit of Cycles' SVM), evaluated once per hit from a [`ShadingPoint`].
//!
//! Every register holds a `Vec3`; a float register uses `.x`. Which registers are
//! floats, colours or vectors is fixed by the compiler (`compile.rs`), so no op ever
//! converts at run time except through an explicit [`Kernel::Convert`].

use super::{color, input, math, texture, vector};
use glam::{Mat3, Vec2, Vec3};

pub type Reg = u32;

/// The per-hit inputs a program reads. World-space unless named otherwise.
#[derive(Clone, Copy, Debug)]
pub struct ShadingPoint {
    pub position: Vec3,
    /// Object-space position (Texture Coordinate › Object).
    pub object_position: Vec3,
    /// Generated coordinates: the object-space position in the mesh's bounding box, 0..1.
    pub generated: Vec3,
    /// Shading normal, facing the incoming ray's side as Cycles' `sd->N`.
    pub normal: Vec3,
    /// Geometric normal (Geometry › True Normal).
    pub true_normal: Vec3,
    /// Unit tangent (MikkTSpace when the mesh has one) and its bitangent sign.
    pub tangent: Vec3,
    pub tangent_sign: f32,
    /// Unit vector from the point towards the ray's origin (Cycles' `sd->I`).
    pub incoming: Vec3,
    pub backfacing: bool,
    /// Default UV map.
    pub uv: Vec2,
    /// Barycentrics (Geometry › Parametric).
    pub parametric: Vec2,
    /// Camera-space position and window coordinates (Texture Coordinate).
    pub camera: Vec3,
    pub window: Vec3,
    /// Object → world for normals (Normal Map object space, Texture Coordinate › Normal).
    pub normal_to_world: Mat3,
    pub object_location: Vec3,
    pub object_color: [f32; 4],
    pub object_index: f32,
    pub material_index: f32,
    pub object_random: f32,
    /// The values of the program's attribute slots (`Program::attributes`) at this hit,
    /// RGBA (UV maps in .xy, scalars in .x).
    pub attributes: [[f32; 4]; MAX_ATTRIBUTES],
    /// Two small steps across the surface (filled only for a program that requests
    /// [`AttributeRequest::Differentials`], the Bump node's): how every interpolated
    /// quantity above changes when the point moves by a step within its triangle.
    pub diff: [Delta; 2],
}

/// The change of a shading point's interpolated data over one step across the surface
/// (`ShadingPoint::diff`), in the same spaces as the fields it offsets.
#[derive(Clone, Copy, Debug, Default)]
pub struct Delta {
    pub position: Vec3,
    pub object_position: Vec3,
    pub generated: Vec3,
    pub uv: Vec2,
    pub attributes: [[f32; 4]; MAX_ATTRIBUTES],
}

impl ShadingPoint {
    /// The tangent (world space, orthogonal to the shading normal) and bitangent sign a
    /// Normal Map or Tangent node reads: its UV map's tangent set in attribute slot
    /// `slot`, else (no slot, or the mesh lacks that set) the mesh's default tangents.
    pub fn tangent_of(&self, slot: Option<usize>) -> (Vec3, f32) {
        let Some(a) = slot.and_then(|k| self.attributes.get(k)) else { return (self.tangent, self.tangent_sign) };
        let t = Vec3::new(a[0], a[1], a[2]);
        if !(t.length_squared() > 1e-12) {
            return (self.tangent, self.tangent_sign);
        }
        // Object → world for a direction is L = m⁻ᵀ (m = normal_to_world = L⁻ᵀ).
        let w = self.normal_to_world.inverse().transpose() * t;
        match (w - self.normal * self.normal.dot(w)).try_normalize() {
            Some(w) => (w, if a[3] < 0.0 { -1.0 } else { 1.0 }),
            None => (self.tangent, self.tangent_sign),
        }
    }

    /// The shading point `s` steps `diff[k]` away (the Bump node's offset evaluations,
    /// in the spirit of Cycles' `svm_node_tex_coord_bump_dx`/`_dy`, which offset the
    /// point by its ray differential).
    pub fn offset(&self, k: usize, s: f32) -> ShadingPoint {
        let d = &self.diff[k];
        let mut o = *self;
        o.position += s * d.position;
        o.object_position += s * d.object_position;
        o.generated += s * d.generated;
        o.uv += s * d.uv;
        for (a, da) in o.attributes.iter_mut().zip(&d.attributes) {
            for (x, dx) in a.iter_mut().zip(da) {
                *x += s * dx;
            }
        }
        o
    }
}

/// Most per-vertex attributes one material reads.
pub const MAX_ATTRIBUTES: usize = 8;

impl Default for ShadingPoint {
    fn default() -> Self {
        Self {
            position: Vec3::ZERO,
            object_position: Vec3::ZERO,
            generated: Vec3::ZERO,
            normal: Vec3::Z,
            true_normal: Vec3::Z,
            tangent: Vec3::X,
            tangent_sign: 1.0,
            incoming: Vec3::Z,
            backfacing: false,
            uv: Vec2::ZERO,
            parametric: Vec2::ZERO,
            camera: Vec3::ZERO,
            window: Vec3::ZERO,
            normal_to_world: Mat3::IDENTITY,
            object_location: Vec3::ZERO,
            object_color: [1.0; 4],
            object_index: 0.0,
            material_index: 0.0,
            object_random: 0.0,
            attributes: [[0.0; 4]; MAX_ATTRIBUTES],
            diff: [Delta::default(); 2],
        }
    }
}

/// Which per-vertex data a program reads (slots of `ShadingPoint::attributes`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum AttributeRequest {
    /// A named UV map (UV Map, Normal Map tangent space).
    Uv(String),
    /// A colour attribute (Color Attribute node; "" is the active one).
    Color(String),
    /// A generic attribute (Attribute node).
    Generic(String),
    /// The tangents of a named UV map (Normal Map and Tangent node): object-space xyz and
    /// the bitangent sign; a mesh without them reads 0, and the op uses the mesh's
    /// default tangents instead ([`ShadingPoint::tangent_of`]).
    Tangent(String),
    /// Not mesh data: asks the walk to fill `ShadingPoint::diff` (Bump). Its slot reads 0.
    Differentials,
}

/// Value conversions Blender applies on links between sockets of different types.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Convert {
    /// Colour → float: Rec.709 luminance.
    ColorToFloat,
    /// Vector → float: the mean of the components.
    VectorToFloat,
    /// Float → colour or vector: grey.
    FloatToVec,
}

/// One node's computation.
#[derive(Clone, Debug)]
pub enum Kernel {
    Convert(Convert),
    Math(math::Math),
    VectorMath(math::VectorMath),
    Clamp(math::Clamp),
    MapRange(math::MapRange),
    Mix(color::Mix),
    Color(color::ColorOp),
    Ramp(Box<color::ColorRamp>),
    Curves(Box<color::Curves>),
    Input(input::Input),
    Vector(vector::VectorOp),
    Image(Box<texture::Image>),
    Procedural(Box<texture::ProceduralNode>),
    Bump(Box<vector::Bump>),
}

impl Kernel {
    /// Reads the shading point (cannot be folded even with constant inputs).
    pub fn varying(&self) -> bool {
        match self {
            Kernel::Input(_) => true,
            Kernel::Vector(v) => v.varying(),
            Kernel::Bump(_) => true,
            _ => false,
        }
    }

    pub fn eval(&self, i: &[Vec3], o: &mut [Vec3], sp: &ShadingPoint) {
        match self {
            Kernel::Convert(c) => {
                o[0] = match c {
                    Convert::ColorToFloat => Vec3::new(color::gray(i[0]), 0.0, 0.0),
                    Convert::VectorToFloat => Vec3::new((i[0].x + i[0].y + i[0].z) / 3.0, 0.0, 0.0),
                    Convert::FloatToVec => Vec3::splat(i[0].x),
                }
            }
            Kernel::Math(k) => k.eval(i, o),
            Kernel::VectorMath(k) => k.eval(i, o),
            Kernel::Clamp(k) => k.eval(i, o),
            Kernel::MapRange(k) => k.eval(i, o),
            Kernel::Mix(k) => k.eval(i, o),
            Kernel::Color(k) => k.eval(i, o),
            Kernel::Ramp(k) => k.eval(i, o),
            Kernel::Curves(k) => k.eval(i, o),
            Kernel::Input(k) => k.eval(i, o, sp),
            Kernel::Vector(k) => k.eval(i, o, sp),
            Kernel::Image(k) => k.eval(i, o),
            Kernel::Procedural(k) => k.eval(i, o),
            Kernel::Bump(k) => k.eval(i, o, sp),
        }
    }
}

/// Most inputs and outputs of any node kernel (Map Range has 12 inputs).
pub const MAX_SOCKETS: usize = 16;

/// A kernel with its input and output registers (`NONE` for outputs nobody reads).
#[derive(Clone, Debug)]
pub struct Instr {
    pub kernel: Kernel,
    pub ins: Vec<Reg>,
    pub outs: Vec<Reg>,
}

pub const NONE: Reg = Reg::MAX;

/// Runs `kernel` on `ins`, replacing any non-finite result component by 0 (the NaN rule
/// of docs/shading.md).
pub fn run_kernel(kernel: &Kernel, ins: &[Vec3], n_out: usize, sp: &ShadingPoint) -> [Vec3; MAX_SOCKETS] {
    let mut o = [Vec3::ZERO; MAX_SOCKETS];
    kernel.eval(ins, &mut o[..n_out.max(1)], sp);
    for v in &mut o[..n_out] {
        *v = Vec3::new(finite(v.x), finite(v.y), finite(v.z));
    }
    o
}

#[inline]
fn finite(x: f32) -> f32 {
    if x.is_finite() {
        x
    } else {
        0.0
    }
}

/// The compiled program: the initial register file (constants in place) and the ops.
#[derive(Clone, Debug, Default)]
pub struct Program {
    pub init: Vec<Vec3>,
    pub ops: Vec<Instr>,
    /// The mesh data the program reads, by slot.
    pub attributes: Vec<AttributeRequest>,
}

impl Program {
    /// Nothing to run: every parameter is a constant.
    pub fn is_constant(&self) -> bool {
        self.ops.is_empty()
    }

    /// The program reduced to the ops that register `reg` depends on (e.g. a
    /// material's alpha, evaluated before any shading: a cut-out that passes costs only
    /// its alpha's ops). Register numbers and attribute slots are unchanged.
    pub fn pruned_for(&self, reg: Reg) -> Program {
        let mut live = vec![false; self.init.len()];
        if let Some(l) = live.get_mut(reg as usize) {
            *l = true;
        }
        let mut keep = vec![false; self.ops.len()];
        for (k, op) in self.ops.iter().enumerate().rev() {
            if op.outs.iter().any(|&r| r != NONE && live[r as usize]) {
                keep[k] = true;
                for &r in &op.ins {
                    live[r as usize] = true;
                }
            }
        }
        let ops = self.ops.iter().zip(keep).filter(|(_, k)| *k).map(|(op, _)| op.clone()).collect();
        Program { init: self.init.clone(), ops, attributes: self.attributes.clone() }
    }

    /// Runs the program at `sp` into `regs` (resized to the register file; reuse it
    /// between hits so no allocation happens per hit).
    pub fn run(&self, sp: &ShadingPoint, regs: &mut Vec<Vec3>) {
        regs.clear();
        regs.extend_from_slice(&self.init);
        let mut ins = [Vec3::ZERO; MAX_SOCKETS];
        for op in &self.ops {
            for (k, &r) in op.ins.iter().enumerate() {
                ins[k] = regs[r as usize];
            }
            let o = run_kernel(&op.kernel, &ins[..op.ins.len()], op.outs.len(), sp);
            for (k, &r) in op.outs.iter().enumerate() {
                if r != NONE {
                    regs[r as usize] = o[k];
                }
            }
        }
    }
}
