"""Polychrome: a spectral path tracer (Zhdanov et al. 2011) with a Rust core.

Build a :class:`Scene`, then :func:`render` it::

    import polychrome as pc
    scene = pc.Scene()
    ...
    result = pc.render(scene, samples=64, progress=True)
    result.save("out.exr")
"""

__version__ = "0.1.0"

from . import spectra
from .render import RenderResult, RenderSettings, render
from .scene import Camera, Diffuse, Emitter, Material, PointLight, Scene, look_at
from . import denoise, ies, ior
from .scene import Conductor, Dielectric, Glossy, SpotLight, SunLight
from .scene import Add, Fresnel, LayerWeight, Medium, Mix, NodeMaterial, Principled, Volume
from .texture import Texture
from .job import Preview, RenderJob

__all__ = [
    "Camera",
    "Conductor",
    "Dielectric",
    "Glossy",
    "Principled",
    "Mix",
    "Add",
    "Fresnel",
    "LayerWeight",
    "NodeMaterial",
    "Medium",
    "Volume",
    "SpotLight",
    "SunLight",
    "denoise",
    "ies",
    "ior",
    "Diffuse",
    "Emitter",
    "Material",
    "PointLight",
    "Preview",
    "RenderJob",
    "RenderResult",
    "RenderSettings",
    "Scene",
    "Texture",
    "look_at",
    "render",
    "spectra",
]
