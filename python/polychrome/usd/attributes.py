"""Names of the ``polychrome:`` attributes that keep spectral data in a USD stage.

Every attribute is optional: a stage without them renders from plain UsdGeom,
UsdPreviewSurface and UsdLux values. When present they win over the standard values
(docs/usd.md lists them with their types and meaning).

Spectra are stored as a JSON *string* holding the spectrum description exactly as
:meth:`polychrome.spectra.Spectrum.to_dict` writes it (``{"type": "tabulated",
"wavelengths": [...], "values": [...], "scale": 1.0}``), so every kind (named
illuminants, blackbodies, narrow bands, tables, RGB) survives losslessly. Stages written
by other tools may instead give a measured spectrum as two float arrays,
``<name>:wavelengths`` (nm, ascending) and ``<name>:values``; the reader accepts both.
"""

NAMESPACE = "polychrome"

# -- materials (on UsdShade.Material prims) -------------------------------------
#: token: the BSDF type of the core's description ("diffuse", "none", "dielectric", ...)
BSDF = "polychrome:bsdf"
#: string (JSON object): every other field of the BSDF description, not covered below
BSDF_EXTRA = "polychrome:bsdf:extra"
#: string (JSON spectrum): diffuse reflectance (or the BSDF's ``reflectance`` field)
REFLECTANCE = "polychrome:reflectance"
#: string (JSON spectrum): emitted radiance, both faces
EMISSION = "polychrome:emission"
#: token: index-of-refraction model: constant, cauchy, sellmeier, abbe, named
IOR_MODEL = "polychrome:ior:model"
#: double[]: its coefficients (constant: [n]; cauchy: [A, B, C] with λ in µm;
#: sellmeier: [B1, B2, B3, C1, C2, C3] with C in µm²; abbe: [nd, Vd])
IOR_COEFFICIENTS = "polychrome:ior:coefficients"
#: string: catalogue glass name for the ``named`` model (e.g. "N-BK7")
IOR_NAME = "polychrome:ior:name"
#: string: the polychrome material name (USD prim names are restricted identifiers)
NAME = "polychrome:name"

# -- meshes ---------------------------------------------------------------------
#: int: position of the mesh in the scene's mesh list (keeps the order of a round trip)
MESH_INDEX = "polychrome:meshIndex"
#: string: the name of the instance placed by this prim (the Mesh, or the instanceable Xform)
INSTANCE_NAME = "polychrome:instanceName"
#: int on a subdivision-surface Mesh: its refinement level, instead of the reader's
#: (UsdGeom has no per-prim level)
SUBDIVISION_LEVEL = "polychrome:subdivisionLevel"

# -- camera (on the UsdGeom.Camera prim) ----------------------------------------
#: string (JSON object): the Blender-style camera of polychrome.Camera (focal length
#: and sensor in mm, sensor fit, shift, clip) without its transform, which is the prim's
CAMERA = "polychrome:camera"

# -- lights (on UsdLux prims) ---------------------------------------------------
#: double: power in watts of a point light (polychrome.PointLight.power)
POWER = "polychrome:power"
#: string (JSON spectrum): colour of a point light (intensity = colour × power / 4π)
COLOR = "polychrome:color"
#: string (JSON spectrum): radiant intensity of a point light (used when power/colour are absent)
INTENSITY = "polychrome:intensity"
#: string (JSON spectrum): radiance of the world (on the DomeLight)
RADIANCE = "polychrome:radiance"
#: string (JSON object): the light's full description (point, spot, distant, ...); on the
#: DomeLight the HDRI's strength, rotation and importance_sampling
LIGHT = "polychrome:light"
#: string (JSON spectrum) on a RectLight / DiskLight: its exact emitted radiance (EMISSION)
#: string on a RectLight / DiskLight: the name of the emission material it came from
MATERIAL_NAME = "polychrome:materialName"
#: bool on a RectLight / DiskLight: its black backing is already a mesh of the stage
HAS_BACKING = "polychrome:hasBacking"
#: bool on a Material: its emission leaves the front face only (``Emitter(one_sided=True)``)
ONE_SIDED = "polychrome:oneSided"
#: bool on a Material: rays pass through it after gathering its emission (``Emitter(see_through=True)``)
SEE_THROUGH = "polychrome:seeThrough"

# -- render settings (on /Render/PolychromeSettings, a UsdRender.Settings prim) --
RENDER_SETTINGS_PATH = "/Render/PolychromeSettings"
# width and height are the standard ``resolution`` of UsdRender.Settings; threads belong
# to the machine that renders and are not stored.
NOT_STORED = ("width", "height", "threads")
#: Sdf value type of each kind of setting in the settings schema.
SDF_TYPES = {"int": "Int", "float": "Double", "bool": "Bool", "enum": "Token", "string": "String", "float_list": "DoubleArray"}


def _settings_attributes():
    from ..settings import SETTINGS as SCHEMA

    return {name: (f"{NAMESPACE}:{name}", SDF_TYPES[spec["kind"]["type"]]) for name, spec in SCHEMA.items() if name not in NOT_STORED}


#: polychrome.RenderSettings field → (attribute name, Sdf value type name): every stored
#: setting of the settings schema, as ``polychrome:<field>``.
SETTINGS = _settings_attributes()


def settings_items(settings):
    """(field, value) of the RenderSettings fields a stage stores; None values are skipped."""
    import dataclasses

    for f in dataclasses.fields(settings):
        value = getattr(settings, f.name)
        if f.name not in NOT_STORED and value is not None:
            yield f.name, value


ALL = [
    BSDF,
    BSDF_EXTRA,
    REFLECTANCE,
    EMISSION,
    IOR_MODEL,
    IOR_COEFFICIENTS,
    IOR_NAME,
    NAME,
    MESH_INDEX,
    INSTANCE_NAME,
    SUBDIVISION_LEVEL,
    CAMERA,
    POWER,
    COLOR,
    INTENSITY,
    RADIANCE,
    LIGHT,
    MATERIAL_NAME,
    HAS_BACKING,
    ONE_SIDED,
    SEE_THROUGH,
    *(name for name, _ in SETTINGS.values()),
]
