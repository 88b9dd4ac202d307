"""Ray visibility against Cycles in the same bpy process: an area light between the
camera and the scene (lights are invisible to camera rays by default), a wall in front of the camera that camera rays do not see, and a
card over the floor that shadow rays do not see. Polychrome and Cycles CPU render the
same scene; the mean CIEDE2000 on 2 × 2 blocks must stay below 2 (colour-science), and
the same scene with every ray seeing every object must differ from Cycles by far more."""

import pytest

from .bhelper import check, run_bpy

pytestmark = pytest.mark.blender


def test_ray_visibility_matches_cycles(tmp_path):
    proc, res = run_bpy(
        tmp_path,
        """
    from mathutils import Vector
    sc = empty_scene(32, 24); sc.world = None
    bpy.ops.mesh.primitive_plane_add(size=10)
    bpy.context.object.data.materials.append(diffuse_material('Floor', (0.7, 0.6, 0.5)))
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0, 0, 0.5))
    bpy.context.object.data.materials.append(diffuse_material('Cube', (0.2, 0.5, 0.7)))
    # a wall right in front of the camera, invisible to camera rays
    bpy.ops.mesh.primitive_plane_add(size=1.5, location=(3.0, -3.3, 2.3), rotation=(math.radians(60), 0, math.radians(45)))
    wall = bpy.context.object; wall.data.materials.append(diffuse_material('Wall', (0.9, 0.1, 0.1)))
    wall.visible_camera = False
    # a card over the floor, invisible to shadow rays
    bpy.ops.mesh.primitive_plane_add(size=1.2, location=(-1.5, 1.0, 1.5))
    card = bpy.context.object; card.data.materials.append(diffuse_material('Card', (0.8, 0.8, 0.8)))
    card.visible_shadow = False
    sun = bpy.data.lights.new('Sun', 'SUN'); sun.energy = 3.0; sun.angle = 0.0
    so = bpy.data.objects.new('Sun', sun); sc.collection.objects.link(so); so.rotation_euler = (math.radians(20), 0, math.radians(30))
    # an area light between the camera and the cube, facing the cube (camera rays pass through it)
    ld = bpy.data.lights.new('Panel', 'AREA'); ld.energy = 60.0; ld.size = 1.0
    lo = bpy.data.objects.new('Panel', ld); sc.collection.objects.link(lo); lo.location = (1.8, -1.8, 1.2)
    lo.rotation_euler = (Vector((0, 0, 0.5)) - lo.location).to_track_quat('-Z', 'Y').to_euler()
    add_camera(sc, (4.0, -4.0, 3.0), (0, 0, 0.4), lens=35)
    sc.render.image_settings.file_format = 'OPEN_EXR'
    c = sc.cycles; c.device = 'CPU'; c.samples = 64; c.use_denoising = False; c.use_adaptive_sampling = False
    c.filter_width = 0.01; c.max_bounces = 4; c.diffuse_bounces = 4
    c.sample_clamp_indirect = 0.0; c.sample_clamp_direct = 0.0
    sc.polychrome.samples = 64; sc.polychrome.max_bounces = 4
    cycles = render_rgb(sc, 'CYCLES', 'cycles')
    poly = render_rgb(sc, 'POLYCHROME', 'poly')
    out = dict(de=mean_de00(cycles, poly, 2), err=Engine.last_error, warn=Engine.last_warnings)
    # every ray sees everything: the panel, its backing and the wall block the view
    for ob in (wall, card, lo):
        for k in ('camera', 'shadow'):
            setattr(ob, 'visible_' + k, True)
    out['de_all_visible'] = mean_de00(cycles, render_rgb(sc, 'POLYCHROME', 'poly_all'), 2)
    emit(**out)
    """,
        timeout=400,
    )
    r = check(proc, res)[0]
    assert r["err"] is None and r["warn"] == [], r
    assert r["de"] < 2.0, r
    assert r["de_all_visible"] > 3.0 * max(r["de"], 1.0), r


def test_diffuse_and_glossy_visibility_match_cycles(tmp_path):
    """A cube invisible to glossy rays in front of a rough mirror (Glossy BSDF), and a
    point light invisible to diffuse rays over a diffuse floor (it still shows in the
    mirror), beside a sun every ray sees: Cycles CPU and Polychrome render the same scene;
    mean CIEDE2000 on 2 × 2 blocks below 2, and far above it when every ray sees all."""
    proc, res = run_bpy(
        tmp_path,
        """
    sc = empty_scene(32, 24); sc.world = None
    bpy.ops.mesh.primitive_plane_add(size=10)
    bpy.context.object.data.materials.append(diffuse_material('Floor', (0.7, 0.6, 0.5)))
    bpy.ops.mesh.primitive_plane_add(size=3.0, location=(0, 1.5, 1.5), rotation=(math.radians(90), 0, 0))
    mirror = bpy.data.materials.new('Mirror'); mirror.use_nodes = True
    nt = mirror.node_tree
    for n in list(nt.nodes):
        if n.type != 'OUTPUT_MATERIAL': nt.nodes.remove(n)
    g = nt.nodes.new('ShaderNodeBsdfGlossy'); g.inputs['Color'].default_value = (0.9, 0.9, 0.9, 1.0)
    g.inputs['Roughness'].default_value = 0.4
    nt.links.new(g.outputs['BSDF'], nt.nodes['Material Output'].inputs['Surface'])
    bpy.context.object.data.materials.append(mirror)
    bpy.ops.mesh.primitive_cube_add(size=0.8, location=(0.3, 0.0, 0.4))
    cube = bpy.context.object; cube.data.materials.append(diffuse_material('Cube', (0.2, 0.5, 0.7)))
    cube.visible_glossy = False
    sun = bpy.data.lights.new('Sun', 'SUN'); sun.energy = 2.0; sun.angle = 0.0
    so = bpy.data.objects.new('Sun', sun); sc.collection.objects.link(so); so.rotation_euler = (math.radians(30), 0, math.radians(200))
    lamp = bpy.data.lights.new('Lamp', 'POINT'); lamp.energy = 300.0; lamp.shadow_soft_size = 0.0
    lo = bpy.data.objects.new('Lamp', lamp); sc.collection.objects.link(lo); lo.location = (-1.0, -0.5, 1.5)
    lo.visible_diffuse = False
    add_camera(sc, (1.5, -5.0, 2.0), (0, 0.5, 0.8), lens=30)
    sc.render.image_settings.file_format = 'OPEN_EXR'
    c = sc.cycles; c.device = 'CPU'; c.samples = 128; c.use_denoising = False; c.use_adaptive_sampling = False
    c.filter_width = 0.01; c.max_bounces = 4; c.diffuse_bounces = 4; c.glossy_bounces = 4
    c.sample_clamp_indirect = 0.0; c.sample_clamp_direct = 0.0
    sc.polychrome.samples = 128; sc.polychrome.max_bounces = 4
    cycles = render_rgb(sc, 'CYCLES', 'cycles')
    poly = render_rgb(sc, 'POLYCHROME', 'poly')
    out = dict(de=mean_de00(cycles, poly, 2), err=Engine.last_error, warn=Engine.last_warnings)
    cube.visible_glossy = True; lo.visible_diffuse = True
    out['de_all_visible'] = mean_de00(cycles, render_rgb(sc, 'POLYCHROME', 'poly_all'), 2)
    emit(**out)
    """,
        timeout=400,
    )
    r = check(proc, res)[0]
    print(r)
    assert r["err"] is None, r
    assert sorted(w.split(":")[0] for w in r["warn"]) == ["light 'Lamp'", "object 'Cube'"], r
    assert r["de"] < 2.0, r
    assert r["de_all_visible"] > 3.0 * max(r["de"], 1.0), r
