"""F12 in Blender with Render Properties › System › Scheduler set (scene.polychrome.scheduler):
the frame is rendered by the workers of that Dask cluster and equals Blender's local
Polychrome render with the same seed (docs/distributed.md), also with a border, and a
checkpointed render resumed in Blender equals it too. The cluster is a LocalCluster
started inside the bpy process (in-process workers, bound to 127.0.0.1), closed at the
end; its workers count the scenes they compiled, which shows they rendered."""

import pytest

from .bhelper import check, run_bpy

pytest.importorskip("distributed")
pytestmark = pytest.mark.timeout(400)


def test_f12_on_a_dask_scheduler_equals_the_local_render(tmp_path):
    proc, res = run_bpy(
        tmp_path,
        """
    from distributed import Client, LocalCluster
    import polychrome.distributed as pd
    from polychrome import checkpoint
    bpy.ops.wm.read_factory_settings()
    sc = bpy.context.scene; r = sc.render
    r.engine = 'POLYCHROME'; r.resolution_x, r.resolution_y, r.resolution_percentage = 40, 30, 100
    sc.polychrome.samples = 8; sc.polychrome.seed = 5
    r.image_settings.file_format = 'OPEN_EXR'
    out = {}
    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=False, protocol='tcp://', host='127.0.0.1', dashboard_address=':0')
    try:
        for border in (False, True):
            r.use_border = border
            r.border_min_x, r.border_max_x, r.border_min_y, r.border_max_y = 0.25, 0.75, 0.0, 0.5
            for where in ('', cluster.scheduler_address):
                sc.polychrome.scheduler = where
                before = pd._COMPILES
                r.filepath = os.path.abspath(f'b{int(border)}_{bool(where)}.exr')
                bpy.ops.render.render(write_still=True)
                out[f'err{int(border)}{bool(where)}'] = Engine.last_error
                out[f'compiles{int(border)}{bool(where)}'] = pd._COMPILES - before
        # A checkpointed render on the cluster, cancelled after its first task, resumed by F12.
        checkpoint.INTERVAL = 0.0
        r.use_border = False
        sc.polychrome.checkpoint = os.path.abspath('shot.npz')
        sc.polychrome.samples = 64
        from polychrome_blender.engine import viewport_settings, material_preview_settings
        from polychrome_blender.engine import settings_from_scene
        sc.polychrome.checkpoint = ''; sc.polychrome.resume = True
        out['default_checkpoint'] = settings_from_scene(sc.polychrome, 8, 8).checkpoint
        out['frame_path'] = r.frame_path()
        sc.polychrome.checkpoint = os.path.abspath('shot.npz'); sc.polychrome.resume = False
        out['viewport_checkpoint'] = [viewport_settings(sc.polychrome).checkpoint, material_preview_settings(sc.polychrome, 8, 8).checkpoint]
        import polychrome as pc
        orig = pc.render
        def cancel_first(scene, settings=None, progress=None, **kw):
            return orig(scene, settings, progress=lambda done, total: False, **kw)
        pc.render = cancel_first
        r.filepath = os.path.abspath('partial.exr'); bpy.ops.render.render(write_still=True)
        pc.render = orig
        out['checkpoint_written'] = os.path.exists('shot.npz')
        sc.polychrome.resume = True
        r.filepath = os.path.abspath('resumed.exr'); bpy.ops.render.render(write_still=True)
        sc.polychrome.checkpoint = ''; sc.polychrome.resume = False; sc.polychrome.scheduler = ''
        r.filepath = os.path.abspath('plain64.exr'); bpy.ops.render.render(write_still=True)
    finally:
        cluster.close()
    for border in (0, 1):
        a, b = (exr_channels(f'b{border}_{w}.exr') for w in (False, True))
        out[f'diff{border}'] = max(float(np.abs(a[c] - b[c]).max()) for c in 'RGB')
        out[f'peak{border}'] = float(a['G'].max())
    p, q, s = (exr_channels(f) for f in ('partial.exr', 'resumed.exr', 'plain64.exr'))
    out['diff_resumed'] = max(float(np.abs(q[c] - s[c]).max()) for c in 'RGB')
    out['diff_partial'] = max(float(np.abs(p[c] - s[c]).max()) for c in 'RGB')
    out['peak64'] = float(s['G'].max())
    emit(**out)
    """,
        timeout=380,
    )
    r = check(proc, res)[0]
    for border in (0, 1):
        assert r[f"err{border}False"] is None and r[f"err{border}True"] is None, r
        assert r[f"compiles{border}False"] == 0 and r[f"compiles{border}True"] >= 1, r  # the workers rendered
        assert r[f"peak{border}"] > 0.01
        assert r[f"diff{border}"] <= 1e-5 * r[f"peak{border}"], r
    assert r["default_checkpoint"] == r["frame_path"] + ".checkpoint.npz"  # Resume alone: beside the output, as the CLI
    assert r["viewport_checkpoint"] == ["", ""]  # the viewport and previews never touch the final's checkpoint
    assert r["checkpoint_written"]
    assert r["diff_partial"] > 1e-3 * r["peak64"], "the cancelled render should differ (it has fewer samples)"
    assert r["diff_resumed"] <= 1e-5 * r["peak64"], r
