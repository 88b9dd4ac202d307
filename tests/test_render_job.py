"""polychrome.RenderJob: background renders with progressive previews (the core publishes
a snapshot after the first pass, then at most every 100 ms, and the final image last),
cancellation from another thread, errors, and no deadlocks (every wait has a timeout)."""

import math
import threading
import time

import numpy as np
import pytest

import polychrome as pc
from polychrome.job import render_with_previews
from conftest import luminance
from test_render_api import furnace_scene

EMISSION, ALBEDO = 0.25, 0.5
EXPECTED = EMISSION / (1 - ALBEDO)  # furnace closed form L / (1 - a)


def assert_furnace(rgba, what):
    y = luminance(rgba)
    se = y.std(ddof=1) / math.sqrt(y.size)
    assert abs(y.mean() - EXPECTED) < 5 * se + 2e-3, (what, y.mean(), EXPECTED, se)
    return se


def collect_previews(job, timeout=120.0):
    """Polls the job until it ends; every distinct preview in order."""
    seen = []
    deadline = time.monotonic() + timeout
    while True:
        ended = job.wait(0.002)
        p = job.preview()
        if p is not None and (not seen or seen[-1].serial != p.serial):
            seen.append(p)
        if ended and seen and seen[-1].last:
            return seen
        assert time.monotonic() < deadline, "the job did not end in time"


def test_previews_arrive_converge_and_the_last_equals_the_result():
    job = pc.RenderJob(furnace_scene(EMISSION, ALBEDO), width=24, height=24, samples=300, max_bounces=100, threads=2)
    assert job.preview() is None and job.preview_serial() == 0
    job.start()
    seen = collect_previews(job)
    result = job.result()
    assert any(not p.last for p in seen), "no preview before the end"
    serials = [p.serial for p in seen]
    assert serials == sorted(set(serials)) and serials[0] >= 1
    assert all(a.samples <= b.samples for a, b in zip(seen, seen[1:]))
    assert seen[0].samples < 300
    for p in seen:
        assert p.rgba.shape == (24, 24, 4) and p.rgba.dtype == np.float32
        assert np.isfinite(p.rgba).all()
        assert_furnace(p.rgba, f"preview at {p.samples} spp")
    last = seen[-1]
    assert last.last and last.samples == result.stats["samples_per_pixel"] == 300
    np.testing.assert_array_equal(last.rgba, result.rgba)
    assert job.done()
    assert job.result() is result  # cached


def test_render_with_previews_calls_back_on_this_thread():
    got = []
    me = threading.get_ident()

    def on_preview(p):
        got.append((p, threading.get_ident()))

    result = render_with_previews(furnace_scene(EMISSION, ALBEDO), preview=on_preview, width=16, height=16, samples=64, max_bounces=100)
    assert got and all(t == me for _, t in got)
    assert got[-1][0].last
    np.testing.assert_array_equal(got[-1][0].rgba, result.rgba)
    assert_furnace(result.rgba, "final")


def test_preview_callback_returning_false_cancels():
    result = render_with_previews(
        furnace_scene(EMISSION, ALBEDO), preview=lambda p: False, width=16, height=16, samples=100_000, max_bounces=100
    )
    assert result.stats["cancelled"]
    assert 1 <= result.stats["samples_per_pixel"] < 100_000


def test_cancel_from_another_thread_stops_promptly():
    job = pc.RenderJob(furnace_scene(EMISSION, ALBEDO), width=32, height=32, samples=1_000_000, max_bounces=100).start()

    def canceller():
        deadline = time.monotonic() + 60
        while job.preview_serial() == 0 and time.monotonic() < deadline:
            time.sleep(0.005)
        job.cancel()

    t = threading.Thread(target=canceller)
    t.start()
    assert job.wait(timeout=90), "the job did not stop after cancel"
    t.join(timeout=10)
    assert not t.is_alive()
    result = job.result()
    assert result.stats["cancelled"]
    assert 1 <= result.stats["samples_per_pixel"] < 1_000_000
    last = job.preview()
    assert last.last
    np.testing.assert_array_equal(last.rgba, result.rgba)
    assert_furnace(result.rgba, "cancelled")


def test_wait_times_out_without_blocking_other_threads():
    job = pc.RenderJob(furnace_scene(EMISSION, ALBEDO), width=32, height=32, samples=1_000_000, max_bounces=100).start()
    # another Python thread keeps running while this one waits (the GIL is released)
    ticks = []
    stop = threading.Event()
    t = threading.Thread(target=lambda: [ticks.append(1) or time.sleep(0.001) for _ in iter(lambda: stop.is_set(), True)])
    t.start()
    assert job.wait(timeout=0.2) is False
    stop.set()
    t.join(timeout=10)
    assert len(ticks) > 10
    assert not job.done()
    job.cancel()
    assert job.wait(timeout=60)
    assert job.result().stats["cancelled"]


def test_context_manager_cancels_and_waits():
    with pc.RenderJob(furnace_scene(EMISSION, ALBEDO), width=16, height=16, samples=1_000_000) as job:
        assert job.started
    assert job.done()
    assert job.result().stats["cancelled"]


def test_no_previews_when_not_requested():
    job = pc.RenderJob(furnace_scene(EMISSION, ALBEDO), width=8, height=8, samples=4, previews=False).start()
    assert job.wait(timeout=60)
    assert job.preview() is None
    assert_furnace(job.result().rgba, "final")


def test_errors_surface_from_result_and_misuse_is_reported():
    with pytest.raises(ValueError, match="method"):
        pc.RenderJob(furnace_scene(EMISSION, ALBEDO), method="NOPE")
    with pytest.raises(ValueError, match="setting 'samples': 0 is below the minimum 1"):
        pc.RenderJob(furnace_scene(EMISSION, ALBEDO), width=8, height=8, samples=0)  # checked when made
    scene = furnace_scene(EMISSION, ALBEDO)
    scene.camera.projection = "ORTHOGRAPHIC"  # light tracing cannot reach it: known only to the render
    job = pc.RenderJob(scene, width=8, height=8, samples=1, direction="FORWARD")
    with pytest.raises(RuntimeError, match="not started"):
        job.wait(0.1)
    job.start()
    with pytest.raises(RuntimeError, match="already started"):
        job.start()
    assert job.wait(timeout=60)
    with pytest.raises(ValueError, match="direction"):
        job.result()
    with pytest.raises(ValueError, match="direction"):
        job.result()
    assert job.preview() is None
