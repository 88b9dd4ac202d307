"""Spectra and colorimetry on the render's grid, against colour-science's CIE data."""

import json
import warnings

import numpy as np
import pytest

warnings.filterwarnings("ignore")
colour = pytest.importorskip("colour")

from polychrome import _core  # noqa: E402

CMFS = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]


def grid_of(**settings):
    lam, w = _core.wavelength_grid(json.dumps(settings))
    return np.asarray(lam, np.float64), np.asarray(w, np.float64)


def reference_xyz(values, lam, w):
    """eq. 6 quadrature with colour-science's CMFs at the grid wavelengths, Y(E=1) = 1."""
    cm = CMFS.copy().align(colour.SpectralShape(360, 830, 1))
    xbar = np.stack([np.interp(lam, cm.wavelengths, cm.values[:, k]) for k in range(3)], axis=1)
    return (values[:, None] * xbar * w[:, None]).sum(0) / (xbar[:, 1] * w).sum()


def cell_average(sd, lam):
    """Average of colour-science's spectrum over each grid cell (midpoint to midpoint)."""
    fine = sd.copy().align(colour.SpectralShape(360, 830, 0.1), extrapolator_kwargs={"method": "Constant", "left": None, "right": None})
    edges = np.concatenate([[lam[0]], 0.5 * (lam[1:] + lam[:-1]), [lam[-1]]])
    out = []
    for lo, hi in zip(edges[:-1], edges[1:]):
        m = (fine.wavelengths >= lo - 1e-9) & (fine.wavelengths <= hi + 1e-9)
        out.append(np.trapz(fine.values[m], fine.wavelengths[m]) / (hi - lo))
    return np.array(out)


def ours(spec, **settings):
    return np.array(_core.spectrum_xyz(json.dumps(spec), json.dumps(settings)))


def test_grid_weights_are_eq6():
    lam, w = grid_of()
    assert len(lam) == 41 and lam[0] == 380 and lam[-1] == 780
    expected = np.concatenate([[5.0], np.full(39, 10.0), [5.0]])
    np.testing.assert_allclose(w, expected)
    lam, w = grid_of(wavelengths=[400, 420, 470, 480, 600])
    np.testing.assert_allclose(w, [10, 35, 30, 65, 60])


def test_illuminant_a_matches_colour_science():
    lam, w = grid_of()
    a = colour.SDS_ILLUMINANTS["A"].copy().align(colour.SpectralShape(360, 830, 1))
    ref = reference_xyz(np.interp(lam, a.wavelengths, a.values) / 100.0, lam, w)
    np.testing.assert_allclose(ours({"type": "a"}), ref, rtol=1e-4)


@pytest.mark.parametrize("temperature", [1500.0, 3000.0, 6500.0, 20000.0])
def test_blackbody_matches_colour_science(temperature):
    lam, w = grid_of()
    # colour-science defaults to CIE 015's rounded c2 = 1.4388e-2 m·K; Polychrome uses
    # the exact SI value h·c/k, so give colour the same constant.
    c2 = 6.62607015e-34 * 299792458.0 / 1.380649e-23
    sd = colour.sd_blackbody(temperature, colour.SpectralShape(300, 900, 0.5), c2=c2)
    peak = colour.sd_blackbody(temperature, colour.SpectralShape(100, 8000, 0.5), c2=c2).values.max()
    ref = reference_xyz(np.interp(lam, sd.wavelengths, sd.values) / peak, lam, w)
    np.testing.assert_allclose(ours({"type": "blackbody", "temperature": temperature}), ref, rtol=1e-4)


def test_d65_matches_colour_science_resampled_by_cell_averages():
    lam, w = grid_of()
    ref = reference_xyz(cell_average(colour.SDS_ILLUMINANTS["D65"], lam) / 100.0, lam, w)
    np.testing.assert_allclose(ours({"type": "d65"}), ref, rtol=1e-4)
    # And the chromaticity is D65's to within the 10 nm grid's own error.
    xyz = ours({"type": "d65"})
    xy = xyz[:2] / xyz.sum()
    np.testing.assert_allclose(xy, [0.3127, 0.3290], atol=1e-3)


def test_non_uniform_grid_integrates_a_smooth_spectrum_like_the_exact_integral():
    rng = np.random.default_rng(1)
    steps = rng.uniform(4.0, 12.0, size=70)
    lam = np.concatenate([[380.0], 380.0 + np.cumsum(steps)])
    lam = lam[lam <= 780.0]
    lam = np.append(lam, 780.0) if lam[-1] < 779.0 else lam
    spec = {"type": "blackbody", "temperature": 5000.0}
    got = ours(spec, wavelengths=lam.tolist())
    # Exact integral at 0.1 nm with colour-science's CMFs over the same range.
    c2 = 6.62607015e-34 * 299792458.0 / 1.380649e-23
    sd = colour.sd_blackbody(5000.0, colour.SpectralShape(380, 780, 0.1), c2=c2)
    peak = colour.sd_blackbody(5000.0, colour.SpectralShape(100, 8000, 0.5), c2=c2).values.max()
    cm = CMFS.copy().align(colour.SpectralShape(380, 780, 0.1))
    exact = (sd.values[:, None] / peak * cm.values).sum(0) / cm.values[:, 1].sum()
    np.testing.assert_allclose(got, exact, rtol=1e-3)


def test_narrow_band_energy_is_kept_between_samples():
    lam, w = grid_of()
    values = np.asarray(_core.spectrum_values(json.dumps({"type": "narrow_band", "center": 589.0, "width": 2.0}), "{}"))
    sigma = 2.0 / np.sqrt(8 * np.log(2))
    assert abs((values * w).sum() - sigma * np.sqrt(2 * np.pi)) < 1e-4


def test_tabulated_spectrum_is_resampled_by_integration():
    lam, w = grid_of()
    spike = {"type": "tabulated", "wavelengths": [500, 504, 505, 506, 510], "values": [0, 0, 8, 0, 0]}
    values = np.asarray(_core.spectrum_values(json.dumps(spike), "{}"))
    assert abs((values * w).sum() - 8.0) < 1e-4  # area of the triangle: 8 × 2 nm / 2


@pytest.mark.parametrize(
    "spec, message",
    [
        ({"type": "blackbody", "temperature": -5}, "temperature"),
        ({"type": "tabulated", "wavelengths": [500, 400], "values": [1, 1]}, "ascending"),
        ({"type": "narrow_band", "center": 500, "width": 0}, "width"),
        ({"type": "fluorescent", "index": 3}, "F3"),
        ({"type": "constant", "value": -1}, "negative"),
        ({"type": "nonsense"}, "unknown variant"),
    ],
)
def test_bad_spectra_raise_value_error_with_reason(spec, message):
    with pytest.raises(ValueError, match=message):
        _core.spectrum_values(json.dumps(spec), "{}", "illuminant")


@pytest.mark.parametrize(
    "settings, message",
    [
        ({"wavelengths": [400, 500, 450, 600]}, "ascending"),
        ({"wavelength_count": 3}, "wavelength_count"),
        ({"wavelength_count": 402}, "wavelength_count"),
        ({"wavelengths": [350, 400, 500, 600]}, "outside"),
        ({"no_such_setting": 1}, "unknown field"),
    ],
)
def test_bad_grids_raise(settings, message):
    with pytest.raises(ValueError, match=message):
        _core.wavelength_grid(json.dumps(settings))


@pytest.mark.parametrize("count", [4, 8, 401])
def test_grid_sizes_from_4_to_401_work(count):
    lam, w = grid_of(wavelength_count=count)
    assert len(lam) == count and abs(w.sum() - 400.0) < 1e-3


@pytest.mark.parametrize("temperature", [2700.0, 4000.0, 6500.0])
def test_tinted_blackbody_is_tint_times_its_rec709_colour(temperature):
    """spectra.tinted: the blackbody's linear Rec.709 colour (colour-science: Planck's law,
    CIE 1931 2°, sRGB matrix) times the tint, per channel."""
    colour = pytest.importorskip("colour")
    from polychrome import spectra

    shape = colour.SpectralShape(380, 780, 5)
    sd = colour.sd_blackbody(temperature, shape)
    peak = colour.sd_blackbody(temperature, colour.SpectralShape(300, 3000, 1)).values.max()
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"].copy().align(shape)
    xyz = np.trapz(cmfs.values * (sd.values / peak)[:, None], axis=0) / np.trapz(cmfs.values[:, 1])
    want = colour.XYZ_to_RGB(xyz, colour.RGB_COLOURSPACES["sRGB"], apply_cctf_encoding=False)
    tint = (0.9, 0.5, 0.25)
    got = spectra.tinted(spectra.blackbody(temperature), *tint)
    assert got.kind == "rgb"
    assert np.allclose(got.params["rgb"], np.array(tint) * want, rtol=0.01), (got.params["rgb"], np.array(tint) * want)
    assert spectra.tinted(spectra.blackbody(temperature), 1.0, 1.0, 1.0) == spectra.blackbody(temperature)
    with pytest.raises(ValueError, match="tint"):
        spectra.tinted(spectra.blackbody(temperature), -1.0, 0.0, 0.0)
