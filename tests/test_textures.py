"""Textures and HDRI environments through the Python API (docs/design.md#rgb-data): the uplift round trip
against colour-science, image files to textures, HDRIs seen directly, constant colour vs
1×1 texture, and errors that name the file or texture."""

import json
import math

import colour
import numpy as np
import pytest

import polychrome as pc
from polychrome.imageio import write_exr
from polychrome.texture import read_radiance_hdr, write_radiance_hdr

CMFS = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
# Rec.709 primaries and D65 white with the matrix derived from them (as the core does;
# colour's "sRGB" uses the 4-digit rounded IEC matrix instead).
SRGB = colour.RGB_COLOURSPACES["ITU-R BT.709"]
D65_XY = SRGB.whitepoint


def lattice(steps=17):
    g = np.linspace(0.0, 1.0, steps)
    return np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3).astype(np.float32)


def grid(settings):
    from polychrome import _core

    lam, w = _core.wavelength_grid(json.dumps(settings))
    return lam.astype(np.float64), w.astype(np.float64)


def cell_average(sd, lam):
    """colour's tabulated spectrum, linearly interpolated, averaged over each grid
    sample's cell (how the core resamples tabulated data)."""
    x, y = sd.wavelengths, sd.values
    edges = np.concatenate([[lam[0]], (lam[1:] + lam[:-1]) / 2, [lam[-1]]])
    out = []
    for lo, hi in zip(edges[:-1], edges[1:]):
        t = np.linspace(lo, hi, 2001)
        out.append(np.trapz(np.interp(t, x, y), t) / (hi - lo))
    return np.array(out)


def xyz_on_grid(spectra, lam, w):
    """XYZ of spectra (..., N) with colour's CIE 1931 CMFs at the grid samples and the
    grid's quadrature weights, normalised so that E = 1 has Y = 1."""
    cmf = CMFS.copy().align(colour.SpectralShape(360, 830, 1))
    xbar = np.stack([np.interp(lam, cmf.wavelengths, cmf.values[:, k]) for k in range(3)], axis=1)  # (N, 3)
    return spectra @ (xbar * w[:, None]) / np.sum(xbar[:, 1] * w)


@pytest.mark.parametrize("method", ["LINEAR", "SMOOTH"])
def test_reflectance_uplift_round_trips_a_17_cube_lattice(core, method):
    settings = {"uplift": method}
    lam, w = grid(settings)
    rgb = lattice()
    spectra = core.uplift(rgb, "reflectance", json.dumps(settings)).astype(np.float64)
    assert spectra.shape == (rgb.shape[0], lam.size)
    assert spectra.min() >= 0.0 and spectra.max() <= 1.0 + 1e-6
    d65 = cell_average(colour.SDS_ILLUMINANTS["D65"], lam)
    # Reflectance under D65 → colour's sRGB matrix, normalised per channel by the
    # grid's white (reflectance 1), as the uplift's reversibility is defined.
    to_rgb = lambda xyz: colour.XYZ_to_RGB(xyz, SRGB, illuminant=D65_XY, apply_cctf_encoding=False)
    got_rgb = to_rgb(xyz_on_grid(spectra * d65, lam, w)) / to_rgb(xyz_on_grid(d65, lam, w))
    lab = lambda c: colour.XYZ_to_Lab(colour.RGB_to_XYZ(c, SRGB, illuminant=D65_XY, apply_cctf_decoding=False), D65_XY)
    de = colour.delta_E(lab(rgb.astype(np.float64)), lab(got_rgb), method="CIE 2000")
    assert np.max(de) < 0.01, f"max ΔE00 {np.max(de):.4g} at RGB {rgb[np.argmax(de)]}"


def test_illuminant_uplift_round_trips_including_hdr_values(core):
    lam, w = grid({})
    rgb = np.concatenate([lattice(), lattice(5) * 1e6, np.array([[1e6, 2e5, 5e5]], np.float32)])
    spectra = core.uplift(rgb, "illuminant", "{}").astype(np.float64)
    assert np.all(spectra >= 0.0)
    got = colour.XYZ_to_RGB(xyz_on_grid(spectra, lam, w), SRGB, illuminant=D65_XY, apply_cctf_encoding=False)
    scale = np.maximum(rgb.max(axis=1, keepdims=True), 1e-6)
    # Compare in Lab relative to each colour's own brightness (HDR values).
    lab = lambda c: colour.XYZ_to_Lab(colour.RGB_to_XYZ(c / scale, SRGB, illuminant=D65_XY, apply_cctf_decoding=False), D65_XY)
    de = colour.delta_E(lab(rgb.astype(np.float64)), lab(got), method="CIE 2000")
    assert np.max(de) < 0.01, f"max ΔE00 {np.max(de):.4g} at RGB {rgb[np.argmax(de)]}"


def sphere(rings=16, segments=32, center=(0.0, 0.0, -4.0), radius=1.0):
    th = np.linspace(0, np.pi, rings + 1)[:, None]
    ph = np.linspace(0, 2 * np.pi, segments + 1)[None, :]
    v = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th) * np.ones_like(ph)], -1).reshape(-1, 3)
    v = v * radius + np.asarray(center)
    row = segments + 1
    a = (np.arange(rings)[:, None] * row + np.arange(segments)[None, :]).ravel()
    t = np.concatenate([np.stack([a, a + row, a + 1], 1), np.stack([a + 1, a + row, a + row + 1], 1)])
    uv = np.stack([(ph * np.ones_like(th)).ravel() / (2 * np.pi), 1 - (th * np.ones_like(ph)).ravel() / np.pi], 1)
    return v, t, uv


def lit_ball(reflectance):
    scene = pc.Scene()
    v, t, uv = sphere()
    scene.add_mesh("ball", v, t, uvs=uv, material=pc.Diffuse(reflectance))
    scene.add_light(pc.PointLight((2.0, 2.0, 0.0), power=300.0))
    return scene


def test_constant_colour_and_one_texel_texture_render_identically():
    s = dict(width=12, height=12, samples=2, seed=5)
    rgb = (0.8, 0.3, 0.1)
    a = pc.render(lit_ball(rgb), **s).rgba
    b = pc.render(lit_ball(pc.Texture.from_array(np.array([[rgb]], np.float32))), **s).rgba
    assert a.max() > 0
    np.testing.assert_array_equal(a, b)
    # 8-bit sRGB bytes are decoded per lookup: same as the constant of the decoded value.
    byte = np.array([[[200, 90, 30]]], np.uint8)
    decoded = tuple(colour.cctf_decoding(byte[0, 0] / 255.0, function="sRGB"))
    c = pc.render(lit_ball(decoded), **s).rgba
    d = pc.render(lit_ball(pc.Texture.from_array(byte, encoding="srgb")), **s)
    np.testing.assert_allclose(c, d.rgba, rtol=1e-5, atol=1e-7)
    assert d.stats["texture_bytes"] == 3


def camera_towards(direction, focal_length=600.0):
    f = np.asarray(direction, float) / np.linalg.norm(direction)
    return pc.Camera.looking_at((0, 0, 0), f, focal_length=focal_length)


def uv_direction(u, v):
    phi, el = (0.5 - u) * 2 * math.pi, (v - 0.5) * math.pi
    return (math.cos(el) * math.cos(phi), math.cos(el) * math.sin(phi), math.sin(el))


@pytest.mark.parametrize("suffix", [".exr", ".hdr"])
def test_hdri_file_seen_directly_returns_its_rgb(tmp_path, suffix):
    # 16×8 image of 4×4 blocks; one block is (1e6, 5e5, 2e5), one a plain colour.
    img = np.full((8, 16, 3), 0.05, np.float32)
    img[0:4, 4:8] = (1e6, 5e5, 2e5)
    img[4:8, 8:12] = (0.25, 0.5, 0.125)  # exact in RGBE too
    path = tmp_path / f"sky{suffix}"
    if suffix == ".exr":
        write_exr(path, np.concatenate([img, np.ones((8, 16, 1), np.float32)], axis=-1))
    else:
        write_radiance_hdr(path, img)
    tex = pc.Texture.from_file(path)
    assert tex.pixels.dtype == np.float32 and tex.pixels.shape == (8, 16, 3)
    for (row, col), rotation in [((0, 1), 0.0), ((1, 2), 0.0), ((1, 2), 2.0)]:
        expected = tex.pixels[4 * row, 4 * col]
        scene = pc.Scene()
        scene.set_world(texture=tex, rotation=rotation)
        d = uv_direction((4 * col + 2) / 16, 1 - (4 * row + 2) / 8)
        c, s = math.cos(-rotation), math.sin(-rotation)
        scene.camera = camera_towards((c * d[0] - s * d[1], s * d[0] + c * d[1], d[2]))
        out = pc.render(scene, width=4, height=4, samples=1, max_bounces=0)
        np.testing.assert_allclose(out.rgba[..., :3], np.broadcast_to(expected, (4, 4, 3)), rtol=1e-3)


def test_radiance_hdr_reader_decodes_rgbe_bytes(tmp_path):
    # Flat scanline: (128, 64, 32, e=129) → (1, 0.5, 0.25); new-style RLE scanline of 8.
    p = tmp_path / "a.hdr"
    head = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n"
    p.write_bytes(head + b"-Y 1 +X 2\n" + bytes([128, 64, 32, 129, 0, 0, 0, 0]))
    np.testing.assert_array_equal(read_radiance_hdr(p), [[[1.0, 0.5, 0.25], [0, 0, 0]]])
    rle = bytes([2, 2, 0, 8]) + b"".join(bytes([128 + 8, v]) for v in (128, 64, 32, 130))
    p.write_bytes(head + b"-Y 1 +X 8\n" + rle)
    np.testing.assert_array_equal(read_radiance_hdr(p), np.tile([2.0, 1.0, 0.5], (1, 8, 1)))


def test_png_texture_is_kept_as_srgb_bytes(tmp_path):
    from PIL import Image

    px = np.array([[[255, 0, 0], [0, 128, 255]]], np.uint8)
    Image.fromarray(px).save(tmp_path / "t.png")
    tex = pc.Texture.from_file(tmp_path / "t.png", wrap="CLIP")
    assert tex.encoding == "srgb" and tex.pixels.dtype == np.uint8 and tex.nbytes() == 6
    assert tex.wrap == "CLIP"


def test_textured_world_furnace_white_sphere_is_invisible():
    c = np.array([0.3, 0.6, 0.9], np.float32)
    scene = pc.Scene()
    v, t, _ = sphere(24, 48, center=(0, 0, -5))
    scene.add_mesh("ball", v, t, material=pc.Diffuse(1.0))
    scene.set_world(texture=pc.Texture.from_array(np.tile(c / 4, (4, 8, 1))), strength=4.0)
    scene.camera = pc.Camera(focal_length=120.0)
    out = pc.render(scene, width=10, height=10, samples=8, max_bounces=64)
    px = out.rgba[..., :3].reshape(-1, 3).astype(np.float64)
    se = px.std(axis=0, ddof=1) / math.sqrt(len(px))
    assert np.all(np.abs(px.mean(axis=0) - c) < 5 * se + 2e-4), (px.mean(axis=0), se)


@pytest.mark.parametrize(
    "make, message",
    [
        (lambda: pc.Texture.from_array(np.zeros((4, 4)), name="Flat").pixels[0, 0, 3], "index"),
        (lambda: pc.Texture.from_array(np.zeros((4, 4, 2)), name="TwoChannel"), "TwoChannel"),
        (lambda: pc.Texture.from_array(np.array([[[0.1, np.nan, 0.2]]]), name="Holes"), "Holes"),
        (lambda: pc.Texture.from_array(np.zeros((1, 1, 3)), wrap="MIRROR", name="W"), "wrap"),
        (lambda: pc.Texture.from_array(np.zeros((1, 1, 3), np.uint8)), "srgb"),
    ],
)
def test_bad_textures_raise_with_the_name(make, message):
    with pytest.raises((ValueError, IndexError), match=message):
        make()


def test_missing_file_and_unknown_type_name_the_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="nowhere.exr"):
        pc.Texture.from_file(tmp_path / "nowhere.exr")
    (tmp_path / "x.tga").write_bytes(b"\0")
    with pytest.raises(ValueError, match="x.tga"):
        pc.Texture.from_file(tmp_path / "x.tga")


def test_world_settings_are_checked():
    scene = pc.Scene()
    with pytest.raises(TypeError, match="world"):
        scene.set_world(texture=np.zeros((2, 2, 3)))
    with pytest.raises(ValueError, match="strength"):
        scene.set_world(texture=pc.Texture.from_array(np.zeros((1, 1, 3))), strength=float("nan"))


def test_description_lists_each_texture_once_with_its_buffer():
    tex = pc.Texture.from_array(np.zeros((2, 3, 4), np.float32), wrap="extend", name="shared")
    byte = pc.Texture.from_array(np.zeros((1, 1, 3), np.uint8), encoding="srgb")
    scene = pc.Scene()
    v, t, uv = sphere(4, 8)
    scene.add_mesh("a", v, t, uvs=uv, material=pc.Diffuse(tex))
    scene.add_mesh("b", v, t, uvs=uv, material=pc.Diffuse(byte))
    scene.add_mesh("c", v, t, uvs=uv, material=pc.Diffuse(tex))
    scene.set_world(texture=tex, strength=2.0, rotation=0.5, importance_sampling=False)
    desc, buffers = scene.description()
    json.dumps(desc)  # every Texture object was replaced by an index
    assert [d["name"] for d in desc["textures"]] == ["shared", "Texture"]
    first = desc["textures"][0]
    # its alpha (0) is not trivial: kept as a fourth channel (docs/textures.md)
    assert (first["width"], first["height"], first["channels"], first["wrap"], first["encoding"]) == (3, 2, 4, "EXTEND", "linear")
    assert buffers[first["buffer"]].dtype == np.float32 and buffers[first["buffer"]].size == 24
    assert buffers[desc["textures"][1]["buffer"]].dtype == np.uint8
    refs = [m["bsdf"]["reflectance"]["texture"] for m in desc["materials"]]
    assert refs == [0, 1, 0]
    assert desc["world"] == {"texture": 0, "strength": 2.0, "rotation": 0.5, "importance_sampling": False}


def test_an_opaque_alpha_channel_is_not_kept():
    opaque = np.concatenate([np.full((2, 3, 3), 0.5, np.float32), np.ones((2, 3, 1), np.float32)], axis=2)
    assert pc.Texture.from_array(opaque).pixels.shape == (2, 3, 3)
    cut = opaque.copy()
    cut[0, 0, 3] = 0.25
    assert pc.Texture.from_array(cut).pixels.shape == (2, 3, 4)
    b = pc.Texture.from_array(np.full((1, 2, 4), 255, np.uint8), encoding="srgb")
    assert b.pixels.shape == (1, 2, 3) and b.nbytes() == 6
