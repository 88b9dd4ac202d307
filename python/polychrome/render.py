"""Rendering a scene: settings with the same names as the CLI and Blender, a progress
bar, cancellation, and the result as numpy arrays with writers for EXR and PNG."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, replace
import json
from pathlib import Path
import sys
import time
from typing import Any
from collections.abc import Callable

import numpy as np

from . import _core
from .scene import Scene

METHODS = ("POLYCHROMATIC", "MONOCHROMATIC_RAYS", "MONOCHROMATIC_SCENES", "RGB")
DIRECTIONS = ("BACKWARD", "FORWARD", "BIDIRECTIONAL")
UPLIFTS = ("LINEAR", "SMOOTH")
#: ``quality`` presets; AUTO fits the grid to the scene and samples adaptively.
QUALITIES = ("AUTO", "PREVIEW", "FINAL", "REFERENCE")
#: Settings a quality preset fills when they are left at None (not set explicitly).
QUALITY_FIELDS = ("samples", "max_bounces", "wavelength_count", "wavelengths", "noise_threshold")


@dataclass
class RenderSettings:
    """Everything that controls a render; names match the CLI flags and ``scene.polychrome``."""

    width: int = 320
    height: int = 240
    #: None: chosen by ``quality`` (the maximum per pixel when sampling adaptively).
    samples: int | None = None
    method: str = "POLYCHROMATIC"
    #: BACKWARD (from the camera), FORWARD (light tracing) or BIDIRECTIONAL.
    direction: str = "BACKWARD"
    #: POLYCHROMATIC only: split into one monochromatic path per wavelength at the
    #: first dispersive surface instead of choosing one (deterministic mode).
    dispersion_splitting: bool = False
    #: None (and no ``wavelengths``): the grid is chosen by ``quality``.
    wavelength_count: int | None = None
    wavelength_min: float = 380.0
    wavelength_max: float = 780.0
    wavelengths: list[float] | None = None
    max_bounces: int | None = None
    seed: int = 0
    threads: int = 0
    time_limit: float = 0.0
    uplift: str = "LINEAR"
    spectral_output: bool = False
    #: AUTO, PREVIEW, FINAL or REFERENCE: fills every setting of QUALITY_FIELDS left at
    #: None; a value given explicitly always wins.
    quality: str = "AUTO"
    #: Adaptive sampling: stop a pixel at this estimated ΔE (0: off; None: from quality).
    noise_threshold: float | None = None

    def to_json(self) -> str:
        d = {k: v for k, v in asdict(self).items() if v is not None or k not in QUALITY_FIELDS}
        if str(d["quality"]).upper() not in QUALITIES:
            raise ValueError(f"setting 'quality': '{d['quality']}' is not one of {', '.join(QUALITIES)}")
        d["quality"] = d["quality"].upper()
        if "noise_threshold" in d:
            d["noise_threshold"] = float(d["noise_threshold"])
            if not d["noise_threshold"] >= 0:
                raise ValueError(f"setting 'noise_threshold': {d['noise_threshold']} must be 0 (off) or positive")
        d["method"] = d["method"].upper()
        d["direction"] = d["direction"].upper()
        d["dispersion_splitting"] = bool(d["dispersion_splitting"])
        d["uplift"] = d["uplift"].upper()
        if d.get("wavelengths") is not None:
            d["wavelengths"] = [float(x) for x in d["wavelengths"]]
        for k in ("width", "height", "samples", "max_bounces", "seed", "threads", "wavelength_count"):
            if k in d and int(d[k]) < 0:
                raise ValueError(f"setting '{k}': {d[k]} must not be negative")
        return json.dumps(d)


@dataclass
class RenderResult:
    """A finished (or cancelled) render. Arrays have row 0 at the top of the image."""

    rgba: np.ndarray
    depth: np.ndarray
    normal: np.ndarray
    albedo: np.ndarray
    spectral: np.ndarray | None
    wavelengths: np.ndarray
    stats: dict[str, Any] = field(default_factory=dict)

    def save(self, path: str | Path, *, passes: bool = False) -> Path:
        """Writes the image by extension: ``.png`` (sRGB 8-bit) or ``.exr`` (float; with
        ``passes`` also Depth, Normal, Albedo layers; a spectral render also writes the
        spectrum in the JCGT 2021 spectral-EXR layout beside the RGB)."""
        from . import imageio

        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        ext = path.suffix.lower()
        if ext == ".png":
            imageio.write_png(path, self.rgba)
        elif ext == ".exr":
            if self.spectral is not None:
                imageio.write_spectral_exr(path, self.spectral, self.wavelengths, rgba=self.rgba)
            elif passes:
                imageio.write_exr_layers(
                    path, {"Combined": self.rgba, "Depth": self.depth[..., None], "Normal": self.normal, "Albedo": self.albedo}
                )
            else:
                imageio.write_exr(path, self.rgba)
        else:
            raise ValueError(f"{path}: unsupported image type '{ext}' (use .png or .exr)")
        return path


ProgressCallback = Callable[[int, int], Any]


def _nonfinite_path(value: Any, path: str = "") -> str | None:
    """Where in a description a NaN or infinity sits, e.g. "materials[1] 'lamp'.emission.scale"."""
    if isinstance(value, float):
        return None if np.isfinite(value) else path
    if isinstance(value, dict):
        for k, v in value.items():
            label = f"{path}.{k}" if path else str(k)
            if isinstance(v, list) and v and isinstance(v[0], dict):
                for i, item in enumerate(v):
                    name = item.get("name") if isinstance(item, dict) else None
                    found = _nonfinite_path(item, f"{label}[{i}]" + (f" '{name}'" if name else ""))
                    if found:
                        return found
                continue
            found = _nonfinite_path(v, label)
            if found:
                return found
    if isinstance(value, (list, tuple)):
        for i, v in enumerate(value):
            found = _nonfinite_path(v, f"{path}[{i}]")
            if found:
                return found
    return None


def check_settings(settings: RenderSettings) -> None:
    """The enum checks, with a message naming the setting."""
    for name, allowed in (("method", METHODS), ("direction", DIRECTIONS), ("uplift", UPLIFTS)):
        value = getattr(settings, name)
        if str(value).upper() not in allowed:
            raise ValueError(f"setting '{name}': '{value}' is not one of {', '.join(allowed)}")


def description_json(desc: dict[str, Any]) -> str:
    """JSON of a scene description; JSON has no NaN or infinity, so a non-finite number is
    reported here with where it is instead of as a parse error in the core."""
    try:
        return json.dumps(desc, allow_nan=False)
    except ValueError:
        where = _nonfinite_path(desc) or "a value"
        raise ValueError(f"scene description: {where} is not finite") from None


def _progress_bar(description: str) -> tuple[ProgressCallback, Callable[[], None]]:
    """A tqdm bar over pixel samples (falls back to nothing if tqdm is missing)."""
    try:
        from tqdm import tqdm
    except ImportError:  # pragma: no cover
        return (lambda done, total: None), (lambda: None)
    bar = tqdm(total=1, desc=description, unit=" samples", unit_scale=True, file=sys.stderr, leave=True, dynamic_ncols=True)
    state = {"total": 0}

    def update(done: int, total: int) -> None:
        if total and total != state["total"]:
            state["total"] = total
            bar.reset(total=total)
        bar.n = done
        bar.refresh()

    return update, bar.close


def render(
    scene: Scene,
    settings: RenderSettings | None = None,
    *,
    progress: bool | ProgressCallback = False,
    **overrides: Any,
) -> RenderResult:
    """Renders ``scene``. Settings come from ``settings`` with keyword overrides, e.g.
    ``render(scene, samples=256, wavelength_count=81)``.

    ``progress``: True for a progress bar on stderr, or a callable ``f(done, total)``
    (pixel samples) called about 20 times a second that may return False to cancel.
    Ctrl-C cancels too (KeyboardInterrupt). Errors in the scene raise ValueError naming
    the object and the problem.
    """
    settings = replace(settings or RenderSettings(), **overrides)
    check_settings(settings)
    desc, buffers = scene.description()
    close = None
    if progress is True:
        callback, close = _progress_bar("Polychrome")
    elif callable(progress):
        callback = progress
    else:
        callback = None
    try:
        start = time.perf_counter()
        out = _core.render(description_json(desc), buffers, settings.to_json(), callback)
    finally:
        if close:
            close()
    stats = json.loads(out["stats"])
    stats["wall_seconds"] = time.perf_counter() - start
    return RenderResult(
        rgba=out["rgba"],
        depth=out["depth"],
        normal=out["normal"],
        albedo=out["albedo"],
        spectral=out["spectral"],
        wavelengths=out["wavelengths"],
        stats=stats,
    )
