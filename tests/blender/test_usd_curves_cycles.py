"""Blender hair curves through Blender's own USD exporter (BasisCurves, catmullRom,
pinned, vertex widths = 2 × radius) read by polychrome.usd and rendered by Polychrome,
against Cycles CPU rendering the .blend: the coverage of 150 tapered emissive hairs
(mean ΔE00 on 2×2 blocks; control: the exported widths × 0.7 must be seen)."""

import textwrap

import pytest

from .bhelper import check, run_bpy
from .test_hair import COMMON

pytestmark = pytest.mark.blender


def test_blender_exported_hair_curves_cover_what_cycles_covers(tmp_path):
    proc, res = run_bpy(
        tmp_path,
        COMMON
        + textwrap.dedent(
            """
    import polychrome as pc
    from polychrome import usd
    sc = stage(True, 64); c = hair_curves(sc, True)
    m = bpy.data.materials.new('HairUsd'); m.use_nodes = True
    p = m.node_tree.nodes['Principled BSDF']
    p.inputs['Base Color'].default_value = (0, 0, 0, 1)
    p.inputs['Emission Color'].default_value = (0.9, 0.5, 0.2, 1); p.inputs['Emission Strength'].default_value = 1.0
    p.inputs['Specular IOR Level'].default_value = 0.0; p.inputs['Roughness'].default_value = 1.0
    c.materials[0] = m
    sc.render.engine = 'CYCLES'; sc.render.filepath = os.path.abspath('ref.exr'); bpy.ops.render.render(write_still=True)
    a = exr_rgb('ref.exr')
    bpy.ops.wm.usd_export(filepath=os.path.abspath('hair.usda'))
    import warnings
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter('always')
        scene = usd.read_stage('hair.usda', resolution=(64, 48))
    from pxr import Usd
    written = Usd.Stage.Open('hair.usda')
    types = sorted({str(q.GetTypeName()) for q in written.Traverse()})
    b = pc.render(scene, width=64, height=48, samples=64, max_bounces=0).rgba[..., :3]
    white = float(np.percentile(a[..., 1], 99))
    de = float(cd.image_delta_e(block_means(a), block_means(b), white_luminance=white).mean())
    # Control: the exported widths × 0.7 must be seen.
    for q in written.Traverse():
        if q.GetTypeName() == 'BasisCurves':
            wa = q.GetAttribute('widths'); wa.Set([0.7 * x for x in wa.Get()])
    written.Export(os.path.abspath('thin.usda'))
    thin = pc.render(usd.read_stage('thin.usda', resolution=(64, 48)), width=64, height=48, samples=64, max_bounces=0).rgba[..., :3]
    control = float(cd.image_delta_e(block_means(a), block_means(thin), white_luminance=white).mean())
    emit(de=de, control=control, ratio=(b.mean(axis=(0, 1)) / np.maximum(a.mean(axis=(0, 1)), 1e-9)).tolist(),
         warnings=[str(w.message) for w in caught], types=types)
    """
        ),
        timeout=400,
    )
    r = check(proc, res)[0]
    print("Blender USD hair vs Cycles:", r)
    assert "BasisCurves" in r["types"]
    assert not [w for w in r["warnings"] if "hair" in w.lower() or "curve" in w.lower()], r["warnings"]
    assert r["ratio"] == pytest.approx([1, 1, 1], abs=0.05), r
    assert r["de"] <= 1.5, r
    assert r["control"] > 2.0, r
