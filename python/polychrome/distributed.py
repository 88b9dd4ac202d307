"""Distributed rendering on Dask.distributed (docs/distributed.md).

The scene is described once on the client (Python API, USD or .blend) and its
description and buffers are scattered once to the workers, which compile it once each
and keep it for the render's tasks. A task renders a range of sample passes and returns
per-pixel sums (weighted sums and sample counts); the client adds them up. Every pixel
sample draws from its own random stream seeded by (seed, pixel, pass), so the image
equals the local render with the same seed and settings to float rounding, however the
passes are split or which worker renders them. With adaptive sampling the tasks keep
the local pass loop's groups (see rust/core/src/render/tasks.rs), so it is exact too.

A worker that dies loses only its running tasks: Dask reschedules them on the others.
Ctrl-C on the client cancels the tasks and returns what finished, marked partial
(:class:`RenderInterrupted`). Workers need only ``pip install polychrome[distributed]``.
"""

from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass, replace
import json
import threading
import time
import uuid
from typing import Any

import numpy as np

from . import _core, tasks
from .checkpoint import content_hash
from .tasks import RenderInterrupted

__all__ = ["RenderInterrupted", "render", "render_frames", "frame_path", "parse_frames"]


@dataclass(frozen=True)
class SceneInputs:
    """What a worker needs to render: scattered once per render, compiled once per worker."""

    token: str
    scene_json: str
    buffers: tuple[np.ndarray, ...]
    settings_json: str


# Compiled scenes of this process (a worker's), newest last; a few are kept so the
# frames of an animation or consecutive renders do not recompile.
_CACHE: OrderedDict[str, Any] = OrderedDict()
_CACHE_SIZE = 2
_CACHE_LOCK = threading.Lock()
#: Scenes this process compiled (the tests check a worker compiles a scene once).
_COMPILES = 0


def _renderer(inputs: SceneInputs):
    global _COMPILES
    with _CACHE_LOCK:  # one compile per scene even when a worker runs tasks in parallel
        r = _CACHE.get(inputs.token)
        if r is None:
            _COMPILES += 1
            r = _core.PassRenderer(inputs.scene_json, list(inputs.buffers), inputs.settings_json)
            _CACHE[inputs.token] = r
            while len(_CACHE) > _CACHE_SIZE:
                _CACHE.popitem(last=False)
        _CACHE.move_to_end(inputs.token)
        return r


def _worker_name() -> str:
    try:
        from distributed import get_worker

        return get_worker().address
    except (ImportError, ValueError):  # not on a worker (e.g. a synchronous test)
        return "local"


def render_passes_task(inputs: SceneInputs, start: int, end: int, active: np.ndarray | None, rect=None) -> tuple[dict, str]:
    """A task: the sums of sample passes ``start..end`` (of the pixels of ``rect``, all
    when None) and the worker's address."""
    return _renderer(inputs).render_passes(start, end, active, rect), _worker_name()


def connect(scheduler):
    """(client, owned): a ``distributed.Client`` as given, or one connected to an address
    (closed by the caller when ``owned``)."""
    try:
        import distributed
    except ImportError:
        raise ValueError("rendering on a scheduler needs Dask: pip install 'polychrome[distributed]'") from None
    if isinstance(scheduler, distributed.Client):
        return scheduler, False
    if not isinstance(scheduler, str) or not scheduler:
        raise ValueError(f"scheduler: expected an address such as tcp://host:8786 or a distributed.Client, got {scheduler!r}")
    try:
        return distributed.Client(scheduler, timeout="20s"), True
    except OSError as e:
        raise ValueError(f"scheduler {scheduler}: cannot connect ({e})") from None


class DaskExecutor:
    """Tasks on the workers of a ``distributed.Client`` (for :func:`polychrome.tasks.run`)."""

    local = False

    def __init__(self, client, inputs):
        self.client = client
        self.inputs = inputs
        self.workers = max(1, len(client.nthreads()))
        self.run = uuid.uuid4().hex[:8]

    def scatter(self, active):
        return self.client.scatter(active, hash=False)

    def submit(self, start: int, end: int, active, rect):
        where = "" if rect is None else "-" + "-".join(map(str, rect))
        key = f"polychrome-passes-{self.run}-{start}-{end}{where}"
        return self.client.submit(render_passes_task, self.inputs, start, end, active, rect, key=key, pure=False)

    def as_completed(self, futures):
        from distributed import as_completed

        return as_completed(futures)

    def cancel(self, futures) -> None:
        if futures:
            self.client.cancel(list(futures))


def render(
    desc: dict[str, Any],
    buffers: list[np.ndarray],
    settings,
    scheduler,
    *,
    progress=None,
    tasks_per_worker: int = 4,
    tile: int | None = None,
):
    """Renders a scene description on a Dask cluster; a :class:`~polychrome.RenderResult`
    as :func:`polychrome.render` returns for the same settings, with
    ``stats["distributed"]`` (scheduler, tasks, pixel samples per worker).

    ``scheduler``: an address or a ``distributed.Client``. ``progress``: a callable
    ``f(done, total)`` (pixel samples) called as tasks finish; returning False cancels.
    ``tile``: image tiles of that many pixels a side (0: none; None: tiles of 512 for
    images above a megapixel). With the ``checkpoint`` setting the finished passes are
    saved there (``resume`` continues from it). Ctrl-C raises :class:`RenderInterrupted`
    holding the finished part.
    """
    from . import checkpoint
    from .render import description_json

    client, owned = connect(scheduler)
    try:
        local = replace(settings, scheduler="")  # the workers render; they need no address
        scene_json = description_json(desc)
        settings_json = local.to_json()
        merge = _core.PassRenderer(scene_json, buffers, settings_json)  # the client's image; checks the scene
        token = content_hash(scene_json, buffers, settings_json)
        inputs = client.scatter(
            SceneInputs(token, scene_json, tuple(np.ascontiguousarray(b) for b in buffers), settings_json), broadcast=True, hash=False
        )
        executor = DaskExecutor(client, inputs)
        tok = checkpoint.token(scene_json, buffers, settings)

        def annotate(result):
            stats = result.stats
            stats["distributed"] = {"scheduler": client.scheduler.address, "tasks": stats.pop("tasks"), "workers": stats.pop("workers")}
            return result

        try:
            result = tasks.run(merge, executor, settings, tok, progress=progress, tile=tile, tasks_per_worker=tasks_per_worker)
        except RenderInterrupted as e:
            raise RenderInterrupted(annotate(e.result)) from None
        return annotate(result)
    finally:
        if owned:
            client.close()


def render_frame_task(inputs: SceneInputs) -> tuple[dict, str]:
    """A task: one whole frame rendered on the worker (as a local render), and the
    worker's address."""
    return _core.render(inputs.scene_json, list(inputs.buffers), inputs.settings_json), _worker_name()


def _result_from(out: dict, wall: float):
    from .render import RenderResult

    stats = json.loads(out["stats"])
    stats["wall_seconds"] = wall
    stats["partial"] = bool(stats.get("cancelled"))
    return RenderResult(
        rgba=out["rgba"],
        depth=out["depth"],
        normal=out["normal"],
        albedo=out["albedo"],
        spectral=out["spectral"],
        wavelengths=out["wavelengths"],
        stats=stats,
    )


def render_frames(frames, describe, scheduler, *, on_frame, progress=None) -> list[int]:
    """Renders the frames of an animation as tasks, one frame each, and calls
    ``on_frame(frame, result)`` on this thread as each completes (in completion order).
    ``describe(frame)`` gives ``(desc, buffers, settings)`` for a frame (read on the
    client). Frames are submitted as they are described, so workers start at once.
    ``progress(done, total)`` counts frames. Returns the frames written; Ctrl-C cancels
    the rest and raises KeyboardInterrupt after the finished frames were handed over."""
    from distributed import as_completed

    from .render import description_json

    frames = list(frames)
    client, owned = connect(scheduler)
    futures: dict = {}
    written: list[int] = []
    run = uuid.uuid4().hex[:8]
    try:
        start = time.perf_counter()
        ac = as_completed()
        for frame in frames:
            desc, buffers, settings = describe(frame)
            scene_json = description_json(desc)
            settings_json = replace(settings, scheduler="").to_json()
            inputs = SceneInputs(
                content_hash(scene_json, buffers, settings_json), scene_json, tuple(np.ascontiguousarray(b) for b in buffers), settings_json
            )
            [scattered] = client.scatter([inputs], hash=False)
            f = client.submit(render_frame_task, scattered, key=f"polychrome-frame-{run}-{frame}", pure=False)
            futures[f] = frame
            ac.add(f)
        for f in ac:
            out, worker = f.result()
            frame = futures.pop(f)
            result = _result_from(out, time.perf_counter() - start)
            result.stats["distributed"] = {
                "scheduler": client.scheduler.address,
                "tasks": 1,
                "workers": {worker: result.stats["total_samples"]},
            }
            result.stats["frame"] = frame
            on_frame(frame, result)
            written.append(frame)
            f.release()
            if progress is not None and progress(len(written), len(frames)) is False:
                break
        return written
    finally:
        if futures:
            client.cancel(list(futures))
        if owned:
            client.close()


def frame_path(pattern: str, frame: int) -> str:
    """The output file of ``frame`` as Blender names it: the last run of ``#`` in the file
    name is replaced by the frame number zero-padded to its length; without ``#`` four
    digits are appended to the name before the extension (``out.png`` → ``out0001.png``)."""
    import os
    import re

    head, tail = os.path.split(pattern)
    runs = list(re.finditer(r"#+", tail))
    if runs:
        m = runs[-1]
        tail = f"{tail[: m.start()]}{frame:0{len(m.group())}d}{tail[m.end() :]}"
    else:
        stem, ext = os.path.splitext(tail)
        tail = f"{stem}{frame:04d}{ext}"
    return os.path.join(head, tail)


def parse_frames(text: str, step: int = 1) -> list[int]:
    """``"1-250"`` or ``"7"`` (and a step) as the list of frames; ValueError naming the problem."""
    text = str(text).strip()
    try:
        if "-" in text[1:]:
            i = text.index("-", 1)
            a, b = int(text[:i]), int(text[i + 1 :])
        else:
            a = b = int(text)
    except ValueError:
        raise ValueError(f"--frames: expected a frame or a range such as 1-250, got '{text}'") from None
    if b < a:
        raise ValueError(f"--frames: the range {a}-{b} ends before it starts")
    if step < 1:
        raise ValueError(f"--frame-step: must be at least 1, got {step}")
    return list(range(a, b + 1, step))
