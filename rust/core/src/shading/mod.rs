//! Shading graphs: a material's inputs driven by Blender's node vocabulary
//! (docs/shading.md). A graph is compiled once at scene build into a flat program of
//! typed ops ([`program`]); constants fold away ([`fold`]), so a graph that is constant
//! becomes the same fixed material a `BsdfDesc` describes ([`closure`]).

pub mod bsdf;
pub mod closure;
pub mod color;
pub mod compile;
pub mod desc;
pub mod emission;
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

/// A compiled material graph: its closures' template, the program that feeds them,
/// its (constant) emission and the warnings compiling it produced.
pub struct CompiledMaterial {
    pub template: closure::Template,
    pub emission: Option<crate::spectrum::SpectrumDesc>,
    /// A top-level Transparent BSDF split off the template: (pass probability, tint).
    pub transparency: Option<(closure::PassProbability, crate::spectrum::SpectrumDesc)>,
    /// An emission that varies over the surface: RGB terms over the program's
    /// registers, evaluated per hit (`emission::GraphEmission`).
    pub varying_emission: Option<Vec<closure::EmissionTerm>>,
    /// The register of the first linked Normal input (Normal Map, Bump, any vector):
    /// the Normal pass at each hit, in world space facing the ray's side. When set,
    /// every closure is shaded about its own normal (`closure::Orient`).
    pub normal: Option<program::Reg>,
    pub program: Program,
    pub warnings: Vec<String>,
}

impl CompiledMaterial {
    /// The fixed description the graph equals, when every closure input is constant.
    pub fn constant_surface(&self) -> Option<crate::scene::BsdfDesc> {
        let init = &self.program.init;
        self.template.is_constant().then(|| self.template.instantiate(&|r| init[r as usize], None))
    }
}

/// Compiles material `name`'s graph against the scene's textures.
pub fn compile_material(name: &str, graph: &GraphDesc, textures: &[Arc<Texture>]) -> Result<CompiledMaterial> {
    let mut c = compile::Compiler::new(name, &graph.nodes, textures);
    if graph.output.volume.is_some() || graph.output.displacement.is_some() {
        c.warnings.push(format!("material '{name}': volume and displacement outputs are not supported yet (ignored)"));
    }
    let (mut template, emission, varying_emission, normal) =
        closure::lower_surface(&mut c, graph.output.surface.as_ref())?;
    let mut transparency = None;
    if let Some((p, color, rest)) = template.split_transparent() {
        transparency = Some((p, color));
        template = rest;
    }
    if template.holdout_under_view_factor() {
        c.warnings.push(format!(
            "material '{name}': a Holdout under a Mix Shader whose Fac is a Fresnel or Layer Weight node holds \
             out with the Mix's weight 0.5, not the view-dependent factor"
        ));
    }
    if template.has_transparent() {
        c.warnings.push(format!(
            "material '{name}': a Transparent BSDF that is not the material's top closure (or one side of a \
             constant Mix Shader there) is not supported yet; it reflects nothing"
        ));
    }
    Ok(CompiledMaterial {
        template,
        emission,
        varying_emission,
        normal,
        transparency,
        program: c.program,
        warnings: c.warnings,
    })
}

#[cfg(test)]
mod tests;
