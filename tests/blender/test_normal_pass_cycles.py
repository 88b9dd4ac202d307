"""The Normal pass of a normal-mapped sphere against Cycles' (docs/shading.md, "Normal
Map and Bump", Normal pass): Cycles writes the closures' average normal — the Normal
Map's — and so does Polychrome. A smooth UV sphere (poles on the silhouette) whose
Normal is a tangent-space Normal Map of a procedural colour (MikkTSpace tangents from
Blender), seen by an orthographic camera, 16 spp with a 1-pixel box filter in both, the
Normal passes read from a multilayer EXR. On the pixels whose 3 × 3 neighbourhood sees
the sphere in Cycles, the mean angle between the passes must stay under 1° with a
Glossy BSDF and 2° with a Principled one (whose diffuse lobe Cycles keeps on the unbent
normal), and the sphere with the Normal unlinked must be more than 4× further."""

import pytest

from .bhelper import check, run_bpy

pytestmark = pytest.mark.blender


def test_normal_pass_of_a_normal_mapped_sphere_matches_cycles(tmp_path):
    proc, res = run_bpy(
        tmp_path,
        """
    sc = empty_scene(40, 40)
    sc.world = bpy.data.worlds.new('W'); sc.world.use_nodes = True
    ld = bpy.data.lights.new('Sun', 'SUN'); ld.energy = 3.0
    sun = bpy.data.objects.new('Sun', ld); sc.collection.objects.link(sun)
    cd = bpy.data.cameras.new('C'); cd.type = 'ORTHO'; cd.ortho_scale = 2.3
    cam = bpy.data.objects.new('C', cd); sc.collection.objects.link(cam); sc.camera = cam; cam.location = (0, 0, 5)
    # The poles (where the UV map's tangents are degenerate) on the silhouette.
    bpy.ops.mesh.primitive_uv_sphere_add(radius=1.0, segments=64, ring_count=32, rotation=(math.pi / 2, 0, 0))
    bpy.ops.object.shade_smooth()
    ob = bpy.context.object
    m = bpy.data.materials.new('Mapped'); m.use_nodes = True; nt = m.node_tree
    out = nt.nodes['Material Output']
    principled = nt.nodes['Principled BSDF']; principled.inputs['Roughness'].default_value = 0.5
    glossy = nt.nodes.new('ShaderNodeBsdfAnisotropic'); glossy.inputs['Roughness'].default_value = 0.5
    ob.data.materials.append(m)
    noise = nt.nodes.new('ShaderNodeTexNoise'); noise.inputs['Scale'].default_value = 2.0
    uv = nt.nodes.new('ShaderNodeUVMap'); uv.uv_map = 'UVMap'
    mapping = nt.nodes.new('ShaderNodeMapping'); mapping.inputs['Scale'].default_value = (4.0, 2.0, 1.0)
    nt.links.new(uv.outputs['UV'], mapping.inputs['Vector']); nt.links.new(mapping.outputs['Vector'], noise.inputs['Vector'])
    mix = nt.nodes.new('ShaderNodeMix'); mix.data_type = 'RGBA'
    mix.inputs['Factor'].default_value = 0.6
    mix.inputs['A'].default_value = (0.5, 0.5, 1.0, 1.0)
    nt.links.new(noise.outputs['Color'], mix.inputs['B'])
    nm = nt.nodes.new('ShaderNodeNormalMap'); nm.space = 'TANGENT'; nm.uv_map = 'UVMap'
    nt.links.new(mix.outputs['Result'], nm.inputs['Color'])

    sc.view_layers[0].use_pass_normal = True
    c = sc.cycles; c.device = 'CPU'; c.samples = 16; c.use_denoising = False; c.use_adaptive_sampling = False
    c.pixel_filter_type = 'BOX'; c.filter_width = 1.0; c.max_bounces = 1  # Polychrome's 1-pixel box
    sc.polychrome.samples = 16; sc.polychrome.max_bounces = 1
    sc.render.image_settings.file_format = 'OPEN_EXR_MULTILAYER'

    def normal_pass(engine, tag):
        sc.render.engine = engine
        sc.render.filepath = os.path.abspath(tag + '.exr'); bpy.ops.render.render(write_still=True)
        ch = exr_channels(tag + '.exr')
        return np.stack([ch['ViewLayer.Normal.' + k] for k in 'XYZ'], -1).reshape(40, 40, 3)

    for name, p in (('glossy', glossy), ('principled', principled)):
        nt.links.new(p.outputs[0], out.inputs['Surface'])
        link = nt.links.new(nm.outputs['Normal'], p.inputs['Normal'])
        cycles = normal_pass('CYCLES', 'cycles')
        poly = normal_pass('POLYCHROME', 'poly')
        err, warn = Engine.last_error, list(Engine.last_warnings or [])
        nt.links.remove(link)
        flat = normal_pass('POLYCHROME', 'flat')
        hit = np.linalg.norm(cycles, axis=-1) > 0.5
        inner = hit.copy()
        for dy in (-1, 0, 1):
            for dx in (-1, 0, 1):
                inner &= np.roll(np.roll(hit, dy, 0), dx, 1)

        def angles(a, b):
            a = a / np.maximum(np.linalg.norm(a, axis=-1, keepdims=True), 1e-12)
            b = b / np.maximum(np.linalg.norm(b, axis=-1, keepdims=True), 1e-12)
            return np.degrees(np.arccos(np.clip((a * b).sum(-1), -1.0, 1.0)))[inner]

        d, control = angles(cycles, poly), angles(cycles, flat)
        emit(name=name, n=int(inner.sum()), mean=float(d.mean()), p95=float(np.percentile(d, 95)), worst=float(d.max()),
             control=float(control.mean()), err=err, warn=warn)
    """,
        timeout=400,
    )
    results = check(proc, res, n=2)
    for r in results:
        print(
            f"{r['name']}: Normal pass vs Cycles over {r['n']} px: mean {r['mean']:.3f}°, 95th {r['p95']:.3f}°, "
            f"worst {r['worst']:.3f}°; unlinked {r['control']:.3f}°"
        )
    for r in results:
        assert r["err"] is None, r
        assert not [w for w in r["warn"] if "Normal" in w or "not supported" in w], r["warn"]
        assert r["n"] > 600, r
        assert r["control"] > 4.0 * r["mean"], r
    glossy, principled = results
    assert glossy["mean"] < 1.0, glossy
    # Cycles' Principled keeps its diffuse lobe on the unbent Normal Map normal (only the
    # specular lobes take ensure_valid_specular_reflection), and its pass averages the
    # lobes: near the silhouette it leans further from the view than Polychrome's one
    # bent normal.
    assert principled["mean"] < 2.0, principled
