"""USD for Polychrome: write a :class:`polychrome.Scene` as a stage that keeps its
spectral data, and render stages Polychrome did not write.

    from polychrome import usd
    usd.write_stage(scene, "scene.usda", settings)   # settings optional
    scene = usd.read_stage("shot.usdc")               # any stage
    settings = polychrome.RenderSettings(**usd.read_settings("shot.usdc"))

Needs usd-core (``pip install 'polychrome[usd]'``). The schema of the ``polychrome:``
attributes is in docs/usd.md and :mod:`polychrome.usd.attributes`.
"""

from . import attributes
from .reader import DescribedLight, DescribedMaterial, read_settings, read_stage
from .writer import write_stage

__all__ = ["DescribedLight", "DescribedMaterial", "attributes", "read_settings", "read_stage", "write_stage"]
