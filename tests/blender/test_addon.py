"""The Blender add-on, driven through bpy in subprocesses (see bhelper.py)."""

import numpy as np
import pytest

from .bhelper import check, run_bpy

pytestmark = pytest.mark.blender


def test_register_adds_engine_and_unregister_removes_it(tmp_path):
    proc, res = run_bpy(
        tmp_path,
        """
    def engines():
        try:
            bpy.context.scene.render.engine = 'NOPE'
        except TypeError as e:
            return str(e).split(' in ', 1)[1]
        return ''
    before = engines()
    has_props = hasattr(bpy.context.scene, 'polychrome')
    bpy.context.scene.render.engine = 'POLYCHROME'
    bpy.context.scene.render.engine = 'CYCLES'
    polychrome_blender.unregister()
    after = engines()
    polychrome_blender.register(); polychrome_blender.register()   # idempotent
    again = engines()
    emit(before=before, after=after, again=again, has_props=has_props,
         names=sorted(p.identifier for p in bpy.types.Scene.bl_rna.properties['polychrome'].fixed_type.properties))
    """,
    )
    r = check(proc, res)[0]
    assert "'POLYCHROME'" in r["before"] and "'CYCLES'" in r["before"]
    assert "POLYCHROME" not in r["after"]
    assert "'POLYCHROME'" in r["again"]
    assert r["has_props"]
    for name in (
        "method",
        "direction",
        "wavelength_count",
        "samples",
        "max_bounces",
        "seed",
        "time_limit",
        "uplift",
        "threads",
        "dispersion_splitting",
    ):
        assert name in r["names"]


def test_default_scene_renders_png_and_multilayer_exr_with_passes(tmp_path):
    proc, res = run_bpy(
        tmp_path,
        """
    bpy.ops.wm.read_factory_settings()          # the default cube, light and camera
    sc = bpy.context.scene
    sc.render.engine = 'POLYCHROME'
    sc.render.resolution_x, sc.render.resolution_y, sc.render.resolution_percentage = 64, 48, 100
    sc.polychrome.samples = 4
    vl = sc.view_layers[0]; vl.use_pass_z = True; vl.use_pass_normal = True
    sc.render.image_settings.file_format = 'PNG'; sc.render.filepath = os.path.abspath('out.png')
    png = bpy.ops.render.render(write_still=True)
    err_png = Engine.last_error
    sc.render.image_settings.file_format = 'OPEN_EXR_MULTILAYER'; sc.render.filepath = os.path.abspath('out.exr')
    exr = bpy.ops.render.render(write_still=True)
    ch = exr_channels('out.exr')
    cam = sc.camera; cube = bpy.data.objects['Cube']
    # depth along the view axis of the cube's nearest corner and centre (independent bound)
    fwd = -np.array(cam.matrix_world.to_3x3().col[2]); cpos = np.array(cam.matrix_world.translation)
    corners = [np.array(cube.matrix_world @ v.co) for v in cube.data.vertices]
    zs = [float(np.dot(c - cpos, fwd)) for c in corners]
    emit(png=list(png), exr=list(exr), err_png=err_png, err=Engine.last_error, stats=Engine.last_stats,
         channels=sorted(ch), finite={k: bool(np.isfinite(v).all()) for k, v in ch.items()},
         zmin=min(zs), zmax=max(zs),
         depth=ch['ViewLayer.Depth.Z'].tolist(), nlen=np.sqrt(sum(ch['ViewLayer.Normal.' + c] ** 2 for c in 'XYZ')).tolist(),
         combined=float(ch['ViewLayer.Combined.R'].mean()), size=list(ch['ViewLayer.Combined.R'].shape))
    """,
    )
    r = check(proc, res)[0]
    assert r["png"] == ["FINISHED"] and r["exr"] == ["FINISHED"]
    assert r["err_png"] is None and r["err"] is None
    assert (tmp_path / "out.png").stat().st_size > 0
    assert r["size"] == [48, 64]
    for p in (
        "Combined.R",
        "Combined.G",
        "Combined.B",
        "Combined.A",
        "Depth.Z",
        "Normal.X",
        "Normal.Y",
        "Normal.Z",
        "Albedo.R",
        "Albedo.G",
        "Albedo.B",
    ):
        assert "ViewLayer." + p in r["channels"], r["channels"]
    assert all(r["finite"].values()), r["finite"]
    assert r["combined"] > 0.0
    import numpy as np

    depth = np.array(r["depth"])
    nlen = np.array(r["nlen"])
    hit = depth < 1e9
    assert 0.05 * depth.size < hit.sum() < depth.size  # the cube covers part of the frame
    # pixels wholly on the cube lie between its nearest and farthest corner along the view axis
    inner = depth[hit & (depth > 0)]
    assert np.median(inner) > r["zmin"] - 1e-3 and np.median(inner) < r["zmax"] + 1e-3
    assert np.median(nlen[hit]) == pytest.approx(1.0, abs=0.05)
    assert np.all(nlen[~hit] < 1e-6)


def test_diffuse_scene_matches_cycles(tmp_path):
    """Same scene (diffuse floor and cube, one-sided area light + point light, no world)
    in Cycles CPU and Polychrome: mean CIEDE2000 below 2. Checks the area/point light unit
    mapping, the camera and the colour pipeline against an independent renderer."""
    proc, res = run_bpy(
        tmp_path,
        """
    sc = empty_scene(48, 36)
    sc.world = None
    bpy.ops.mesh.primitive_plane_add(size=8)
    bpy.context.object.data.materials.append(diffuse_material('Floor', (0.7, 0.4, 0.2)))
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0, 0, 0.5))
    bpy.context.object.data.materials.append(diffuse_material('Cube', (0.2, 0.5, 0.7)))
    ld = bpy.data.lights.new('Area', 'AREA'); ld.energy = 300.0; ld.size = 1.5
    lo = bpy.data.objects.new('Area', ld); sc.collection.objects.link(lo); lo.location = (0.5, -0.5, 3.0)
    pd = bpy.data.lights.new('Point', 'POINT'); pd.energy = 150.0; pd.shadow_soft_size = 0.0; pd.color = (1.0, 0.9, 0.8)
    po = bpy.data.objects.new('Point', pd); sc.collection.objects.link(po); po.location = (-2.0, -1.0, 2.0)
    add_camera(sc, (4.0, -4.0, 3.0), (0, 0, 0.4), lens=35)
    A, B = cycles_and_polychrome(sc, 128)
    import polychrome.colordiff as cd
    white = float(np.percentile(A[..., 1], 99))
    de = cd.image_delta_e(A, B, white_luminance=white)
    emit(mean=float(de.mean()), err=Engine.last_error, warn=Engine.last_warnings,
         ma=A.mean(axis=(0, 1)).tolist(), mb=B.mean(axis=(0, 1)).tolist())
    """,
    )
    r = check(proc, res)[0]
    assert r["err"] is None and r["warn"] == []
    assert r["mean"] < 2.0, r
    # mean image colour within 3 % per channel (about 5 standard errors at 128 spp over 1728 pixels)
    for x, y in zip(r["ma"], r["mb"]):
        assert y == pytest.approx(x, rel=0.03)


def test_cancel_and_time_limit_stop_the_render(tmp_path):
    proc, res = run_bpy(
        tmp_path,
        """
    bpy.ops.wm.read_factory_settings()
    sc = bpy.context.scene
    sc.render.engine = 'POLYCHROME'
    sc.render.resolution_x, sc.render.resolution_y, sc.render.resolution_percentage = 64, 64, 100
    sc.polychrome.samples = 1000000
    calls = []
    def hook(done, total):
        calls.append(done)
        return True                                  # like pressing Esc at the first report
    Engine.test_break_hook = hook
    sc.render.image_settings.file_format = 'OPEN_EXR'; sc.render.filepath = os.path.abspath('c.exr')
    r1 = bpy.ops.render.render(write_still=True)
    s1 = dict(Engine.last_stats or {}); e1 = Engine.last_error
    Engine.test_break_hook = None
    sc.polychrome.time_limit = 0.3
    r2 = bpy.ops.render.render(write_still=True)
    s2 = dict(Engine.last_stats or {})
    emit(r1=list(r1), s1=s1, e1=e1, calls=len(calls), r2=list(r2), s2=s2,
         finite=bool(all(np.isfinite(v).all() for v in exr_channels('c.exr').values())))
    """,
    )
    r = check(proc, res)[0]
    assert r["r1"] == ["FINISHED"] and r["e1"] is None
    assert r["calls"] >= 1
    assert r["s1"]["cancelled"] is True and r["s1"]["samples_per_pixel"] < 1000000
    assert r["s2"]["time_limited"] is True and r["s2"]["samples_per_pixel"] < 1000000
    assert r["finite"]


def test_non_finite_vertex_is_reported_without_crash(tmp_path):
    proc, res = run_bpy(
        tmp_path,
        """
    bpy.ops.wm.read_factory_settings()
    sc = bpy.context.scene
    sc.render.engine = 'POLYCHROME'
    sc.render.resolution_x, sc.render.resolution_y, sc.render.resolution_percentage = 32, 24, 100
    bpy.data.objects['Cube'].data.vertices[0].co = (float('nan'), 0.0, 0.0)
    sc.render.image_settings.file_format = 'OPEN_EXR'       # the write_still + EXR path that can segfault
    sc.render.filepath = os.path.abspath('bad.exr')
    try:
        bpy.ops.render.render(write_still=True)
        raised = None
    except RuntimeError as e:                               # an ERROR report makes the operator raise
        raised = str(e)
    emit(raised=raised, err=Engine.last_error, exists=os.path.exists('bad.exr'))
    """,
    )
    r = check(proc, res)[0]
    assert r["err"] is not None
    assert "Cube" in r["err"] and "finite" in r["err"]
    assert r["raised"] is not None and "Cube" in r["raised"]
    assert "Polychrome ERROR" in proc.stdout


def test_unsupported_method_and_node_are_reported(tmp_path):
    proc, res = run_bpy(
        tmp_path,
        """
    from polychrome.render import METHODS
    bpy.ops.wm.read_factory_settings()
    sc = bpy.context.scene
    sc.render.engine = 'POLYCHROME'
    sc.render.resolution_x, sc.render.resolution_y, sc.render.resolution_percentage = 16, 12, 100
    sc.polychrome.samples = 2
    missing = [m for m in ('POLYCHROMATIC', 'MONOCHROMATIC_RAYS', 'MONOCHROMATIC_SCENES', 'RGB') if m not in METHODS]
    errs = {}
    for m in missing:
        sc.polychrome.method = m
        try:
            bpy.ops.render.render()
        except RuntimeError:
            pass
        errs[m] = Engine.last_error
    sc.polychrome.method = 'POLYCHROMATIC'
    # a node the exporter does not know -> grey diffuse and one warning naming material and node
    mat = bpy.data.materials['Material']
    nt = mat.node_tree
    g = nt.nodes.new('ShaderNodeBsdfToon'); g.name = 'MyToon'
    nt.links.new(g.outputs[0], nt.nodes['Material Output'].inputs['Surface'])
    bpy.ops.render.render()
    emit(errs=errs, err=Engine.last_error, warn=Engine.last_warnings)
    """,
    )
    r = check(proc, res)[0]
    for m, e in r["errs"].items():
        assert e is not None and m in e
    assert r["err"] is None
    # the startup scene's point light (radius 0.1, Soft Falloff on) warns as well
    warned = [w for w in r["warn"] if "Soft Falloff" not in w]
    assert len(warned) == 1 and "Material" in warned[0] and "MyToon" in warned[0], r["warn"]


def test_mesh_export_matches_blender_triangles_and_instances_share_data(tmp_path):
    """The split-vertex export gives the same triangle corner positions, normals and UVs
    as Blender's own loop triangles; linked instances are exported once."""
    proc, res = run_bpy(
        tmp_path,
        """
    from polychrome_blender.export.meshes import mesh_arrays
    import polychrome as pc
    from polychrome_blender.export import export_scene
    sc = empty_scene(16, 12)
    bpy.ops.mesh.primitive_uv_sphere_add(segments=12, ring_count=6)
    ob = bpy.context.object
    bpy.ops.object.shade_smooth()
    ob.data.polygons[0].use_smooth = False          # one flat face: its corners split
    mod = ob.modifiers.new('sub', 'SUBSURF'); mod.levels = 1
    # a collection instanced twice
    coll = bpy.data.collections.new('Inst'); sc.collection.children.link(coll)
    bpy.ops.mesh.primitive_cube_add(size=0.5, location=(3, 0, 0))
    cube = bpy.context.object
    for c in cube.users_collection: c.objects.unlink(cube)
    coll.objects.link(cube)
    sc.collection.children.unlink(coll)
    for x in (5.0, 7.0):
        e = bpy.data.objects.new('E%d' % x, None); e.instance_type = 'COLLECTION'; e.instance_collection = coll
        e.location = (x, 0, 0); sc.collection.objects.link(e)
    add_camera(sc, (0, -10, 0))
    dg = bpy.context.evaluated_depsgraph_get()
    ev = ob.evaluated_get(dg)
    v, t, n, uv, slot = mesh_arrays(ev, ob.name)[:5]
    me = ev.to_mesh(); me.calc_loop_triangles()
    ref_p = np.array([[tuple(me.vertices[i].co) for i in lt.vertices] for lt in me.loop_triangles])
    ref_n = np.array([[tuple(me.corner_normals[l].vector) for l in lt.loops] for lt in me.loop_triangles])
    ref_uv = np.array([[tuple(me.uv_layers.active.uv[l].vector) for l in lt.loops] for lt in me.loop_triangles])
    nv = len(me.vertices)
    ev.to_mesh_clear()
    scene, warns = export_scene(dg)
    desc, bufs = scene.description()
    emit(dp=float(np.abs(v[t.astype(int)] - ref_p).max()), dn=float(np.abs(n[t.astype(int)] - ref_n).max()),
         duv=float(np.abs(uv[t.astype(int)] - ref_uv).max()), nv=nv, split=int(len(v)),
         meshes=[m['name'] for m in desc['meshes']], inst=[i['mesh'] for i in desc['instances']])
    """,
    )
    r = check(proc, res)[0]
    assert r["dp"] < 1e-6 and r["dn"] < 1e-6 and r["duv"] < 1e-6
    assert r["split"] >= r["nv"]
    assert sorted(r["meshes"]) == ["Cube", "Sphere"]
    cube = r["meshes"].index("Cube")
    assert r["inst"].count(cube) == 2


def test_geometry_node_instances_keep_their_own_mesh(tmp_path):
    """Geometry-node instances carry the instancer's name; each must export its own
    geometry (the instanced ico sphere, not the instancer's realised mesh), shared once."""
    proc, res = run_bpy(
        tmp_path,
        """
    import polychrome as pc
    from polychrome_blender.export import export_scene
    sc = empty_scene(8, 8)
    add_camera(sc, (0, -10, 3))
    bpy.ops.mesh.primitive_plane_add(size=4)
    pl = bpy.context.object
    ng = bpy.data.node_groups.new('GN', 'GeometryNodeTree')
    ng.interface.new_socket('Geometry', in_out='INPUT', socket_type='NodeSocketGeometry')
    ng.interface.new_socket('Geometry', in_out='OUTPUT', socket_type='NodeSocketGeometry')
    gi = ng.nodes.new('NodeGroupInput'); go = ng.nodes.new('NodeGroupOutput')
    iop = ng.nodes.new('GeometryNodeInstanceOnPoints')
    ico = ng.nodes.new('GeometryNodeMeshIcoSphere'); ico.inputs['Radius'].default_value = 0.2
    cone = ng.nodes.new('GeometryNodeMeshCone')
    join = ng.nodes.new('GeometryNodeJoinGeometry')
    ng.links.new(gi.outputs[0], iop.inputs['Points']); ng.links.new(ico.outputs['Mesh'], iop.inputs['Instance'])
    ng.links.new(iop.outputs[0], join.inputs[0]); ng.links.new(cone.outputs['Mesh'], join.inputs[0])
    ng.links.new(join.outputs[0], go.inputs[0])
    pl.modifiers.new('GN', 'NODES').node_group = ng
    dg = bpy.context.evaluated_depsgraph_get()
    ref = {}
    for inst in dg.object_instances:
        if inst.object.type == 'MESH':
            ref.setdefault(inst.is_instance, set()).add(len(inst.object.data.vertices))
    scene, warns = export_scene(dg)
    desc, bufs = scene.description()
    nverts = [len(np.unique(bufs[m['triangles']])) for m in desc['meshes']]
    emit(inst=[i['mesh'] for i in desc['instances']], nverts=nverts, ref_inst=sorted(ref[True]), ref_base=sorted(ref[False]))
    """,
    )
    r = check(proc, res)[0]
    from collections import Counter

    assert r["ref_inst"] == [12] and len(r["nverts"]) == 2  # ico sphere + the instancer's realised mesh
    counts = Counter(r["inst"])
    shared = [m for m, c in counts.items() if c == 4]  # one per plane vertex, sharing one mesh
    base = [m for m, c in counts.items() if c == 1]
    assert len(shared) == 1 and len(base) == 1, r
    assert r["nverts"][shared[0]] in (12, 60)  # 12 vertices, or 20 flat faces × 3 split
    assert r["nverts"][base[0]] not in (12, 60)


def test_border_render_places_the_region(tmp_path):
    """Border render, cropped and not: the region's pixels sit where Blender puts the
    border (x 0.25-0.75, y 0-0.5 from the bottom) and equal the whole frame's pixels
    there (same seed); outside an uncropped border Blender leaves zeros."""
    proc, res = run_bpy(
        tmp_path,
        """
    bpy.ops.wm.read_factory_settings()
    sc = bpy.context.scene; r = sc.render
    r.engine = 'POLYCHROME'; r.resolution_x, r.resolution_y, r.resolution_percentage = 64, 48, 100
    sc.polychrome.samples = 4
    r.image_settings.file_format = 'OPEN_EXR'
    r.filepath = os.path.abspath('full.exr'); bpy.ops.render.render(write_still=True)
    r.use_border = True
    r.border_min_x, r.border_max_x, r.border_min_y, r.border_max_y = 0.25, 0.75, 0.0, 0.5
    out = {}
    for crop in (False, True):
        r.use_crop_to_border = crop
        r.filepath = os.path.abspath(f'b{int(crop)}.exr'); bpy.ops.render.render(write_still=True)
        out[f'err{int(crop)}'] = Engine.last_error
    full, b0, b1 = (exr_channels(p)['G'] for p in ('full.exr', 'b0.exr', 'b1.exr'))
    region = full[24:48, 16:48]                      # file rows start at the top
    outside = b0.copy(); outside[24:48, 16:48] = 0
    emit(shape0=list(b0.shape), shape1=list(b1.shape), d_crop=float(np.abs(b1 - region).max()),
         d_uncrop=float(np.abs(b0[24:48, 16:48] - region).max()), outside=float(np.abs(outside).max()),
         region_mean=float(region.mean()), **out)
    """,
    )
    r = check(proc, res)[0]
    assert r["err0"] is None and r["err1"] is None
    assert r["shape0"] == [48, 64] and r["shape1"] == [24, 32]
    assert r["region_mean"] > 0
    assert r["d_crop"] < 1e-6 and r["d_uncrop"] < 1e-6 and r["outside"] == 0.0


def test_emissive_mesh_with_blackbody_matches_cycles(tmp_path):
    """A mesh light (Emission shader, strength 30, Blackbody 4000 K) in Cycles CPU and
    Polychrome: same emission units (radiance = strength × colour, both faces) and the
    same luminance normalisation of Blackbody. The colours may differ slightly — Cycles
    multiplies RGB, Polychrome spectra (the paper's point) — so mean ΔE00 < 2 and mean
    luminance within 5 %."""
    proc, res = run_bpy(
        tmp_path,
        """
    sc = empty_scene(48, 36)
    sc.world = None
    bpy.ops.mesh.primitive_plane_add(size=8)
    bpy.context.object.data.materials.append(diffuse_material('Floor', (0.7, 0.4, 0.2)))
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0, 0, 0.5))
    bpy.context.object.data.materials.append(diffuse_material('Cube', (0.2, 0.5, 0.7)))
    bpy.ops.mesh.primitive_plane_add(size=1.0, location=(0.5, -0.5, 3.0))
    lamp = bpy.context.object
    m = bpy.data.materials.new('Lamp'); m.use_nodes = True; nt = m.node_tree
    for n in list(nt.nodes):
        if n.type != 'OUTPUT_MATERIAL': nt.nodes.remove(n)
    e = nt.nodes.new('ShaderNodeEmission'); e.inputs['Strength'].default_value = 30.0
    bb = nt.nodes.new('ShaderNodeBlackbody'); bb.inputs['Temperature'].default_value = 4000.0
    nt.links.new(bb.outputs[0], e.inputs['Color'])
    nt.links.new(e.outputs[0], nt.nodes['Material Output'].inputs['Surface'])
    lamp.data.materials.append(m)
    add_camera(sc, (4.0, -4.0, 3.0), (0, 0, 0.4), lens=35)
    A, B = cycles_and_polychrome(sc, 128)
    import polychrome.colordiff as cd
    de = cd.image_delta_e(A, B, white_luminance=float(np.percentile(A[..., 1], 99)))
    emit(mean=float(de.mean()), err=Engine.last_error, warn=Engine.last_warnings,
         ya=float((A.mean(axis=(0, 1)) @ [0.2126, 0.7152, 0.0722])), yb=float((B.mean(axis=(0, 1)) @ [0.2126, 0.7152, 0.0722])))
    """,
    )
    r = check(proc, res)[0]
    assert r["err"] is None and r["warn"] == []
    assert r["mean"] < 2.0, r
    assert r["yb"] == pytest.approx(r["ya"], rel=0.05), r


def test_settings_reach_the_core_and_seed_is_deterministic(tmp_path):
    proc, res = run_bpy(
        tmp_path,
        """
    bpy.ops.wm.read_factory_settings()
    sc = bpy.context.scene; p = sc.polychrome
    sc.render.engine = 'POLYCHROME'
    sc.render.resolution_x, sc.render.resolution_y, sc.render.resolution_percentage = 40, 30, 50
    p.method = 'MONOCHROMATIC_RAYS'; p.wavelength_count = 16; p.samples = 3; p.max_bounces = 2; p.threads = 1
    sc.render.image_settings.file_format = 'OPEN_EXR'
    imgs, stats = [], []
    for i, seed in enumerate((5, 5, 6)):
        p.seed = seed
        sc.render.filepath = os.path.abspath(f's{i}.exr'); bpy.ops.render.render(write_still=True)
        imgs.append(exr_channels(f's{i}.exr')['R']); stats.append(Engine.last_stats)
    emit(stats=stats[0], shape=list(imgs[0].shape), same=float(np.abs(imgs[0] - imgs[1]).max()),
         diff=float(np.abs(imgs[0] - imgs[2]).max()))
    """,
    )
    r = check(proc, res)[0]
    s = r["stats"]
    assert s["method"] == "MONOCHROMATIC_RAYS" and s["wavelengths"] == 16 and s["samples_per_pixel"] == 3
    assert s["threads"] == 1
    assert r["shape"] == [15, 20]  # resolution × 50 %
    assert r["same"] == 0.0 and r["diff"] > 0.0


def test_spectral_passes_integrate_to_the_combined_pass(tmp_path):
    """With spectral_output, the multilayer EXR holds one pass per wavelength; integrating
    them with colour-science's CIE 1931 CMFs (trapezoid weights, normalised by ∫ȳ as the
    core does) gives the Combined pass's luminance."""
    proc, res = run_bpy(
        tmp_path,
        """
    bpy.ops.wm.read_factory_settings()
    sc = bpy.context.scene; p = sc.polychrome
    sc.render.engine = 'POLYCHROME'
    sc.render.resolution_x, sc.render.resolution_y, sc.render.resolution_percentage = 24, 18, 100
    p.samples = 4; p.wavelength_count = 21; p.spectral_output = True
    sc.render.image_settings.file_format = 'OPEN_EXR_MULTILAYER'; sc.render.filepath = os.path.abspath('spec.exr')
    bpy.ops.render.render(write_still=True)
    ch = exr_channels('spec.exr')
    names = sorted((k for k in ch if k.startswith('ViewLayer.Spectral ')), key=lambda k: float(k.split()[1]))
    emit(err=Engine.last_error, names=names, bands=[ch[k].tolist() for k in names],
         rgb=[ch['ViewLayer.Combined.' + c].tolist() for c in 'RGB'])
    """,
    )
    r = check(proc, res)[0]
    assert r["err"] is None
    assert len(r["names"]) == 21 and r["names"][0] == "ViewLayer.Spectral 380.0 nm.V" and r["names"][-1] == "ViewLayer.Spectral 780.0 nm.V"
    colour = pytest.importorskip("colour")
    import numpy as np

    lam = np.linspace(380.0, 780.0, 21)
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    ybar = np.array([cmfs[l][1] for l in lam])
    w = np.full(21, lam[1] - lam[0])
    w[0] = w[-1] = (lam[1] - lam[0]) / 2  # eq. 6 weights
    bands = np.array(r["bands"])  # (21, H, W)
    y_spec = np.tensordot(ybar * w, bands, axes=1) / np.sum(ybar * w)
    rgb = np.array(r["rgb"])
    y_rgb = 0.2126729 * rgb[0] + 0.7151522 * rgb[1] + 0.0721750 * rgb[2]
    assert y_rgb.mean() > 0
    assert np.allclose(y_spec, y_rgb, rtol=0.02, atol=1e-4), float(np.abs(y_spec - y_rgb).max())


def test_material_slots_loose_vertices_and_empty_meshes(tmp_path):
    proc, res = run_bpy(
        tmp_path,
        """
    import polychrome as pc
    from polychrome_blender.export import export_scene
    sc = empty_scene(8, 8)
    add_camera(sc, (0, -10, 0))
    me = bpy.data.meshes.new('Two')
    me.from_pydata([(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (2, 0, 0), (2, 1, 0), (9, 9, 9)], [],
                   [(0, 1, 2, 3), (1, 4, 5, 2)])          # vertex 6 is loose
    me.polygons[1].material_index = 1
    ob = bpy.data.objects.new('Two', me); sc.collection.objects.link(ob)
    me.materials.append(diffuse_material('Red', (0.8, 0.1, 0.1)))
    me.materials.append(diffuse_material('Blue', (0.1, 0.1, 0.8)))
    e = bpy.data.objects.new('Empty', bpy.data.meshes.new('Empty')); sc.collection.objects.link(e)
    n = bpy.data.objects.new('NoMat', bpy.data.meshes.new('NoMat')); sc.collection.objects.link(n)
    n.data.from_pydata([(0, 0, 1), (1, 0, 1), (0, 1, 1)], [], [(0, 1, 2)])
    scene, warns = export_scene(bpy.context.evaluated_depsgraph_get())
    desc, bufs = scene.description()
    mats = [m['name'] for m in desc['materials']]
    meshes = {m['name']: m for m in desc['meshes']}
    two = meshes['Two']
    emit(mats=mats, ids=[mats[i] for i in bufs[two['material_ids']].tolist()],
         nverts=len(bufs[two['vertices']]) // 3, verts=bufs[two['vertices']].reshape(-1, 3).tolist(),
         names=sorted(meshes), nomat=mats[int(bufs[meshes['NoMat']['material_ids']][0])], warns=warns)
    """,
    )
    r = check(proc, res)[0]
    assert r["ids"] == ["Red", "Red", "Blue", "Blue"]
    assert r["nverts"] == 6 and [9.0, 9.0, 9.0] not in r["verts"]  # the loose vertex is dropped
    assert r["names"] == ["NoMat", "Two"]  # the empty mesh is skipped
    assert r["nomat"] == "default" and r["warns"] == []


def test_mesh_export_matches_blender_corners_on_awkward_faces(tmp_path):
    """Against a plain-Python walk over Blender's loop triangles: concave, degenerate and
    non-planar quads, an n-gon, flat and smooth faces, custom normals, the render UV map
    (not the active one) and per-face material slots; loose vertices are dropped."""
    proc, res = run_bpy(
        tmp_path,
        """
    from polychrome_blender.export.meshes import mesh_arrays
    sc = empty_scene(8, 8)
    me = bpy.data.meshes.new('Awkward')
    verts = [(0, 0, 0), (2, 0, 0), (0.5, 0.5, 0), (0, 2, 0),            # concave quad (dart)
             (3, 0, 0), (4, 0, 0), (4, 0, 0), (3, 1, 0),                # degenerate quad (two equal corners)
             (5, 0, 0), (6, 0, 1), (6, 1, 0), (5, 1, 1),                # non-planar quad
             (7, 0, 0), (8, 0, 0), (8.5, 1, 0), (7.5, 1.8, 0.2), (6.8, 1, 0),  # pentagon
             (0, 0, 3), (1, 0, 3), (0, 1, 3),                          # triangle
             (9, 9, 9), (9, 9, 8)]                                      # loose
    me.from_pydata(verts, [], [(0, 1, 2, 3), (4, 5, 6, 7), (8, 9, 10, 11), (12, 13, 14, 15, 16), (17, 18, 19),
                               (1, 4, 7, 2)])
    for i, p in enumerate(me.polygons):
        p.material_index = i % 3
        p.use_smooth = i % 2 == 0
    for n in ('A', 'B', 'C'):
        me.materials.append(bpy.data.materials.new(n))
    rng = np.random.default_rng(7)
    a = me.uv_layers.new(name='Active'); r = me.uv_layers.new(name='Render')
    for layer in (a, r):
        for d in layer.uv: d.vector = tuple(rng.random(2))
    me.uv_layers.active = a; r.active_render = True
    custom = rng.normal(size=(len(me.loops), 3))
    custom[:4] = (0, 0, 1)   # shared by the concave quad's corners
    me.normals_split_custom_set([tuple(v / np.linalg.norm(v)) for v in custom])
    ob = bpy.data.objects.new('Awkward', me); sc.collection.objects.link(ob)
    dg = bpy.context.evaluated_depsgraph_get(); ev = ob.evaluated_get(dg)
    out = mesh_arrays(ev, ob.name)
    em = ev.to_mesh(); em.calc_loop_triangles()
    uvl = em.uv_layers['Render'].uv
    ref = dict(
        p=[[list(em.vertices[i].co) for i in lt.vertices] for lt in em.loop_triangles],
        n=[[list(em.corner_normals[l].vector) for l in lt.loops] for lt in em.loop_triangles],
        uv=[[list(uvl[l].vector) for l in lt.loops] for lt in em.loop_triangles],
        slot=[lt.material_index for lt in em.loop_triangles],
    )
    ev.to_mesh_clear()
    t = out.triangles.astype(int)
    emit(p=out.vertices[t].tolist(), n=out.normals[t].tolist(), uv=out.uvs[t].tolist(), slot=out.tri_slot.tolist(),
         dtype=str(out.triangles.dtype), nv=len(out.vertices), used=len(set(t.ravel().tolist())), ref=ref)
    """,
    )
    r = check(proc, res)[0]
    ref = r["ref"]
    for k in ("p", "n", "uv"):
        assert np.abs(np.array(r[k]) - np.array(ref[k])).max() < 1e-6, k
    assert r["slot"] == ref["slot"] == [i % 3 for i, k in enumerate((4, 4, 4, 5, 3, 4)) for _ in range(k - 2)]
    assert r["dtype"] == "uint32" and r["used"] == r["nv"]  # every exported vertex is used: loose ones dropped
