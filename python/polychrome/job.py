"""Background renders with progressive previews, for interactive front ends (the Blender
viewport, notebooks, GUIs).

::

    job = pc.RenderJob(scene, samples=256, width=320, height=240).start()
    while not job.wait(0.1):
        p = job.preview()            # Preview(rgba, samples, serial, last) or None
        ...                          # draw p.rgba
    result = job.result()            # a RenderResult, as pc.render returns

The render runs on its own thread without the GIL; every method may be called from any
Python thread. The core publishes a preview after the first pass, then at most every
100 ms, and the final image last (``last=True``; its ``rgba`` equals ``result().rgba``).
With ``denoise_previews`` the previews are denoised (colour only, OIDN's fast quality:
the core's previews carry no aux images); with ``denoise`` the result is, and so the
last preview.
"""

from __future__ import annotations

from dataclasses import replace
import json
import time
from typing import Any, NamedTuple
from collections.abc import Callable

import numpy as np

from . import _core
from .render import RenderResult, RenderSettings, description_json, warn_left_out
from .scene import Scene


class Preview(NamedTuple):
    """A snapshot of a running render: ``rgba`` (H, W, 4) float32, row 0 at the top,
    converted exactly as the final image; ``samples`` per pixel so far; ``serial`` counts
    the job's snapshots from 1; ``last`` marks the final image."""

    rgba: np.ndarray
    samples: int
    serial: int
    last: bool


class RenderJob:
    """A render of ``scene`` on a background thread. Settings as :func:`polychrome.render`
    (``settings`` plus keyword overrides). ``previews=False`` skips the snapshots."""

    def __init__(
        self,
        scene: Scene | None = None,
        settings: RenderSettings | None = None,
        *,
        previews: bool = True,
        description: tuple[dict[str, Any], list[np.ndarray]] | None = None,
        **overrides: Any,
    ):
        self.settings = replace(settings or RenderSettings(), **overrides)  # validates every setting
        if self.settings.denoise or self.settings.denoise_previews:
            from . import denoise

            denoise.require()
        if description is None:
            if scene is None:
                raise ValueError("RenderJob needs a scene (or a description)")
            description = scene.description()
        desc, buffers = description
        self._job = _core.RenderJob(description_json(desc), buffers, self.settings.to_json(), previews)
        self._result: RenderResult | None = None
        self._error: BaseException | None = None
        self._started: float | None = None

    @classmethod
    def from_description(
        cls, desc: dict[str, Any], buffers: list[np.ndarray], settings: RenderSettings | None = None, **kw: Any
    ) -> RenderJob:
        """A job for an already built description (``Scene.description()``)."""
        return cls(None, settings, description=(desc, buffers), **kw)

    def start(self) -> RenderJob:
        self._started = time.perf_counter()
        self._job.start()
        return self

    @property
    def started(self) -> bool:
        return self._started is not None

    def progress(self) -> tuple[int, int]:
        """(pixel samples done, pixel samples planned)."""
        return self._job.progress()

    def preview_serial(self) -> int:
        """Serial of the newest preview (0: none yet); cheap, copies nothing."""
        return self._job.preview_serial()

    def preview(self) -> Preview | None:
        """The newest snapshot, or None before the first pass has ended."""
        p = self._job.preview()
        if p is None:
            return None
        p = Preview(*p)
        if p.last and self.settings.denoise:
            return p._replace(rgba=self.result().rgba)  # the final image, denoised with its aux
        if self.settings.denoise_previews and not p.last:
            from . import denoise

            return p._replace(rgba=denoise.denoise(p.rgba, quality="fast"))
        return p

    def cancel(self) -> None:
        """Asks the render to stop (returns at once; the job ends within a pass's tile row)."""
        self._job.cancel()

    def done(self) -> bool:
        """True once the started render has ended (finished, cancelled or failed)."""
        return self._job.done()

    def wait(self, timeout: float | None = None) -> bool:
        """Blocks (without the GIL) until the render ends or ``timeout`` seconds pass;
        returns whether it ended."""
        return self._job.wait(timeout)

    def result(self) -> RenderResult:
        """Waits for the end; the :class:`RenderResult` (raises the render's error)."""
        if self._error is not None:
            raise self._error
        if self._result is None:
            try:
                out = self._job.result()
            except BaseException as e:
                self._error = e
                raise
            stats = json.loads(out["stats"])
            stats["wall_seconds"] = time.perf_counter() - (self._started or time.perf_counter())
            warn_left_out(stats)
            self._result = RenderResult(
                rgba=out["rgba"],
                depth=out["depth"],
                normal=out["normal"],
                albedo=out["albedo"],
                spectral=out["spectral"],
                wavelengths=out["wavelengths"],
                stats=stats,
            )
            if self.settings.denoise:
                self._result = self._result.denoised()
        return self._result

    def __enter__(self) -> RenderJob:
        if not self.started:
            self.start()
        return self

    def __exit__(self, *exc: Any) -> None:
        self.cancel()
        self.wait()


def render_with_previews(
    scene: Scene,
    settings: RenderSettings | None = None,
    *,
    preview: Callable[[Preview], Any],
    progress: Callable[[int, int], Any] | None = None,
    interval: float = 0.05,
    **overrides: Any,
) -> RenderResult:
    """:func:`polychrome.render` with ``preview(Preview)`` called on this thread for every
    new snapshot (the last one is the final image). ``preview`` or ``progress`` returning
    False cancels; Ctrl-C cancels and raises KeyboardInterrupt."""
    job = RenderJob(scene, settings, **overrides).start()
    seen = 0
    try:
        while True:
            ended = job.wait(interval)
            if progress is not None and progress(*job.progress()) is False:
                job.cancel()
            serial = job.preview_serial()
            if serial != seen:
                p = job.preview()
                if p is not None:
                    seen = p.serial
                    if preview(p) is False:
                        job.cancel()
            if ended and seen == job.preview_serial():
                break
    except BaseException:
        job.cancel()
        job.wait()
        raise
    return job.result()
