"""Tests for polychrome.imageio (OpenEXR and PNG files)."""

import colour
import numpy as np
import OpenEXR
import pytest
from PIL import Image

from polychrome import imageio
from polychrome.imageio import (
    linear_to_srgb,
    read_image,
    read_spectral_exr,
    spectral_channel_name,
    srgb_to_linear,
    write_exr,
    write_exr_layers,
    write_png,
    write_spectral_exr,
)


def _srgb_reference(x):
    """IEC 61966-2-1 encoding written out independently of the module under test."""
    x = np.asarray(x, dtype=np.float64)
    return np.array([12.92 * v if v <= 0.0031308 else 1.055 * v ** (1 / 2.4) - 0.055 for v in x.ravel()]).reshape(x.shape)


def _read_channels(path):
    with OpenEXR.File(str(path), separate_channels=True) as exr:
        return {name: np.array(ch.pixels) for name, ch in exr.channels().items()}, dict(exr.header())


# --------------------------------------------------------------------------- sRGB curve


def test_srgb_curve_matches_iec_61966_2_1():
    x = np.concatenate([np.linspace(0, 0.01, 101), np.linspace(0, 1, 257)])
    np.testing.assert_allclose(linear_to_srgb(x), _srgb_reference(x), rtol=1e-13, atol=1e-15)
    np.testing.assert_allclose(linear_to_srgb(x), colour.cctf_encoding(x, function="sRGB"), atol=1e-12)
    v = np.linspace(0, 1, 257)
    np.testing.assert_allclose(srgb_to_linear(v), colour.cctf_decoding(v, function="sRGB"), atol=1e-12)
    np.testing.assert_allclose(srgb_to_linear(linear_to_srgb(x)), x, atol=1e-12)
    assert linear_to_srgb(1.0) == pytest.approx(1.0, abs=1e-12)


# --------------------------------------------------------------------------- EXR


@pytest.mark.parametrize("channels", [3, 4])
def test_exr_round_trip(tmp_path, channels):
    rng = np.random.default_rng(channels)
    rgba = rng.uniform(-1.0, 100.0, size=(5, 7, channels)).astype(np.float32)
    rgba[0, :, 0] = 1234.5  # row 0 = top of the image, stored first
    path = tmp_path / "img.exr"
    write_exr(path, rgba)

    planes, header = _read_channels(path)
    assert sorted(planes) == sorted("RGBA"[:channels])
    assert header["compression"] == OpenEXR.ZIP_COMPRESSION
    for c, name in enumerate("RGBA"[:channels]):
        assert planes[name].dtype == np.float32
        np.testing.assert_array_equal(planes[name], rgba[:, :, c])
    assert np.all(planes["R"][0] == 1234.5)

    back = read_image(path)
    assert back.shape == (5, 7, 4) and back.dtype == np.float32
    np.testing.assert_array_equal(back[:, :, :channels], rgba)
    if channels == 3:
        assert np.all(back[:, :, 3] == 1.0)


def test_exr_accepts_non_contiguous_and_float64(tmp_path):
    rgba = np.random.default_rng(0).uniform(size=(4, 6, 4))[:, ::2, :]
    write_exr(tmp_path / "v.exr", rgba)
    np.testing.assert_array_equal(read_image(tmp_path / "v.exr"), rgba.astype(np.float32))


def test_exr_bad_shape(tmp_path):
    with pytest.raises(ValueError, match=r"\(4, 4, 2\)"):
        write_exr(tmp_path / "x.exr", np.zeros((4, 4, 2)))


def test_exr_layers(tmp_path):
    rng = np.random.default_rng(1)
    combined = rng.uniform(size=(3, 4, 4)).astype(np.float32)
    depth = rng.uniform(size=(3, 4)).astype(np.float32)
    normal = rng.uniform(-1, 1, size=(3, 4, 3)).astype(np.float32)
    albedo = rng.uniform(size=(3, 4, 3)).astype(np.float32)
    path = tmp_path / "passes.exr"
    write_exr_layers(path, {"Combined": combined, "Depth": depth, "Normal": normal, "Albedo": albedo})

    planes, _ = _read_channels(path)
    expected = {
        **{f"Combined.{c}": combined[:, :, i] for i, c in enumerate("RGBA")},
        "Depth.Z": depth,
        **{f"Normal.{c}": normal[:, :, i] for i, c in enumerate("XYZ")},
        **{f"Albedo.{c}": albedo[:, :, i] for i, c in enumerate("RGB")},
    }
    assert sorted(planes) == sorted(expected)
    for name, plane in expected.items():
        np.testing.assert_array_equal(planes[name], plane)


def test_exr_layers_explicit_names_and_size_check(tmp_path):
    uv = np.zeros((2, 2, 2), np.float32)
    write_exr_layers(tmp_path / "uv.exr", {"UV": uv}, channel_names={"UV": ("U", "V")})
    assert sorted(_read_channels(tmp_path / "uv.exr")[0]) == ["UV.U", "UV.V"]
    with pytest.raises(ValueError, match="Depth"):
        write_exr_layers(tmp_path / "bad.exr", {"Combined": np.zeros((2, 2, 4)), "Depth": np.zeros((3, 2))})


# --------------------------------------------------------------------------- spectral EXR


def test_spectral_channel_name_format():
    # Fichet et al. 2021: S0.<value with comma decimal separator><unit>, written like std::to_string.
    assert spectral_channel_name(550) == "S0.550,000000nm"
    assert spectral_channel_name(380.5) == "S0.380,500000nm"


def test_spectral_exr_layout_and_round_trip(tmp_path):
    rng = np.random.default_rng(2)
    wavelengths = np.array([700.0, 400.0, 455.5, 550.0])  # unsorted on purpose
    spectral = rng.uniform(0, 5, size=(3, 5, 4)).astype(np.float32)
    rgba = rng.uniform(size=(3, 5, 4)).astype(np.float32)
    path = tmp_path / "spectral.exr"
    write_spectral_exr(path, spectral, wavelengths, rgba=rgba)

    planes, header = _read_channels(path)
    names = {"S0.700,000000nm", "S0.400,000000nm", "S0.455,500000nm", "S0.550,000000nm"}
    assert set(planes) == names | set("RGBA")
    assert header["spectralLayoutVersion"] == "1.0"
    assert header["emissiveUnits"] == "W.m^-2.sr^-1"
    np.testing.assert_array_equal(planes["S0.455,500000nm"], spectral[:, :, 2])
    np.testing.assert_array_equal(planes["A"], rgba[:, :, 3])

    wl_back, spectral_back = read_spectral_exr(path)
    order = np.argsort(wavelengths)
    np.testing.assert_array_equal(wl_back, wavelengths[order])
    np.testing.assert_array_equal(spectral_back, spectral[:, :, order])
    np.testing.assert_array_equal(read_image(path), rgba)


def test_spectral_exr_without_preview(tmp_path):
    path = tmp_path / "s.exr"
    write_spectral_exr(path, np.ones((2, 3, 2)), [500, 600])
    assert sorted(_read_channels(path)[0]) == ["S0.500,000000nm", "S0.600,000000nm"]
    with pytest.raises(ValueError, match="missing channel"):
        read_image(path)


def test_read_spectral_exr_other_units(tmp_path):
    # The layout also allows SI prefixes, metres and hertz; polarised S1..S3 are not S0 bands.
    path = tmp_path / "units.exr"
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    channels = {
        "S0.0,5um": np.full((1, 1), 1.0, np.float32),
        "S0.600nm": np.full((1, 1), 2.0, np.float32),
        "S0.5,99584916e14Hz": np.full((1, 1), 3.0, np.float32),  # c / 500 nm
        "S1.600nm": np.full((1, 1), 9.0, np.float32),
    }
    OpenEXR.File(header, channels).write(str(path))
    wavelengths, spectral = read_spectral_exr(path)
    np.testing.assert_allclose(wavelengths, [500.0, 500.0, 600.0], rtol=1e-6)
    assert sorted(spectral[0, 0].tolist()) == [1.0, 2.0, 3.0]


def test_spectral_exr_validation(tmp_path):
    with pytest.raises(ValueError, match="wavelengths"):
        write_spectral_exr(tmp_path / "a.exr", np.zeros((2, 2, 3)), [400, 500])
    with pytest.raises(ValueError, match="distinct"):
        write_spectral_exr(tmp_path / "a.exr", np.zeros((2, 2, 2)), [500, 500])
    write_exr(tmp_path / "rgb.exr", np.zeros((2, 2, 3)))
    with pytest.raises(ValueError, match="rgb.exr"):
        read_spectral_exr(tmp_path / "rgb.exr")


# --------------------------------------------------------------------------- PNG


def test_png_matches_srgb_curve(tmp_path):
    ramp = np.linspace(0.0, 1.0, 256)
    rgba = np.stack([ramp, ramp**2, ramp[::-1], ramp], axis=-1)[None].repeat(2, axis=0)
    path = tmp_path / "ramp.png"
    write_png(path, rgba)
    with Image.open(path) as im:
        assert im.mode == "RGBA" and im.size == (256, 2)
        pixels = np.asarray(im)
    expected_rgb = np.rint(_srgb_reference(rgba[..., :3]) * 255)
    np.testing.assert_array_equal(pixels[..., :3], expected_rgb)
    np.testing.assert_array_equal(pixels[..., 3], np.rint(ramp * 255)[None].repeat(2, axis=0))  # alpha linear


def test_png_clamps_exposure_and_nan(tmp_path):
    rgb = np.array([[[np.nan, 2.0, -1.0], [np.inf, -np.inf, 0.25]]])
    path = tmp_path / "clamp.png"
    write_png(path, rgb, exposure=1.0)
    with Image.open(path) as im:
        assert im.mode == "RGB"
        pixels = np.asarray(im)
    expected_quarter = np.rint(_srgb_reference(0.5) * 255)
    np.testing.assert_array_equal(pixels[0], [[0, 255, 0], [255, 0, expected_quarter]])


def test_png_read_back_is_linear(tmp_path):
    rgba = np.random.default_rng(3).uniform(size=(4, 4, 4))
    write_png(tmp_path / "p.png", rgba)
    back = read_image(tmp_path / "p.png")
    assert back.shape == (4, 4, 4) and back.dtype == np.float32
    np.testing.assert_allclose(back, rgba, atol=0.01)  # 8-bit quantisation


# --------------------------------------------------------------------------- errors


@pytest.mark.parametrize("name", ["missing.exr", "missing.png"])
def test_missing_file_names_the_file(tmp_path, name):
    path = tmp_path / name
    with pytest.raises(FileNotFoundError, match=name):
        read_image(path)


def test_missing_spectral_file_names_the_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="nothing.exr"):
        read_spectral_exr(tmp_path / "nothing.exr")


def test_unsupported_extension_names_the_file(tmp_path):
    with pytest.raises(ValueError, match="picture.tiff"):
        read_image(tmp_path / "picture.tiff")


def test_not_an_exr_names_the_file(tmp_path):
    path = tmp_path / "fake.exr"
    path.write_bytes(b"not an exr at all")
    with pytest.raises(ValueError, match="fake.exr"):
        read_image(path)


@pytest.mark.parametrize("suffix", [".png", ".exr"])
def test_a_failed_write_leaves_the_existing_image_and_no_temporary_file(tmp_path, monkeypatch, suffix):
    """Writers go through a temporary file renamed over the target: a write that dies
    half-way (here: the encoder raises after writing some bytes) keeps the good image."""
    path = tmp_path / f"image{suffix}"
    good = np.full((4, 5, 4), 0.5, np.float32)
    write = imageio.write_png if suffix == ".png" else imageio.write_exr
    write(path, good)
    before = path.read_bytes()

    def broken(self, target, *args, **kwargs):
        with open(target, "wb") as f:
            f.write(b"truncated")
        raise OSError("disk full")

    if suffix == ".png":
        from PIL import Image

        monkeypatch.setattr(Image.Image, "save", broken)
    else:
        import OpenEXR

        monkeypatch.setattr(OpenEXR.File, "write", broken)
    with pytest.raises(OSError, match="disk full"):
        write(path, np.zeros((4, 5, 4), np.float32))
    assert path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == [path.name]


@pytest.mark.parametrize("suffix", [".png", ".exr"])
def test_metadata_round_trips(tmp_path, suffix):
    path = tmp_path / f"m{suffix}"
    write = imageio.write_png if suffix == ".png" else imageio.write_exr
    write(path, np.zeros((2, 3, 4), np.float32), metadata={"polychrome:partial": "1", "note": "x y"})
    meta = imageio.read_metadata(path)
    assert meta["polychrome:partial"] == "1" and meta["note"] == "x y"
