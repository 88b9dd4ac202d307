"""Building a scene in Python: meshes from numpy arrays, materials, lights, a camera.

The scene is a plain description; :func:`polychrome.render` hands it to the Rust core
as JSON plus numpy buffers (no per-triangle Python loops).
"""

from __future__ import annotations

from dataclasses import dataclass, field
import math
from typing import Any
from collections.abc import Sequence

import numpy as np

from . import spectra
from .spectra import Spectrum, as_spectrum
from .texture import Texture


def _matrix(value: Any, what: str) -> list[list[float]]:
    m = np.asarray(value, dtype=np.float64)
    if m.shape != (4, 4):
        raise ValueError(f"{what}: expected a 4×4 matrix, got shape {m.shape}")
    if not np.all(np.isfinite(m)):
        raise ValueError(f"{what}: matrix has non-finite entries")
    return m.tolist()


def _finite_floats(values: Any, what: str) -> list[float]:
    """Floats that must be finite (JSON cannot carry NaN/inf, and the core would only
    report a parse error without the object's name)."""
    out = [float(c) for c in values]
    if not all(math.isfinite(c) for c in out):
        raise ValueError(f"{what} is not finite ({out})")
    return out


def _motion_matrices(value: Any, what: str) -> list[list[list[float]]]:
    """Motion keys: K ≥ 2 finite 4×4 matrices evenly spaced over the shutter."""
    m = np.asarray(value, dtype=np.float64)
    if m.ndim != 3 or m.shape[1:] != (4, 4) or m.shape[0] < 2:
        raise ValueError(f"{what}: motion must be K ≥ 2 matrices of 4×4 (shape (K, 4, 4)), got shape {m.shape}")
    return [_matrix(k, f"{what}: motion key {i}") for i, k in enumerate(m)]


def _motion_keys(value: Any, shape: tuple[int, ...], what: str) -> list[np.ndarray]:
    """Per-vertex motion keys: K ≥ 2 arrays of ``shape``."""
    a = np.ascontiguousarray(value, dtype=np.float32)
    if a.ndim != 3 or a.shape[1:] != tuple(shape) or a.shape[0] < 2:
        raise ValueError(f"{what} must have shape (K ≥ 2, {shape[0]}, {shape[1]}), got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{what} has non-finite values")
    return list(a)


def look_at(position: Sequence[float], target: Sequence[float], up: Sequence[float] = (0.0, 0.0, 1.0)) -> np.ndarray:
    """Camera → world matrix of a camera at ``position`` looking at ``target`` (Blender's
    convention: the camera looks down its local −Z with +Y up; the world is Z-up)."""
    p = np.asarray(position, dtype=np.float64)
    forward = np.asarray(target, dtype=np.float64) - p
    n = np.linalg.norm(forward)
    if n == 0:
        raise ValueError("look_at: position and target coincide")
    forward /= n
    right = np.cross(forward, np.asarray(up, dtype=np.float64))
    if np.linalg.norm(right) < 1e-9:
        right = np.cross(forward, [0.0, 1.0, 0.0] if abs(forward[1]) < 0.9 else [1.0, 0.0, 0.0])
    right /= np.linalg.norm(right)
    true_up = np.cross(right, forward)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = right, true_up, -forward, p
    return m


#: Blender's panoramic projections (``Camera.panorama_type``).
PANORAMA_TYPES = (
    "EQUIRECTANGULAR",
    "EQUIANGULAR_CUBEMAP_FACE",
    "MIRRORBALL",
    "FISHEYE_EQUIDISTANT",
    "FISHEYE_EQUISOLID",
    "FISHEYE_LENS_POLYNOMIAL",
    "CENTRAL_CYLINDRICAL",
)

#: Blender's default polynomial fisheye coefficients k0…k4.
FISHEYE_POLYNOMIAL_DEFAULT = (-1.1735144e-05, -0.019988736, -3.3525323e-06, 3.0992753e-06, -2.6064647e-08)


@dataclass
class Camera:
    """A camera described as Blender describes one (mm lenses, sensor fit, shift, clip,
    pixel aspect, depth of field, panoramic projections); see docs/camera.md.

    Depth of field: set ``fstop`` (the aperture radius is then ``focal_length / (2·fstop)``
    with the focal length in metres, as Cycles computes it — scene units are metres; for
    orthographic cameras ``1 / (2·fstop)``) or ``aperture_radius`` in scene units, and
    ``focus_distance``. Both zero (the default): a pinhole, everything sharp.
    """

    to_world: Any = field(default_factory=lambda: np.eye(4))
    #: PERSPECTIVE, ORTHOGRAPHIC or PANORAMIC.
    projection: str = "PERSPECTIVE"
    focal_length: float = 50.0
    sensor_width: float = 36.0
    sensor_height: float = 24.0
    sensor_fit: str = "AUTO"
    ortho_scale: float = 7.314
    #: Lens shift in units of the fitted image side (Blender's shift_x/shift_y).
    shift_x: float = 0.0
    shift_y: float = 0.0
    clip_start: float = 0.1
    clip_end: float = 1000.0
    #: Width / height of one pixel (Blender's pixel_aspect_x / pixel_aspect_y).
    pixel_aspect: float = 1.0
    fstop: float = 0.0
    aperture_radius: float = 0.0
    focus_distance: float = 10.0
    #: Diaphragm blades (polygonal bokeh); fewer than 3 is round.
    aperture_blades: int = 0
    #: Rotation of the blades, radians.
    aperture_rotation: float = 0.0
    #: Anamorphic bokeh: the aperture's width is divided by this.
    aperture_ratio: float = 1.0
    #: One of PANORAMA_TYPES, for ``projection="PANORAMIC"``.
    panorama_type: str = "EQUIRECTANGULAR"
    fisheye_fov: float = math.pi
    fisheye_lens: float = 10.5
    latitude_min: float = -math.pi / 2
    latitude_max: float = math.pi / 2
    longitude_min: float = -math.pi
    longitude_max: float = math.pi
    fisheye_polynomial: Sequence[float] = FISHEYE_POLYNOMIAL_DEFAULT
    central_cylindrical_range_u_min: float = -math.pi
    central_cylindrical_range_u_max: float = math.pi
    central_cylindrical_range_v_min: float = -1.0
    central_cylindrical_range_v_max: float = 1.0
    central_cylindrical_radius: float = 1.0
    #: Motion blur: camera → world transforms (K ≥ 2, 4×4) evenly spaced from shutter
    #: open to close; None: the camera stands at ``to_world``.
    motion: Any = None
    #: How open the shutter is at evenly spaced times from open to close (Blender's
    #: shutter curve); None: fully open throughout.
    shutter_curve: Sequence[float] | None = None
    #: Rolling shutter (Cycles' TOP type) and the share of the shutter each row is
    #: exposed for (Cycles' rolling shutter duration).
    rolling_shutter: bool = False
    rolling_shutter_duration: float = 0.1
    name: str = "Camera"

    @classmethod
    def looking_at(cls, position, target, up=(0.0, 0.0, 1.0), **kwargs) -> Camera:
        return cls(to_world=look_at(position, target, up), **kwargs)

    def resolved_aperture_radius(self) -> float:
        """The thin lens's radius in scene units (0: a pinhole)."""
        what = f"camera '{self.name}'"
        fstop, radius = float(self.fstop), float(self.aperture_radius)
        if not (math.isfinite(fstop) and fstop >= 0 and math.isfinite(radius) and radius >= 0):
            raise ValueError(f"{what}: fstop {fstop} and aperture_radius {radius} must be zero or positive")
        if fstop > 0 and radius > 0:
            raise ValueError(f"{what}: give fstop or aperture_radius, not both")
        if fstop == 0:
            return radius
        # Cycles (blender/camera.cpp): lens in mm → metres, halved, over the f-number.
        if self.projection.upper() == "ORTHOGRAPHIC":
            return 1.0 / (2.0 * fstop)
        return float(self.focal_length) * 1e-3 / (2.0 * fstop)

    def to_dict(self) -> dict[str, Any]:
        what = f"camera '{self.name}'"
        panorama = str(self.panorama_type).upper()
        if panorama not in PANORAMA_TYPES:
            raise ValueError(f"{what}: panorama_type {self.panorama_type!r} is not one of {', '.join(PANORAMA_TYPES)}")
        polynomial = _finite_floats(self.fisheye_polynomial, f"{what}: fisheye_polynomial")
        if len(polynomial) != 5:
            raise ValueError(f"{what}: fisheye_polynomial needs 5 coefficients k0…k4, got {len(polynomial)}")
        blades = int(self.aperture_blades)
        if blades < 0:
            raise ValueError(f"{what}: aperture_blades {blades} must not be negative")
        floats = (
            "focal_length",
            "sensor_width",
            "sensor_height",
            "ortho_scale",
            "shift_x",
            "shift_y",
            "clip_start",
            "clip_end",
            "pixel_aspect",
            "focus_distance",
            "aperture_rotation",
            "aperture_ratio",
            "fisheye_fov",
            "fisheye_lens",
            "latitude_min",
            "latitude_max",
            "longitude_min",
            "longitude_max",
            "central_cylindrical_range_u_min",
            "central_cylindrical_range_u_max",
            "central_cylindrical_range_v_min",
            "central_cylindrical_range_v_max",
            "central_cylindrical_radius",
        )
        values = dict(zip(floats, _finite_floats([getattr(self, k) for k in floats], what)))
        return {
            "name": self.name,
            "to_world": _matrix(self.to_world, what),
            "projection": self.projection.upper(),
            "sensor_fit": self.sensor_fit.upper(),
            **values,
            "aperture_radius": self.resolved_aperture_radius(),
            "aperture_blades": blades,
            "panorama_type": panorama,
            "fisheye_polynomial": polynomial,
            "motion": [] if self.motion is None or np.size(self.motion) == 0 else _motion_matrices(self.motion, what),
            "shutter_curve": [] if self.shutter_curve is None else _finite_floats(self.shutter_curve, f"{what}: shutter_curve"),
            "rolling_shutter": bool(self.rolling_shutter),
            "rolling_shutter_duration": _finite_floats([self.rolling_shutter_duration], f"{what}: rolling_shutter_duration")[0],
        }


class Medium:
    """A homogeneous participating medium filling closed meshes (docs/media.md).

    ``absorption`` σa and ``scattering`` σs are coefficients per scene unit of length —
    a spectrum, a number or an RGB triple in [0, 1] (uplifted as a reflectance) — each
    times ``density``; ``anisotropy`` is Henyey–Greenstein's g; ``emission`` is radiance
    per unit length. Put it on a material (``volume=``, or ``material.volume = ...``);
    :class:`Volume` is a material that is only a medium (no surface).

    ``density_grid`` makes it heterogeneous (docs/media.md, "Grid media"): a 3-D array
    of finite, non-negative densities indexed ``[z, y, x]`` (shape (nz, ny, nx)) that
    further scales σa and σs, trilinear between voxel centres, filling the box
    ``grid_bounds = ((x0, y0, z0), (x1, y1, z1))`` in the object space of each mesh with
    the material (0 outside it). Not with ``emission``."""

    def __init__(
        self,
        absorption: Any = None,
        scattering: Any = None,
        *,
        density: float = 1.0,
        anisotropy: float = 0.0,
        emission: Any = None,
        density_grid: Any = None,
        grid_bounds: Any = None,
    ):
        self.density = _finite_floats([density], "medium: density")[0]
        if self.density < 0.0:
            raise ValueError(f"medium: density {density} must be non-negative")
        self.anisotropy = _finite_floats([anisotropy], "medium: anisotropy")[0]
        if not -1.0 < self.anisotropy < 1.0:
            raise ValueError(f"medium: anisotropy {anisotropy} must be in (-1, 1)")
        self.absorption = None if absorption is None else as_spectrum(absorption)
        self.scattering = None if scattering is None else as_spectrum(scattering)
        self.emission = None if emission is None else as_spectrum(emission)
        self.density_grid: np.ndarray | None = None
        self.grid_bounds: list[list[float]] | None = None
        if density_grid is not None:
            g = np.asarray(density_grid, dtype=np.float32)
            if g.ndim != 3 or 0 in g.shape:
                raise ValueError(f"medium: density_grid must be a non-empty 3-D array [z, y, x], not shape {g.shape}")
            if not (np.isfinite(g).all() and (g >= 0).all()):
                raise ValueError("medium: density_grid values must be finite and non-negative")
            if grid_bounds is None:
                raise ValueError("medium: a density_grid needs grid_bounds ((x0, y0, z0), (x1, y1, z1))")
            b = np.asarray(grid_bounds, dtype=np.float64)
            if b.shape != (2, 3) or not np.isfinite(b).all() or not (b[0] < b[1]).all():
                raise ValueError(f"medium: grid_bounds {grid_bounds} must be (min, max) corners with min < max")
            if self.emission is not None:
                raise ValueError("medium: emission with a density_grid is not supported")
            self.density_grid = g
            self.grid_bounds = b.tolist()

    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {"anisotropy": self.anisotropy}
        if self.density_grid is not None:
            nz, ny, nx = self.density_grid.shape
            d["density_grid"] = {
                "dims": [nx, ny, nz],
                "values": self.density_grid.ravel().tolist(),
                "bounds": self.grid_bounds,
            }
        if self.absorption is not None:
            d["absorption"] = (self.absorption * self.density).to_dict()
        if self.scattering is not None:
            d["scattering"] = (self.scattering * self.density).to_dict()
        if self.emission is not None:
            d["emission"] = self.emission.to_dict()
        return d


def _medium(volume: Any, name: str) -> Medium | None:
    if volume is not None and not isinstance(volume, Medium):
        raise TypeError(f"material '{name}': volume must be a polychrome.Medium, not {type(volume).__name__}")
    return volume


class Material:
    """Base class of materials: a BSDF, an optional emission and an optional medium
    inside (``volume``, a :class:`Medium`)."""

    name: str = "Material"
    emission: Spectrum | None = None
    volume: Medium | None = None

    def bsdf_dict(self) -> dict[str, Any]:  # pragma: no cover - abstract
        raise NotImplementedError

    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {"name": self.name, "bsdf": self.bsdf_dict()}
        if self.emission is not None:
            d["emission"] = self.emission.to_dict()
        if _medium(self.volume, self.name) is not None:
            d["volume"] = self.volume.to_dict()
        return d


class Volume(Material):
    """A material that is only a medium: its surface lets rays pass straight through
    (Blender's material with only a Volume output)."""

    def __init__(self, medium: Medium, *, name: str = "Volume"):
        self.volume = _medium(medium, name)
        self.name = name

    def bsdf_dict(self) -> dict[str, Any]:
        return {"type": "null"}


class Diffuse(Material):
    """Lambertian reflectance (a spectrum, a number, an RGB triple or a
    :class:`~polychrome.Texture`, converted per hit), optionally emissive."""

    def __init__(self, reflectance: Any = 0.8, *, emission: Any = None, name: str = "Diffuse"):
        self.reflectance = reflectance if isinstance(reflectance, Texture) else as_spectrum(reflectance)
        self.emission = None if emission is None else as_spectrum(emission)
        self.name = name

    def bsdf_dict(self) -> dict[str, Any]:
        return {"type": "diffuse", "reflectance": self.reflectance.to_dict()}


class Emitter(Material):
    """A surface that only emits (radiance ``emission`` times ``strength``), from both
    faces, or with ``one_sided`` from its front face only: the side its triangles'
    winding normal ((v1 − v0) × (v2 − v0)) points to, as Cycles' and UsdLux's area
    lights (black behind). With ``see_through`` rays pass through it after gathering its
    emission and it never blocks shadow rays, as Cycles treats its lights; otherwise it
    is an opaque black surface that emits."""

    def __init__(
        self,
        emission: Any = (1.0, 1.0, 1.0),
        *,
        strength: float = 1.0,
        one_sided: bool = False,
        see_through: bool = False,
        name: str = "Emitter",
    ):
        self.emission = as_spectrum(emission) * strength
        self.one_sided = bool(one_sided)
        self.see_through = bool(see_through)
        self.name = name

    def bsdf_dict(self) -> dict[str, Any]:
        return {"type": "none"}

    def to_dict(self) -> dict[str, Any]:
        d = super().to_dict()
        if self.one_sided:
            d["one_sided"] = True
        if self.see_through:
            d["see_through"] = True
        return d


@dataclass
class PointLight:
    """An isotropic point light of ``power`` watts (as Blender gives it) and ``color``.

    The radiant intensity is ``color × power / 4π`` per wavelength; ``color`` may be
    any spectrum (RGB white gives a D65-shaped spectrum of luminance 1). With
    ``radius`` > 0 it is a sphere light (soft shadows) of uniform radiance
    intensity / (π r²), as Cycles' point light of that radius: BSDF rays hit the sphere
    (its highlight in a mirror, its caustic through glass), camera rays only with
    ``visibility={"camera": True}``; it blocks nothing.
    """

    position: Sequence[float]
    power: float = 100.0
    color: Any = (1.0, 1.0, 1.0)
    name: str = "PointLight"
    radius: float = 0.0
    #: the kinds of rays that see it, e.g. ``{"diffuse": False}``, ``{"camera": True}`` (``LIGHT_RAY_KINDS``)
    visibility: Any = None
    #: an IES profile scaling the intensity per direction (:func:`polychrome.ies.read`, or a path to an .ies file)
    profile: Any = None
    #: the light's axes (3 × 3, columns: its local X, Y, Z in world space; it shines down −Z): turns the profile
    orientation: Any = None
    #: motion blur: K ≥ 2 light → world 4×4 keys evenly spaced over the shutter; the light as given is where it
    #: is at the frame (``orientation`` its axes there) and moves rigidly with the keys (their scale is dropped)
    motion: Any = None

    def to_dict(self) -> dict[str, Any]:
        pos = _finite_floats(self.position, f"light '{self.name}': position")
        if len(pos) != 3:
            raise ValueError(f"light '{self.name}': position must have 3 coordinates")
        _finite_floats([self.power], f"light '{self.name}': power")
        intensity = as_spectrum(self.color) * (float(self.power) / (4.0 * math.pi))
        d = {"type": "point", "name": self.name, "position": pos, "intensity": intensity.to_dict()}
        _with_profile(d, self.profile, self.orientation)
        _with_light_motion(d, self.motion, self.name)
        return _with_light_visibility(_with_radius(d, self.radius, self.name), self.visibility, self.name)


def _with_light_motion(d: dict[str, Any], motion: Any, name: str) -> dict[str, Any]:
    """``d`` with the light's motion keys (none: it stands still)."""
    if motion is not None and np.size(motion) > 0:
        d["motion"] = _motion_matrices(motion, f"light '{name}'")
    return d


def _with_profile(d: dict[str, Any], profile: Any, orientation: Any) -> dict[str, Any]:
    """``d`` with the light's IES ``profile`` (an IESProfile or a path) turned by ``orientation``."""
    if profile is None:
        return d
    from . import ies

    if not isinstance(profile, ies.IESProfile):
        profile = ies.read(profile)
    d["profile"] = profile.to_dict(orientation)
    return d


#: The kinds of rays a light's ``visibility`` names (Cycles' light ray visibility): the
#: bounces it lights and whose rays see a sphere light or a sun's disk (diffuse, glossy,
#: transmission; on by default), and whether camera rays see them (off by default, as
#: Cycles' ``visible_camera``). A light that is no geometry has no shadow visibility.
LIGHT_RAY_KINDS = ("camera", "diffuse", "glossy", "transmission")


def _with_light_visibility(d: dict[str, Any], visibility: Any, name: str) -> dict[str, Any]:
    """``d`` with the light's ray visibility (a dict of LIGHT_RAY_KINDS booleans, missing
    ones at their defaults: camera False, the others True), left out when it is the default."""
    if visibility is None:
        return d
    vis = dict(visibility)
    unknown = sorted(set(vis) - set(LIGHT_RAY_KINDS))
    if unknown:
        raise ValueError(f"light '{name}': unknown ray visibility {unknown} (known: {', '.join(LIGHT_RAY_KINDS)})")
    if not all(isinstance(v, (bool, np.bool_)) for v in vis.values()):
        raise ValueError(f"light '{name}': ray visibility values must be True or False")
    if any(bool(v) != (k != "camera") for k, v in vis.items()):
        d["visibility"] = {k: bool(v) for k, v in vis.items()}
    return d


def _with_radius(d: dict[str, Any], radius: float, name: str) -> dict[str, Any]:
    r = float(radius)
    if not (math.isfinite(r) and r >= 0.0):
        raise ValueError(f"light '{name}': radius {radius} must be finite and non-negative")
    if r > 0.0:
        d["radius"] = r
    return d


def _roughness(value: Any, name: str) -> float:
    r = float(value)
    if not (math.isfinite(r) and 0.0 <= r <= 1.0):
        raise ValueError(f"material '{name}': roughness {value} must be in 0..1")
    return r


class Dielectric(Material):
    """Glass (Blender's Glass BSDF): an index of refraction — a number, a glass name or a
    model from :mod:`polychrome.ior` (``cauchy``, ``sellmeier``, ``abbe``, ``named``) —
    and a roughness (0: smooth; otherwise GGX with alpha = roughness²). A glass whose
    index varies over the wavelength grid disperses light."""

    def __init__(self, ior: Any = 1.5, *, roughness: float = 0.0, volume: Medium | None = None, name: str = "Glass"):
        from .ior import as_ior

        self.ior = as_ior(ior)
        self.roughness = _roughness(roughness, name)
        self.volume = _medium(volume, name)
        self.name = name

    def bsdf_dict(self) -> dict[str, Any]:
        return {"type": "dielectric", "ior": self.ior.to_dict(), "roughness": self.roughness}


class Conductor(Material):
    """A metal: a measured one by name (``metal="gold"``, "silver", "copper",
    "aluminium") or a complex index ``eta`` + i ``k`` (numbers or spectra), with GGX
    ``roughness`` as Blender's (alpha = roughness²)."""

    def __init__(self, metal: str | None = None, *, eta: Any = None, k: Any = None, roughness: float = 0.0, name: str = "Metal"):
        if metal is None and (eta is None or k is None):
            raise ValueError(f"material '{name}': give metal=... or both eta and k")
        if metal is not None and (eta is not None or k is not None):
            raise ValueError(f"material '{name}': give metal=... or eta and k, not both")
        self.metal = metal
        self.eta = None if eta is None else as_spectrum(eta)
        self.k = None if k is None else as_spectrum(k)
        self.roughness = _roughness(roughness, name)
        self.name = name

    def bsdf_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {"type": "conductor", "roughness": self.roughness}
        if self.metal is not None:
            d["metal"] = str(self.metal)
        else:
            d["eta"] = self.eta.to_dict()
            d["k"] = self.k.to_dict()
        return d


class Glossy(Material):
    """Blender's Glossy BSDF: GGX reflection whose Fresnel (Schlick) is tinted by
    ``reflectance`` (the colour at normal incidence)."""

    def __init__(self, reflectance: Any = 0.8, *, roughness: float = 0.5, name: str = "Glossy"):
        self.reflectance = as_spectrum(reflectance)
        self.roughness = _roughness(roughness, name)
        self.name = name

    def bsdf_dict(self) -> dict[str, Any]:
        return {"type": "glossy", "reflectance": self.reflectance.to_dict(), "roughness": self.roughness}


@dataclass
class SpotLight:
    """Blender's spot light: ``power`` watts and ``color`` as for a point light
    (intensity ``color × power / 4π`` on the axis), shining along ``direction`` within a
    cone of full angle ``spot_size`` radians, its edge softened over ``spot_blend``.
    ``radius`` > 0: a sphere light as :class:`PointLight`'s, the spot falloff seen
    from its centre."""

    position: Sequence[float]
    direction: Sequence[float] = (0.0, 0.0, -1.0)
    power: float = 100.0
    color: Any = (1.0, 1.0, 1.0)
    spot_size: float = math.radians(45.0)
    spot_blend: float = 0.15
    name: str = "SpotLight"
    radius: float = 0.0
    #: the kinds of rays that see it, e.g. ``{"diffuse": False}``, ``{"camera": True}`` (``LIGHT_RAY_KINDS``)
    visibility: Any = None
    #: an IES profile scaling the intensity per direction, on top of the cone (see PointLight)
    profile: Any = None
    #: the light's axes (3 × 3, columns: local X, Y, Z in world space): turns the profile
    orientation: Any = None
    #: motion blur: light → world 4×4 keys over the shutter, as :class:`PointLight`'s
    motion: Any = None

    def to_dict(self) -> dict[str, Any]:
        pos = _finite_floats(self.position, f"light '{self.name}': position")
        d = _finite_floats(self.direction, f"light '{self.name}': direction")
        _finite_floats([self.power, self.spot_size, self.spot_blend], f"light '{self.name}': power/spot_size/spot_blend")
        if len(pos) != 3 or len(d) != 3:
            raise ValueError(f"light '{self.name}': position and direction must have 3 coordinates")
        intensity = as_spectrum(self.color) * (float(self.power) / (4.0 * math.pi))
        out = {
            "type": "spot",
            "name": self.name,
            "position": pos,
            "direction": d,
            "intensity": intensity.to_dict(),
            "spot_size": float(self.spot_size),
            "spot_blend": float(self.spot_blend),
        }
        _with_profile(out, self.profile, self.orientation)
        _with_light_motion(out, self.motion, self.name)
        return _with_light_visibility(_with_radius(out, self.radius, self.name), self.visibility, self.name)


@dataclass
class SunLight:
    """Blender's sun: parallel light travelling along ``direction`` (the lamp's −Z) with
    irradiance ``strength`` W/m² times ``color`` on a surface facing it. ``angle``:
    the sun's angular diameter in radians (Blender's sun angle; 0..π): a disk of
    directions of uniform radiance, soft shadows, the same irradiance on a surface
    facing it; BSDF rays that leave the scene inside the disk see it (the sun in a mirror,
    its caustic through glass), camera rays only with ``visibility={"camera": True}``."""

    direction: Sequence[float] = (0.0, 0.0, -1.0)
    strength: float = 1.0
    color: Any = (1.0, 1.0, 1.0)
    name: str = "Sun"
    angle: float = 0.0
    #: the kinds of rays that see it, e.g. ``{"diffuse": False}``, ``{"camera": True}`` (``LIGHT_RAY_KINDS``)
    visibility: Any = None
    #: motion blur: K ≥ 2 light → world 4×4 keys evenly spaced over the shutter; at each time the sun shines
    #: along its key's −Z (it turns; translation does nothing to it), ``direction`` is the one at the frame
    motion: Any = None

    def to_dict(self) -> dict[str, Any]:
        d = _finite_floats(self.direction, f"light '{self.name}': direction")
        if len(d) != 3:
            raise ValueError(f"light '{self.name}': direction must have 3 coordinates")
        _finite_floats([self.strength], f"light '{self.name}': strength")
        irradiance = as_spectrum(self.color) * float(self.strength)
        out = {"type": "distant", "name": self.name, "direction": d, "irradiance": irradiance.to_dict()}
        a = float(self.angle)
        if not (math.isfinite(a) and 0.0 <= a <= math.pi):
            raise ValueError(f"light '{self.name}': angle {self.angle} rad must be in [0, π]")
        if a > 0.0:
            out["angle"] = a
        _with_light_motion(out, self.motion, self.name)
        return _with_light_visibility(out, self.visibility, self.name)


def _unit(value: Any, what: str, name: str) -> float:
    v = float(value)
    if not (math.isfinite(v) and 0.0 <= v <= 1.0):
        raise ValueError(f"material '{name}': {what} {value} must be in 0..1")
    return v


def _sum_emission(parts: list[tuple[float, Spectrum | None]], name: str) -> Spectrum | None:
    """Weighted sum of emissions: kept exact when one part emits or all are RGB."""
    parts = [(w, e) for w, e in parts if e is not None and w > 0.0]
    if not parts:
        return None
    if len(parts) == 1:
        return parts[0][1] * parts[0][0]
    if all(e.kind == "rgb" for _, e in parts):
        rgb = [sum(w * e.scale * e.params["rgb"][c] for w, e in parts) for c in range(3)]
        return spectra.rgb(*rgb)
    if all(e.kind == "constant" for _, e in parts):
        return spectra.constant(sum(w * e.scale * e.params["value"] for w, e in parts))
    raise ValueError(f"material '{name}': cannot combine emissions of kinds {[e.kind for _, e in parts]}; give emission= explicitly")


class Principled(Material):
    """Blender's Principled BSDF: a diffuse ``base_color`` (a spectrum, number, RGB
    triple or :class:`~polychrome.Texture`) under a dielectric GGX specular layer with
    Fresnel at ``ior`` (a number or a :mod:`polychrome.ior` model: a dispersive index
    also disperses the transmitted light), blended towards a metal (``metallic``, base
    colour as F0, ``specular_tint`` at grazing angles) and a rough glass
    (``transmission``, tinted by the base colour). ``thin_film_thickness`` (nm) and
    ``thin_film_ior`` put an interference film on the specular interface (and on the
    metal). ``specular_ior_level`` scales the specular layer's normal-incidence reflectance
    by 2·level (0.5 keeps ``ior``). ``roughness`` as Blender's (alpha = roughness²).
    ``diffuse_roughness`` makes the base Oren–Nayar (Cycles' energy-preserving form).
    ``coat_weight`` puts Blender's Coat over everything (a GGX dielectric of
    ``coat_roughness`` and ``coat_ior`` whose ``coat_tint`` absorbs the light reaching the
    layers below), ``sheen_weight`` the microfibre sheen (``sheen_roughness``,
    ``sheen_tint``) over the coat, stacked as Cycles does (docs/materials.md).
    ``subsurface_weight`` of the base scatters inside the mesh as Cycles' random walk,
    with mean free path from ``subsurface_radius`` (per Rec.709 channel, made a spectrum
    by the uplift) × ``subsurface_scale`` (scene units), Henyey–Greenstein
    ``subsurface_anisotropy`` inside, ``subsurface_method`` ``"random_walk"`` or
    ``"random_walk_skin"`` (which enters through ``subsurface_ior``).
    Defaults are Blender's."""

    def __init__(
        self,
        base_color: Any = 0.8,
        *,
        metallic: float = 0.0,
        roughness: float = 0.5,
        ior: Any = 1.5,
        transmission: float = 0.0,
        specular_tint: Any = None,
        thin_film_thickness: float = 0.0,
        thin_film_ior: float = 1.33,
        specular_ior_level: float = 0.5,
        diffuse_roughness: float = 0.0,
        coat_weight: float = 0.0,
        coat_roughness: float = 0.03,
        coat_ior: float = 1.5,
        coat_tint: Any = None,
        sheen_weight: float = 0.0,
        sheen_roughness: float = 0.5,
        sheen_tint: Any = None,
        subsurface_weight: float = 0.0,
        subsurface_radius: tuple[float, float, float] = (1.0, 0.2, 0.1),
        subsurface_scale: float = 0.05,
        subsurface_ior: float = 1.4,
        subsurface_anisotropy: float = 0.0,
        subsurface_method: str = "random_walk",
        emission: Any = None,
        name: str = "Principled",
    ):
        from .ior import as_ior

        self.base_color = base_color if isinstance(base_color, Texture) else as_spectrum(base_color)
        self.metallic = _unit(metallic, "metallic", name)
        self.roughness = _roughness(roughness, name)
        self.ior = as_ior(ior)
        self.transmission = _unit(transmission, "transmission", name)
        self.specular_tint = None if specular_tint is None else as_spectrum(specular_tint)
        t = float(thin_film_thickness)
        if not (math.isfinite(t) and 0.0 <= t <= 100_000.0):
            raise ValueError(f"material '{name}': thin_film_thickness {thin_film_thickness} nm must be in 0..100000")
        n = float(thin_film_ior)
        if not (math.isfinite(n) and 1.0 <= n <= 10.0):
            raise ValueError(f"material '{name}': thin_film_ior {thin_film_ior} must be in 1..10")
        self.thin_film_thickness, self.thin_film_ior = t, n
        self.specular_ior_level = _unit(specular_ior_level, "specular_ior_level", name)
        self.diffuse_roughness = _unit(diffuse_roughness, "diffuse_roughness", name)
        self.coat_weight = _unit(coat_weight, "coat_weight", name)
        self.coat_roughness = _unit(coat_roughness, "coat_roughness", name)
        ci = float(coat_ior)
        if not (math.isfinite(ci) and 1.0 <= ci <= 10.0):
            raise ValueError(f"material '{name}': coat_ior {coat_ior} must be in 1..10")
        self.coat_ior = ci
        self.coat_tint = None if coat_tint is None else as_spectrum(coat_tint)
        self.sheen_weight = _unit(sheen_weight, "sheen_weight", name)
        self.sheen_roughness = _unit(sheen_roughness, "sheen_roughness", name)
        self.sheen_tint = None if sheen_tint is None else as_spectrum(sheen_tint)
        self.subsurface_weight = _unit(subsurface_weight, "subsurface_weight", name)
        radius = tuple(float(r) for r in subsurface_radius)
        if len(radius) != 3 or not all(math.isfinite(r) and r >= 0.0 for r in radius):
            raise ValueError(f"material '{name}': subsurface_radius {subsurface_radius} must be three finite values ≥ 0")
        scale = float(subsurface_scale)
        if not (math.isfinite(scale) and scale >= 0.0):
            raise ValueError(f"material '{name}': subsurface_scale {subsurface_scale} must be finite and ≥ 0")
        sior, aniso = float(subsurface_ior), float(subsurface_anisotropy)
        if not (math.isfinite(sior) and math.isfinite(aniso)):
            raise ValueError(f"material '{name}': subsurface_ior and subsurface_anisotropy must be finite")
        if subsurface_method not in ("random_walk", "random_walk_skin"):
            raise ValueError(f"material '{name}': subsurface_method {subsurface_method!r} is not 'random_walk' or 'random_walk_skin'")
        self.subsurface_radius, self.subsurface_scale = radius, scale
        self.subsurface_ior, self.subsurface_anisotropy, self.subsurface_method = sior, aniso, subsurface_method
        self.emission = None if emission is None else as_spectrum(emission)
        self.name = name

    def bsdf_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {
            "type": "principled",
            "base_color": self.base_color.to_dict(),
            "metallic": self.metallic,
            "roughness": self.roughness,
            "ior": self.ior.to_dict(),
            "transmission": self.transmission,
            "thin_film_thickness": self.thin_film_thickness,
            "thin_film_ior": self.thin_film_ior,
            "specular_ior_level": self.specular_ior_level,
        }
        if self.specular_tint is not None:
            d["specular_tint"] = self.specular_tint.to_dict()
        if self.diffuse_roughness > 0.0:
            d["diffuse_roughness"] = self.diffuse_roughness
        if self.coat_weight > 0.0:
            d["coat"] = {"weight": self.coat_weight, "roughness": self.coat_roughness, "ior": self.coat_ior}
            if self.coat_tint is not None:
                d["coat"]["tint"] = self.coat_tint.to_dict()
        if self.sheen_weight > 0.0:
            d["sheen"] = {"weight": self.sheen_weight, "roughness": self.sheen_roughness}
            if self.sheen_tint is not None:
                d["sheen"]["tint"] = self.sheen_tint.to_dict()
        if self.subsurface_weight > 0.0:
            d["subsurface"] = {
                "weight": self.subsurface_weight,
                "radius": list(self.subsurface_radius),
                "scale": self.subsurface_scale,
                "ior": self.subsurface_ior,
                "anisotropy": self.subsurface_anisotropy,
                "method": self.subsurface_method,
            }
        return d


@dataclass(frozen=True)
class Fresnel:
    """A view-dependent Mix factor: Blender's Fresnel node (dielectric reflectance at
    ``ior`` for the viewing angle)."""

    ior: float = 1.45

    def at_normal(self) -> float:
        n = max(float(self.ior), 1e-5)
        return ((n - 1) / (n + 1)) ** 2

    def to_dict(self) -> dict[str, Any]:
        n = float(self.ior)
        if not (math.isfinite(n) and n >= 0.0):
            raise ValueError(f"Fresnel factor: ior {self.ior} must be finite and non-negative")
        return {"type": "fresnel", "ior": n}


@dataclass(frozen=True)
class LayerWeight:
    """A view-dependent Mix factor: Blender's Layer Weight node, its ``"FRESNEL"`` or
    ``"FACING"`` output, with ``blend`` in 0..1."""

    blend: float = 0.5
    output: str = "FRESNEL"

    def at_normal(self) -> float:
        if self.output.upper() == "FACING":
            return 0.0
        eta = 1.0 / max(1.0 - float(self.blend), 1e-5)
        return ((eta - 1) / (eta + 1)) ** 2

    def to_dict(self) -> dict[str, Any]:
        b = float(self.blend)
        if not (math.isfinite(b) and 0.0 <= b <= 1.0):
            raise ValueError(f"LayerWeight factor: blend {self.blend} must be in 0..1")
        kind = {"FRESNEL": "layer_weight_fresnel", "FACING": "layer_weight_facing"}.get(self.output.upper())
        if kind is None:
            raise ValueError(f"LayerWeight factor: output {self.output!r} must be 'FRESNEL' or 'FACING'")
        return {"type": kind, "blend": b}


class Mix(Material):
    """Blender's Mix Shader of two materials: ``(1 − factor)·a + factor·b`` (factor 0
    gives ``a``, 1 gives ``b``). ``factor`` is a number or a view-dependent
    :class:`Fresnel` / :class:`LayerWeight` (Blender's nodes on Fac). Emissions mix the
    same way (a view-dependent factor by its value at normal incidence) unless
    ``emission`` is given. Mixes nest: ``a`` and ``b`` may be any material, including a Mix."""

    def __init__(self, a: Material, b: Material, factor: Any = 0.5, *, emission: Any = None, name: str = "Mix"):
        if not isinstance(a, Material) or not isinstance(b, Material):
            raise TypeError(f"material '{name}': a and b must be polychrome materials")
        self.a, self.b = a, b
        if isinstance(factor, (Fresnel, LayerWeight)):
            factor.to_dict()  # validates
            self.factor_from = factor
            self.factor = min(max(factor.at_normal(), 0.0), 1.0)
        else:
            self.factor_from = None
            self.factor = _unit(factor, "factor", name)
        self.name = name
        self.emission = (
            as_spectrum(emission)
            if emission is not None
            else _sum_emission([(1.0 - self.factor, a.emission), (self.factor, b.emission)], name)
        )

    def bsdf_dict(self) -> dict[str, Any]:
        d = {"type": "mix", "a": self.a.bsdf_dict(), "b": self.b.bsdf_dict(), "factor": self.factor}
        if self.factor_from is not None:
            d["factor_from"] = self.factor_from.to_dict()
        return d


class Add(Material):
    """Blender's Add Shader: ``a + b`` (emissions add too). Like Cycles, it may reflect
    more light than it receives when ``a`` and ``b`` together do."""

    def __init__(self, a: Material, b: Material, *, emission: Any = None, name: str = "Add"):
        if not isinstance(a, Material) or not isinstance(b, Material):
            raise TypeError(f"material '{name}': a and b must be polychrome materials")
        self.a, self.b = a, b
        self.name = name
        self.emission = as_spectrum(emission) if emission is not None else _sum_emission([(1.0, a.emission), (1.0, b.emission)], name)

    def bsdf_dict(self) -> dict[str, Any]:
        return {"type": "add", "a": self.a.bsdf_dict(), "b": self.b.bsdf_dict()}


class NodeMaterial(Material):
    """A material given as a node graph in Blender's vocabulary (docs/shading.md):
    ``nodes`` is the flat list of ``{"type", "name", "props", "inputs"}`` dicts and
    ``output`` names the closure, e.g. ``{"surface": [3, "BSDF"]}``. A
    :class:`~polychrome.Texture` given as a node's ``props["texture"]`` is added to the
    scene's textures. The core compiles and checks the graph."""

    def __init__(self, name: str, nodes: Sequence[dict[str, Any]], output: dict[str, Any]):
        if not isinstance(nodes, (list, tuple)) or not all(isinstance(n, dict) for n in nodes):
            raise TypeError(f"material '{name}': nodes must be a list of dicts")
        if not isinstance(output, dict):
            raise TypeError(f"material '{name}': output must be a dict such as {{'surface': [0, 'BSDF']}}")
        self.name = name
        self.nodes = [dict(n) for n in nodes]
        self.output = dict(output)

    def to_dict(self) -> dict[str, Any]:
        d = {"name": self.name, "nodes": self.nodes, "output": self.output}
        if _medium(self.volume, self.name) is not None:
            d["volume"] = self.volume.to_dict()
        return d


#: The kinds of rays an instance's ``visibility`` names (Cycles' ray visibility).
RAY_KINDS = ("camera", "shadow", "diffuse", "glossy", "transmission")


class Scene:
    """A scene description: camera, materials, meshes, instances, lights, world."""

    def __init__(self) -> None:
        self.camera = Camera()
        self.materials: list[Material] = []
        self._meshes: list[dict[str, Any]] = []
        self._buffers: list[np.ndarray] = []
        self._instances: list[dict[str, Any]] = []
        self.lights: list[Any] = []
        self.world: Spectrum | None = None
        self.world_texture: dict[str, Any] | None = None
        #: A :class:`Medium` filling all space (Blender's World > Volume): it adds to the
        #: media of closed meshes and surrounds the camera (docs/media.md).
        self.world_volume: Medium | None = None
        #: Cycles' Film > Transparent: the background seen directly makes the image's
        #: alpha 0 there (Holdout closures do so either way, docs/materials.md#holdout).
        self.film_transparent = False

    # -- materials -------------------------------------------------------------
    def add_material(self, material: Material) -> int:
        """Adds a material, returning its index."""
        if not isinstance(material, Material):
            raise TypeError(f"expected a polychrome material, got {type(material).__name__}")
        self.materials.append(material)
        return len(self.materials) - 1

    def _material_index(self, material: Material | int | None, mesh: str) -> int:
        if material is None:
            return 0
        if isinstance(material, Material):
            for i, m in enumerate(self.materials):
                if m is material:
                    return i
            return self.add_material(material)
        index = int(material)
        if not 0 <= index < max(len(self.materials), 1):
            raise ValueError(f"mesh '{mesh}': material {index} does not exist ({len(self.materials)} materials)")
        return index

    def _buffer(self, array: np.ndarray) -> int:
        self._buffers.append(array)
        return len(self._buffers) - 1

    # -- geometry --------------------------------------------------------------
    def add_mesh(
        self,
        name: str,
        vertices: Any,
        triangles: Any,
        *,
        normals: Any = None,
        uvs: Any = None,
        material: Material | int | None = None,
        material_ids: Any = None,
        transform: Any = None,
        place: bool = True,
        motion_vertices: Any = None,
        motion_normals: Any = None,
        motion: Any = None,
        uv_maps: dict[str, Any] | None = None,
        colors: dict[str, Any] | None = None,
        attributes: dict[str, Any] | None = None,
        tangents: Any = None,
        tangent_maps: dict[str, Any] | None = None,
    ) -> int:
        """Adds a triangle mesh from arrays: vertices (V, 3), triangles (T, 3) vertex
        indices, optional per-vertex normals (V, 3) and uvs (V, 2), one material or
        per-triangle ``material_ids`` (T,). Returns the mesh index. Unless ``place`` is
        False the mesh is placed once with ``transform`` (4×4, object → world);
        :meth:`add_instance` places it again.

        Motion blur (docs/camera.md): ``motion_vertices`` (K, V, 3), K ≥ 2 positions
        evenly spaced from shutter open to close, makes a deforming mesh (with
        ``motion_normals`` of the same shape, optionally); ``motion`` (K, 4, 4)
        transforms move the placement made here.

        Shading graphs (:class:`NodeMaterial`, docs/shading.md) read named per-vertex
        data: ``uv_maps`` {name: (V, 2)}, ``colors`` {name: (V, 4) or (V, 3) linear
        RGBA}, ``attributes`` {name: (V,), (V, 3) or (V, 4)}, ``tangents`` (V, 4):
        tangent xyz and bitangent sign of the default UV map, and ``tangent_maps``
        {UV map name: (V, 4)}: the tangents a Normal Map or Tangent node naming that UV
        map reads (a map without its own set reads ``tangents``)."""
        v = np.ascontiguousarray(vertices, dtype=np.float32)
        if v.ndim != 2 or v.shape[1] != 3:
            raise ValueError(f"mesh '{name}': vertices must have shape (V, 3), got {v.shape}")
        t = np.asarray(triangles)
        if t.ndim != 2 or t.shape[1] != 3:
            raise ValueError(f"mesh '{name}': triangles must have shape (T, 3), got {t.shape}")
        if not np.issubdtype(t.dtype, np.integer) and t.size:
            raise ValueError(f"mesh '{name}': triangles must be integer vertex indices, got {t.dtype}")
        if t.size and t.min() < 0:
            raise ValueError(f"mesh '{name}': triangle {int(np.argwhere(t < 0)[0][0])} has a negative vertex index")
        entry: dict[str, Any] = {
            "name": name,
            "vertices": self._buffer(v.ravel()),
            "triangles": self._buffer(np.ascontiguousarray(t, dtype=np.uint32).ravel()),
        }
        if normals is not None:
            n = np.ascontiguousarray(normals, dtype=np.float32)
            if n.shape != v.shape:
                raise ValueError(f"mesh '{name}': normals must have shape {v.shape}, got {n.shape}")
            entry["normals"] = self._buffer(n.ravel())
        if uvs is not None:
            uv = np.ascontiguousarray(uvs, dtype=np.float32)
            if uv.shape != (v.shape[0], 2):
                raise ValueError(f"mesh '{name}': uvs must have shape ({v.shape[0]}, 2), got {uv.shape}")
            entry["uvs"] = self._buffer(uv.ravel())
        for key, table, widths in (("uv_maps", uv_maps, (2,)), ("colors", colors, (4, 3)), ("attributes", attributes, (1, 3, 4))):
            if table is None:
                continue
            entry[key] = {}
            for attr, values in table.items():
                a = np.ascontiguousarray(values, dtype=np.float32).reshape(v.shape[0], -1)
                if a.shape[1] not in widths or not np.all(np.isfinite(a)):
                    raise ValueError(
                        f"mesh '{name}': {key} '{attr}' must be finite with shape (V, {' or '.join(map(str, widths))}), got {a.shape}"
                    )
                entry[key][str(attr)] = self._buffer(a.ravel())
        if tangents is not None:
            tg = np.ascontiguousarray(tangents, dtype=np.float32)
            if tg.shape != (v.shape[0], 4):
                raise ValueError(f"mesh '{name}': tangents must have shape ({v.shape[0]}, 4), got {tg.shape}")
            entry["tangents"] = self._buffer(tg.ravel())
        if tangent_maps:
            entry["tangent_maps"] = {}
            for uv_name, values in tangent_maps.items():
                tg = np.ascontiguousarray(values, dtype=np.float32)
                if tg.shape != (v.shape[0], 4) or not np.all(np.isfinite(tg)):
                    raise ValueError(f"mesh '{name}': tangent_maps '{uv_name}' must be finite with shape ({v.shape[0]}, 4), got {tg.shape}")
                entry["tangent_maps"][str(uv_name)] = self._buffer(tg.ravel())
        if material_ids is not None:
            ids = np.asarray(material_ids)
            if ids.shape != (t.shape[0],):
                raise ValueError(f"mesh '{name}': material_ids must have shape ({t.shape[0]},), got {ids.shape}")
            if ids.size and (ids.min() < 0 or ids.max() >= len(self.materials)):
                raise ValueError(f"mesh '{name}': material_ids must lie in 0..{len(self.materials) - 1}")
            entry["material_ids"] = self._buffer(np.ascontiguousarray(ids, dtype=np.uint32))
        else:
            entry["material"] = self._material_index(material, name)
        if motion_vertices is not None:
            keys = _motion_keys(motion_vertices, v.shape, f"mesh '{name}': motion_vertices")
            entry["motion_vertices"] = [self._buffer(k.ravel()) for k in keys]
            if motion_normals is not None:
                nkeys = _motion_keys(motion_normals, v.shape, f"mesh '{name}': motion_normals")
                if len(nkeys) != len(keys):
                    raise ValueError(f"mesh '{name}': {len(nkeys)} motion_normals keys for {len(keys)} motion_vertices keys")
                entry["motion_normals"] = [self._buffer(k.ravel()) for k in nkeys]
        elif motion_normals is not None:
            raise ValueError(f"mesh '{name}': motion_normals need motion_vertices")
        self._meshes.append(entry)
        index = len(self._meshes) - 1
        if place:
            self.add_instance(index, np.eye(4) if transform is None else transform, name, motion=motion)
        elif motion is not None:
            raise ValueError(f"mesh '{name}': motion moves a placement, but place=False makes none")
        return index

    def add_curves(
        self,
        name: str,
        keys: Any,
        counts: Any,
        *,
        radius: Any = 0.005,
        material: Material | int | None = None,
        material_ids: Any = None,
        linear: bool = False,
        subdivisions: int = 4,
        sides: int = 8,
        transform: Any = None,
        place: bool = True,
    ) -> int:
        """Adds curves (hair, fur): ``keys`` (K, 3) in order, ``counts`` keys per curve,
        ``radius`` per key (K,) or one value, one material or per-curve ``material_ids``.
        They are interpolated like Cycles' (Catmull-Rom; ``linear``: straight segments)
        and tessellated into tubes of ``sides`` sides with ``subdivisions`` rings per key
        segment (``polychrome.curves``; docs/camera.md). Returns the mesh index; placed
        like :meth:`add_mesh`."""
        from . import curves

        v, n, uv, t, tri_curve = curves.curves_mesh(keys, radius, counts, subdivisions=subdivisions, sides=sides, linear=linear, name=name)
        ids = None
        if material_ids is not None:
            per_curve = np.asarray(material_ids)
            if per_curve.shape != (len(np.asarray(counts)),):
                raise ValueError(f"curves '{name}': material_ids must have one entry per curve")
            ids = per_curve[tri_curve]
        return self.add_mesh(name, v, t, normals=n, uvs=uv, material=material, material_ids=ids, transform=transform, place=place)

    def add_points(
        self,
        name: str,
        positions: Any,
        *,
        radius: Any = 0.01,
        material: Material | int | None = None,
        material_ids: Any = None,
        level: int = 1,
        transform: Any = None,
        place: bool = True,
    ) -> int:
        """Adds a point cloud as spheres (``radius`` per point or one value), each a
        subdivided icosahedron of ``level`` (1: 80 triangles; ``polychrome.curves``).
        Returns the mesh index; placed like :meth:`add_mesh`."""
        from . import curves

        v, n, uv, t, tri_point = curves.points_mesh(positions, radius, level=level, name=name)
        ids = None
        if material_ids is not None:
            per_point = np.asarray(material_ids)
            if per_point.shape != (len(np.asarray(positions)),):
                raise ValueError(f"point cloud '{name}': material_ids must have one entry per point")
            ids = per_point[tri_point]
        return self.add_mesh(name, v, t, normals=n, uvs=uv, material=material, material_ids=ids, transform=transform, place=place)

    def add_instance(
        self,
        mesh: int,
        transform: Any,
        name: str = "",
        *,
        motion: Any = None,
        visibility: Any = None,
        random: float | None = None,
        holdout: bool = False,
    ) -> None:
        """Places mesh ``mesh`` again with ``transform``; instances share the mesh's data.
        ``motion``: object → world transforms (K ≥ 2, 4×4 each) evenly spaced from
        shutter open to close, for motion blur; ``transform`` is then its placement at
        the frame (docs/camera.md). ``visibility``: the kinds of rays that see it, a dict
        of ``camera``, ``shadow``, ``diffuse``, ``glossy``, ``transmission`` booleans
        (missing ones True), as Cycles' ray visibility (docs/blender.md). ``random``: what
        Object Info › Random reads on it, 0..1 (default: Cycles' hash of the name, as for a
        Blender object that is no instance). ``holdout``: Cycles' object holdout (Object ›
        Visibility › Holdout): the camera sees a hole of alpha 0 there, every other ray
        the mesh's materials (docs/materials.md#holdout)."""
        if not 0 <= mesh < len(self._meshes):
            raise ValueError(f"instance '{name}': mesh {mesh} does not exist")
        label = name or self._meshes[mesh]["name"]
        entry = {"name": label, "mesh": int(mesh), "transform": _matrix(transform, f"instance '{label}'")}
        if motion is not None:
            entry["motion"] = _motion_matrices(motion, f"instance '{label}'")
        if random is not None:
            r = float(random)
            if not (math.isfinite(r) and 0.0 <= r <= 1.0):
                raise ValueError(f"instance '{label}': random {random} must be in 0..1")
            entry["random"] = r
        if holdout:
            entry["holdout"] = True
        if visibility is not None:
            vis = dict(visibility)
            unknown = sorted(set(vis) - set(RAY_KINDS))
            if unknown:
                raise ValueError(f"instance '{label}': unknown ray visibility {unknown} (known: {', '.join(RAY_KINDS)})")
            if not all(isinstance(v, (bool, np.bool_)) for v in vis.values()):
                raise ValueError(f"instance '{label}': ray visibility values must be True or False")
            if not all(vis.values()):  # all visible is the default: leave the description as it was
                entry["visibility"] = {k: bool(v) for k, v in vis.items()}
        self._instances.append(entry)

    def add_light(self, light: Any) -> None:
        self.lights.append(light)

    def set_world(
        self,
        radiance: Any = None,
        *,
        texture: Texture | None = None,
        strength: float = 1.0,
        rotation: float = 0.0,
        importance_sampling: bool = True,
    ) -> None:
        """Uniform radiance from every direction (Blender's world colour), or an
        equirectangular HDRI ``texture`` (Blender's Environment Texture, Z-up) times
        ``strength``, turned by ``rotation`` radians about +Z (the Mapping node's Z
        rotation). With neither, the world is removed."""
        self.world_texture = None
        if texture is not None:
            if not isinstance(texture, Texture):
                raise TypeError(f"world: texture must be a polychrome.Texture, got {type(texture).__name__}")
            s, r = float(strength), float(rotation)
            if not (math.isfinite(s) and s >= 0.0) or not math.isfinite(r):
                raise ValueError(f"world: strength {strength} must be finite and non-negative, rotation {rotation} finite")
            self.world = None
            self.world_texture = {"texture": texture, "strength": s, "rotation": r, "importance_sampling": bool(importance_sampling)}
            return
        self.world = None if radiance is None else as_spectrum(radiance)

    # -- export to the core ----------------------------------------------------
    def description(self) -> tuple[dict[str, Any], list[np.ndarray]]:
        """The JSON-ready description and its buffers, as the core reads them."""
        desc = {
            "camera": self.camera.to_dict(),
            "materials": [m.to_dict() for m in self.materials],
            "meshes": self._meshes,
            "instances": self._instances,
            "lights": [light.to_dict() for light in self.lights],
            "world": None if self.world is None else {"radiance": self.world.to_dict()},
        }
        if self.film_transparent:
            desc["film_transparent"] = True
        desc, buffers = self._resolve_textures(desc, self._buffers)
        volume = _medium(self.world_volume, "World")
        if volume is not None:
            desc["world"] = {**(desc["world"] or {}), "volume": volume.to_dict()}
        return desc, buffers

    def _resolve_textures(self, desc: dict[str, Any], buffers: list[np.ndarray]) -> tuple[dict[str, Any], list[np.ndarray]]:
        """Replaces Texture objects in the description by indices into a ``textures``
        list whose pixels go into new numbered buffers (float32 or uint8)."""
        textures: list[Texture] = []
        buffers = list(buffers)
        entries: list[dict[str, Any]] = []

        def index(t: Texture) -> int:
            for i, known in enumerate(textures):
                if known is t:
                    return i
            textures.append(t)
            buffers.append(t.pixels.ravel())
            entries.append(
                {
                    "name": t.name,
                    "width": t.width,
                    "height": t.height,
                    "channels": int(t.pixels.shape[2]),
                    "buffer": len(buffers) - 1,
                    "encoding": t.encoding,
                    "wrap": t.wrap,
                }
            )
            return len(textures) - 1

        def walk(value: Any) -> Any:
            if isinstance(value, dict):
                return {k: (index(v) if isinstance(v, Texture) else walk(v)) for k, v in value.items()}
            if isinstance(value, list):
                return [walk(v) for v in value]
            return value

        desc = walk(desc)
        if self.world_texture is not None:
            desc["world"] = {**self.world_texture, "texture": index(self.world_texture["texture"])}
        if textures:
            desc["textures"] = entries
        return desc, buffers


__all__ = ["Camera", "Material", "Diffuse", "Emitter", "PointLight", "Scene", "Texture", "look_at", "spectra"]
__all__ += ["Dielectric", "Conductor", "Glossy", "SpotLight", "SunLight"]
__all__ += ["Principled", "Mix", "Add", "Fresnel", "LayerWeight", "NodeMaterial"]
