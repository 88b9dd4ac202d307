//! Graph-level tests: folding, lowering, errors, evaluation at a shading point.

use super::compile::{Compiler, Value};
use super::*;
use crate::scene::BsdfDesc;
use glam::{Vec2, Vec3};
use serde_json::json;

fn graph(v: serde_json::Value) -> GraphDesc {
    serde_json::from_value(v).unwrap()
}

fn compile(v: serde_json::Value) -> Result<CompiledMaterial> {
    compile_material("M", &graph(v), &[])
}

#[test]
fn a_constant_graph_folds_to_the_fixed_principled() {
    let c = compile(json!({
        "nodes": [
            {"type": "ShaderNodeValue", "name": "Rough", "props": {"value": 0.2}},
            {"type": "ShaderNodeMath", "name": "Twice", "props": {"operation": "MULTIPLY"},
             "inputs": {"Value": {"link": [0, "Value"]}, "Value_001": 2.0}},
            {"type": "ShaderNodeCombineColor", "name": "C", "inputs": {"Red": 0.5, "Green": {"link": [1, "Value"]}, "Blue": 1.0}},
            {"type": "ShaderNodeBsdfPrincipled", "name": "P",
             "inputs": {"Roughness": {"link": [1, "Value"]}, "Base Color": {"link": [2, "Color"]}, "Metallic": 0.25}}
        ],
        "output": {"surface": [3, "BSDF"]}
    }))
    .unwrap();
    assert!(c.program.is_constant() && c.template.is_constant());
    let BsdfDesc::Principled { roughness, metallic, base_color, ior, .. } = &c.constant_surface().unwrap() else {
        panic!()
    };
    assert!((roughness - 0.4).abs() < 1e-6 && *metallic == 0.25);
    assert_eq!(base_color.kind, crate::spectrum::named::SpectrumKind::Rgb { rgb: [0.5, 0.4, 1.0] });
    assert!(matches!(ior, crate::material::IorDesc::Constant { ior } if (*ior - 1.5).abs() < 1e-6));
    assert!(c.emission.is_none());
}

#[test]
fn mix_and_add_shaders_lower_with_their_emission_weighted() {
    let c = compile(json!({
        "nodes": [
            {"type": "ShaderNodeEmission", "name": "E", "inputs": {"Color": [1.0, 0.5, 0.0, 1.0], "Strength": 4.0}},
            {"type": "ShaderNodeBsdfDiffuse", "name": "D"},
            {"type": "ShaderNodeMixShader", "name": "Mix", "inputs": {"Fac": 0.25,
                "Shader": {"link": [0, "Emission"]}, "Shader_001": {"link": [1, "BSDF"]}}}
        ],
        "output": {"surface": [2, "Shader"]}
    }))
    .unwrap();
    let BsdfDesc::Mix { factor, a, b, .. } = &c.constant_surface().unwrap() else { panic!() };
    assert_eq!(*factor, 0.25);
    assert!(matches!(**a, BsdfDesc::None) && matches!(**b, BsdfDesc::Diffuse { .. }));
    let e = c.emission.unwrap();
    assert_eq!(e.kind, crate::spectrum::named::SpectrumKind::Rgb { rgb: [3.0, 1.5, 0.0] });
}

#[test]
fn a_fresnel_on_the_mix_factor_becomes_the_view_dependent_factor() {
    let c = compile(json!({
        "nodes": [
            {"type": "ShaderNodeFresnel", "name": "F", "inputs": {"IOR": 1.33}},
            {"type": "ShaderNodeBsdfDiffuse", "name": "D"},
            {"type": "ShaderNodeBsdfAnisotropic", "name": "G", "inputs": {"Roughness": 0.1}},
            {"type": "ShaderNodeMixShader", "name": "Mix", "inputs": {"Fac": {"link": [0, "Fac"]},
                "Shader": {"link": [1, "BSDF"]}, "Shader_001": {"link": [2, "BSDF"]}}}
        ],
        "output": {"surface": [3, "Shader"]}
    }))
    .unwrap();
    let BsdfDesc::Mix { factor_from: Some(crate::scene::MixFactorDesc::Fresnel { ior }), .. } =
        c.constant_surface().unwrap()
    else {
        panic!()
    };
    assert!((ior - 1.33).abs() < 1e-6);
}

#[test]
fn cycles_are_errors_naming_the_nodes() {
    let e = compile(json!({
        "nodes": [
            {"type": "ShaderNodeMath", "name": "A", "inputs": {"Value": {"link": [1, "Value"]}}},
            {"type": "ShaderNodeMath", "name": "B", "inputs": {"Value": {"link": [0, "Value"]}}},
            {"type": "ShaderNodeBsdfDiffuse", "name": "D", "inputs": {"Roughness": {"link": [0, "Value"]}}}
        ],
        "output": {"surface": [2, "BSDF"]}
    }))
    .err()
    .unwrap()
    .to_string();
    assert!(e.contains("cycle") && e.contains("'A'") && e.contains("'B'") && e.contains("'M'"), "{e}");
}

#[test]
fn unknown_sockets_outputs_and_nodes_are_reported() {
    let diffuse_reading = |link: serde_json::Value, extra: serde_json::Value| {
        json!({
            "nodes": [extra, {"type": "ShaderNodeBsdfDiffuse", "name": "D", "inputs": {"Roughness": link}}],
            "output": {"surface": [1, "BSDF"]}
        })
    };
    let e = compile(diffuse_reading(json!({"link": [0, "Nope"]}), json!({"type": "ShaderNodeMath", "name": "A"})))
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("no output 'Nope'") && e.contains("'A'"), "{e}");
    let e = compile(diffuse_reading(
        json!({"link": [0, "Value"]}),
        json!({"type": "ShaderNodeMath", "name": "A", "inputs": {"Valu": 1.0}}),
    ))
    .err()
    .unwrap()
    .to_string();
    assert!(e.contains("unknown input socket 'Valu'") && e.contains("'A'"), "{e}");
    let e = compile(diffuse_reading(json!({"link": [7, "Value"]}), json!({"type": "ShaderNodeMath", "name": "A"})))
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("node 7") && e.contains("'D'"), "{e}");
    // An unknown node reads 0 and warns once, naming material and node.
    let c = compile(diffuse_reading(json!({"link": [0, "Whatever"]}), json!({"type": "ShaderNodeFancy", "name": "F"})))
        .unwrap();
    assert_eq!(c.warnings.len(), 1);
    assert!(c.warnings[0].contains("'M'") && c.warnings[0].contains("'F'"), "{:?}", c.warnings);
    assert!(matches!(c.constant_surface(), Some(BsdfDesc::Diffuse { .. })));
}

#[test]
fn nan_constants_are_errors_and_non_finite_results_become_zero() {
    let mut g = graph(json!({
        "nodes": [{"type": "ShaderNodeBsdfDiffuse", "name": "D"}],
        "output": {"surface": [0, "BSDF"]}
    }));
    g.nodes[0].inputs.insert("Roughness".into(), InputDesc::Number(f32::NAN));
    let e = compile_material("M", &g, &[]).err().unwrap().to_string();
    assert!(e.contains("'M'") && e.contains("'D'") && e.contains("Roughness"), "{e}");
    // exp(1000) overflows: the folded result is 0, not infinity.
    let c = compile(json!({
        "nodes": [
            {"type": "ShaderNodeMath", "name": "X", "props": {"operation": "EXPONENT"}, "inputs": {"Value": 1000.0}},
            {"type": "ShaderNodeEmission", "name": "E", "inputs": {"Strength": {"link": [0, "Value"]}}}
        ],
        "output": {"surface": [1, "Emission"]}
    }))
    .unwrap();
    assert!(c.emission.is_none());
}

#[test]
fn a_varying_graph_keeps_its_program_and_builds_each_hit_from_it() {
    use crate::material::{Bsdf, Diffuse, SpectralParam};
    let c = compile(json!({
        "nodes": [
            {"type": "ShaderNodeTexCoord", "name": "T"},
            {"type": "ShaderNodeSeparateXYZ", "name": "S", "inputs": {"Vector": {"link": [0, "UV"]}}},
            {"type": "ShaderNodeCombineColor", "name": "C", "inputs": {"Red": {"link": [1, "X"]}, "Green": 0.5, "Blue": 0.5}},
            {"type": "ShaderNodeBsdfDiffuse", "name": "D", "inputs": {"Color": {"link": [2, "Color"]}}}
        ],
        "output": {"surface": [3, "BSDF"]}
    }))
    .unwrap();
    assert!(!c.template.is_constant() && c.constant_surface().is_none());
    // Build the hit's diffuse with a grey spectrum of the colour's red, to check the
    // plumbing without an RGB → spectrum map.
    let build = Box::new(|d: &BsdfDesc| -> crate::Result<Box<dyn Bsdf>> {
        let BsdfDesc::Diffuse { reflectance } = d else { panic!("{d:?}") };
        let crate::spectrum::named::SpectrumKind::Rgb { rgb } = reflectance.kind else { panic!() };
        Ok(Box::new(Diffuse {
            reflectance: SpectralParam::Constant(crate::spectrum::SampledSpectrum::splat(4, rgb[0])),
        }))
    });
    let g = bsdf::GraphBsdf::new(c.program, c.template, build, false).unwrap();
    let grid = crate::spectrum::WavelengthGrid::uniform(4, 400.0, 700.0).unwrap();
    let mut ctx = crate::material::ShadingContext::new(&grid);
    let mut out = crate::spectrum::SampledSpectrum::zeros(4);
    for u in [0.1f32, 0.8, 0.35, 0.8] {
        ctx.hit = ShadingPoint { uv: Vec2::new(u, 0.5), position: Vec3::splat(u), ..Default::default() };
        g.albedo(&ctx, &mut out);
        assert!(out.values().iter().all(|&v| (v - u).abs() < 1e-6), "{u}: {:?}", out.values());
    }
}

/// Compiles the value at `link` of the graph and evaluates it at `sp`.
fn evaluate(v: serde_json::Value, sp: &ShadingPoint) -> Vec3 {
    let g = graph(v);
    let mut c = Compiler::new("M", &g.nodes, &[]);
    let last = g.nodes.len() - 1;
    let Value::Reg(r) = c.input(last, "Color").unwrap() else { panic!() };
    let mut regs = Vec::new();
    c.program.run(sp, &mut regs);
    regs[r as usize]
}

#[test]
fn a_program_evaluated_at_a_hit_equals_the_closed_form() {
    // Color = (u·2 + 0.1, sin v, u mod 0.3) read through conversions.
    let g = json!({
        "nodes": [
            {"type": "ShaderNodeUVMap", "name": "UV"},
            {"type": "ShaderNodeSeparateXYZ", "name": "S", "inputs": {"Vector": {"link": [0, "UV"]}}},
            {"type": "ShaderNodeMath", "name": "A", "props": {"operation": "MULTIPLY_ADD"},
             "inputs": {"Value": {"link": [1, "X"]}, "Value_001": 2.0, "Value_002": 0.1}},
            {"type": "ShaderNodeMath", "name": "B", "props": {"operation": "SINE"}, "inputs": {"Value": {"link": [1, "Y"]}}},
            {"type": "ShaderNodeMath", "name": "C", "props": {"operation": "MODULO"},
             "inputs": {"Value": {"link": [1, "X"]}, "Value_001": 0.3}},
            {"type": "ShaderNodeMath", "name": "Unused", "props": {"operation": "COSINE"}, "inputs": {"Value": {"link": [1, "Z"]}}},
            {"type": "ShaderNodeCombineColor", "name": "Comb",
             "inputs": {"Red": {"link": [2, "Value"]}, "Green": {"link": [3, "Value"]}, "Blue": {"link": [4, "Value"]}}},
            {"type": "ShaderNodeBsdfDiffuse", "name": "D", "inputs": {"Color": {"link": [6, "Color"]}}}
        ],
        "output": {"surface": [7, "BSDF"]}
    });
    for (u, v) in [(0.1f32, 0.7f32), (0.45, 0.2), (0.9, 0.95)] {
        let sp = ShadingPoint { uv: Vec2::new(u, v), ..Default::default() };
        let c = evaluate(g.clone(), &sp);
        let want = Vec3::new(u * 2.0 + 0.1, v.sin(), u % 0.3);
        assert!((c - want).abs().max_element() < 1e-6, "{c} vs {want}");
    }
    // Dead-node elimination: the COSINE nobody reads is not in the program.
    let gd = graph(g);
    let mut c = Compiler::new("M", &gd.nodes, &[]);
    c.input(7, "Color").unwrap();
    assert!(c
        .program
        .ops
        .iter()
        .all(|op| !matches!(&op.kernel, program::Kernel::Math(m) if m.op == math::MathOp::Cosine)));
    assert_eq!(c.program.ops.len(), 6, "{:?}", c.program.ops.iter().map(|o| &o.kernel).collect::<Vec<_>>());
}

#[test]
fn colour_to_float_links_use_luminance_and_float_to_colour_is_grey() {
    let sp = ShadingPoint::default();
    let c = evaluate(
        json!({"nodes": [
            {"type": "ShaderNodeRGB", "name": "RGB", "props": {"color": [1.0, 0.0, 0.0, 1.0]}},
            {"type": "ShaderNodeMath", "name": "A", "props": {"operation": "ADD"},
             "inputs": {"Value": {"link": [0, "Color"]}, "Value_001": 0.0}},
            {"type": "ShaderNodeBsdfDiffuse", "name": "D", "inputs": {"Color": {"link": [1, "Value"]}}}
        ], "output": {"surface": [2, "BSDF"]}}),
        &sp,
    );
    assert!((c - Vec3::splat(0.2126)).abs().max_element() < 1e-6, "{c}");
}

#[test]
fn procedural_nodes_evaluate_through_crate_procedural() {
    let sp = ShadingPoint { generated: Vec3::new(0.3, 0.6, 0.1), ..Default::default() };
    let c = evaluate(
        json!({"nodes": [
            {"type": "ShaderNodeTexChecker", "name": "K", "inputs": {"Scale": 2.0, "Color1": [1.0, 0.0, 0.0, 1.0]}},
            {"type": "ShaderNodeBsdfDiffuse", "name": "D", "inputs": {"Color": {"link": [0, "Color"]}}}
        ], "output": {"surface": [1, "BSDF"]}}),
        &sp,
    );
    let want = crate::procedural::CheckerTexture { scale: 2.0, color1: Vec3::new(1.0, 0.0, 0.0), ..Default::default() }
        .evaluate(sp.generated)
        .color;
    assert_eq!(c, want);
}

#[test]
fn principled_alpha_and_a_transparent_mix_split_into_a_pass_probability() {
    let c = compile(json!({
        "nodes": [{"type": "ShaderNodeBsdfPrincipled", "name": "P", "inputs": {"Alpha": 0.35}}],
        "output": {"surface": [0, "BSDF"]}
    }))
    .unwrap();
    let (p, tint) = c.transparency.clone().unwrap();
    let p = p.at(&|_| Vec3::ZERO);
    assert!((p - 0.65).abs() < 1e-6);
    assert_eq!(tint.kind, crate::spectrum::named::SpectrumKind::Rgb { rgb: [1.0; 3] });
    assert!(matches!(c.constant_surface().unwrap(), BsdfDesc::Principled { .. }));
    assert!(c.warnings.is_empty(), "{:?}", c.warnings);
    let c = compile(json!({
        "nodes": [
            {"type": "ShaderNodeBsdfDiffuse", "name": "D"},
            {"type": "ShaderNodeBsdfTransparent", "name": "T", "inputs": {"Color": [0.5, 0.25, 1.0, 1.0]}},
            {"type": "ShaderNodeMixShader", "name": "Mix", "inputs": {"Fac": 0.2,
                "Shader": {"link": [0, "BSDF"]}, "Shader_001": {"link": [1, "BSDF"]}}}
        ],
        "output": {"surface": [2, "Shader"]}
    }))
    .unwrap();
    let (p, tint) = c.transparency.clone().unwrap();
    let p = p.at(&|_| Vec3::ZERO);
    assert!((p - 0.2).abs() < 1e-6);
    assert_eq!(tint.kind, crate::spectrum::named::SpectrumKind::Rgb { rgb: [0.5, 0.25, 1.0] });
    assert!(matches!(c.constant_surface().unwrap(), BsdfDesc::Diffuse { .. }));
    // Below an Add Shader it cannot be split: warned, it reflects nothing.
    let c = compile(json!({
        "nodes": [
            {"type": "ShaderNodeBsdfDiffuse", "name": "D"},
            {"type": "ShaderNodeBsdfTransparent", "name": "T"},
            {"type": "ShaderNodeAddShader", "name": "Add", "inputs": {
                "Shader": {"link": [0, "BSDF"]}, "Shader_001": {"link": [1, "BSDF"]}}}
        ],
        "output": {"surface": [2, "Shader"]}
    }))
    .unwrap();
    assert!(c.transparency.is_none());
    assert!(c.warnings.iter().any(|w| w.contains("'M'") && w.contains("Transparent")), "{:?}", c.warnings);
}

#[test]
fn a_textured_alpha_is_a_per_hit_pass_probability_with_its_own_pruned_program() {
    // Alpha = UV.x through a Separate XYZ; Base Color from a Checker (not needed for alpha).
    let c = compile(json!({
        "nodes": [
            {"type": "ShaderNodeUVMap", "name": "UV"},
            {"type": "ShaderNodeSeparateXYZ", "name": "S", "inputs": {"Vector": {"link": [0, "UV"]}}},
            {"type": "ShaderNodeTexChecker", "name": "C", "inputs": {"Vector": {"link": [0, "UV"]}}},
            {"type": "ShaderNodeBsdfPrincipled", "name": "P", "inputs": {
                "Alpha": {"link": [1, "X"]}, "Base Color": {"link": [2, "Color"]}}}
        ],
        "output": {"surface": [3, "BSDF"]}
    }))
    .unwrap();
    assert!(c.warnings.is_empty(), "{:?}", c.warnings);
    let (p, _) = c.transparency.clone().unwrap();
    let crate::shading::closure::PassProbability::Register { reg, invert: true, .. } = p else { panic!("{p:?}") };
    let pruned = c.program.pruned_for(reg);
    assert!(pruned.ops.len() < c.program.ops.len(), "{} vs {}", pruned.ops.len(), c.program.ops.len());
    for u in [0.0f32, 0.3, 1.0] {
        let mut attributes = [[0.0; 4]; crate::shading::program::MAX_ATTRIBUTES];
        attributes[0] = [u, 0.5, 0.0, 0.0];
        let sp = crate::shading::ShadingPoint { uv: glam::Vec2::new(u, 0.5), attributes, ..Default::default() };
        let (mut full, mut small) = (Vec::new(), Vec::new());
        c.program.run(&sp, &mut full);
        pruned.run(&sp, &mut small);
        assert_eq!(full[reg as usize], small[reg as usize]);
        // Pass probability 1 − alpha.
        assert!((p.at(&|r| small[r as usize]) - (1.0 - u)).abs() < 1e-6);
    }
    // The opaque rest is the Principled alone, varying (its base colour).
    assert!(!c.template.is_constant() && !c.template.has_transparent());
}

/// The RGB emission of a compiled graph at `sp`, from its varying terms.
fn emitted_rgb(c: &CompiledMaterial, sp: &ShadingPoint) -> Vec3 {
    let mut regs = Vec::new();
    c.program.run(sp, &mut regs);
    c.varying_emission.as_ref().expect("varying emission").iter().fold(Vec3::ZERO, |a, t| a + t.eval(&regs))
}

#[test]
fn a_varying_emission_is_evaluated_per_hit() {
    // UV → Emission Color (strength 3), mixed per hit by the UV's v with a constant
    // orange emission: e = (1 − v)·3·(u, v, 0) + v·(1, 0.5, 0).
    let c = compile(json!({
        "nodes": [
            {"type": "ShaderNodeTexCoord", "name": "TC"},
            {"type": "ShaderNodeEmission", "name": "E", "inputs": {"Color": {"link": [0, "UV"]}, "Strength": 3.0}},
            {"type": "ShaderNodeEmission", "name": "O", "inputs": {"Color": [1.0, 0.5, 0.0, 1.0], "Strength": 1.0}},
            {"type": "ShaderNodeSeparateXYZ", "name": "S", "inputs": {"Vector": {"link": [0, "UV"]}}},
            {"type": "ShaderNodeMixShader", "name": "Mix", "inputs": {"Fac": {"link": [3, "Y"]},
                "Shader": {"link": [1, "Emission"]}, "Shader_001": {"link": [2, "Emission"]}}}
        ],
        "output": {"surface": [4, "Shader"]}
    }))
    .unwrap();
    assert!(c.emission.is_none());
    let sp = ShadingPoint { uv: Vec2::new(0.25, 0.5), ..Default::default() };
    let e = emitted_rgb(&c, &sp);
    let want = 0.5 * 3.0 * Vec3::new(0.25, 0.5, 0.0) + 0.5 * Vec3::new(1.0, 0.5, 0.0);
    assert!((e - want).abs().max_element() < 1e-6, "{e} vs {want}");
    // A varying strength over a constant colour, never negative.
    let c = compile(json!({
        "nodes": [
            {"type": "ShaderNodeTexCoord", "name": "TC"},
            {"type": "ShaderNodeSeparateXYZ", "name": "S", "inputs": {"Vector": {"link": [0, "UV"]}}},
            {"type": "ShaderNodeMath", "name": "M", "props": {"operation": "SUBTRACT"},
             "inputs": {"Value": {"link": [1, "X"]}, "Value_001": 0.5}},
            {"type": "ShaderNodeEmission", "name": "E", "inputs": {"Color": [0.2, 0.4, 0.8, 1.0], "Strength": {"link": [2, "Value"]}}}
        ],
        "output": {"surface": [3, "Emission"]}
    }))
    .unwrap();
    let at = |u: f32| emitted_rgb(&c, &ShadingPoint { uv: Vec2::new(u, 0.0), ..Default::default() });
    assert!((at(1.0) - 0.5 * Vec3::new(0.2, 0.4, 0.8)).abs().max_element() < 1e-6);
    assert_eq!(at(0.0), Vec3::ZERO);
}

/// A world-space Normal Map of a constant colour: the unit normal `n` (node `name`).
fn world_normal(name: &str, n: Vec3) -> serde_json::Value {
    let c = 0.5 * n + Vec3::splat(0.5);
    json!({"type": "ShaderNodeNormalMap", "name": name, "props": {"space": "WORLD"}, "inputs": {"Color": [c.x, c.y, c.z, 1.0]}})
}

/// Each closure keeps its own normal (no warning): a Principled's Coat Normal differs
/// from its Normal, the two Glossy BSDFs of a Mix read different Normals, a Diffuse
/// keeps the smooth one; instantiated at a hit seen straight on (where no normal needs
/// bending), each lobe carries its normal in the vertex's frame.
#[test]
fn every_closure_keeps_its_own_normal() {
    let (na, nb) = (Vec3::new(0.3f32.sin(), 0.0, 0.3f32.cos()), Vec3::new(0.0, 0.4f32.sin(), 0.4f32.cos()));
    let c = compile(json!({
        "nodes": [
            world_normal("A", na), world_normal("B", nb),
            {"type": "ShaderNodeBsdfPrincipled", "name": "P", "inputs": {"Coat Weight": 1.0,
                "Normal": {"link": [0, "Normal"]}, "Coat Normal": {"link": [1, "Normal"]}}},
            {"type": "ShaderNodeBsdfAnisotropic", "name": "G1", "inputs": {"Normal": {"link": [0, "Normal"]}}},
            {"type": "ShaderNodeBsdfAnisotropic", "name": "G2", "inputs": {"Normal": {"link": [1, "Normal"]}}},
            {"type": "ShaderNodeMixShader", "name": "M1", "inputs": {"Shader": {"link": [3, "BSDF"]}, "Shader_001": {"link": [4, "BSDF"]}}},
            {"type": "ShaderNodeBsdfDiffuse", "name": "D"},
            {"type": "ShaderNodeAddShader", "name": "A1", "inputs": {"Shader": {"link": [5, "Shader"]}, "Shader_001": {"link": [6, "BSDF"]}}},
            {"type": "ShaderNodeAddShader", "name": "A2", "inputs": {"Shader": {"link": [2, "BSDF"]}, "Shader_001": {"link": [7, "Shader"]}}}
        ],
        "output": {"surface": [8, "Shader"]}
    }))
    .unwrap();
    assert!(c.warnings.is_empty(), "{:?}", c.warnings);
    assert!(c.normal.is_some() && !c.template.is_constant());
    let sp = ShadingPoint::default();
    let mut regs = Vec::new();
    c.program.run(&sp, &mut regs);
    let o = closure::Orient::at(&sp, crate::geometry::Frame::from_normal(glam::Vec3A::Z));
    let d = c.template.instantiate(&|r| regs[r as usize], Some(&o));
    let near = |n: &Option<[f32; 3]>, e: Vec3| n.is_some_and(|n| (Vec3::from(n) - e).length() < 1e-5);
    let BsdfDesc::Add { a: p, b: rest } = &d else { panic!("{d:?}") };
    let BsdfDesc::Principled { normals: Some(n), coat: Some(_), .. } = &**p else { panic!("{p:?}") };
    assert!(near(&n.base, na) && near(&n.coat, nb) && n.sheen.is_none(), "{n:?}");
    let BsdfDesc::Add { a: mix, b: diffuse } = &**rest else { panic!() };
    let BsdfDesc::Mix { a: g1, b: g2, .. } = &**mix else { panic!("{mix:?}") };
    for (g, e) in [(g1, na), (g2, nb)] {
        let BsdfDesc::Oriented { normal, bsdf, .. } = &**g else { panic!("{g:?}") };
        assert!(near(&Some(*normal), e) && matches!(**bsdf, BsdfDesc::Glossy { .. }), "{normal:?} vs {e}");
    }
    // The smooth normal is the vertex frame's own here: nothing to orient.
    assert!(matches!(**diffuse, BsdfDesc::Diffuse { .. }), "{diffuse:?}");
    // Without a hit to orient at (a default build), no lobe is oriented.
    let plain = c.template.instantiate(&|r| regs[r as usize], None);
    assert!(!format!("{plain:?}").contains("Oriented"));
}

/// Cycles bends the specular closures' normals (maybe_ensure_valid_specular_reflection)
/// and leaves the diffuse's: a Normal tilted 60° seen straight on would mirror the view
/// below the surface, so the Glossy's normal is lifted until the mirror leaves 0.01
/// above it, while the Diffuse keeps the 60° tilt.
#[test]
fn only_specular_closures_bend_their_normal() {
    let n = Vec3::new(60f32.to_radians().sin(), 0.0, 60f32.to_radians().cos());
    let c = compile(json!({
        "nodes": [
            world_normal("N", n),
            {"type": "ShaderNodeBsdfAnisotropic", "name": "G", "inputs": {"Normal": {"link": [0, "Normal"]}}},
            {"type": "ShaderNodeBsdfDiffuse", "name": "D", "inputs": {"Normal": {"link": [0, "Normal"]}}},
            {"type": "ShaderNodeAddShader", "name": "A", "inputs": {"Shader": {"link": [1, "BSDF"]}, "Shader_001": {"link": [2, "BSDF"]}}}
        ],
        "output": {"surface": [3, "Shader"]}
    }))
    .unwrap();
    let sp = ShadingPoint::default();
    let mut regs = Vec::new();
    c.program.run(&sp, &mut regs);
    let o = closure::Orient::at(&sp, crate::geometry::Frame::from_normal(glam::Vec3A::Z));
    let BsdfDesc::Add { a, b } = c.template.instantiate(&|r| regs[r as usize], Some(&o)) else { panic!() };
    let normal = |d: &BsdfDesc| match d {
        BsdfDesc::Oriented { normal, .. } => Vec3::from(*normal),
        _ => panic!("{d:?}"),
    };
    let (g, d) = (normal(&a), normal(&b));
    assert!((d - n).length() < 1e-5, "diffuse {d}");
    let mirror = 2.0 * g.dot(Vec3::Z) * g - Vec3::Z;
    assert!((mirror.z - 0.01).abs() < 1e-3 && g.y.abs() < 1e-6 && g.x > 0.0, "glossy {g}: mirror {mirror}");
}

/// An anisotropic Principled and Glossy read a tangent (Cycles' default: the radial
/// tangent of Generated coordinates, `input::radial_tangent`) and are built per hit in
/// the vertex's frame, with no warning; Anisotropic 0 reads none and stays constant.
#[test]
fn anisotropic_closures_read_the_default_tangent_per_hit() {
    let c = compile(json!({
        "nodes": [
            {"type": "ShaderNodeBsdfPrincipled", "name": "P",
             "inputs": {"Metallic": 1.0, "Anisotropic": 0.8, "Anisotropic Rotation": 0.25}},
            {"type": "ShaderNodeBsdfAnisotropic", "name": "G", "inputs": {"Anisotropy": -0.5, "Rotation": 0.1}},
            {"type": "ShaderNodeAddShader", "name": "A", "inputs": {"Shader": {"link": [0, "BSDF"]}, "Shader_001": {"link": [1, "BSDF"]}}}
        ],
        "output": {"surface": [2, "Shader"]}
    }))
    .unwrap();
    assert!(c.warnings.is_empty(), "{:?}", c.warnings);
    assert!(c.template.needs_tangent() && !c.template.is_constant());
    let sp = ShadingPoint {
        generated: Vec3::new(1.0, 0.5, 0.5),
        normal: Vec3::X,
        true_normal: Vec3::X,
        incoming: Vec3::X,
        ..Default::default()
    };
    let mut regs = Vec::new();
    c.program.run(&sp, &mut regs);
    let frame = crate::geometry::Frame::from_normal(glam::Vec3A::X);
    let o = closure::Orient::at(&sp, frame);
    let BsdfDesc::Add { a: p, b: g } = c.template.instantiate(&|r| regs[r as usize], Some(&o)) else { panic!() };
    let BsdfDesc::Principled { anisotropic, anisotropic_rotation, normals: Some(n), .. } = &*p else { panic!("{p:?}") };
    assert!((*anisotropic - 0.8).abs() < 1e-6 && (*anisotropic_rotation - 0.25).abs() < 1e-6);
    let t = frame.to_world(glam::Vec3A::from(n.tangent.expect("a tangent")));
    assert!((t - glam::Vec3A::Y).length() < 1e-5, "{t}");
    let BsdfDesc::Glossy { anisotropy, rotation, tangent: Some(gt), .. } = &*g else { panic!("{g:?}") };
    assert!((*anisotropy + 0.5).abs() < 1e-6 && (*rotation - 0.1).abs() < 1e-6);
    assert!((frame.to_world(glam::Vec3A::from(*gt)) - glam::Vec3A::Y).length() < 1e-5);
    // Isotropic: no tangent, a constant surface.
    let c = compile(json!({
        "nodes": [{"type": "ShaderNodeBsdfPrincipled", "name": "P", "inputs": {"Anisotropic": 0.0, "Anisotropic Rotation": 0.3}}],
        "output": {"surface": [0, "BSDF"]}
    }))
    .unwrap();
    assert!(!c.template.needs_tangent() && c.template.is_constant() && c.warnings.is_empty());
}

/// The Principled's Subsurface inputs and the Subsurface Scattering node lower to the
/// random walk with Cycles' clamps: no "not supported" warning, the node as a Principled
/// whose base all walks with no specular layer (roughness √Roughness), a negative
/// radius clamped to 0 with a warning naming the node.
#[test]
fn subsurface_inputs_and_node_lower_to_the_walk() {
    let c = compile(json!({
        "nodes": [{"type": "ShaderNodeBsdfPrincipled", "name": "P", "props": {"subsurface_method": "RANDOM_WALK_SKIN"},
                   "inputs": {"Subsurface Weight": 0.7, "Subsurface Radius": [2.0, 1.0, 0.5], "Subsurface Scale": 0.3,
                              "Subsurface IOR": 1.33, "Subsurface Anisotropy": 0.2}}],
        "output": {"surface": [0, "BSDF"]}
    }))
    .unwrap();
    assert!(c.warnings.is_empty(), "{:?}", c.warnings);
    let BsdfDesc::Principled { subsurface: Some(s), .. } = &c.constant_surface().unwrap() else { panic!() };
    assert_eq!((s.weight, s.radius, s.scale, s.ior, s.anisotropy), (0.7, [2.0, 1.0, 0.5], 0.3, 1.33, 0.2));
    assert_eq!(s.method, "random_walk_skin");
    let c = compile(json!({
        "nodes": [{"type": "ShaderNodeSubsurfaceScattering", "name": "S",
                   "inputs": {"Color": [0.9, 0.6, 0.5, 1.0], "Radius": [1.0, -0.5, 0.25], "Roughness": 0.25}}],
        "output": {"surface": [0, "BSSRDF"]}
    }))
    .unwrap();
    assert!(c.warnings.iter().any(|w| w.contains("'S'") && w.contains("Radius")), "{:?}", c.warnings);
    let BsdfDesc::Principled { subsurface: Some(s), specular_ior_level, roughness, .. } =
        &c.constant_surface().unwrap()
    else {
        panic!()
    };
    assert_eq!((s.weight, s.radius, s.method.as_str()), (1.0, [1.0, 0.0, 0.25], "random_walk"));
    assert_eq!((*specular_ior_level, *roughness), (0.0, 0.5));
}
