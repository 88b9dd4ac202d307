"""Node-graph materials (docs/shading.md) through the Python API: a graph that folds to
constants renders exactly as the equivalent fixed material, and bad graphs are clear
errors naming the material and node."""

from __future__ import annotations

import numpy as np
import pytest

import polychrome as pc


def plane_scene(material: pc.Material) -> pc.Scene:
    """A plane seen straight down by an orthographic camera under a uniform world and a sun."""
    scene = pc.Scene()
    m = np.eye(4)
    m[2, 3] = 5.0
    scene.camera = pc.Camera(to_world=m, projection="ORTHOGRAPHIC", ortho_scale=1.0)
    v = np.array([[-4, -4, 0], [4, -4, 0], [4, 4, 0], [-4, 4, 0]], dtype=np.float32)
    scene.add_mesh("plane", v, np.array([[0, 1, 2], [0, 2, 3]]), material=material)
    scene.set_world(pc.spectra.constant(0.5))
    scene.add_light(pc.SunLight(direction=(0.3, 0.2, -1.0), strength=2.0))
    return scene


def render(material: pc.Material) -> pc.RenderResult:
    return pc.render(plane_scene(material), width=8, height=8, samples=4, max_bounces=3, seed=7)


def test_constant_principled_graph_renders_as_the_fixed_principled():
    """Roughness computed by Math (0.2·2), base colour by Combine Color, IOR on the node:
    the graph folds at load and the image equals pc.Principled's, pixel for pixel."""
    nodes = [
        {"type": "ShaderNodeValue", "name": "Rough", "props": {"value": 0.2}},
        {
            "type": "ShaderNodeMath",
            "name": "Twice",
            "props": {"operation": "MULTIPLY"},
            "inputs": {"Value": {"link": [0, "Value"]}, "Value_001": 2.0},
        },
        {"type": "ShaderNodeCombineColor", "name": "Colour", "inputs": {"Red": 0.7, "Green": 0.3, "Blue": 0.1}},
        {
            "type": "ShaderNodeBsdfPrincipled",
            "name": "Principled BSDF",
            "inputs": {"Base Color": {"link": [2, "Color"]}, "Roughness": {"link": [1, "Value"]}, "Metallic": 0.3, "IOR": 1.45},
        },
    ]
    graph = render(pc.NodeMaterial("Graph", nodes, {"surface": [3, "BSDF"]}))
    fixed = render(pc.Principled((0.7, 0.3, 0.1), roughness=0.4, metallic=0.3, ior=1.45))
    assert graph.rgba.mean() > 0.05
    np.testing.assert_array_equal(graph.rgba, fixed.rgba)


def test_constant_mix_of_emission_and_diffuse_renders_as_the_fixed_mix():
    nodes = [
        {"type": "ShaderNodeEmission", "name": "Glow", "inputs": {"Color": [1.0, 0.5, 0.25, 1.0], "Strength": 2.0}},
        {"type": "ShaderNodeBsdfDiffuse", "name": "Matte", "inputs": {"Color": [0.2, 0.6, 0.4, 1.0]}},
        {
            "type": "ShaderNodeMixShader",
            "name": "Mix",
            "inputs": {"Fac": 0.75, "Shader": {"link": [0, "Emission"]}, "Shader_001": {"link": [1, "BSDF"]}},
        },
    ]
    graph = render(pc.NodeMaterial("Graph", nodes, {"surface": [2, "Shader"]}))
    fixed = render(pc.Mix(pc.Emitter((1.0, 0.5, 0.25), strength=2.0), pc.Diffuse((0.2, 0.6, 0.4)), 0.75, emission=(0.5, 0.25, 0.125)))
    np.testing.assert_allclose(graph.rgba, fixed.rgba, rtol=1e-5, atol=1e-6)


def test_bad_graphs_name_material_and_node():
    cycle = [
        {"type": "ShaderNodeMath", "name": "A", "inputs": {"Value": {"link": [1, "Value"]}}},
        {"type": "ShaderNodeMath", "name": "B", "inputs": {"Value": {"link": [0, "Value"]}}},
        {"type": "ShaderNodeBsdfDiffuse", "name": "D", "inputs": {"Roughness": {"link": [0, "Value"]}}},
    ]
    with pytest.raises(Exception, match=r"(?s)Loop.*cycle.*'A'.*'B'"):
        render(pc.NodeMaterial("Loop", cycle, {"surface": [2, "BSDF"]}))
    bad_socket = [{"type": "ShaderNodeBsdfDiffuse", "name": "D", "inputs": {"Colour": [1, 0, 0]}}]
    with pytest.raises(Exception, match=r"(?s)Typo.*'D'.*Colour"):
        render(pc.NodeMaterial("Typo", bad_socket, {"surface": [0, "BSDF"]}))


def test_unsupported_nodes_warn_once_naming_material_and_node():
    nodes = [
        {"type": "ShaderNodeSomethingNew", "name": "Mystery"},
        {"type": "ShaderNodeBsdfDiffuse", "name": "D", "inputs": {"Roughness": {"link": [0, "Out"]}}},
    ]
    with pytest.warns(UserWarning, match=r"'Odd'.*'Mystery'"):
        render(pc.NodeMaterial("Odd", nodes, {"surface": [1, "BSDF"]}))


def halves_scene(material: pc.Material, **mesh) -> pc.Scene:
    """A unit square filling an orthographic view, u (and the attribute data) running
    left to right, lit only by a uniform white world: a diffuse pixel is its albedo."""
    scene = pc.Scene()
    m = np.eye(4)
    m[2, 3] = 5.0
    scene.camera = pc.Camera(to_world=m, projection="ORTHOGRAPHIC", ortho_scale=1.0)
    v = np.array([[-0.5, -0.5, 0], [0.5, -0.5, 0], [0.5, 0.5, 0], [-0.5, 0.5, 0]], dtype=np.float32)
    uvs = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=np.float32)
    scene.add_mesh("square", v, np.array([[0, 1, 2], [0, 2, 3]]), uvs=uvs, material=material, **mesh)
    scene.set_world(pc.spectra.constant(1.0))
    return scene


def step_colour_graph(vector_node: dict) -> list[dict]:
    """Colour = red where the vector's x > 0.5, else green (Math GREATER_THAN into Mix)."""
    return [
        vector_node,
        {"type": "ShaderNodeSeparateXYZ", "name": "Split", "inputs": {"Vector": {"link": [0, vector_node.get("out", "UV")]}}},
        {
            "type": "ShaderNodeMath",
            "name": "Step",
            "props": {"operation": "GREATER_THAN"},
            "inputs": {"Value": {"link": [1, "X"]}, "Value_001": 0.5},
        },
        {
            "type": "ShaderNodeMix",
            "name": "Pick",
            "props": {"data_type": "RGBA"},
            "inputs": {"Factor_Float": {"link": [2, "Value"]}, "A_Color": [0.1, 0.6, 0.2, 1.0], "B_Color": [0.7, 0.2, 0.1, 1.0]},
        },
        {"type": "ShaderNodeBsdfDiffuse", "name": "Matte", "inputs": {"Color": {"link": [3, "Result_Color"]}}},
    ]


HALVES = dict(width=16, height=8, samples=16, max_bounces=2, seed=3)


def fixed_render(material: pc.Material) -> np.ndarray:
    """The same view of a fixed material, same samples and seed."""
    return pc.render(halves_scene(material), **HALVES).rgba[..., :3]


@pytest.mark.parametrize(
    "vector,mesh",
    [
        ({"type": "ShaderNodeUVMap", "name": "UV"}, {}),
        (
            {"type": "ShaderNodeUVMap", "name": "UV", "props": {"uv_map": "Second"}},
            {"uv_maps": {"Second": [[0, 0], [1, 0], [1, 1], [0, 1]]}},
        ),
        (
            {"type": "ShaderNodeAttribute", "name": "A", "out": "Vector", "props": {"attribute_name": "ramp"}},
            {"attributes": {"ramp": [0.0, 1.0, 1.0, 0.0]}},
        ),
    ],
)
def test_a_uv_driven_colour_renders_its_two_values_in_the_two_halves(vector, mesh):
    """Per-hit evaluation: the left half renders as the fixed green diffuse, the right
    half as the fixed red one (same albedo under a white world), away from the seam."""
    nodes = step_colour_graph(dict(vector))
    for n in nodes:
        n.pop("out", None)
    out = pc.render(halves_scene(pc.NodeMaterial("Halves", nodes, {"surface": [4, "BSDF"]}), **mesh), **HALVES).rgba[..., :3]
    green = fixed_render(pc.Diffuse((0.1, 0.6, 0.2)))
    red = fixed_render(pc.Diffuse((0.7, 0.2, 0.1)))
    np.testing.assert_allclose(out[:, :7], green[:, :7], rtol=1e-4, atol=1e-6)
    np.testing.assert_allclose(out[:, 9:], red[:, 9:], rtol=1e-4, atol=1e-6)


def test_a_checker_driven_roughness_renders_two_glossy_looks():
    """Roughness from a Checker's Fac through Map Range (0.2 or 0.6 in alternate cells)
    on a Glossy BSDF: each cell renders as the fixed Glossy of that roughness."""
    nodes = [
        {"type": "ShaderNodeUVMap", "name": "UV"},
        {"type": "ShaderNodeTexChecker", "name": "Cells", "inputs": {"Vector": {"link": [0, "UV"]}, "Scale": 1.0}},
        {"type": "ShaderNodeMapRange", "name": "Range", "inputs": {"Value": {"link": [1, "Fac"]}, "To Min": 0.2, "To Max": 0.6}},
        {
            "type": "ShaderNodeBsdfAnisotropic",
            "name": "Gloss",
            "inputs": {"Roughness": {"link": [2, "Result"]}, "Color": [0.9, 0.9, 0.9, 1.0]},
        },
    ]
    scene = halves_scene(pc.NodeMaterial("Cells", nodes, {"surface": [3, "BSDF"]}))
    scene.add_light(pc.SunLight(direction=(0.4, 0.1, -1.0), strength=3.0))
    out = pc.render(scene, **HALVES).rgba[..., :3]
    refs = {}
    for r in (0.2, 0.6):
        s = halves_scene(pc.Glossy((0.9, 0.9, 0.9), roughness=r))
        s.add_light(pc.SunLight(direction=(0.4, 0.1, -1.0), strength=3.0))
        refs[r] = pc.render(s, **HALVES).rgba[..., :3]
    assert not np.allclose(refs[0.2], refs[0.6], rtol=1e-2)
    # Each pixel away from the cell edge (u = 0.5) equals one of the two references.
    for half in (np.s_[:, :7], np.s_[:, 9:]):
        matches = [np.allclose(out[half], refs[r][half], rtol=1e-4, atol=1e-6) for r in (0.2, 0.6)]
        assert sum(matches) == 1, matches
    assert not np.allclose(out[:, :7].mean(), out[:, 9:].mean(), rtol=1e-3)


def test_transparent_and_alpha_pass_the_world_through_stochastically():
    """Under a uniform white world (radiance 1) with nothing behind the square: a
    Transparent BSDF of colour c shows what a Diffuse of albedo c shows (both are the
    uplifted reflectance c(λ) times the world), and a Mix Shader of a
    Transparent (weight 1 − Fac) and a black Diffuse passes 1 − Fac of the world, as does
    a black, non-specular Principled with Alpha 0.35 (Cycles' stochastic transparency)."""
    tinted = [{"type": "ShaderNodeBsdfTransparent", "name": "T", "inputs": {"Color": [0.9, 0.5, 0.2, 1.0]}}]
    out = pc.render(halves_scene(pc.NodeMaterial("Tinted", tinted, {"surface": [0, "BSDF"]})), **HALVES).rgba[..., :3]
    diffuse = fixed_render(pc.Diffuse((0.9, 0.5, 0.2)))
    assert np.allclose(out.mean(axis=(0, 1)), diffuse.mean(axis=(0, 1)), atol=0.01), (out.mean(axis=(0, 1)), diffuse.mean(axis=(0, 1)))
    mix = [
        {"type": "ShaderNodeBsdfTransparent", "name": "T"},
        {"type": "ShaderNodeBsdfDiffuse", "name": "D", "inputs": {"Color": [0.0, 0.0, 0.0, 1.0]}},
        {
            "type": "ShaderNodeMixShader",
            "name": "Mix",
            "inputs": {"Fac": 0.3, "Shader": {"link": [0, "BSDF"]}, "Shader_001": {"link": [1, "BSDF"]}},
        },
    ]
    alpha = [
        {
            "type": "ShaderNodeBsdfPrincipled",
            "name": "P",
            "inputs": {"Base Color": [0.0, 0.0, 0.0, 1.0], "Specular IOR Level": 0.0, "Alpha": 0.35},
        }
    ]
    clear = [{"type": "ShaderNodeBsdfTransparent", "name": "T"}]
    world = pc.render(halves_scene(pc.NodeMaterial("Clear", clear, {"surface": [0, "BSDF"]})), **HALVES).rgba[..., :3]
    world = world.mean(axis=(0, 1))  # the world's colour (constant 1 is not RGB white)
    for name, nodes, out_id, passed in (("Mix", mix, [2, "Shader"], 0.7), ("Alpha", alpha, [0, "BSDF"], 0.65)):
        settings = dict(HALVES, samples=256)
        img = pc.render(halves_scene(pc.NodeMaterial(name, nodes, {"surface": out_id})), **settings).rgba[..., :3]
        assert np.allclose(img.mean(axis=(0, 1)), passed * world, atol=0.01), (name, img.mean(axis=(0, 1)), world)


def tangent_strength_graph(uv_map: str | None) -> list[dict]:
    """White emission whose Strength is the y of a Tangent node reading `uv_map`'s
    tangents (None: a constant Strength of 1)."""
    if uv_map is None:
        return [{"type": "ShaderNodeEmission", "name": "Glow", "inputs": {"Color": [1.0, 1.0, 1.0, 1.0], "Strength": 1.0}}]
    return [
        {"type": "ShaderNodeTangent", "name": "T", "props": {"direction_type": "UV_MAP", "uv_map": uv_map}},
        {"type": "ShaderNodeSeparateXYZ", "name": "Split", "inputs": {"Vector": {"link": [0, "Tangent"]}}},
        {
            "type": "ShaderNodeEmission",
            "name": "Glow",
            "inputs": {"Color": [1.0, 1.0, 1.0, 1.0], "Strength": {"link": [1, "Y"]}},
        },
    ]


def test_each_uv_map_has_its_own_tangents():
    """``tangent_maps``: a Tangent node naming a UV map reads that map's tangent set (here
    along y: the emission of Strength = tangent y is the constant Strength 1 one), one
    naming none or a map without a set reads the default ``tangents`` (along x: black)."""
    ones = np.ones((4, 1), np.float32)
    mesh = dict(
        tangents=np.hstack([np.tile([1.0, 0.0, 0.0], (4, 1)), ones]),
        tangent_maps={"B": np.hstack([np.tile([0.0, 1.0, 0.0], (4, 1)), ones])},
        uv_maps={"B": [[0, 0], [0, 1], [1, 1], [1, 0]]},
    )

    def shot(uv_map):
        nodes = tangent_strength_graph(uv_map)
        mat = pc.NodeMaterial(f"T {uv_map}", nodes, {"surface": [len(nodes) - 1, "Emission"]})
        return pc.render(halves_scene(mat, **mesh), **HALVES).rgba[..., :3]

    lit = shot(None)
    assert lit.mean() > 0.5
    np.testing.assert_allclose(shot("B"), lit, rtol=1e-5, atol=1e-6)
    for other in ("", "A"):
        assert np.abs(shot(other)).max() < 1e-6, other
    with pytest.raises(ValueError, match="tangent_maps 'B'"):
        pc.Scene().add_mesh("bad", np.zeros((3, 3)), [[0, 1, 2]], tangent_maps={"B": np.zeros((2, 4))})
