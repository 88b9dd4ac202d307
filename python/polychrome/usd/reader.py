"""Reads any USD stage into a :class:`polychrome.Scene` (``read_stage``).

What is read: UsdGeom meshes (polygons fan-triangulated, holes dropped, GeomSubsets per
material, normals and ``st`` per vertex or face-varying), the intrinsic shapes, BasisCurves
and Points (tubes and spheres, ``basis.py``), transforms
(``ComputeLocalToWorldTransform`` through an XformCache), instanceable prims and
PointInstancers, one UsdGeom.Camera, UsdLux sphere / rect / disk / distant / dome lights,
UsdPreviewSurface materials (networks of UsdUVTexture, UsdTransform2d and UsdPrimvarReader
become shading graphs, ``preview.py``), MaterialX Standard Surface / OpenPBR / glTF PBR
networks (``materialx.py``; referenced ``.mtlx`` documents through ``mtlxdoc.py``) and the
``polychrome:`` attributes (which win). Units are
converted to metres (``metersPerUnit``) and Y-up stages rotated to Z-up.

Unsupported prims are skipped with one ``warnings.warn`` each naming the prim. A prim
whose data is malformed (array lengths, indices, non-finite values, bad JSON) is skipped
with one warning naming it and the problem, and the rest of the stage is read
(``_Reader.guarded``); only a stage that cannot be opened raises ``ValueError``.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any
import warnings

import numpy as np

from ..ior import Ior
from ..scene import Conductor, Dielectric, Diffuse, Emitter, Glossy, Material, PointLight, SpotLight, SunLight
from . import attributes as A

#: Tessellation of the intrinsic shapes (Sphere, Cylinder, Cone).
GPRIM_RINGS, GPRIM_SEGMENTS = 24, 48
# Subdivision surfaces: refinement levels (read_stage's subdivision_level, the CLI's
# --subdivision-level). 2 = Blender's Subdivision Surface render default and usdview's
# "High" complexity; usdview's default ("Low", complexity 1.0) is refine level 0.
DEFAULT_SUBDIVISION_LEVEL, MAX_SUBDIVISION_LEVEL = 2, 6
#: Most faces a refined mesh may have (each level multiplies them by about 4): a prim
#: whose level would exceed it is refined at the highest level within it, with a warning.
MAX_REFINED_FACES = 1 << 24
#: Segments of the polygon standing in for a DiskLight.
DISK_SEGMENTS = 32
#: Sides of the prism standing in for a CylinderLight.
CYLINDER_SEGMENTS = 32
#: UsdPreviewSurface's fallback diffuseColor, used for unbound meshes without displayColor.
FALLBACK_GREY = (0.18, 0.18, 0.18)

_SILENT_TYPES = {
    "",
    "Xform",
    "Scope",
    "Material",
    "Shader",
    "NodeGraph",
    "GeomSubset",
    "RenderSettings",
    "RenderProduct",
    "RenderVar",
    "RenderPass",
    "SkelRoot",
    "Skeleton",
    "SkelAnimation",
    "BlendShape",
    "PhysicsScene",
    "Backdrop",
}
#: Motion keys over the shutter: at most this many, and enough that neighbours turn by
#: at most MAX_KEY_TURN (radians).
MAX_MOTION_KEYS = 33


def PROTOTYPE_PREDICATE(Usd):
    """The prims of a PointInstancer prototype that are drawn, as Hydra chooses them:
    active, loaded, not abstract, with a defining specifier of their own (an ancestor may
    be an `over`)."""
    return Usd.PrimIsActive & Usd.PrimHasDefiningSpecifier & ~Usd.PrimIsAbstract & Usd.PrimIsLoaded


MAX_KEY_TURN = math.pi / 4
#: PointInstancers inside prototypes of PointInstancers: at most this many levels.
MAX_INSTANCER_DEPTH = 8
#: Prims the reader turns into triangle meshes.
GEOMETRY_TYPES = ("Mesh", "Sphere", "Cube", "Cylinder", "Cone", "Capsule", "Capsule_1", "Plane", "BasisCurves", "HermiteCurves", "Points")
_LIGHTS_SKIPPED = {"GeometryLight", "PortalLight", "PluginLight", "MeshLight", "VolumeLight"}


class PrimError(ValueError):
    """Malformed data of one prim: ``read_stage`` skips the prim with a warning."""

    def __init__(self, message: str, where: str, problem: str):
        super().__init__(message)
        self.where, self.problem = where, problem


def _pxr_error_detail(e) -> str:
    """The first message of a pxr Tf.ErrorException, without pxr's namespace noise."""
    import re

    messages = [" ".join(m.split()) for m in re.findall(r" : '(.*?)'\s*(?=\n\s*Error in|$)", str(e), re.S)]
    detail = messages[0] if messages else (str(e).strip().splitlines() or ["USD error"])[0]
    return re.sub(r"pxrInternal_\w+?__pxrReserved__::", "", detail)


def _is_pxr_error(e) -> bool:
    return type(e).__name__ == "ErrorException"


def _is_bad_data(e) -> bool:
    """Exceptions that malformed data of one prim raises: PrimError and other ValueErrors,
    pxr's errors, and TypeErrors (an attribute of an unknown type reads as pxr's
    UnregisteredValue, which is no number and no array)."""
    return isinstance(e, (ValueError, TypeError)) or _is_pxr_error(e)


#: The core's largest vertex coordinate (rust/core geometry::mesh::MAX_COORDINATE).
MAX_COORDINATE = 1e12
#: float32's largest finite value: the core holds transforms and spectra in float32.
F32_MAX = float(np.finfo(np.float32).max)


class DescribedLight:
    """A light kept as the core's description (a type without a Python class here)."""

    def __init__(self, description: dict[str, Any]):
        self.description = dict(description)
        self.name = str(self.description.get("name", "Light"))

    def to_dict(self) -> dict[str, Any]:
        return dict(self.description)

    def __repr__(self) -> str:
        return f"DescribedLight({self.description!r})"


class DescribedMaterial(Material):
    """A material kept as the core's description: any BSDF type the stage names,
    including ones this Python package has no class for."""

    def __init__(self, description: dict[str, Any]):
        self.description = dict(description)
        self.name = str(self.description.get("name", "Material"))
        self.emission = None

    def bsdf_dict(self) -> dict[str, Any]:
        return dict(self.description.get("bsdf") or {"type": "none"})

    def to_dict(self) -> dict[str, Any]:
        return dict(self.description)

    def __repr__(self) -> str:
        return f"DescribedMaterial({self.description!r})"


def material_from_description(d: dict[str, Any]):
    """The polychrome material class for a core description when one reproduces it
    exactly (Diffuse, Emitter, Dielectric, Conductor, Glossy), else a DescribedMaterial."""

    name = d.get("name", "Material")
    bsdf = dict(d.get("bsdf") or {})
    emission = None if d.get("emission") is None else _spectrum_from_dict(d["emission"])
    kind = bsdf.get("type")

    def spec(key):
        v = bsdf[key]
        if isinstance(v, dict) and v.get("type") == "texture":
            return v["texture"]
        return _spectrum_from_dict(v)

    try:
        if kind == "diffuse":
            m = Diffuse(spec("reflectance"), emission=emission, name=name)
        elif kind == "none" and emission is not None:
            m = Emitter(emission, one_sided=bool(d.get("one_sided", False)), see_through=bool(d.get("see_through", False)), name=name)
        elif kind == "dielectric":
            ior = dict(bsdf["ior"])
            m = Dielectric(Ior(str(ior.pop("type")), ior), roughness=bsdf.get("roughness", 0.0), name=name)
        elif kind == "conductor":
            if "metal" in bsdf:
                m = Conductor(bsdf["metal"], roughness=bsdf.get("roughness", 0.0), name=name)
            else:
                m = Conductor(eta=spec("eta"), k=spec("k"), roughness=bsdf.get("roughness", 0.0), name=name)
        elif kind == "glossy":
            m = Glossy(spec("reflectance"), roughness=bsdf.get("roughness", 0.5), name=name)
        else:
            m = None
        if m is not None and kind != "diffuse" and kind != "none" and emission is not None:
            m.emission = emission
        if m is not None and _same(m.to_dict(), d):
            return m
    except (KeyError, TypeError, ValueError):
        pass
    return DescribedMaterial(d)


def _same(a: Any, b: Any) -> bool:
    """Equality of descriptions, where texture objects compare by identity."""
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    if type(a).__name__ == "Texture" or type(b).__name__ == "Texture":
        return a is b
    return a == b


def light_from_description(d: dict[str, Any], power=None, colour=None):
    """The polychrome light class for a core description when one reproduces it exactly
    (PointLight, SpotLight, SunLight), else a DescribedLight."""

    kind = d.get("type")
    name = d.get("name", "Light")
    try:
        if kind in ("point", "spot"):
            if power is not None and colour is not None:
                p, c = float(power), colour
            else:
                p, c = 4.0 * math.pi, _spectrum_from_dict(d["intensity"])
            if kind == "point":
                light = PointLight(list(d["position"]), power=p, color=c, name=name, radius=d.get("radius", 0.0))
            else:
                light = SpotLight(
                    list(d["position"]),
                    list(d["direction"]),
                    power=p,
                    color=c,
                    spot_size=d["spot_size"],
                    spot_blend=d["spot_blend"],
                    name=name,
                    radius=d.get("radius", 0.0),
                )
        elif kind == "distant":
            irradiance = _spectrum_from_dict(d["irradiance"])
            light = SunLight(list(d["direction"]), strength=1.0, color=irradiance, name=name, angle=d.get("angle", 0.0))
        else:
            light = None
        if light is not None and light.to_dict() == d:
            return light
    except (KeyError, TypeError, ValueError, AttributeError):
        pass
    return DescribedLight(d)


def _pxr():
    try:
        from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdRender, UsdShade
    except ImportError as e:  # pragma: no cover
        raise ImportError("polychrome.usd needs usd-core: pip install 'polychrome[usd]'") from e
    return Gf, Sdf, Usd, UsdGeom, UsdLux, UsdRender, UsdShade


def _spectrum_from_dict(d: dict[str, Any]):
    from ..spectra import Spectrum

    d = dict(d)
    kind = d.pop("type")
    scale = float(d.pop("scale", 1.0))
    return Spectrum(str(kind), d, scale)


class _Reader:
    def __init__(self, path: Path, resolution=None, time=None, subdivision_level=None):
        Gf, Sdf, Usd, UsdGeom, UsdLux, UsdRender, UsdShade = _pxr()
        self.Gf, self.Sdf, self.Usd, self.UsdGeom, self.UsdLux, self.UsdRender, self.UsdShade = (
            Gf,
            Sdf,
            Usd,
            UsdGeom,
            UsdLux,
            UsdRender,
            UsdShade,
        )
        from pxr import Ar

        self.Ar = Ar
        self.path = path
        self.stage = open_stage(path)
        # An animation's frame is a time code (Blender writes frame n at time code n).
        self.time = Usd.TimeCode.EarliestTime() if time is None else Usd.TimeCode(float(time))
        self.cache = UsdGeom.XformCache(self.time)
        self.warned: set[str] = set()
        self.mpu = float(UsdGeom.GetStageMetersPerUnit(self.stage))
        if not (math.isfinite(self.mpu) and self.mpu > 0):
            self.warn("mpu", f"metersPerUnit {self.mpu} must be positive; UsdGeom's fallback 0.01 is used")
            self.mpu = 0.01
        up = UsdGeom.GetStageUpAxis(self.stage)
        c = np.eye(4) * self.mpu
        c[3, 3] = 1.0
        if up == UsdGeom.Tokens.y:
            rot = np.array([[1, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1]], dtype=np.float64)
            c = rot @ c
        self.correction = c
        self.identity_correction = bool(np.array_equal(c, np.eye(4)))
        self.resolution = resolution
        self.subdivision_level = _check_level(DEFAULT_SUBDIVISION_LEVEL if subdivision_level is None else subdivision_level)
        # Collected, then turned into a Scene at the end.
        self.materials: list[Any] = []
        self.material_index: dict[str, int] = {}
        self.default_materials: dict[Any, int] = {}
        self.meshes: dict[str, dict[str, Any]] = {}
        self.instances: list[tuple] = []  # (mesh key, matrix, name[, visibility[, prim that moves]])
        self.mesh_prims: dict[str, Any] = {}
        self.key_caches: dict[float, Any] = {}
        # PointInstancer placements: (instancer, first instance, instance ids, prototype-relative matrix).
        self.instancer_runs: list[tuple] = []
        # PointInstancers holding PointInstancers: (instancer, first instance, end), moved
        # over the shutter by re-reading them at each key (nested_motion).
        self.nested_runs: list[tuple] = []
        # The time PointInstancer positions are sampled at (velocities extrapolate from it).
        self.base_time = self.time
        self.lights: list[Any] = []
        self.light_prims: dict[int, Any] = {}  # index in lights → the prim it was read from
        # DomeLights read: (prim path, ("uniform", spectrum) or ("texture", set_world kwargs)).
        self.domes: list[tuple[str, tuple[str, Any]]] = []
        self.cameras: list[Any] = []
        self.textures: dict[str, Any] = {}
        # Files read out of .usdz packages: resolved path → temporary copy (None: absent).
        self.unpacked: dict[str, Path | None] = {}
        self.unpack_dir = None
        # UV sets and primvars some material's network reads (meshes carry them).
        self.uv_names: set[str] = set()
        self.attribute_names: set[str] = set()

    # -- helpers ------------------------------------------------------------------
    def error(self, prim_or_path, problem: str) -> PrimError:
        where = prim_or_path if isinstance(prim_or_path, str) else str(prim_or_path.GetPath())
        return PrimError(f"{self.path}: prim {where}: {problem}", where, problem)

    def skip_message(self, prim, e: Exception, what: str = "it is skipped") -> str:
        """'prim P: problem; it is skipped' for a PrimError (naming the prim that has the
        problem when it is another, e.g. a GeomSubset), a pxr error or a ValueError."""
        path = str(prim.GetPath()) if not isinstance(prim, str) else prim
        if isinstance(e, PrimError):
            at = "" if e.where == path else f"{e.where}: "
            problem = at + e.problem
        elif _is_pxr_error(e):
            problem = _pxr_error_detail(e).replace(str(self.path) + ":", "line ")
        elif isinstance(e, TypeError):
            problem = f"a value of an unusable type ({e})"
        else:
            problem = str(e).replace(f"{self.path}: ", "")
        return f"prim {path}: {problem}; {what}"

    def optional(self, prim, what: str, read):
        """``read()`` of optional data (normals, uvs); malformed (a PrimError, ValueError,
        TypeError or pxr error): None, with one warning naming the prim and that the data is
        ignored."""
        try:
            return read()
        except Exception as e:  # noqa: BLE001 - as guarded
            if not _is_bad_data(e):
                raise
            self.warn(f"bad:{prim.GetPath()}:{what}", self.skip_message(prim, e, f"its {what} are ignored"))
            return None

    def guarded(self, prim, read, what: str = "it is skipped") -> bool:
        """Runs ``read()`` for one prim; malformed data (a PrimError, ValueError or pxr
        error) skips the prim with one warning naming it and the problem: whatever it had
        added (instances, meshes, lights, the world) is taken back. True when it read."""
        state = (
            len(self.instances),
            len(self.lights),
            len(self.instancer_runs),
            set(self.meshes),
            len(self.domes),
        )
        try:
            read()
            return True
        except Exception as e:  # noqa: BLE001 - pxr's Tf.ErrorException is not importable by name
            if not _is_bad_data(e):
                raise
            n_inst, n_lights, n_runs, keys, n_domes = state
            del self.instances[n_inst:], self.lights[n_lights:], self.instancer_runs[n_runs:], self.domes[n_domes:]
            for key in set(self.meshes) - keys:
                if self.meshes[key] is not None:  # a mesh that failed stays None: not retried
                    del self.meshes[key]
                    self.mesh_prims.pop(key, None)
            path = str(prim.GetPath())
            self.warn(f"bad:{path}", self.skip_message(prim, e, what))
            return False

    def warn(self, key: str, message: str) -> None:
        if key in self.warned:
            return
        self.warned.add(key)
        warnings.warn(f"{self.path}: {message}", stacklevel=4)

    def world_matrix(self, prim) -> np.ndarray:
        """Object → world as polychrome wants it: column vectors, metres, Z up."""
        m = np.array(self.cache.GetLocalToWorldTransform(prim), dtype=np.float64).T
        if not self.identity_correction:
            m = self.correction @ m
        if not np.all(np.isfinite(m)):
            raise self.error(prim, "its transform is not finite")
        return m

    def get(self, attr, default=None):
        if attr and not attr.HasAuthoredValue() and attr.GetName().startswith("inputs:"):
            # UsdLux before 21.02 named its attributes without "inputs:".
            legacy = attr.GetPrim().GetAttribute(attr.GetName()[len("inputs:") :])
            if legacy and legacy.HasAuthoredValue():
                attr = legacy
        if not attr or not attr.HasAuthoredValue() and not attr.HasFallbackValue():
            return default
        v = attr.Get(self.time)
        return default if v is None else v

    def custom(self, prim, name: str, default=None):
        attr = prim.GetAttribute(name)
        if not attr or not attr.HasAuthoredValue():
            return default
        v = attr.Get(self.time)
        return default if v is None else v

    def json_attr(self, prim, name: str):
        text = self.custom(prim, name)
        if text is None:
            return None
        try:
            return json.loads(str(text))
        except json.JSONDecodeError as e:
            raise self.error(prim, f"{name} is not valid JSON ({e.msg})") from None

    def spectrum_attr(self, prim, name: str):
        """A spectrum from ``name`` (JSON) or ``name:wavelengths`` + ``name:values``."""
        from ..spectra import tabulated

        d = self.json_attr(prim, name)
        if d is not None:
            if not isinstance(d, dict) or "type" not in d:
                raise self.error(prim, f"{name} must be a JSON spectrum description with a 'type'")
            return _spectrum_from_dict(d)
        wl, vals = self.custom(prim, name + ":wavelengths"), self.custom(prim, name + ":values")
        if wl is None or vals is None:
            return None
        wl, vals = np.asarray(wl, np.float64), np.asarray(vals, np.float64)
        if wl.shape != vals.shape or wl.size < 1 or not (np.all(np.isfinite(wl)) and np.all(np.isfinite(vals))):
            raise self.error(prim, f"{name}:wavelengths and {name}:values must be finite arrays of one length")
        if np.any(np.diff(wl) <= 0):
            raise self.error(prim, f"{name}:wavelengths must be ascending")
        return tabulated(wl, vals)

    @staticmethod
    def key_of(prim) -> str:
        return str(prim.GetPrimInPrototype().GetPath() if prim.IsInstanceProxy() else prim.GetPath())

    # -- materials -------------------------------------------------------------------
    def add_material(self, material) -> int:
        self.materials.append(material)
        return len(self.materials) - 1

    def material_for(self, mat_prim) -> int:
        key = self.key_of(mat_prim)
        if key not in self.material_index:
            try:
                material = self.read_material(mat_prim)
            except Exception as e:  # noqa: BLE001 - as guarded: malformed data, one warning
                if not _is_bad_data(e):
                    raise
                self.warn(f"bad:{mat_prim.GetPath()}", self.skip_message(mat_prim, e, "UsdPreviewSurface's fallback 0.18 grey is used"))
                from ..spectra import rgb

                material = Diffuse(rgb(*FALLBACK_GREY), name=str(mat_prim.GetPath()))
            self.material_index[key] = self.add_material(material)
        return self.material_index[key]

    def display_primvar(self, prim, name: str, width: int):
        """(mean, varies) of a displayColor / displayOpacity primvar, or None."""
        try:
            c = _primvar_values(self.UsdGeom.PrimvarsAPI(prim).GetPrimvar(name), self.time)
            if c is None or not len(c):
                return None
            arr = np.asarray(c, np.float64).reshape(-1, width)
        except (TypeError, ValueError):  # malformed optional data: dropped, one warning
            self.warn(
                f"bad:{prim.GetPath()}:{name}", f"prim {prim.GetPath()}: {name} is not an array of {width}-value items; it is ignored"
            )
            return None
        if not np.all(np.isfinite(arr)):
            return None
        varies = len(arr) > 1 and float(np.ptp(arr, axis=0).max()) > 0 and prim.GetTypeName() in ("Mesh", "BasisCurves", "Points")
        return tuple(float(x) for x in arr.mean(axis=0)), varies

    def default_material(self, prim) -> int:
        """UsdPreviewSurface's fallback for an unbound gprim: a diffuse of its
        ``displayColor`` (0.18 grey without) and coverage ``displayOpacity``, read per
        vertex / face (the graph's Attribute node) when they vary over the mesh."""
        from ..spectra import rgb

        colour = self.display_primvar(prim, "displayColor", 3) or (FALLBACK_GREY, False)
        opacity = self.display_primvar(prim, "displayOpacity", 1)
        if opacity is not None and not opacity[1] and opacity[0][0] >= 1.0:
            opacity = None
        if not colour[1] and opacity is None:
            c = colour[0]
            if c not in self.default_materials:
                self.default_materials[c] = self.add_material(Diffuse(rgb(*c), name=f"displayColor {c}"))
            return self.default_materials[c]
        key = (
            "display",
            colour[0] if not colour[1] else "varying",
            None if opacity is None else opacity[0] if not opacity[1] else "varying",
        )
        if key not in self.default_materials:
            self.default_materials[key] = self.add_material(self.display_material(colour, opacity))
        return self.default_materials[key]

    def display_material(self, colour, opacity):
        from ..scene import NodeMaterial

        nodes: list[dict[str, Any]] = []
        if colour[1]:
            self.attribute_names.add("displayColor")
            nodes.append({"type": "ShaderNodeAttribute", "name": "displayColor", "props": {"attribute_name": "displayColor"}})
            base: Any = {"link": [0, "Color"]}
        else:
            base = list(colour[0])
        if opacity is None:
            nodes.append({"type": "ShaderNodeBsdfDiffuse", "name": "Diffuse", "inputs": {"Color": base}})
            return NodeMaterial("displayColor", nodes, {"surface": [len(nodes) - 1, "BSDF"]})
        if opacity[1]:
            self.attribute_names.add("displayOpacity")
            nodes.append({"type": "ShaderNodeAttribute", "name": "displayOpacity", "props": {"attribute_name": "displayOpacity"}})
            alpha: Any = {"link": [len(nodes) - 1, "Fac"]}
        else:
            alpha = float(opacity[0][0])
        # A Lambertian base (no specular layer) whose coverage is the opacity.
        inputs = {"Base Color": base, "Alpha": alpha, "Specular IOR Level": 0.0}
        nodes.append({"type": "ShaderNodeBsdfPrincipled", "name": "displayColor", "inputs": inputs})
        return NodeMaterial("displayColor, displayOpacity", nodes, {"surface": [len(nodes) - 1, "BSDF"]})

    def bound_material(self, prim) -> int:
        # The 'full' (final render) binding, falling back to the all-purpose one.
        mat, _ = self.UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial(self.UsdShade.Tokens.full)
        if mat and mat.GetPrim().IsValid():
            return self.material_for(mat.GetPrim())
        return self.default_material(prim)

    def texture_source(self, inp):
        """The UsdUVTexture shader driving ``inp``, or None."""
        sources = inp.GetConnectedSources()[0] if inp and inp.HasConnectedSource() else []
        if not sources:
            return None
        src = self.UsdShade.Shader(sources[0].source.GetPrim())
        if src and src.GetShaderId() == "UsdUVTexture":
            return src
        return None

    def asset_path(self, attr_value, prim, what: str) -> Path | None:
        """An SdfAssetPath as a file path (resolved, or relative to the stage's layer);
        None, after one warning naming the prim and the file, when there is no such file."""
        resolved = getattr(attr_value, "resolvedPath", "") or ""
        raw = getattr(attr_value, "path", "") or str(attr_value or "")
        if resolved and self.Ar.IsPackageRelativePath(resolved):
            return self.packaged_file(resolved, prim, what, raw)
        if resolved:
            return Path(resolved)
        p = Path(raw)
        if not p.is_absolute():
            p = Path(self.stage.GetRootLayer().realPath or self.path).parent / p
        if not p.is_file():
            self.warn(f"missing:{prim.GetPath()}:{raw}", f"prim {prim.GetPath()}: {what} {raw!r} does not exist; its fallback is used")
            return None
        return p

    def packaged_file(self, resolved: str, prim, what: str, raw: str) -> Path | None:
        """A file inside a package (``pkg.usdz[textures/x.png]``, nested packages too),
        read through Ar and copied to a temporary directory the reader owns (the texture
        loaders read paths and choose the format by suffix; textures are read eagerly)."""
        if resolved in self.unpacked:
            return self.unpacked[resolved]
        asset = self.Ar.GetResolver().OpenAsset(self.Ar.ResolvedPath(resolved))
        data = asset.GetBuffer() if asset is not None else None
        if data is None:
            self.warn(
                f"missing:{prim.GetPath()}:{raw}", f"prim {prim.GetPath()}: {what} {resolved!r} is not in its package; its fallback is used"
            )
            self.unpacked[resolved] = None
            return None
        if self.unpack_dir is None:
            import tempfile

            self.unpack_dir = tempfile.TemporaryDirectory(prefix="polychrome-usdz-")  # removed with the reader
        inner = self.Ar.SplitPackageRelativePathInner(resolved)[1]
        out = Path(self.unpack_dir.name) / str(len(self.unpacked)) / Path(inner).name  # keeps the file's name
        out.parent.mkdir()
        out.write_bytes(bytes(data))
        self.unpacked[resolved] = out
        return out

    def texture_input(self, shader, name: str, material_prim):
        """A polychrome.Texture for an input driven by a UsdUVTexture, or None (no file,
        a missing or unreadable one: the input's fallback is used)."""
        from ..texture import Texture

        tex = self.texture_source(shader.GetInput(name))
        if tex is None:
            return None
        key = str(tex.GetPath())
        if key in self.textures:
            return self.textures[key]
        self.textures[key] = None  # warn once, whatever happens below
        file_input = tex.GetInput("file")
        value = file_input.Get(self.time) if file_input else None
        if value is None or not (getattr(value, "path", "") or ""):
            self.warn(f"texfile:{key}", f"prim {tex.GetPath()}: UsdUVTexture without a file; {name} uses its fallback")
            return None
        path = self.asset_path(value, tex.GetPrim(), "texture file")
        if path is None:
            return None
        wrap_in = tex.GetInput("wrapS")
        wrap = str(wrap_in.Get(self.time)) if wrap_in and wrap_in.Get(self.time) is not None else "repeat"
        mode = {"repeat": "REPEAT", "black": "CLIP", "clamp": "EXTEND"}.get(wrap, "REPEAT")
        if wrap == "mirror":
            self.warn(f"mirror:{key}", f"prim {tex.GetPath()}: mirror wrapping is not supported; repeat is used")
        for unsupported in ("scale", "bias"):
            i = tex.GetInput(unsupported)
            if i and i.Get(self.time) is not None:
                self.warn(f"{unsupported}:{key}", f"prim {tex.GetPath()}: texture {unsupported} is not supported and is ignored")
        try:
            texture = Texture.from_file(path, wrap=mode, name=str(self.custom(tex.GetPrim(), A.NAME, path.name)))
        except (OSError, ValueError) as e:
            self.warn(f"unreadable:{key}", f"prim {tex.GetPath()}: cannot read texture {path} ({e}); its fallback is used")
            return None
        self.textures[key] = texture
        return texture

    def read_material(self, prim):
        from ..spectra import rgb

        name = str(self.custom(prim, A.NAME, str(prim.GetPath())))
        kind = self.custom(prim, A.BSDF)
        reflectance = self.spectrum_attr(prim, A.REFLECTANCE)
        emission = self.spectrum_attr(prim, A.EMISSION)
        ior = self.read_ior(prim)
        extra = self.json_attr(prim, A.BSDF_EXTRA)
        if extra is not None and not isinstance(extra, dict):
            raise self.error(prim, f"{A.BSDF_EXTRA} must be a JSON object")
        surface = self.UsdShade.Material(prim).ComputeSurfaceSource()
        surface_shader = surface[0] if surface and surface[0] and surface[0].GetShaderId() == "UsdPreviewSurface" else None
        if kind is not None:
            kind = str(kind)
            bsdf: dict[str, Any] = {"type": kind, **(extra or {})}
            if reflectance is not None:
                bsdf["reflectance"] = reflectance.to_dict()
            elif surface_shader is not None:
                texture = self.texture_input(surface_shader, "diffuseColor", prim)
                if texture is not None:
                    bsdf["reflectance"] = texture.to_dict()
            if ior is not None:
                bsdf["ior"] = {**ior, **(bsdf.get("ior") or {})}
            d = {"name": name, "bsdf": bsdf}
            if emission is not None:
                d["emission"] = emission.to_dict()
            if self.custom(prim, A.ONE_SIDED, False):
                d["one_sided"] = True
            if self.custom(prim, A.SEE_THROUGH, False):
                d["see_through"] = True
            return material_from_description(d)

        # Plain UsdPreviewSurface, with polychrome spectra where given.
        diffuse, emissive, opacity, ior_value, metallic, roughness = FALLBACK_GREY, (0.0, 0.0, 0.0), 1.0, 1.5, 0.0, 0.5
        shader = None
        from . import materialx

        # The "mtlx" surface when it is one materialx.py translates (Houdini writes a
        # UsdPreviewSurface approximation on the universal surface beside the MaterialX
        # network: the network is the material), else the universal one.
        surface = self.UsdShade.Material(prim).ComputeSurfaceSource("mtlx")  # falls back to universal
        if not (surface and surface[0] and materialx.translates(str(surface[0].GetShaderId()))):
            universal = self.UsdShade.Material(prim).ComputeSurfaceSource()
            if universal and universal[0]:
                surface = universal
        if surface and surface[0]:
            shader = surface[0]
            shader_id = shader.GetShaderId()

            if materialx.is_materialx(str(shader_id)):
                material = materialx.build(self, prim, shader, name)
                if reflectance is not None or emission is not None:
                    self.warn(
                        f"graphspec:{self.key_of(prim)}",
                        f"prim {prim.GetPath()}: polychrome: spectra are not applied to a MaterialX surface",
                    )
                return material
            if shader_id not in ("UsdPreviewSurface", "ND_UsdPreviewSurface_surfaceshader"):
                what = f"'{shader_id}'"
                if shader_id is None:  # info:implementationSource sourceAsset / sourceCode (glslfx, OSL, ...)
                    source = shader.GetImplementationSource()
                    assets = [shader.GetSourceAsset(t) for t in (shader.GetSourceTypes() or [""])] if source == "sourceAsset" else []
                    named = [a.path for a in assets if a]
                    what = f"with sourceAsset '{named[0]}'" if named else f"with {source} and no id"
                self.warn(
                    f"shader:{self.key_of(prim)}",
                    f"prim {prim.GetPath()}: surface shader {what} is not supported; rendered as grey diffuse",
                )
                shader = None
        else:
            # Only a render context's surface (MaterialX "mtlx", "ri", ...): not readable.
            others = [o.GetAttr().GetName() for o in self.UsdShade.Material(prim).GetSurfaceOutputs() if o.HasConnectedSource()]
            if others:
                self.warn(
                    f"shader:{self.key_of(prim)}",
                    f"prim {prim.GetPath()}: its surface is only given for render contexts ({', '.join(others)}), which are not supported; rendered as grey diffuse",
                )
        if shader is not None:
            from . import preview

            # MaterialX's definition of UsdPreviewSurface reads MaterialX pattern nodes too.
            mx_graph = materialx.MxGraph if str(shader.GetShaderId()).startswith("ND_") else None
            graph, consts = preview.build(self, prim, shader, name, graph_class=mx_graph)
            if graph is not None:
                if reflectance is not None or emission is not None:
                    self.warn(
                        f"graphspec:{self.key_of(prim)}",
                        f"prim {prim.GetPath()}: polychrome: spectra are not applied to a textured UsdPreviewSurface",
                    )
                return graph
            as3 = lambda v: tuple(float(x) for x in v)[:3] if isinstance(v, tuple) else (float(v),) * 3  # noqa: E731
            as1 = lambda v: float(v[0]) if isinstance(v, tuple) else float(v)  # noqa: E731
            diffuse, emissive = as3(consts["diffuseColor"]), as3(consts["emissiveColor"])
            opacity, ior_value = as1(consts["opacity"]), as1(consts["ior"])
            metallic, roughness = as1(consts["metallic"]), as1(consts["roughness"])
        values = [*diffuse, *emissive, opacity, ior_value, metallic, roughness]
        if not all(math.isfinite(v) for v in values):
            raise self.error(prim, "its UsdPreviewSurface inputs are not finite")
        if emission is None and max(emissive) > 0.0:
            emission = rgb(*emissive)
        if reflectance is None:
            reflectance = rgb(*(min(max(c, 0.0), 1.0) for c in diffuse))
        rough = min(max(float(roughness), 0.0), 1.0)
        if ior is not None or opacity < 1.0:
            # UsdPreviewSurface transparency: a clear (or rough) glass of index `ior`.
            if opacity > 0.0 and ior is None:
                self.warn(f"opacity:{self.key_of(prim)}", f"prim {prim.GetPath()}: partial opacity {opacity:g} is rendered as clear glass")
            desc = {
                "name": name,
                "bsdf": {
                    "type": "dielectric",
                    "ior": ior if ior is not None else {"type": "constant", "ior": float(ior_value)},
                    "roughness": rough,
                },
            }
            if emission is not None:
                desc["emission"] = emission.to_dict()
            return material_from_description(desc)
        if metallic > 0.5:
            # UsdPreviewSurface metal: Fresnel tinted by the base colour (Blender's Glossy).
            desc = {
                "name": name,
                "bsdf": {
                    "type": "glossy",
                    "reflectance": reflectance.to_dict() if hasattr(reflectance, "kind") else rgb(*diffuse).to_dict(),
                    "roughness": rough,
                },
            }
            if emission is not None:
                desc["emission"] = emission.to_dict()
            return material_from_description(desc)
        if metallic > 0.0:
            self.warn(f"metal:{self.key_of(prim)}", f"prim {prim.GetPath()}: metallic {metallic:g} is rendered as diffuse (below 0.5)")
        return Diffuse(reflectance, emission=emission, name=name)

    def read_ior(self, prim) -> dict[str, Any] | None:
        model = self.custom(prim, A.IOR_MODEL)
        if model is None:
            return None
        model = str(model)
        coeffs = self.custom(prim, A.IOR_COEFFICIENTS)
        c = None if coeffs is None else [float(x) for x in coeffs]
        if c is not None and not all(math.isfinite(x) for x in c):
            raise self.error(prim, f"{A.IOR_COEFFICIENTS} are not finite")
        need = {"constant": 1, "cauchy": 3, "sellmeier": 6, "abbe": 2}
        if model in need and (c is None or len(c) != need[model]):
            raise self.error(
                prim, f"{A.IOR_COEFFICIENTS} of the {model} model needs {need[model]} values, got {0 if c is None else len(c)}"
            )
        if model == "constant":
            return {"type": "constant", "ior": c[0]}
        if model == "cauchy":
            return {"type": "cauchy", "a": c[0], "b": c[1], "c": c[2]}
        if model == "sellmeier":
            return {"type": "sellmeier", "b": c[:3], "c": c[3:]}
        if model == "abbe":
            return {"type": "abbe", "nd": c[0], "vd": c[1]}
        if model == "named":
            glass = self.custom(prim, A.IOR_NAME)
            if glass is None:
                raise self.error(prim, f"the named ior model needs {A.IOR_NAME}")
            return {"type": "named", "name": str(glass)}
        d: dict[str, Any] = {"type": model}
        if c is not None:
            d["coefficients"] = c
        return d

    # -- meshes ------------------------------------------------------------------------
    def primvar(self, prim, name: str, what: str, n_points: int, n_corners: int, n_faces: int, width: int):
        """(array, interpolation) of a primvar, flattened; None when absent or unusable."""
        pv = self.UsdGeom.PrimvarsAPI(prim).GetPrimvar(name)
        if not pv or not pv.HasValue():
            return None
        value = pv.ComputeFlattened(self.time)
        if value is None:
            return None
        arr = np.asarray(value, dtype=np.float32)
        if arr.size == 0:
            return None
        arr = arr.reshape(-1, width) if arr.size % width == 0 else None
        if arr is None:
            raise self.error(prim, f"{what} has a size that is not a multiple of {width}")
        return self.check_interp(prim, arr, pv.GetInterpolation(), what, n_points, n_corners, n_faces)

    def check_interp(self, prim, arr, interp, what, n_points, n_corners, n_faces):
        expected = {"vertex": n_points, "varying": n_points, "faceVarying": n_corners, "uniform": n_faces, "constant": 1}.get(str(interp))
        if expected is None:
            return None
        if len(arr) != expected:
            raise self.error(prim, f"{what} has {len(arr)} values for {interp} interpolation; expected {expected}")
        if not np.all(np.isfinite(arr)):
            bad = int(np.argwhere(~np.all(np.isfinite(arr), axis=1))[0][0])
            raise self.error(prim, f"{what}[{bad}] is not finite")
        if interp in ("uniform", "constant"):
            return None  # flat data: the geometric normal / no texture variation does the same
        # "varying" is per vertex too; subdivision surfaces interpolate it linearly (subdivide).
        return arr, {"faceVarying": "corner", "varying": "varying"}.get(str(interp), "vertex")

    def gprim_arrays(self, prim) -> dict[str, Any] | None:
        """Triangles for the intrinsic UsdGeom shapes (Sphere, Cube, Cylinder, Cone, Capsule, Plane)."""
        t = str(prim.GetTypeName())
        attr = lambda name, default: float(self.get(prim.GetAttribute(name), default))  # noqa: E731
        normals = None
        if t == "Sphere":
            r = attr("radius", 1.0)
            rings, segments = GPRIM_RINGS, GPRIM_SEGMENTS
            theta = np.linspace(0.0, math.pi, rings + 1)
            phi = np.linspace(0.0, 2 * math.pi, segments + 1)
            th, ph = np.meshgrid(theta, phi, indexing="ij")
            unit = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], -1).reshape(-1, 3)
            a = (np.arange(rings)[:, None] * (segments + 1) + np.arange(segments)[None, :]).ravel()
            b = a + segments + 1
            tris = np.concatenate([np.stack([a, b, a + 1], 1), np.stack([a + 1, b, b + 1], 1)])
            verts, normals, dims = unit * r, unit, [r]
        elif t == "Cube":
            h = attr("size", 2.0) / 2
            verts = np.array([[x, y, z] for z in (-h, h) for y in (-h, h) for x in (-h, h)], np.float64)
            quads = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
            tris = np.array([[q[0], q[1], q[2]] for q in quads] + [[q[0], q[2], q[3]] for q in quads])
            dims = [h]
        elif t in ("Cylinder", "Cone"):
            r, height = attr("radius", 1.0), attr("height", 2.0)
            n = GPRIM_SEGMENTS
            ang = np.linspace(0.0, 2 * math.pi, n, endpoint=False)
            ring = np.stack([np.cos(ang) * r, np.sin(ang) * r], 1)
            bottom = np.concatenate([ring, np.full((n, 1), -height / 2)], 1)
            top = np.concatenate([ring if t == "Cylinder" else ring * 0.0, np.full((n, 1), height / 2)], 1)
            centres = np.array([[0.0, 0.0, -height / 2], [0.0, 0.0, height / 2]])
            verts = np.concatenate([bottom, top, centres])
            k = np.arange(n)
            k1 = (k + 1) % n
            side = np.concatenate([np.stack([k, k1, n + k1], 1), np.stack([k, n + k1, n + k], 1)])
            cap_b = np.stack([np.full(n, 2 * n), k1, k], 1)
            cap_t = np.stack([np.full(n, 2 * n + 1), n + k, n + k1], 1)
            tris = np.concatenate([side, cap_b] + ([cap_t] if t == "Cylinder" else []))
            dims = [r, height]
        elif t in ("Capsule", "Capsule_1"):
            # The spine of length ``height`` along the axis, capped by hemispheres of ``radius``.
            if t == "Capsule":
                r = attr("radius", 0.5)
            else:
                r_top, r_bottom = attr("radiusTop", 0.5), attr("radiusBottom", 0.5)
                if r_top != r_bottom:
                    self.warn(f"capsule:{prim.GetPath()}", f"prim {prim.GetPath()}: a capsule with two radii is read with their mean")
                r = 0.5 * (r_top + r_bottom)
            height = attr("height", 1.0)
            half = GPRIM_RINGS // 2
            theta = np.concatenate([np.linspace(0.0, math.pi / 2, half + 1), np.linspace(math.pi / 2, math.pi, half + 1)])
            rings = len(theta) - 1
            phi = np.linspace(0.0, 2 * math.pi, GPRIM_SEGMENTS + 1)
            th, ph = np.meshgrid(theta, phi, indexing="ij")
            unit = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], -1)
            offset = np.where(np.arange(rings + 1) <= half, height / 2, -height / 2)
            verts = (unit * r + np.stack([0 * offset, 0 * offset, offset], -1)[:, None, :]).reshape(-1, 3)
            unit = unit.reshape(-1, 3)
            segments = GPRIM_SEGMENTS
            a = (np.arange(rings)[:, None] * (segments + 1) + np.arange(segments)[None, :]).ravel()
            b = a + segments + 1
            tris = np.concatenate([np.stack([a, b, a + 1], 1), np.stack([a + 1, b, b + 1], 1)])
            normals, dims = unit, [r, height]
        elif t == "Plane":
            w, length = attr("width", 2.0) / 2, attr("length", 2.0) / 2
            verts = np.array([[-w, -length, 0], [w, -length, 0], [w, length, 0], [-w, length, 0]], np.float64)
            tris = np.array([[0, 1, 2], [0, 2, 3]])
            dims = [w, length]
        else:
            return None
        if not all(math.isfinite(d) for d in dims):
            raise self.error(prim, "its size is not finite")
        axis = str(self.get(prim.GetAttribute("axis"), "Z")) if t != "Sphere" and t != "Cube" else "Z"
        perm = {"X": [2, 0, 1], "Y": [1, 2, 0]}.get(axis)
        if perm is not None:  # a cyclic permutation keeps the winding: local Z becomes the axis
            verts = verts[:, perm]
            normals = None if normals is None else normals[:, perm]
        material = self.bound_material(prim)
        uv_maps, attrs = self.implicit_primvars(prim, len(verts), material)
        return {
            "name": str(prim.GetPath()),
            "order": None,
            "vertices": verts.astype(np.float32),
            "triangles": tris.astype(np.int64),
            "normals": None if normals is None else normals.astype(np.float32),
            "uvs": None,
            "uv_maps": uv_maps,
            "attributes": attrs,
            "material_ids": None,
            "material": material,
        }

    def implicit_primvars(self, prim, n_vertices: int, material):
        """(uv_maps, attributes) of an intrinsic shape (Sphere, Cube, ...): the primvars its
        material's network reads, each of one value (constant, or any interpolation with
        a single value) on every tessellated vertex. A missing one is the primvar reader's
        fallback, with one warning as on meshes; one of several values (varying over a
        shape USD does not tessellate for us) is its mean, with one warning."""
        if material is None:
            return None, None
        mat = self.materials[material]
        reads = getattr(mat, "usd_primvar_reads", ())
        api = self.UsdGeom.PrimvarsAPI(prim)
        where = prim.GetPath()
        out: dict[tuple[str, str], np.ndarray] = {}
        for kind, name in sorted(reads):
            pv = api.GetPrimvar(name)
            value = _primvar_values(pv, self.time)
            if value is None or len(value) == 0:
                reader, fb = mat.usd_primvar_fallbacks[(kind, name)]
                self.warn(
                    f"noprimvar:{where}:{name}",
                    f"prim {where}: primvar '{name}' read by {reader} (material '{mat.name}') is missing; "
                    f"the reader's fallback {fb} is used",
                )
                arr = np.asarray(fb, np.float32).reshape(1, -1)
            else:
                arr = np.asarray(value, np.float32)
                arr = arr.reshape(len(arr), -1)
                if not np.all(np.isfinite(arr)):
                    raise self.error(prim, f"primvars:{name} is not finite")
                if len(arr) > 1:
                    self.warn(
                        f"implicitpv:{where}:{name}",
                        f"prim {where}: primvars:{name} has {len(arr)} {pv.GetInterpolation()} values on a {prim.GetTypeName()}, "
                        "which is tessellated without its parameterisation; their mean is used",
                    )
                    arr = arr.mean(axis=0, keepdims=True)
            if kind == "uv":
                arr = arr[:, :2]
            out[(kind, name)] = np.repeat(arr, n_vertices, axis=0)
        uv_maps = {k[1]: v for k, v in out.items() if k[0] == "uv"} or None
        attrs = {k[1]: (v if v.shape[1] > 1 else v[:, 0]) for k, v in out.items() if k[0] == "attr"} or None
        return uv_maps, attrs

    def finite_points(self, prim, attr, what: str):
        raw = attr.Get(self.time)
        if raw is None or len(raw) == 0:
            return None
        pts = np.asarray(raw, dtype=np.float64).reshape(-1, 3)
        if not np.all(np.isfinite(pts)):
            bad = int(np.argwhere(~np.all(np.isfinite(pts), axis=1))[0][0])
            raise self.error(prim, f"{what} {bad} is not finite")
        return pts

    def widths(self, prim, schema, expected: dict[str, int], n_vertices: int):
        """(widths, interpolation) of a Curves / Points prim: ``expected`` counts per
        interpolation; unauthored widths are 1 scene unit (Hydra's fallback)."""
        attr = schema.GetWidthsAttr()
        raw = attr.Get(self.time) if attr and attr.HasAuthoredValue() else None
        if raw is None or len(raw) == 0:
            return np.ones(n_vertices), "vertex"
        w = np.asarray(raw, dtype=np.float64).ravel()
        interp = str(schema.GetWidthsInterpolation())
        if interp not in expected:
            interp = "vertex"
        if len(w) == 1 and interp != "uniform":
            interp = "constant"
        if len(w) != expected.get(interp, -1) or not np.all(np.isfinite(w)) or w.min() < 0:
            raise self.error(
                prim, f"widths has {len(w)} values for {interp} interpolation; expected {expected.get(interp)} finite, non-negative ones"
            )
        return w, interp

    def curves_arrays(self, prim) -> dict[str, Any] | None:
        """UsdGeom.BasisCurves → tubes (``Scene.add_curves`` tessellation) along the
        curves as the basis evaluates them (polychrome.usd.basis); width = diameter."""
        from .. import curves as pc_curves
        from . import basis as B

        hermite = prim.GetTypeName() == "HermiteCurves"
        c = self.UsdGeom.HermiteCurves(prim) if hermite else self.UsdGeom.BasisCurves(prim)
        pts = self.finite_points(prim, c.GetPointsAttr(), "point")
        counts_raw = c.GetCurveVertexCountsAttr().Get(self.time)
        if pts is None or counts_raw is None or len(counts_raw) == 0:
            if (pts is None) != (counts_raw is None or len(counts_raw) == 0):  # one without the other: malformed
                have, lack = ("points", "curveVertexCounts") if pts is not None else ("curveVertexCounts", "points")
                raise self.error(prim, f"it has {have} but no {lack}")
            return None
        counts = np.asarray(counts_raw, dtype=np.int64)
        if counts.min() < 0 or int(counts.sum()) != len(pts):
            raise self.error(prim, f"curveVertexCounts add up to {int(counts.sum())} but there are {len(pts)} points")
        if hermite:
            ctype, basis, wrap = "cubic", "bezier", "nonperiodic"  # converted below
        else:
            ctype = str(self.get(c.GetTypeAttr(), "cubic"))
            basis = str(self.get(c.GetBasisAttr(), "bezier"))
            wrap = str(self.get(c.GetWrapAttr(), "nonperiodic"))
        if ctype == "cubic" and basis not in B.CUBIC_BASES:
            self.warn(f"basis:{prim.GetPath()}", f"prim {prim.GetPath()}: curve basis '{basis}' is not supported; read as catmullRom")
            basis = "catmullRom"
        if ctype not in ("linear", "cubic"):
            ctype = "cubic"
        if self.get(c.GetNormalsAttr()) is not None:
            self.warn(f"ribbon:{prim.GetPath()}", f"prim {prim.GetPath()}: oriented curves (normals) are rendered as round tubes")
        by_count = {int(n): B.varying_count(int(n), ctype, basis, wrap) for n in np.unique(counts)}
        varying = [by_count[int(n)] for n in counts]
        if hermite:  # one value per point for vertex and varying alike (a segment per point pair)
            varying = [int(n) for n in counts]
        w, interp = self.widths(prim, c, {"constant": 1, "uniform": len(counts), "vertex": len(pts), "varying": sum(varying)}, len(pts))
        if interp == "constant":
            w = np.full(len(pts), w[0])
        elif interp == "uniform":
            w = np.repeat(w, counts)
        if (ctype == "linear" or hermite) and interp == "varying":
            interp = "vertex"
        if hermite:
            pts, w, counts = self.hermite_to_bezier(prim, c, pts, w, counts)
            varying = [B.varying_count(int(n), ctype, basis, wrap) for n in counts]
        starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
        varying = np.asarray(varying, np.int64)
        vstarts = np.concatenate([[0], np.cumsum(varying)[:-1]])
        # Curves of the same vertex count are evaluated together (hair: usually all).
        keys, radii, out_counts, kept, skipped = [], [], [], [], 0
        for n_vertices in np.unique(counts):
            which = np.nonzero(counts == n_vertices)[0]
            gather = starts[which][:, None] + np.arange(n_vertices)[None, :]
            if interp == "varying":
                nv = int(varying[which[0]])
                wi = w[vstarts[which][:, None] + np.arange(nv)[None, :]]
            else:
                wi = w[gather]
            ev = B.evaluate_curves(pts[gather], wi, interp == "varying", ctype, basis, wrap)
            if ev is None:
                skipped += len(which)
                continue
            keys.append(ev[0].reshape(-1, 3))
            radii.append(ev[1].ravel() / 2.0)
            out_counts.append(np.full(len(which), ev[0].shape[1]))
            kept.append(which)
        if skipped:
            self.warn(
                f"short:{prim.GetPath()}",
                f"prim {prim.GetPath()}: {skipped} curve(s) with too few vertices for a {ctype} {basis} segment are skipped",
            )
        if not keys:
            return None
        v, n, uv, t, owner = pc_curves.curves_mesh(
            np.concatenate(keys), np.concatenate(radii), np.concatenate(out_counts), subdivisions=1, linear=True, name=str(prim.GetPath())
        )
        kept = np.concatenate(kept)
        return self.shape_dict(prim, v, t, n, uv, owner, kept[owner] if len(kept) else None, counts)

    def hermite_to_bezier(self, prim, c, pts, w, counts):
        """UsdGeomHermiteCurves: the segment from P_k to P_k+1 with tangents T_k, T_k+1 is
        the Bézier P_k, P_k + T_k/3, P_k+1 − T_k+1/3, P_k+1; widths linear along it."""
        raw = c.GetTangentsAttr().Get(self.time)
        tan = np.asarray(raw, np.float64).reshape(-1, 3) if raw is not None else np.zeros((0, 3))
        if tan.shape != pts.shape or not np.all(np.isfinite(tan)):
            raise self.error(prim, f"tangents has {len(tan)} values; expected {len(pts)} finite ones (one per point)")
        out_p, out_w, out_c = [], [], []
        start = 0
        for n in counts:
            p, t, wi = pts[start : start + n], tan[start : start + n], w[start : start + n]
            start += n
            if n < 2:
                continue
            bez = np.empty((3 * (n - 1) + 1, 3))
            bez[0::3] = p
            bez[1::3] = p[:-1] + t[:-1] / 3.0
            bez[2::3] = p[1:] - t[1:] / 3.0
            bw = np.empty(3 * (n - 1) + 1)
            bw[0::3] = wi
            bw[1::3] = (2 * wi[:-1] + wi[1:]) / 3.0
            bw[2::3] = (wi[:-1] + 2 * wi[1:]) / 3.0
            out_p.append(bez)
            out_w.append(bw)
            out_c.append(len(bez))
        if not out_p:
            return np.zeros((0, 3)), np.zeros(0), np.zeros(0, np.int64)
        return np.concatenate(out_p), np.concatenate(out_w), np.asarray(out_c, np.int64)

    def points_arrays(self, prim) -> dict[str, Any] | None:
        """UsdGeom.Points → spheres of diameter ``widths`` (``Scene.add_points``)."""
        from .. import curves as pc_curves

        p = self.UsdGeom.Points(prim)
        pts = self.finite_points(prim, p.GetPointsAttr(), "point")
        if pts is None:
            return None
        w, _ = self.widths(prim, p, {"constant": 1, "vertex": len(pts), "varying": len(pts)}, len(pts))
        v, n, uv, t, owner = pc_curves.points_mesh(pts, np.broadcast_to(w, (len(pts),)) / 2.0, name=str(prim.GetPath()))
        return self.shape_dict(prim, v, t, n, uv, owner, owner, np.ones(len(pts), np.int64))

    def element_attributes(self, prim, tris, element_of_tri, counts, n_vertices) -> dict[str, np.ndarray] | None:
        """displayColor / displayOpacity of curves or points that vary per curve or point
        (uniform, or vertex / varying averaged over each curve): per tessellated vertex,
        for the display material's Attribute nodes."""
        out = {}
        for name, width in (("displayColor", 3), ("displayOpacity", 1)):
            if name not in self.attribute_names:
                continue
            value = _primvar_values(self.UsdGeom.PrimvarsAPI(prim).GetPrimvar(name), self.time)
            if value is None or len(value) == 0:
                continue
            arr = np.asarray(value, np.float64).reshape(-1, width)
            if len(arr) == len(counts):
                per_element = arr
            elif len(arr) == int(counts.sum()):
                per_element = np.add.reduceat(arr, np.concatenate([[0], np.cumsum(counts)[:-1]])) / np.maximum(counts, 1)[:, None]
            elif len(arr) == 1:
                per_element = np.repeat(arr, len(counts), axis=0)
            else:
                self.warn(f"display:{prim.GetPath()}:{name}", f"prim {prim.GetPath()}: {name} has {len(arr)} values; its mean is used")
                per_element = np.repeat(arr.mean(axis=0, keepdims=True), len(counts), axis=0)
            vert = np.zeros((n_vertices, width), np.float32)
            vert[tris.ravel()] = np.repeat(per_element[element_of_tri], 3, axis=0)
            out[name] = vert if width > 1 else vert[:, 0]
        return out or None

    def shape_dict(self, prim, v, t, n, uv, owner=None, element_of_tri=None, counts=None) -> dict[str, Any]:
        material = self.bound_material(prim)
        tris = np.asarray(t).reshape(-1, 3)  # uint32 from the core, as add_mesh wants them
        verts = np.asarray(v, np.float32).reshape(-1, 3)
        attrs = None
        if element_of_tri is not None and counts is not None:
            attrs = self.element_attributes(prim, tris, element_of_tri, np.asarray(counts, np.int64), len(verts))
        return {
            "name": str(self.custom(prim, A.NAME, str(prim.GetPath()))),
            "order": self.custom(prim, A.MESH_INDEX),
            "vertices": verts,
            "triangles": tris,
            "normals": np.asarray(n, np.float32).reshape(-1, 3),
            "uvs": np.asarray(uv, np.float32).reshape(-1, 2),
            "attributes": attrs,
            "material_ids": None,
            "material": material,
        }

    def mesh_arrays(self, prim) -> dict[str, Any] | None:
        UsdGeom = self.UsdGeom
        if prim.GetTypeName() in ("BasisCurves", "HermiteCurves"):
            return self.curves_arrays(prim)
        if prim.GetTypeName() == "Points":
            return self.points_arrays(prim)
        if prim.GetTypeName() != "Mesh":
            return self.gprim_arrays(prim)
        mesh = UsdGeom.Mesh(prim)
        where = prim.GetPath()
        points = mesh.GetPointsAttr().Get(self.time)
        counts = mesh.GetFaceVertexCountsAttr().Get(self.time)
        indices = mesh.GetFaceVertexIndicesAttr().Get(self.time)
        have = {"points": points, "faceVertexCounts": counts, "faceVertexIndices": indices}
        missing = [name for name, v in have.items() if v is None or len(v) == 0]
        if missing:
            if len(missing) < len(have):  # some topology without the rest: malformed (all absent: nothing to draw)
                raise self.error(where.pathString, f"it has {', '.join(k for k in have if k not in missing)} but no {' or '.join(missing)}")
            return None
        pts = np.asarray(points, dtype=np.float32).reshape(-1, 3)
        if not np.all(np.isfinite(pts)):
            bad = int(np.argwhere(~np.all(np.isfinite(pts), axis=1))[0][0])
            raise self.error(where.pathString, f"point {bad} is not finite")
        counts = np.asarray(counts, dtype=np.int64)
        idx = np.asarray(indices, dtype=np.int64)
        if counts.min() < 0:
            raise self.error(where.pathString, f"faceVertexCounts[{int(np.argmin(counts))}] is negative")
        if int(counts.sum()) != len(idx):
            raise self.error(where.pathString, f"faceVertexCounts add up to {int(counts.sum())} but there are {len(idx)} faceVertexIndices")
        if len(idx) and (idx.min() < 0 or idx.max() >= len(pts)):
            bad = int(np.argwhere((idx < 0) | (idx >= len(pts)))[0][0])
            raise self.error(
                where.pathString, f"faceVertexIndices[{bad}] = {int(idx[bad])} is out of range (the mesh has {len(pts)} points)"
            )
        n_faces, n_corners = len(counts), len(idx)
        hole = np.zeros(n_faces, bool)
        holes = mesh.GetHoleIndicesAttr().Get(self.time)
        if holes is not None and len(holes):
            h = np.asarray(holes, dtype=np.int64)
            hole[h[(h >= 0) & (h < n_faces)]] = True
        if not np.any((counts >= 3) & ~hole):
            return None
        left_handed = self.get(mesh.GetOrientationAttr(), "rightHanded") == "leftHanded"

        # Normals (primvars:normals wins over normals) and texture coordinates.
        # Malformed normals or uvs (optional data) are dropped with one warning, as Hydra
        # draws such a mesh (usd-wg's normalsTypes.usda): computed normals, no uvs.
        normals = self.optional(
            prim, "primvars:normals", lambda: self.primvar(prim, "normals", "primvars:normals", len(pts), n_corners, n_faces, 3)
        )
        if normals is None:
            attr = mesh.GetNormalsAttr()
            raw = attr.Get(self.time) if attr and attr.HasAuthoredValue() else None

            def legacy():
                if raw is None or not len(raw):
                    return None
                arr = np.asarray(raw, np.float32).reshape(-1, 3)
                return self.check_interp(prim, arr, mesh.GetNormalsInterpolation(), "normals", len(pts), n_corners, n_faces)

            normals = self.optional(prim, "normals", legacy)
        uv_name = "st"
        if not self.UsdGeom.PrimvarsAPI(prim).HasPrimvar("st"):
            for pv in self.UsdGeom.PrimvarsAPI(prim).GetPrimvars():
                if pv.GetTypeName() in (self.Sdf.ValueTypeNames.TexCoord2fArray, self.Sdf.ValueTypeNames.Float2Array):
                    uv_name = pv.GetPrimvarName()
                    break
        uvs = self.optional(
            prim, f"primvars:{uv_name}", lambda: self.primvar(prim, uv_name, f"primvars:{uv_name}", len(pts), n_corners, n_faces, 2)
        )

        # Materials: GeomSubsets of the materialBind family, else the prim's binding.
        binding = self.UsdShade.MaterialBindingAPI(prim)
        subsets = binding.GetMaterialBindSubsets()
        material_ids = None
        material = None
        if subsets:
            face_material = np.full(n_faces, -1, dtype=np.int64)
            for subset in subsets:
                faces = subset.GetIndicesAttr().Get(self.time)
                if faces is None or len(faces) == 0:
                    continue
                f = np.asarray(faces, dtype=np.int64)
                if f.min() < 0 or f.max() >= n_faces:
                    bad = int(f[(f < 0) | (f >= n_faces)][0])
                    raise self.error(subset.GetPrim(), f"face index {bad} is out of range (the mesh has {n_faces} faces)")
                face_material[f] = self.bound_material(subset.GetPrim())
            if np.any(face_material < 0):
                face_material[face_material < 0] = self.bound_material(prim)
            material_ids = face_material
        else:
            material = self.bound_material(prim)
        # Named UV sets and primvars that some material's network reads.
        extras: dict[tuple[str, str], tuple[np.ndarray, str]] = {}
        api = self.UsdGeom.PrimvarsAPI(prim)
        used = [material] if material is not None else sorted({int(m) for m in np.unique(material_ids)})
        wanted = [("uv", n) for n in sorted(self.uv_names)] + [("attr", n) for n in sorted(self.attribute_names)]

        def extra_entry(pv, value, kind, pv_name):
            arr = np.asarray(value, dtype=np.float32)
            arr = arr.reshape(len(arr), -1)
            if kind == "uv":
                arr = arr[:, :2]
            interp = str(pv.GetInterpolation())
            if interp in ("uniform", "constant"):
                expected = n_faces if interp == "uniform" else 1
                if len(arr) != expected or not np.all(np.isfinite(arr)):
                    raise self.error(
                        prim, f"primvars:{pv_name} has {len(arr)} values for {interp} interpolation; expected {expected} finite ones"
                    )
                if interp == "constant":
                    return np.repeat(arr, len(pts), axis=0), "vertex"
                return arr[np.repeat(np.arange(n_faces), counts)], "corner"
            return self.check_interp(prim, arr, interp, f"primvars:{pv_name}", len(pts), n_corners, n_faces)

        for kind, pv_name in wanted:
            pv = api.GetPrimvar(pv_name)
            value, entry = None, None
            try:
                value = _primvar_values(pv, self.time)
                if value is not None and len(value):
                    entry = extra_entry(pv, value, kind, pv_name)
            except Exception as e:  # noqa: BLE001 - malformed optional data: read as missing
                if not _is_bad_data(e):
                    raise
                self.warn(f"bad:{where}:{pv_name}", self.skip_message(prim, e, f"primvars:{pv_name} is read as missing"))
                value = None
            if value is None or len(value) == 0:
                # Read by this mesh's network but missing: the primvar reader's fallback.
                for m in used:
                    mat = self.materials[m]
                    if (kind, pv_name) in getattr(mat, "usd_primvar_reads", ()):
                        reader, fb = mat.usd_primvar_fallbacks[(kind, pv_name)]
                        self.warn(
                            f"noprimvar:{where}:{pv_name}",
                            f"prim {where}: primvar '{pv_name}' read by {reader} (material '{mat.name}') is missing; "
                            f"the reader's fallback {fb} is used",
                        )
                        extras[(kind, pv_name)] = (np.tile(np.asarray(fb, np.float32), (len(pts), 1)), "vertex")
                        break
                continue
            if entry is not None:
                extras[(kind, pv_name)] = entry

        # Subdivision surfaces refined (subdivision.py); face_src: the control face of each face.
        per_vertex = [("normals", normals), ("uvs", uvs)] + list(extras.items())
        face_src = np.arange(n_faces)
        refined = self.subdivide(prim, mesh, pts, counts, idx, hole, per_vertex, left_handed)
        if refined is not None:
            pts, counts, idx, face_src, per_vertex, hole, fv_mesh = refined
            n_faces, n_corners = len(counts), len(idx)
            normals, uvs = per_vertex[0][1], per_vertex[1][1]
        # Fan triangulation, vectorised: face f gives (c0, ck, ck+1) for k = 1 .. n−2.
        first = np.concatenate([[0], np.cumsum(counts)[:-1]])
        keep = (counts >= 3) & ~hole[face_src]
        ntri = np.where(keep, counts - 2, 0)
        total = int(ntri.sum())
        if total == 0:
            return None
        face_of_tri = np.repeat(np.arange(n_faces), ntri)
        tri_start = np.cumsum(ntri) - ntri
        k = np.arange(total) - np.repeat(tri_start, ntri) + 1
        base = first[face_of_tri]
        corners = np.stack([base, base + k, base + k + 1], axis=1)
        if left_handed:
            corners = corners[:, [0, 2, 1]]
        if material_ids is not None:
            material_ids = material_ids[face_src[face_of_tri]]
        n_fv = sum(d is not None and d[1] == "corner" for _, d in per_vertex)
        if refined is not None and n_fv == 1:
            # One face-varying array: its refined face-varying vertices are the vertices
            # (each lies on one point), no welding needed.
            values, value_of_corner = fv_mesh[0]
            vertex_of = np.empty(len(values), np.int64)
            vertex_of[value_of_corner] = idx
            vertices = pts[vertex_of]
            tris = value_of_corner[corners]
            out = {key: (values.astype(np.float32) if d[1] == "corner" else d[0][vertex_of]) for key, d in per_vertex if d is not None}
        elif refined is not None and n_fv:
            # A refined mesh: vertex data is per vertex, so only the face-varying data splits
            # vertices (subdivision.weld: hashed rows, millions of corners in about a second).
            from .subdivision import weld

            corner_cols = [
                np.ascontiguousarray(d[0], dtype=np.float32).view(np.int32) for _, d in per_vertex if d is not None and d[1] == "corner"
            ]
            first_corner, inverse = weld(
                np.concatenate([idx.astype(np.int64)[:, None].view(np.int32).reshape(n_corners, 2), *corner_cols], axis=1)
            )
            vertices = pts[idx[first_corner]]
            tris = inverse[corners]
            out = {key: (d[0][first_corner] if d[1] == "corner" else d[0][idx[first_corner]]) for key, d in per_vertex if d is not None}
        elif any(d is not None and d[1] == "corner" for _, d in per_vertex):
            # Split vertices whose corners disagree (as Blender's exporter does).
            cols = [idx.astype(np.int64)[:, None].view(np.int32).reshape(n_corners, 2)]
            corner_data = {}
            for key, d in per_vertex:
                if d is None:
                    continue
                c = np.ascontiguousarray(d[0] if d[1] == "corner" else d[0][idx], dtype=np.float32)
                corner_data[key] = c
                cols.append(c.view(np.int32))
            keys = np.ascontiguousarray(np.concatenate(cols, axis=1))
            row = keys.view(np.dtype((np.void, keys.dtype.itemsize * keys.shape[1]))).ravel()
            _, first_corner, inverse = np.unique(row, return_index=True, return_inverse=True)
            vertices = pts[idx[first_corner]]
            tris = inverse.ravel()[corners]
            out = {key: c[first_corner] for key, c in corner_data.items()}
        else:
            vertices = pts
            tris = idx[corners]
            out = {key: d[0] for key, d in per_vertex if d is not None}
        out_n, out_uv = out.get("normals"), out.get("uvs")
        uv_maps = {k[1]: v for k, v in out.items() if isinstance(k, tuple) and k[0] == "uv"} or None
        attrs = {k[1]: v for k, v in out.items() if isinstance(k, tuple) and k[0] == "attr"} or None
        # The core derives tangents from the default UV set; a normal map read through
        # another set gets that set's (one set per mesh, like Blender's MikkTSpace export).
        tangents = None
        tangent_sets = sorted({str(getattr(self.materials[m], "usd_tangent_uv", None) or "") for m in used} - {"", uv_name})
        if tangent_sets and uv_maps and tangent_sets[0] in uv_maps:
            from .preview import smooth_tangents

            tangents = smooth_tangents(vertices, tris, uv_maps[tangent_sets[0]], out_n)
            if len(tangent_sets) > 1 or any(getattr(self.materials[m], "usd_tangent_uv", None) in ("", uv_name) for m in used):
                self.warn(
                    f"tangentuv:{where}",
                    f"prim {where}: its normal maps read several UV sets; all use the tangents of '{tangent_sets[0]}'",
                )

        return {
            "name": str(self.custom(prim, A.NAME, str(prim.GetPath()))),
            "order": self.custom(prim, A.MESH_INDEX),
            "vertices": vertices,
            "triangles": tris,
            "normals": out_n,
            "uvs": out_uv,
            "uv_maps": uv_maps,
            "attributes": attrs,
            "tangents": tangents,
            "material_ids": material_ids,
            "material": material,
        }

    def subdivision_level_of(self, prim) -> int:
        """The prim's ``polychrome:subdivisionLevel`` (UsdGeom has no per-prim level), else
        the reader's ``subdivision_level``."""
        own = self.custom(prim, A.SUBDIVISION_LEVEL)
        if own is None:
            return self.subdivision_level
        try:
            level = int(own)
        except (TypeError, ValueError):
            level = -1
        if not 0 <= level <= MAX_SUBDIVISION_LEVEL:
            raise self.error(prim, f"{A.SUBDIVISION_LEVEL} {own!r} must be a whole number from 0 to {MAX_SUBDIVISION_LEVEL}")
        return level

    def subdivide(self, prim, mesh, pts, counts, idx, hole, per_vertex, left_handed):
        """A catmullClark / bilinear (/ loop, read as catmullClark) mesh refined at its
        level (docs/usd.md, "Subdivision surfaces"): (points, counts, indices, control face
        of each face, per_vertex data refined, holes per control face); None for a
        polygon mesh (scheme "none") or level 0 (the control cage)."""
        from . import subdivision

        where = prim.GetPath()
        scheme = str(self.get(mesh.GetSubdivisionSchemeAttr(), "catmullClark"))
        if scheme == "none":
            return None
        level = self.subdivision_level_of(prim)
        if level == 0:
            return None
        if scheme == "loop":
            self.warn(f"loop:{where}", f"prim {where}: subdivisionScheme 'loop' is not supported; refined as catmullClark")
            scheme = "catmullClark"
        elif scheme not in ("catmullClark", "bilinear"):
            self.warn(f"scheme:{where}", f"prim {where}: subdivisionScheme '{scheme}' is unknown; rendered as its control cage")
            return None
        boundary = str(self.get(mesh.GetInterpolateBoundaryAttr(), "edgeAndCorner"))
        if boundary not in subdivision.BOUNDARIES:
            self.warn(f"boundary:{where}", f"prim {where}: interpolateBoundary '{boundary}' is unknown; read as edgeAndCorner")
            boundary = "edgeAndCorner"
        fv_mode = str(self.get(mesh.GetFaceVaryingLinearInterpolationAttr(), "cornersPlus1"))
        if fv_mode not in subdivision.FACE_VARYING:
            self.warn(f"fvlinear:{where}", f"prim {where}: faceVaryingLinearInterpolation '{fv_mode}' is unknown; read as cornersPlus1")
            fv_mode = "cornersPlus1"
        if str(self.get(mesh.GetTriangleSubdivisionRuleAttr(), "catmullClark")) == "smooth":
            self.warn(f"trirule:{where}", f"prim {where}: triangleSubdivisionRule 'smooth' is read as catmullClark")

        def arr(attr, dtype):
            v = attr.Get(self.time) if attr and attr.HasAuthoredValue() else None
            return None if v is None or len(v) == 0 else np.asarray(v, dtype)

        valid = counts >= 3  # points and lines take no part
        corner_ok = np.repeat(valid, counts)
        # Level 1 makes one quad per corner, every further level 4 of each.
        quads = lambda n: int(corner_ok.sum()) * 4 ** (n - 1)  # noqa: E731
        if quads(level) > MAX_REFINED_FACES:
            fits = max([n for n in range(1, level) if quads(n) <= MAX_REFINED_FACES], default=0)
            self.warn(
                f"sublevel:{where}",
                f"prim {where}: subdivision level {level} would make {quads(level):,} faces; refined at level {fits} "
                f"(at most {MAX_REFINED_FACES:,} faces)",
            )
            if fits == 0:
                return None
            level = fits
        columns, layout, face_varying, varying = [np.asarray(pts, np.float64)], [], [], []
        for key, d in per_vertex:
            if d is None or key == "normals":  # authored normals do not apply to a subdivided surface
                layout.append((key, None, 0))
            elif d[1] == "vertex":
                layout.append((key, "vertex", d[0].shape[1]))
                columns.append(np.asarray(d[0], np.float64))
            elif d[1] == "varying":  # linear: the bilinear scheme on the same faces
                layout.append((key, "varying", len(varying)))
                varying.append(np.asarray(d[0], np.float64))
            else:
                layout.append((key, "corner", len(face_varying)))
                face_varying.append(d[0][corner_ok])
        try:
            r = subdivision.refine(
                np.concatenate(columns, axis=1),
                counts[valid],
                idx[corner_ok],
                level,
                scheme=scheme,
                boundary=boundary,
                crease_indices=arr(mesh.GetCreaseIndicesAttr(), np.int64),
                crease_lengths=arr(mesh.GetCreaseLengthsAttr(), np.int64),
                crease_sharpnesses=arr(mesh.GetCreaseSharpnessesAttr(), np.float64),
                corner_indices=arr(mesh.GetCornerIndicesAttr(), np.int64),
                corner_sharpnesses=arr(mesh.GetCornerSharpnessesAttr(), np.float64),
                face_varying=face_varying,
                face_varying_interpolation=fv_mode,
            )
            linear = [subdivision.refine(v, counts[valid], idx[corner_ok], level, scheme="bilinear")["points"] for v in varying]
        except ValueError as e:
            raise self.error(prim, str(e)) from None
        data = r["points"]
        new_pts = data[:, :3].astype(np.float32)
        face_src = np.nonzero(valid)[0][r["face"]]
        hole = hole.copy()
        hole[np.nonzero(valid)[0][r["boundary_holes"]]] = True
        normals = subdivision.smooth_normals(data[:, :3], r["indices"])
        if left_handed:
            normals = -normals
        out, col = [], 3
        for key, kind, width in layout:
            if key == "normals":
                out.append((key, (normals.astype(np.float32), "vertex")))
            elif kind is None:
                out.append((key, None))
            elif kind == "vertex":
                out.append((key, (data[:, col : col + width].astype(np.float32), "vertex")))
                col += width
            elif kind == "varying":
                out.append((key, (linear[width].astype(np.float32), "vertex")))
            else:
                out.append((key, (r["face_varying"][width].astype(np.float32), "corner")))
        return new_pts, r["counts"], r["indices"], face_src, out, hole, r["face_varying_mesh"]

    def mesh_key(self, prim) -> str | None:
        key = self.key_of(prim)
        if key not in self.meshes:
            try:
                arrays = self.mesh_arrays(prim)
            except Exception:
                self.meshes[key] = None  # type: ignore[assignment]  # warned once by guarded
                raise
            if arrays is not None and len(arrays["vertices"]):
                far = np.abs(np.asarray(arrays["vertices"], np.float64)).max(axis=1)
                if not far.max() <= MAX_COORDINATE:
                    self.meshes[key] = None  # type: ignore[assignment]
                    i = int(np.argmax(~(far <= MAX_COORDINATE)))
                    raise self.error(prim, f"vertex {i} has a coordinate {far[i]:g} beyond ±{MAX_COORDINATE:g}")
            self.meshes[key] = arrays  # type: ignore[assignment]
            self.mesh_prims[key] = prim
        return key if self.meshes[key] is not None else None

    def instance_name(self, prim) -> str:
        p = prim
        while p and p.IsValid() and not p.IsPseudoRoot():
            name = self.custom(p, A.INSTANCE_NAME)
            if name is not None:
                return str(name)
            if p.IsInstance() or not p.IsInstanceProxy():
                break
            p = p.GetParent()
        return str(prim.GetPath())

    def read_mesh(self, prim) -> None:
        key = self.mesh_key(prim)
        if key is None:
            return
        self.instances.append((key, self.world_matrix(prim), self.instance_name(prim), None, prim))

    def read_point_instancer(self, prim, parents=None, names=None, depth: int = 0) -> None:
        """A PointInstancer's instances: each prototype's gprims placed by
        ``ComputeInstanceTransformsAtTime`` (prototype root transform included) times the
        instancer's own transform. ``parents`` (row-vector 4 × 4s, stage frame) are the
        instancer's local-to-world transforms when it sits inside another instancer's
        prototype (one per outer instance, ``names`` theirs); PointInstancers inside a
        prototype are read the same way, level by level (UsdGeomPointInstancer composes
        one level per ComputeInstanceTransformsAtTime)."""
        UsdGeom, Usd = self.UsdGeom, self.Usd
        pi = UsdGeom.PointInstancer(prim)
        protos = pi.GetPrototypesRel().GetForwardedTargets()
        proto_indices = pi.GetProtoIndicesAttr().Get(self.time)
        positions = pi.GetPositionsAttr().Get(self.time)
        # The schema requires prototypes, protoIndices and positions; without one of them
        # the instancer is skipped with one warning (as Hydra does: OpenUSD's
        # testUsdImagingGLPointInstancer/pi_bad_schema_input.usda).
        missing = [
            name
            for name, ok in (
                ("prototypes", bool(protos)),
                ("protoIndices", proto_indices is not None),
                ("positions", positions is not None),
            )
            if not ok
        ]
        if missing and (protos or proto_indices is not None or positions is not None):
            self.warn(
                f"pi:{prim.GetPath()}",
                f"prim {prim.GetPath()}: PointInstancer without {' or '.join(missing)} (the schema requires them); it is skipped",
            )
            return
        if missing or len(proto_indices) == 0:
            return  # nothing authored, or no instances
        pidx = np.asarray(proto_indices, dtype=np.int64)
        if pidx.min() < 0 or pidx.max() >= len(protos):
            bad = int(np.argwhere((pidx < 0) | (pidx >= len(protos)))[0][0])
            raise self.error(prim, f"protoIndices[{bad}] = {int(pidx[bad])} is out of range ({len(protos)} prototypes)")
        if len(positions) != len(pidx):
            self.warn(
                f"pi:{prim.GetPath()}",
                f"prim {prim.GetPath()}: {len(positions)} positions for {len(pidx)} protoIndices; the PointInstancer is skipped",
            )
            return
        PI = UsdGeom.PointInstancer
        xforms = pi.ComputeInstanceTransformsAtTime(self.time, self.base_time, PI.IncludeProtoXform, PI.IgnoreMask)
        if xforms is None or len(xforms) != len(pidx):
            raise self.error(prim, "its instance transforms cannot be computed (orientations or scales of the wrong length?)")
        inst = np.asarray(xforms, dtype=np.float64).reshape(-1, 4, 4)
        keep = np.ones(len(pidx), dtype=bool)
        mask = pi.ComputeMaskAtTime(self.time)
        if mask is not None and len(mask) == len(pidx):
            keep &= np.asarray(mask, dtype=bool)
        invisible = pi.GetInvisibleIdsAttr().Get(self.time)
        if invisible is not None and len(invisible):
            ids = pi.GetIdsAttr().Get(self.time)
            ids = np.arange(len(pidx)) if ids is None or len(ids) != len(pidx) else np.asarray(ids, dtype=np.int64)
            keep &= ~np.isin(ids, np.asarray(invisible, dtype=np.int64))
        if not np.all(np.isfinite(inst[keep])):
            raise self.error(prim, "its instance positions, orientations or scales are not finite")
        nested = parents is not None
        first, runs = len(self.instances), len(self.instancer_runs)
        holds_instancers = False
        if not nested:
            parents = np.array(self.cache.GetLocalToWorldTransform(prim), dtype=np.float64)[None]
            names = [str(prim.GetPath())]
        for p, target in enumerate(protos):
            root = self.stage.GetPrimAtPath(target)
            if not root:
                raise self.error(prim, f"prototype {target} does not exist")
            which = np.nonzero((pidx == p) & keep)[0]
            if len(which) == 0:
                continue
            placed = len(self.instances)
            # Prototypes may sit under an `over` (not "defined" to the default predicate,
            # which asks it of every ancestor): Hydra's predicate for prototypes asks each
            # prim's own specifier (UsdImagingDelegate::_GetDisplayPredicateForPrototypes).
            it = iter(Usd.PrimRange(root, Usd.TraverseInstanceProxies(PROTOTYPE_PREDICATE(Usd))))
            for sub in it:
                t = sub.GetTypeName()
                if t not in GEOMETRY_TYPES and t != "PointInstancer":
                    if t not in _SILENT_TYPES:
                        self.warn(
                            f"proto:{sub.GetPath()}",
                            f"prim {sub.GetPath()}: {t} inside a PointInstancer prototype is not supported and is skipped",
                        )
                    continue
                rel, _ = self.cache.ComputeRelativeTransform(sub, root) if sub != root else (self.Gf.Matrix4d(1.0), False)
                rel = np.array(rel, dtype=np.float64)
                # row vectors: local → prototype → instancer → world, for every outer placement
                mats = (rel[None, None] @ inst[which][None] @ parents[:, None]).reshape(-1, 4, 4)
                tail = str(sub.GetPath())[len(str(root.GetPath())) :]
                sub_names = [f"{n}[{int(j)}]{tail}" for n in names for j in which]
                if t == "PointInstancer":
                    holds_instancers = True
                    it.PruneChildren()  # its prototypes are drawn through it
                    if depth + 1 > MAX_INSTANCER_DEPTH:
                        self.warn(
                            f"pidepth:{sub.GetPath()}",
                            f"prim {sub.GetPath()}: PointInstancers nested deeper than {MAX_INSTANCER_DEPTH} levels are skipped",
                        )
                        continue
                    self.guarded(sub, lambda: self.read_point_instancer(sub, mats, sub_names, depth + 1))
                    continue
                key = self.mesh_key(sub)
                if key is None:
                    continue
                world = np.transpose(mats, (0, 2, 1))
                if not self.identity_correction:
                    world = self.correction[None] @ world
                if not nested:  # motion keys over the shutter (instancer_motion): one level
                    self.instancer_runs.append((prim, len(self.instances), which, rel))
                for m, name in zip(world, sub_names):
                    self.instances.append((key, m, name))
            if len(self.instances) == placed:
                self.warn(
                    f"proto:{target}",
                    f"prim {prim.GetPath()}: prototype {target} holds no geometry that is read; its {len(which)} instances are empty",
                )
        if holds_instancers and not nested:  # all its instances move by re-reading it (nested_motion)
            del self.instancer_runs[runs:]
            self.nested_runs.append((prim, first, len(self.instances)))

    # -- lights ---------------------------------------------------------------------------
    def authored_by_blender(self, prim, attr) -> bool:
        """Whether ``attr`` (else the prim) is authored in a layer Blender's USD exporter
        wrote: its ``doc`` starts "Blender v" (io/usd: usd_capi_export.cc). Asked per light,
        so a Blender asset referenced into another stage keeps Blender's conventions."""
        specs = attr.GetPropertyStack(self.time) if attr and attr.HasAuthoredValue() else []
        layer = specs[0].layer if specs else (prim.GetPrimStack()[0].layer if prim.GetPrimStack() else None)
        return bool(layer is not None and str(layer.documentation).startswith("Blender v"))

    def light_rgb(self, prim, light) -> tuple[float, tuple[float, float, float], Any]:
        """(scalar intensity × 2^exposure, rgb colour, blackbody spectrum or None)."""
        intensity = float(self.get(light.GetIntensityAttr(), 1.0))
        exposure = float(self.get(light.GetExposureAttr(), 0.0))
        colour = tuple(float(c) for c in self.get(light.GetColorAttr(), (1.0, 1.0, 1.0)))
        scalar = intensity * 2.0**exposure
        if not (math.isfinite(scalar) and all(math.isfinite(c) and c >= 0.0 for c in colour)):
            raise self.error(prim, "its intensity, exposure or colour is not finite (or the colour is negative)")
        if scalar < 0:
            raise self.error(prim, f"its intensity × 2^exposure {scalar:g} is negative (no negative light)")
        if scalar * max(colour, default=0.0) > F32_MAX:
            raise self.error(prim, f"its intensity × 2^exposure {scalar:g} is too large")
        blackbody = None
        enabled = bool(self.get(light.GetEnableColorTemperatureAttr(), False))
        if enabled and self.authored_by_blender(prim, light.GetIntensityAttr()):
            # Blender 4.5's exporter writes enableColorTemperature = 1 on every light and
            # colorTemperature only when it is not 6500 K, whether or not the light uses
            # its temperature: without an authored temperature the light had it off (the
            # default), or on at 6500 K, which cannot be told apart; read it as off.
            t_attr = light.GetColorTemperatureAttr()
            enabled = bool(t_attr and t_attr.HasAuthoredValue())
        if enabled:
            t = float(self.get(light.GetColorTemperatureAttr(), 6500.0))
            if not (math.isfinite(t) and t > 0):
                raise self.error(prim, f"colour temperature {t} K must be positive")
            blackbody = _blackbody_white(t)
        for name, label in (("diffuse", "diffuse"), ("specular", "specular")):
            attr = prim.GetAttribute(f"inputs:{name}")
            v = attr.Get(self.time) if attr and attr.HasAuthoredValue() else None
            if v is not None and float(v) != 1.0:
                self.warn(
                    f"{name}:{prim.GetPath()}",
                    f"prim {prim.GetPath()}: the light's {label} multiplier {float(v):g} is not supported and is ignored",
                )
        return scalar, colour, blackbody

    def emitted(self, scalar, colour, blackbody):
        """The emitted spectrum: colour × (colour temperature, when enabled) × scalar, as
        UsdLux multiplies them (spectra.tinted: in linear Rec.709)."""
        from ..spectra import rgb, tinted

        if blackbody is not None:
            return tinted(blackbody, *colour) * scalar
        return rgb(*colour) * scalar

    def described_light(self, prim, m: np.ndarray) -> bool:
        """Adds the light of a ``polychrome:light`` description, if the prim has one. Its
        position and direction follow the prim's transform when that moved it."""
        d = self.json_attr(prim, A.LIGHT)
        if d is None:
            return False
        if not isinstance(d, dict) or "type" not in d:
            raise self.error(prim, f"{A.LIGHT} must be a JSON light description with a 'type'")
        d = dict(d)
        if "position" in d and not np.allclose(d["position"], m[:3, 3], rtol=1e-9, atol=1e-9):
            d["position"] = [float(x) for x in m[:3, 3]]
        if "direction" in d:
            axis = -m[:3, 2] / np.linalg.norm(m[:3, 2])
            given = np.asarray(d["direction"], dtype=np.float64)
            if not (np.linalg.norm(given) > 0 and np.allclose(given / np.linalg.norm(given), axis, atol=1e-9)):
                d["direction"] = [float(x) for x in axis]
        power = self.custom(prim, A.POWER)
        colour = self.spectrum_attr(prim, A.COLOR)
        self.lights.append(light_from_description(d, power, colour))
        return True

    def read_sphere_light(self, prim) -> None:

        m = self.world_matrix(prim)
        if self.described_light(prim, m):
            return
        pos = [float(x) for x in m[:3, 3]]
        name = str(self.custom(prim, A.NAME, str(prim.GetPath())))
        intensity_spec = self.spectrum_attr(prim, A.INTENSITY)
        if intensity_spec is not None:
            self.lights.append(PointLight(pos, power=4.0 * math.pi, color=intensity_spec, name=name))
            return
        light = self.UsdLux.SphereLight(prim)
        scalar, colour, blackbody = self.light_rgb(prim, light)
        radius = float(self.get(light.GetRadiusAttr(), 0.5))
        det = float(np.linalg.det(m[:3, :3]))
        r = radius * (float(np.cbrt(abs(det))) if det != 0 else 0.0)  # metres
        if not (math.isfinite(r) and r >= 0):
            raise self.error(prim, f"radius {radius} must be finite and non-negative")
        normalize = bool(self.get(light.GetNormalizeAttr(), False))
        treat_as_point = bool(self.get(light.GetTreatAsPointAttr(), False))
        # Radiant intensity of a sphere of radiance L and radius r is L·πr²; normalised,
        # L = intensity/(4πr²) and the intensity is intensity/4 for any radius. A zero
        # radius without normalisation takes intensity as the radiant intensity itself.
        if normalize:
            factor = 0.25
        elif r > 0:
            factor = math.pi * r * r
        else:
            factor = 1.0
        # A sphere of that radius (soft shadows) unless treatAsPoint; its radiance is
        # I/(πr²), the spec's (intensity, or intensity/(4πr²) normalised).
        sphere = 0.0 if treat_as_point else r
        spectrum = self.emitted(scalar * factor, colour, blackbody)
        profile, axes = None, None
        if prim.HasAPI(self.UsdLux.ShapingAPI):
            shaping = self.UsdLux.ShapingAPI(prim)
            cone = float(self.get(shaping.GetShapingConeAngleAttr(), 90.0))
            softness = float(self.get(shaping.GetShapingConeSoftnessAttr(), 0.0))
            ies = self.get(shaping.GetShapingIesFileAttr())
            if float(self.get(shaping.GetShapingFocusAttr(), 0.0)) != 0.0:
                self.warn(f"focus:{prim.GetPath()}", f"prim {prim.GetPath()}: shaping:focus is not supported and is ignored")
            if ies is not None and getattr(ies, "path", ""):
                profile = self.ies_profile(prim, shaping, ies)
                axes = m[:3, :3] / np.where(np.linalg.norm(m[:3, :3], axis=0) > 0, np.linalg.norm(m[:3, :3], axis=0), 1.0)
            if not (math.isfinite(cone) and math.isfinite(softness)):
                raise self.error(prim, "its shaping cone angle or softness is not finite")
            if cone < 90.0:
                axis = -m[:3, 2] / np.linalg.norm(m[:3, 2])
                self.lights.append(
                    SpotLight(
                        pos,
                        axis.tolist(),
                        power=4.0 * math.pi,
                        color=spectrum,
                        spot_size=2.0 * math.radians(max(cone, 0.0)),
                        spot_blend=min(max(softness, 0.0), 1.0),
                        name=name,
                        radius=sphere,
                        profile=profile,
                        orientation=axes,
                    )
                )
                return
        self.lights.append(
            PointLight(pos, power=4.0 * math.pi, color=spectrum, name=name, radius=sphere, profile=profile, orientation=axes)
        )

    def ies_profile(self, prim, shaping, asset):
        """The light's ``shaping:ies:file`` as a profile of relative values: the file's
        candela over its largest (a shape of at most 1 multiplying the light's intensity:
        UsdLux gives IES files no absolute unit), or with ``shaping:ies:normalize`` over
        its mean on the sphere (the light emits the power it has without the profile).
        None, after a warning naming the prim, if the file is missing or unreadable."""
        from .. import ies

        path = self.asset_path(asset, prim, "IES file")
        if path is None:
            return None
        try:
            profile = ies.read(path)
        except ValueError as e:
            self.warn(f"ies:{prim.GetPath()}", f"prim {prim.GetPath()}: {e}; the light has no profile")
            return None
        angle_scale = float(self.get(shaping.GetShapingIesAngleScaleAttr(), 0.0))
        if not math.isfinite(angle_scale):
            raise self.error(prim, f"shaping:ies:angleScale {angle_scale} is not finite")
        # The scale is the file's (UsdLux: normalize divides by "iesProfilePower(iesFile)"),
        # before angleScale remaps its vertical angles.
        if bool(self.get(shaping.GetShapingIesNormalizeAttr(), False)):
            scale = profile.sphere_mean()
        else:
            scale = float(profile.values.max())
        if not scale > 0.0:
            self.warn(
                f"ies:{prim.GetPath()}", f"prim {prim.GetPath()}: IES file '{path.name}' is dark everywhere; the light has no profile"
            )
            return None
        profile.values = profile.values / scale
        if angle_scale != 0.0:
            try:
                profile = ies.angle_scaled(profile, angle_scale)
            except ValueError as e:
                self.warn(f"ies:{prim.GetPath()}", f"prim {prim.GetPath()}: {e}; the light has no profile")
                return None
        return profile

    def add_emitter_polygon(self, prim, pts2d: np.ndarray, size: float, normalize: bool, scalar, colour, blackbody) -> None:
        """An emissive polygon in the light's local XY plane emitting from its −Z face
        only (UsdLux: RectLight and DiskLight emit "from one side", "along the -Z
        axis")."""
        n = len(pts2d)
        verts = np.concatenate([pts2d, np.zeros((n, 1))], axis=1).astype(np.float32)
        tris = np.stack([np.zeros(n - 2, np.int64), np.arange(1, n - 1), np.arange(2, n)], axis=1)
        # counter-clockwise seen from −Z: the emitting front face looks along −Z
        self.add_emitter_mesh(prim, verts, tris[:, ::-1].copy(), normalize, scalar, colour, blackbody)

    def add_emitter_mesh(self, prim, verts: np.ndarray, tris: np.ndarray, normalize: bool, scalar, colour, blackbody) -> None:
        """A one-sided emissive mesh in the light's local frame (``tris`` counter-clockwise
        seen from the side that emits), see-through and invisible to camera and shadow
        rays as Cycles' lights. Normalised, the radiance is divided by the mesh's
        world-space area (UsdLux: "divide luminance by the world-space surface area", so
        transform scale counts)."""
        if prim.HasAPI(self.UsdLux.ShapingAPI):
            self.warn(f"shaping:{prim.GetPath()}", f"prim {prim.GetPath()}: ShapingAPI on an area light is not supported and is ignored")
        m = self.world_matrix(prim)
        world = (m[:3, :3] @ verts.T.astype(np.float64)).T
        area = 0.5 * float(
            np.linalg.norm(np.cross(world[tris[:, 1]] - world[tris[:, 0]], world[tris[:, 2]] - world[tris[:, 0]]), axis=1).sum()
        )
        if not area > 0.0 or scalar == 0.0:
            return
        if normalize:
            scalar = scalar / area
        name = str(self.custom(prim, A.NAME, str(prim.GetPath())))
        exact = self.spectrum_attr(prim, A.EMISSION)  # the radiance Polychrome wrote, if it did
        radiance = exact if exact is not None else self.emitted(scalar, colour, blackbody)
        # A stage Polychrome wrote from a two-sided emitter with a black backing (before
        # area lights were one-sided) holds the backing as a mesh: keep both as they were.
        legacy = bool(self.custom(prim, A.HAS_BACKING, False))
        vis = None if legacy else {"camera": False, "shadow": False}
        material_name = str(self.custom(prim, A.MATERIAL_NAME, name))
        emitter = self.add_material(Emitter(radiance, one_sided=not legacy, see_through=not legacy, name=material_name))
        key = f"light:{prim.GetPath()}"
        self.meshes[key] = {
            "name": name,
            "order": None,
            "vertices": verts,
            "triangles": tris[:, ::-1].copy() if legacy else tris,
            "normals": None,
            "uvs": None,
            "material_ids": None,
            "material": emitter,
        }
        self.instances.append((key, m, name, vis, prim))  # the prim: its motion over the shutter

    def read_rect_light(self, prim) -> None:
        light = self.UsdLux.RectLight(prim)
        scalar, colour, blackbody = self.light_rgb(prim, light)
        w = float(self.get(light.GetWidthAttr(), 1.0))
        h = float(self.get(light.GetHeightAttr(), 1.0))
        if not (math.isfinite(w) and math.isfinite(h)):
            raise self.error(prim, "its width or height is not finite")
        if self.get(light.GetTextureFileAttr()):
            self.warn(f"recttex:{prim.GetPath()}", f"prim {prim.GetPath()}: rect light textures are not supported; its colour is used")
        pts = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], np.float64) * [w / 2, h / 2]
        self.add_emitter_polygon(prim, pts, max(w, h), bool(self.get(light.GetNormalizeAttr(), False)), scalar, colour, blackbody)

    def read_disk_light(self, prim) -> None:
        light = self.UsdLux.DiskLight(prim)
        scalar, colour, blackbody = self.light_rgb(prim, light)
        r = float(self.get(light.GetRadiusAttr(), 0.5))
        if not math.isfinite(r):
            raise self.error(prim, "its radius is not finite")
        a = np.linspace(0.0, 2.0 * math.pi, DISK_SEGMENTS, endpoint=False)
        # The polygon's circumradius is chosen so that its area is the disk's, πr².
        k = math.sqrt(2.0 * math.pi / (DISK_SEGMENTS * math.sin(2.0 * math.pi / DISK_SEGMENTS)))
        pts = np.stack([np.cos(a), np.sin(a)], axis=1) * r * k
        self.add_emitter_polygon(prim, pts, 2 * r, bool(self.get(light.GetNormalizeAttr(), False)), scalar, colour, blackbody)

    def read_cylinder_light(self, prim) -> None:
        """UsdLux CylinderLight: emits outward from the side of a cylinder of ``radius``
        and ``length`` along its local X axis (not from the end caps), radiance
        intensity × 2^exposure × colour, ÷ the world-space side area when normalised.
        A prism of CYLINDER_SEGMENTS sides whose perimeter, hence area, is the
        cylinder's; ``treatAsLine`` is a hint that area-light renderers may ignore."""
        light = self.UsdLux.CylinderLight(prim)
        scalar, colour, blackbody = self.light_rgb(prim, light)
        r = float(self.get(light.GetRadiusAttr(), 0.5))
        length = float(self.get(light.GetLengthAttr(), 1.0))
        if not (math.isfinite(r) and math.isfinite(length)):
            raise self.error(prim, "its radius or length is not finite")
        if r <= 0.0 or length <= 0.0:
            return
        n = CYLINDER_SEGMENTS
        a = np.linspace(0.0, 2.0 * math.pi, n, endpoint=False)
        rk = r * math.pi / (n * math.sin(math.pi / n))
        ring = np.stack([np.cos(a), np.sin(a)], axis=1) * rk
        verts = np.concatenate(
            [np.concatenate([np.full((n, 1), -length / 2), ring], axis=1), np.concatenate([np.full((n, 1), length / 2), ring], axis=1)]
        ).astype(np.float32)
        i, j = np.arange(n), (np.arange(n) + 1) % n
        # counter-clockwise seen from outside (angles grow from +Y towards +Z)
        tris = np.concatenate([np.stack([i, j, n + j], axis=1), np.stack([i, n + j, n + i], axis=1)])
        self.add_emitter_mesh(prim, verts, tris, bool(self.get(light.GetNormalizeAttr(), False)), scalar, colour, blackbody)

    def read_distant_light(self, prim) -> None:

        m = self.world_matrix(prim)
        if self.described_light(prim, m):
            return
        light = self.UsdLux.DistantLight(prim)
        scalar, colour, blackbody = self.light_rgb(prim, light)
        axis = -m[:3, 2] / np.linalg.norm(m[:3, 2])
        angle = math.radians(float(self.get(light.GetAngleAttr(), 0.53)))
        if not math.isfinite(angle):
            raise self.error(prim, "its angle is not finite")
        if self.authored_by_blender(prim, light.GetIntensityAttr()):
            # Blender's exporter writes a sun of strength S and angle θ as intensity S/4 and
            # angle θ/2, and its importer undoes both (io/usd: usd_writer_light.cc,
            # usd_reader_light.cc); read back as Blender meant it.
            scalar *= 4.0
            angle *= 2.0
        # Normalised, intensity is the irradiance; otherwise it is the radiance of the sun
        # disk of angular diameter `angle`: E = L·π·sin²(angle/2) (zero angle: E = intensity).
        if not self.get(light.GetNormalizeAttr(), False) and angle > 0:
            scalar *= math.pi * math.sin(angle / 2) ** 2
        if not 0.0 <= angle <= math.pi:
            self.warn(f"angle:{prim.GetPath()}", f"prim {prim.GetPath()}: angle {math.degrees(angle):g}° is clamped to 0..180")
            angle = min(max(angle, 0.0), math.pi)
        self.lights.append(
            SunLight(
                axis.tolist(),
                strength=1.0,
                color=self.emitted(scalar, colour, blackbody),
                name=str(self.custom(prim, A.NAME, str(prim.GetPath()))),
                angle=angle,
            )
        )

    def read_dome_light(self, prim) -> None:
        """One DomeLight: its uniform radiance or its latlong texture; several domes are
        summed at the end (``combined_world``)."""
        self.domes.append((str(prim.GetPath()), self.dome_contribution(prim)))

    def dome_contribution(self, prim) -> tuple[str, Any]:
        from ..texture import Texture

        radiance = self.spectrum_attr(prim, A.RADIANCE)
        if radiance is not None:
            return ("uniform", radiance)
        light = self.UsdLux.DomeLight(prim) if prim.GetTypeName() == "DomeLight" else self.UsdLux.DomeLight_1(prim)
        scalar, colour, blackbody = self.light_rgb(prim, light)
        tex = self.get(light.GetTextureFileAttr())
        if tex is None or not (getattr(tex, "path", "") or ""):
            return ("uniform", self.emitted(scalar, colour, blackbody))
        fmt = str(self.get(light.GetTextureFormatAttr(), "automatic"))
        if fmt not in ("automatic", "latlong"):
            self.warn(f"domefmt:{prim.GetPath()}", f"prim {prim.GetPath()}: dome texture format '{fmt}' is not supported; read as latlong")
        if colour != (1.0, 1.0, 1.0) or blackbody is not None:
            self.warn(
                f"dometint:{prim.GetPath()}", f"prim {prim.GetPath()}: a colour tint on a dome texture is not supported and is ignored"
            )
        path = self.asset_path(tex, prim, "dome texture")
        try:
            texture = Texture.from_file(path, name=path.name) if path is not None else None
        except (OSError, ValueError) as e:
            self.warn(f"unreadable:{prim.GetPath()}", f"prim {prim.GetPath()}: cannot read dome texture {path} ({e}); its fallback is used")
            texture = None
        if texture is None:  # the dome's fallback: its uniform colour
            return ("uniform", self.emitted(scalar, colour, blackbody))
        # The latlong image has +Y up in the dome's frame (OpenEXR latlong, centre towards
        # +Z). In Polychrome's Z-up world that frame is W = Rz(φ)·Rx(90°) for a dome turned
        # by φ about the up axis, which Polychrome's rotation π/2 − φ reproduces. A
        # DomeLight_1 whose poleAxis is Z (or "scene" on a Z-up stage) has its pole on
        # its local +Z already: as if the Y-pole dome were turned by Rx(90°) inside it.
        w = self.world_matrix(prim)[:3, :3]
        w = w / np.cbrt(abs(np.linalg.det(w)))
        rx = np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]], dtype=np.float64)
        pole = "Y"
        if prim.GetTypeName() == "DomeLight_1":
            pole = str(self.get(light.GetPoleAxisAttr(), "scene"))
            if pole == "scene":
                pole = "Y" if self.UsdGeom.GetStageUpAxis(self.stage) == self.UsdGeom.Tokens.y else "Z"
        wz = w if pole == "Z" else w @ rx.T
        if abs(wz[2, 2] - 1.0) > 1e-4:
            self.warn(
                f"dometilt:{prim.GetPath()}",
                f"prim {prim.GetPath()}: a dome tilted away from the up axis is not supported; only its turn about the up axis is used",
            )
        phi = math.atan2(wz[1, 0], wz[0, 0])
        extra = self.json_attr(prim, A.LIGHT) or {}
        rotation = extra.get("rotation") if "rotation" in extra else math.remainder(math.pi / 2 - phi, 2 * math.pi)
        return (
            "texture",
            {
                "texture": texture,
                "strength": float(extra.get("strength", scalar)),
                "rotation": float(rotation),
                "importance_sampling": bool(extra.get("importance_sampling", True)),
            },
        )

    def combined_world(self) -> dict[str, Any] | None:
        """``Scene.set_world`` arguments for the DomeLights read: one as it is; several
        summed (lights add). Uniform radiances: their sum (RGB colours added, the
        same spectrum kind by scale, other mixes tabulated on a 1 nm grid). With
        textures: one latlong of the largest texture's size and rotation, every other
        texture resampled into it (bilinear, as the core looks textures up) and the
        uniform radiances' RGB colours (a spectrum's linear Rec.709 colour) added to each
        texel."""
        if not self.domes:
            return None
        if len(self.domes) == 1:
            kind, value = self.domes[0][1]
            return dict(value) if kind == "texture" else {"radiance": value}
        names = ", ".join(path for path, _ in self.domes)
        uniforms = [v for _, (k, v) in self.domes if k == "uniform"]
        textures = [v for _, (k, v) in self.domes if k == "texture"]
        if not textures:  # exact: no warning
            return {"radiance": _sum_spectra(uniforms)}
        from ..spectra import rec709
        from ..texture import Texture

        base = max(textures, key=lambda d: d["texture"].width * d["texture"].height)
        tex = base["texture"]
        h, w = tex.height, tex.width
        s0 = base["strength"]
        total = np.zeros((h, w, 3), np.float64)
        # Texel centres of the base image → world azimuth offsets of each other texture.
        u = (np.arange(w) + 0.5) / w
        v = 1.0 - (np.arange(h) + 0.5) / h
        for d in textures:
            lin = _linear_texels(d["texture"])
            if d is base:
                total += lin * d["strength"]
                continue
            # Base lookup: u = 0.5 − (φ + r0)/2π; this one: u' = 0.5 − (φ + r)/2π = u − (r − r0)/2π.
            du = (d["rotation"] - base["rotation"]) / (2 * math.pi)
            total += _bilinear(lin, (u - du)[None, :], v[:, None]) * d["strength"]
        for spectrum in uniforms:  # an RGB colour as it is (the texels are RGB too), else its colour
            own = [spectrum.scale * c for c in spectrum.params["rgb"]] if spectrum.kind == "rgb" else rec709(spectrum)
            total += np.asarray(own, np.float64)[None, None, :]
        if s0 > 0:
            total /= s0
        self.warn(
            "domes",
            f"{len(self.domes)} DomeLights ({names}) are summed into one latlong texture of {w} × {h} (the largest's size and turn)",
        )
        world = dict(base)
        world["texture"] = Texture.from_array(total.astype(np.float32), "linear", name=f"{tex.name} + {len(self.domes) - 1} domes")
        world["strength"] = s0 if s0 > 0 else 1.0
        world["importance_sampling"] = any(d["importance_sampling"] for d in textures)
        return world

    # -- camera --------------------------------------------------------------------------
    def read_camera(self, prim, resolution, pixel_aspect=1.0):
        from ..scene import Camera

        m = self.world_matrix(prim)
        for k in range(3):
            n = np.linalg.norm(m[:3, k])
            if not n > 0:
                raise self.error(prim, "its transform is singular")
            if abs(n - 1.0) > 1e-9:  # camera scale does not change the view (as in Blender)
                m[:3, k] /= n
        if abs(np.linalg.det(m[:3, :3])) < 1e-6 or not np.all(np.abs(m) <= F32_MAX):  # axes in a plane (the core: |det| ≥ 1e-12)
            raise self.error(prim, "its transform is singular")
        fields = self.json_attr(prim, A.CAMERA)
        if fields is not None:
            if not isinstance(fields, dict):
                raise self.error(prim, f"{A.CAMERA} must be a JSON object")
            known = set(Camera.__dataclass_fields__) - {"to_world"}
            try:
                return Camera(to_world=m, **{k: v for k, v in fields.items() if k in known})
            except TypeError as e:
                raise self.error(prim, f"{A.CAMERA}: {e}") from None
        cam = self.UsdGeom.Camera(prim)
        ortho = self.get(cam.GetProjectionAttr(), "perspective") == "orthographic"
        focal = float(self.get(cam.GetFocalLengthAttr(), 50.0))
        ax = float(self.get(cam.GetHorizontalApertureAttr(), 20.955))
        ay = float(self.get(cam.GetVerticalApertureAttr(), 15.2908))
        ox = float(self.get(cam.GetHorizontalApertureOffsetAttr(), 0.0))
        oy = float(self.get(cam.GetVerticalApertureOffsetAttr(), 0.0))
        clip = tuple(float(x) for x in self.get(cam.GetClippingRangeAttr(), (1.0, 1000000.0)))
        fstop = float(self.get(cam.GetFStopAttr(), 0.0))
        focus = float(self.get(cam.GetFocusDistanceAttr(), 0.0))
        values = [focal, ax, ay, ox, oy, *clip, fstop, focus]
        if not all(math.isfinite(v) for v in values):
            raise self.error(prim, "its lens, aperture, clipping range, fStop or focusDistance is not finite")
        if not (ax > 0 and ay > 0 and (ortho or focal > 0)):
            raise self.error(prim, f"focal length {focal} and apertures {ax} × {ay} must be positive")
        if fstop < 0 or focus < 0:
            raise self.error(prim, f"fStop {fstop} and focusDistance {focus} must not be negative")
        mm = 100.0 * self.mpu  # tenths of a scene unit → mm
        if not all(abs(v) * max(mm, 1.0) <= F32_MAX for v in values):
            raise self.error(prim, "its lens, aperture, clipping range or focusDistance is too large")
        w, h = resolution if resolution else (ax, ay)
        w = w * pixel_aspect
        # UsdRender's default conform policy, expandAperture: the whole aperture stays visible.
        horizontal = ax / ay >= w / h
        film_w, film_h = (ax, ax * h / w) if horizontal else (ay * w / h, ay)
        # The core's shift counts in units of the fitted side.
        fitted = film_w if horizontal else film_h
        dof = {}
        if fstop > 0 and not ortho:
            # UsdGeomCamera: the aperture's diameter is focalLength / fStop (both in
            # tenths of a scene unit); the core wants the radius in metres.
            if not focus > 0:
                self.warn(f"focus:{prim.GetPath()}", f"prim {prim.GetPath()}: fStop {fstop} with no focusDistance; depth of field is off")
            else:
                dof = dict(aperture_radius=focal * 0.1 * self.mpu / (2.0 * fstop), focus_distance=focus * self.mpu)
        elif fstop > 0:
            self.warn(f"fstop:{prim.GetPath()}", f"prim {prim.GetPath()}: depth of field on an orthographic camera is not read")
        return Camera(
            to_world=m,
            projection="ORTHOGRAPHIC" if ortho else "PERSPECTIVE",
            focal_length=focal * mm,
            sensor_width=ax * mm,
            sensor_height=ay * mm,
            sensor_fit="HORIZONTAL" if horizontal else "VERTICAL",
            ortho_scale=(ax if horizontal else ay) * 0.1 * self.mpu,
            shift_x=ox / fitted,
            shift_y=oy / fitted,
            clip_start=clip[0] * self.mpu,
            clip_end=clip[1] * self.mpu,
            pixel_aspect=pixel_aspect,
            name=str(prim.GetPath()),
            **dof,
        )

    # -- motion ---------------------------------------------------------------------------
    def shutter_times(self, cam_prim, settings: dict[str, Any]) -> tuple[float, float] | None:
        """The shutter in time codes: the camera's ``shutter:open`` / ``shutter:close``
        (offsets from the frame, UsdGeomCamera) around the frame read — the ``time``
        asked for, else the stage's ``startTimeCode`` (0 when unauthored) — or None when it
        does not open (close ≤ open, no camera, or the render settings'
        ``disableMotionBlur`` / ``instantaneousShutter``)."""
        if cam_prim is None:
            return None
        sp = self.stage.GetPrimAtPath(settings["_settings_prim"]) if settings.get("_settings_prim") else None
        if sp:
            for name in ("disableMotionBlur", "instantaneousShutter"):
                if self.get(sp.GetAttribute(name), False):
                    return None
        cam = self.UsdGeom.Camera(cam_prim)
        t_open = float(self.get(cam.GetShutterOpenAttr(), 0.0))
        t_close = float(self.get(cam.GetShutterCloseAttr(), 0.0))
        if not (math.isfinite(t_open) and math.isfinite(t_close)):
            raise self.error(cam_prim, "shutter:open / shutter:close is not finite")
        if not t_close > t_open:
            return None
        if self.time.IsEarliestTime():
            base = float(self.stage.GetStartTimeCode()) if self.stage.HasAuthoredTimeCodeRange() else 0.0
        else:
            base = float(self.time.GetValue())
        self.frame = base
        return base + t_open, base + t_close

    @staticmethod
    def key_count(sample_times, t0: float, t1: float) -> int:
        """Keys evenly spaced over the shutter: 3 (as Cycles' camera), two more per time
        sample inside it, at most 17 (transform_motion adds keys for fast turns)."""
        inside = sum(1 for t in sample_times if t0 < t < t1)
        return min(17, 3 + 2 * inside)

    def key_count_of_samples(self, times, shutter) -> int:
        """The keys for time samples ``times``: the samples themselves when they are evenly
        spaced from the shutter's opening to its closing (write_stage's motion), else
        ``key_count``."""
        grid = np.array(sorted(times))
        if (
            len(grid) >= 2
            and np.isclose(grid[0], shutter[0])
            and np.isclose(grid[-1], shutter[1])
            and np.allclose(np.diff(grid), grid[1] - grid[0])
        ):
            return len(grid)
        return self.key_count(times, *shutter)

    def key_matrix(self, prim, t: float) -> np.ndarray:
        m = np.array(self.key_matrix_row(prim, t), dtype=np.float64).T
        if not self.identity_correction:
            m = self.correction @ m
        if not np.all(np.isfinite(m)):
            raise self.error(prim, f"its transform at time {t:g} is not finite")
        return m

    def transform_motion(self, prim, shutter) -> list[np.ndarray] | None:
        """Object → world keys over the shutter when the prim's (or an ancestor's) local
        transform is time-sampled; None when it is not; one key (its placement during the
        exposure) when it is time-sampled but stands still over the shutter."""
        times: set[float] = set()
        varying = False
        interval = self.Gf.Interval(shutter[0], shutter[1])
        angles = []  # time-varying rotateX/Y/Z/XYZ/... ops: USD interpolates their angles
        p = prim
        while p and p.IsValid() and not p.IsPseudoRoot():
            x = self.UsdGeom.Xformable(p)
            if x:
                for op in x.GetOrderedXformOps():
                    attr = op.GetAttr()
                    if attr.ValueMightBeTimeVarying():
                        varying = True
                        times.update(attr.GetTimeSamplesInInterval(interval))
                        if op.GetOpName().split(":")[1].startswith("rotate"):
                            angles.append(attr)
                if x.GetResetXformStack():
                    break
            p = p.GetParent()
        if not varying:
            return None

        def op_turn(ta: float, tb: float) -> float:  # the largest change of an authored angle (radians)
            turns = [np.abs(np.subtract(a.Get(tb), a.Get(ta), dtype=np.float64)).max() for a in angles]
            return math.radians(float(max(turns, default=0.0)))

        k = self.key_count_of_samples(times, shutter)
        while True:
            ts = np.linspace(shutter[0], shutter[1], k)
            keys = [self.key_matrix(prim, t) for t in ts]
            # The core interpolates decomposed transforms between keys (the shorter way
            # round): keys are added until no two neighbours turn by more than MAX_KEY_TURN,
            # as matrices or as the angles USD interpolates (a 360° spin between two samples).
            turn = max(max(_turn(a, b), op_turn(ta, tb)) for a, b, ta, tb in zip(keys, keys[1:], ts, ts[1:]))
            if k >= MAX_MOTION_KEYS or turn <= MAX_KEY_TURN * (1 + 1e-9):
                break
            k = min(2 * k - 1, MAX_MOTION_KEYS)
        if all(np.allclose(keys[0], m, rtol=0, atol=1e-9) for m in keys[1:]):
            return keys[:1]
        return keys

    def instancer_motion(self, shutter) -> dict[int, list[np.ndarray]]:
        """Instance index → keys of PointInstancer instances that move over the shutter:
        ``ComputeInstanceTransformsAtTimes`` (positions, orientations and scales
        interpolated, velocities and angular velocities extrapolated from the frame) and the
        instancer's own transform at each key."""
        PI = self.UsdGeom.PointInstancer
        out: dict[int, list[np.ndarray]] = {}
        computed: dict[str, Any] = {}
        interval = self.Gf.Interval(shutter[0], shutter[1])
        for prim, start, which, rel in self.instancer_runs:
            path = str(prim.GetPath())
            if path not in computed:
                pi = PI(prim)
                times: set[float] = set()
                for attr in (pi.GetPositionsAttr(), pi.GetOrientationsAttr(), pi.GetScalesAttr()):
                    times.update(attr.GetTimeSamplesInInterval(interval))
                k = self.key_count(times, *shutter)
                while True:
                    ts = [float(t) for t in np.linspace(shutter[0], shutter[1], k)]
                    xf = pi.ComputeInstanceTransformsAtTimes(ts, self.frame, PI.IncludeProtoXform, PI.IgnoreMask)
                    if xf is None or len(xf) != k or any(len(x) != len(xf[0]) for x in xf):
                        self.warn(
                            f"pimotion:{path}", f"prim {path}: its instance motion cannot be computed; instances are placed at the frame"
                        )
                        computed[path] = None
                        break
                    inst = np.stack([np.asarray(x, dtype=np.float64).reshape(-1, 4, 4) for x in xf])  # (K, n, 4, 4) row vectors
                    r = inst[:, :, :3, :3] / np.maximum(np.linalg.norm(inst[:, :, :3, :3], axis=3, keepdims=True), 1e-300)
                    cos = (np.einsum("knij,knij->kn", r[:-1], r[1:]) - 1.0) / 2.0
                    if k >= MAX_MOTION_KEYS or float(np.arccos(np.clip(cos, -1, 1)).max(initial=0.0)) <= MAX_KEY_TURN * (1 + 1e-9):
                        worlds = [np.array(self.key_matrix_row(prim, t)) for t in ts]
                        computed[path] = (inst, worlds)
                        break
                    k = min(2 * k - 1, MAX_MOTION_KEYS)
            if computed[path] is None:
                continue
            inst, worlds = computed[path]
            if len(inst[0]) <= int(np.max(which, initial=-1)):
                continue
            keys = np.stack([rel[None] @ inst[i][which] @ w[None] for i, w in enumerate(worlds)])  # (K, m, 4, 4)
            keys = np.transpose(keys, (0, 1, 3, 2))
            if not self.identity_correction:
                keys = self.correction[None, None] @ keys
            if not np.all(np.isfinite(keys)):
                self.warn(
                    f"bad:pimotion:{path}",
                    f"prim {path}: its instance positions, orientations, scales or velocities over the shutter are not finite; "
                    "its instances are placed at the frame without motion blur",
                )
                continue
            for j in range(len(which)):
                ks = keys[:, j]
                if not np.allclose(ks[0], ks[1:], rtol=0, atol=1e-9):
                    out[start + j] = list(ks)
        return out

    def placements_at(self, prim, t: float) -> np.ndarray | None:
        """The world transforms (column vectors, metres, Z up) of every instance a
        PointInstancer places at time code ``t``, in the order read_point_instancer places
        them at the frame: it read again at ``t`` (time-sampled positions interpolated,
        velocities extrapolated from the frame), quietly; None when it cannot be read at ``t``."""
        saved = (self.time, self.cache, self.instances, self.instancer_runs, self.nested_runs, self.base_time, self.warned)
        keys = set(self.meshes)
        if t not in self.key_caches:
            self.key_caches[t] = self.UsdGeom.XformCache(self.Usd.TimeCode(t))
        self.time, self.cache, self.base_time = self.Usd.TimeCode(t), self.key_caches[t], self.Usd.TimeCode(self.frame)
        self.instances, self.instancer_runs, self.nested_runs, self.warned = [], [], [], set(self.warned)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                self.read_point_instancer(prim)
            return np.stack([m for _, m, *_ in self.instances]) if self.instances else None
        except Exception as e:  # noqa: BLE001 - as guarded
            if not _is_bad_data(e):
                raise
            return None
        finally:
            self.time, self.cache, self.instances, self.instancer_runs, self.nested_runs, self.base_time, self.warned = saved
            for key in set(self.meshes) - keys:  # a prototype seen only at t is not drawn
                del self.meshes[key]
                self.mesh_prims.pop(key, None)

    def nested_motion(self, shutter) -> dict[int, list[np.ndarray]]:
        """Instance index → keys of the instances of PointInstancers that hold
        PointInstancers, each instancer re-read at K times evenly spaced over the shutter
        (K as for transforms: 3 plus 2 per authored sample inside the shutter, of any
        attribute in its subtree or prototypes, doubled until no instance turns by more
        than 45° between neighbours); one warning when its instances change in number."""
        out: dict[int, list[np.ndarray]] = {}
        interval = self.Gf.Interval(shutter[0], shutter[1])
        Usd = self.Usd
        for prim, start, end in self.nested_runs:
            times: set[float] = set()
            seen: set[str] = set()
            pending = [prim]
            while pending:  # the instancer, its prototypes and theirs (prototypes may live anywhere)
                top = pending.pop()
                for sub in Usd.PrimRange(top, Usd.TraverseInstanceProxies(PROTOTYPE_PREDICATE(Usd))):
                    if str(sub.GetPath()) in seen:
                        continue
                    seen.add(str(sub.GetPath()))
                    for attr in sub.GetAttributes():
                        if attr.ValueMightBeTimeVarying():
                            times.update(attr.GetTimeSamplesInInterval(interval))
                    if sub.GetTypeName() == "PointInstancer":
                        pending.extend(
                            self.stage.GetPrimAtPath(t) for t in self.UsdGeom.PointInstancer(sub).GetPrototypesRel().GetForwardedTargets()
                        )
                pending = [p for p in pending if p and str(p.GetPath()) not in seen]
            k = self.key_count(times, *shutter)
            path = str(prim.GetPath())
            while True:
                ts = [float(t) for t in np.linspace(shutter[0], shutter[1], k)]
                keys = [self.placements_at(prim, t) for t in ts]
                if any(m is None or len(m) != end - start for m in keys):
                    self.warn(
                        f"pimotion:{path}",
                        f"prim {path}: its nested instances change in number over the shutter; they are placed at the frame",
                    )
                    keys = None
                    break
                stack = np.stack(keys)  # (K, n, 4, 4), column vectors
                r = stack[:, :, :3, :3] / np.maximum(np.linalg.norm(stack[:, :, :3, :3], axis=2, keepdims=True), 1e-300)
                cos = (np.einsum("knij,knij->kn", r[:-1], r[1:]) - 1.0) / 2.0
                if k >= MAX_MOTION_KEYS or float(np.arccos(np.clip(cos, -1, 1)).max(initial=0.0)) <= MAX_KEY_TURN * (1 + 1e-9):
                    break
                k = min(2 * k - 1, MAX_MOTION_KEYS)
            if keys is None:
                continue
            if not np.all(np.isfinite(stack)):
                self.warn(
                    f"bad:pimotion:{path}", f"prim {path}: its instances over the shutter are not finite; they are placed at the frame"
                )
                continue
            for j in range(end - start):
                ks = stack[:, j]
                if not np.allclose(ks[0], ks[1:], rtol=0, atol=1e-9):
                    out[start + j] = list(ks)
        return out

    def placement_problem(self, key: str, matrices) -> str | None:
        """Why the core would refuse an instance of mesh ``key`` placed by ``matrices``
        (its transform, or its motion keys), or None: a singular transform (float32
        determinant 0, as the core computes it) or a vertex placed beyond ±1e12 (checked
        on the mesh's bounding box, whose corners bound every vertex an affine map moves)."""
        m = self.meshes[key]
        if "_box" not in m:
            v = np.asarray(m["vertices"], np.float64).reshape(-1, 3)
            lo, hi = (v.min(axis=0), v.max(axis=0)) if len(v) else (np.zeros(3), np.zeros(3))
            m["_box"] = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        for mat in matrices:
            mat = np.asarray(mat, np.float64)
            c = mat[:3, :3].astype(np.float32)
            with np.errstate(all="ignore"):
                det = np.dot(c[:, 2], np.cross(c[:, 0], c[:, 1]))  # glam's Mat3::determinant, in float32
            if not (np.isfinite(det) and det != 0):
                return "its transform is singular (zero scale?)"
            corners = m["_box"] @ mat[:3, :3].T + mat[:3, 3]
            if not np.abs(corners).max() <= MAX_COORDINATE:
                return f"its transform places vertices beyond ±{MAX_COORDINATE:g}"
        return None

    def guarded_motion(self, prim, shutter):
        """transform_motion, or (one warning naming the prim) None when its transform over
        the shutter is not finite: the prim is then placed at the frame, unblurred."""
        try:
            return self.transform_motion(prim, shutter)
        except PrimError as e:
            self.warn(f"bad:motion:{prim.GetPath()}", self.skip_message(prim, e, "it is placed at the frame without motion blur"))
            return None

    def key_matrix_row(self, prim, t: float):
        if t not in self.key_caches:
            self.key_caches[t] = self.UsdGeom.XformCache(self.Usd.TimeCode(t))
        return self.key_caches[t].GetLocalToWorldTransform(prim)

    def deformation(self, key: str, shutter) -> dict[str, np.ndarray] | None:
        """motion_vertices (and motion_normals) of a mesh whose own attributes (points,
        widths, radius, ...) are time-sampled: the shape re-read at each key; None when it
        keeps its shape, or (one warning) when its topology changes over the shutter."""
        prim = self.mesh_prims.get(key)
        base = self.meshes[key]
        if prim is None or base is None:
            return None
        interval = self.Gf.Interval(shutter[0], shutter[1])
        times: set[float] = set()
        varying = False
        for attr in prim.GetAttributes():
            name = attr.GetName()
            if name.startswith("xformOp") or name in ("visibility", "purpose", "extent") or name.startswith("primvars:display"):
                continue
            if attr.ValueMightBeTimeVarying():
                varying = True
                times.update(attr.GetTimeSamplesInInterval(interval))
        if not varying:
            return None
        frame = self.time
        shapes = []
        try:
            for t in np.linspace(shutter[0], shutter[1], self.key_count_of_samples(times, shutter)):
                self.time = self.Usd.TimeCode(float(t))
                shapes.append(self.mesh_arrays(prim))
        finally:
            self.time = frame
        n = len(base["vertices"])
        if any(a is None or len(a["vertices"]) != n or len(a["triangles"]) != len(base["triangles"]) for a in shapes):
            self.warn(
                f"topology:{prim.GetPath()}",
                f"prim {prim.GetPath()}: its topology changes over the shutter; its deformation is not blurred",
            )
            return None
        verts = np.stack([a["vertices"] for a in shapes])
        if np.array_equal(verts.min(axis=0), verts.max(axis=0)):
            return None
        out = {"motion_vertices": verts}
        if base["normals"] is not None and all(a["normals"] is not None and a["normals"].shape == base["normals"].shape for a in shapes):
            normals = np.stack([a["normals"] for a in shapes])
            if not np.array_equal(normals.min(axis=0), normals.max(axis=0)):  # still normals stay the mesh's own
                out["motion_normals"] = normals
        return out

    # -- the whole stage ------------------------------------------------------------------
    def read(self):
        from ..scene import Camera, Scene

        Usd, UsdGeom = self.Usd, self.UsdGeom
        # Every material first, in stage order (keeps the order of a round trip).
        for prim in Usd.PrimRange(self.stage.GetPseudoRoot(), Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)):
            if prim.GetTypeName() == "Material":
                self.material_for(prim)

        it = iter(Usd.PrimRange(self.stage.GetPseudoRoot(), Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)))
        for prim in it:
            if prim.IsPseudoRoot():
                continue
            self.current_prim = str(prim.GetPath())  # named by read_stage if pxr raises
            t = str(prim.GetTypeName())
            img = UsdGeom.Imageable(prim)
            if img and (
                img.ComputeVisibility(self.time) == UsdGeom.Tokens.invisible
                or img.ComputePurpose() in (UsdGeom.Tokens.guide, UsdGeom.Tokens.proxy)
            ):
                it.PruneChildren()
                continue
            reader = {
                "PointInstancer": self.read_point_instancer,
                "SphereLight": self.read_sphere_light,
                "RectLight": self.read_rect_light,
                "DiskLight": self.read_disk_light,
                "CylinderLight": self.read_cylinder_light,
                "DistantLight": self.read_distant_light,
                "DomeLight": self.read_dome_light,
                "DomeLight_1": self.read_dome_light,
            }.get(t, self.read_mesh if t in GEOMETRY_TYPES else None)
            if reader is not None:
                n_lights = len(self.lights)
                self.guarded(prim, lambda: reader(prim))
                for i in range(n_lights, len(self.lights)):  # its motion is read with the shutter
                    self.light_prims[i] = prim
                if t == "PointInstancer":
                    it.PruneChildren()
            elif t == "Camera":
                self.cameras.append(prim)
            elif t in ("Material", "RenderSettings", "RenderProduct", "RenderVar", "RenderPass"):
                it.PruneChildren()
            elif t in _SILENT_TYPES:
                continue
            else:
                key = self.key_of(prim)
                what = "light" if t in _LIGHTS_SKIPPED else "prim type"
                self.warn(f"type:{key}", f"prim {prim.GetPath()}: {what} '{t}' is not supported and is skipped")

        scene = Scene()
        scene.materials = list(self.materials)
        settings = read_settings_from_stage(self.stage, self.path, warn=self.warn)
        resolution = self.resolution or ((settings["width"], settings["height"]) if "width" in settings else None)
        candidates = list(self.cameras)
        cam_path = settings.get("_camera")
        if cam_path:
            cam_prim = self.stage.GetPrimAtPath(cam_path)
            if not cam_prim or cam_prim.GetTypeName() != "Camera":
                self.warn(
                    "rendercamera",
                    f"prim {settings['_settings_prim']}: camera {cam_path} is not a UsdGeom.Camera; "
                    + ("the stage's first camera is used" if candidates else "the default camera is used"),
                )
            else:
                candidates.insert(0, cam_prim)
        # The render camera, else the first camera that reads (a malformed one is warned).
        cam_prim = None
        for candidate in candidates:
            got: list[Any] = []
            if self.guarded(
                candidate,
                lambda c=candidate: got.append(self.read_camera(c, resolution, settings.get("_pixel_aspect", 1.0))),
                "it is skipped (the next camera, else the default camera, is used)",
            ):
                cam_prim, scene.camera = candidate, got[0]
                break
        if cam_prim is None:
            if not candidates:
                self.warn("camera", "the stage has no UsdGeom.Camera; the default camera at the origin looking down −Z is used")
            scene.camera = Camera()
        # Motion blur over the camera's shutter (docs/usd.md, "Motion").
        shutter = None
        try:
            shutter = self.shutter_times(cam_prim, settings)
        except PrimError as e:
            self.warn(f"bad:shutter:{cam_prim.GetPath()}", self.skip_message(cam_prim, e, "no motion blur"))
        if shutter is not None:
            cam_keys = self.guarded_motion(cam_prim, shutter)
            if cam_keys is not None:
                for m in cam_keys:  # camera scale does not change the view (read_camera)
                    m[:3, :3] /= np.linalg.norm(m[:3, :3], axis=0)
                if len(cam_keys) > 1:
                    scene.camera.motion = cam_keys
                else:
                    scene.camera.to_world = cam_keys[0]

        order = sorted(
            self.meshes,
            key=lambda k: (
                self.meshes[k] is None,
                float("inf") if self.meshes[k] is None or self.meshes[k]["order"] is None else self.meshes[k]["order"],
            ),
        )
        index: dict[str, int] = {}
        for key in order:
            m = self.meshes[key]
            if m is None:
                continue
            motion = {}
            if shutter:
                try:
                    motion = self.deformation(key, shutter) or {}
                except PrimError as e:
                    self.warn(f"bad:deform:{key}", self.skip_message(self.mesh_prims[key], e, "its deformation is not blurred"))
            try:
                index[key] = scene.add_mesh(
                    m["name"],
                    m["vertices"],
                    m["triangles"],
                    normals=m["normals"],
                    uvs=m["uvs"],
                    material=m["material"],
                    material_ids=m["material_ids"],
                    place=False,
                    uv_maps=m.get("uv_maps"),
                    attributes=m.get("attributes"),
                    tangents=m.get("tangents"),
                    **motion,
                )
            except ValueError as e:  # the scene's own checks (a last line: the reader checks first)
                prim = self.mesh_prims.get(key)
                self.warn(f"bad:{key}", self.skip_message(prim if prim is not None else key, e))
        refused: dict[str, tuple[str, str, int]] = {}  # prim → (first instance, problem, how many)
        instanced = self.instancer_motion(shutter) if shutter is not None and self.instancer_runs else {}
        if shutter is not None and self.nested_runs:
            instanced.update(self.nested_motion(shutter))
        for i, (key, matrix, name, *rest) in enumerate(self.instances):
            if key not in index:  # its mesh was refused (warned)
                continue
            visibility = rest[0] if rest else None
            moving = rest[1] if len(rest) > 1 else None
            motion = self.guarded_motion(moving, shutter) if moving is not None and shutter is not None else instanced.get(i)
            if motion is not None and len(motion) == 1:  # animated, but still while the shutter is open
                matrix, motion = motion[0], None
            problem = self.placement_problem(key, [matrix] if motion is None else motion)
            if problem is not None:  # one warning per prim (a PointInstancer's: with their number)
                owner = name.split("[")[0]
                first, first_problem, count = refused.get(owner, (name, problem, 0))
                refused[owner] = (first, first_problem, count + 1)
                continue
            try:
                scene.add_instance(index[key], matrix, name, visibility=visibility, motion=motion)
            except ValueError as e:  # the scene's own checks (a last line, as for meshes)
                self.warn(f"bad:instance:{name}", self.skip_message(name, e))
        for first, problem, count in refused.values():
            more = f" (and {count - 1} more of its instances)" if count > 1 else ""
            self.warn(f"bad:instance:{first}", f"prim {first}: {problem}; it is skipped{more}")
        for i, light in enumerate(self.lights):
            prim = self.light_prims.get(i)
            if shutter is not None and prim is not None:
                keys = self.guarded_motion(prim, shutter)
                if keys is not None and len(keys) > 1:
                    light.motion = keys  # point, spot and distant lights move (docs/usd.md, "Motion")
            d = light.to_dict()
            if not _f32_finite(d):  # e.g. a normalized light of a tiny area: the core's float32 overflows
                self.warn(f"bad:light:{d.get('name')}", f"prim {d.get('name')}: its emission is too large for the renderer; it is skipped")
                continue
            scene.add_light(light)
        for path, (kind, _) in self.domes if shutter is not None else []:
            keys = self.guarded_motion(self.stage.GetPrimAtPath(path), shutter) if kind == "texture" else None
            if keys is not None and len(keys) > 1 and not all(np.allclose(k[:3, :3], keys[0][:3, :3]) for k in keys):
                self.warn(f"domemotion:{path}", f"prim {path}: a DomeLight does not turn over the shutter; it is rendered at the frame")
        world = self.combined_world()
        if world is not None:
            scene.set_world(**world)
        return scene


def _primvar_values(pv, time):
    """A primvar's flattened values as a sequence (a scalar primvar, ``float primvars:x =
    0`` — legal UsdGeom, constant by nature — as one value); None when it has none."""
    if not pv or not pv.HasValue():
        return None
    value = pv.ComputeFlattened(time)
    if value is not None and not pv.GetTypeName().isArray:
        return [value]
    return value


def _f32_finite(d) -> bool:
    """Whether every number in a (JSON-like) description is finite in float32."""
    if isinstance(d, dict):
        return all(_f32_finite(v) for v in d.values())
    if isinstance(d, (list, tuple)):
        return all(_f32_finite(v) for v in d)
    if isinstance(d, (float, int)) and not isinstance(d, bool):
        return math.isfinite(d) and abs(d) <= F32_MAX
    return True


def _sum_spectra(spectra):
    """The sum of emitted spectra: RGB colours added (exact under the linear uplift), one
    kind with the same parameters by its scales, else tabulated on a 1 nm grid."""
    from .. import _core
    from ..spectra import Spectrum, rgb, tabulated

    if all(s.kind == "rgb" for s in spectra):
        return rgb(*(float(sum(s.scale * s.params["rgb"][i] for s in spectra)) for i in range(3)))
    if all(s.kind == spectra[0].kind and s.params == spectra[0].params for s in spectra):
        return Spectrum(spectra[0].kind, spectra[0].params, float(sum(s.scale for s in spectra)))
    wl = np.arange(360.0, 831.0)
    settings = json.dumps({"wavelengths": wl.tolist()})
    values = sum(np.asarray(_core.spectrum_values(json.dumps(s.to_dict()), settings), np.float64) for s in spectra)
    return tabulated(wl, values)


def _linear_texels(texture) -> np.ndarray:
    """A texture's texels as linear float RGB (sRGB bytes decoded, IEC 61966-2-1)."""
    px = np.asarray(texture.pixels)[..., :3]
    if texture.encoding == "linear":
        return px.astype(np.float64)
    c = px.astype(np.float64) / 255.0
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def _bilinear(img: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Bilinear lookup of an (H, W, 3) latlong at (u, v) (broadcast), as the core's
    environment does: texel centres at (i + ½)/W, rows from the top (v = 1), u repeated,
    v extended."""
    h, w = img.shape[:2]
    u, v = np.broadcast_arrays(u, v)
    x = u * w - 0.5
    y = (1.0 - v) * h - 0.5
    x0, y0 = np.floor(x), np.floor(y)
    fx, fy = (x - x0)[..., None], (y - y0)[..., None]
    xi0, xi1 = x0.astype(np.int64) % w, (x0.astype(np.int64) + 1) % w
    yi0, yi1 = np.clip(y0.astype(np.int64), 0, h - 1), np.clip(y0.astype(np.int64) + 1, 0, h - 1)
    top = img[yi0, xi0] * (1 - fx) + img[yi0, xi1] * fx
    bottom = img[yi1, xi0] * (1 - fx) + img[yi1, xi1] * fx
    return top * (1 - fy) + bottom * fy


def _turn(a: np.ndarray, b: np.ndarray) -> float:
    """The angle (radians) by which the rotation of transform b differs from a's (scale removed)."""
    ra, rb = a[:3, :3], b[:3, :3]
    na, nb = np.linalg.norm(ra, axis=0), np.linalg.norm(rb, axis=0)
    if not (np.all(na > 0) and np.all(nb > 0)):
        return 0.0
    r = (ra / na).T @ (rb / nb)
    return math.acos(max(-1.0, min(1.0, (float(np.trace(r)) - 1.0) / 2.0)))


def _blackbody_white(temperature: float):
    """Planck's law at ``temperature`` K scaled to luminance 1 (as RGB white is)."""
    from .. import _core
    from ..spectra import blackbody

    spec = blackbody(temperature)
    settings = json.dumps({"wavelength_count": 81})
    y = _core.spectrum_xyz(json.dumps(spec.to_dict()), settings)[1]
    return spec * (1.0 / y if y > 0 else 1.0)


def open_stage(path, *, report: bool = True):
    """Opens ``path`` as a USD stage; ValueError naming the file when it cannot. USD's
    own diagnostics (unresolved references, ...) become one Python warning each instead
    of lines printed on stderr (with ``report`` False they are dropped)."""
    _, _, Usd, _, _, _, _ = _pxr()
    from pxr import UsdUtils

    p = Path(path)
    if not p.is_file():
        raise ValueError(f"{p}: no such file")
    delegate = UsdUtils.CoalescingDiagnosticDelegate()
    try:
        try:
            stage = Usd.Stage.Open(str(p))
        except Exception as e:  # noqa: BLE001 - pxr raises Tf.ErrorException
            import re

            messages = [" ".join(m.split()) for m in re.findall(r" : '(.*?)'\s*(?=\n\s*Error in|$)", str(e), re.S)]
            detail = messages[0] if messages else (str(e).strip().splitlines() or ["unreadable"])[0]
            detail = re.sub(r"pxrInternal_\w+?__pxrReserved__::", "", detail).replace(str(p) + ":", "line ")
            raise ValueError(f"{p}: not a readable USD stage ({detail[:200]})") from None
        if stage is None:
            raise ValueError(f"{p}: not a readable USD stage")
        # .mtlx documents it references, read by mtlxdoc.py (usd-core has no usdMtlx): USD's
        # "cannot determine file format" for them is then not a problem.
        from . import mtlxdoc

        notes: list[str] = []
        handled = mtlxdoc.attach(stage, notes.append)
        if report:
            seen = set()
            for diagnostic in delegate.TakeUncoalescedDiagnostics():
                text = " ".join(str(diagnostic.commentary).split())
                if "Cannot determine file format" in text and any(h in text for h in handled):
                    continue
                if text and text not in seen:
                    seen.add(text)
                    warnings.warn(f"{p}: {text}", stacklevel=3)
            for text in dict.fromkeys(notes):
                warnings.warn(f"{p}: {text}", stacklevel=3)
    finally:
        del delegate
    return stage


def read_settings_from_stage(stage, path, warn=None) -> dict[str, Any]:
    """RenderSettings fields stored in the stage: the prim named by the stage's
    ``renderSettingsPrimPath``, else /Render/PolychromeSettings, else the first
    UsdRender.Settings. Keys ``_camera`` / ``_settings_prim`` give its camera. A malformed
    value (a resolution that is not positive, a non-finite number) is left out, with
    ``warn(key, message)`` when given."""
    from pxr import UsdRender

    def bad(prim, what: str) -> None:
        if warn is not None:
            warn(f"bad:{prim.GetPath()}:{what}", f"prim {prim.GetPath()}: {what}; it is ignored")

    prim = None
    meta = stage.GetMetadata("renderSettingsPrimPath") if stage.HasAuthoredMetadata("renderSettingsPrimPath") else None
    for candidate in (meta, A.RENDER_SETTINGS_PATH):
        if candidate:
            p = stage.GetPrimAtPath(candidate)
            if p and p.IsA(UsdRender.Settings):
                prim = p
                break
    if prim is None:
        for p in stage.Traverse():
            if p.IsA(UsdRender.Settings):
                prim = p
                break
    out: dict[str, Any] = {}
    if prim is None:
        return out
    rs = UsdRender.Settings(prim)
    out["_settings_prim"] = str(prim.GetPath())
    res_attr = rs.GetResolutionAttr()
    if res_attr and res_attr.HasAuthoredValue():
        res = res_attr.Get()
        if res is None or res[0] <= 0 or res[1] <= 0:
            bad(prim, f"resolution {res} must be positive")
        else:
            out["width"], out["height"] = int(res[0]), int(res[1])
    aspect_attr = rs.GetPixelAspectRatioAttr()
    if aspect_attr and aspect_attr.HasAuthoredValue():
        aspect = float(aspect_attr.Get())
        if not (math.isfinite(aspect) and aspect > 0):
            bad(prim, f"pixelAspectRatio {aspect} must be positive")
        else:
            out["_pixel_aspect"] = aspect
    targets = rs.GetCameraRel().GetForwardedTargets()
    if targets:
        out["_camera"] = str(targets[0])
    import dataclasses

    from ..render import RenderSettings

    fields = {f.name for f in dataclasses.fields(RenderSettings)} - set(A.NOT_STORED)
    for attr in prim.GetAttributes():
        name = attr.GetName()
        field = name[len(A.NAMESPACE) + 1 :] if name.startswith(A.NAMESPACE + ":") else None
        if field not in fields or not attr.HasAuthoredValue():
            continue
        v = attr.Get()
        if v is None:
            continue
        if hasattr(v, "__len__") and not isinstance(v, str):
            v = [float(x) for x in v]
            if not all(math.isfinite(x) for x in v):
                bad(prim, f"{name} is not finite")
                continue
        elif isinstance(v, float) and not math.isfinite(v):
            bad(prim, f"{name} is not finite")
            continue
        elif not isinstance(v, (bool, int, float)):
            v = str(v)
        out[field] = v
    return out


def _check_level(level) -> int:
    if isinstance(level, bool) or not isinstance(level, (int, np.integer)) or not 0 <= int(level) <= MAX_SUBDIVISION_LEVEL:
        raise ValueError(f"subdivision_level must be a whole number from 0 to {MAX_SUBDIVISION_LEVEL}, got {level!r}")
    return int(level)


def read_stage(path, *, resolution=None, time=None, subdivision_level=None):
    """Reads the USD stage at ``path`` into a :class:`polychrome.Scene`.

    ``resolution`` (width, height) decides how the camera's aperture is conformed to the
    image (UsdRender's expandAperture); by default the stage's render settings' resolution,
    else the aperture's own aspect. ``time``: the time code to read animated values at
    (an animation's frame number); by default the earliest. ``subdivision_level``: how
    many times subdivision surfaces (``subdivisionScheme`` catmullClark, USD's default,
    or bilinear) are refined, 0 to 6 (default 2; 0 renders the control cage); a prim's
    own ``polychrome:subdivisionLevel`` wins.

    A prim whose data is malformed is skipped with one ``warnings.warn`` naming it and
    the problem (docs/usd.md, "Malformed prims are skipped"); a stage that cannot be opened
    raises ``ValueError`` naming the file."""
    reader = _Reader(Path(path), resolution, time, subdivision_level)
    try:
        return reader.read()
    except Exception as e:  # noqa: BLE001 - pxr's Tf.ErrorException is not importable by name here
        if type(e).__name__ != "ErrorException":
            raise
        # E.g. an xformOp whose value type does not match its op (found by fuzzing):
        # a ValueError naming the file and the prim, not pxr's internal exception.
        import re

        messages = [" ".join(m.split()) for m in re.findall(r" : '(.*?)'\s*(?=\n\s*Error in|$)", str(e), re.S)]
        detail = messages[0] if messages else (str(e).strip().splitlines() or ["USD error"])[0]
        where = getattr(reader, "current_prim", None)
        raise ValueError(f"{path}: " + (f"prim {where}: " if where else "") + detail) from None
    finally:
        if reader.unpack_dir is not None:  # files copied out of a .usdz (read by now)
            reader.unpack_dir.cleanup()


def read_settings(path) -> dict[str, Any]:
    """The :class:`polychrome.RenderSettings` fields a stage stores (its UsdRender.Settings
    resolution and ``polychrome:`` attributes), as a dict ready for ``RenderSettings(**d)``."""
    stage = open_stage(path, report=False)  # read_stage reports the stage's problems
    return {k: v for k, v in read_settings_from_stage(stage, Path(path)).items() if not k.startswith("_")}
