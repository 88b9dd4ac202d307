//! The JSON form of a node graph (docs/shading.md, "In the scene description").

use crate::material::IorDesc;
use crate::spectrum::SpectrumDesc;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// One node: Blender's idname, its name (for messages), properties and inputs.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NodeDesc {
    #[serde(rename = "type")]
    pub kind: String,
    #[serde(default)]
    pub name: String,
    #[serde(default)]
    pub props: serde_json::Map<String, serde_json::Value>,
    /// Input socket identifier → value or link; absent inputs take Blender's default.
    #[serde(default)]
    pub inputs: BTreeMap<String, InputDesc>,
}

/// The value of an input socket.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(untagged)]
pub enum InputDesc {
    Number(f32),
    /// A vector or colour (3 or 4 numbers; a colour's alpha is ignored).
    Array(Vec<f32>),
    /// The output `.1` of node `.0`.
    Link {
        link: (usize, String),
    },
    /// Polychrome's spectral extension: a spectrum on a colour input.
    Spectrum {
        spectrum: SpectrumDesc,
    },
    /// An index of refraction model on an IOR input.
    Ior {
        ior: IorDesc,
    },
}

/// The material's outputs: node index and output identifier of each closure.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputDesc {
    #[serde(default)]
    pub surface: Option<(usize, String)>,
    #[serde(default)]
    pub volume: Option<(usize, String)>,
    #[serde(default)]
    pub displacement: Option<(usize, String)>,
}

/// A material's graph.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GraphDesc {
    pub nodes: Vec<NodeDesc>,
    pub output: OutputDesc,
}
