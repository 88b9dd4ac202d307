"""Denoising with Intel Open Image Denoise (OIDN), through the ``pyoidn`` package.

OIDN's ``RT`` filter turns a noisy HDR render into a clean one, guided by two auxiliary
images: the albedo and the normal (OIDN's documentation asks for them at the first
non-specular hit). At low sample counts the aux images are noisy too, so they are first
denoised on their own ("prefiltering", OIDN's documented two-pass mode) and the colour
pass is then filtered with ``cleanAux`` set. See docs/denoise.md.

Only the RGB image is denoised; spectral passes stay raw. ``pyoidn`` is an optional
dependency (``pip install "polychrome[denoise]"``); without it :func:`denoise` raises an
ImportError naming it.
"""

from __future__ import annotations

import threading
from typing import Any

import numpy as np

#: The PyPI package that bundles OIDN (and the extra that installs it).
PACKAGE = "pyoidn"
INSTALL_HINT = 'pip install "polychrome[denoise]"'

#: OIDN's own working memory cap (MB). Above it OIDN denoises the image in overlapping
#: tiles (its ``maxMemoryMB`` parameter; the overlap is the network's receptive field),
#: so large images do not need a large scratch buffer.
MAX_MEMORY_MB = 1024

_lock = threading.Lock()
_device: Any = None


def available() -> bool:
    """Whether the ``pyoidn`` package can be imported."""
    try:
        _oidn()
    except ImportError:
        return False
    return True


def _oidn():
    try:
        import pyoidn
    except ImportError as e:
        raise ImportError(
            f"denoising needs the '{PACKAGE}' package (Intel Open Image Denoise), which is not installed: {INSTALL_HINT}"
        ) from e
    return pyoidn


def require() -> None:
    """Raises the ImportError naming ``pyoidn`` if it is missing (checked before a render
    starts, so a long render does not end in that error)."""
    _oidn()


def version() -> str:
    """The OIDN version ``pyoidn`` bundles, e.g. "2.5.1"."""
    return _oidn().version.oidn_version


def _shared_device():
    """One committed CPU device for the process (creating one costs ~0.1 s)."""
    global _device
    oidn = _oidn()
    if _device is None:
        device = oidn.Device(oidn.OIDN_DEVICE_TYPE_CPU)
        device.commit()
        _check(device, "creating the CPU device")
        _device = device
    return _device


def _check(device, what: str) -> None:
    err = device.get_error()
    if err:
        raise RuntimeError(f"Open Image Denoise: {what} failed: {err}")


def _free_memory_bytes() -> int | None:
    """Memory available to new allocations (Linux's MemAvailable), None if unknown."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError):  # pragma: no cover - not Linux
        pass
    return None


def _rgb(name: str, image: Any, shape: tuple[int, int]) -> tuple[np.ndarray, int]:
    """A contiguous float32 (H, W, 3) copy with non-finite values set to 0, and how many
    there were (the film already drops non-finite samples; this keeps OIDN safe anyway)."""
    a = np.asarray(image, dtype=np.float32)
    if a.ndim != 3 or a.shape[:2] != shape or a.shape[2] < 3:
        raise ValueError(f"denoise: {name} must have shape {shape + (3,)}, got {a.shape}")
    a = np.array(a[..., :3], dtype=np.float32, order="C")
    bad = ~np.isfinite(a)
    n_bad = int(bad.any(axis=2).sum())
    if n_bad:
        a[bad] = 0.0
    return a, n_bad


def denoise(
    rgba: Any,
    albedo: Any | None = None,
    normal: Any | None = None,
    *,
    prefilter: bool = True,
    quality: str = "high",
) -> np.ndarray:
    """The denoised image: ``rgba`` (H, W, 3 or 4) linear HDR, guided by ``albedo`` and
    ``normal`` (H, W, 3) when given (the normal only together with the albedo, as OIDN
    requires). ``prefilter`` denoises the aux images first and tells OIDN they are clean
    (best at low sample counts); False passes them as they are (``cleanAux`` off).
    ``quality``: "high" (final renders), "balanced" or "fast" (previews). Alpha is kept
    as given. Negative RGB components (colours outside the sRGB gamut, e.g. spectral
    lines) are clipped to 0: OIDN's HDR mode takes non-negative input. The result is
    always finite."""
    oidn = _oidn()
    image = np.asarray(rgba)
    if image.ndim != 3 or image.shape[2] not in (3, 4) or min(image.shape[:2]) == 0:
        raise ValueError(f"denoise: the image must have shape (H, W, 3) or (H, W, 4), got {image.shape}")
    if normal is not None and albedo is None:
        raise ValueError("denoise: a normal image needs an albedo image too (Open Image Denoise takes albedo or albedo + normal)")
    qualities = {"high": oidn.OIDN_QUALITY_HIGH, "balanced": oidn.OIDN_QUALITY_BALANCED, "fast": oidn.OIDN_QUALITY_FAST}
    if quality not in qualities:
        raise ValueError(f"denoise: quality must be one of {sorted(qualities)}, got {quality!r}")
    h, w = image.shape[:2]
    images = 2 + (albedo is not None) + (normal is not None)  # colour, output, aux
    # The float32 copies handed to OIDN plus its scratch (at most MAX_MEMORY_MB: it tiles).
    need = h * w * 3 * 4 * images + min(MAX_MEMORY_MB * 2**20, h * w * 3 * 4 * 64)
    free = _free_memory_bytes()
    if free is not None and need > free:
        raise MemoryError(
            f"denoise: a {w}x{h} image needs about {need / 2**30:.1f} GiB to denoise but {free / 2**30:.1f} GiB are free; "
            "render without denoise and denoise a crop, or free memory"
        )
    color, _ = _rgb("the image", image, (h, w))
    np.maximum(color, 0.0, out=color)
    aux = {}
    if albedo is not None:
        aux["albedo"] = np.clip(_rgb("albedo", albedo, (h, w))[0], 0.0, 1.0)
    if normal is not None:
        aux["normal"] = np.clip(_rgb("normal", normal, (h, w))[0], -1.0, 1.0)
    fmt = oidn.OIDN_FORMAT_FLOAT3
    out = np.zeros_like(color)
    with _lock:
        device = _shared_device()
        if prefilter:
            for name, a in aux.items():  # each aux image denoised in place on its own
                with oidn.Filter(device, oidn.OIDN_FILTER_TYPE_RT) as f:
                    f.set_image(name, a, fmt)
                    f.set_image("output", a, fmt)
                    f.set_quality(qualities[quality])
                    f.set_int("maxMemoryMB", MAX_MEMORY_MB)
                    f.commit()
                    f.execute()
                _check(device, f"prefiltering the {name} image")
        with oidn.Filter(device, oidn.OIDN_FILTER_TYPE_RT) as f:
            f.set_image("color", color, fmt)
            for name, a in aux.items():
                f.set_image(name, a, fmt)
            f.set_image("output", out, fmt)
            f.set_bool("hdr", True)
            f.set_bool("cleanAux", bool(prefilter and aux))
            f.set_quality(qualities[quality])
            f.set_int("maxMemoryMB", MAX_MEMORY_MB)
            f.commit()
            f.execute()
        _check(device, "denoising")
    out = np.nan_to_num(out, nan=0.0, posinf=0.0, neginf=0.0)
    if image.shape[2] == 4:
        alpha = np.nan_to_num(np.asarray(image[..., 3:4], np.float32), nan=0.0, posinf=0.0, neginf=0.0)
        out = np.concatenate([out, alpha], axis=2)
    return out
