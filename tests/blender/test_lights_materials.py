"""Spot and sun lights against closed forms, and the BSDF types the exporter chooses for
Blender's standard nodes (checked on the exported description)."""

import math

import numpy as np
import pytest

from .bhelper import check, run_bpy

pytestmark = pytest.mark.blender


def test_sun_and_spot_light_units(tmp_path):
    proc, res = run_bpy(
        tmp_path,
        """
    import polychrome as pc
    if not (hasattr(pc, 'SunLight') and hasattr(pc, 'SpotLight')):
        emit(skip='no SunLight/SpotLight'); raise SystemExit(0)
    sc = empty_scene(16, 16); sc.world = None
    sc.render.engine = 'POLYCHROME'; sc.polychrome.samples = 16
    bpy.ops.mesh.primitive_plane_add(size=40)
    bpy.context.object.data.materials.append(diffuse_material('Grey', (0.5, 0.5, 0.5)))
    cd = bpy.data.cameras.new('C'); cd.type = 'ORTHO'; cd.ortho_scale = 0.2
    cam = bpy.data.objects.new('C', cd); sc.collection.objects.link(cam); sc.camera = cam; cam.location = (0, 0, 1)
    sc.render.image_settings.file_format = 'OPEN_EXR'
    out = {}
    sun = bpy.data.lights.new('Sun', 'SUN'); sun.energy = 3.0; sun.angle = 0.0
    so = bpy.data.objects.new('Sun', sun); sc.collection.objects.link(so)
    so.rotation_euler = (math.radians(30), 0, 0)          # 30° from the zenith
    sc.render.filepath = os.path.abspath('sun.exr'); bpy.ops.render.render(write_still=True)
    out['sun'] = [float(exr_channels('sun.exr')[c].mean()) for c in 'RGB']; out['e_sun'] = Engine.last_error
    bpy.data.objects.remove(so)
    spot = bpy.data.lights.new('Spot', 'SPOT'); spot.energy = 200.0; spot.shadow_soft_size = 0.0
    spot.spot_size = math.radians(60); spot.spot_blend = 0.0
    sp = bpy.data.objects.new('Spot', spot); sc.collection.objects.link(sp); sp.location = (0, 0, 2.0)
    sc.render.filepath = os.path.abspath('spot.exr'); bpy.ops.render.render(write_still=True)
    out['spot'] = [float(exr_channels('spot.exr')[c].mean()) for c in 'RGB']; out['e_spot'] = Engine.last_error
    emit(**out)
    """,
    )
    r = check(proc, res)[0]
    if "skip" in r:
        pytest.skip(r["skip"])
    assert r["e_sun"] is None and r["e_spot"] is None
    # sun: L = ρ E cosθ / π with E = 3 W/m²; spot on its axis: E = P / (4π d²)
    sun = 0.5 * 3.0 * math.cos(math.radians(30)) / math.pi
    spot = 0.5 * (200.0 / (4 * math.pi * 2.0**2)) / math.pi
    assert np.allclose(r["sun"], sun, rtol=0.03), (r["sun"], sun)
    assert np.allclose(r["spot"], spot, rtol=0.03), (r["spot"], spot)


def test_standard_nodes_map_to_polychrome_bsdfs(tmp_path):
    proc, res = run_bpy(
        tmp_path,
        """
    import polychrome as pc
    from polychrome_blender.export import export_scene, materials
    materials.GRAPHS = False  # the fixed-pattern export (node graphs: test_node_graph.py, test_node_oracle.py)
    sc = empty_scene(8, 8)
    add_camera(sc, (0, -5, 0))
    def mat_with(name, idname, **inputs):
        m = bpy.data.materials.new(name); m.use_nodes = True; nt = m.node_tree
        for n in list(nt.nodes):
            if n.type != 'OUTPUT_MATERIAL': nt.nodes.remove(n)
        n = nt.nodes.new(idname)
        for k, v in inputs.items(): n.inputs[k].default_value = v
        nt.links.new(n.outputs[0], nt.nodes['Material Output'].inputs['Surface'])
        return m, n
    mats = [
        mat_with('Glass', 'ShaderNodeBsdfGlass', IOR=1.33)[0],
        mat_with('Gloss', 'ShaderNodeBsdfGlossy', Roughness=0.3)[0],
        mat_with('Metal', 'ShaderNodeBsdfPrincipled', Metallic=1.0)[0],
        mat_with('Clear', 'ShaderNodeBsdfPrincipled', **{'Transmission Weight': 1.0, 'IOR': 1.45})[0],
        mat_with('Paint', 'ShaderNodeBsdfPrincipled', **{'Base Color': (0.2, 0.3, 0.4, 1.0)})[0],
    ]
    m, em = mat_with('Warm', 'ShaderNodeEmission', Strength=2.0)
    bb = m.node_tree.nodes.new('ShaderNodeBlackbody'); bb.inputs['Temperature'].default_value = 3000.0
    m.node_tree.links.new(bb.outputs[0], em.inputs['Color']); mats.append(m)
    d, dn = mat_with('Prism', 'PolychromeDispersionNode'); dn.model = 'NAMED'; dn.named = 'N_SF11'; mats.append(d)
    for i, mat in enumerate(mats):
        bpy.ops.mesh.primitive_cube_add(size=0.5, location=(i - 3, 0, 0))
        bpy.context.object.data.materials.append(mat)
    dg = bpy.context.evaluated_depsgraph_get()
    scene, warns = export_scene(dg)
    desc, _ = scene.description()
    emit(m={x['name']: x for x in desc['materials']}, warns=warns)
    """,
    )
    r = check(proc, res)[0]
    m = r["m"]
    assert r["warns"] == []
    assert m["Glass"]["bsdf"]["type"] == "dielectric"
    assert m["Glass"]["bsdf"]["ior"] == {"type": "constant", "ior": pytest.approx(1.33)}
    assert m["Gloss"]["bsdf"] == {"type": "glossy", "reflectance": m["Gloss"]["bsdf"]["reflectance"], "roughness": pytest.approx(0.3)}
    # Principled BSDFs map to polychrome.Principled with their lobe weights
    # (tests/blender/test_principled_mix.py checks the mapping in detail).
    assert m["Metal"]["bsdf"]["type"] == "principled" and m["Metal"]["bsdf"]["metallic"] == 1.0
    assert m["Clear"]["bsdf"]["type"] == "principled" and m["Clear"]["bsdf"]["transmission"] == 1.0
    assert m["Clear"]["bsdf"]["ior"] == {"type": "constant", "ior": pytest.approx(1.45)}
    assert m["Paint"]["bsdf"]["type"] == "principled"
    assert m["Paint"]["bsdf"]["base_color"]["rgb"] == pytest.approx([0.2, 0.3, 0.4])
    warm = m["Warm"]["emission"]
    assert warm["type"] == "blackbody" and warm["temperature"] == 3000.0
    # luminance of the exported blackbody = Emission strength (Cycles normalises Blackbody
    # to luminance 1); checked with colour-science's Planck law and CIE 1931 ȳ
    colour = pytest.importorskip("colour")
    shape = colour.SpectralShape(380, 780, 1)
    sd = colour.sd_blackbody(3000.0, shape)
    ybar = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"].copy().align(shape).values[:, 1]
    peak = colour.sd_blackbody(3000.0, colour.SpectralShape(380, 3000, 1)).values.max()  # Wien peak 966 nm
    planck = sd.values / peak
    luminance = warm["scale"] * np.trapz(ybar * planck) / np.trapz(ybar)
    assert luminance == pytest.approx(2.0, rel=0.01)
    assert m["Prism"]["bsdf"]["type"] == "dielectric" and m["Prism"]["bsdf"]["ior"]["name"] == "N-SF11"


def test_area_light_radiance_follows_cycles_convention(tmp_path):
    """Exported emitter radiance = P / (π A) (Normalize on) or P / π (off), A the true area of
    the square / rectangle / disk / ellipse (the 32-gon's area, so the power is exact)."""
    proc, res = run_bpy(
        tmp_path,
        """
    import polychrome as pc
    from polychrome_blender.export import export_scene
    sc = empty_scene(8, 8); add_camera(sc, (0, -10, 0))
    cases = [('SQUARE', 2.0, 1.0, True), ('RECTANGLE', 2.0, 0.5, True), ('DISK', 1.0, 1.0, True),
             ('ELLIPSE', 2.0, 1.0, True), ('SQUARE', 2.0, 1.0, False)]
    for i, (shape, sx, sy, norm) in enumerate(cases):
        ld = bpy.data.lights.new(f'L{i}', 'AREA'); ld.shape = shape; ld.size = sx; ld.size_y = sy
        ld.energy = 100.0; ld.normalize = norm
        o = bpy.data.objects.new(f'L{i}', ld); sc.collection.objects.link(o); o.location = (3 * i, 0, 3)
    scene, warns = export_scene(bpy.context.evaluated_depsgraph_get())
    desc, bufs = scene.description()
    out = {}
    for m in desc['materials']:
        if m['name'].endswith('(area light)'):
            out[m['name'].split()[0]] = m['emission']['scale']
    areas = {}
    for mesh in desc['meshes']:
        if mesh['name'].startswith('L') and '(back)' not in mesh['name']:
            v = bufs[mesh['vertices']].reshape(-1, 3).astype(float); t = bufs[mesh['triangles']].reshape(-1, 3)
            areas[mesh['name']] = float(0.5 * np.linalg.norm(np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]]), axis=1).sum())
    emit(scale=out, areas=areas, warns=warns, cases=cases)
    """,
    )
    r = check(proc, res)[0]
    assert r["warns"] == []
    exact = [4.0, 1.0, math.pi / 4, math.pi / 2, 4.0]
    for i, (shape, _sx, _sy, norm) in enumerate(r["cases"]):
        area = r["areas"][f"L{i}"]
        assert area == pytest.approx(exact[i], rel=0.01 if shape in ("DISK", "ELLIPSE") else 1e-6)
        want = 100.0 / (math.pi * (area if norm else 1.0))
        assert r["scale"][f"L{i}"] == pytest.approx(want, rel=1e-6), (shape, norm)


def test_light_exposure_and_temperature(tmp_path):
    proc, res = run_bpy(
        tmp_path,
        """
    import polychrome as pc
    from polychrome_blender.export import export_scene
    sc = empty_scene(8, 8); add_camera(sc, (0, -10, 0))
    ld = bpy.data.lights.new('P', 'POINT'); ld.energy = 100.0; ld.exposure = 1.5
    ld.use_temperature = True; ld.temperature = 2700.0
    o = bpy.data.objects.new('P', ld); sc.collection.objects.link(o)
    scene, warns = export_scene(bpy.context.evaluated_depsgraph_get())
    desc, _ = scene.description()
    emit(light=desc['lights'][0], warns=warns)
    """,
    )
    r = check(proc, res)[0]
    i = r["light"]["intensity"]
    assert r["warns"] == [] and i["type"] == "blackbody" and i["temperature"] == 2700.0
    # intensity = luminance-1 blackbody × P 2^exposure / 4π: the scale over the luminance-1 factor
    colour = pytest.importorskip("colour")
    shape = colour.SpectralShape(380, 780, 1)
    peak = colour.sd_blackbody(2700.0, colour.SpectralShape(380, 3000, 1)).values.max()
    planck = colour.sd_blackbody(2700.0, shape).values / peak
    ybar = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"].copy().align(shape).values[:, 1]
    lum = np.trapz(ybar * planck) / np.trapz(ybar)
    assert i["scale"] * lum == pytest.approx(100.0 * 2**1.5 / (4 * math.pi), rel=0.01)
