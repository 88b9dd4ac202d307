"""Render passes: Combined (RGBA), Depth (Z), Normal (XYZ, world space: the shading normal, a Normal Map's or
Bump's where linked, facing the view, as Cycles'), Albedo (RGB) and,
with ``scene.polychrome.spectral_output``, one 1-channel pass per wavelength. With
``scene.polychrome.denoise`` Combined is denoised and Cycles' names carry the rest: Noisy
Image (RGBA) and the Denoising Data passes Denoising Albedo (RGB) and Denoising Normal
(XYZ), which the compositor's Denoise node takes.

Depth and Normal follow the view layer's ``use_pass_z`` / ``use_pass_normal``; Albedo is
always written. Polychrome's arrays have row 0 at the top; Blender's at the bottom.
"""

import numpy as np

NO_HIT_DEPTH = 1.0e10  # what Cycles writes where nothing was hit


def spectral_pass_names(count, lo=380.0, hi=780.0):
    """Names of the per-wavelength passes of a uniform grid (as the core builds it)."""
    if count < 2:
        return []
    return [f"Spectral {lo + (hi - lo) * i / (count - 1):.1f} nm" for i in range(count)]


def register_passes(engine, scene, renderlayer):
    engine.register_pass(scene, renderlayer, "Combined", 4, "RGBA", "COLOR")
    if renderlayer.use_pass_z:
        engine.register_pass(scene, renderlayer, "Depth", 1, "Z", "VALUE")
    if renderlayer.use_pass_normal:
        engine.register_pass(scene, renderlayer, "Normal", 3, "XYZ", "VECTOR")
    engine.register_pass(scene, renderlayer, "Albedo", 3, "RGB", "COLOR")
    if scene.polychrome.denoise:
        engine.register_pass(scene, renderlayer, "Noisy Image", 4, "RGBA", "COLOR")
        engine.register_pass(scene, renderlayer, "Denoising Normal", 3, "XYZ", "VECTOR")
        engine.register_pass(scene, renderlayer, "Denoising Albedo", 3, "RGB", "COLOR")
    if scene.polychrome.spectral_output:
        for name in spectral_pass_names(scene.polychrome.wavelength_count):
            engine.register_pass(scene, renderlayer, name, 1, "V", "VALUE")


def pass_arrays(result, width, height):
    """Blender-ordered float32 arrays by pass name, from a polychrome RenderResult (or
    None: black, as written when a render failed)."""
    if result is None:
        rgba = np.zeros((height, width, 4), np.float32)
        rgba[..., 3] = 1.0
        return {
            "Combined": rgba,
            "Depth": np.full((height, width, 1), NO_HIT_DEPTH, np.float32),
            "Normal": np.zeros((height, width, 3), np.float32),
            "Albedo": np.zeros((height, width, 3), np.float32),
        }
    depth = np.asarray(result.depth, np.float32).reshape(height, width, 1)
    depth = np.where(depth > 0.0, depth, NO_HIT_DEPTH).astype(np.float32)
    out = {
        "Combined": np.asarray(result.rgba, np.float32).reshape(height, width, 4),
        "Depth": depth,
        "Normal": np.asarray(result.normal, np.float32).reshape(height, width, 3),
        "Albedo": np.asarray(result.albedo, np.float32).reshape(height, width, 3),
    }
    if result.noisy is not None:
        out["Noisy Image"] = np.asarray(result.noisy, np.float32).reshape(height, width, 4)
        out["Denoising Albedo"] = out["Albedo"]
        out["Denoising Normal"] = out["Normal"]
    spectral = result.spectral
    if spectral is not None:
        spectral = np.asarray(spectral, np.float32).reshape(height, width, -1)
        for i, name in enumerate(spectral_pass_names(spectral.shape[2])):
            out[name] = spectral[:, :, i : i + 1]
    for k, v in out.items():
        out[k] = np.nan_to_num(v[::-1], nan=0.0, posinf=0.0, neginf=0.0) if k != "Depth" else v[::-1]
    return out


def fill_result(render_result, arrays):
    """Writes every pass present in the render result's first layer."""
    layer = render_result.layers[0]
    for p in layer.passes:
        data = arrays.get(p.name)
        if data is None:
            continue
        flat = np.ascontiguousarray(data, np.float32)
        if flat.shape[-1] != p.channels:
            continue
        p.rect.foreach_set(flat.ravel())
