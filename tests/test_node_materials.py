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
