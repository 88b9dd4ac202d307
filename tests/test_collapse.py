"""The wavelength choice at a dispersive surface (the paper's eq. 9; setting `collapse`,
docs/methods.md): ENERGY (one wavelength ∝ energy, independent uniform), STRATIFIED (the
same, each of a pixel's samples drawing from another stratum) and SPLIT (collapse_k
wavelengths stratified over the energy CDF, each weighted 1/(k·p)) are unbiased
estimators of the same image: per spectral band, their mean over independent seeds
equals ENERGY's within four standard errors (estimated from the seeds themselves); the
closed form they converge to is Snell + Sellmeier (tests/test_figures.py renders the
prism with each). No NaN or infinity at 4 and 401 wavelengths."""

from __future__ import annotations

import numpy as np
import pytest

import polychrome as pc
from polychrome import spectra

from meshes import quad, uv_sphere


class Glass(pc.Material):
    """A catalogue glass (the core's dispersive dielectric)."""

    def __init__(self, glass: str):
        self.glass = glass
        self.name = glass

    def bsdf_dict(self):
        return {"type": "dielectric", "ior": {"type": "named", "name": self.glass}}


def glass_box() -> pc.Scene:
    """A small closed room, a coloured back wall seen through a dense flint ball (N-SF11:
    strong dispersion) in front of the camera, an area light."""
    scene = pc.Scene()
    white = scene.add_material(pc.Diffuse(0.7, name="white"))
    red = scene.add_material(pc.Diffuse(spectra.tabulated([380, 570, 610, 780], [0.05, 0.06, 0.8, 0.85]), name="red"))
    lamp = scene.add_material(pc.Emitter(spectra.d65(), strength=1.5, name="lamp"))
    glass = scene.add_material(Glass("N-SF11"))
    s = 1.0
    scene.add_mesh("floor", *quad((-s, -s, -s), (s, -s, -s), (s, s, -s), (-s, s, -s)), material=white)
    scene.add_mesh("ceiling", *quad((-s, -s, s), (-s, s, s), (s, s, s), (s, -s, s)), material=white)
    scene.add_mesh("left", *quad((-s, -s, -s), (-s, s, -s), (-s, s, s), (-s, -s, s)), material=red)
    scene.add_mesh("right", *quad((s, -s, -s), (s, -s, s), (s, s, s), (s, s, -s)), material=white)
    scene.add_mesh("back", *quad((-s, s, -s), (s, s, -s), (s, s, s), (-s, s, s)), material=red)
    scene.add_mesh("front", *quad((-s, -s, -s), (-s, -s, s), (s, -s, s), (s, -s, -s)), material=white)
    l = 0.6
    scene.add_mesh("lamp", *quad((-l, -l, 0.98), (l, -l, 0.98), (l, l, 0.98), (-l, l, 0.98)), material=lamp)
    scene.add_mesh("ball", *uv_sphere((0.0, 0.1, -0.3), 0.45, rings=12, segments=24), material=glass)
    scene.camera = pc.Camera.looking_at((0.0, -0.95, 0.0), (0.0, 1.0, -0.3), focal_length=16.0)
    return scene


STRATEGIES = [("ENERGY", {}), ("STRATIFIED", {}), ("SPLIT", {"collapse_k": 3})]
SEEDS = 8
BASE = dict(width=8, height=8, samples=32, wavelength_count=21, max_bounces=4, noise_threshold=0.0)


def band_totals(result) -> np.ndarray:
    """The image's spectral radiance summed over pixels in four bands of the grid."""
    s = result.spectral.sum(axis=(0, 1))
    return np.array([b.sum() for b in np.array_split(s, 4)])


@pytest.fixture(scope="module")
def per_seed():
    scene = glass_box()
    out = {}
    for name, extra in STRATEGIES:
        runs = []
        for seed in range(SEEDS):
            r = pc.render(scene, collapse=name, seed=100 + seed, spectral_output=True, **BASE, **extra)
            assert r.stats["nonfinite_samples"] == 0
            runs.append(band_totals(r))
        out[name] = np.array(runs)
    return out


@pytest.mark.parametrize("name", ["STRATIFIED", "SPLIT"])
def test_each_strategy_has_the_energy_collapse_mean_per_band(per_seed, name):
    ref, got = per_seed["ENERGY"], per_seed[name]
    se = np.sqrt(ref.var(axis=0, ddof=1) / SEEDS + got.var(axis=0, ddof=1) / SEEDS)
    diff = np.abs(got.mean(axis=0) - ref.mean(axis=0))
    assert np.all(diff < 4.0 * se + 1e-6 * ref.mean(axis=0)), (diff, se)
    # The tolerance is tight enough to see a bias of 10 % in any band.
    assert np.all(4.0 * se < 0.1 * ref.mean(axis=0)), (se, ref.mean(axis=0))


def test_strategies_differ_in_their_samples_not_in_the_image(per_seed):
    """STRATIFIED draws other numbers than ENERGY (same seeds), so its images differ."""
    assert not np.allclose(per_seed["STRATIFIED"], per_seed["ENERGY"])


@pytest.mark.parametrize("count", [4, 401])
@pytest.mark.parametrize("name,extra", STRATEGIES + [("SPLIT", {"collapse_k": 401})])
def test_no_nan_at_the_extremes_of_the_grid(name, extra, count):
    for direction in ("BACKWARD", "BIDIRECTIONAL"):
        r = pc.render(
            glass_box(),
            width=6,
            height=6,
            samples=2,
            wavelength_count=count,
            max_bounces=4,
            collapse=name,
            direction=direction,
            seed=1,
            **extra,
        )
        assert r.stats["nonfinite_samples"] == 0
        assert np.all(np.isfinite(r.rgba))
        assert r.rgba[..., :3].sum() > 0


def test_dispersion_splitting_with_another_collapse_is_an_error_naming_it():
    with pytest.raises(ValueError, match="setting 'dispersion_splitting'.*collapse STRATIFIED"):
        pc.render(glass_box(), width=4, height=4, samples=1, dispersion_splitting=True, collapse="STRATIFIED")
    with pytest.raises(ValueError, match="setting 'collapse_k': 1 is below the minimum 2"):
        pc.RenderSettings(collapse_k=1)


@pytest.mark.parametrize("method", ["HERO", "RGB", "MONOCHROMATIC_RAYS"])
def test_split_with_another_method_is_an_error_not_ignored(method):
    """SPLIT divides a polychromatic ray among k wavelengths; HERO ends its secondary
    wavelengths at a dispersive surface and RGB collapses to a channel, so SPLIT there
    would silently do nothing."""
    with pytest.raises(ValueError, match="setting 'collapse'.*POLYCHROMATIC"):
        pc.render(glass_box(), width=4, height=4, samples=1, method=method, collapse="SPLIT")
    # AUTO and ENERGY stay valid with every method.
    r = pc.render(glass_box(), width=4, height=4, samples=1, method=method, collapse="ENERGY")
    assert np.all(np.isfinite(r.rgba))
