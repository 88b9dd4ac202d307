"""A render run as tasks: ranges of sample passes (and image tiles) rendered by an
executor — Dask workers (:mod:`polychrome.distributed`) or a thread of this process (a
local render with a checkpoint) — whose sums the client adds up in a
``_core.PassRenderer``, and optionally saves to a checkpoint file to resume from
(:mod:`polychrome.checkpoint`).

Every pixel sample draws from its own random stream seeded by (seed, pixel, pass), so
however the passes and the image are cut, and in whatever order the tasks finish, the
image equals the local render with the same seed and settings to float rounding. With
adaptive sampling the tasks keep the local pass loop's groups and halves (see
rust/core/src/render/tasks.rs).
"""

from __future__ import annotations

import concurrent.futures
import json
import math
import time
import warnings
from dataclasses import dataclass, field

import numpy as np

from . import checkpoint as ck

#: Images of more pixels than this are cut into tiles of ``TILE`` pixels a side (each
#: task then returns the sums of one tile, not of the whole image).
TILE_PIXELS = 1 << 20
TILE = 512


class RenderInterrupted(KeyboardInterrupt):
    """Ctrl-C during a render in tasks: ``result`` holds the passes that finished (its
    stats have ``partial`` true). A KeyboardInterrupt, so code that does not catch it
    stops as on any Ctrl-C."""

    def __init__(self, result):
        super().__init__("render interrupted; result holds the finished passes")
        self.result = result


class LocalExecutor:
    """Tasks rendered one after another on a thread of this process (each on every core
    of the ``threads`` setting), so that the calling thread can take Ctrl-C and write
    checkpoints between them. Pieces follow the local pass loop's groups (1, 1, 1, 1,
    2, ... up to 16 passes), so progress and checkpoints come as often as there; a
    cancel ends the running piece within a tile row."""

    workers = 1
    local = True

    def __init__(self, renderer):
        self._renderer = renderer
        self._pool = concurrent.futures.ThreadPoolExecutor(1, thread_name_prefix="polychrome-task")

    def scatter(self, active):
        return active

    def submit(self, start: int, end: int, active, rect):
        return self._pool.submit(lambda: (self._renderer.render_passes(start, end, active, rect), "local"))

    def as_completed(self, futures):
        return concurrent.futures.as_completed(futures)

    def cancel(self, futures) -> None:
        """Stops the run: the queued tasks are dropped and the running one ends within a
        tile row (its result is None)."""
        for f in futures:
            f.cancel()
        self._renderer.cancel()

    def close(self) -> None:
        self._pool.shutdown(wait=False, cancel_futures=True)


def tile_rects(width: int, height: int, tile: int) -> list:
    """The image cut into tiles (x0, y0, x1, y1) of ``tile`` pixels a side, row by row;
    ``[None]`` (the whole image) when ``tile`` is 0."""
    if tile <= 0:
        return [None]
    return [(x, y, min(x + tile, width), min(y + tile, height)) for y in range(0, height, tile) for x in range(0, width, tile)]


def subtract(r: tuple[int, int], done: list[tuple[int, int]]) -> list[tuple[int, int]]:
    """The parts of pass range ``r`` not covered by the ranges ``done``."""
    out = []
    a, b = r
    for s, e in sorted(done):
        if e <= a or s >= b:
            continue
        if s > a:
            out.append((a, s))
        a = max(a, e)
    if a < b:
        out.append((a, b))
    return out


def split(r: tuple[int, int], parts: int) -> list[tuple[int, int]]:
    """``r`` cut into at most ``parts`` contiguous non-empty ranges."""
    a, b = r
    n = b - a
    parts = max(1, min(parts, n))
    cuts = [a + (n * k) // parts for k in range(parts + 1)]
    return [(cuts[k], cuts[k + 1]) for k in range(parts) if cuts[k + 1] > cuts[k]]


def pieces(ranges: list[tuple[int, int]], parts: int, cuts: list[int] | None) -> list[tuple[int, int]]:
    """``ranges`` cut at ``cuts`` (pass numbers) when given, else into about ``parts``
    pieces in all, in proportion to their lengths."""
    if cuts is not None:
        out = []
        for a, b in ranges:
            points = [a, *(c for c in cuts if a < c < b), b]
            out += list(zip(points[:-1], points[1:]))
        return out
    total = sum(b - a for a, b in ranges)
    return [p for r in ranges for p in split(r, max(1, round(parts * (r[1] - r[0]) / max(total, 1))))]


def _area(rect, pixels: int) -> int:
    return pixels if rect is None else (rect[2] - rect[0]) * (rect[3] - rect[1])


@dataclass
class Outcome:
    """How a run ended: stats the caller adds (``per_worker`` pixel samples, ``tasks``)."""

    cancelled: bool = False
    time_limited: bool = False
    tasks: int = 0
    per_worker: dict[str, int] = field(default_factory=dict)
    resumed_samples: int = 0


def run(merge, executor, settings, tok: str, *, progress=None, tile: int | None = None, tasks_per_worker: int = 4):
    """Renders ``merge``'s scene (a ``_core.PassRenderer``) in tasks on ``executor`` and
    returns the :class:`~polychrome.RenderResult` (``stats["tasks"]``; with a checkpoint
    ``stats["checkpoint"]``). ``settings``: the render's settings (``checkpoint``,
    ``resume``); ``tok``: :func:`polychrome.checkpoint.token` of the scene and settings.
    ``progress(done, total)`` (pixel samples) after every task; False cancels. ``tile``:
    tile side in pixels (0: whole image; None: tiles only above ``TILE_PIXELS``). Ctrl-C
    raises :class:`RenderInterrupted` with the finished part."""
    start_time = time.perf_counter()
    width, height = merge.size()
    pixels = width * height
    path = settings.checkpoint or None
    if settings.resume and not path:
        raise ValueError("resume: needs a checkpoint file (the checkpoint setting; the CLI uses OUTPUT.checkpoint.npz)")
    out = Outcome()
    finished: dict[int, list[tuple[int, int]]] = {}
    saved = ck.load(path, tok) if settings.resume else None
    if settings.resume and saved is None:
        warnings.warn(f"checkpoint {path}: no such file; rendering from the start", stacklevel=3)
    if saved is not None:
        try:
            merge.restore(saved.state)
        except ValueError as e:
            raise ValueError(f"checkpoint {path}: {e}") from None
        tile, finished = saved.tile, saved.finished
    if tile is None:
        tile = TILE if pixels > TILE_PIXELS and merge.tileable() else 0
    if tile and not merge.tileable():
        raise ValueError("tile: a render with light paths (direction FORWARD or BIDIRECTIONAL) cannot be cut into image tiles")
    rects = tile_rects(width, height, tile)
    total_passes = merge.sample_passes()
    adaptive = merge.adaptive()
    # Without adaptive sampling all passes are one group: tasks of any length, in any order.
    groups = [tuple(g) for g in merge.groups()] if adaptive else [(0, total_passes)]
    cuts = sorted({g[1] for g in merge.groups()}) if getattr(executor, "local", False) else None
    total = total_passes * pixels
    done_samples = merge.passes() * pixels + sum((e - s) * _area(rects[t], pixels) for t, rs in finished.items() for s, e in rs)
    out.resumed_samples = done_samples
    limit = merge.time_limit()
    last_write = time.perf_counter()
    pending: list = []

    def save(partial: dict) -> None:
        nonlocal last_write
        if path:
            ck.save(path, tok, merge, tile, partial)
            last_write = time.perf_counter()

    def group_passes_done() -> int:  # of the group under way: what every tile has
        return min(sum(e - s for s, e in finished.get(t, [])) for t in range(len(rects)))

    try:
        for g0, g1 in groups:
            if g1 <= merge.passes():
                continue  # ended before the checkpoint
            if not merge.any_active():
                break
            if limit > 0 and merge.passes() > 0 and time.perf_counter() - start_time >= limit:
                out.time_limited = True
                break
            active = merge.active()
            handle = executor.scatter(active) if active is not None else None
            halves = merge.halves(g0, g1)
            parts = executor.workers * tasks_per_worker if not adaptive else math.ceil(executor.workers / 2)
            parts = max(1, math.ceil(parts / len(rects)))
            futures = {}
            for h, half in enumerate(halves):
                if half[1] <= half[0]:
                    continue
                for t, rect in enumerate(rects):
                    for s, e in pieces(subtract(tuple(half), finished.get(t, [])), parts, cuts):
                        futures[executor.submit(s, e, handle, rect)] = (h == 0, t, s, e)
            pending = list(futures)
            for f in executor.as_completed(pending):
                sums, worker = f.result()
                if sums is None:  # the renderer was cancelled mid-task (LocalExecutor.cancel)
                    out.cancelled = True
                    executor.cancel(pending)
                    break
                # Arrays unpickled from a worker's message may be unaligned; the core needs aligned ones.
                sums = {k: np.require(v, requirements="AC") if isinstance(v, np.ndarray) else v for k, v in sums.items()}
                first_half, t, s, e = futures[f]
                merge.add(sums, first_half, rects[t])
                pending.remove(f)
                finished.setdefault(t, []).append((s, e))
                out.per_worker[worker] = out.per_worker.get(worker, 0) + int(sums["count"].sum())
                done_samples += (e - s) * _area(rects[t], pixels)
                out.tasks += 1
                if not pending:
                    merge.end_group(g1 - g0)
                    finished = {}
                if progress is not None and progress(done_samples, total) is False:
                    out.cancelled = True
                if limit > 0 and time.perf_counter() - start_time >= limit and pending:
                    out.time_limited = True
                if out.cancelled or out.time_limited:
                    executor.cancel(pending)
                    break
                if path and pending and time.perf_counter() - last_write >= ck.INTERVAL:
                    save(finished)
            if out.cancelled or out.time_limited:
                break
        save(finished)
        if finished:  # what finished of the interrupted group counts
            merge.end_group(group_passes_done())
    except KeyboardInterrupt:
        executor.cancel(pending)
        save(finished)
        if finished:
            merge.end_group(group_passes_done())
        out.cancelled = True
        raise RenderInterrupted(result(merge, out, start_time, settings)) from None
    except BaseException:
        executor.cancel(pending)
        raise
    return result(merge, out, start_time, settings)


def result(merge, out: Outcome, start_time: float, settings):
    """The :class:`~polychrome.RenderResult` of what ``merge`` holds."""
    from .render import RenderResult

    seconds = time.perf_counter() - start_time
    o = merge.output(out.cancelled, out.time_limited, seconds)
    stats = json.loads(o["stats"])
    stats["wall_seconds"] = seconds
    stats["partial"] = bool(out.cancelled or stats.get("cancelled"))
    stats["tasks"] = out.tasks
    stats["workers"] = dict(sorted(out.per_worker.items()))  # pixel samples each rendered
    if settings.checkpoint:
        stats["checkpoint"] = {"file": settings.checkpoint, "resumed_samples": out.resumed_samples}
    return RenderResult(
        rgba=o["rgba"],
        depth=o["depth"],
        normal=o["normal"],
        albedo=o["albedo"],
        spectral=o["spectral"],
        wavelengths=o["wavelengths"],
        stats=stats,
    )


def render_local(desc, buffers, settings, *, progress=None, tile: int | None = None):
    """A render on this machine in tasks (for a ``checkpoint``): the image of
    :func:`polychrome.render` with the same settings, to float rounding."""
    from . import _core
    from .render import description_json

    scene_json = description_json(desc)
    merge = _core.PassRenderer(scene_json, buffers, settings.to_json())
    executor = LocalExecutor(merge)
    try:
        result = run(merge, executor, settings, ck.token(scene_json, buffers, settings), progress=progress, tile=tile)
    except RenderInterrupted as e:
        e.result.stats.pop("workers")
        raise
    finally:
        executor.close()
    result.stats.pop("workers")
    return result
