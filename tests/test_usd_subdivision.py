"""Subdivision surfaces of UsdGeom.Mesh (polychrome/usd/subdivision.py, read_stage's
``subdivision_level``) against independent references: Catmull–Clark's level-1 rules
worked by hand on a cube; infinitely sharp creases keeping edges straight; and Blender's
own Subdivision Surface modifier (OpenSubdiv) in a bpy subprocess — the same cages
(a cube, a cube with creases of sharpness 2 and 0.5 and a corner of sharpness 3, an
open bumpy grid, a prism with pentagon caps and triangles) at level 2 with
``use_limit_surface`` off (the level-2 points, not the limit), compared as point sets;
and its UVs for every faceVaryingLinearInterpolation (Blender's UV Smooth options) on
four UV layouts with seams, corners, a junction of three regions, concave corners and a
dart, compared as sets of (position, uv) corners."""

import json
import warnings
from pathlib import Path

import numpy as np
import pytest

pxr = pytest.importorskip("pxr")
from pxr import Usd, UsdGeom, Vt  # noqa: E402

from polychrome import usd  # noqa: E402
from polychrome.usd import reader as usd_reader  # noqa: E402
from polychrome.usd import subdivision  # noqa: E402

CUBE_POINTS = [(x, y, z) for z in (-1.0, 1.0) for y in (-1.0, 1.0) for x in (-1.0, 1.0)]
CUBE_QUADS = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]


def grid(n=3, bump=0.4):
    """An open n × n quad grid over [-1, 1]², z a bump (non-planar, so boundaries matter)."""
    u = np.linspace(-1, 1, n + 1)
    x, y = np.meshgrid(u, u, indexing="ij")
    z = bump * np.cos(x * 1.3) * np.cos(y * 0.9) + 0.1 * x * y
    pts = np.stack([x, y, z], -1).reshape(-1, 3)
    a = (np.arange(n)[:, None] * (n + 1) + np.arange(n)[None, :]).ravel()
    quads = np.stack([a, a + n + 1, a + n + 2, a + 1], 1)
    return pts, [4] * len(quads), quads.ravel().tolist()


def prism():
    """A pentagonal prism: two pentagon caps (n-gons), its sides split into triangles."""
    ang = np.linspace(0, 2 * np.pi, 5, endpoint=False)
    ring = np.stack([np.cos(ang), np.sin(ang)], 1)
    pts = np.concatenate([np.c_[ring, -np.ones(5)], np.c_[ring * 0.7, np.ones(5)]])
    counts, idx = [5, 5], list(range(4, -1, -1)) + list(range(5, 10))
    for k in range(5):
        k1 = (k + 1) % 5
        counts += [3, 3]
        idx += [k, k1, 5 + k1, k, 5 + k1, 5 + k]
    return pts, counts, idx


# Each case: points, counts, indices, creases [(a, b, sharpness)], corners [(v, sharpness)], interpolateBoundary.
CASES = {
    "cube": (CUBE_POINTS, [4] * 6, [i for q in CUBE_QUADS for i in q], [], [], "edgeAndCorner"),
    "creased_cube": (
        CUBE_POINTS,
        [4] * 6,
        [i for q in CUBE_QUADS for i in q],
        [(4, 5, 2.0), (5, 7, 2.0), (7, 6, 2.0), (6, 4, 2.0), (0, 1, 0.5)],
        [(2, 3.0)],
        "edgeAndCorner",
    ),
    "grid": (*grid(), [], [], "edgeAndCorner"),
    "grid_edge_only": (*grid(), [], [], "edgeOnly"),
    "prism": (*prism(), [(5, 6, 1.5)], [], "edgeAndCorner"),
}


def as_lists(case):
    pts, counts, idx, creases, corners, boundary = case
    return [np.asarray(pts, float).tolist(), list(counts), [int(i) for i in idx], creases, corners, boundary]


def write_stage(path, case, level=None):
    pts, counts, idx, creases, corners, boundary = case
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, "Z")
    mesh = UsdGeom.Mesh.Define(stage, "/m")  # subdivisionScheme unauthored: catmullClark
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(np.asarray(pts, np.float32)))
    mesh.CreateFaceVertexCountsAttr(list(counts))
    mesh.CreateFaceVertexIndicesAttr([int(i) for i in idx])
    mesh.CreateInterpolateBoundaryAttr(boundary)
    if creases:
        mesh.CreateCreaseIndicesAttr([int(v) for a, b, _ in creases for v in (a, b)])
        mesh.CreateCreaseLengthsAttr([2] * len(creases))
        mesh.CreateCreaseSharpnessesAttr([float(s) for _, _, s in creases])
    if corners:
        mesh.CreateCornerIndicesAttr([int(v) for v, _ in corners])
        mesh.CreateCornerSharpnessesAttr([float(s) for _, s in corners])
    if level is not None:
        mesh.GetPrim().CreateAttribute("polychrome:subdivisionLevel", pxr.Sdf.ValueTypeNames.Int).Set(level)
    stage.GetRootLayer().Save()
    return path


def read_mesh(path, **kw):
    """The reader's arrays of /m (vertices, triangles, normals, ...)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # no camera
        r = usd_reader._Reader(Path(path), **kw)
        return r.mesh_arrays(r.stage.GetPrimAtPath("/m"))


def point_set_distance(a, b):
    """The largest nearest-neighbour distance from either set to the other."""
    d = np.linalg.norm(np.asarray(a, float)[:, None, :] - np.asarray(b, float)[None, :, :], axis=2)
    return max(d.min(axis=1).max(), d.min(axis=0).max())


def test_cube_level_one_by_hand():
    """Face points are the face centroids, edge points (v0 + v1 + f0 + f1) / 4, an old
    vertex (Q + 2R + (n − 3)S) / n with n = 3 — worked out for the cube [-1, 1]³."""
    r = subdivision.refine(CUBE_POINTS, [4] * 6, [i for q in CUBE_QUADS for i in q], 1)
    p = r["points"]
    assert len(p) == 8 + 12 + 6 and len(r["counts"]) == 24
    S = np.array(CUBE_POINTS)
    faces = np.array([S[list(q)].mean(axis=0) for q in CUBE_QUADS])  # (±1, 0, 0) ...
    np.testing.assert_allclose(np.sort(np.abs(p[20:]), axis=0), np.sort(np.abs(faces), axis=0), atol=1e-12)
    # Edge (-1,-1,-1)-(1,-1,-1): its faces' points (0,-1,0), (0,0,-1): (0, -3/4, -3/4).
    edges = p[8:20]
    assert np.allclose(np.sort(np.abs(edges), axis=1), [0, 0.75, 0.75])
    # Vertex (-1,-1,-1): Q = mean of (-1,0,0), (0,-1,0), (0,0,-1) = -1/3 each; R = mean
    # of the edge midpoints (0,-1,-1), (-1,0,-1), (-1,-1,0) = -2/3 each; n = 3.
    q, rr, n = -1 / 3, -2 / 3, 3
    expected = (q + 2 * rr + (n - 3) * -1.0) / n
    np.testing.assert_allclose(p[:8], S * abs(expected), atol=1e-12)
    assert abs(expected - -5 / 9) < 1e-15


def test_infinitely_sharp_creases_keep_edges_straight():
    """Sharpness 10 (infinite) on all 12 cube edges: every vertex a corner (3 sharp edges),
    so at level 3 the cube stays a cube: every point on its faces, each edge's 7 new points
    evenly spaced on the straight edge. On the top ring alone (a crease loop, vertices
    with 2 sharp edges: (a + 6S + b) / 8) the ring's points stay in the plane z = 1."""
    idx = [i for q in CUBE_QUADS for i in q]
    edges = sorted({tuple(sorted((q[k], q[(k + 1) % 4]))) for q in CUBE_QUADS for k in range(4)})
    r = subdivision.refine(
        CUBE_POINTS, [4] * 6, idx, 3, crease_indices=[v for e in edges for v in e], crease_lengths=[2] * 12, crease_sharpnesses=[10.0] * 12
    )
    p = r["points"]
    np.testing.assert_allclose(np.abs(p).max(axis=1), 1.0, atol=1e-12)
    on_edges = p[(np.isclose(np.abs(p), 1.0, atol=1e-12).sum(axis=1) >= 2)]
    assert len(on_edges) == 8 + 12 * 7
    x_edge = on_edges[np.isclose(on_edges[:, 1], -1) & np.isclose(on_edges[:, 2], -1)]
    np.testing.assert_allclose(np.sort(x_edge[:, 0]), np.linspace(-1, 1, 9), atol=1e-12)
    ring = [(4, 5), (5, 7), (7, 6), (6, 4)]
    r = subdivision.refine(
        CUBE_POINTS, [4] * 6, idx, 1, crease_indices=[v for e in ring for v in e], crease_lengths=[2] * 4, crease_sharpnesses=[10.0] * 4
    )
    p = r["points"]
    np.testing.assert_allclose(p[4:8], np.array(CUBE_POINTS[4:]) * [0.75, 0.75, 1.0], atol=1e-12)  # (a + 6S + b) / 8


def test_bilinear():
    """bilinear: the refined points lie on the cage's faces (a cube stays a cube)."""
    r = subdivision.refine(CUBE_POINTS, [4] * 6, [i for q in CUBE_QUADS for i in q], 2, scheme="bilinear")
    assert np.allclose(np.abs(r["points"]).max(axis=1), 1.0)


def test_reader_levels(tmp_path):
    """Level 0 is the cage (no normals: flat), the default level 2 (98 points, 96 quads),
    smooth outward normals; a prim's polychrome:subdivisionLevel wins over the reader's."""
    path = write_stage(tmp_path / "cube.usda", CASES["cube"])
    cage = read_mesh(path, subdivision_level=0)
    assert len(cage["vertices"]) == 8 and len(cage["triangles"]) == 12 and cage["normals"] is None
    default = read_mesh(path)
    assert len(default["vertices"]) == 98 and len(default["triangles"]) == 2 * 96  # level 2
    n = default["normals"]
    np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0, rtol=1e-6)
    assert np.all(np.sum(n * default["vertices"], axis=1) > 0)  # outward, as the winding
    own = read_mesh(write_stage(tmp_path / "own.usda", CASES["cube"], level=1), subdivision_level=3)
    assert len(own["vertices"]) == 26
    with pytest.raises(ValueError, match="subdivision_level"):
        read_mesh(path, subdivision_level=-1)


def test_uv_and_holes(tmp_path):
    """Face-varying st refined bilinearly inside each face (a quad's st stays bilinear in
    its parameters); a hole's children are left out; GeomSubset materials follow the faces."""
    stage = Usd.Stage.CreateNew(str(tmp_path / "g.usda"))
    pts, counts, idx = grid(2, 0.0)
    mesh = UsdGeom.Mesh.Define(stage, "/m")
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(np.asarray(pts, np.float32)))
    mesh.CreateFaceVertexCountsAttr(counts)
    mesh.CreateFaceVertexIndicesAttr(idx)
    mesh.CreateHoleIndicesAttr([3])
    st = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("st", pxr.Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.faceVarying)
    st.Set(Vt.Vec2fArray.FromNumpy((np.asarray(pts)[idx, :2] * 0.5 + 0.5).astype(np.float32)))
    stage.GetRootLayer().Save()
    m = read_mesh(tmp_path / "g.usda", subdivision_level=2)
    assert len(m["triangles"]) == 2 * 16 * 3  # 3 of 4 faces, 16 quads each
    # A flat grid with corners kept: st = (x, y) / 2 + 1/2 everywhere on the refined points too.
    np.testing.assert_allclose(m["uvs"], m["vertices"][:, :2] * 0.5 + 0.5, atol=1e-6)


def test_vertex_and_varying_primvars(tmp_path):
    """A vertex primvar follows the vertex rules (as the points), a varying one is linear
    (the bilinear scheme): st = (x, y) of the cube's points at level 1 — varying st at the
    old vertices stays (±1, ±1), vertex st moves with the points to (±5/9, ±5/9)."""
    path = write_stage(tmp_path / "cube.usda", CASES["cube"])
    stage = Usd.Stage.Open(str(path))
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath("/m"))
    xy = np.asarray(CUBE_POINTS, np.float32)[:, :2]
    for interp in ("vertex", "varying"):
        st = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("st", pxr.Sdf.ValueTypeNames.TexCoord2fArray, interp)
        st.Set(Vt.Vec2fArray.FromNumpy(xy))
        stage.GetRootLayer().Save()
        m = read_mesh(path, subdivision_level=1)
        corners = np.all(np.isclose(np.abs(m["vertices"]), 5 / 9, atol=1e-6), axis=1)
        assert corners.sum() == 8
        want = np.sign(m["vertices"][corners, :2]) * (5 / 9 if interp == "vertex" else 1.0)
        np.testing.assert_allclose(m["uvs"][corners], want, atol=1e-6)
        if interp == "vertex":
            np.testing.assert_allclose(m["uvs"], m["vertices"][:, :2], atol=1e-6)


def test_level_capped_by_face_count(tmp_path, monkeypatch):
    """A level that would make more than MAX_REFINED_FACES faces is lowered to the highest
    that fits, with one warning naming the prim (the cube's 24 corners: 24 · 4^(n−1) quads)."""
    monkeypatch.setattr(usd_reader, "MAX_REFINED_FACES", 24 * 16)
    path = write_stage(tmp_path / "cube.usda", CASES["cube"])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        r = usd_reader._Reader(Path(path), subdivision_level=5)
        m = r.mesh_arrays(r.stage.GetPrimAtPath("/m"))
    assert len(m["triangles"]) == 2 * 24 * 16  # level 3
    said = [str(w.message) for w in caught if "subdivision level" in str(w.message)]
    assert len(said) == 1 and "/m" in said[0] and "level 3" in said[0]


# bpy code both Blender tests run first: the cage as a Blender mesh with its creases
# (Blender's crease c is OpenSubdiv sharpness 10·c²) and a level-2 Subdivision Surface
# modifier with the limit surface off.
CAGE_PRELUDE = """
def sharp(s):
    return math.sqrt(min(s, 10.0) / 10.0)  # Blender: sharpness = 10 · crease²

def subdivided_cage(name, pts, counts, idx, creases, corners, boundary='PRESERVE_CORNERS', uvs=None, uv_smooth=None):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    faces, k = [], 0
    for c in counts:
        faces.append(idx[k:k + c]); k += c
    me = bpy.data.meshes.new(name)
    me.from_pydata(pts, [], faces)
    me.update()
    if uvs is not None:
        me.uv_layers.new(name='st').uv.foreach_set('vector', np.asarray(uvs, np.float32).ravel())  # loops in face order
    if creases:
        attr = me.attributes.new('crease_edge', 'FLOAT', 'EDGE')
        lookup = {tuple(sorted(e.vertices)): e.index for e in me.edges}
        for a, b, s in creases:
            attr.data[lookup[tuple(sorted((a, b)))]].value = sharp(s)
    if corners:
        attr = me.attributes.new('crease_vert', 'FLOAT', 'POINT')
        for v, s in corners:
            attr.data[v].value = sharp(s)
    ob = bpy.data.objects.new(name, me)
    bpy.context.scene.collection.objects.link(ob)
    mod = ob.modifiers.new('S', 'SUBSURF')
    mod.subdivision_type = 'CATMULL_CLARK'
    mod.levels = mod.render_levels = 2
    mod.use_limit_surface = False
    mod.use_creases = True
    mod.boundary_smooth = boundary
    if uv_smooth is not None:
        mod.uv_smooth = uv_smooth
    ev = ob.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
    co = np.empty(len(ev.vertices) * 3, np.float32)
    ev.attributes['position'].data.foreach_get('vector', co)
    return ev, co.reshape(-1, 3)
"""

BLENDER_BODY = """
cases = json.loads(open('cases.json').read())
out = {}
for name, (pts, counts, idx, creases, corners, boundary) in cases.items():
    smooth = 'PRESERVE_CORNERS' if boundary == 'edgeAndCorner' else 'ALL'
    ev, co = subdivided_cage(name, pts, counts, idx, creases, corners, boundary=smooth)
    out[name] = {'points': co.tolist(), 'faces': len(ev.polygons)}
emit(**out)
"""


def test_against_blender_subdivision_modifier(tmp_path):
    """Blender's Subdivision Surface modifier (OpenSubdiv) at level 2, limit surface off,
    creases on (Blender's crease c is OpenSubdiv sharpness 10·c²), 'keep corners'
    boundaries = edgeAndCorner, 'all' = edgeOnly: the same point sets as the reader's
    level-2 meshes, within 1e-4 of the cage's size."""
    from blender.bhelper import check, run_bpy

    (tmp_path / "cases.json").write_text(json.dumps({k: as_lists(v) for k, v in CASES.items()}))
    proc, results = run_bpy(tmp_path, CAGE_PRELUDE + BLENDER_BODY, timeout=180)
    blender = check(proc, results)[0]
    worst = {}
    for name, case in CASES.items():
        ours = read_mesh(write_stage(tmp_path / f"{name}.usda", case), subdivision_level=2)
        size = np.ptp(np.asarray(case[0], float), axis=0).max()
        ref = np.asarray(blender[name]["points"])
        assert len(ours["vertices"]) == len(ref), name
        assert len(ours["triangles"]) == 2 * blender[name]["faces"], name
        worst[name] = point_set_distance(ours["vertices"], ref) / size
    assert max(worst.values()) < 1e-4, worst


def test_cli_flag(tmp_path, monkeypatch, capsys):
    """`polychrome render --subdivision-level N` reaches read_stage (a reader option, not a
    render setting); out-of-range values and a .blend exit 2 with one line."""
    from polychrome import cli

    path = write_stage(tmp_path / "cube.usda", CASES["cube"])
    seen = []
    real = usd.read_stage

    def spy(*a, **kw):
        seen.append(kw.get("subdivision_level"))
        return real(*a, **kw)

    monkeypatch.setattr(usd, "read_stage", spy)
    args = ["render", str(path), "-o", str(tmp_path / "x.png"), "--quiet", "--width", "8", "--height", "8", "--samples", "1"]
    assert cli.main(args + ["--subdivision-level", "0"]) == 0
    assert cli.main(args) == 0
    assert seen == [0, None]
    for bad in (["--subdivision-level", "7"], ["--subdivision-level", "-1"]):
        assert cli.main(args + bad) == 2
        assert "--subdivision-level" in capsys.readouterr().err
    blend = tmp_path / "x.blend"
    blend.write_bytes(b"")
    assert cli.main(["render", str(blend), "-o", str(tmp_path / "y.png"), "--subdivision-level", "1"]) == 2
    assert "USD stages only" in capsys.readouterr().err


# faceVaryingLinearInterpolation → the Subdivision Surface modifier's UV Smooth (Blender
# maps these to OpenSubdiv's FVAR_LINEAR_* options).
UV_SMOOTH = {
    "all": "NONE",
    "cornersOnly": "PRESERVE_CORNERS",
    "cornersPlus1": "PRESERVE_CORNERS_AND_JUNCTIONS",
    "cornersPlus2": "PRESERVE_CORNERS_JUNCTIONS_AND_CONCAVE",
    "boundaries": "PRESERVE_BOUNDARIES",
    "none": "SMOOTH_ALL",
}


def uv_layouts():
    """Meshes with face-varying st: the 3 × 3 grid with four layouts of UV islands (each
    island a smooth non-affine map of the grid, offset by half a tile): quadrants meeting
    at an interior vertex (4 corners); three regions there (a junction: two corners and a
    value of two faces); an L of three faces against the rest (a corner and a concave
    corner at interior vertices); one island with a seam from the boundary ending inside
    (a dart). And the creased cube (creases 2 and 0.5, a corner of 3) with a strip of three
    faces unfolded as a net (bottom, front, top) beside three faces of their own:
    {name: (points, counts, indices, creases, corners, st)}."""
    pts, counts, idx = grid(3)
    g = np.stack(np.meshgrid(np.arange(4), np.arange(4), indexing="ij"), -1).reshape(-1, 2).astype(float)

    def layout(island_of_face):
        uv = []
        for f in range(9):
            i, j = divmod(f, 3)
            island = island_of_face(i, j)
            for v in idx[4 * f : 4 * f + 4]:
                x, y = g[v]
                uv.append([x / 6 + 0.04 * np.sin(2.1 * y) + 0.5 * (island % 2), y / 6 + 0.03 * np.cos(1.7 * x) + 0.5 * (island // 2)])
        return np.array(uv)

    layouts = {
        "quadrants": layout(lambda i, j: (i >= 1) + 2 * (j >= 1)),
        "three": layout(lambda i, j: 0 if (i == 0 and j <= 1) else (1 if (i, j) == (1, 0) else 2)),
        "concave": layout(lambda i, j: 0 if (i, j) in ((0, 0), (0, 1), (1, 0)) else 3),
    }
    dart = layout(lambda i, j: 0)
    dart[[k for k in range(4) if tuple(g[idx[k]]) == (1.0, 0.0)]] += [0.1, 0.05]  # face (0, 0) at the boundary vertex (1, 0)
    layouts["dart"] = dart
    out = {name: (pts, counts, idx, [], [], uv) for name, uv in layouts.items()}

    cube_pts, cube_counts, cube_idx, creases, corners, _ = CASES["creased_cube"]
    p = np.asarray(cube_pts, float)
    strip = {0: lambda x, y, z: (x, y), 2: lambda x, y, z: (x, -2 - z), 1: lambda x, y, z: (x, -4 - y)}  # a net: bottom, front, top
    uv = []
    for f in range(6):
        for k, v in enumerate(cube_idx[4 * f : 4 * f + 4]):
            if f in strip:
                U, V = strip[f](*p[v])
                uv.append([0.2 * U + 0.5 + 0.03 * np.sin(2 * V), 0.12 * V + 0.6 + 0.02 * U * U])
            else:
                a, b = [(0, 0), (1, 0), (1, 1), (0, 1)][k]
                uv.append([f / 6 + 0.15 * a + 0.02 * np.sin(3 * p[v][2]), 0.45 * b + 0.01 * p[v][0]])
    out["creased_cube_strip"] = (p, cube_counts, cube_idx, creases, corners, np.array(uv))
    return out


UV_BODY = """
cases = json.loads(open('uv.json').read())
modes = cases.pop('_modes')
out = {}
for name, (pts, counts, idx, creases, corners, uvs) in cases.items():
    for mode, smooth in modes.items():
        ev, co = subdivided_cage(mode, pts, counts, idx, creases, corners, uvs=uvs, uv_smooth=smooth)
        cv = np.empty(len(ev.loops), np.int32); ev.attributes['.corner_vert'].data.foreach_get('value', cv)
        u = np.empty(len(ev.loops) * 2, np.float32); ev.uv_layers.active.uv.foreach_get('vector', u)
        rows = np.concatenate([co[cv], u.reshape(-1, 2)], 1)
        out[name + ':' + mode] = np.unique(np.round(rows, 6), axis=0).tolist()
emit(**out)
"""


def test_face_varying_against_blender(tmp_path):
    """Smooth face-varying st (each faceVaryingLinearInterpolation) at level 2 against
    Blender's UV Smooth options: the sets of (position, uv) corners agree within 1e-5 on
    every mesh and mode, where the modes differ from each other by 0.016 or more.
    (A UV map folded over an edge — opposite UV winding on its two faces — is a seam to
    Blender, not to OpenSubdiv's face-varying topology, so the layouts keep the winding.)"""
    from blender.bhelper import check, run_bpy

    cases = uv_layouts()
    payload = {
        name: [np.asarray(p, float).tolist(), list(c), [int(i) for i in x], cr, co, uv.tolist()]
        for name, (p, c, x, cr, co, uv) in cases.items()
    }
    payload["_modes"] = UV_SMOOTH
    (tmp_path / "uv.json").write_text(json.dumps(payload))
    proc, results = run_bpy(tmp_path, CAGE_PRELUDE + UV_BODY, timeout=300)
    blender = check(proc, results)[0]
    worst, apart = {}, []
    for name, (p, c, x, creases, corners, uv) in cases.items():
        for mode in UV_SMOOTH:
            path = write_stage(tmp_path / f"{name}_{mode}.usda", (p, c, x, creases, corners, "edgeAndCorner"))
            stage = Usd.Stage.Open(str(path))
            mesh = UsdGeom.Mesh(stage.GetPrimAtPath("/m"))
            mesh.CreateFaceVaryingLinearInterpolationAttr(mode)
            st = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("st", pxr.Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.faceVarying)
            st.Set(Vt.Vec2fArray.FromNumpy(uv.astype(np.float32)))
            stage.GetRootLayer().Save()
            m = read_mesh(path, subdivision_level=2)
            ours = np.concatenate([m["vertices"], m["uvs"]], 1)
            ref = np.asarray(blender[f"{name}:{mode}"])
            assert len(ours) == len(ref), (name, mode)
            worst[(name, mode)] = point_set_distance(ours, ref)
        if name == "concave":
            apart = [
                point_set_distance(np.asarray(blender[f"{name}:{a}"]), np.asarray(blender[f"{name}:{b}"]))
                for a, b in (("all", "none"), ("cornersOnly", "boundaries"), ("cornersPlus1", "cornersPlus2"))
            ]
    assert max(worst.values()) < 1e-5, worst
    assert min(apart) > 0.01, apart
