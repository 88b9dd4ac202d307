//! End-to-end renders of the layered and combined BSDFs (Principled, Mix, Add) from
//! JSON descriptions, against closed forms.

mod common;

use common::*;
use polychrome_core::render::{render, Direction, Method, RenderControl, ResolvedSettings};
use polychrome_core::scene::{Buffer, MaterialDesc, SceneDesc};

fn material(json: &str) -> MaterialDesc {
    serde_json::from_str(json).expect("valid material JSON")
}

/// Furnace: inside a closed sphere of emission L whose BSDF has albedo a at every angle,
/// every point sees L/(1 − a). A Principled BSDF with a white base reflects everything
/// (its base takes the energy the specular layer does not reflect), so mixing it with
/// a black BSDF at factor t gives a = 1 − t exactly, at any roughness and IOR.
#[test]
fn furnace_principled_white_mixed_with_black() {
    // Every method and direction sees the same closed form (the base layer is reciprocal,
    // so light tracing agrees with camera tracing).
    let cases = [
        (0.5f32, 1.5f32, 0.0f32, Method::Polychromatic, Direction::Backward),
        (0.1, 2.0, 0.0, Method::Polychromatic, Direction::Backward),
        (0.3, 1.45, 350.0, Method::Polychromatic, Direction::Backward),
        (0.3, 1.45, 350.0, Method::Polychromatic, Direction::Forward),
        (0.5, 1.5, 0.0, Method::Polychromatic, Direction::Bidirectional),
        (0.3, 1.45, 350.0, Method::MonochromaticRays, Direction::Backward),
        (0.3, 1.45, 350.0, Method::Rgb, Direction::Backward),
    ];
    for (roughness, ior, film, method, direction) in cases {
        let t = 0.4f64;
        let l = 0.5f64;
        let json = format!(
            r#"{{"name": "layered", "emission": {{"type": "constant", "value": {l}}},
                "bsdf": {{"type": "mix", "factor": {t},
                          "a": {{"type": "principled", "base_color": {{"type": "constant", "value": 1.0}},
                                "roughness": {roughness}, "ior": {{"type": "constant", "ior": {ior}}},
                                "thin_film_thickness": {film}, "thin_film_ior": 1.33}},
                          "b": {{"type": "none"}}}}}}"#
        );
        let mut desc = SceneDesc::default();
        let mut buffers: Vec<Buffer> = Vec::new();
        desc.materials.push(material(&json));
        let (v, tri) = uv_sphere([0.0; 3], 2.0, 24, 48);
        add_mesh(&mut desc, &mut buffers, "sphere", v, tri, 0);
        // Monochromatic and light paths are noisier per sample: more of them.
        let samples = if method == Method::MonochromaticRays || direction == Direction::Forward { 64 } else { 16 };
        let settings = ResolvedSettings {
            width: 16,
            height: 16,
            samples,
            max_bounces: 200,
            method,
            direction,
            ..Default::default()
        };
        let out = render(&desc, &buffers, &settings, &RenderControl::new()).unwrap();
        let (mean, se) = mean_and_standard_error(&out.images.rgba);
        let expected = l / t;
        assert!((mean - expected).abs() < 4.0 * se + 2e-3 * expected, "{method:?} {direction:?} roughness {roughness} ior {ior} film {film}: mean {mean} expected {expected} (se {se})");
        assert!(se < 0.05 * expected, "{method:?} {direction:?}: too noisy: se {se}");
        assert_eq!(out.stats.nonfinite_samples, 0);
    }
}

/// Bad Principled and Mix parameters are errors naming the material.
#[test]
fn bad_layered_parameters_name_the_material() {
    let cases = [
        r#"{"name": "M1", "bsdf": {"type": "principled", "metallic": 1.5}}"#,
        r#"{"name": "M2", "bsdf": {"type": "principled", "thin_film_thickness": 200, "thin_film_ior": 0.5}}"#,
        r#"{"name": "M3", "bsdf": {"type": "principled", "base_color": {"type": "constant", "value": 1.5}}}"#,
        r#"{"name": "M4", "bsdf": {"type": "mix", "factor": 2.0, "a": {"type": "none"}, "b": {"type": "none"}}}"#,
        r#"{"name": "M5", "bsdf": {"type": "add", "a": {"type": "none"}, "b": {"type": "dielectric", "roughness": 3.0}}}"#,
        r#"{"name": "M6", "bsdf": {"type": "principled", "roughness": "NaN"}}"#,
        r#"{"name": "M7", "bsdf": {"type": "mix", "a": {"type": "none"}, "b": {"type": "none"}, "factor_from": {"type": "layer_weight_facing", "blend": 2.0}}}"#,
    ];
    for (k, json) in cases.iter().enumerate() {
        let name = format!("M{}", k + 1);
        let Ok(m) = serde_json::from_str::<MaterialDesc>(json) else {
            // A value JSON cannot hold is rejected by the parser already.
            assert_eq!(name, "M6");
            continue;
        };
        let mut desc = SceneDesc::default();
        let mut buffers: Vec<Buffer> = Vec::new();
        desc.materials.push(m);
        let (v, tri) = uv_sphere([0.0; 3], 1.0, 4, 8);
        add_mesh(&mut desc, &mut buffers, "s", v, tri, 0);
        let settings = ResolvedSettings { width: 2, height: 2, samples: 1, ..Default::default() };
        let err = render(&desc, &buffers, &settings, &RenderControl::new()).err().expect("must fail").to_string();
        assert!(err.contains(&format!("material '{name}'")), "{err}");
    }
}

/// One builder (scene/layered.rs): a BSDF description is validated alike whether it is
/// the material's own or nested inside a Mix — the top level once had its own copy of
/// the leaf arms, which accepted a negative diffuse reflectance the nested builder
/// refused. Bad leaves fail in both places with the same message; good ones build in
/// both.
#[test]
fn top_level_and_nested_bsdfs_are_validated_alike() {
    let build = |bsdf: &str| -> Result<(), String> {
        let json = format!(r#"{{"name": "leaf", "bsdf": {bsdf}}}"#);
        let mut desc = SceneDesc::default();
        let mut buffers: Vec<Buffer> = Vec::new();
        desc.materials.push(material(&json));
        let (v, tri) = uv_sphere([0.0; 3], 1.0, 4, 8);
        add_mesh(&mut desc, &mut buffers, "s", v, tri, 0);
        let settings = ResolvedSettings { width: 2, height: 2, samples: 1, ..Default::default() };
        render(&desc, &buffers, &settings, &RenderControl::new()).map(|_| ()).map_err(|e| e.to_string())
    };
    let bad = [
        r#"{"type": "diffuse", "reflectance": {"type": "constant", "value": -0.2}}"#,
        r#"{"type": "diffuse", "reflectance": {"type": "constant", "value": 1.2}}"#,
        r#"{"type": "glossy", "reflectance": {"type": "constant", "value": 0.5}, "roughness": 3.0}"#,
        r#"{"type": "conductor", "metal": "unobtainium"}"#,
        r#"{"type": "dielectric", "roughness": -1.0}"#,
    ];
    let good = [
        r#"{"type": "diffuse", "reflectance": {"type": "constant", "value": 0.5}}"#,
        r#"{"type": "glossy", "reflectance": {"type": "constant", "value": 0.5}, "roughness": 0.3}"#,
        r#"{"type": "conductor", "metal": "gold", "roughness": 0.2}"#,
        r#"{"type": "dielectric", "roughness": 0.1}"#,
    ];
    let nested = |leaf: &str| format!(r#"{{"type": "mix", "factor": 0.5, "a": {leaf}, "b": {{"type": "none"}}}}"#);
    for leaf in bad {
        let (top, mix) = (build(leaf), build(&nested(leaf)));
        let (Err(a), Err(b)) = (&top, &mix) else { panic!("{leaf}: top level {top:?}, nested {mix:?}") };
        assert!(a.contains("material 'leaf'"), "{a}");
        assert_eq!(a, b, "{leaf}");
    }
    for leaf in good {
        assert_eq!(build(leaf), Ok(()), "{leaf}");
        assert_eq!(build(&nested(leaf)), Ok(()), "{leaf} nested");
    }
}
