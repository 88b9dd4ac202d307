"""``scene.polychrome``: the render settings, with the same names as
:class:`polychrome.RenderSettings` (and the CLI flags)."""

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty, PointerProperty

METHOD_ITEMS = [
    ("POLYCHROMATIC", "Polychromatic Rays", "Every ray carries the whole sampled spectrum (the paper's method, default)"),
    ("MONOCHROMATIC_RAYS", "Monochromatic Rays", "Every ray carries one wavelength"),
    ("MONOCHROMATIC_SCENES", "Monochromatic Scenes", "One render per wavelength, summed"),
    ("RGB", "RGB", "Three-channel rendering, for comparison with the spectral methods"),
]
DIRECTION_ITEMS = [
    ("BACKWARD", "Backward", "Path tracing from the camera with next-event estimation"),
    ("FORWARD", "Forward", "Light tracing from the lights, splatted onto the film"),
    ("BIDIRECTIONAL", "Bidirectional", "Backward and forward tracing combined"),
]
UPLIFT_ITEMS = [
    ("LINEAR", "Linear", "The paper's linear RGB to spectrum map (eq. 10)"),
    ("SMOOTH", "Smooth", "A smooth bounded non-linear uplift"),
]


QUALITY_ITEMS = [
    ("AUTO", "Auto", "Wavelength grid fitted to the scene's spectra, adaptive sampling to the noise threshold"),
    ("PREVIEW", "Preview", "16 wavelengths, at most 32 samples stopping at dE00 3, 4 bounces"),
    ("FINAL", "Final", "41 wavelengths, 256 samples, 8 bounces, no adaptive stop"),
    ("REFERENCE", "Reference", "81 wavelengths, 2048 samples, 16 bounces, no adaptive stop"),
]


class PolychromeRenderSettings(bpy.types.PropertyGroup):
    quality: EnumProperty(
        name="Quality",
        items=QUALITY_ITEMS,
        default="AUTO",
        description="Fills the settings never set here (wavelengths, max bounces, noise threshold); a value set explicitly wins",
    )
    noise_threshold: FloatProperty(
        name="Noise Threshold",
        default=0.0,
        min=0.0,
        soft_max=10.0,
        description="Adaptive sampling: a pixel stops at this estimated dE00, Samples being the maximum (0: off, every pixel gets Samples)",
    )
    method: EnumProperty(name="Method", items=METHOD_ITEMS, default="POLYCHROMATIC")
    direction: EnumProperty(name="Direction", items=DIRECTION_ITEMS, default="BACKWARD")
    wavelength_count: IntProperty(name="Wavelengths", description="Samples of the 380-780 nm grid", default=41, min=4, max=401)
    samples: IntProperty(name="Samples", description="Samples per pixel", default=64, min=1, soft_max=4096)
    max_bounces: IntProperty(name="Max Bounces", default=8, min=0, max=1024)
    seed: IntProperty(name="Seed", description="Same settings and seed give the same pixels", default=0, min=0)
    time_limit: FloatProperty(
        name="Time Limit", description="Seconds after which no new pass starts (0: none)", default=0.0, min=0.0, unit="TIME_ABSOLUTE"
    )
    uplift: EnumProperty(name="RGB Uplift", items=UPLIFT_ITEMS, default="LINEAR")
    dispersion_splitting: BoolProperty(
        name="Dispersion Splitting",
        description="Polychromatic rays: at the first dispersive surface split into one ray per wavelength "
        "instead of choosing one (deterministic mode)",
        default=False,
    )
    spectral_output: BoolProperty(
        name="Spectral Passes",
        description="Also write one pass per wavelength ('Spectral 550.0 nm', spectral radiance) into the render result and multilayer EXR",
        default=False,
    )
    threads: IntProperty(name="Threads", description="Worker threads (0: every core)", default=0, min=0, max=1024)
    viewport_samples: IntProperty(
        name="Viewport Samples",
        description="Samples per pixel of the interactive viewport render (it refines up to this many, "
        "restarting on every edit or view change)",
        default=256,
        min=1,
        soft_max=4096,
    )
    viewport_pixel_size: IntProperty(
        name="Viewport Pixel Size",
        description="Screen pixels per rendered pixel in the viewport (larger: faster, blockier)",
        default=2,
        min=1,
        max=16,
    )


classes = (PolychromeRenderSettings,)


def register():
    for c in classes:
        bpy.utils.register_class(c)
    bpy.types.Scene.polychrome = PointerProperty(type=PolychromeRenderSettings)


def unregister():
    if hasattr(bpy.types.Scene, "polychrome"):
        del bpy.types.Scene.polychrome
    for c in reversed(classes):
        bpy.utils.unregister_class(c)
