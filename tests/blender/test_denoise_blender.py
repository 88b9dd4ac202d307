"""scene.polychrome.denoise in Blender: the Combined pass is denoised by Open Image Denoise,
the multilayer EXR holds Noisy Image and the Denoising Data passes (Denoising Albedo,
Denoising Normal) under Cycles' names, and Blender's own compositor Denoise node (Blender's
OIDN build, an independent implementation of the call) accepts them and agrees with ours."""

import pytest

from .bhelper import check, run_bpy

pytest.importorskip("pyoidn")
pytestmark = pytest.mark.blender


def test_denoise_passes_in_multilayer_exr_and_the_compositor_denoise_node(tmp_path):
    proc, res = run_bpy(
        tmp_path,
        """
    bpy.ops.wm.read_factory_settings()          # the default cube, light and camera
    sc = bpy.context.scene
    sc.render.engine = 'POLYCHROME'
    sc.render.resolution_x, sc.render.resolution_y, sc.render.resolution_percentage = 64, 48, 100
    sc.polychrome.samples = 4
    sc.polychrome.denoise = True
    vl = sc.view_layers[0]; vl.use_pass_normal = True
    sc.render.image_settings.file_format = 'OPEN_EXR_MULTILAYER'; sc.render.filepath = os.path.abspath('out.exr')
    exr = bpy.ops.render.render(write_still=True)
    err = Engine.last_error
    ch = exr_channels('out.exr')
    # Blender's compositor: Render Layers' Noisy Image + Denoising Data -> Denoise -> Composite.
    sc.use_nodes = True
    tree = sc.node_tree
    for n in list(tree.nodes):
        tree.nodes.remove(n)
    rl = tree.nodes.new('CompositorNodeRLayers')
    dn = tree.nodes.new('CompositorNodeDenoise')
    dn.prefilter = 'ACCURATE'
    comp = tree.nodes.new('CompositorNodeComposite')
    outputs = sorted(o.name for o in rl.outputs if o.enabled)
    tree.links.new(rl.outputs['Noisy Image'], dn.inputs['Image'])
    tree.links.new(rl.outputs['Denoising Albedo'], dn.inputs['Albedo'])
    tree.links.new(rl.outputs['Denoising Normal'], dn.inputs['Normal'])
    tree.links.new(dn.outputs['Image'], comp.inputs['Image'])
    sc.render.filepath = os.path.abspath('comp.exr')
    sc.render.image_settings.file_format = 'OPEN_EXR'
    comp_ok = bpy.ops.render.render(write_still=True)
    comp_ch = exr_channels('comp.exr')
    emit(exr=list(exr), err=err, comp=list(comp_ok), comp_err=Engine.last_error, channels=sorted(ch),
         comp_channels=sorted(comp_ch), outputs=outputs,
         finite={k: bool(np.isfinite(v).all()) for k, v in ch.items()},
         combined=ch['ViewLayer.Combined.G'].tolist(), noisy=ch['ViewLayer.Noisy Image.G'].tolist(),
         comp_g=comp_ch.get('G', comp_ch.get('RenderLayer.Combined.G', np.zeros(1))).tolist())
    """,
        timeout=300,
    )
    r = check(proc, res)[0]
    assert r["exr"] == ["FINISHED"] and r["err"] is None, r
    for p in (
        "Combined.R",
        "Noisy Image.R",
        "Noisy Image.A",
        "Denoising Albedo.R",
        "Denoising Albedo.B",
        "Denoising Normal.X",
        "Denoising Normal.Z",
    ):
        assert "ViewLayer." + p in r["channels"], r["channels"]
    assert all(r["finite"].values()), r["finite"]
    assert {"Noisy Image", "Denoising Albedo", "Denoising Normal"} <= set(r["outputs"]), r["outputs"]
    import numpy as np

    combined, noisy = np.array(r["combined"]), np.array(r["noisy"])
    assert not np.allclose(combined, noisy)
    # Blender's Denoise node on our passes gives what our denoiser gave (same OIDN model;
    # Blender's prefilter and build differ a little). Measured: 1.0% mean difference.
    assert r["comp"] == ["FINISHED"], r
    comp = np.array(r["comp_g"])
    assert comp.shape == combined.shape, r["comp_channels"]
    print("Blender Denoise node vs ours: mean |diff| / mean =", np.abs(comp - combined).mean() / np.abs(combined).mean())
    assert np.abs(comp - combined).mean() < 0.03 * np.abs(combined).mean() + 1e-4, (np.abs(comp - combined).mean(), combined.mean())
