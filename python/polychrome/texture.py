"""Image textures and HDRI environments, kept RGB and converted to spectra by the core
when a ray hits them (docs/design.md#rgb-data, deferred conversion).

A :class:`Texture` holds an RGB image as float32 linear values or as 8-bit sRGB bytes
(row 0 = the top of the image, Blender's UV convention: v = 0 at the bottom). Use it as
a diffuse reflectance (``Diffuse(reflectance=tex)``) or as the world
(``scene.set_world(texture=tex, strength=1.0, rotation=0.0)``, an equirectangular
lat-long image in a Z-up world, mapped as Blender's Environment Texture node).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

ENCODINGS = ("linear", "srgb")
WRAPS = ("REPEAT", "CLIP", "EXTEND")


class Texture:
    """An RGB image texture (use :meth:`from_array` or :meth:`from_file`)."""

    def __init__(self, pixels: np.ndarray, encoding: str, wrap: str, name: str):
        self.pixels = pixels
        self.encoding = encoding
        self.wrap = wrap
        self.name = name

    @property
    def width(self) -> int:
        return int(self.pixels.shape[1])

    @property
    def height(self) -> int:
        return int(self.pixels.shape[0])

    @classmethod
    def from_array(cls, rgb: Any, encoding: str = "linear", wrap: str = "REPEAT", name: str = "Texture") -> Texture:
        """A texture from an (H, W, 3|4) array. A fourth channel is kept as the
        texture's alpha (linear, never sRGB-encoded; read by the shading graph's Image
        Texture Alpha output) only when some texel's alpha is not 1.

        ``encoding="linear"``: scene-linear values, stored as float32 (any finite value;
        HDRIs may exceed 1). ``encoding="srgb"``: 8-bit sRGB-encoded values — a uint8
        array is stored as is (3 bytes per texel), floats in [0, 1] are quantised to
        bytes. ``wrap`` is Blender's extension mode: REPEAT, CLIP or EXTEND.
        """
        enc = str(encoding).lower()
        if enc not in ENCODINGS:
            raise ValueError(f"texture '{name}': encoding {encoding!r} must be 'linear' or 'srgb'")
        mode = str(wrap).upper()
        if mode not in WRAPS:
            raise ValueError(f"texture '{name}': wrap {wrap!r} must be one of {', '.join(WRAPS)}")
        a = np.asarray(rgb)
        if a.ndim == 2:
            a = np.repeat(a[:, :, None], 3, axis=2)
        if a.ndim != 3 or a.shape[2] not in (3, 4) or a.shape[0] == 0 or a.shape[1] == 0:
            raise ValueError(f"texture '{name}': expected an array of shape (H, W, 3) or (H, W, 4), got {a.shape}")
        if a.shape[2] == 4:
            opaque = np.all(a[:, :, 3] == (255 if a.dtype == np.uint8 else 1.0))
            if opaque:
                a = a[:, :, :3]
        if enc == "linear":
            if a.dtype == np.uint8:
                raise ValueError(f"texture '{name}': uint8 pixels need encoding='srgb' (or convert to float linear)")
            pixels = np.ascontiguousarray(a, dtype=np.float32)
            bad = ~np.isfinite(pixels)
            if bad.any():
                y, x, _ = np.argwhere(bad)[0]
                raise ValueError(f"texture '{name}': texel ({x}, {y}) is not finite ({pixels[y, x].tolist()})")
        else:
            if a.dtype == np.uint8:
                pixels = np.ascontiguousarray(a)
            else:
                f = np.asarray(a, dtype=np.float64)
                if not np.all(np.isfinite(f)):
                    raise ValueError(f"texture '{name}': sRGB values must be finite")
                pixels = np.ascontiguousarray(np.rint(np.clip(f, 0.0, 1.0) * 255.0).astype(np.uint8))
        return cls(pixels, enc, mode, name)

    @classmethod
    def from_file(cls, path: Any, wrap: str = "REPEAT", name: str | None = None) -> Texture:
        """Reads .exr (linear float, via :func:`polychrome.imageio.read_image`), .hdr
        (Radiance RGBE, read by this module), or .png/.jpg/.jpeg (8-bit sRGB via Pillow,
        kept as bytes and decoded per lookup)."""
        p = Path(path)
        label = name or p.name
        if not p.is_file():
            raise FileNotFoundError(f"texture '{label}': file {p} does not exist")
        suffix = p.suffix.lower()
        if suffix == ".exr":
            from .imageio import read_image

            return cls.from_array(read_image(p)[:, :, :3], "linear", wrap, label)
        if suffix == ".hdr":
            return cls.from_array(read_radiance_hdr(p), "linear", wrap, label)
        if suffix in (".png", ".jpg", ".jpeg"):
            from PIL import Image

            try:
                with Image.open(p) as im:
                    if im.mode in ("I", "I;16", "I;16B", "F"):
                        raise ValueError(f"texture '{label}': {p}: {im.mode} images (16-bit/float) are not supported; use EXR")
                    rgb = np.asarray(im.convert("RGB"), dtype=np.uint8)
            except (OSError, Image.DecompressionBombError, SyntaxError) as exc:  # bombs and bad chunks are not OSErrors
                raise ValueError(f"texture '{label}': cannot read {p} ({exc})") from exc
            return cls.from_array(rgb, "srgb", wrap, label)
        raise ValueError(f"texture '{label}': unsupported image type {suffix or '(none)'!r} (use .exr, .hdr, .png, .jpg)")

    def to_dict(self) -> dict[str, Any]:
        # Resolved to an index by Scene.description().
        return {"type": "texture", "texture": self}

    def nbytes(self) -> int:
        return int(self.pixels.nbytes)

    def __repr__(self) -> str:
        return f"Texture({self.name!r}, {self.width}×{self.height}, {self.encoding}, {self.wrap})"


def read_radiance_hdr(path: Any) -> np.ndarray:
    """Reads a Radiance RGBE (.hdr) image as float32 (H, W, 3), top row first.

    Supports the ``-Y H +X W`` orientation (what every common writer produces), flat and
    new-style run-length-encoded scanlines. Written here because Pillow has no HDR reader.
    """
    p = Path(path)
    data = p.read_bytes()
    pos = 0

    def line() -> bytes:
        nonlocal pos
        end = data.find(b"\n", pos)
        if end < 0:
            raise ValueError(f"{p}: truncated Radiance header")
        out = data[pos:end]
        pos = end + 1
        return out

    first = line()
    if not first.startswith(b"#?"):
        raise ValueError(f"{p}: not a Radiance .hdr file (no #? signature)")
    while True:
        l = line().strip()
        if not l:
            break
        if l.startswith(b"FORMAT=") and l != b"FORMAT=32-bit_rle_rgbe":
            raise ValueError(f"{p}: unsupported format {l.decode(errors='replace')}")
    res = line().split()
    if len(res) != 4 or res[0] != b"-Y" or res[2] != b"+X":
        raise ValueError(f"{p}: unsupported orientation {b' '.join(res).decode(errors='replace')} (only -Y H +X W)")
    try:
        h, w = int(res[1]), int(res[3])
    except ValueError:
        raise ValueError(f"{p}: bad resolution line {b' '.join(res).decode(errors='replace')}") from None
    # Check the size against the data before allocating (found by fuzzing: a corrupt
    # header asked for 37 GiB). A run-length scanline encodes at most 127 pixels of a
    # channel in 2 bytes, so h·w ≤ 64 × the remaining bytes for any readable file.
    if h <= 0 or w <= 0 or h * w > 64 * max(len(data) - pos, 0):
        raise ValueError(f"{p}: resolution {w}×{h} does not match the file's {len(data) - pos} bytes of pixel data")
    rgbe = np.zeros((h, w, 4), dtype=np.uint8)
    buf = np.frombuffer(data, dtype=np.uint8)
    for y in range(h):
        if 8 <= w < 32768 and pos + 4 <= len(buf) and buf[pos] == 2 and buf[pos + 1] == 2 and not (buf[pos + 2] & 0x80):
            if (int(buf[pos + 2]) << 8 | int(buf[pos + 3])) != w:
                raise ValueError(f"{p}: bad scanline length at row {y}")
            pos += 4
            for c in range(4):
                x = 0
                while x < w:
                    if pos >= len(buf):
                        raise ValueError(f"{p}: truncated pixel data at row {y}")
                    count = int(buf[pos])
                    pos += 1
                    if count > 128:
                        count -= 128
                        if x + count > w:
                            raise ValueError(f"{p}: bad run at row {y}")
                        rgbe[y, x : x + count, c] = buf[pos]
                        pos += 1
                    else:
                        if count == 0 or x + count > w or pos + count > len(buf):
                            raise ValueError(f"{p}: bad literal at row {y}")
                        rgbe[y, x : x + count, c] = buf[pos : pos + count]
                        pos += count
                    x += count
        else:
            n = 4 * w
            if pos + n > len(buf):
                raise ValueError(f"{p}: truncated pixel data at row {y}")
            rgbe[y] = buf[pos : pos + n].reshape(w, 4)
            pos += n
    e = rgbe[:, :, 3].astype(np.int32)
    scale = np.where(e > 0, np.ldexp(1.0, e - 136), 0.0)
    return (rgbe[:, :, :3].astype(np.float64) * scale[:, :, None]).astype(np.float32)


def write_radiance_hdr(path: Any, rgb: Any) -> None:
    """Writes float (H, W, 3) as a flat (uncompressed) Radiance RGBE file."""
    a = np.asarray(rgb, dtype=np.float64)[:, :, :3]
    h, w = a.shape[:2]
    m = a.max(axis=2)
    mant, exp = np.frexp(m)
    scale = np.where(m > 1e-32, mant * 256.0 / np.where(m > 0, m, 1.0), 0.0)
    out = np.zeros((h, w, 4), dtype=np.uint8)
    out[:, :, :3] = np.clip(a * scale[:, :, None], 0, 255).astype(np.uint8)
    out[:, :, 3] = np.where(m > 1e-32, exp + 128, 0).astype(np.uint8)
    header = f"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {h} +X {w}\n".encode()
    Path(path).write_bytes(header + out.tobytes())


__all__ = ["Texture", "read_radiance_hdr", "write_radiance_hdr"]
