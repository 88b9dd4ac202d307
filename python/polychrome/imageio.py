"""Image files for Polychrome: scene-linear OpenEXR (RGBA, layered, spectral) and 8-bit sRGB PNG.

Conventions used throughout:

* Images are numpy arrays of shape (H, W, C), row 0 is the *top* of the image
  (OpenEXR's increasing-y scan-line order, and Pillow's), channels R, G, B[, A].
* EXR pixel values are scene-linear float32 with Rec.709/sRGB primaries.
* PNG files are display-referred 8-bit sRGB (IEC 61966-2-1 transfer curve).

Spectral EXRs follow Fichet, Pacanowski & Wilkie 2021, "An OpenEXR Layout for
Spectral Images", JCGT 10(3): one emissive channel per wavelength named
``S0.<wavelength>nm`` where the wavelength is printed like C++
``std::to_string(double)`` (six decimals) with a comma as the decimal
separator, since a dot already separates layer from channel in EXR names,
e.g. ``S0.550,000000nm``.
"""

from __future__ import annotations

import contextlib
import os
import re
import uuid
from pathlib import Path
from collections.abc import Mapping, Sequence

import numpy as np

__all__ = [
    "linear_to_srgb",
    "srgb_to_linear",
    "write_exr",
    "write_exr_layers",
    "write_spectral_exr",
    "spectral_channel_name",
    "read_spectral_exr",
    "read_image",
    "write_png",
]

RGBA_CHANNELS = ("R", "G", "B", "A")
SPECTRAL_LAYOUT_VERSION = "1.0"
EMISSIVE_UNITS = "W.m^-2.sr^-1"

# Channel-name grammar of Fichet et al. 2021 (emissive, unpolarised Stokes component S0).
_SPECTRAL_CHANNEL = re.compile(r"^S0\.(\d*,?\d*(?:[Ee][+-]?\d+)?)(Y|Z|E|P|T|G|M|k|h|da|d|c|m|u|n|p)?(m|Hz)$")
_SI_PREFIX = {
    "Y": 1e24,
    "Z": 1e21,
    "E": 1e18,
    "P": 1e15,
    "T": 1e12,
    "G": 1e9,
    "M": 1e6,
    "k": 1e3,
    "h": 1e2,
    "da": 1e1,
    "d": 1e-1,
    "c": 1e-2,
    "m": 1e-3,
    "u": 1e-6,
    "n": 1e-9,
    "p": 1e-12,
}
_SPEED_OF_LIGHT = 299_792_458.0

# Default per-layer channel suffixes for write_exr_layers (Blender-style pass names).
_LAYER_SUFFIXES = {
    "Depth": ("Z",),
    "Normal": ("X", "Y", "Z"),
    "Denoising Normal": ("X", "Y", "Z"),
    "Position": ("X", "Y", "Z"),
    "Vector": ("X", "Y", "Z", "W"),
}
_SUFFIXES_BY_COUNT = {1: ("V",), 2: ("X", "Y"), 3: ("R", "G", "B"), 4: ("R", "G", "B", "A")}


# --------------------------------------------------------------------------- sRGB transfer


def linear_to_srgb(linear):
    """Encode scene-linear values with the exact IEC 61966-2-1 piecewise sRGB curve (no clamping)."""
    x = np.asarray(linear, dtype=np.float64)
    power = 1.055 * np.power(np.maximum(x, 0.0031308), 1.0 / 2.4) - 0.055
    return np.where(x <= 0.0031308, 12.92 * x, power)


def srgb_to_linear(encoded):
    """Decode sRGB-encoded values with the exact IEC 61966-2-1 piecewise curve (no clamping)."""
    v = np.asarray(encoded, dtype=np.float64)
    power = np.power((np.maximum(v, 0.04045) + 0.055) / 1.055, 2.4)
    return np.where(v <= 0.04045, v / 12.92, power)


# --------------------------------------------------------------------------- helpers


def _check_image(rgba, what="image") -> np.ndarray:
    """Return `rgba` as float32 (H, W, 3|4), or raise ValueError describing the bad shape."""
    arr = np.asarray(rgba)
    if arr.ndim != 3 or arr.shape[2] not in (3, 4):
        raise ValueError(f"{what} must have shape (H, W, 3) or (H, W, 4), got {arr.shape}")
    return arr.astype(np.float32, copy=False)


def _exr_header(**attributes) -> dict:
    """Scan-line, ZIP-compressed EXR header (ZIP: lossless and well supported for float data)."""
    import OpenEXR

    return {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage, **attributes}


@contextlib.contextmanager
def atomic_path(path):
    """A temporary name beside ``path`` to write to; renamed over ``path`` (atomically, on
    the same file system) only once the write has succeeded, so an interrupted or failed
    write never leaves a truncated image over a good one."""
    path = Path(path)
    tmp = path.with_name(f".{path.stem}.{uuid.uuid4().hex[:8]}.tmp{path.suffix}")
    try:
        yield tmp
        os.replace(tmp, path)
    finally:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()


def _write_channels(path, channels: Mapping[str, np.ndarray], metadata: Mapping[str, str] | None = None, **attributes) -> None:
    """Write named 2-D float32 planes to one EXR file (atomically), with string
    ``metadata`` as header attributes."""
    import OpenEXR

    planes = {name: np.ascontiguousarray(plane, dtype=np.float32) for name, plane in channels.items()}
    header = _exr_header(**attributes, **{k: str(v) for k, v in (metadata or {}).items()})
    with atomic_path(path) as tmp:
        OpenEXR.File(header, planes).write(os.fspath(tmp))


def _rgba_planes(rgba: np.ndarray, prefix: str = "", suffixes=RGBA_CHANNELS) -> dict:
    """Split an (H, W, C) array into {prefix + suffix: plane}."""
    return {prefix + suffixes[c]: rgba[:, :, c] for c in range(rgba.shape[2])}


def _require_file(path) -> Path:
    """Fail early with the file's name: OpenEXR's and Pillow's own messages are less clear."""
    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"{p}: no such file")
    return p


def _read_exr_channels(path) -> dict:
    """Read every channel of an EXR file as {name: float32 (H, W)}."""
    import OpenEXR

    p = _require_file(path)
    try:
        with OpenEXR.File(str(p), separate_channels=True) as exr:
            return {name: np.asarray(ch.pixels, dtype=np.float32) for name, ch in exr.channels().items()}
    except RuntimeError as exc:  # OpenEXR reports corrupt/non-EXR files as RuntimeError
        raise ValueError(f"{p}: cannot read as OpenEXR ({exc})") from exc


# --------------------------------------------------------------------------- EXR writers


def write_exr(path, rgba, metadata: Mapping[str, str] | None = None) -> None:
    """Write a scene-linear float32 (H, W, 3|4) image as channels R, G, B(, A); row 0 is the top.
    ``metadata``: string header attributes (every writer here takes them)."""
    image = _check_image(rgba)
    _write_channels(path, _rgba_planes(image), metadata)


def write_exr_layers(path, layers: Mapping[str, np.ndarray], channel_names=None, metadata: Mapping[str, str] | None = None) -> None:
    """Write render passes as one multi-channel EXR with "Layer.Channel" names.

    Each layer is (H, W) or (H, W, C). Channel suffixes come from `channel_names`
    (layer -> sequence of suffixes) if given, else from the pass name
    (Depth -> Z, Normal/Position -> X, Y, Z), else from C (3 -> R, G, B; 4 -> R, G, B, A;
    1 -> V; 2 -> X, Y). Example: {"Combined": rgba, "Depth": z, "Normal": n} gives
    Combined.R/G/B/A, Depth.Z and Normal.X/Y/Z.
    """
    channel_names = dict(channel_names or {})
    planes, size = {}, None
    for layer, data in layers.items():
        arr = np.asarray(data, dtype=np.float32)
        arr = arr[:, :, None] if arr.ndim == 2 else arr
        if arr.ndim != 3:
            raise ValueError(f"layer {layer!r} must be (H, W) or (H, W, C), got {arr.shape}")
        if size is not None and arr.shape[:2] != size:
            raise ValueError(f"layer {layer!r} is {arr.shape[:2]}, other layers are {size}")
        size = arr.shape[:2]
        suffixes = _layer_suffixes(layer, arr.shape[2], channel_names.get(layer))
        planes.update(_rgba_planes(arr, f"{layer}.", suffixes))
    if not planes:
        raise ValueError("write_exr_layers needs at least one layer")
    _write_channels(path, planes, metadata)


def _layer_suffixes(layer: str, count: int, explicit=None) -> Sequence[str]:
    """Pick channel suffixes for one layer (see write_exr_layers)."""
    suffixes = explicit or _LAYER_SUFFIXES.get(layer)
    if not explicit and (suffixes is None or len(suffixes) != count):
        suffixes = _SUFFIXES_BY_COUNT.get(count) or tuple(str(i) for i in range(count))
    if len(suffixes) != count:
        raise ValueError(f"layer {layer!r} has {count} channels but {len(suffixes)} names: {suffixes}")
    return tuple(suffixes)


def spectral_channel_name(wavelength_nm: float) -> str:
    """Emissive S0 channel name of Fichet et al. 2021, e.g. 550 -> 'S0.550,000000nm'."""
    return "S0." + f"{float(wavelength_nm):f}".replace(".", ",") + "nm"


def write_spectral_exr(path, spectral, wavelengths_nm, rgba=None, metadata: Mapping[str, str] | None = None) -> None:
    """Write an (H, W, N) emissive spectral image (Fichet et al. 2021 layout) with an optional RGB(A) preview."""
    data = np.asarray(spectral, dtype=np.float32)
    wavelengths = np.asarray(wavelengths_nm, dtype=np.float64).reshape(-1)
    if data.ndim != 3 or data.shape[2] != wavelengths.size:
        raise ValueError(f"spectral must be (H, W, N) with N = {wavelengths.size} wavelengths, got {data.shape}")
    if not np.all(np.isfinite(wavelengths) & (wavelengths > 0)):
        raise ValueError(f"wavelengths must be finite and positive, got {wavelengths}")
    names = [spectral_channel_name(w) for w in wavelengths]
    if len(set(names)) != len(names):
        raise ValueError("wavelengths must be distinct (at the layout's 1e-6 nm precision)")
    planes = {name: data[:, :, i] for i, name in enumerate(names)}
    if rgba is not None:
        preview = _check_image(rgba, "rgba preview")
        if preview.shape[:2] != data.shape[:2]:
            raise ValueError(f"rgba preview is {preview.shape[:2]}, spectral image is {data.shape[:2]}")
        planes.update(_rgba_planes(preview))
    _write_channels(path, planes, metadata, spectralLayoutVersion=SPECTRAL_LAYOUT_VERSION, emissiveUnits=EMISSIVE_UNITS)


# --------------------------------------------------------------------------- readers


def _parse_spectral_channel(name: str):
    """Wavelength in nm of an emissive S0 channel name (any SI prefix, metres or hertz), else None."""
    match = _SPECTRAL_CHANNEL.match(name)
    if match is None or match.group(1) in ("", ","):
        return None
    number, prefix, unit = float(match.group(1).replace(",", ".")), match.group(2) or "", match.group(3)
    if unit == "m" and prefix == "n":
        return number  # the common case, kept exact
    value = number * _SI_PREFIX.get(prefix, 1.0)
    return value * 1e9 if unit == "m" else _SPEED_OF_LIGHT / value * 1e9


def read_spectral_exr(path):
    """Read an emissive spectral EXR: (wavelengths in nm ascending, float32 (H, W, N))."""
    channels = _read_exr_channels(path)
    bands = sorted((wl, name) for name in channels if (wl := _parse_spectral_channel(name)) is not None)
    if not bands:
        raise ValueError(f"{path}: no spectral S0.<wavelength> channels (found {sorted(channels)})")
    wavelengths = np.array([wl for wl, _ in bands])
    return wavelengths, np.stack([channels[name] for _, name in bands], axis=-1)


def read_image(path) -> np.ndarray:
    """Read a .exr (R, G, B[, A]) or .png (sRGB, decoded to linear) as scene-linear float32 (H, W, 4)."""
    suffix = Path(path).suffix.lower()
    if suffix not in (".exr", ".png"):
        raise ValueError(f"{path}: unsupported image type {suffix or '(none)'!r}; use .exr or .png")
    return _read_exr_rgba(path) if suffix == ".exr" else _read_png_rgba(path)


def _read_exr_rgba(path) -> np.ndarray:
    """R, G, B (required) and A (default 1) of an EXR as float32 (H, W, 4)."""
    channels = _read_exr_channels(path)
    missing = [c for c in RGBA_CHANNELS[:3] if c not in channels]
    if missing:
        raise ValueError(f"{path}: missing channel(s) {', '.join(missing)} (found {sorted(channels)})")
    alpha = channels.get("A", np.ones_like(channels["R"]))
    return np.stack([channels["R"], channels["G"], channels["B"], alpha], axis=-1)


def _read_png_rgba(path) -> np.ndarray:
    """PNG as float32 (H, W, 4): colour decoded from sRGB to linear, alpha left linear."""
    from PIL import Image

    p = _require_file(path)
    try:
        with Image.open(p) as im:
            pixels = np.asarray(im.convert("RGBA"), dtype=np.float64) / 255.0
    except (OSError, Image.DecompressionBombError, SyntaxError) as exc:  # bombs and bad chunks are not OSErrors
        raise ValueError(f"{p}: cannot read as PNG ({exc})") from exc
    pixels[:, :, :3] = srgb_to_linear(pixels[:, :, :3])
    return pixels.astype(np.float32)


# --------------------------------------------------------------------------- PNG writer


def write_png(path, rgba, exposure: float = 0.0, metadata: Mapping[str, str] | None = None) -> None:
    """Write scene-linear (H, W, 3|4) as 8-bit sRGB PNG (atomically); colour scaled by
    2**exposure, clamped, NaN -> 0; ``metadata`` as PNG text chunks."""
    from PIL import Image, PngImagePlugin

    image = np.asarray(_check_image(rgba), dtype=np.float64)
    image = np.nan_to_num(image, nan=0.0, posinf=1.0, neginf=0.0)
    colour = linear_to_srgb(image[:, :, :3] * (2.0**exposure))
    encoded = np.concatenate([colour, image[:, :, 3:]], axis=-1)
    pixels = np.rint(np.clip(np.nan_to_num(encoded), 0.0, 1.0) * 255.0).astype(np.uint8)
    info = PngImagePlugin.PngInfo()
    for k, v in (metadata or {}).items():
        info.add_text(k, str(v))
    with atomic_path(path) as tmp:
        Image.fromarray(pixels, "RGBA" if pixels.shape[2] == 4 else "RGB").save(os.fspath(tmp), format="PNG", pnginfo=info)


def read_metadata(path) -> dict[str, str]:
    """The string metadata of an image written here: EXR header string attributes or PNG
    text chunks."""
    p = _require_file(path)
    if p.suffix.lower() == ".png":
        from PIL import Image

        with Image.open(p) as im:
            return {k: str(v) for k, v in getattr(im, "text", {}).items()}
    import OpenEXR

    with OpenEXR.File(str(p)) as exr:
        return {k: v for k, v in exr.header().items() if isinstance(v, str)}
