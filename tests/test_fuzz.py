"""Bounded fuzzing of every input parser (issue 8): a few hundred mutated inputs per
target with a fixed seed (see tests/fuzzing.py for the engine and the long run), plus
the hand-made corner cases the fuzzer found, and the panic → RuntimeError boundary."""

import json
import struct
import zlib

import numpy as np
import pytest

import fuzzing  # tests/fuzzing.py (the mutation engine)
import polychrome as pc
from polychrome import _core, imageio, texture


@pytest.mark.timeout(300)
@pytest.mark.parametrize("target, cases", [("json", 150), ("usd", 120), ("images", 300)])
def test_mutated_inputs_raise_clear_errors_or_work(target, cases):
    if target == "usd":
        pytest.importorskip("pxr")
    totals, findings = fuzzing.run(cases, seed=8, targets=(target,))
    assert totals, "nothing ran"
    assert not findings, findings[:3]
    for tally in totals.values():
        # The mutations must reach the parsers: both outcomes occur.
        assert tally.get("rejected", 0) > 0
        assert tally.get("rendered", 0) + tally.get("read", 0) > 0


def test_hdr_header_asking_for_huge_image_is_a_value_error(tmp_path):
    p = tmp_path / "big.hdr"
    p.write_bytes(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 100000 +X 100000\n" + b"\0" * 16)
    with pytest.raises(ValueError, match="big.hdr"):
        texture.read_radiance_hdr(p)
    p.write_bytes(b"#?RADIANCE\n\n-Y 4 +X abc\n" + b"\0" * 16)
    with pytest.raises(ValueError, match="big.hdr"):
        texture.read_radiance_hdr(p)


def test_png_decompression_bomb_is_a_value_error(tmp_path):
    def chunk(t, d):
        return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xFFFFFFFF)

    data = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", 60000, 60000, 8, 2, 0, 0, 0))
    data += chunk(b"IDAT", zlib.compress(b"\0" * 100)) + chunk(b"IEND", b"")
    p = tmp_path / "bomb.png"
    p.write_bytes(data)
    with pytest.raises(ValueError, match="bomb.png"):
        imageio.read_image(p)
    with pytest.raises(ValueError, match="bomb.png"):
        pc.Texture.from_file(p)


def test_vertex_beyond_1e12_is_rejected_naming_the_mesh():
    """Found by the scene-builder proptest: coordinates near f32::MAX overflowed the BVH's
    boxes and panicked inside obvhs; now a load-time error."""
    scene = pc.Scene()
    scene.add_mesh("far away", [[0, 0, 0], [1, 0, 0], [0, 3e38, 0]], [[0, 1, 2]])
    with pytest.raises(ValueError, match="far away"):
        pc.render(scene, width=4, height=3, samples=1)
    scene = pc.Scene()
    m = np.eye(4) * 1e30
    m[3, 3] = 1
    scene.add_mesh("tri", [[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]], transform=m)
    with pytest.raises(ValueError, match="instance 'tri'"):
        pc.render(scene, width=4, height=3, samples=1)


def test_non_finite_number_anywhere_in_a_description_names_where():
    scene = pc.Scene()
    scene.add_material(pc.Emitter((1, 1, 1), strength=float("nan"), name="lamp"))
    scene.add_mesh("panel", [[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    with pytest.raises(ValueError, match="lamp") as e:
        pc.render(scene, width=4, height=3, samples=1)
    assert "not finite" in str(e.value)


def test_internal_panic_becomes_runtime_error():
    """Panics at the PyO3 boundary are caught (`guarded`): Python sees a RuntimeError and
    the process carries on rendering."""
    with pytest.raises(RuntimeError, match="internal error in _panic_for_tests.*deliberate"):
        _core._panic_for_tests("deliberate test panic")
    scene = pc.Scene()
    scene.set_world(0.5)
    r = pc.render(scene, width=4, height=3, samples=1, wavelength_count=41)
    assert np.isfinite(r.rgba).all()


def test_garbage_json_and_buffers_are_clear_errors():
    settings = json.dumps({"width": 4, "height": 3, "samples": 1})
    # ("[]" is accepted: serde reads a struct from an empty sequence as the empty scene.)
    for scene_json in ["", "{", "null", '{"meshes": 3}', '{"camera": {"to_world": "x"}}', '{"unknown": 1}']:
        with pytest.raises(ValueError):
            _core.render(scene_json, [], settings)
    with pytest.raises(TypeError, match="buffer 0"):
        _core.render(
            '{"meshes": [{"name": "m", "vertices": 0, "triangles": 1}]}', [np.zeros(3, np.int16), np.zeros(3, np.uint32)], settings
        )
    with pytest.raises(ValueError, match="'m'"):
        _core.render(
            '{"meshes": [{"name": "m", "vertices": 0, "triangles": 1}]}', [np.zeros(3, np.uint32), np.zeros(3, np.uint32)], settings
        )


def test_degenerate_meshes_render():
    """Meshes PLOC makes a chain of (10k triangles at one point, 2000 copies of one
    triangle) build and render: the point mesh overflowed the wide-BVH conversion's
    recursion (a stack overflow aborts the whole process), the copies made a tree deeper
    than the traversal's 32-entry stack. The copies cover the view: the image is lit."""
    scene = pc.Scene()
    scene.add_mesh("speck", [[0.1, 0.2, 0.3]], [[0, 0, 0]] * 10_000)
    lamp = scene.add_material(pc.Emitter((1, 1, 1), strength=2.0, name="lamp"))
    quad = [[-9, -9, -1], [9, -9, -1], [0, 9, -1]]
    scene.add_mesh("copies", quad, [[0, 1, 2]] * 2000, material=lamp)
    r = pc.render(scene, width=4, height=3, samples=1, wavelength_count=41)
    assert np.isfinite(r.rgba).all()
    assert (r.rgba[..., :3] > 0.1).all(), r.rgba[..., :3]


def test_pass_count_overflow_is_a_value_error():
    """PassRenderer.end_group past 2^32 - 1 passes: a ValueError (it was an integer
    overflow: pyo3's PanicException, a BaseException, in debug builds; a count wrapped to
    a few passes in release ones)."""
    from polychrome.render import RenderSettings, description_json

    scene = pc.Scene()
    scene.set_world(0.5)
    desc, buffers = scene.description()
    settings = RenderSettings(width=4, height=3, samples=1, wavelength_count=41)
    r = _core.PassRenderer(description_json(desc), buffers, settings.to_json())
    r.end_group(2**32 - 2)
    with pytest.raises(ValueError, match="end_group"):
        r.end_group(2)
    r.end_group(1)
    assert r.passes() == 2**32 - 1
