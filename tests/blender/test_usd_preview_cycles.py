"""usd-wg/assets' TextureTransformTest (vendored in tests/data/usd, CC0): nine textured
planes whose UsdTransform2d (offset, rotation, scale, all three) and clamp/repeat wraps
show a check mark when a renderer gets the spec's order of operations right. The stage,
wrapped with an orthographic camera in front of it (and a white dome for Polychrome),
is rendered by `polychrome.usd.read_stage` + Polychrome and by Blender's own USD importer
+ Cycles CPU under a uniform white world: mean CIEDE2000 on 2 × 2 blocks ≤ 2.0 (issue
15's bar; measured 1.38 at 68 × 46, 16 / 32 samples) and no reader warning.

Blender 4.5's importer reads an orthographic camera's aperture without USD's tenths of a
unit (ortho_scale 3400 for a 340-unit view in a centimetre stage); the script sets it to
the view's width in metres.
"""

import warnings

import numpy as np
import pytest

from .bhelper import ROOT, check, run_bpy

pytestmark = pytest.mark.blender

pxr = pytest.importorskip("pxr")

ASSET = ROOT / "tests" / "data" / "usd" / "TextureTransformTest" / "TextureTransformTest.usd"
WIDTH, HEIGHT = 68, 46


def wrapper(tmp_path, dome):
    from pxr import Gf, Usd, UsdGeom, UsdLux

    path = tmp_path / ("wrap.usda" if dome else "wrap_for_blender.usda")
    stage = Usd.Stage.CreateNew(str(path))
    stage.GetRootLayer().subLayerPaths.append(str(ASSET))
    UsdGeom.SetStageUpAxis(stage, "Y")
    UsdGeom.SetStageMetersPerUnit(stage, 0.01)
    # The planes span x ±160, y ±105 (cm) facing +Z: a 340 × 230 view from +Z.
    cam = UsdGeom.Camera.Define(stage, "/WrapCam")
    cam.CreateProjectionAttr("orthographic")
    cam.CreateHorizontalApertureAttr(340 * 10.0)
    cam.CreateVerticalApertureAttr(230 * 10.0)
    cam.CreateClippingRangeAttr(Gf.Vec2f(1.0, 10000.0))
    cam.AddTranslateOp().Set(Gf.Vec3d(0, 0, 500))
    if dome:
        UsdLux.DomeLight.Define(stage, "/WrapDome").CreateIntensityAttr(1.0)
    stage.Save()
    return path


def test_texture_transform_test_matches_blender_import_and_cycles(tmp_path):
    import polychrome as pc
    from polychrome import usd

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = usd.read_stage(wrapper(tmp_path, dome=True))
    assert not caught, [str(w.message) for w in caught]
    ours = pc.render(scene, width=WIDTH, height=HEIGHT, samples=16, seed=1).rgba[..., :3]
    np.save(tmp_path / "polychrome.npy", ours)
    proc, res = run_bpy(
        tmp_path,
        f"""
    sc = empty_scene({WIDTH}, {HEIGHT})
    bpy.ops.wm.usd_import(filepath={str(wrapper(tmp_path, dome=False))!r})
    cam = [o for o in bpy.data.objects if o.type == 'CAMERA'][0]
    sc.camera = cam
    cam.data.ortho_scale = 3.4  # 340 cm; see the module docstring
    w = bpy.data.worlds.new('White'); w.use_nodes = True
    w.node_tree.nodes['Background'].inputs['Color'].default_value = (1, 1, 1, 1)
    w.node_tree.nodes['Background'].inputs['Strength'].default_value = 1.0
    sc.world = w
    sc.cycles.samples = 32; sc.cycles.device = 'CPU'
    sc.render.image_settings.file_format = 'OPEN_EXR'; sc.render.image_settings.color_depth = '32'
    ref = render_rgb(sc, 'CYCLES', 'cycles')
    test = np.load('polychrome.npy')
    emit(de=mean_de00(ref, test, 2), ref=ref.mean(axis=(0, 1)).tolist(), test=test.mean(axis=(0, 1)).tolist())
    """,
        timeout=500,
    )
    r = check(proc, res)[0]
    print(r)
    assert r["de"] <= 2.0, r
