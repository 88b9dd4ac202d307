//! Each supported node's sockets: Blender 4.5's identifiers, types and defaults, dumped
//! from bpy 4.5 (`node.inputs[i].identifier/type/default_value`), so an input the front
//! end leaves out takes exactly Blender's default.

/// A socket's value type. Integer and boolean sockets are floats; rotation is a vector.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SocketType {
    Float,
    Vector,
    Color,
    Shader,
}

pub struct InputSpec {
    pub id: &'static str,
    pub ty: SocketType,
    /// Blender's default (floats in `.0[0]`).
    pub default: [f32; 3],
}

pub struct NodeSpec {
    pub idname: &'static str,
    pub inputs: &'static [InputSpec],
    pub outputs: &'static [(&'static str, SocketType)],
}

use SocketType::*;

const fn i(id: &'static str, ty: SocketType, default: [f32; 3]) -> InputSpec {
    InputSpec { id, ty, default }
}

pub static NODES: &[NodeSpec] = &[
    NodeSpec {
        idname: "ShaderNodeMath",
        inputs: &[
            i("Value", Float, [0.5, 0.0, 0.0]),
            i("Value_001", Float, [0.5, 0.0, 0.0]),
            i("Value_002", Float, [0.5, 0.0, 0.0]),
        ],
        outputs: &[("Value", Float)],
    },
    NodeSpec {
        idname: "ShaderNodeVectorMath",
        inputs: &[
            i("Vector", Vector, [0.0, 0.0, 0.0]),
            i("Vector_001", Vector, [0.0, 0.0, 0.0]),
            i("Vector_002", Vector, [0.0, 0.0, 0.0]),
            i("Scale", Float, [1.0, 0.0, 0.0]),
        ],
        outputs: &[("Vector", Vector), ("Value", Float)],
    },
    NodeSpec {
        idname: "ShaderNodeClamp",
        inputs: &[
            i("Value", Float, [1.0, 0.0, 0.0]),
            i("Min", Float, [0.0, 0.0, 0.0]),
            i("Max", Float, [1.0, 0.0, 0.0]),
        ],
        outputs: &[("Result", Float)],
    },
    NodeSpec {
        idname: "ShaderNodeMapRange",
        inputs: &[
            i("Value", Float, [1.0, 0.0, 0.0]),
            i("From Min", Float, [0.0, 0.0, 0.0]),
            i("From Max", Float, [1.0, 0.0, 0.0]),
            i("To Min", Float, [0.0, 0.0, 0.0]),
            i("To Max", Float, [1.0, 0.0, 0.0]),
            i("Steps", Float, [4.0, 0.0, 0.0]),
            i("Vector", Vector, [0.0, 0.0, 0.0]),
            i("From_Min_FLOAT3", Vector, [0.0, 0.0, 0.0]),
            i("From_Max_FLOAT3", Vector, [1.0, 1.0, 1.0]),
            i("To_Min_FLOAT3", Vector, [0.0, 0.0, 0.0]),
            i("To_Max_FLOAT3", Vector, [1.0, 1.0, 1.0]),
            i("Steps_FLOAT3", Vector, [4.0, 4.0, 4.0]),
        ],
        outputs: &[("Result", Float), ("Vector", Vector)],
    },
    NodeSpec {
        idname: "ShaderNodeMix",
        inputs: &[
            i("Factor_Float", Float, [0.5, 0.0, 0.0]),
            i("Factor_Vector", Vector, [0.5, 0.5, 0.5]),
            i("A_Float", Float, [0.0, 0.0, 0.0]),
            i("B_Float", Float, [0.0, 0.0, 0.0]),
            i("A_Vector", Vector, [0.0, 0.0, 0.0]),
            i("B_Vector", Vector, [0.0, 0.0, 0.0]),
            i("A_Color", Color, [0.5, 0.5, 0.5]),
            i("B_Color", Color, [0.5, 0.5, 0.5]),
            i("A_Rotation", Vector, [0.0, 0.0, 0.0]),
            i("B_Rotation", Vector, [0.0, 0.0, 0.0]),
        ],
        outputs: &[
            ("Result_Float", Float),
            ("Result_Vector", Vector),
            ("Result_Color", Color),
            ("Result_Rotation", Vector),
        ],
    },
    NodeSpec {
        idname: "ShaderNodeHueSaturation",
        inputs: &[
            i("Hue", Float, [0.5, 0.0, 0.0]),
            i("Saturation", Float, [1.0, 0.0, 0.0]),
            i("Value", Float, [1.0, 0.0, 0.0]),
            i("Fac", Float, [1.0, 0.0, 0.0]),
            i("Color", Color, [0.8, 0.8, 0.8]),
        ],
        outputs: &[("Color", Color)],
    },
    NodeSpec {
        idname: "ShaderNodeInvert",
        inputs: &[i("Fac", Float, [1.0, 0.0, 0.0]), i("Color", Color, [0.0, 0.0, 0.0])],
        outputs: &[("Color", Color)],
    },
    NodeSpec {
        idname: "ShaderNodeGamma",
        inputs: &[i("Color", Color, [1.0, 1.0, 1.0]), i("Gamma", Float, [1.0, 0.0, 0.0])],
        outputs: &[("Color", Color)],
    },
    NodeSpec {
        idname: "ShaderNodeBrightContrast",
        inputs: &[
            i("Color", Color, [1.0, 1.0, 1.0]),
            i("Bright", Float, [0.0, 0.0, 0.0]),
            i("Contrast", Float, [0.0, 0.0, 0.0]),
        ],
        outputs: &[("Color", Color)],
    },
    NodeSpec { idname: "ShaderNodeRGBToBW", inputs: &[i("Color", Color, [0.5, 0.5, 0.5])], outputs: &[("Val", Float)] },
    NodeSpec {
        idname: "ShaderNodeSeparateColor",
        inputs: &[i("Color", Color, [0.8, 0.8, 0.8])],
        outputs: &[("Red", Float), ("Green", Float), ("Blue", Float)],
    },
    NodeSpec {
        idname: "ShaderNodeCombineColor",
        inputs: &[
            i("Red", Float, [0.0, 0.0, 0.0]),
            i("Green", Float, [0.0, 0.0, 0.0]),
            i("Blue", Float, [0.0, 0.0, 0.0]),
        ],
        outputs: &[("Color", Color)],
    },
    NodeSpec {
        idname: "ShaderNodeSeparateXYZ",
        inputs: &[i("Vector", Vector, [0.0, 0.0, 0.0])],
        outputs: &[("X", Float), ("Y", Float), ("Z", Float)],
    },
    NodeSpec {
        idname: "ShaderNodeCombineXYZ",
        inputs: &[i("X", Float, [0.0, 0.0, 0.0]), i("Y", Float, [0.0, 0.0, 0.0]), i("Z", Float, [0.0, 0.0, 0.0])],
        outputs: &[("Vector", Vector)],
    },
    NodeSpec {
        idname: "ShaderNodeValToRGB",
        inputs: &[i("Fac", Float, [0.5, 0.0, 0.0])],
        outputs: &[("Color", Color), ("Alpha", Float)],
    },
    NodeSpec {
        idname: "ShaderNodeRGBCurve",
        inputs: &[i("Fac", Float, [1.0, 0.0, 0.0]), i("Color", Color, [1.0, 1.0, 1.0])],
        outputs: &[("Color", Color)],
    },
    NodeSpec {
        idname: "ShaderNodeFloatCurve",
        inputs: &[i("Factor", Float, [1.0, 0.0, 0.0]), i("Value", Float, [1.0, 0.0, 0.0])],
        outputs: &[("Value", Float)],
    },
    NodeSpec {
        idname: "ShaderNodeVectorCurve",
        inputs: &[i("Fac", Float, [1.0, 0.0, 0.0]), i("Vector", Vector, [0.0, 0.0, 0.0])],
        outputs: &[("Vector", Vector)],
    },
    NodeSpec { idname: "ShaderNodeValue", inputs: &[], outputs: &[("Value", Float)] },
    NodeSpec { idname: "ShaderNodeRGB", inputs: &[], outputs: &[("Color", Color)] },
    NodeSpec {
        idname: "ShaderNodeTexCoord",
        inputs: &[],
        outputs: &[
            ("Generated", Vector),
            ("Normal", Vector),
            ("UV", Vector),
            ("Object", Vector),
            ("Camera", Vector),
            ("Window", Vector),
            ("Reflection", Vector),
        ],
    },
    NodeSpec { idname: "ShaderNodeUVMap", inputs: &[], outputs: &[("UV", Vector)] },
    NodeSpec { idname: "ShaderNodeTangent", inputs: &[], outputs: &[("Tangent", Vector)] },
    NodeSpec {
        idname: "ShaderNodeNewGeometry",
        inputs: &[],
        outputs: &[
            ("Position", Vector),
            ("Normal", Vector),
            ("Tangent", Vector),
            ("True Normal", Vector),
            ("Incoming", Vector),
            ("Parametric", Vector),
            ("Backfacing", Float),
            ("Pointiness", Float),
            ("Random Per Island", Float),
        ],
    },
    NodeSpec { idname: "ShaderNodeVertexColor", inputs: &[], outputs: &[("Color", Color), ("Alpha", Float)] },
    NodeSpec {
        idname: "ShaderNodeAttribute",
        inputs: &[],
        outputs: &[("Color", Color), ("Vector", Vector), ("Fac", Float), ("Alpha", Float)],
    },
    NodeSpec {
        idname: "ShaderNodeObjectInfo",
        inputs: &[],
        outputs: &[
            ("Location", Vector),
            ("Color", Color),
            ("Alpha", Float),
            ("Object Index", Float),
            ("Material Index", Float),
            ("Random", Float),
        ],
    },
    NodeSpec {
        idname: "ShaderNodeFresnel",
        inputs: &[i("IOR", Float, [1.5, 0.0, 0.0]), i("Normal", Vector, [0.0, 0.0, 0.0])],
        outputs: &[("Fac", Float)],
    },
    NodeSpec {
        idname: "ShaderNodeLayerWeight",
        inputs: &[i("Blend", Float, [0.5, 0.0, 0.0]), i("Normal", Vector, [0.0, 0.0, 0.0])],
        outputs: &[("Fresnel", Float), ("Facing", Float)],
    },
    NodeSpec {
        idname: "ShaderNodeWavelength",
        inputs: &[i("Wavelength", Float, [500.0, 0.0, 0.0])],
        outputs: &[("Color", Color)],
    },
    NodeSpec {
        idname: "ShaderNodeBlackbody",
        inputs: &[i("Temperature", Float, [1500.0, 0.0, 0.0])],
        outputs: &[("Color", Color)],
    },
    NodeSpec {
        idname: "ShaderNodeMapping",
        inputs: &[
            i("Vector", Vector, [0.0, 0.0, 0.0]),
            i("Location", Vector, [0.0, 0.0, 0.0]),
            i("Rotation", Vector, [0.0, 0.0, 0.0]),
            i("Scale", Vector, [1.0, 1.0, 1.0]),
        ],
        outputs: &[("Vector", Vector)],
    },
    NodeSpec {
        idname: "ShaderNodeNormalMap",
        inputs: &[i("Strength", Float, [1.0, 0.0, 0.0]), i("Color", Color, [0.5, 0.5, 1.0])],
        outputs: &[("Normal", Vector)],
    },
    NodeSpec {
        idname: "ShaderNodeBump",
        inputs: &[
            i("Strength", Float, [1.0, 0.0, 0.0]),
            i("Distance", Float, [0.001, 0.0, 0.0]),
            i("Filter Width", Float, [0.1, 0.0, 0.0]),
            i("Height", Float, [1.0, 0.0, 0.0]),
            i("Normal", Vector, [0.0, 0.0, 0.0]),
        ],
        outputs: &[("Normal", Vector)],
    },
    NodeSpec {
        idname: "ShaderNodeTexImage",
        inputs: &[i("Vector", Vector, [0.0, 0.0, 0.0])],
        outputs: &[("Color", Color), ("Alpha", Float)],
    },
    NodeSpec {
        idname: "ShaderNodeTexEnvironment",
        inputs: &[i("Vector", Vector, [0.0, 0.0, 0.0])],
        outputs: &[("Color", Color)],
    },
    NodeSpec {
        idname: "ShaderNodeTexNoise",
        inputs: &[
            i("Vector", Vector, [0.0, 0.0, 0.0]),
            i("W", Float, [0.0, 0.0, 0.0]),
            i("Scale", Float, [5.0, 0.0, 0.0]),
            i("Detail", Float, [2.0, 0.0, 0.0]),
            i("Roughness", Float, [0.5, 0.0, 0.0]),
            i("Lacunarity", Float, [2.0, 0.0, 0.0]),
            i("Offset", Float, [0.0, 0.0, 0.0]),
            i("Gain", Float, [1.0, 0.0, 0.0]),
            i("Distortion", Float, [0.0, 0.0, 0.0]),
        ],
        outputs: &[("Fac", Float), ("Color", Color)],
    },
    NodeSpec {
        idname: "ShaderNodeTexVoronoi",
        inputs: &[
            i("Vector", Vector, [0.0, 0.0, 0.0]),
            i("W", Float, [0.0, 0.0, 0.0]),
            i("Scale", Float, [5.0, 0.0, 0.0]),
            i("Detail", Float, [0.0, 0.0, 0.0]),
            i("Roughness", Float, [0.5, 0.0, 0.0]),
            i("Lacunarity", Float, [2.0, 0.0, 0.0]),
            i("Smoothness", Float, [1.0, 0.0, 0.0]),
            i("Exponent", Float, [0.5, 0.0, 0.0]),
            i("Randomness", Float, [1.0, 0.0, 0.0]),
        ],
        outputs: &[("Distance", Float), ("Color", Color), ("Position", Vector), ("W", Float), ("Radius", Float)],
    },
    NodeSpec {
        idname: "ShaderNodeTexChecker",
        inputs: &[
            i("Vector", Vector, [0.0, 0.0, 0.0]),
            i("Color1", Color, [0.8, 0.8, 0.8]),
            i("Color2", Color, [0.2, 0.2, 0.2]),
            i("Scale", Float, [5.0, 0.0, 0.0]),
        ],
        outputs: &[("Color", Color), ("Fac", Float)],
    },
    NodeSpec {
        idname: "ShaderNodeTexGradient",
        inputs: &[i("Vector", Vector, [0.0, 0.0, 0.0])],
        outputs: &[("Color", Color), ("Fac", Float)],
    },
    NodeSpec {
        idname: "ShaderNodeTexWave",
        inputs: &[
            i("Vector", Vector, [0.0, 0.0, 0.0]),
            i("Scale", Float, [5.0, 0.0, 0.0]),
            i("Distortion", Float, [0.0, 0.0, 0.0]),
            i("Detail", Float, [2.0, 0.0, 0.0]),
            i("Detail Scale", Float, [1.0, 0.0, 0.0]),
            i("Detail Roughness", Float, [0.5, 0.0, 0.0]),
            i("Phase Offset", Float, [0.0, 0.0, 0.0]),
        ],
        outputs: &[("Color", Color), ("Fac", Float)],
    },
    NodeSpec {
        idname: "ShaderNodeTexMagic",
        inputs: &[
            i("Vector", Vector, [0.0, 0.0, 0.0]),
            i("Scale", Float, [5.0, 0.0, 0.0]),
            i("Distortion", Float, [1.0, 0.0, 0.0]),
        ],
        outputs: &[("Color", Color), ("Fac", Float)],
    },
    NodeSpec {
        idname: "ShaderNodeTexBrick",
        inputs: &[
            i("Vector", Vector, [0.0, 0.0, 0.0]),
            i("Color1", Color, [0.8, 0.8, 0.8]),
            i("Color2", Color, [0.2, 0.2, 0.2]),
            i("Mortar", Color, [0.0, 0.0, 0.0]),
            i("Scale", Float, [5.0, 0.0, 0.0]),
            i("Mortar Size", Float, [0.02, 0.0, 0.0]),
            i("Mortar Smooth", Float, [0.1, 0.0, 0.0]),
            i("Bias", Float, [0.0, 0.0, 0.0]),
            i("Brick Width", Float, [0.5, 0.0, 0.0]),
            i("Row Height", Float, [0.25, 0.0, 0.0]),
        ],
        outputs: &[("Color", Color), ("Fac", Float)],
    },
    NodeSpec {
        idname: "ShaderNodeTexWhiteNoise",
        inputs: &[i("Vector", Vector, [0.0, 0.0, 0.0]), i("W", Float, [0.0, 0.0, 0.0])],
        outputs: &[("Value", Float), ("Color", Color)],
    },
    NodeSpec {
        idname: "ShaderNodeBsdfPrincipled",
        inputs: &[
            i("Weight", Float, [0.0, 0.0, 0.0]),
            i("Base Color", Color, [0.8, 0.8, 0.8]),
            i("Metallic", Float, [0.0, 0.0, 0.0]),
            i("Roughness", Float, [0.5, 0.0, 0.0]),
            i("IOR", Float, [1.5, 0.0, 0.0]),
            i("Alpha", Float, [1.0, 0.0, 0.0]),
            i("Normal", Vector, [0.0, 0.0, 0.0]),
            i("Diffuse Roughness", Float, [0.0, 0.0, 0.0]),
            i("Subsurface Weight", Float, [0.0, 0.0, 0.0]),
            i("Subsurface Radius", Vector, [1.0, 0.2, 0.1]),
            i("Subsurface Scale", Float, [0.05, 0.0, 0.0]),
            i("Subsurface IOR", Float, [1.4, 0.0, 0.0]),
            i("Subsurface Anisotropy", Float, [0.0, 0.0, 0.0]),
            i("Specular IOR Level", Float, [0.5, 0.0, 0.0]),
            i("Specular Tint", Color, [1.0, 1.0, 1.0]),
            i("Anisotropic", Float, [0.0, 0.0, 0.0]),
            i("Anisotropic Rotation", Float, [0.0, 0.0, 0.0]),
            i("Tangent", Vector, [0.0, 0.0, 0.0]),
            i("Transmission Weight", Float, [0.0, 0.0, 0.0]),
            i("Coat Weight", Float, [0.0, 0.0, 0.0]),
            i("Coat Roughness", Float, [0.03, 0.0, 0.0]),
            i("Coat IOR", Float, [1.5, 0.0, 0.0]),
            i("Coat Tint", Color, [1.0, 1.0, 1.0]),
            i("Coat Normal", Vector, [0.0, 0.0, 0.0]),
            i("Sheen Weight", Float, [0.0, 0.0, 0.0]),
            i("Sheen Roughness", Float, [0.5, 0.0, 0.0]),
            i("Sheen Tint", Color, [1.0, 1.0, 1.0]),
            i("Emission Color", Color, [1.0, 1.0, 1.0]),
            i("Emission Strength", Float, [0.0, 0.0, 0.0]),
            i("Thin Film Thickness", Float, [0.0, 0.0, 0.0]),
            i("Thin Film IOR", Float, [1.33, 0.0, 0.0]),
        ],
        outputs: &[("BSDF", Shader)],
    },
    NodeSpec {
        idname: "ShaderNodeBsdfDiffuse",
        inputs: &[
            i("Weight", Float, [0.0, 0.0, 0.0]),
            i("Color", Color, [0.8, 0.8, 0.8]),
            i("Roughness", Float, [0.0, 0.0, 0.0]),
            i("Normal", Vector, [0.0, 0.0, 0.0]),
        ],
        outputs: &[("BSDF", Shader)],
    },
    NodeSpec {
        idname: "ShaderNodeBsdfAnisotropic",
        inputs: &[
            i("Weight", Float, [0.0, 0.0, 0.0]),
            i("Color", Color, [0.8, 0.8, 0.8]),
            i("Roughness", Float, [0.5, 0.0, 0.0]),
            i("Anisotropy", Float, [0.0, 0.0, 0.0]),
            i("Rotation", Float, [0.0, 0.0, 0.0]),
            i("Normal", Vector, [0.0, 0.0, 0.0]),
            i("Tangent", Vector, [0.0, 0.0, 0.0]),
        ],
        outputs: &[("BSDF", Shader)],
    },
    NodeSpec {
        idname: "ShaderNodeBsdfGlass",
        inputs: &[
            i("Weight", Float, [0.0, 0.0, 0.0]),
            i("Color", Color, [1.0, 1.0, 1.0]),
            i("Roughness", Float, [0.0, 0.0, 0.0]),
            i("IOR", Float, [1.5, 0.0, 0.0]),
            i("Normal", Vector, [0.0, 0.0, 0.0]),
        ],
        outputs: &[("BSDF", Shader)],
    },
    NodeSpec {
        idname: "ShaderNodeBsdfRefraction",
        inputs: &[
            i("Weight", Float, [0.0, 0.0, 0.0]),
            i("Color", Color, [1.0, 1.0, 1.0]),
            i("Roughness", Float, [0.0, 0.0, 0.0]),
            i("IOR", Float, [1.45, 0.0, 0.0]),
            i("Normal", Vector, [0.0, 0.0, 0.0]),
        ],
        outputs: &[("BSDF", Shader)],
    },
    NodeSpec {
        idname: "ShaderNodeSubsurfaceScattering",
        inputs: &[
            i("Weight", Float, [0.0, 0.0, 0.0]),
            i("Color", Color, [0.8, 0.8, 0.8]),
            i("Scale", Float, [0.05, 0.0, 0.0]),
            i("Radius", Vector, [1.0, 0.2, 0.1]),
            i("IOR", Float, [1.4, 0.0, 0.0]),
            i("Roughness", Float, [1.0, 0.0, 0.0]),
            i("Anisotropy", Float, [0.0, 0.0, 0.0]),
            i("Normal", Vector, [0.0, 0.0, 0.0]),
        ],
        outputs: &[("BSSRDF", Shader)],
    },
    NodeSpec {
        idname: "ShaderNodeBsdfTranslucent",
        inputs: &[
            i("Weight", Float, [0.0, 0.0, 0.0]),
            i("Color", Color, [0.8, 0.8, 0.8]),
            i("Normal", Vector, [0.0, 0.0, 0.0]),
        ],
        outputs: &[("BSDF", Shader)],
    },
    NodeSpec {
        idname: "ShaderNodeBsdfSheen",
        inputs: &[
            i("Weight", Float, [0.0, 0.0, 0.0]),
            i("Color", Color, [0.8, 0.8, 0.8]),
            i("Roughness", Float, [0.5, 0.0, 0.0]),
            i("Normal", Vector, [0.0, 0.0, 0.0]),
        ],
        outputs: &[("BSDF", Shader)],
    },
    NodeSpec {
        idname: "ShaderNodeEmission",
        inputs: &[
            i("Weight", Float, [0.0, 0.0, 0.0]),
            i("Color", Color, [1.0, 1.0, 1.0]),
            i("Strength", Float, [1.0, 0.0, 0.0]),
        ],
        outputs: &[("Emission", Shader)],
    },
    NodeSpec {
        idname: "ShaderNodeMixShader",
        inputs: &[
            i("Fac", Float, [0.5, 0.0, 0.0]),
            i("Shader", Shader, [0.0, 0.0, 0.0]),
            i("Shader_001", Shader, [0.0, 0.0, 0.0]),
        ],
        outputs: &[("Shader", Shader)],
    },
    NodeSpec {
        idname: "ShaderNodeAddShader",
        inputs: &[i("Shader", Shader, [0.0, 0.0, 0.0]), i("Shader_001", Shader, [0.0, 0.0, 0.0])],
        outputs: &[("Shader", Shader)],
    },
    NodeSpec {
        idname: "ShaderNodeBsdfTransparent",
        inputs: &[i("Weight", Float, [0.0, 0.0, 0.0]), i("Color", Color, [1.0, 1.0, 1.0])],
        outputs: &[("BSDF", Shader)],
    },
    NodeSpec {
        idname: "ShaderNodeHoldout",
        inputs: &[i("Weight", Float, [0.0, 0.0, 0.0])],
        outputs: &[("Holdout", Shader)],
    },
    NodeSpec {
        idname: "ShaderNodeBsdfMetallic",
        inputs: &[
            i("Weight", Float, [0.0, 0.0, 0.0]),
            i("Base Color", Color, [0.617, 0.577, 0.54]),
            i("Edge Tint", Color, [0.695, 0.726, 0.77]),
            i("IOR", Vector, [2.757, 2.513, 2.231]),
            i("Extinction", Vector, [3.867, 3.404, 3.009]),
            i("Roughness", Float, [0.5, 0.0, 0.0]),
            i("Anisotropy", Float, [0.0, 0.0, 0.0]),
            i("Rotation", Float, [0.0, 0.0, 0.0]),
            i("Normal", Vector, [0.0, 0.0, 0.0]),
            i("Tangent", Vector, [0.0, 0.0, 0.0]),
        ],
        outputs: &[("BSDF", Shader)],
    },
];

/// The node's sockets, if the core knows the node.
pub fn spec(idname: &str) -> Option<&'static NodeSpec> {
    NODES.iter().find(|n| n.idname == idname)
}

impl NodeSpec {
    pub fn input(&self, id: &str) -> Option<(usize, &'static InputSpec)> {
        self.inputs.iter().enumerate().find(|(_, s)| s.id == id)
    }
    pub fn output(&self, id: &str) -> Option<(usize, SocketType)> {
        self.outputs.iter().enumerate().find(|(_, s)| s.0 == id).map(|(k, s)| (k, s.1))
    }
}

/// What an unlinked input reads when Blender gives it an implicit value instead of its
/// `default_value` (hidden vector sockets of textures, normals, tangents).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Implicit {
    /// The default UV map (Image Texture's Vector).
    Uv,
    /// Generated coordinates (procedural textures' Vector).
    Generated,
    /// The shading normal (every Normal input of closures, Fresnel, Layer Weight, Bump).
    Normal,
    /// The tangent (Principled, Glossy).
    Tangent,
    /// The incident direction (Environment Texture's Vector on a surface: the ray direction).
    Incoming,
}

/// Cycles' implicit value of an unlinked input (`node_shader_*`'s `implicit_field` and
/// the SVM compiler's defaults), if it has one.
pub fn implicit(idname: &str, input: &str) -> Option<Implicit> {
    match (idname, input) {
        ("ShaderNodeTexImage", "Vector") => Some(Implicit::Uv),
        ("ShaderNodeTexEnvironment", "Vector") => Some(Implicit::Incoming),
        (t, "Vector") if t.starts_with("ShaderNodeTex") => Some(Implicit::Generated),
        (_, "Normal" | "Coat Normal") if idname != "ShaderNodeNormalMap" => Some(Implicit::Normal),
        (_, "Tangent") => Some(Implicit::Tangent),
        _ => None,
    }
}
