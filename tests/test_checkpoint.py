"""Checkpoint and resume on one machine (docs/distributed.md): a render with a checkpoint
runs in tasks of sample passes on a thread here, saving the finished passes; an
interrupted render (cancelled, Ctrl-C on the CLI, the process SIGKILLed) resumed from
its checkpoint equals the uninterrupted render of the core's own pass loop. The
reference is `_core.render` (no tasks, no checkpoint). The local task loop adds the same
per-pass sums in the same order as the pass loop, so the images are compared bit for
bit; the Dask variants are in test_distributed.py."""

from __future__ import annotations

import re
import signal
import subprocess
import sys
import threading
import time
import warnings

import numpy as np
import pytest

import polychrome as pc
from polychrome import checkpoint as ck

from test_distributed import SETTINGS, box_scene

pytestmark = pytest.mark.timeout(300)


@pytest.fixture(autouse=True)
def write_every_task(monkeypatch):
    monkeypatch.setattr(ck, "INTERVAL", 0.0)


def cancel_after(n: int):
    calls = []

    def progress(done, total):
        calls.append(done)
        return len(calls) < n

    return progress, calls


def assert_identical(a: pc.RenderResult, b: pc.RenderResult) -> None:
    assert float(a.rgba[..., :3].max()) > 0.01, "a black image proves nothing"
    np.testing.assert_array_equal(a.rgba, b.rgba)
    np.testing.assert_array_equal(a.albedo, b.albedo)
    np.testing.assert_array_equal(a.normal, b.normal)
    assert a.stats["total_samples"] == b.stats["total_samples"]
    assert a.stats["samples_per_pixel"] == b.stats["samples_per_pixel"]


def test_a_checkpointed_render_equals_the_pass_loop(tmp_path):
    scene = box_scene()
    reference = pc.render(scene, **SETTINGS)
    path = tmp_path / "box.npz"
    result = pc.render(scene, checkpoint=str(path), **SETTINGS)
    assert_identical(result, reference)
    assert result.stats["tasks"] > 1 and result.stats["checkpoint"] == {"file": str(path), "resumed_samples": 0}
    assert path.exists()  # the complete render's checkpoint: resuming it renders nothing more
    again = pc.render(scene, checkpoint=str(path), resume=True, **SETTINGS)
    assert again.stats["tasks"] == 0
    assert_identical(again, reference)
    # A different seed is a different image (the comparisons can fail).
    assert float(np.abs(pc.render(scene, **{**SETTINGS, "seed": 8}).rgba - reference.rgba).max()) > 1e-3


@pytest.mark.parametrize("adaptive", [False, True])
def test_a_cancelled_render_resumed_equals_the_uninterrupted_one(tmp_path, adaptive):
    scene = box_scene()
    settings = {**SETTINGS, "samples": 64, "noise_threshold": 3.0} if adaptive else SETTINGS
    reference = pc.render(scene, **settings)
    if adaptive:
        assert 0 < reference.stats["converged_pixels"] < 24 * 18
    path = tmp_path / "box.npz"
    progress, calls = cancel_after(5)
    partial = pc.render(scene, checkpoint=str(path), progress=progress, **settings)
    assert partial.stats["partial"] is True
    assert 0 < partial.stats["samples_per_pixel"] < settings["samples"]
    resumed = pc.render(scene, checkpoint=str(path), resume=True, **settings)
    assert resumed.stats["partial"] is False
    assert resumed.stats["checkpoint"]["resumed_samples"] == calls[-1] > 0
    assert_identical(resumed, reference)
    if adaptive:
        assert resumed.stats["converged_pixels"] == reference.stats["converged_pixels"]


def test_resume_of_other_settings_is_refused_naming_the_file(tmp_path):
    scene = box_scene()
    path = tmp_path / "box.npz"
    progress, _ = cancel_after(2)
    pc.render(scene, checkpoint=str(path), progress=progress, **SETTINGS)
    with pytest.raises(ValueError, match=re.escape(str(path)) + ".*another scene or other settings"):
        pc.render(scene, checkpoint=str(path), resume=True, **{**SETTINGS, "samples": 32})
    # Settings that do not change pixels keep it valid.
    r = pc.render(scene, checkpoint=str(path), resume=True, **{**SETTINGS, "threads": 2, "time_limit": 100.0})
    assert r.stats["checkpoint"]["resumed_samples"] > 0
    (tmp_path / "junk.npz").write_bytes(b"not a checkpoint")
    with pytest.raises(ValueError, match="junk.npz: not a Polychrome checkpoint"):
        pc.render(scene, checkpoint=str(tmp_path / "junk.npz"), resume=True, **SETTINGS)
    with pytest.raises(ValueError, match="resume: needs a checkpoint file"):
        pc.render(scene, resume=True, **SETTINGS)


def test_resume_without_a_checkpoint_file_renders_from_the_start(tmp_path):
    scene = box_scene()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        r = pc.render(scene, checkpoint=str(tmp_path / "none.npz"), resume=True, **SETTINGS)
    assert any("none.npz: no such file" in str(w.message) for w in caught)
    assert_identical(r, pc.render(scene, **SETTINGS))


KILLED_RENDER = """
import sys, threading
sys.path.insert(0, {tests!r})
import polychrome as pc
from polychrome import checkpoint
from test_distributed import SETTINGS, box_scene
checkpoint.INTERVAL = 0.0
pc.render(box_scene(), checkpoint={path!r}, **{{**SETTINGS, "samples": 4000}})
"""


def test_a_killed_process_resumes_from_its_last_checkpoint(tmp_path):
    """SIGKILL (no chance to write anything more) once checkpoints are being written: the
    file is whole (written atomically) and resuming from it gives the complete image."""
    path = tmp_path / "box.npz"
    code = KILLED_RENDER.format(tests=str(__import__("pathlib").Path(__file__).parent), path=str(path))
    proc = subprocess.Popen([sys.executable, "-c", code], stderr=subprocess.PIPE)
    try:
        deadline = time.monotonic() + 120
        while not path.exists():
            assert proc.poll() is None, proc.stderr.read().decode()
            assert time.monotonic() < deadline, "no checkpoint written"
            time.sleep(0.05)
        time.sleep(0.5)  # a few more pieces (and checkpoint rewrites)
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    settings = {**SETTINGS, "samples": 4000}
    resumed = pc.render(box_scene(), checkpoint=str(path), resume=True, **settings)
    done = resumed.stats["checkpoint"]["resumed_samples"]
    assert 0 < done < 4000 * 24 * 18, "the kill came too late to test anything"
    # A kill mid-write may leave a temporary file (never a torn checkpoint); the next write removes it.
    assert not list(tmp_path.glob(".*.tmp")), "a temporary checkpoint was left behind"
    assert_identical(resumed, pc.render(box_scene(), **settings))


def test_render_job_with_a_checkpoint_previews_cancels_and_resumes(tmp_path):
    scene = box_scene()
    settings = {**SETTINGS, "samples": 400}
    path = tmp_path / "job.npz"
    job = pc.RenderJob(scene, checkpoint=str(path), **settings).start()
    deadline = time.monotonic() + 60
    while job.preview_serial() < 2 and time.monotonic() < deadline:
        job.wait(0.01)
    first = job.preview()
    assert first is not None and not first.last and 0 < first.samples < 400
    job.cancel()
    job.wait()
    partial = job.result()
    assert partial.stats["partial"] is True and path.exists()
    job = pc.RenderJob(scene, checkpoint=str(path), resume=True, **settings).start()
    result = job.result()
    assert job.preview().last and np.array_equal(job.preview().rgba, result.rgba)
    assert result.stats["checkpoint"]["resumed_samples"] > 0
    assert_identical(result, pc.render(scene, **settings))


def test_ctrl_c_on_the_cli_then_resume_gives_the_uninterrupted_image(tmp_path):
    """`polychrome render --resume`: SIGINT once a piece is in writes the partial image and
    keeps OUTPUT.checkpoint.npz; the same command again continues, writes the image of an
    uninterrupted render and removes the checkpoint."""
    from polychrome import imageio, usd

    stage = tmp_path / "box.usda"
    usd.write_stage(box_scene(), stage, pc.RenderSettings(width=24, height=18))
    out = tmp_path / "out.exr"
    flags = ["--samples", "2000", "--quality", "FINAL", "--wavelengths", "8", "--threads", "1", "--seed", "3"]
    # checkpoint.INTERVAL 0: written after every piece, so the test need not wait 10 s.
    launch = "import sys; from polychrome import checkpoint, cli; checkpoint.INTERVAL = 0.0; sys.exit(cli.main(sys.argv[1:]))"
    cmd = [sys.executable, "-c", launch, "render", str(stage), "-o", str(out), "--resume", *flags]
    proc = subprocess.Popen(cmd, stderr=subprocess.PIPE, stdout=subprocess.PIPE)
    seen = bytearray()
    started = threading.Event()

    def watch():
        while chunk := proc.stderr.read1(256):
            seen.extend(chunk)
            if re.search(rb"\s[1-9]\d?%\|", seen):  # the bar moved: a piece finished
                started.set()

    reader = threading.Thread(target=watch, daemon=True)
    reader.start()
    try:
        assert started.wait(120), seen.decode(errors="replace")[-2000:]
        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=60) == 130, seen.decode(errors="replace")[-2000:]
    finally:
        if proc.poll() is None:
            proc.kill()
    reader.join(10)
    checkpoint_file = tmp_path / "out.exr.checkpoint.npz"
    assert checkpoint_file.exists()
    assert imageio.read_metadata(out)["polychrome:partial"] == "1"
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=240)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "resumed from" in done.stdout
    assert not checkpoint_file.exists()
    assert imageio.read_metadata(out)["polychrome:partial"] == "0"
    reference = tmp_path / "reference.exr"
    plain = [sys.executable, "-m", "polychrome.cli", "render", str(stage), "-o", str(reference), "--quiet", *flags]
    subprocess.run(plain, check=True, capture_output=True, timeout=240)
    np.testing.assert_array_equal(imageio.read_image(out), imageio.read_image(reference))


def test_frames_resume_skips_the_frames_written_whole(tmp_path, capsys):
    """`--frames 1-3 --resume` after frame 1 was written whole and frame 2 only partially
    (marked partial in its metadata): frames 2 and 3 are rendered, frame 1 is left as is."""
    import os

    from polychrome import cli, imageio

    from test_distributed import animated_stage

    stage = tmp_path / "anim.usda"
    animated_stage(stage)
    flags = ["--samples", "4", "--quality", "FINAL", "--wavelengths", "8", "--seed", "3", "--threads", "1", "--quiet"]
    out = tmp_path / "shot_#.exr"
    assert cli.main(["render", str(stage), "-o", str(out), "--frames", "1-2", *flags]) == 0
    partial = imageio.read_image(tmp_path / "shot_2.exr")
    imageio.write_exr(tmp_path / "shot_2.exr", partial, metadata={"polychrome:partial": "1"})
    os.utime(tmp_path / "shot_1.exr", (1_000_000, 1_000_000))
    capsys.readouterr()
    assert cli.main(["render", str(stage), "-o", str(out), "--frames", "1-3", "--resume", *flags]) == 0
    printed = capsys.readouterr().out
    assert "rendered 2 frame(s)" in printed and "shot_1.exr" not in printed, printed
    assert os.stat(tmp_path / "shot_1.exr").st_mtime == 1_000_000
    assert all(imageio.read_metadata(tmp_path / f"shot_{f}.exr")["polychrome:partial"] == "0" for f in (1, 2, 3))
    assert cli.main(["render", str(stage), "-o", str(out), "--frames", "1-3", "--resume", *flags]) == 0
    assert "every frame is written already" in capsys.readouterr().out


def test_cancel_ends_a_running_piece_at_once():
    """PassRenderer.cancel() (what a cancelled checkpointed RenderJob or Ctrl-C calls)
    ends a running render_passes within a tile row: it returns None long before the range
    would have finished."""
    from polychrome import _core
    from polychrome.render import RenderSettings, description_json

    desc, buffers = box_scene().description()
    r = _core.PassRenderer(description_json(desc), buffers, RenderSettings(**{**SETTINGS, "samples": 4000}).to_json())
    t = time.perf_counter()
    assert r.render_passes(0, 20) is not None
    per_pass = (time.perf_counter() - t) / 20
    out = {}
    worker = threading.Thread(target=lambda: out.update(sums=r.render_passes(20, 4000)))
    t = time.perf_counter()
    worker.start()
    time.sleep(0.1)
    r.cancel()
    worker.join(60)
    took = time.perf_counter() - t
    assert not worker.is_alive() and out["sums"] is None
    assert took < 0.25 * 3980 * per_pass, (took, 3980 * per_pass)
    assert r.render_passes(0, 1) is None  # a cancelled renderer renders nothing more
