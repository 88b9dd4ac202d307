"""Distributed rendering on a real Dask cluster: a `dask scheduler` and two `dask worker`
processes on 127.0.0.1 (free ports), started and killed by the tests themselves. The
reference is the local render of the same scene, seed and settings: the distributed one
must equal it to float rounding (the per-sample random streams do not depend on how
passes are split), also with adaptive sampling, and also when a worker is SIGKILLed
mid-render (Dask reschedules its tasks)."""

from __future__ import annotations

import contextlib
import os
import signal
import socket
import subprocess
import sys
import threading

import numpy as np
import pytest

import polychrome as pc

distributed = pytest.importorskip("distributed")

pytestmark = pytest.mark.timeout(300)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _stop(procs: list[subprocess.Popen]) -> None:
    for p in procs:
        if p.poll() is None:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(p.pid, signal.SIGKILL)
    for p in procs:
        with contextlib.suppress(subprocess.TimeoutExpired):
            p.wait(timeout=10)


@contextlib.contextmanager
def dask_cluster(workers: int = 2):
    """(address, worker processes): a scheduler and `workers` single-threaded workers
    without nannies (so a SIGKILL ends a worker for good), each in its own process group
    so that everything is killed on the way out, whatever happened."""
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    dask = [sys.executable, "-m", "dask"]
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    procs: list[subprocess.Popen] = []
    try:
        procs.append(
            subprocess.Popen(
                [*dask, "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard", "--no-show"],
                stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL,
                start_new_session=True,
                env=env,
            )
        )
        worker_procs = []
        for _ in range(workers):
            p = subprocess.Popen(
                [
                    *dask,
                    "worker",
                    address,
                    "--host",
                    "127.0.0.1",
                    "--nthreads",
                    "1",
                    "--no-nanny",
                    "--no-dashboard",
                    "--memory-limit",
                    "0",
                    "--death-timeout",
                    "60",
                ],
                stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL,
                start_new_session=True,
                env=env,
            )
            procs.append(p)
            worker_procs.append(p)
        with distributed.Client(address, timeout="60s") as client:
            client.wait_for_workers(workers, timeout=120)
        yield address, worker_procs
    finally:
        _stop(procs)


@pytest.fixture(scope="module")
def cluster():
    with dask_cluster(2) as c:
        yield c


def box_scene() -> pc.Scene:
    """A closed grey box lit by a small emissive panel, with a red and a green wall."""
    scene = pc.Scene()
    grey = scene.add_material(pc.Diffuse(0.7, name="grey"))
    red = scene.add_material(pc.Diffuse(pc.spectra.rgb(0.8, 0.1, 0.1), name="red"))
    green = scene.add_material(pc.Diffuse(pc.spectra.rgb(0.1, 0.8, 0.1), name="green"))
    lamp = scene.add_material(pc.Diffuse(0.0, emission=8.0, name="lamp"))
    s = 1.0

    def quad(name, p, m):
        scene.add_mesh(name, np.array(p, np.float32), np.array([[0, 1, 2], [0, 2, 3]]), material=m)

    quad("floor", [[-s, -s, -s], [s, -s, -s], [s, s, -s], [-s, s, -s]], grey)
    quad("ceiling", [[-s, -s, s], [-s, s, s], [s, s, s], [s, -s, s]], grey)
    quad("left", [[-s, -s, -s], [-s, s, -s], [-s, s, s], [-s, -s, s]], red)
    quad("right", [[s, -s, -s], [s, -s, s], [s, s, s], [s, s, -s]], green)
    quad("back", [[-s, s, -s], [s, s, -s], [s, s, s], [-s, s, s]], grey)
    quad("front", [[-s, -s, -s], [-s, -s, s], [s, -s, s], [s, -s, -s]], grey)
    quad("lamp", [[-0.3, -0.3, 0.98], [0.3, -0.3, 0.98], [0.3, 0.3, 0.98], [-0.3, 0.3, 0.98]], lamp)
    scene.camera = pc.Camera.looking_at((0, -0.95, 0), (0, 1, 0), up=(0, 0, 1))
    return scene


SETTINGS = dict(width=24, height=18, samples=24, quality="FINAL", wavelength_count=8, max_bounces=4, seed=7, threads=1)


def assert_same_image(a: pc.RenderResult, b: pc.RenderResult) -> None:
    peak = float(np.abs(a.rgba).max())
    assert peak > 0.01, "a black image proves nothing"
    err = float(np.abs(a.rgba - b.rgba).max())
    assert err <= 1e-5 * peak, f"distributed and local images differ by {err} (peak {peak})"
    assert a.stats["total_samples"] == b.stats["total_samples"]
    assert a.stats["samples_per_pixel"] == b.stats["samples_per_pixel"]


def test_distributed_render_equals_the_local_render(cluster):
    address, _ = cluster
    scene = box_scene()
    local = pc.render(scene, **SETTINGS)
    remote = pc.render(scene, scheduler=address, **SETTINGS)
    assert_same_image(remote, local)
    d = remote.stats["distributed"]
    assert d["scheduler"] == address
    assert d["tasks"] >= 2
    # Both workers took part and every camera sample is accounted to one of them.
    assert len(d["workers"]) == 2, d
    assert sum(d["workers"].values()) == local.stats["total_samples"]
    assert remote.stats["partial"] is False and remote.stats["cancelled"] is False
    # A different seed is a different image (the comparison above can fail).
    other = pc.render(scene, **{**SETTINGS, "seed": 8})
    assert float(np.abs(other.rgba - local.rgba).max()) > 1e-3


def test_scene_is_scattered_once_and_compiled_once_per_worker(cluster):
    address, _ = cluster
    scene = box_scene()
    settings = {**SETTINGS, "seed": 11}
    with distributed.Client(address) as client:
        before = client.run(lambda: __import__("polychrome.distributed").distributed._COMPILES)
        pc.render(scene, scheduler=client, **settings)
        after = client.run(lambda: __import__("polychrome.distributed").distributed._COMPILES)
    assert set(after) == set(before) and len(after) == 2
    assert all(after[w] - before[w] <= 1 for w in after), (before, after)
    assert sum(after[w] - before[w] for w in after) >= 1


def test_adaptive_sampling_across_tasks_equals_the_local_render(cluster):
    address, _ = cluster
    scene = box_scene()
    settings = {**SETTINGS, "samples": 64, "noise_threshold": 3.0}
    local = pc.render(scene, **settings)
    converged = local.stats["converged_pixels"]
    assert 0 < converged < 24 * 18, f"the test needs pixels that stop early and pixels that do not: {converged}"
    remote = pc.render(scene, scheduler=address, **settings)
    assert_same_image(remote, local)
    assert remote.stats["converged_pixels"] == converged


def test_cancelling_returns_the_finished_passes_marked_partial(cluster):
    address, _ = cluster
    scene = box_scene()
    calls = []

    def progress(done, total):
        calls.append((done, total))
        return False  # cancel after the first task

    result = pc.render(scene, scheduler=address, progress=progress, **{**SETTINGS, "samples": 64})
    assert result.stats["partial"] is True and result.stats["cancelled"] is True
    assert 0 < result.stats["samples_per_pixel"] < 64
    assert calls and calls[0][1] == 64 * 24 * 18
    assert np.isfinite(result.rgba).all() and float(result.rgba[..., :3].max()) > 0


def test_a_worker_killed_mid_render_loses_nothing():
    scene = box_scene()
    settings = {**SETTINGS, "width": 32, "height": 24, "samples": 96}
    local = pc.render(scene, **settings)
    with dask_cluster(2) as (address, workers):
        victim = workers[1]
        first_task = threading.Event()
        out: dict = {}

        def progress(done, total):
            first_task.set()

        def run():
            try:
                out["result"] = pc.render(scene, scheduler=address, progress=progress, **settings)
            except BaseException as e:  # reported below
                out["error"] = e

        t = threading.Thread(target=run, daemon=True)
        t.start()
        assert first_task.wait(120), "no task finished"
        os.kill(victim.pid, signal.SIGKILL)
        victim.wait(timeout=10)
        t.join(240)
        assert not t.is_alive(), "the render did not finish after a worker was killed"
    assert "error" not in out, out.get("error")
    result = out["result"]
    assert victim.returncode == -signal.SIGKILL
    assert_same_image(result, local)
    assert sum(result.stats["distributed"]["workers"].values()) == local.stats["total_samples"]
    assert result.stats["partial"] is False


def animated_stage(path) -> None:
    """The box as a USD stage whose lamp grows from frame 1 to frame 3 (time-sampled points)."""
    from pxr import Usd, UsdGeom

    from polychrome import usd

    usd.write_stage(box_scene(), path, pc.RenderSettings(width=20, height=16))
    stage = Usd.Stage.Open(str(path))
    [lamp] = [UsdGeom.Mesh(p) for p in stage.Traverse() if p.IsA(UsdGeom.Mesh) and "lamp" in p.GetName()]
    points = np.array(lamp.GetPointsAttr().Get(), np.float64)
    centre = points.mean(axis=0)
    for frame, scale in ((1, 0.5), (2, 1.0), (3, 1.5)):
        lamp.GetPointsAttr().Set([tuple(centre + (p - centre) * scale) for p in points], Usd.TimeCode(frame))
    stage.GetRootLayer().Save()


@pytest.mark.parametrize("on_cluster", [False, True])
def test_frames_are_rendered_and_written_with_blender_numbering(tmp_path, cluster, on_cluster, capsys):
    from polychrome import cli, imageio, usd

    stage = tmp_path / "anim.usda"
    animated_stage(stage)
    flags = ["--samples", "8", "--quality", "FINAL", "--wavelengths", "8", "--seed", "3", "--threads", "1", "--quiet"]
    if on_cluster:
        flags += ["--scheduler", cluster[0]]
    out = tmp_path / "frames" / "shot_###.exr"
    assert cli.main(["render", str(stage), "-o", str(out), "--frames", "1-3", "--frame-step", "2", *flags]) == 0
    written = sorted(p.name for p in (tmp_path / "frames").iterdir())
    assert written == ["shot_001.exr", "shot_003.exr"], written
    settings = pc.RenderSettings(width=20, height=16, samples=8, quality="FINAL", wavelength_count=8, seed=3, threads=1)
    means = []
    for frame in (1, 3):
        expected = pc.render(usd.read_stage(stage, resolution=(20, 16), time=frame), settings)
        got = imageio.read_image(tmp_path / "frames" / f"shot_{frame:03d}.exr")
        assert np.abs(got - expected.rgba).max() <= 1e-5 * np.abs(expected.rgba).max(), frame
        assert imageio.read_metadata(tmp_path / "frames" / f"shot_{frame:03d}.exr")["polychrome:partial"] == "0"
        means.append(float(got[..., :3].mean()))
    assert means[1] > 1.5 * means[0], "the lamp grows: a later frame is brighter"


def test_frame_paths_follow_blender():
    from polychrome.distributed import frame_path, parse_frames

    assert frame_path("/r/shot_####.exr", 42) == "/r/shot_0042.exr"
    assert frame_path("/r/a#b_##.png", 7) == "/r/a#b_07.png"  # the last run of '#'
    assert frame_path("/r/out.png", 42) == "/r/out0042.png"
    assert frame_path("/r/shot_#.exr", 1234) == "/r/shot_1234.exr"  # wider numbers are not cut
    assert parse_frames("1-7", 3) == [1, 4, 7]
    assert parse_frames("5") == [5]
    for bad in ("x", "9-3"):
        with pytest.raises(ValueError, match="--frames"):
            parse_frames(bad)


def test_ctrl_c_on_the_cli_writes_the_finished_part_marked_partial(tmp_path, cluster):
    """SIGINT to `polychrome render --scheduler` once the first task is in: exit status 130,
    the finished passes written, marked partial in the file's metadata."""
    import re

    from polychrome import imageio, usd

    stage = tmp_path / "box.usda"
    usd.write_stage(box_scene(), stage, pc.RenderSettings(width=24, height=18))
    out = tmp_path / "out.exr"
    flags = ["--samples", "1024", "--quality", "FINAL", "--wavelengths", "8", "--threads", "1"]
    cmd = [sys.executable, "-m", "polychrome.cli", "render", str(stage), "-o", str(out), "--scheduler", cluster[0], *flags]
    proc = subprocess.Popen(cmd, stderr=subprocess.PIPE, stdout=subprocess.PIPE, start_new_session=True)
    seen = bytearray()
    started = threading.Event()

    def watch():
        while chunk := proc.stderr.read1(256):
            seen.extend(chunk)
            if re.search(rb"\s[1-9]\d?%\|", seen):  # the bar moved: a task finished
                started.set()

    reader = threading.Thread(target=watch, daemon=True)
    reader.start()
    try:
        assert started.wait(120), seen.decode(errors="replace")[-2000:]
        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=60) == 130, seen.decode(errors="replace")[-2000:]
    finally:
        _stop([proc])
    reader.join(10)
    assert b"marked partial" in seen, seen.decode(errors="replace")[-2000:]
    meta = imageio.read_metadata(out)
    assert meta["polychrome:partial"] == "1"
    assert 0 < int(meta["polychrome:samples"]) < 1024
    assert float(imageio.read_image(out)[..., :3].mean()) > 0


def test_a_cancelled_distributed_render_resumes_on_the_cluster_or_here(tmp_path, cluster, monkeypatch):
    """The checkpoint of a cancelled cluster render holds the finished tasks' passes;
    resumed on the cluster, or on this machine without Dask, it gives the local image."""
    from polychrome import checkpoint

    monkeypatch.setattr(checkpoint, "INTERVAL", 0.0)
    address, _ = cluster
    scene = box_scene()
    settings = {**SETTINGS, "samples": 64}
    local = pc.render(scene, **settings)
    for where in (address, ""):
        path = tmp_path / f"box{bool(where)}.npz"
        partial = pc.render(scene, scheduler=address, checkpoint=str(path), progress=lambda done, total: False, **settings)
        assert partial.stats["partial"] is True and 0 < partial.stats["samples_per_pixel"] < 64
        resumed = pc.render(scene, scheduler=where, checkpoint=str(path), resume=True, **settings)
        assert resumed.stats["partial"] is False
        assert resumed.stats["checkpoint"]["resumed_samples"] == partial.stats["samples_per_pixel"] * 24 * 18
        assert_same_image(resumed, local)


def render_tiled(scene, address, settings, tile, **kw):
    from polychrome import distributed as pd

    desc, buffers = scene.description()
    return pd.render(desc, buffers, pc.RenderSettings(**settings), address, tile=tile, **kw)


@pytest.mark.parametrize("adaptive", [False, True])
def test_image_tiles_merge_exactly(cluster, adaptive):
    """Tasks of tile × pass range (tiles of 16 pixels on a 40×28 image: 3 × 2 tiles, the
    last row and column cut short) add up to the local image."""
    address, _ = cluster
    scene = box_scene()
    settings = {**SETTINGS, "width": 40, "height": 28}
    if adaptive:
        settings.update(samples=64, noise_threshold=3.0)
    local = pc.render(scene, **settings)
    tiled = render_tiled(scene, address, settings, 16)
    assert_same_image(tiled, local)
    assert tiled.stats["distributed"]["tasks"] >= 6
    assert sum(tiled.stats["distributed"]["workers"].values()) == local.stats["total_samples"]
    if adaptive:
        assert 0 < local.stats["converged_pixels"] == tiled.stats["converged_pixels"]


def test_a_tiled_render_with_a_region_resumes_from_its_checkpoint(tmp_path, cluster, monkeypatch):
    """A render region (Blender's border) on the cluster, in tiles some of which lie
    outside it, cancelled and resumed: the local image of that region, black and
    transparent outside."""
    from polychrome import checkpoint

    monkeypatch.setattr(checkpoint, "INTERVAL", 0.0)
    address, _ = cluster
    scene = box_scene()
    settings = {**SETTINGS, "width": 40, "height": 28, "samples": 48, "region": [5.0, 3.0, 22.0, 15.0]}
    local = pc.render(scene, **settings)
    assert float(np.abs(local.rgba[20:, 30:]).max()) == 0.0 and float(local.rgba[5:14, 6:20, 3].min()) == 1.0
    assert_same_image(pc.render(scene, scheduler=address, **settings), local)
    path = tmp_path / "region.npz"
    ck_settings = {**settings, "checkpoint": str(path)}
    partial = render_tiled(scene, address, ck_settings, 8, progress=lambda done, total: False)
    assert partial.stats["partial"] is True
    # The checkpoint's tiles are kept on resume (asked for none here).
    resumed = render_tiled(scene, address, {**ck_settings, "resume": True}, 0)
    assert resumed.stats["checkpoint"]["resumed_samples"] > 0
    assert_same_image(resumed, local)


def test_tiles_with_light_paths_are_refused():
    scene = box_scene()
    with distributed.Client(processes=False, n_workers=1, threads_per_worker=1, dashboard_address=":0") as client:
        with pytest.raises(ValueError, match="light paths.*cannot be cut into image tiles"):
            render_tiled(scene, client, {**SETTINGS, "direction": "BIDIRECTIONAL"}, 8)
