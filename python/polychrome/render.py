"""Rendering a scene: settings with the same names as the CLI and Blender, a progress
bar, cancellation, and the result as numpy arrays with writers for EXR and PNG."""

from __future__ import annotations

from dataclasses import dataclass, field, replace
import json
from pathlib import Path
import sys
import time
from typing import Any
from collections.abc import Callable

import numpy as np

from . import _core
from . import settings as _settings
from .scene import Scene

#: Generated from the core's settings schema (see polychrome.settings): the same names,
#: defaults and ranges as the CLI flags and Blender's ``scene.polychrome``.
RenderSettings = _settings.make_settings_class()
METHODS = _settings.choices("method")
DIRECTIONS = _settings.choices("direction")
UPLIFTS = _settings.choices("uplift")
#: ``quality`` presets; AUTO fits the grid to the scene and samples adaptively.
QUALITIES = _settings.choices("quality")
#: Settings a quality preset fills when they are left at None (not set explicitly).
QUALITY_FIELDS = tuple(name for name, s in _settings.SETTINGS.items() if s["from_quality"])


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
    #: With ``denoise``: the image before denoising (``rgba`` is then the denoised one).
    noisy: np.ndarray | None = None

    def denoised(self) -> RenderResult:
        """This result with ``rgba`` denoised by Open Image Denoise (guided by the albedo
        and normal passes, prefiltered) and the original kept as ``noisy``; spectral
        passes stay raw. See :mod:`polychrome.denoise`."""
        from . import denoise

        if self.noisy is not None:
            return self
        start = time.perf_counter()
        rgba = denoise.denoise(self.rgba, self.albedo, self.normal)
        stats = dict(self.stats, denoise_seconds=time.perf_counter() - start, denoiser=f"Open Image Denoise {denoise.version()}")
        return replace(self, rgba=rgba, noisy=self.rgba, stats=stats)

    @property
    def partial(self) -> bool:
        """The render stopped early (cancelled, Ctrl-C): not every sample was taken."""
        return bool(self.stats.get("partial") or self.stats.get("cancelled"))

    def metadata(self) -> dict[str, str]:
        """What :meth:`save` writes into the file (EXR header attributes, PNG text):
        ``polychrome:partial`` ("1" when the render stopped early), the samples per pixel
        and the stats as JSON."""
        return {
            "polychrome:partial": "1" if self.partial else "0",
            "polychrome:samples": str(self.stats.get("samples_per_pixel", "")),
            "polychrome:stats": json.dumps(self.stats, default=str),
        }

    def save(self, path: str | Path, *, passes: bool = False) -> Path:
        """Writes the image by extension: ``.png`` (sRGB 8-bit) or ``.exr`` (float; with
        ``passes`` also Depth, Normal, Albedo layers, and for a denoised render Blender's
        Noisy Image, Denoising Albedo and Denoising Normal; a spectral render also writes
        the spectrum in the JCGT 2021 spectral-EXR layout beside the RGB). The file is written
        to a temporary name and renamed over ``path``, so a failed or interrupted write never
        truncates an existing image; :meth:`metadata` goes into the file."""
        from . import imageio

        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        ext = path.suffix.lower()
        meta = self.metadata()
        if ext == ".png":
            imageio.write_png(path, self.rgba, metadata=meta)
        elif ext == ".exr":
            if self.spectral is not None:
                imageio.write_spectral_exr(path, self.spectral, self.wavelengths, rgba=self.rgba, metadata=meta)
            elif passes:
                layers = {"Combined": self.rgba, "Depth": self.depth[..., None], "Normal": self.normal, "Albedo": self.albedo}
                if self.noisy is not None:
                    layers.update({"Noisy Image": self.noisy, "Denoising Albedo": self.albedo, "Denoising Normal": self.normal})
                imageio.write_exr_layers(path, layers, metadata=meta)
            else:
                imageio.write_exr(path, self.rgba, metadata=meta)
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


def warn_left_out(stats: dict[str, Any]) -> None:
    """One warning per thing the core left out of the render (``stats["warnings"]``)."""
    import warnings

    for message in stats.get("warnings", []):
        warnings.warn(message, stacklevel=3)


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

    ``checkpoint``: a file the finished passes are saved to while rendering (in tasks on
    this machine or the cluster); with ``resume`` the render continues from it and ends
    with the image of an uninterrupted render (docs/distributed.md).

    ``scheduler``: a Dask scheduler address (``tcp://host:8786``) or a
    ``distributed.Client`` renders on that cluster (docs/distributed.md): the same image
    for the same seed; Ctrl-C raises ``polychrome.distributed.RenderInterrupted``, whose
    ``result`` holds the finished passes.
    """
    client = None
    if not isinstance(overrides.get("scheduler", ""), str):  # a distributed.Client
        client = overrides.pop("scheduler")
    settings = replace(settings or RenderSettings(), **overrides)  # validates every setting
    if settings.denoise:
        from . import denoise

        denoise.require()  # before rendering, not after
    desc, buffers = scene.description()
    close = None
    if progress is True:
        callback, close = _progress_bar("Polychrome")
    elif callable(progress):
        callback = progress
    else:
        callback = None
    try:
        if client is not None or settings.scheduler:
            from . import distributed

            result = distributed.render(desc, buffers, settings, client or settings.scheduler, progress=callback)
        elif settings.checkpoint or settings.resume:
            from . import tasks

            result = tasks.render_local(desc, buffers, settings, progress=callback)
        else:
            start = time.perf_counter()
            out = _core.render(description_json(desc), buffers, settings.to_json(), callback)
            stats = json.loads(out["stats"])
            stats["wall_seconds"] = time.perf_counter() - start
            result = RenderResult(
                rgba=out["rgba"],
                depth=out["depth"],
                normal=out["normal"],
                albedo=out["albedo"],
                spectral=out["spectral"],
                wavelengths=out["wavelengths"],
                stats=stats,
            )
    finally:
        if close:
            close()
    warn_left_out(result.stats)
    return result.denoised() if settings.denoise else result
