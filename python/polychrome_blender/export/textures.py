"""Blender images → ``polychrome.Texture`` (kept RGB; the core converts per hit).

8-bit images in the sRGB colour space stay sRGB bytes; float images and non-colour data
are passed as linear float. Blender's pixel rows start at the bottom, polychrome's at the
top. Each image is converted once per export."""

import numpy as np

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


def blender_texture(pc, node, owner, warnings, cache):
    """A Texture for an Image Texture node, or None (with a warning) if it cannot be used."""
    img = node.image
    if img is None:
        return None
    extension = getattr(node, "extension", "REPEAT")  # Environment Texture has none
    key = (img.original.name if hasattr(img, "original") else img.name, extension)
    if key in cache:
        return cache[key]
    px = image_pixels(img)
    if px is None:
        warnings.add(("img", img.name), f"{owner}: image '{img.name}' has no pixels (missing file?); its node is ignored")
        cache[key] = None
        return None
    wrap = WRAPS.get(extension)
    if wrap is None:
        warnings.add(("wrap", img.name), f"{owner}: image '{img.name}': extension {extension} is not supported; REPEAT is used")
        wrap = "REPEAT"
    px = np.nan_to_num(px[:, :, :3], nan=0.0, posinf=0.0, neginf=0.0)
    srgb = (not img.is_float) and img.colorspace_settings.name in ("sRGB", "sRGB EOTF")
    tex = pc.Texture.from_array(px, "srgb" if srgb else "linear", wrap, img.name)
    cache[key] = tex
    return tex
