"""Blender images → ``polychrome.Texture`` (kept RGB; the core converts per hit).

8-bit images in the sRGB colour space stay sRGB bytes; float images and non-colour data
are passed as linear float. Blender's pixel rows start at the bottom, polychrome's at the
top. :class:`TextureCache` converts each image once and keeps it until the image changes.

:func:`graph_texture` is the shading graph's form (docs/shading.md): RGBA, and 8-bit
images in any other colour space than sRGB, Non-Color and Linear Rec.709 converted to
scene linear with Blender's own OpenColorIO configuration (Blender already gives float
images in scene linear)."""

import os
import sys

import numpy as np
import polychrome as pc

from .warnings import Warnings

WRAPS = {"REPEAT": "REPEAT", "EXTEND": "EXTEND", "CLIP": "CLIP"}


def image_pixels(img):
    """(H, W, C) float32, row 0 at the top, or None if the image has no pixels."""
    w, h = img.size
    if w * h == 0:
        return None
    c = img.channels
    buf = np.empty(w * h * c, np.float32)
    img.pixels.foreach_get(buf)
    return buf.reshape(h, w, c)[::-1]


def finite(px):
    """``px`` with NaN and ±inf replaced by 0. One ``isfinite`` pass when every value is
    finite (always for 8-bit images) instead of ``np.nan_to_num``'s copy and three
    passes, which took 27 of DamagedHelmet's 43 s of export under cProfile (five 2048²
    images, loaded machine): 0.12 s against 1.47 s per 2048² RGBA float32 image."""
    if np.isfinite(px).all():
        return px
    return np.nan_to_num(px, nan=0.0, posinf=0.0, neginf=0.0)


def blender_texture(node, owner, warnings):
    """A Texture for an Image (or Environment) Texture node, or None (with a warning) if
    it cannot be used."""
    img = node.image
    if img is None:
        return None
    px = image_pixels(img)
    if px is None:
        warnings.add(("img", img.name), f"{owner}: image '{img.name}' has no pixels (missing file?); Cycles' missing-image magenta is used")
        return None
    extension = getattr(node, "extension", "REPEAT")  # an Environment Texture has none
    wrap = WRAPS.get(extension)
    if wrap is None:
        warnings.add(("wrap", img.name), f"{owner}: image '{img.name}': extension {extension} is not supported; REPEAT is used")
        wrap = "REPEAT"
    px = finite(px[:, :, :3])
    srgb = (not img.is_float) and img.colorspace_settings.name in ("sRGB", "sRGB EOTF")
    return pc.Texture.from_array(px, "srgb" if srgb else "linear", wrap, img.name)


#: What an Image Texture node without an image, or whose image has no pixels (a missing
#: file), reads in Cycles (IMAGE_TEXTURE_MISSING_RGBA; measured with bpy 4.5).
MISSING_RGBA = (1.0, 0.0, 1.0, 1.0)

#: 8-bit colour spaces whose bytes are used as they are (linear values or data).
LINEAR_BYTES = ("Linear Rec.709", "Non-Color")
SRGB_BYTES = ("sRGB", "sRGB EOTF")


def _ocio_processor(colorspace):
    """A CPU processor from ``colorspace`` to scene linear, from the OpenColorIO
    configuration Blender uses ($OCIO, else the one bpy ships) and the PyOpenColorIO bpy bundles."""
    import bpy

    local = bpy.utils.resource_path("LOCAL")
    site = os.path.join(local, "python", "lib", f"python{sys.version_info[0]}.{sys.version_info[1]}", "site-packages")
    if os.path.isdir(site) and site not in sys.path:
        sys.path.append(site)
    import PyOpenColorIO as ocio

    path = os.environ.get("OCIO") or os.path.join(local, "datafiles", "colormanagement", "config.ocio")
    config = ocio.Config.CreateFromFile(path)
    return config.getProcessor(colorspace, ocio.ROLE_SCENE_LINEAR).getDefaultCPUProcessor()


def graph_rgba(img, owner, warnings):
    """(H, W, 4) pixels of ``img`` for the shading graph and their encoding ("srgb" bytes
    or "linear" float), or None (with a warning) when the image has no pixels."""
    if img.source == "TILED":
        warnings.add(("udim", img.name), f"{owner}: image '{img.name}' is a UDIM image; only its first tile is used")
    px = image_pixels(img)
    if px is None:
        warnings.add(
            ("img", img.name), f"{owner}: image '{img.name}' has no pixels (missing file?); its node reads magenta (1, 0, 1), as in Cycles"
        )
        return None
    if px.shape[2] != 4:  # grey or RGB: make it RGBA
        rgb = np.repeat(px[:, :, :1], 3, axis=2) if px.shape[2] < 3 else px[:, :, :3]
        alpha = px[:, :, 1:2] if px.shape[2] == 2 else np.ones_like(px[:, :, :1])
        px = np.concatenate([rgb, alpha], axis=2)
    px = finite(px)
    space = img.colorspace_settings.name
    if img.is_float or img.colorspace_settings.is_data or space in LINEAR_BYTES:
        return px, "linear"
    if space in SRGB_BYTES:
        return np.rint(np.clip(px, 0.0, 1.0) * 255.0).astype(np.uint8), "srgb"
    try:
        proc = _ocio_processor(space)
    except Exception as e:  # no OpenColorIO or an unknown colour space: read as sRGB
        warnings.add(("ocio", img.name), f"{owner}: image '{img.name}': colour space '{space}' cannot be converted ({e}); read as sRGB")
        return np.rint(np.clip(px, 0.0, 1.0) * 255.0).astype(np.uint8), "srgb"
    buf = np.ascontiguousarray(px, np.float32)
    proc.applyRGBA(buf)
    return finite(buf), "linear"


def missing_texture():
    """The 1 × 1 RGBA texture of MISSING_RGBA: what Cycles reads from an Image Texture
    node without an image or whose image has no pixels."""
    return pc.Texture.from_array(np.array([[MISSING_RGBA]], np.float32), "linear", "REPEAT", "missing image")


def graph_texture(node, owner, node_name, warnings, cache, user=None, associate=False, ignore_alpha=False):
    """The RGBA Texture of an Image or Environment Texture node for the shading graph, or
    None. ``associate``: colour × alpha (in the stored encoding, as Cycles associates 8-bit
    sRGB bytes before decoding them). ``ignore_alpha``: alpha 1 (alpha mode None). The
    alpha channel is kept only where some texel's alpha is not 1."""
    img = node.image
    extension = getattr(node, "extension", "REPEAT")

    def convert(own):
        got = graph_rgba(img, owner, own)
        if got is None:
            return missing_texture()
        px, encoding = got
        if ignore_alpha:
            px = px[:, :, :3]
        elif associate and not img.is_float:  # Blender's float buffers are associated already
            if px.dtype == np.uint8:
                a = px[:, :, 3:4].astype(np.float32) / 255.0
                px = np.concatenate([np.rint(px[:, :, :3] * a).astype(np.uint8), px[:, :, 3:]], axis=2)
            else:
                px = np.concatenate([px[:, :, :3] * px[:, :, 3:4], px[:, :, 3:]], axis=2)
        return pc.Texture.from_array(px, encoding, extension if extension in WRAPS else "REPEAT", img.name)

    kind = "graph-" + ("opaque" if ignore_alpha else "associated" if associate else "straight")
    return cache.texture(node, owner, warnings, user, convert=convert, kind=kind)


class TextureCache:
    """Textures by (image, extension), each converted once; a cached texture's warnings
    are added again wherever it is used. Each use names its ``user`` (e.g. the material),
    so that what a changed user saw can be converted again: Blender reports a reloaded
    image as an update of the materials and worlds that use it, not of the image."""

    def __init__(self):
        self._entries = {}  # (image name, extension) -> (Texture or None, warning items)
        self._used = {}  # user -> image names it used
        self.converted = 0  # images converted; the Exporter counts per export

    def texture(self, node, owner, warnings, user=None, convert=None, kind="rgb"):
        """The node's texture, converted by ``convert(warnings)`` (default: :func:`blender_texture`)."""
        img = node.image
        if img is None:
            return None
        key = (img.original.name, getattr(node, "extension", "REPEAT"), kind)
        self._used.setdefault(user, set()).add(key[0])
        if key not in self._entries:
            own = Warnings()
            tex = blender_texture(node, owner, own) if convert is None else convert(own)
            self._entries[key] = (tex, own.items)
            self.converted += 1
        tex, items = self._entries[key]
        warnings.extend(items)
        return tex

    def users_of(self, image_name):
        return [user for user, names in self._used.items() if image_name in names]

    def forget(self, image_name):
        """Converts ``image_name`` again when next used."""
        for key in [k for k in self._entries if k[0] == image_name]:
            del self._entries[key]

    def forget_used_by(self, user):
        """Converts the images ``user`` used again when next used."""
        for name in self._used.pop(user, ()):
            self.forget(name)

    def clear(self):
        self._entries.clear()
        self._used.clear()
