"""Writes a :class:`polychrome.Scene` as a USD stage (``write_stage``).

Layout of a written stage (Z up, metres)::

    /World                         Xform (default prim)
        Looks/<material>           UsdShade.Material + UsdPreviewSurface, polychrome:* spectra
        <instance>                 UsdGeom.Mesh when its mesh is placed once, with xformOp:transform
        <instance>                 Xform, instanceable, referencing /Prototypes/<mesh> when shared
        Camera                     UsdGeom.Camera, polychrome:camera
        Lights/<light>             UsdLux SphereLight (treatAsPoint) / DomeLight (the world)
    /Prototypes                    class prim (not rendered by itself): shared meshes
    /Render/PolychromeSettings     UsdRender.Settings with polychrome:* render settings

Meshes keep their triangles in order, per-vertex normals and ``primvars:st``, and one
GeomSubset per material when they have per-triangle materials. The standard USD values
(preview surface colours, UsdLux intensities, camera lens) are written for other tools;
the ``polychrome:`` attributes (``attributes.py``) keep the spectral data exactly.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any
import warnings

import numpy as np

from ..ior import LAMBDA_D
from . import attributes as A

# Linear Rec.709 from CIE XYZ (D65 white), IEC 61966-2-1.
_XYZ_TO_REC709 = np.array(
    [
        [3.2404542, -1.5371385, -0.4985314],
        [-0.9692660, 1.8760108, 0.0415560],
        [0.0556434, -0.2040259, 1.0572252],
    ]
)
#: Wavelength grid of the RGB previews written for other tools (380..780 nm every 5 nm).
PREVIEW_GRID = json.dumps({"wavelength_count": 81})
#: Radius given to point lights so that renderers without point lights still see them.
POINT_LIGHT_RADIUS = 0.05


def _pxr():
    try:
        from pxr import Gf, Sdf, Tf, Usd, UsdGeom, UsdLux, UsdRender, UsdShade, Vt
    except ImportError as e:  # pragma: no cover - depends on the install
        raise ImportError("polychrome.usd needs usd-core: pip install 'polychrome[usd]'") from e
    return Gf, Sdf, Tf, Usd, UsdGeom, UsdLux, UsdRender, UsdShade, Vt


# --------------------------------------------------------------------------- colours


class _Rgb:
    """RGB previews of spectrum descriptions through the core's own CIE observer."""

    def __init__(self, settings_json: str):
        from .. import _core

        self._core = _core
        self._settings = settings_json
        grid, _ = _core.wavelength_grid(settings_json)
        self._lambdas = np.asarray(grid, dtype=np.float64)
        d65 = {"type": "d65", "scale": 1.0}
        self._d65 = np.asarray(_core.spectrum_values(json.dumps(d65), settings_json, "illuminant"), np.float64)
        xyz = np.array(_core.spectrum_xyz(json.dumps(d65), settings_json))
        self._white = _XYZ_TO_REC709 @ xyz  # RGB of D65: reflectance 1 and emission "white" map to 1
        self._white_lum = self._white / xyz[1]

    def _rgb_of(self, values: np.ndarray) -> np.ndarray:
        tab = {"type": "tabulated", "wavelengths": self._lambdas.tolist(), "values": values.tolist(), "scale": 1.0}
        return _XYZ_TO_REC709 @ np.array(self._core.spectrum_xyz(json.dumps(tab), self._settings))

    def reflectance(self, spec: dict[str, Any]) -> tuple[float, float, float]:
        kind, scale = spec.get("type"), float(spec.get("scale", 1.0))
        if kind == "rgb":
            return tuple(float(c) * scale for c in spec["rgb"])  # type: ignore[return-value]
        if kind == "constant":
            return (float(spec["value"]) * scale,) * 3  # type: ignore[return-value]
        try:
            v = np.asarray(self._core.spectrum_values(json.dumps(spec), self._settings, "reflectance"), np.float64)
            rgb = self._rgb_of(v * self._d65) / self._white
        except Exception:  # noqa: BLE001 - a preview colour is never worth failing the export
            return (0.18, 0.18, 0.18)
        return tuple(float(c) for c in np.clip(np.nan_to_num(rgb), 0.0, None))  # type: ignore[return-value]

    def emission(self, spec: dict[str, Any]) -> tuple[float, float, float]:
        kind, scale = spec.get("type"), float(spec.get("scale", 1.0))
        if kind == "rgb":
            return tuple(float(c) * scale for c in spec["rgb"])  # type: ignore[return-value]
        try:
            xyz = np.array(self._core.spectrum_xyz(json.dumps(spec), self._settings))
            rgb = (_XYZ_TO_REC709 @ xyz) / self._white_lum
        except Exception:  # noqa: BLE001
            return (1.0, 1.0, 1.0)
        return tuple(float(c) for c in np.clip(np.nan_to_num(rgb), 0.0, None))  # type: ignore[return-value]

    def metal(self, bsdf: dict[str, Any]) -> tuple[float, float, float]:
        """Normal-incidence reflectance ((n−1)² + k²)/((n+1)² + k²) of a conductor."""
        metal = bsdf.get("metal")
        if metal is not None:
            return _METAL_RGB.get(str(metal).lower(), (0.9, 0.9, 0.9))
        try:
            n = np.asarray(self._core.spectrum_values(json.dumps(bsdf["eta"]), self._settings, "unbounded"), np.float64)
            k = np.asarray(self._core.spectrum_values(json.dumps(bsdf["k"]), self._settings, "unbounded"), np.float64)
            f0 = ((n - 1) ** 2 + k**2) / ((n + 1) ** 2 + k**2)
            rgb = self._rgb_of(f0 * self._d65) / self._white
        except Exception:  # noqa: BLE001
            return (0.9, 0.9, 0.9)
        return tuple(float(c) for c in np.clip(np.nan_to_num(rgb), 0.0, 1.0))  # type: ignore[return-value]


#: Linear Rec.709 normal-incidence colours of the catalogue metals (UsdPreviewSurface only).
_METAL_RGB = {
    "gold": (1.0, 0.766, 0.336),
    "silver": (0.972, 0.960, 0.915),
    "copper": (0.955, 0.638, 0.538),
    "aluminium": (0.913, 0.922, 0.924),
    "aluminum": (0.913, 0.922, 0.924),
}
_WRAP_TO_USD = {"REPEAT": "repeat", "CLIP": "black", "EXTEND": "clamp"}


def _intensity_colour(rgb) -> tuple[float, tuple[float, float, float]]:
    """UsdLux style: a scalar intensity times a colour whose largest channel is 1."""
    peak = max(float(c) for c in rgb)
    if not peak > 0.0 or not math.isfinite(peak):
        return 0.0, (1.0, 1.0, 1.0)
    return peak, tuple(float(c) / peak for c in rgb)  # type: ignore[return-value]


def _ior_nd(ior: dict[str, Any]) -> float:
    """The index at the d line (:data:`polychrome.ior.LAMBDA_D`), for UsdPreviewSurface's ``ior`` input."""
    kind = ior.get("type")
    lam = LAMBDA_D / 1000.0  # coefficients are in micrometres
    try:
        if kind == "constant":
            return float(ior["ior"])
        if kind == "cauchy":
            return float(ior["a"]) + float(ior["b"]) / lam**2 + float(ior.get("c", 0.0)) / lam**4
        if kind == "sellmeier":
            l2 = lam * lam
            return math.sqrt(1.0 + sum(b * l2 / (l2 - c) for b, c in zip(ior["b"], ior["c"])))
        if kind == "abbe":
            return float(ior["nd"])
    except (KeyError, TypeError, ValueError, ZeroDivisionError):
        pass
    return 1.5


_IOR_FIELDS = {"constant": ["ior"], "cauchy": ["a", "b", "c"], "abbe": ["nd", "vd"]}


def _ior_coefficients(ior: dict[str, Any]) -> list[float] | None:
    kind = ior.get("type")
    if kind == "sellmeier":
        return [float(x) for x in list(ior["b"]) + list(ior["c"])]
    if kind in _IOR_FIELDS:
        return [float(ior.get(k, 0.0)) for k in _IOR_FIELDS[kind]]
    return None


# --------------------------------------------------------------------------- names


class _Names:
    """Valid, unique USD prim names under one parent."""

    def __init__(self, Tf):
        self._Tf = Tf
        self._used: set[str] = set()

    def __call__(self, name: str, fallback: str) -> str:
        base = self._Tf.MakeValidIdentifier(name) if name else fallback
        if not base or base == "_":
            base = fallback
        out, k = base, 1
        while out in self._used:
            out = f"{base}_{k}"
            k += 1
        self._used.add(out)
        return out


# --------------------------------------------------------------------------- writer


def _write_motion(Gf, Usd, op, keys) -> bool:
    """Motion keys (evenly spaced over the shutter) as time samples 0 … 1 of ``op``
    (the frame's transform stays its default value); whether there were any."""
    if not keys:
        return False
    for k, m in enumerate(keys):
        op.Set(_matrix_to_usd(Gf, m), Usd.TimeCode(k / (len(keys) - 1)))
    return True


def _write_deformation(Gf, Usd, Vt, mesh, md, buffers) -> bool:
    """A deforming mesh's ``motion_vertices`` (and ``motion_normals``) keys, evenly spaced
    over the shutter, as time samples 0 … 1 of its ``points`` (``normals``) and
    ``extent``; the frame's arrays stay the default values. Whether there were any."""
    keys = md.get("motion_vertices") or []
    if not keys:
        return False
    last = len(keys) - 1
    extent = mesh.GetExtentAttr()
    for k, key in enumerate(keys):
        time = Usd.TimeCode(k / last)
        p = np.ascontiguousarray(np.asarray(buffers[key], dtype=np.float32).reshape(-1, 3))
        mesh.GetPointsAttr().Set(Vt.Vec3fArray.FromNumpy(p), time)
        if len(p):
            lo, hi = p.min(axis=0), p.max(axis=0)
            extent.Set(Vt.Vec3fArray([Gf.Vec3f(*map(float, lo)), Gf.Vec3f(*map(float, hi))]), time)
    for k, key in enumerate(md.get("motion_normals") or []):
        n = np.ascontiguousarray(np.asarray(buffers[key], dtype=np.float32).reshape(-1, 3))
        mesh.GetNormalsAttr().Set(Vt.Vec3fArray.FromNumpy(n), Usd.TimeCode(k / last))
    return True


def _matrix_to_usd(Gf, m) -> Any:
    """polychrome's column-vector 4×4 (translation in the last column) → USD's row-vector matrix."""
    return Gf.Matrix4d(np.asarray(m, dtype=np.float64).T.tolist())


def _world_points(desc, buffers, inst) -> np.ndarray:
    md = desc["meshes"][int(inst["mesh"])]
    v = np.asarray(buffers[md["vertices"]], dtype=np.float64).reshape(-1, 3)
    m = np.asarray(inst["transform"], dtype=np.float64)
    return v @ m[:3, :3].T + m[:3, 3]


def _is_black(material) -> bool:
    bsdf = material.get("bsdf") or {}
    r = bsdf.get("reflectance") or {}
    if bsdf.get("type") != "diffuse" or material.get("emission") is not None:
        return False
    scale = float(r.get("scale", 1.0))
    if r.get("type") == "constant":
        return float(r.get("value", 1.0)) * scale == 0.0
    if r.get("type") == "rgb":
        return all(float(c) * scale == 0.0 for c in r.get("rgb", [1.0]))
    return False


def _light_like(mat, inst) -> bool:
    """A one-sided see-through emitter the camera does not see (and that, being
    see-through, casts no shadow), seen by every other kind of ray: a UsdLux light as the
    reader gives it and Cycles' area lights are by default."""
    if not (mat.get("one_sided") and mat.get("see_through")):
        return False
    vis = {k: True for k in ("camera", "diffuse", "glossy", "transmission")}
    vis.update({k: v for k, v in (inst.get("visibility") or {}).items() if k != "shadow"})
    return vis == {"camera": False, "diffuse": True, "glossy": True, "transmission": True}


def _area_lights(desc, buffers, uses) -> dict[int, dict[str, Any]]:
    """Instances that are emissive rectangles / regular polygons emitting from one face
    with a light's visibility (Blender's area lights as polychrome_blender exports them),
    or from both faces with a black backing just behind (how it exported them before):
    instance → shape (``one_sided`` for the first kind)."""
    found: dict[int, dict[str, Any]] = {}
    materials, meshes, instances = desc["materials"], desc["meshes"], desc["instances"]
    backings = []
    for k, inst in enumerate(instances):
        md = meshes[int(inst["mesh"])]
        if md.get("material_ids") is None and materials and _is_black(materials[int(md.get("material") or 0)]):
            backings.append((k, _world_points(desc, buffers, inst)))
    for k, inst in enumerate(instances):
        index = int(inst["mesh"])
        md = meshes[index]
        if (
            uses[index] != 1
            or md.get("material_ids") is not None
            or md.get("normals") is not None
            or md.get("uvs") is not None
            or not materials
        ):
            continue
        mat = materials[int(md.get("material") or 0)]
        if (mat.get("bsdf") or {}).get("type") != "none" or mat.get("emission") is None:
            continue
        one_sided = bool(mat.get("one_sided"))
        if (one_sided and not _light_like(mat, inst)) or (not one_sided and (not backings or mat.get("see_through"))):
            continue
        tris = np.asarray(buffers[md["triangles"]], dtype=np.int64).reshape(-1, 3)
        p = _world_points(desc, buffers, inst)
        n = len(p)
        if n < 4 or len(tris) != n - 2 or len(np.unique(tris)) != n:
            continue
        c = p.mean(axis=0)
        size = float(np.linalg.norm(p - c, axis=1).max())
        cross = np.cross(p[tris[:, 1]] - p[tris[:, 0]], p[tris[:, 2]] - p[tris[:, 0]])
        tri_area = 0.5 * np.linalg.norm(cross, axis=1)
        if not size > 0 or np.any(tri_area <= 0):
            continue
        normal = cross[0] / np.linalg.norm(cross[0])
        if np.any(np.abs((p - c) @ normal) > 1e-6 * size) or np.any(cross @ normal <= 0):
            continue  # not planar, or folded
        # Polygon outline in angular order around the centre.
        x_axis = (p[0] - c) / np.linalg.norm(p[0] - c)
        y_axis = np.cross(normal, x_axis)
        order = np.argsort(np.arctan2((p - c) @ y_axis, (p - c) @ x_axis))
        q = p[order]
        edges = np.roll(q, -1, axis=0) - q
        polygon_area = 0.5 * abs(float(np.dot(np.cross(q, np.roll(q, -1, axis=0)).sum(axis=0), normal)))
        if abs(tri_area.sum() - polygon_area) > 1e-6 * polygon_area:
            continue  # triangles overlap or leave holes
        shape: dict[str, Any]
        if n == 4:
            e0, e1 = edges[0], edges[1]
            if abs(np.dot(e0, e1)) > 1e-6 * np.linalg.norm(e0) * np.linalg.norm(e1) or not np.allclose(
                edges[0], -edges[2], atol=1e-6 * size
            ):
                continue
            # Width along the edge closest to the instance's own x axis (as Blender sizes it).
            local_x = np.asarray(inst["transform"], dtype=np.float64)[:3, 0]
            if abs(np.dot(e1, local_x)) / np.linalg.norm(e1) > abs(np.dot(e0, local_x)) / np.linalg.norm(e0):
                e0, e1 = e1, e0
            if np.dot(e0, local_x) < 0:
                e0 = -e0
            shape = {"kind": "rect", "width": float(np.linalg.norm(e0)), "height": float(np.linalg.norm(e1)), "x": e0 / np.linalg.norm(e0)}
        elif n >= 8:
            radii = np.linalg.norm(p - c, axis=1)
            lengths = np.linalg.norm(edges, axis=1)
            if np.ptp(radii) > 1e-5 * size or np.ptp(lengths) > 1e-5 * size:
                continue
            shape = {"kind": "disk", "radius": float(math.sqrt(polygon_area / math.pi)), "x": x_axis}  # same area
        else:
            continue
        if one_sided:
            # It emits along its winding normal (through the inverse transpose, as the
            # core orients it): the light's −Z.
            linear = np.asarray(inst["transform"], dtype=np.float64)[:3, :3]
            z = -normal if np.linalg.det(linear) > 0 else normal
            x = shape.pop("x")
            x = x - np.dot(x, z) * z
            x /= np.linalg.norm(x)
            frame = np.eye(4)
            frame[:3, 0], frame[:3, 1], frame[:3, 2], frame[:3, 3] = x, np.cross(z, x), z, c
            shape["frame"] = frame
            shape["one_sided"] = True
            found[k] = shape
            continue
        # A black copy just behind it: the light shines away from that side.
        for _, back in backings:
            if len(back) != n:
                continue
            offset = back.mean(axis=0) - c
            dist = float(np.dot(offset, normal))
            if (
                0 < abs(dist) < 0.01 * size
                and np.allclose(back - offset, p, atol=1e-5 * size)
                and np.allclose(offset, dist * normal, atol=1e-6 * size)
            ):
                z = normal if dist > 0 else -normal  # the light's +Z points at the backing
                x = shape.pop("x")
                x = x - np.dot(x, z) * z
                x /= np.linalg.norm(x)
                frame = np.eye(4)
                frame[:3, 0], frame[:3, 1], frame[:3, 2], frame[:3, 3] = x, np.cross(z, x), z, c
                shape["frame"] = frame
                found[k] = shape
                break
    return found


def _aim(direction, position) -> np.ndarray:
    """Object → world matrix whose −Z axis points along ``direction`` (lights look down −Z)."""
    d = np.asarray(direction, dtype=np.float64)
    n = np.linalg.norm(d)
    if not (np.isfinite(n) and n > 0):
        raise ValueError(f"light direction {list(direction)} must be finite and non-zero")
    z = -d / n
    helper = np.array([0.0, 0.0, 1.0]) if abs(z[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = x, y, z, np.asarray(position, dtype=np.float64)
    return m


def _sensor_apertures(cam: dict[str, Any], width: int, height: int) -> tuple[float, float, float]:
    """(horizontal, vertical, fitted) film extent in mm (perspective) or scene units
    (orthographic) that polychrome's camera shows for a ``width`` × ``height`` image
    (``fitted``: the side the sensor spans, the unit of the lens shift)."""
    fit = cam["sensor_fit"]
    width = width * cam.get("pixel_aspect", 1.0)
    horizontal = width > height if fit == "AUTO" else fit == "HORIZONTAL"
    if cam["projection"] == "ORTHOGRAPHIC":
        fitted = cam["ortho_scale"]
    else:
        fitted = cam["sensor_height"] if fit == "VERTICAL" else cam["sensor_width"]
    if horizontal:
        w, h = fitted, fitted * height / width
    else:
        w, h = fitted * width / height, fitted
    return w, h, fitted


def write_stage(scene, path, settings=None, *, area_lights: bool = True) -> Path:
    """Writes ``scene`` (a :class:`polychrome.Scene`) as a USD stage at ``path``
    (``.usda`` text, ``.usdc`` or ``.usd`` binary). ``settings`` (a
    :class:`polychrome.RenderSettings`, default: the defaults) go to
    ``/Render/PolychromeSettings``; its image size also sets the camera's apertures.

    With ``area_lights`` (default), an emission-only rectangle or regular polygon that
    emits from one face and is see-through (``Emitter(one_sided=True,
    see_through=True)``) and that the camera does not see (how Blender's area lights
    are exported) is written as a UsdLux
    RectLight / DiskLight shining the same way, keeping its exact spectrum in
    ``polychrome:emission``. So is a two-sided one backed by a black copy just behind
    it (the add-on's former export), shining away from the backing, which stays a mesh.
    Returns the path."""
    Gf, Sdf, Tf, Usd, UsdGeom, UsdLux, UsdRender, UsdShade, Vt = _pxr()
    from ..render import RenderSettings

    path = Path(path)
    if path.suffix.lower() not in (".usd", ".usda", ".usdc"):
        raise ValueError(f"{path}: a USD stage must end in .usd, .usda or .usdc")
    settings = settings or RenderSettings()
    settings.to_json()  # validates the settings (ValueError naming a bad one)
    desc, buffers = scene.description()
    for key, value in desc.items():
        if key not in ("camera", "materials", "meshes", "instances", "lights", "world", "textures") and value:
            warnings.warn(f"{path}: the scene's '{key}' cannot be written to USD yet and is left out", stacklevel=2)
    rgb = _Rgb(PREVIEW_GRID)  # preview colours do not depend on the render's grid

    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    world = UsdGeom.Xform.Define(stage, "/World")
    stage.SetDefaultPrim(world.GetPrim())
    world_names = _Names(Tf)
    for reserved in ("Looks", "Camera", "Lights"):
        world_names(reserved, reserved)

    # -- textures (image files beside the stage) --------------------------------
    texture_dir = path.parent / f"{path.stem}_textures"
    texture_files: dict[int, str] = {}
    texture_names = _Names(Tf)

    def texture_file(index: int) -> str:
        """Writes texture ``index`` once, returning its path relative to the stage."""
        if index not in texture_files:
            entry = desc["textures"][index]
            pixels = np.asarray(buffers[entry["buffer"]]).reshape(entry["height"], entry["width"], entry["channels"])
            texture_dir.mkdir(parents=True, exist_ok=True)
            stem = texture_names(str(entry.get("name", "")).rsplit(".", 1)[0], f"texture{index}")
            if entry.get("encoding") == "srgb":
                from PIL import Image

                file = texture_dir / f"{stem}.png"
                Image.fromarray(np.ascontiguousarray(pixels[:, :, :3].astype(np.uint8)), "RGB").save(file, format="PNG")
            else:
                from ..imageio import write_exr

                file = texture_dir / f"{stem}.exr"
                write_exr(file, np.asarray(pixels[:, :, :3], dtype=np.float32))
            texture_files[index] = f"./{texture_dir.name}/{file.name}"
        return texture_files[index]

    def texture_shader(mp, index: int):
        """UsdUVTexture (reading primvars:st) for texture ``index``: returns its rgb output."""
        entry = desc["textures"][index]
        reader = UsdShade.Shader.Define(stage, mp.AppendChild("st"))
        reader.CreateIdAttr("UsdPrimvarReader_float2")
        reader.CreateInput("varname", Sdf.ValueTypeNames.Token).Set("st")
        tex = UsdShade.Shader.Define(stage, mp.AppendChild("Texture"))
        tex.CreateIdAttr("UsdUVTexture")
        tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(Sdf.AssetPath(texture_file(index)))
        tex.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(reader.ConnectableAPI(), "result")
        wrap = _WRAP_TO_USD.get(str(entry.get("wrap", "REPEAT")).upper(), "repeat")
        tex.CreateInput("wrapS", Sdf.ValueTypeNames.Token).Set(wrap)
        tex.CreateInput("wrapT", Sdf.ValueTypeNames.Token).Set(wrap)
        tex.CreateInput("sourceColorSpace", Sdf.ValueTypeNames.Token).Set("sRGB" if entry.get("encoding") == "srgb" else "raw")
        tex.GetPrim().CreateAttribute(A.NAME, Sdf.ValueTypeNames.String).Set(str(entry.get("name", "")))
        return tex.CreateOutput("rgb", Sdf.ValueTypeNames.Float3)

    # -- area lights (found first: their emission materials need no Material prim) --
    instances = desc["instances"]
    uses = np.zeros(len(desc["meshes"]), dtype=np.int64)
    for inst in instances:
        uses[inst["mesh"]] += 1
    area = _area_lights(desc, buffers, uses) if area_lights else {}
    converted = {int(instances[k]["mesh"]) for k in area}
    needed = set()
    for index, md in enumerate(desc["meshes"]):
        if index in converted:
            continue
        if md.get("material_ids") is not None:
            needed.update(int(x) for x in np.unique(np.asarray(buffers[md["material_ids"]])))
        else:
            needed.add(int(md.get("material") or 0))
    only_lights = {int(desc["meshes"][i].get("material") or 0) for i in converted} - needed

    # -- materials ------------------------------------------------------------
    materials = []
    UsdGeom.Scope.Define(stage, "/World/Looks")
    look_names = _Names(Tf)
    for i, m in enumerate(desc["materials"]):
        if i in only_lights:
            materials.append(None)  # kept on the RectLight/DiskLight instead
            continue
        mp = Sdf.Path("/World/Looks").AppendChild(look_names(m.get("name", ""), f"Material{i}"))
        mat = UsdShade.Material.Define(stage, mp)
        prim = mat.GetPrim()
        prim.CreateAttribute(A.NAME, Sdf.ValueTypeNames.String).Set(str(m.get("name", "")))
        bsdf = dict(m.get("bsdf") or {"type": "diffuse", "reflectance": {"type": "constant", "value": 0.8, "scale": 1.0}})
        kind = str(bsdf.pop("type", "diffuse"))
        prim.CreateAttribute(A.BSDF, Sdf.ValueTypeNames.Token).Set(kind)
        shader = UsdShade.Shader.Define(stage, mp.AppendChild("PreviewSurface"))
        shader.CreateIdAttr("UsdPreviewSurface")
        inp = lambda n, t, v: shader.CreateInput(n, t).Set(v)  # noqa: E731
        colour = Sdf.ValueTypeNames.Color3f
        reflectance = bsdf.pop("reflectance", None)
        if isinstance(reflectance, dict) and reflectance.get("type") == "texture":
            # An image: a UsdUVTexture network any tool reads (no polychrome:reflectance).
            shader.CreateInput("diffuseColor", colour).ConnectToSource(texture_shader(mp, int(reflectance["texture"])))
        elif reflectance is not None:
            prim.CreateAttribute(A.REFLECTANCE, Sdf.ValueTypeNames.String).Set(json.dumps(reflectance))
            inp("diffuseColor", colour, Gf.Vec3f(*rgb.reflectance(reflectance)))
        elif kind == "none":
            inp("diffuseColor", colour, Gf.Vec3f(0.0, 0.0, 0.0))
        ior = bsdf.pop("ior", None)
        if isinstance(ior, dict):
            prim.CreateAttribute(A.IOR_MODEL, Sdf.ValueTypeNames.Token).Set(str(ior.get("type", "")))
            coeffs = _ior_coefficients(ior)
            if coeffs is not None:
                prim.CreateAttribute(A.IOR_COEFFICIENTS, Sdf.ValueTypeNames.DoubleArray).Set(Vt.DoubleArray(coeffs))
            if "name" in ior:
                prim.CreateAttribute(A.IOR_NAME, Sdf.ValueTypeNames.String).Set(str(ior["name"]))
            extra_ior = {
                k: v
                for k, v in ior.items()
                if k not in ("type", "name")
                and k not in _IOR_FIELDS.get(str(ior.get("type")), [])
                and not (ior.get("type") == "sellmeier" and k in ("b", "c"))
            }
            if extra_ior:
                bsdf["ior"] = extra_ior  # unknown fields of a future model: kept in extra
            inp("ior", Sdf.ValueTypeNames.Float, float(_ior_nd(ior)))
            inp("opacity", Sdf.ValueTypeNames.Float, 0.0)
        elif ior is not None:
            bsdf["ior"] = ior
        if kind == "diffuse":
            inp("roughness", Sdf.ValueTypeNames.Float, 1.0)
        elif "roughness" in bsdf:
            inp("roughness", Sdf.ValueTypeNames.Float, float(bsdf["roughness"]))
        if kind in ("conductor", "glossy"):
            inp("metallic", Sdf.ValueTypeNames.Float, 1.0)
            if kind == "conductor":
                inp("diffuseColor", colour, Gf.Vec3f(*rgb.metal(bsdf)))
        if bsdf:
            prim.CreateAttribute(A.BSDF_EXTRA, Sdf.ValueTypeNames.String).Set(json.dumps(bsdf))
        emission = m.get("emission")
        if m.get("one_sided"):
            prim.CreateAttribute(A.ONE_SIDED, Sdf.ValueTypeNames.Bool).Set(True)
        if m.get("see_through"):
            prim.CreateAttribute(A.SEE_THROUGH, Sdf.ValueTypeNames.Bool).Set(True)
        if emission is not None:
            prim.CreateAttribute(A.EMISSION, Sdf.ValueTypeNames.String).Set(json.dumps(emission))
            inp("emissiveColor", colour, Gf.Vec3f(*rgb.emission(emission)))
        mat.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
        materials.append(mat)

    # -- meshes and instances ---------------------------------------------------
    proto_names = _Names(Tf)
    proto_paths: dict[int, Any] = {}
    deforming = [False]  # whether a mesh was written with time-sampled points

    def fill_mesh(mp, index: int):
        md = desc["meshes"][index]
        mesh = UsdGeom.Mesh.Define(stage, mp)
        prim = mesh.GetPrim()
        v = np.ascontiguousarray(np.asarray(buffers[md["vertices"]], dtype=np.float32).reshape(-1, 3))
        t = np.ascontiguousarray(np.asarray(buffers[md["triangles"]]).reshape(-1, 3).astype(np.int32))
        mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(v))
        mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(len(t), 3, dtype=np.int32)))
        mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(t.ravel()))
        mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
        mesh.CreateDoubleSidedAttr(True)
        if len(v):
            mesh.CreateExtentAttr(Vt.Vec3fArray([Gf.Vec3f(*map(float, v.min(axis=0))), Gf.Vec3f(*map(float, v.max(axis=0)))]))
        if md.get("normals") is not None:
            n = np.ascontiguousarray(np.asarray(buffers[md["normals"]], dtype=np.float32).reshape(-1, 3))
            mesh.CreateNormalsAttr(Vt.Vec3fArray.FromNumpy(n))
            mesh.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
        deforming[0] |= _write_deformation(Gf, Usd, Vt, mesh, md, buffers)
        if md.get("uvs") is not None:
            uv = np.ascontiguousarray(np.asarray(buffers[md["uvs"]], dtype=np.float32).reshape(-1, 2))
            pv = UsdGeom.PrimvarsAPI(prim).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex)
            pv.Set(Vt.Vec2fArray.FromNumpy(uv))
        prim.CreateAttribute(A.NAME, Sdf.ValueTypeNames.String).Set(str(md.get("name", "")))
        prim.CreateAttribute(A.MESH_INDEX, Sdf.ValueTypeNames.Int).Set(int(index))
        binding = UsdShade.MaterialBindingAPI.Apply(prim)
        if md.get("material_ids") is not None:
            ids = np.asarray(buffers[md["material_ids"]]).astype(np.int64)
            order = np.argsort(ids, kind="stable")
            sorted_ids = ids[order]
            present = np.unique(sorted_ids)
            starts = np.searchsorted(sorted_ids, present, side="left")
            ends = np.searchsorted(sorted_ids, present, side="right")
            for mat_index, s, e in zip(present.tolist(), starts, ends):
                faces = np.sort(order[s:e]).astype(np.int32)
                subset = binding.CreateMaterialBindSubset(f"material_{mat_index}", Vt.IntArray.FromNumpy(faces), UsdGeom.Tokens.face)
                UsdShade.MaterialBindingAPI.Apply(subset.GetPrim()).Bind(materials[mat_index])
            binding.SetMaterialBindSubsetsFamilyType(UsdGeom.Tokens.partition)
        elif materials:
            binding.Bind(materials[int(md.get("material") or 0)])
        return mesh

    for index, count in enumerate(uses):
        if count >= 2:
            if not stage.GetPrimAtPath("/Prototypes"):
                stage.CreateClassPrim("/Prototypes")
            root = Sdf.Path("/Prototypes").AppendChild(proto_names(desc["meshes"][index].get("name", ""), f"Mesh{index}"))
            UsdGeom.Xform.Define(stage, root)
            fill_mesh(root.AppendChild("mesh"), index)
            proto_paths[index] = root

    moving = deforming[0]
    for k, inst in enumerate(instances):
        index = int(inst["mesh"])
        if k in area:
            continue  # written as a UsdLux light below
        ip = Sdf.Path("/World").AppendChild(world_names(inst.get("name", ""), f"Instance{k}"))
        if index in proto_paths:
            xf = UsdGeom.Xform.Define(stage, ip)
            xf.GetPrim().GetReferences().AddInternalReference(proto_paths[index])
            xf.GetPrim().SetInstanceable(True)
            xformable = xf
        else:
            xformable = fill_mesh(ip, index)
        op = xformable.AddTransformOp()
        op.Set(_matrix_to_usd(Gf, inst["transform"]))
        moving |= _write_motion(Gf, Usd, op, inst.get("motion"))
        xformable.GetPrim().CreateAttribute(A.INSTANCE_NAME, Sdf.ValueTypeNames.String).Set(str(inst.get("name", "")))

    # -- camera ---------------------------------------------------------------------
    cam = desc["camera"]
    camera = UsdGeom.Camera.Define(stage, "/World/Camera")
    op = camera.AddTransformOp()
    op.Set(_matrix_to_usd(Gf, cam["to_world"]))
    moving |= _write_motion(Gf, Usd, op, cam.get("motion"))
    if moving:  # motion keys are time samples 0 … 1, over a shutter open from 0 to 1
        camera.CreateShutterOpenAttr(0.0)
        camera.CreateShutterCloseAttr(1.0)
        stage.SetStartTimeCode(0.0)
        stage.SetEndTimeCode(1.0)
    ortho = cam["projection"] == "ORTHOGRAPHIC"
    camera.CreateProjectionAttr(UsdGeom.Tokens.orthographic if ortho else UsdGeom.Tokens.perspective)
    # Lens and filmback are in tenths of a scene unit (UsdGeomCamera, "Units of Measure
    # for Camera Properties"): with metersPerUnit = 1 that is 100 mm per unit.
    w, h, fitted = _sensor_apertures(cam, settings.width, settings.height)
    # Orthographic extents are scene units (×10 tenths); perspective ones are mm (÷100).
    to_tenths = (lambda x: x * 10.0) if ortho else (lambda x: x / 100.0)
    camera.CreateFocalLengthAttr(float(cam["focal_length"]) / 100.0)
    camera.CreateHorizontalApertureAttr(float(to_tenths(w)))
    camera.CreateVerticalApertureAttr(float(to_tenths(h)))
    camera.CreateHorizontalApertureOffsetAttr(float(to_tenths(cam["shift_x"] * fitted)))
    camera.CreateVerticalApertureOffsetAttr(float(to_tenths(cam["shift_y"] * fitted)))
    if cam.get("aperture_radius", 0.0) > 0 and not ortho:
        # UsdGeomCamera: aperture diameter = focalLength / fStop (metres per unit = 1).
        camera.CreateFStopAttr(float(cam["focal_length"] * 1e-3 / (2.0 * cam["aperture_radius"])))
        camera.CreateFocusDistanceAttr(float(cam["focus_distance"]))
    camera.CreateClippingRangeAttr(Gf.Vec2f(float(cam["clip_start"]), float(cam["clip_end"])))
    camera_fields = {k: v for k, v in cam.items() if k != "to_world"}
    camera.GetPrim().CreateAttribute(A.CAMERA, Sdf.ValueTypeNames.String).Set(json.dumps(camera_fields))

    # -- lights -----------------------------------------------------------------------
    UsdGeom.Scope.Define(stage, "/World/Lights")
    light_names = _Names(Tf)
    for i, (light, ld) in enumerate(zip(scene.lights, desc["lights"])):
        lp = Sdf.Path("/World/Lights").AppendChild(light_names(ld.get("name", ""), f"Light{i}"))
        kind = ld.get("type")
        if kind in ("point", "spot") or ("position" in ld and kind != "distant"):
            lt = UsdLux.SphereLight.Define(stage, lp)
            # A sphere light keeps its radius; a point is a tiny sphere treated as a point.
            lt.CreateTreatAsPointAttr(not float(ld.get("radius", 0.0)) > 0.0)
            lt.CreateRadiusAttr(float(ld.get("radius", 0.0)) or POINT_LIGHT_RADIUS)
            # Normalised sphere of radius r: radiance intensity/(4πr²), radiant intensity
            # L·πr² = intensity/4, whatever the radius (docs/usd.md, "Lights").
            lt.CreateNormalizeAttr(True)
            if isinstance(ld.get("intensity"), dict):
                peak, colour = _intensity_colour(rgb.emission(ld["intensity"]))
                lt.CreateIntensityAttr(4.0 * peak)
                lt.CreateColorAttr(Gf.Vec3f(*colour))
            position = [float(c) for c in ld.get("position", (0.0, 0.0, 0.0))]
            if kind == "spot" and "direction" in ld:
                lt.AddTransformOp().Set(_matrix_to_usd(Gf, _aim(ld["direction"], position)))
                shaping = UsdLux.ShapingAPI.Apply(lt.GetPrim())
                shaping.CreateShapingConeAngleAttr(math.degrees(float(ld.get("spot_size", math.pi / 4))) / 2.0)
                shaping.CreateShapingConeSoftnessAttr(float(ld.get("spot_blend", 0.0)))
            else:
                lt.AddTranslateOp().Set(Gf.Vec3d(*position))
        elif "direction" in ld:
            lt = UsdLux.DistantLight.Define(stage, lp)
            lt.AddTransformOp().Set(_matrix_to_usd(Gf, _aim(ld["direction"], (0.0, 0.0, 0.0))))
            lt.CreateAngleAttr(math.degrees(float(ld.get("angle", 0.0))))  # the angular diameter
            lt.CreateNormalizeAttr(True)  # normalised: intensity × colour is the irradiance
            if isinstance(ld.get("irradiance"), dict):
                peak, colour = _intensity_colour(rgb.emission(ld["irradiance"]))
                lt.CreateIntensityAttr(peak)
                lt.CreateColorAttr(Gf.Vec3f(*colour))
        else:
            lt = UsdLux.SphereLight.Define(stage, lp)
            lt.CreateIntensityAttr(0.0)
        prim = lt.GetPrim()
        power, colour_spec = getattr(light, "power", None), getattr(light, "color", None)
        if kind in ("point", "spot") and power is not None and colour_spec is not None:
            from ..spectra import as_spectrum

            try:
                prim.CreateAttribute(A.POWER, Sdf.ValueTypeNames.Double).Set(float(power))
                prim.CreateAttribute(A.COLOR, Sdf.ValueTypeNames.String).Set(json.dumps(as_spectrum(colour_spec).to_dict()))
            except (TypeError, ValueError):
                pass
        prim.CreateAttribute(A.NAME, Sdf.ValueTypeNames.String).Set(str(ld.get("name", "")))
        prim.CreateAttribute(A.LIGHT, Sdf.ValueTypeNames.String).Set(json.dumps(ld))

    for k, shape in area.items():
        inst = instances[k]
        md = desc["meshes"][int(inst["mesh"])]
        mat = desc["materials"][int(md.get("material") or 0)]
        lp = Sdf.Path("/World/Lights").AppendChild(light_names(inst.get("name", ""), f"AreaLight{k}"))
        if shape["kind"] == "rect":
            al = UsdLux.RectLight.Define(stage, lp)
            al.CreateWidthAttr(float(shape["width"]))
            al.CreateHeightAttr(float(shape["height"]))
        else:
            al = UsdLux.DiskLight.Define(stage, lp)
            al.CreateRadiusAttr(float(shape["radius"]))
        al.AddTransformOp().Set(_matrix_to_usd(Gf, shape["frame"]))
        al.CreateNormalizeAttr(False)  # intensity × colour is the radiance
        peak, colour = _intensity_colour(rgb.emission(mat["emission"]))
        al.CreateIntensityAttr(peak)
        al.CreateColorAttr(Gf.Vec3f(*colour))
        prim = al.GetPrim()
        prim.CreateAttribute(A.EMISSION, Sdf.ValueTypeNames.String).Set(json.dumps(mat["emission"]))
        prim.CreateAttribute(A.NAME, Sdf.ValueTypeNames.String).Set(str(inst.get("name", "")))
        prim.CreateAttribute(A.MATERIAL_NAME, Sdf.ValueTypeNames.String).Set(str(mat.get("name", "")))
        if not shape.get("one_sided"):
            prim.CreateAttribute(A.HAS_BACKING, Sdf.ValueTypeNames.Bool).Set(True)

    world_desc = desc.get("world")
    if world_desc is not None and (world_desc.get("radiance") is not None or world_desc.get("texture") is not None):
        dome = UsdLux.DomeLight.Define(stage, "/World/Lights/World")
        extra = {k: v for k, v in world_desc.items() if k not in ("radiance", "texture")}
        if world_desc.get("texture") is not None:
            # Polychrome looks up u = 0.5 − atan2(y, x)/2π after Rz(rotation); a latlong
            # dome oriented to the Z-up stage (rotateX 90) and turned by φ about Z looks
            # up u = 0.5 − atan2(x', −y')/2π of Rz(−φ)·d: the same for φ = π/2 − rotation.
            phi = math.pi / 2 - float(world_desc.get("rotation", 0.0))
            c, sn = math.cos(phi), math.sin(phi)
            rz = np.array([[c, -sn, 0, 0], [sn, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])
            rx = np.array([[1, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1]], dtype=np.float64)
            dome.AddTransformOp().Set(_matrix_to_usd(Gf, rz @ rx))
            dome.CreateTextureFileAttr(Sdf.AssetPath(texture_file(int(world_desc["texture"]))))
            dome.CreateTextureFormatAttr(UsdLux.Tokens.latlong)
            dome.CreateIntensityAttr(float(world_desc.get("strength", 1.0)))
        else:
            radiance = world_desc["radiance"]
            peak, colour = _intensity_colour(rgb.emission(radiance))
            dome.CreateIntensityAttr(peak)
            dome.CreateColorAttr(Gf.Vec3f(*colour))
            dome.GetPrim().CreateAttribute(A.RADIANCE, Sdf.ValueTypeNames.String).Set(json.dumps(radiance))
        if extra:
            dome.GetPrim().CreateAttribute(A.LIGHT, Sdf.ValueTypeNames.String).Set(json.dumps(extra))

    # -- render settings ----------------------------------------------------------------
    UsdGeom.Scope.Define(stage, "/Render")
    rs = UsdRender.Settings.Define(stage, A.RENDER_SETTINGS_PATH)
    rs.CreateResolutionAttr(Gf.Vec2i(int(settings.width), int(settings.height)))
    if cam.get("pixel_aspect", 1.0) != 1.0:
        rs.CreatePixelAspectRatioAttr(float(cam["pixel_aspect"]))
    rs.CreateCameraRel().SetTargets([camera.GetPath()])
    for field, value in A.settings_items(settings):
        attr, type_name = A.SETTINGS[field]
        if type_name == "DoubleArray":
            value = Vt.DoubleArray([float(x) for x in value])
        rs.GetPrim().CreateAttribute(attr, getattr(Sdf.ValueTypeNames, type_name)).Set(value)
    stage.SetMetadata("renderSettingsPrimPath", A.RENDER_SETTINGS_PATH)

    path.parent.mkdir(parents=True, exist_ok=True)
    if not stage.GetRootLayer().Export(str(path)):
        raise OSError(f"{path}: USD could not write the stage")
    return path
