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
import threading
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
        if self.settings.checkpoint or self.settings.resume:
            self._job = _TaskJob(desc, buffers, self.settings, previews)
        else:
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
            if isinstance(out, RenderResult):  # a render in tasks (_TaskJob)
                warn_left_out(out.stats)
                self._result = out.denoised() if self.settings.denoise else out
                return self._result
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


class _TaskJob:
    """The core job's interface over a render in tasks on a thread of this process
    (:mod:`polychrome.tasks`), for a RenderJob with a ``checkpoint``: the passes are
    saved as they finish and ``resume`` continues from them. A cancel ends the running
    piece within a tile row (its passes are dropped); previews come between pieces."""

    def __init__(self, desc, buffers, settings: RenderSettings, previews: bool):
        from . import checkpoint

        scene_json = description_json(desc)
        self._merge = _core.PassRenderer(scene_json, buffers, settings.to_json())
        self._token = checkpoint.token(scene_json, buffers, settings)
        self._settings = settings
        self._previews = previews
        w, h = self._merge.size()
        self._progress = (0, self._merge.sample_passes() * w * h)
        self._cancelled = False
        self._ended = threading.Event()
        self._thread: threading.Thread | None = None
        self._preview: tuple | None = None
        self._serial = 0
        self._last_preview = 0.0
        self._out: RenderResult | None = None
        self._error: BaseException | None = None

    def start(self) -> None:
        if self._thread is None:
            self._thread = threading.Thread(target=self._run, name="polychrome-job", daemon=True)
            self._thread.start()

    def _run(self) -> None:
        from . import tasks

        executor = tasks.LocalExecutor(self._merge)
        try:
            self._out = tasks.run(self._merge, executor, self._settings, self._token, progress=self._on_progress)
            self._publish(self._out.rgba, self._out.stats["samples_per_pixel"], True)
        except BaseException as e:  # handed to result()
            self._error = e
        finally:
            executor.close()
            self._ended.set()

    def _on_progress(self, done: int, total: int) -> bool:
        self._progress = (done, total)
        if self._previews and time.perf_counter() - self._last_preview >= 0.1:
            w, h = self._merge.size()
            self._publish(self._merge.output(False, False, 0.0)["rgba"], done // (w * h), False)  # passes so far
        return not self._cancelled

    def _publish(self, rgba, samples: int, last: bool) -> None:
        if self._previews:
            self._serial += 1
            self._preview = (rgba, samples, self._serial, last)
            self._last_preview = time.perf_counter()

    def progress(self) -> tuple[int, int]:
        return self._progress

    def cancel(self) -> None:
        self._cancelled = True
        self._merge.cancel()  # the running piece ends within a tile row

    def done(self) -> bool:
        return self._ended.is_set()

    def preview_serial(self) -> int:
        return self._serial

    def preview(self):
        return self._preview

    def wait(self, timeout: float | None = None) -> bool:
        if self._thread is None:
            return True
        return self._ended.wait(timeout)

    def result(self) -> RenderResult:
        self.wait()
        if self._error is not None:
            raise self._error
        if self._out is None:
            raise RuntimeError("RenderJob.result(): the job was never started")
        return self._out


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
