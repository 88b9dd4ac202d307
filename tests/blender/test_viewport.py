"""Interactive viewport and material preview rendering of the add-on, driven through bpy
in subprocesses. Headless Blender cannot draw, so the engine's own view_update /
view_draw run on a stand-in engine object (drawing recorded instead of done) with a real
depsgraph and the region matrices a 3D view would pass; material previews are rendered by
Blender itself (ID.asset_generate_preview)."""

import textwrap

import pytest

from .bhelper import check, run_bpy

pytestmark = pytest.mark.blender

VIEWPORT_HELPERS = """
import types, time
import polychrome as pc
from polychrome_blender import viewport

class FakeEngine:
    '''Borrows the engine's viewport methods; records redraw requests and draws.'''
    view_update = Engine.view_update
    view_draw = Engine.view_draw
    _report_once = Engine._report_once
    _report = Engine._report
    __del__ = Engine.__del__
    def __init__(self):
        self.session = None; self.exporter = None; self.redraws = 0; self.drawn = []; self.reports = []; self.stats = ''
    def follow_updates(self):
        '''Calls view_update from the depsgraph update, as Blender does (depsgraph.updates is
        empty once the update is over).'''
        self._follow = lambda scene, dg: self.view_update(bpy.context, dg)
        bpy.app.handlers.depsgraph_update_post.append(self._follow)
    def stop_following(self):
        bpy.app.handlers.depsgraph_update_post.remove(self._follow)
    def tag_redraw(self): self.redraws += 1
    def report(self, level, msg): self.reports.append((sorted(level), msg))
    def update_stats(self, a, b): self.stats = b
    def _draw_preview(self, scene, preview, w, h): self.drawn.append((preview.serial, preview.samples, w, h))

def region_ctx(cam_ob, dg, w, h, pixel_size=2):
    pm = cam_ob.calc_matrix_camera(dg, x=w // pixel_size, y=h // pixel_size)
    rd = types.SimpleNamespace(view_matrix=cam_ob.matrix_world.inverted(), window_matrix=pm)
    return types.SimpleNamespace(region=types.SimpleNamespace(width=w, height=h), region_data=rd)

def refine(fake, ctx, timeout=120):
    '''Calls view_draw as Blender does after tag_redraw, until the render stops refining.'''
    deadline = time.monotonic() + timeout
    while True:
        before = fake.redraws
        dg = bpy.context.evaluated_depsgraph_get()
        fake.view_draw(ctx, dg)
        if fake.redraws == before:
            return
        assert time.monotonic() < deadline, 'viewport render did not finish'
        time.sleep(0.005)

def lum(rgba):
    return float((0.2126 * rgba[..., 0] + 0.7152 * rgba[..., 1] + 0.0722 * rgba[..., 2]).mean())
"""


def test_view_camera_matches_the_exported_scene_camera(tmp_path):
    proc, res = run_bpy(
        tmp_path,
        VIEWPORT_HELPERS
        + textwrap.dedent("""
    from polychrome_blender.export.camera import export_camera
    from polychrome_blender.export.warnings import Warnings
    out = []
    for kind, (w, h), fit in (('PERSP', (48, 32), 'AUTO'), ('PERSP', (30, 44), 'VERTICAL'), ('ORTHO', (40, 30), 'AUTO')):
        sc = empty_scene(w, h)
        bpy.ops.mesh.primitive_monkey_add(location=(0, 0, 0))
        bpy.ops.mesh.primitive_plane_add(size=6, location=(0, 0, -1))
        cam = add_camera(sc, (4, -5, 3), lens=35)
        cam.data.type = kind; cam.data.ortho_scale = 5.0; cam.data.sensor_fit = fit
        cam.data.shift_x, cam.data.shift_y = 0.1, -0.07
        dg = bpy.context.evaluated_depsgraph_get()
        from polychrome_blender.export import export_scene
        scene, _ = export_scene(dg)
        ref = pc.render(scene, width=w, height=h, samples=1, max_bounces=0)
        scene.camera = viewport.view_camera(cam.matrix_world.inverted(), cam.calc_matrix_camera(dg, x=w, y=h), w, h)
        got = pc.render(scene, width=w, height=h, samples=1, max_bounces=0)
        close = np.isclose(got.depth, ref.depth, rtol=1e-3, atol=1e-4)
        out.append(dict(kind=kind, fit=fit, frac=float(close.mean()), hit=float((ref.depth > 0).mean())))
    emit(out=out)
    """),
    )
    for r in check(proc, res)[0]["out"]:
        assert 0.2 < r["hit"] < 1.0, r  # the test view shows both objects and background
        assert r["frac"] > 0.98, r  # the same rays (edges may flip by rounding)


def test_view_update_and_view_draw_restart_on_edits_and_refine(tmp_path):
    proc, res = run_bpy(
        tmp_path,
        VIEWPORT_HELPERS
        + textwrap.dedent("""
    sc = empty_scene(32, 24)
    sc.render.engine = 'POLYCHROME'
    sc.polychrome.viewport_samples = 16
    sc.polychrome.viewport_pixel_size = 2
    bpy.ops.mesh.primitive_plane_add(size=20, location=(0, 0, 0))
    plane = bpy.context.active_object
    mat = diffuse_material('Paint', (0.8, 0.1, 0.1)); plane.data.materials.append(mat)
    ld = bpy.data.lights.new('Lamp', 'POINT'); ld.energy = 500.0
    lamp = bpy.data.objects.new('Lamp', ld); sc.collection.objects.link(lamp); lamp.location = (0, 0, 3)
    cam = add_camera(sc, (0, -6, 5))
    fake = FakeEngine()
    dg = bpy.context.evaluated_depsgraph_get()
    ctx = region_ctx(cam, dg, 64, 48)
    steps = {}
    fake.view_update(bpy.context, dg)
    fake.follow_updates()

    def step(name, edit=None, view=None):
        global ctx
        if edit: edit(); bpy.context.view_layer.update()
        if view is not None: ctx = view
        dg = bpy.context.evaluated_depsgraph_get()
        fake.view_update(bpy.context, dg)                    # a later call without updates changes nothing
        fake.drawn.clear()
        refine(fake, ctx)
        s = fake.session
        steps[name] = dict(restarts=s.restarts, samples=s.samples, error=s.error, lum=lum(s.latest.rgba),
                           rg=float(s.latest.rgba[..., 0].mean() / max(s.latest.rgba[..., 1].mean(), 1e-9)),
                           drawn=list(fake.drawn), size=list(s.latest.rgba.shape))
        return s

    s = step('first')
    first_rgba = s.latest.rgba.copy()
    step('again')                                             # nothing changed: no restart
    step('material', edit=lambda: mat.node_tree.nodes['Diffuse BSDF'].inputs['Color'].default_value.__setitem__(slice(0, 3), (0.1, 0.8, 0.1)))
    step('light', edit=lambda: setattr(ld, 'energy', 1000.0))
    step('move', edit=lambda: setattr(plane, 'location', (0, 0, -0.5)))
    step('settings', edit=lambda: setattr(sc.polychrome, 'viewport_samples', 8))
    cam.location = (1, -6, 5); bpy.context.view_layer.update()
    step('view', view=region_ctx(cam, bpy.context.evaluated_depsgraph_get(), 64, 48))
    # a settings edit seen only by the next redraw (no view_update) restarts too
    sc.polychrome.max_bounces = 3
    before = fake.session.restarts
    refine(fake, ctx)
    draw_only = fake.session.restarts - before
    job = fake.session.job
    fake.stop_following()
    fake.__del__()                                           # the engine is freed
    emit(steps=steps, freed=fake.session is None and job.done(), reports=fake.reports,
         redraws=fake.redraws, draw_only=draw_only)
    """),
    )
    r = check(proc, res)[0]
    st = r["steps"]
    assert not r["reports"], r["reports"]
    assert all(v["error"] is None for v in st.values()), st
    assert [st[k]["restarts"] for k in ("first", "again", "material", "light", "move", "settings", "view")] == [1, 1, 2, 3, 4, 5, 6]
    first = st["first"]
    assert first["samples"] == 16 and first["size"] == [24, 32, 4]
    samples = [d[1] for d in first["drawn"]]
    assert samples[-1] == 16 and samples == sorted(samples) and len(samples) >= 1
    assert all(d[2:] == [64, 48] for d in first["drawn"])  # drawn over the whole region
    assert st["again"]["samples"] == 16  # the finished image stays
    assert st["first"]["rg"] > 3 and st["material"]["rg"] < 0.5  # red paint, then green
    # same seed and paths, only the point light's power doubled: exactly twice as bright
    assert st["light"]["lum"] == pytest.approx(2 * st["material"]["lum"], rel=1e-3)
    assert st["settings"]["samples"] == 8
    assert r["draw_only"] == 1
    assert r["freed"]


def test_exporter_re_exports_only_what_changed_and_equals_a_fresh_export(tmp_path):
    proc, res = run_bpy(
        tmp_path,
        VIEWPORT_HELPERS
        + textwrap.dedent("""
    from polychrome_blender.export import Exporter, export_scene
    sc = empty_scene(32, 24)
    bpy.ops.mesh.primitive_cube_add(location=(-1, 0, 0)); a = bpy.context.active_object
    bpy.ops.mesh.primitive_uv_sphere_add(location=(1, 0, 0)); b = bpy.context.active_object
    ma = diffuse_material('MA', (0.8, 0.1, 0.1)); a.data.materials.append(ma)
    mb = diffuse_material('MB', (0.1, 0.1, 0.8)); b.data.materials.append(mb)
    img = bpy.data.images.new('Checker', 4, 4); img.pixels.foreach_set(np.linspace(0, 1, 64, dtype=np.float32))
    tex = mb.node_tree.nodes.new('ShaderNodeTexImage'); tex.image = img
    mb.node_tree.links.new(tex.outputs['Color'], mb.node_tree.nodes['Diffuse BSDF'].inputs['Color'])
    ld = bpy.data.lights.new('Lamp', 'POINT'); lamp = bpy.data.objects.new('Lamp', ld); sc.collection.objects.link(lamp)
    add_camera(sc, (0, -6, 3))
    exporter = Exporter()
    def follow(scene, dg):
        exporter.update(dg)
    bpy.app.handlers.depsgraph_update_post.append(follow)
    out = {}

    def step(name, edit=None):
        if edit:
            edit(); bpy.context.view_layer.update()
        dg = bpy.context.evaluated_depsgraph_get()
        scene, warns = exporter.export(dg)
        fresh, fresh_warns = export_scene(dg)
        out[name] = dict(counts=dict(exporter.counts), same=viewport.description_digest(*scene.description())
                         == viewport.description_digest(*fresh.description()), warns=warns == fresh_warns,
                         cached=len(exporter._meshes), lamp=ld.energy)

    step('first')
    step('again')
    step('move', lambda: setattr(a, 'location', (-1, 0, 0.5)))
    def reshape():
        a.data.vertices[0].co.z += 0.5; a.data.update()
    step('geometry', reshape)
    step('material', lambda: ma.node_tree.nodes['Diffuse BSDF'].inputs['Color'].default_value.__setitem__(slice(0, 3), (0.1, 0.8, 0.1)))
    def repaint():
        img.pixels.foreach_set(np.linspace(1, 0, 64, dtype=np.float32)); img.update(); img.update_tag()  # as painting tags it
    step('image', repaint)
    step('light', lambda: setattr(ld, 'energy', 50.0))
    def duplicate():
        c = a.copy(); c.location = (0, 2, 0); sc.collection.objects.link(c)
    step('duplicate', duplicate)
    step('delete', lambda: bpy.data.objects.remove(b))
    bpy.app.handlers.depsgraph_update_post.remove(follow)    # a handler left behind hangs the exit
    emit(**out)
    """),
    )
    r = check(proc, res)[0]
    for name, step in r.items():
        assert step["same"] and step["warns"], (name, step)  # cached parts give the fresh export's scene
    counts = {name: step["counts"] for name, step in r.items()}
    assert counts["first"] == {"meshes": 2, "materials": 2, "images": 1}
    for name in ("again", "move", "light"):
        assert counts[name] == {"meshes": 0, "materials": 0, "images": 0}, name
    assert counts["geometry"] == {"meshes": 1, "materials": 0, "images": 0}
    assert counts["material"] == {"meshes": 0, "materials": 1, "images": 0}
    assert counts["image"] == {"meshes": 0, "materials": 1, "images": 1}
    assert counts["duplicate"]["meshes"] <= 1 and counts["duplicate"]["materials"] == 0
    assert r["delete"]["cached"] == 1  # the sphere's mesh is dropped with it


def test_viewport_image_equals_the_final_render_of_the_same_view(tmp_path):
    proc, res = run_bpy(
        tmp_path,
        VIEWPORT_HELPERS
        + textwrap.dedent("""
    sc = empty_scene(32, 24)
    sc.render.engine = 'POLYCHROME'
    sc.polychrome.viewport_samples = sc.polychrome.samples = 8
    sc.polychrome.viewport_pixel_size = 1
    bpy.ops.mesh.primitive_monkey_add(location=(0, 0, 0))
    bpy.ops.mesh.primitive_plane_add(size=10, location=(0, 0, -1))
    ld = bpy.data.lights.new('Lamp', 'AREA'); ld.energy = 300.0; ld.size = 2
    lamp = bpy.data.objects.new('Lamp', ld); sc.collection.objects.link(lamp); lamp.location = (1, -1, 4)
    cam = add_camera(sc, (3, -5, 3))
    fake = FakeEngine()
    dg = bpy.context.evaluated_depsgraph_get()
    fake.view_update(bpy.context, dg)
    refine(fake, region_ctx(cam, dg, 32, 24, pixel_size=1))
    view = fake.session.latest.rgba
    fake.__del__()
    sc.render.image_settings.file_format = 'OPEN_EXR'; sc.render.image_settings.color_depth = '32'
    sc.render.filepath = os.path.abspath('f12.exr')
    bpy.ops.render.render(write_still=True)
    ch = exr_channels('f12.exr')
    f12 = np.stack([ch['R'], ch['G'], ch['B']], -1)             # EXR rows top-down, as polychrome's
    from polychrome.colordiff import image_delta_e
    de = image_delta_e(view[..., :3], f12)
    emit(de_mean=float(np.mean(de)), lum_view=lum(view), lum_f12=float(f12.mean()), err=Engine.last_error,
         same=bool(np.allclose(view[..., :3], f12, rtol=1e-3, atol=1e-4)))
    """),
    )
    r = check(proc, res)[0]
    assert r["err"] is None
    assert r["lum_view"] > 0
    # the same camera rays, seed and settings: the same pixels (up to float rounding)
    assert r["same"], r
    assert r["de_mean"] < 0.05, r


def test_unregister_stops_viewport_renders(tmp_path):
    proc, res = run_bpy(
        tmp_path,
        VIEWPORT_HELPERS
        + textwrap.dedent("""
    sc = empty_scene(32, 24)
    sc.render.engine = 'POLYCHROME'
    sc.polychrome.viewport_samples = 1000000
    bpy.ops.mesh.primitive_cube_add()
    cam = add_camera(sc, (4, -4, 3))
    fake = FakeEngine()
    dg = bpy.context.evaluated_depsgraph_get()
    fake.view_update(bpy.context, dg)
    fake.view_draw(region_ctx(cam, dg, 64, 48), dg)
    job = fake.session.job
    t0 = time.monotonic()
    while job.preview_serial() == 0 and time.monotonic() - t0 < 60: time.sleep(0.01)
    t0 = time.monotonic()
    polychrome_blender.unregister()
    emit(done=job.done(), seconds=time.monotonic() - t0, cancelled=job.result().stats['cancelled'])
    """),
    )
    r = check(proc, res)[0]
    assert r["done"] and r["cancelled"]


def test_material_preview_renders_through_the_engine(tmp_path):
    proc, res = run_bpy(
        tmp_path,
        """
    bpy.ops.wm.read_factory_settings()
    sc = bpy.context.scene
    sc.render.engine = 'POLYCHROME'
    out = {}
    for name, rgb in (('Red', (0.8, 0.05, 0.05)), ('Green', (0.05, 0.8, 0.05))):
        m = diffuse_material(name, rgb)
        Engine.last_stats = None
        m.asset_generate_preview()
        p = m.preview
        w, h = p.image_size
        px = np.array(p.image_pixels_float[:], np.float64).reshape(h, w, 4)
        c = px[h // 2 - 8:h // 2 + 8, w // 2 - 8:w // 2 + 8, :3].mean(axis=(0, 1))
        out[name] = dict(size=[w, h], centre=c.tolist(), err=Engine.last_error,
                         spp=(Engine.last_stats or {}).get('samples_per_pixel'))
    emit(**out)
    """,
    )
    r = check(proc, res)[0]
    red, green = r["Red"], r["Green"]
    for m in (red, green):
        assert m["err"] is None and m["spp"] == 16 and m["size"][0] >= 32, m
    # display-encoded (sRGB) preview pixels: the sphere is clearly red, then green
    assert red["centre"][0] > 1.25 * max(red["centre"][1], red["centre"][2]), red
    assert green["centre"][1] > 1.25 * max(green["centre"][0], green["centre"][2]), green


def test_final_render_shows_intermediate_images_and_ends_with_the_same_pixels(tmp_path):
    proc, res = run_bpy(
        tmp_path,
        """
    bpy.ops.wm.read_factory_settings()
    sc = bpy.context.scene
    sc.render.engine = 'POLYCHROME'
    sc.render.resolution_x, sc.render.resolution_y, sc.render.resolution_percentage = 64, 48, 100
    # Long enough (~1 s at 2048 spp) that the engine's 0.05 s poll sees the job running: at 64 spp an idle
    # machine finished before the first poll, with nothing intermediate to show.
    sc.polychrome.samples = 2048
    sc.render.image_settings.file_format = 'OPEN_EXR'; sc.render.image_settings.color_depth = '32'
    out = {}
    for mode in (False, True):
        Engine.progressive_final = mode
        Engine.PROGRESSIVE_INTERVAL = 0.05
        Engine.intermediate_updates = 0
        sc.render.filepath = os.path.abspath(f'p{int(mode)}.exr')
        r = bpy.ops.render.render(write_still=True)
        out[mode] = dict(r=list(r), err=Engine.last_error, n=Engine.intermediate_updates,
                         spp=Engine.last_stats['samples_per_pixel'])
    a, b = exr_channels('p0.exr'), exr_channels('p1.exr')
    # Esc during a progressive render
    Engine.test_break_hook = lambda done, total: done > 0
    sc.polychrome.samples = 100000
    sc.render.filepath = os.path.abspath('p2.exr')
    bpy.ops.render.render(write_still=True)
    emit(off=out[False], on=out[True], same=all(np.array_equal(a[k], b[k]) for k in a), keys=sorted(a),
         cancelled=Engine.last_stats['cancelled'], err2=Engine.last_error)
    """,
    )
    r = check(proc, res)[0]
    assert r["off"]["err"] is None and r["on"]["err"] is None
    assert r["off"]["n"] == 0 and r["on"]["n"] >= 1
    assert r["off"]["spp"] == r["on"]["spp"] == 2048
    assert r["same"], r["keys"]
    assert r["cancelled"] and r["err2"] is None
