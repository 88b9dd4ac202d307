//! Shading graphs: a material's inputs driven by Blender's node vocabulary
//! (docs/shading.md). A graph is compiled once at scene build into a flat program of
//! typed ops ([`program`]); constants fold away ([`fold`]), so a graph that is constant
//! becomes the same fixed material a `BsdfDesc` describes ([`closure`]).

pub mod closure;
pub mod color;
pub mod compile;
pub mod desc;
pub mod fold;
pub mod input;
pub mod math;
pub mod program;
pub mod props;
pub mod sockets;
pub mod texture;
pub mod vector;

pub use desc::{GraphDesc, InputDesc, NodeDesc, OutputDesc};
pub use program::{Program, ShadingPoint};

use crate::material::Texture;
use crate::Result;
use std::sync::Arc;

/// A compiled material graph: its surface as a fixed description (when constant) and
/// the warnings compiling it produced.
pub struct CompiledMaterial {
    pub surface: closure::Lowered,
    pub program: Program,
    pub warnings: Vec<String>,
}

/// Compiles material `name`'s graph against the scene's textures.
pub fn compile_material(name: &str, graph: &GraphDesc, textures: &[Arc<Texture>]) -> Result<CompiledMaterial> {
    let mut c = compile::Compiler::new(name, &graph.nodes, textures);
    if graph.output.volume.is_some() || graph.output.displacement.is_some() {
        c.warnings.push(format!("material '{name}': volume and displacement outputs are not supported yet (ignored)"));
    }
    let surface = closure::lower_surface(&mut c, graph.output.surface.as_ref())?;
    Ok(CompiledMaterial { surface, program: c.program, warnings: c.warnings })
}

#[cfg(test)]
mod tests;
