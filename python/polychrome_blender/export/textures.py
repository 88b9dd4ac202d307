"""Blender images → ``polychrome.Texture`` (kept RGB; the core converts per hit).

8-bit images in the sRGB colour space stay sRGB bytes; float images and non-colour data
are passed as linear float. Blender's pixel rows start at the bottom, polychrome's at the
top. :class:`TextureCache` converts each image once and keeps it until the image changes."""

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


def blender_texture(node, owner, warnings):
    """A Texture for an Image (or Environment) Texture node, or None (with a warning) if
    it cannot be used."""
    img = node.image
    if img is None:
        return None
    px = image_pixels(img)
    if px is None:
        warnings.add(("img", img.name), f"{owner}: image '{img.name}' has no pixels (missing file?); its node is ignored")
        return None
    extension = getattr(node, "extension", "REPEAT")  # an Environment Texture has none
    wrap = WRAPS.get(extension)
    if wrap is None:
        warnings.add(("wrap", img.name), f"{owner}: image '{img.name}': extension {extension} is not supported; REPEAT is used")
        wrap = "REPEAT"
    px = np.nan_to_num(px[:, :, :3], nan=0.0, posinf=0.0, neginf=0.0)
    srgb = (not img.is_float) and img.colorspace_settings.name in ("sRGB", "sRGB EOTF")
    return pc.Texture.from_array(px, "srgb" if srgb else "linear", wrap, img.name)


class TextureCache:
    """Textures by (image, extension), each converted once; a cached texture's warnings
    are added again wherever it is used. Each use names its ``user`` (e.g. the material),
    so that what a changed user saw can be converted again: Blender reports a reloaded
    image as an update of the materials and worlds that use it, not of the image."""

    def __init__(self):
        self._entries = {}  # (image name, extension) -> (Texture or None, warning items)
        self._used = {}  # user -> image names it used
        self.converted = 0  # images converted; the Exporter counts per export

    def texture(self, node, owner, warnings, user=None):
        img = node.image
        if img is None:
            return None
        key = (img.original.name, getattr(node, "extension", "REPEAT"))
        self._used.setdefault(user, set()).add(key[0])
        if key not in self._entries:
            own = Warnings()
            self._entries[key] = (blender_texture(node, owner, own), own.items)
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
