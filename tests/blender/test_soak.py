"""Blender soak test (issue 8): one bpy process renders 50 varied small scenes, 10 of them
cancelled midway through the engine's test_break path, plus renders of broken meshes
(NaN and ±inf vertices: reported by the engine, naming the object). Memory must come
back to its level after the first render, nothing may hang (subprocess timeout), and
the engine must unregister cleanly."""

import pytest

from .bhelper import check, run_bpy

pytestmark = [pytest.mark.blender, pytest.mark.slow]

RENDERS = 50
CANCELLED = 10
RSS_MARGIN_MB = 50.0


def test_fifty_renders_ten_cancelled_memory_flat_and_clean_unregister(tmp_path):
    proc, res = run_bpy(
        tmp_path,
        f"""
    import gc, time

    def rss_mb():
        with open('/proc/self/statm') as f:
            return int(f.read().split()[1]) * os.sysconf('SC_PAGE_SIZE') / 2**20

    sc = empty_scene(24, 16)
    sc.render.engine = 'POLYCHROME'
    add_camera(sc, (0, -6, 3))
    methods = ['POLYCHROMATIC', 'MONOCHROMATIC_RAYS', 'MONOCHROMATIC_SCENES', 'RGB']
    cancel_at = set(range(3, {RENDERS}, {RENDERS} // {CANCELLED}))    # 10 renders cancelled
    rss, outcomes, seconds = [], [], []
    for k in range({RENDERS}):
        # Vary the scene: a few objects come and go, lights and materials change.
        for ob in [o for o in sc.objects if o.type != 'CAMERA']:
            bpy.data.objects.remove(ob, do_unlink=True)
        for me in list(bpy.data.meshes):
            if me.users == 0:
                bpy.data.meshes.remove(me)
        for ld in list(bpy.data.lights):
            if ld.users == 0:
                bpy.data.lights.remove(ld)
        if k % 2 == 0:
            bpy.ops.mesh.primitive_uv_sphere_add(segments=8 + k % 5 * 4, ring_count=6 + k % 4, location=(0, 0, 1))
        else:
            bpy.ops.mesh.primitive_cube_add(location=(k % 3 - 1, 0, 0.5))
        ob = bpy.context.active_object
        ob.data.materials.append(diffuse_material(f'm{{k}}', ((k * 37) % 100 / 100, 0.5, 0.3)))
        bpy.ops.mesh.primitive_plane_add(size=10)
        ld = bpy.data.lights.new(f'l{{k}}', type=['POINT', 'SUN', 'SPOT', 'AREA'][k % 4]); ld.energy = 200.0 if k % 4 != 1 else 3.0
        lo = bpy.data.objects.new(f'l{{k}}', ld); sc.collection.objects.link(lo); lo.location = (1, -2, 4)
        broken = k in (7, 29)
        if broken:   # non-finite vertex data: the engine reports it, naming the object
            ob.data.vertices[0].co = (float('nan') if k == 7 else float('inf'), 0.0, 0.0)
            ob.name = f'broken{{k}}'
        props = sc.polychrome
        props.method = methods[k % 4]
        props.wavelength_count = [8, 16, 41][k % 3] if props.method != 'MONOCHROMATIC_SCENES' else 6
        props.max_bounces = 3
        cancel = k in cancel_at
        props.samples = 100000 if cancel else 2 + k % 4
        Engine.test_break_hook = (lambda done, total: True) if cancel else None
        t0 = time.perf_counter()
        try:
            bpy.ops.render.render()
            raised = None
        except RuntimeError as e:             # an ERROR report makes the operator raise
            raised = str(e)
        seconds.append(time.perf_counter() - t0)
        st = dict(Engine.last_stats or {{}})
        outcomes.append(dict(k=k, cancel=cancel, broken=broken, err=Engine.last_error, raised=raised,
                             cancelled=st.get('cancelled'), nonfinite=st.get('nonfinite_samples'),
                             spp=st.get('samples_per_pixel')))
        gc.collect()
        rss.append(rss_mb())
    Engine.test_break_hook = None
    polychrome_blender.unregister()
    try:
        sc.render.engine = 'POLYCHROME'
        still_there = True
    except TypeError:
        still_there = False
    polychrome_blender.register()             # so the epilogue's unregister has something to undo
    emit(rss=rss, outcomes=outcomes, seconds=seconds, still_there=still_there)
    """,
        timeout=240,
    )
    r = check(proc, res)[0]
    outs = r["outcomes"]
    assert len(outs) == RENDERS
    cancelled = [o for o in outs if o["cancel"]]
    assert len(cancelled) == CANCELLED
    for o in cancelled:
        assert o["err"] is None and o["cancelled"] is True and o["spp"] < 100000, o
    for o in outs:
        if o["broken"]:
            # (Blender hands ±inf over as ±3.4e38, which the core rejects as out of range.)
            assert o["err"] and f"broken{o['k']}" in o["err"] and ("finite" in o["err"] or "beyond" in o["err"]), o
            assert o["raised"] is not None, o
        elif not o["cancel"]:
            assert o["err"] is None and o["nonfinite"] == 0 and o["cancelled"] is False, o
    # Memory back to its level after the first render (within RSS_MARGIN_MB).
    growth = max(r["rss"][1:]) - r["rss"][0]
    assert growth < RSS_MARGIN_MB, (growth, r["rss"])
    assert r["rss"][-1] - r["rss"][0] < RSS_MARGIN_MB
    assert r["still_there"] is False
    print(
        f"soak: {RENDERS} renders in {sum(r['seconds']):.1f} s, RSS first {r['rss'][0]:.0f} MB, "
        f"max {max(r['rss']):.0f} MB, last {r['rss'][-1]:.0f} MB"
    )
