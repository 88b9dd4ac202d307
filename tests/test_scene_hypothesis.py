"""Property-based tests (hypothesis) of the Python scene API (issue 8): random arrays of
random shapes, dtypes and values (NaN, ±inf, huge, negative indices) handed to
``Scene.add_mesh`` either build a scene that renders with finite passes, or raise a
ValueError/TypeError that names the mesh — never a crash or another exception."""

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import polychrome as pc

NAME = "hypo mesh"

floats = st.one_of(
    st.floats(-10, 10, width=32),
    st.sampled_from([np.float32(v) for v in (np.nan, np.inf, -np.inf, 1e30, -1e38, 0.0)]),
)


def arrays(dtype, elements):
    shapes = st.one_of(
        hnp.array_shapes(min_dims=2, max_dims=2, min_side=0, max_side=6).map(lambda s: (s[0], 3)),
        hnp.array_shapes(min_dims=0, max_dims=3, min_side=0, max_side=5),
    )
    return hnp.arrays(dtype, shapes, elements=elements)


vertex_arrays = st.one_of(arrays(np.float32, floats), arrays(np.float64, st.floats(-5, 5)))
index_arrays = st.one_of(
    arrays(np.int64, st.integers(-2, 8)),
    arrays(np.uint32, st.integers(0, 2**32 - 1)),
    arrays(np.float32, st.floats(0, 5, width=32)),
)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    vertices=vertex_arrays,
    triangles=index_arrays,
    normals=st.one_of(st.none(), vertex_arrays),
    uvs=st.one_of(st.none(), arrays(np.float32, floats)),
    material_ids=st.one_of(st.none(), arrays(np.int64, st.integers(-1, 3))),
)
def test_random_arrays_build_and_render_or_raise_naming_the_mesh(vertices, triangles, normals, uvs, material_ids):
    scene = pc.Scene()
    scene.add_material(pc.Diffuse(0.5, name="grey"))
    scene.add_material(pc.Emitter((1, 1, 1), strength=2.0, name="glow"))
    scene.camera = pc.Camera.looking_at((0, -6, 3), (0, 0, 0))
    try:
        scene.add_mesh(NAME, vertices, triangles, normals=normals, uvs=uvs, material_ids=material_ids)
        result = pc.render(scene, width=4, height=3, samples=1, wavelength_count=8, max_bounces=2, threads=1)
    except (ValueError, TypeError) as e:
        assert NAME in str(e), str(e)
        return
    for name in ("rgba", "depth", "normal", "albedo"):
        assert np.isfinite(getattr(result, name)).all(), name
    assert result.stats["nonfinite_samples"] == 0


@settings(max_examples=60, deadline=None)
@given(
    position=st.lists(st.one_of(st.floats(-5, 5), st.sampled_from([np.nan, np.inf])), min_size=0, max_size=4),
    power=st.one_of(st.floats(0, 1e6), st.sampled_from([np.nan, np.inf, -1.0])),
)
def test_random_point_lights_render_or_raise_naming_the_light(position, power):
    scene = pc.Scene()
    scene.add_mesh("floor", [[-2, -2, 0], [2, -2, 0], [2, 2, 0], [-2, 2, 0]], [[0, 1, 2], [0, 2, 3]])
    scene.add_light(pc.PointLight(position, power=power, name="hypo light"))
    scene.camera = pc.Camera.looking_at((0, -6, 3), (0, 0, 0))
    try:
        result = pc.render(scene, width=4, height=3, samples=1, wavelength_count=8, threads=1)
    except (ValueError, TypeError) as e:
        assert "hypo light" in str(e), str(e)
        return
    assert np.isfinite(result.rgba).all() and result.stats["nonfinite_samples"] == 0
