"""UsdGeom BasisCurves, Points, Capsule and transform motion read by polychrome.usd,
against closed forms: an emissive prim over a black world seen by an orthographic camera
covers its projected area (width × length for a curve, πd²/4 per point, 2rh + πr² for a
capsule seen side-on), measured against an emissive reference square of known area in
the same image; a square moving D over the shutter smears into the box ⊛ box profile."""

import math
import re
import warnings

import numpy as np
import pytest

pxr = pytest.importorskip("pxr")
from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade  # noqa: E402

import polychrome as pc  # noqa: E402
from polychrome import usd  # noqa: E402
from polychrome.usd import basis  # noqa: E402
from conftest import luminance  # noqa: E402
from test_usd import floor_mesh, new_stage, top_camera  # noqa: E402

N, VIEW = 96, 2.0  # pixels and metres across the orthographic view
PIXEL_AREA = (VIEW / N) ** 2
REF_CENTRE, REF_HALF = (-0.6, 0.6), 0.2


def lamp(stage):
    mat = UsdShade.Material.Define(stage, "/Looks/lamp")
    sh = UsdShade.Shader.Define(stage, "/Looks/lamp/Surface")
    sh.CreateIdAttr("UsdPreviewSurface")
    sh.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0, 0, 0))
    sh.CreateInput("emissiveColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(1, 1, 1))
    mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), "surface")
    return mat


def bind(prim, mat):
    UsdShade.MaterialBindingAPI.Apply(prim.GetPrim()).Bind(mat)


def stage_with_reference(path):
    """A stage with an emissive square of side 2·REF_HALF (the unit of coverage) and a top camera."""
    stage = new_stage(path)
    mat = lamp(stage)
    ref = floor_mesh(stage, "/ref", REF_HALF, mat)
    ref.AddTranslateOp().Set(Gf.Vec3d(*REF_CENTRE, 0))
    cam = top_camera(stage, "/cam", 4.0, VIEW)
    return stage, mat, cam


def render(path, samples=32, unit_box=None, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        scene = usd.read_stage(path, **kw)
    result = pc.render(scene, width=N, height=N, samples=samples, max_bounces=0, seed=3)
    assert result.stats["nonfinite_samples"] == 0
    y = luminance(result.rgba)
    # Coverage: the reference square's light per area is 1.
    box = unit_box or (REF_CENTRE[0] - 0.3, REF_CENTRE[0] + 0.3, REF_CENTRE[1] - 0.3, REF_CENTRE[1] + 0.3)
    unit = region_sum(y, *box) / (4 * REF_HALF**2)
    return y / unit


def centres():
    c = (np.arange(N) + 0.5) / N * VIEW - VIEW / 2
    return c, -c  # x of each column, y of each row (row 0 at the top)


def region_sum(img, x0, x1, y0, y1):
    """Area covered in the box (m²) of a coverage image, pixels by their centres."""
    x, y = centres()
    rows = (y > y0) & (y < y1)
    cols = (x > x0) & (x < x1)
    return float(img[np.ix_(rows, cols)].sum() * PIXEL_AREA)


def test_basis_curves_follow_the_usd_bases():
    p = np.array([[0, 0, 0], [1, 2, 0], [3, 2, 0], [4, 0, 0]], float)
    w = np.array([1.0, 2.0, 3.0, 4.0])
    bez, bw = basis.evaluate_curve(p, w, False, "cubic", "bezier", "nonperiodic")
    assert np.allclose(bez[0], p[0]) and np.allclose(bez[-1], p[-1])
    assert np.allclose(bez[len(bez) // 2], [2.0, 1.5, 0.0])  # B(½) = (P0 + 3P1 + 3P2 + P3)/8
    assert np.allclose(bw[[0, -1]], [1.0, 4.0])
    cr, _ = basis.evaluate_curve(p, w, False, "cubic", "catmullRom", "nonperiodic")
    assert np.allclose(cr[[0, -1]], p[[1, 2]])  # through the inner vertices only
    pinned, _ = basis.evaluate_curve(p, w, False, "cubic", "catmullRom", "pinned")
    assert np.allclose(pinned[[0, -1]], p[[0, 3]])
    assert any(np.allclose(q, p[1]) for q in pinned) and any(np.allclose(q, p[2]) for q in pinned)
    bs, _ = basis.evaluate_curve(p, w, False, "cubic", "bspline", "nonperiodic")
    assert np.allclose(bs[0], (p[0] + 4 * p[1] + p[2]) / 6)
    bsp, _ = basis.evaluate_curve(p, w, False, "cubic", "bspline", "pinned")
    assert np.allclose(bsp[[0, -1]], p[[0, 3]])
    ring, _ = basis.evaluate_curve(p, w, False, "cubic", "bspline", "periodic")
    assert np.allclose(ring[0], ring[-1]) and len(ring) == 4 * basis.SAMPLES_PER_SEGMENT + 1
    assert basis.evaluate_curve(p[:3], w[:3], False, "cubic", "bezier", "nonperiodic") is None


def test_curves_and_points_cover_width_times_length_and_their_disks(tmp_path):
    path = tmp_path / "curves.usda"
    stage, mat, _ = stage_with_reference(path)
    linear = UsdGeom.BasisCurves.Define(stage, "/hair/linear")
    linear.CreateTypeAttr("linear")
    linear.CreatePointsAttr([(-0.8, -0.3, 0), (0.0, -0.3, 0), (0.8, -0.3, 0)])
    linear.CreateCurveVertexCountsAttr([3])
    linear.CreateWidthsAttr([0.06])
    linear.SetWidthsInterpolation("constant")
    bind(linear, mat)
    # A straight Bézier (evenly spaced control points: linear in t) whose vertex widths
    # grow linearly 0.04 → 0.12: its area is the mean width × length.
    bez = UsdGeom.BasisCurves.Define(stage, "/hair/bezier")
    bez.CreatePointsAttr([(x, -0.7, 0) for x in np.linspace(-0.8, 0.8, 4)])
    bez.CreateCurveVertexCountsAttr([4])
    bez.CreateWidthsAttr(list(np.linspace(0.04, 0.12, 4)))
    bind(bez, mat)
    pts = UsdGeom.Points.Define(stage, "/dust")
    pts.CreatePointsAttr([(0.1, 0.5, 0), (0.4, 0.5, 0), (0.7, 0.5, 0)])
    pts.CreateWidthsAttr([0.15, 0.15, 0.2])
    bind(pts, mat)
    stage.Save()
    cover = render(path)

    got_linear = region_sum(cover, -1, 1, -0.5, -0.1)
    got_bezier = region_sum(cover, -1, 1, -0.95, -0.5)
    got_points = region_sum(cover, -0.1, 1, 0.3, 0.7)
    want_points = math.pi / 4 * (2 * 0.15**2 + 0.2**2)
    print(
        f"linear {got_linear:.5f} / {1.6 * 0.06:.5f}, bezier {got_bezier:.5f} / {1.6 * 0.08:.5f}, points {got_points:.5f} / {want_points:.5f}"
    )
    # Curves are 8-sided tubes whose mean projected width is the diameter (polychrome.curves):
    # one view sees between cos(π/8) and 1 times their circumscribed width 2R = 1.026 w.
    for got, want in ((got_linear, 1.6 * 0.06), (got_bezier, 1.6 * 0.08)):
        assert 0.94 < got / want < 1.04, (got, want)
    assert got_points == pytest.approx(want_points, rel=0.03)
    # Where the geometry is: the linear curve's band is centred on y = −0.3.
    x, y = centres()
    band = cover[:, (x > -0.7) & (x < 0.7)].mean(axis=1)
    sel = (y > -0.5) & (y < -0.1)
    assert float((band[sel] * y[sel]).sum() / band[sel].sum()) == pytest.approx(-0.3, abs=0.005)


def test_capsule_silhouette_is_two_r_h_plus_pi_r_squared(tmp_path):
    path = tmp_path / "capsule.usda"
    stage, mat, _ = stage_with_reference(path)
    r, h = 0.15, 0.6
    cap = UsdGeom.Capsule.Define(stage, "/pill")
    cap.CreateRadiusAttr(r)
    cap.CreateHeightAttr(h)
    cap.CreateAxisAttr("X")
    cap.AddTranslateOp().Set(Gf.Vec3d(0.2, -0.45, 0))
    bind(cap, mat)
    stage.Save()
    cover = render(path)
    got = region_sum(cover, -0.5, 1, -1, 0.0)
    want = 2 * r * h + math.pi * r * r
    x, _ = centres()
    extent = x[cover[:, :].max(axis=0) > 0.5]
    extent = extent[extent > -0.3]
    print(f"capsule {got:.5f} / {want:.5f}, length {extent.max() - extent.min() + VIEW / N:.4f} / {h + 2 * r:.4f}")
    assert got == pytest.approx(want, rel=0.02)
    assert extent.max() - extent.min() + VIEW / N == pytest.approx(h + 2 * r, abs=1.5 * VIEW / N)


def test_bad_curve_data_skips_the_prim_with_one_warning_naming_it(tmp_path):
    path = tmp_path / "bad_curves.usda"
    stage, _, _ = stage_with_reference(path)
    c = UsdGeom.BasisCurves.Define(stage, "/hair")
    c.CreateTypeAttr("linear")
    c.CreatePointsAttr([(0, 0, 0), (1, 0, 0), (2, 0, 0)])
    c.CreateCurveVertexCountsAttr([3])
    c.CreateWidthsAttr([0.1, 0.2])
    stage.Save()
    for problem in (r"widths has 2 values for vertex interpolation; expected 3", r"curveVertexCounts add up to 4 but there are 3 points"):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            scene = usd.read_stage(path)
        hits = [str(w.message) for w in caught if re.search(rf"bad_curves\.usda: prim /hair: {problem}.*; it is skipped", str(w.message))]
        assert len(hits) == 1, [str(w.message) for w in caught]
        assert [i["name"] for i in scene.description()[0]["instances"]] == ["/ref"]  # the rest is read
        c.CreateCurveVertexCountsAttr([4])
        stage.Save()


W, D, X0, Y = 0.2, 0.8, -0.5, -0.5  # a square of side W at (X0, Y) travels D along +x over the shutter


def moving_square_stage(path, how, shutter=(0.0, 1.0)):
    stage, mat, cam = stage_with_reference(path)
    cam.CreateShutterOpenAttr(shutter[0])
    cam.CreateShutterCloseAttr(shutter[1])
    if how in ("nested", "nested_outer"):
        # A PointInstancer inside another's prototype: the inner one's positions move (nested),
        # or the outer one's (nested_outer); the other level stays, a quarter turn about Z
        # undone by its prototype root's turn the other way.
        outer = UsdGeom.PointInstancer.Define(stage, "/outer")
        proto = UsdGeom.Xform.Define(stage, "/outer/proto")
        proto.AddRotateZOp().Set(-90.0)
        inner = UsdGeom.PointInstancer.Define(stage, "/outer/proto/swarm")
        floor_mesh(stage, "/outer/proto/swarm/square", W / 2, mat)
        inner.CreatePrototypesRel().AddTarget("/outer/proto/swarm/square")
        inner.CreateProtoIndicesAttr([0])
        outer.CreatePrototypesRel().AddTarget("/outer/proto")
        outer.CreateProtoIndicesAttr([0])
        outer.CreateOrientationsAttr([Gf.Quath(math.cos(math.pi / 4), 0, 0, math.sin(math.pi / 4))])
        moving, still = (inner, outer) if how == "nested" else (outer, inner)
        moving.CreatePositionsAttr().Set([(X0, Y, 0)], 0.0)
        moving.GetPositionsAttr().Set([(X0 + D, Y, 0)], 1.0)
        still.CreatePositionsAttr([(0, 0, 0)])
        stage.Save()
        return path
    if how in ("instancer", "velocities"):  # a PointInstancer's time-sampled positions, or its velocities
        pi = UsdGeom.PointInstancer.Define(stage, "/swarm")
        floor_mesh(stage, "/swarm/proto", W / 2, mat)
        pi.CreatePrototypesRel().AddTarget("/swarm/proto")
        pi.CreateProtoIndicesAttr([0])
        if how == "instancer":
            pi.CreatePositionsAttr().Set([(X0, Y, 0)], 0.0)
            pi.GetPositionsAttr().Set([(X0 + D, Y, 0)], 1.0)
        else:  # units per second; 24 time codes per second (the stage's fallback)
            pi.CreatePositionsAttr().Set([(X0, Y, 0)], 0.0)
            pi.CreateVelocitiesAttr().Set([(D * 24.0, 0, 0)], 0.0)
        stage.Save()
        return path
    sq = floor_mesh(stage, "/square", W / 2, mat)
    if how == "xform":
        op = sq.AddTranslateOp()
        op.Set(Gf.Vec3d(X0, Y, 0), 0.0)
        op.Set(Gf.Vec3d(X0 + D, Y, 0), 1.0)
    elif how == "camera":  # the camera moves −D: the still square moves +D in the image
        sq.AddTranslateOp().Set(Gf.Vec3d(X0, Y, 0))
        op = cam.GetOrderedXformOps()[0]
        op.Set(Gf.Vec3d(0, 0, 4), 0.0)
        op.Set(Gf.Vec3d(-D, 0, 4), 1.0)
    else:  # deformation: the points themselves are time-sampled
        pts = np.array(sq.GetPointsAttr().Get(), float)
        sq.GetPointsAttr().Set([tuple(p) for p in pts + [X0, Y, 0]], 0.0)
        sq.GetPointsAttr().Set([tuple(p) for p in pts + [X0 + D, Y, 0]], 1.0)
    stage.Save()
    return path


def smear(x):
    """Share of the shutter for which x is covered: |[x − W/2, x + W/2] ∩ [X0, X0 + D]| / D."""
    lo, hi = np.maximum(x - W / 2, X0), np.minimum(x + W / 2, X0 + D)
    return np.clip(hi - lo, 0.0, None) / D


@pytest.mark.parametrize("how", ["xform", "points", "camera", "instancer", "velocities", "nested", "nested_outer"])
def test_moving_square_smears_into_its_analytic_streak(tmp_path, how):
    path = moving_square_stage(tmp_path / f"moving_{how}.usda", how)
    # (The reference square smears too when the camera moves: its whole streak is the unit.)
    cover = render(path, samples=128, unit_box=(-0.95, 0.95, 0.3, 0.9), time=0)
    x, y = centres()
    rows = np.abs(y - Y) < W / 2 - VIEW / N  # rows wholly inside the square's band
    profile = cover[rows][:, x > -0.9].mean(axis=0)
    xs = x[x > -0.9]
    fine = (np.arange(16) + 0.5) / 16 * VIEW / N - VIEW / N / 2
    want = np.array([smear(c + fine).mean() for c in xs])
    err = float(np.abs(profile - want).max())
    # The streak's length at half its height: D for a trapezoid of ramps W < D.
    above = np.nonzero(profile > 0.5 * W / D)[0]
    i, j = above[0], above[-1]
    half = 0.5 * W / D
    left = xs[i - 1] + (half - profile[i - 1]) / (profile[i] - profile[i - 1]) * (xs[i] - xs[i - 1])
    right = xs[j] + (profile[j] - half) / (profile[j] - profile[j + 1]) * (xs[j + 1] - xs[j])
    length = float(right - left)
    plateau = float(profile[np.abs(xs - (X0 + D / 2)) < (D - W) / 2 - 0.02].mean())
    area = region_sum(cover, -0.9, 1, -1, -0.2)
    print(
        f"{how}: max |profile − analytic| {err:.4f}, streak (at half height) {length:.4f} / {D:.4f}, plateau {plateau:.4f} / {W / D:.4f}, area {area:.5f} / {W * W:.5f}"
    )
    assert err < 0.06
    assert length == pytest.approx(D, abs=0.5 * VIEW / N)
    assert plateau == pytest.approx(W / D, abs=0.015)
    assert area == pytest.approx(W * W, rel=0.03)


def test_closed_shutter_reads_one_sample(tmp_path):
    """No shutter (close = open): the earliest sample, sharp — where the square starts."""
    path = moving_square_stage(tmp_path / "still.usda", "xform", shutter=(0.0, 0.0))
    scene = usd.read_stage(path)
    desc, _ = scene.description()
    square = [i for i in desc["instances"] if i["name"] == "/square"][0]
    assert not square.get("motion")
    assert np.allclose(np.asarray(square["transform"])[:3, 3], [X0, Y, 0])


def test_two_full_turns_over_the_shutter_smear_into_a_disk(tmp_path):
    """A clock hand of length a and width b turning 720° about its end (two rotateZ
    samples, 0° and 720°, whose transforms are equal: keys are added until neighbours
    turn ≤ 45°) covers radius ρ for a share asin(b / 2ρ) / π of the shutter (b/2 < ρ < a),
    the same in every direction."""
    a, b, centre = 0.35, 0.04, (0.4, -0.5)
    path = tmp_path / "spin.usda"
    stage, mat, cam = stage_with_reference(path)
    cam.CreateShutterOpenAttr(0.0)
    cam.CreateShutterCloseAttr(1.0)
    bar = UsdGeom.Mesh.Define(stage, "/bar")
    bar.CreatePointsAttr([(0, -b / 2, 0), (a, -b / 2, 0), (a, b / 2, 0), (0, b / 2, 0)])
    bar.CreateFaceVertexCountsAttr([4])
    bar.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    bind(bar, mat)
    bar.AddTranslateOp().Set(Gf.Vec3d(*centre, 0))
    spin = bar.AddRotateZOp()
    spin.Set(0.0, 0.0)
    spin.Set(720.0, 1.0)
    stage.Save()
    cover = render(path, samples=128, time=0)
    x, y = centres()
    gx, gy = np.meshgrid(x - centre[0], y - centre[1])
    rho = np.hypot(gx, gy)
    want = np.arcsin(np.clip(b / (2 * np.maximum(rho, 1e-9)), 0, 1)) / math.pi
    errs = []
    for r0 in np.arange(0.06, a - 0.03, 0.03):  # the formula holds inside ρ < a
        ring = (rho >= r0) & (rho < r0 + 0.03)
        errs.append(abs(float(cover[ring].mean() - want[ring].mean())))
    near = (rho > b) & (rho < a - 0.02)
    quadrants = [
        float(cover[q].sum() / want[q].sum())
        for q in (near & (np.sign(gx) == sx) & (np.sign(gy) == sy) for sx in (-1, 1) for sy in (-1, 1))
    ]
    area = region_sum(cover, -0.1, 1, -1, 0.0)
    print(
        f"spin: max ring |coverage − analytic| {max(errs):.4f}, quadrants / analytic {np.round(quadrants, 3)}, area {area:.5f} / {a * b:.5f}"
    )
    assert max(errs) < 0.01
    assert all(abs(q - 1) < 0.05 for q in quadrants)
    assert area == pytest.approx(a * b, rel=0.03)


def test_display_color_per_curve_and_per_point(tmp_path):
    """Unbound curves and points with a displayColor per curve / point: diffuse of that
    colour; a convex diffuse body under a uniform white dome of radiance 1 has radiance ρ."""
    from pxr import UsdLux

    path = tmp_path / "colours.usda"
    stage = new_stage(path)
    top_camera(stage, "/cam", 4.0, VIEW)
    dome = UsdLux.DomeLight.Define(stage, "/dome")
    dome.CreateIntensityAttr(1.0)
    colours = [(0.7, 0.2, 0.1), (0.1, 0.6, 0.2)]
    c = UsdGeom.BasisCurves.Define(stage, "/hair")
    c.CreateTypeAttr("linear")
    c.CreatePointsAttr([(-0.8, -0.3, 0), (0.8, -0.3, 0), (-0.8, -0.7, 0), (0.8, -0.7, 0)])
    c.CreateCurveVertexCountsAttr([2, 2])
    c.CreateWidthsAttr([0.12])
    c.SetWidthsInterpolation("constant")
    pv = c.CreateDisplayColorPrimvar(UsdGeom.Tokens.uniform)
    pv.Set(colours)
    p = UsdGeom.Points.Define(stage, "/dust")
    p.CreatePointsAttr([(-0.4, 0.5, 0), (0.4, 0.5, 0)])
    p.CreateWidthsAttr([0.3, 0.3])
    p.CreateDisplayColorPrimvar(UsdGeom.Tokens.vertex).Set(colours[::-1])
    stage.Save()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        scene = usd.read_stage(path)
    rgba = pc.render(scene, width=N, height=N, samples=64, max_bounces=4, seed=5).rgba
    x, y = centres()

    def at(px, py, half):  # mean over the pixels within `half` in x and one pixel in y of (px, py)
        rows = np.abs(y - py) < VIEW / N
        cols = np.abs(x - px) < half
        return rgba[np.ix_(rows, cols)][..., :3].reshape(-1, 3).mean(axis=0)

    got = {"curve 0": at(0.0, -0.3, 0.5), "curve 1": at(0.0, -0.7, 0.5), "point 0": at(-0.4, 0.5, 0.03), "point 1": at(0.4, 0.5, 0.03)}
    want = {"curve 0": colours[0], "curve 1": colours[1], "point 0": colours[1], "point 1": colours[0]}
    print({k: np.round(v, 3) for k, v in got.items()})
    for k in got:
        assert np.allclose(got[k], want[k], atol=0.03), (k, got[k], want[k])


def test_a_prim_still_over_a_later_shutter_is_placed_where_the_shutter_sees_it(tmp_path):
    """Samples at 0 (X0) and 1 (X0 + D); the shutter is open over [2, 3] (frame 0): the
    square is held at its last sample there, not at the earliest one, and does not blur."""
    path = moving_square_stage(tmp_path / "late.usda", "xform", shutter=(2.0, 3.0))
    scene = usd.read_stage(path)
    desc, _ = scene.description()
    square = [i for i in desc["instances"] if i["name"] == "/square"][0]
    assert not square.get("motion")
    assert np.allclose(np.asarray(square["transform"])[:3, 3], [X0 + D, Y, 0])


def test_hermite_curves_follow_their_tangents(tmp_path):
    """UsdGeomHermiteCurves: P0 = (0, 0, 0), P1 = (1, 0, 0), T0 = (0, 2, 0), T1 = (0, −2, 0):
    H(½) = (P0 + P1)/2 + (T0 − T1)/8 = (0.5, 0.5, 0), the curve's highest point; a straight
    one covers width × length."""
    path = tmp_path / "hermite.usda"
    stage, mat, _ = stage_with_reference(path)
    arc = UsdGeom.HermiteCurves.Define(stage, "/arc")
    arc.CreatePointsAttr([(0, 0, 0), (1, 0, 0)])
    arc.CreateTangentsAttr([(0, 2, 0), (0, -2, 0)])
    arc.CreateCurveVertexCountsAttr([2])
    arc.CreateWidthsAttr([0.02])
    arc.SetWidthsInterpolation("constant")
    arc.AddTranslateOp().Set(Gf.Vec3d(5, 5, 0))  # out of view
    line = UsdGeom.HermiteCurves.Define(stage, "/line")
    line.CreatePointsAttr([(-0.8, -0.3, 0), (0.0, -0.3, 0), (0.8, -0.3, 0)])
    line.CreateTangentsAttr([(0.8, 0, 0)] * 3)
    line.CreateCurveVertexCountsAttr([3])
    line.CreateWidthsAttr([0.06] * 3)
    bind(line, mat)
    stage.Save()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        scene = usd.read_stage(path)
    desc, buffers = scene.description()
    v = {m["name"]: np.asarray(buffers[m["vertices"]]).reshape(-1, 3) for m in desc["meshes"]}["/arc"]
    r = 0.01  # w/2; the tube's octagon reaches 0.948…1.026 × w/2 from the axis
    assert 0.5 + 0.94 * r < v[:, 1].max() < 0.5 + 1.04 * r, v[:, 1].max()
    assert v[:, 0].min() == pytest.approx(0.0, abs=0.011) and v[:, 0].max() == pytest.approx(1.0, abs=0.011)
    cover = render(path)
    got = region_sum(cover, -1, 1, -0.5, -0.1)
    print(f"hermite: top {v[:, 1].max():.4f} (0.5 + w/2 = 0.51), straight coverage {got:.5f} / {1.6 * 0.06:.5f}")
    assert 0.94 < got / (1.6 * 0.06) < 1.04


def test_instance_and_camera_motion_round_trip_through_write_stage(tmp_path):
    """write_stage writes motion keys as time samples 0 … 1 with a shutter open from 0 to 1;
    read_stage reads exactly those keys back (their grid spans the shutter)."""

    def rz(deg, x):
        c, s_ = math.cos(math.radians(deg)), math.sin(math.radians(deg))
        return np.array([[c, -s_, 0, x], [s_, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], float)

    scene = pc.Scene()
    keys = [rz(0, 0.0), rz(30, 0.2), rz(60, 0.5)]
    scene.add_mesh("quad", [(0, 0, 0), (1, 0, 0), (1, 1, 0)], [(0, 1, 2)], transform=keys[0], motion=keys)
    cam_keys = [np.eye(4) + np.array([[0, 0, 0, x], [0, 0, 0, 0], [0, 0, 0, 5], [0, 0, 0, 0]]) for x in (0.0, 0.1)]
    scene.camera = pc.Camera(to_world=cam_keys[0], motion=cam_keys)
    path = tmp_path / "motion.usda"
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        usd.write_stage(scene, path)
        back = usd.read_stage(path)
    desc, _ = back.description()
    got = np.asarray(desc["instances"][0]["motion"])
    assert got.shape == (3, 4, 4) and np.allclose(got, keys, atol=1e-12)
    assert np.allclose(np.asarray(desc["camera"]["motion"]), cam_keys, atol=1e-12)


@pytest.mark.parametrize("with_normals", [False, True])
def test_deforming_mesh_round_trips_through_write_stage(tmp_path, with_normals):
    """write_stage writes a deforming mesh's motion_vertices (and motion_normals) as time
    samples 0 … 1 of its points (normals) with a shutter open from 0 to 1; read_stage reads
    exactly those arrays back as the mesh's keys (float32), for a placed mesh and one
    shared by two instances (a prototype), beside a rigidly moving instance."""
    rng = np.random.default_rng(7)
    verts = np.array([(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0.2)], np.float32)
    tris = np.array([(0, 1, 2), (0, 2, 3)])
    keys = np.stack([verts + rng.normal(0, 0.1, verts.shape) for _ in range(4)]).astype(np.float32)
    normals = np.tile(np.float32([0, 0, 1]), (4, 1))
    nkeys = None
    if with_normals:
        nkeys = rng.normal(0, 0.2, (4, 4, 3)) + [0, 0, 1]
        nkeys = (nkeys / np.linalg.norm(nkeys, axis=2, keepdims=True)).astype(np.float32)
    scene = pc.Scene()
    scene.add_mesh(
        "cloth",
        verts,
        tris,
        normals=normals if with_normals else None,
        motion_vertices=keys,
        motion_normals=nkeys,
        transform=np.diag([1.0, 1.0, 1.0, 1.0]),
    )
    shared = scene.add_mesh("flag", verts, tris, motion_vertices=keys[:3][::-1], place=False)
    for x in (2.0, 4.0):
        m = np.eye(4)
        m[0, 3] = x
        scene.add_instance(shared, m, f"flag{x:g}")
    path = tmp_path / "deform.usdc"
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        usd.write_stage(scene, path)
        back = usd.read_stage(path)
    stage = Usd.Stage.Open(str(path))
    cam = UsdGeom.Camera(stage.GetPrimAtPath("/World/Camera"))
    assert (cam.GetShutterOpenAttr().Get(), cam.GetShutterCloseAttr().Get()) == (0.0, 1.0)
    desc, buffers = back.description()
    by_name = {m["name"]: m for m in desc["meshes"]}

    def arrays(entry, field):
        return np.stack([np.asarray(buffers[b], np.float32).reshape(-1, 3) for b in entry[field]])

    cloth = by_name["cloth"]
    np.testing.assert_array_equal(arrays(cloth, "motion_vertices"), keys)
    # The frame's arrays are the points' default value, for tools that ignore time;
    # read_stage reads the earliest time, where USD resolves the first sample.
    assert np.array_equal(np.asarray(stage.GetPrimAtPath("/World/cloth").GetAttribute("points").Get()), verts)
    np.testing.assert_array_equal(np.asarray(buffers[cloth["vertices"]], np.float32).reshape(-1, 3), keys[0])
    if with_normals:
        np.testing.assert_array_equal(arrays(cloth, "motion_normals"), nkeys)
    else:
        assert not cloth.get("motion_normals")
    flag = by_name["flag"]
    np.testing.assert_array_equal(arrays(flag, "motion_vertices"), keys[:3][::-1])
    assert sorted(i["name"] for i in desc["instances"] if i["mesh"] == desc["meshes"].index(flag)) == ["flag2", "flag4"]


def test_moving_lights_read_their_motion(tmp_path):
    """UsdLux lights whose transforms are time-sampled move over the shutter: a
    DistantLight turning about X (its keys' −Z the direction at each time, matching
    pxr's ComputeLocalToWorldTransform), a SphereLight sliding along X (its keys'
    translation), a RectLight (its emitter polygon an instance with keys); a textured
    DomeLight turning is one warning naming it (it stays at the frame); lights that
    stand still get no keys. The lit floor's time average is the closed form of
    rust/core/tests/motion.rs and tests/test_motion.py."""
    from pxr import UsdLux

    from polychrome import imageio

    imageio.write_exr(tmp_path / "env.exr", np.full((4, 8, 3), 0.1, np.float32))
    path = tmp_path / "lights.usda"
    stage = new_stage(path)
    cam = top_camera(stage, "/cam", 5.0, 2.0)
    cam.CreateShutterOpenAttr(0.0)
    cam.CreateShutterCloseAttr(1.0)
    sun = UsdLux.DistantLight.Define(stage, "/sun")
    op = sun.AddRotateXOp()
    op.Set(-10.0, 0.0)
    op.Set(60.0, 1.0)
    lamp = UsdLux.SphereLight.Define(stage, "/lamp")
    op = lamp.AddTranslateOp()
    op.Set(Gf.Vec3d(-1, 0, 2), 0.0)
    op.Set(Gf.Vec3d(1, 0, 2), 1.0)
    UsdLux.SphereLight.Define(stage, "/still").AddTranslateOp().Set(Gf.Vec3d(0, 1, 2))
    rect = UsdLux.RectLight.Define(stage, "/panel")
    op = rect.AddTranslateOp()
    op.Set(Gf.Vec3d(0, -1, 2), 0.0)
    op.Set(Gf.Vec3d(0, 1, 2), 1.0)
    dome = UsdLux.DomeLight.Define(stage, "/sky")
    dome.CreateTextureFileAttr("./env.exr")
    op = dome.AddRotateZOp()
    op.Set(0.0, 0.0)
    op.Set(90.0, 1.0)
    stage.Save()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = usd.read_stage(path)
    messages = [str(w.message) for w in caught]
    assert [m for m in messages if "/sky" in m and "turn" in m], messages
    assert not [m for m in messages if "/sun" in m or "/lamp" in m or "/panel" in m], messages
    desc, _ = scene.description()
    lights = {d["name"]: d for d in desc["lights"]}
    st = Usd.Stage.Open(str(path))

    def world(prim, t):
        return np.asarray(UsdGeom.Xformable(st.GetPrimAtPath(prim)).ComputeLocalToWorldTransform(t), float).T

    sun_keys = np.asarray(lights["/sun"]["motion"])
    assert len(sun_keys) >= 2
    for k, t in ((sun_keys[0], 0.0), (sun_keys[-1], 1.0)):
        assert np.allclose(-k[:3, 2], -world("/sun", t)[:3, 2], atol=1e-6)
    lamp_keys = np.asarray(lights["/lamp"]["motion"])
    assert np.allclose(lamp_keys[0][:3, 3], [-1, 0, 2]) and np.allclose(lamp_keys[-1][:3, 3], [1, 0, 2])
    assert "motion" not in lights["/still"]
    panel = [i for i in desc["instances"] if i["name"] == "/panel"][0]
    assert np.allclose(np.asarray(panel["motion"])[[0, -1]][:, :3, 3], [[0, -1, 2], [0, 1, 2]])
