"""Blender's `scene.polychrome` against the core's settings schema, read in a bpy
subprocess through RNA: every setting the schema shows in Blender is a property with the
schema's label, description, default (Blender's where the schema says it differs),
hard and soft range and enum items; the others are not properties; the panel draws the
schema's rows; an out-of-range value cannot be typed in (RNA clamps to the schema's
range) and one stored around RNA is reported naming the setting."""

import json

import pytest

from polychrome import _core

from .bhelper import check, run_bpy

pytestmark = pytest.mark.blender

SCHEMA = json.loads(_core.settings_schema())


def test_scene_polychrome_properties_are_the_schemas(tmp_path):
    proc, res = run_bpy(
        tmp_path,
        """
    props = {}
    for p in polychrome_blender.properties.PolychromeRenderSettings.bl_rna.properties:
        if p.identifier in ('rna_type', 'name'):
            continue
        d = dict(type=p.type, label=p.name, description=p.description)
        if p.type in ('INT', 'FLOAT'):
            d.update(default=p.default, min=p.hard_min, max=p.hard_max, soft_min=p.soft_min, soft_max=p.soft_max)
        elif p.type == 'ENUM':
            d.update(default=p.default, items=[[i.identifier, i.name, i.description] for i in p.enum_items])
        else:
            d.update(default=p.default)
        props[p.identifier] = d
    # the panel's rows: draw() on a layout that records what it is asked to show
    class Layout:
        def __init__(self, rows): self.rows = rows
        def column(self, **kw): return self
        def row(self, **kw): return self
        def prop(self, data, name, **kw): self.rows.append(name)
        use_property_split = use_property_decorate = active = False
    rows = []
    import types
    panel = types.SimpleNamespace(layout=Layout(rows))
    polychrome_blender.ui.RENDER_PT_polychrome.draw(panel, types.SimpleNamespace(scene=bpy.context.scene))
    emit(props=props, rows=rows)
    """,
    )
    r = check(proc, res)[0]
    props, rows = r["props"], r["rows"]
    shown = [s for s in SCHEMA["settings"] if s["blender"]["property"]]
    assert set(props) == {s["name"] for s in shown} | {"viewport_samples", "viewport_pixel_size"}
    types = {"int": "INT", "float": "FLOAT", "bool": "BOOLEAN", "enum": "ENUM", "string": "STRING"}
    for s in shown:
        p, k = props[s["name"]], s["kind"]
        assert p["type"] == types[k["type"]], s["name"]
        assert (p["label"], p["description"]) == (s["label"], s["help"]), s["name"]
        assert p["default"] == pytest.approx(s["blender"]["default"]), s["name"]
        if k["type"] in ("int", "float"):
            assert p["min"] == pytest.approx(k["min"]), s["name"]
            if k["max"] is not None:
                assert p["max"] == pytest.approx(min(k["max"], 2**31 - 1)), s["name"]
            if k["soft_max"] is not None:
                assert p["soft_max"] == pytest.approx(k["soft_max"]), s["name"]
        if k["type"] == "enum":
            assert p["items"] == [[i["name"], i["label"], i["description"]] for i in k["items"]]
    # where Blender's default differs, the schema says so once: samples, explicit as in Cycles
    samples = next(s for s in SCHEMA["settings"] if s["name"] == "samples")
    assert samples["default"] is None and samples["blender"] == {"property": True, "always": True, "default": 64}
    assert rows == [s["name"] for s in sorted(shown, key=lambda s: [g["group"] for g in shown].index(s["group"]))] + [
        "viewport_samples",
        "viewport_pixel_size",
    ]


def test_blender_values_reach_the_settings_and_bad_ones_name_the_setting(tmp_path):
    proc, res = run_bpy(
        tmp_path,
        """
    from polychrome_blender.engine import settings_from_scene
    sc = empty_scene(8, 6)
    sc.render.engine = 'POLYCHROME'
    add_camera(sc, (0, -4, 0))
    p = sc.polychrome
    first = settings_from_scene(p, 8, 6)
    p.max_bounces = 3; p.quality = 'PREVIEW'; p.method = 'RGB'
    second = settings_from_scene(p, 8, 6)
    p.samples = 0                                   # RNA clamps to the schema's minimum
    clamped = p.samples
    try:
        p.method = 'HYPERSPECTRAL'
        enum_error = None
    except TypeError as e:
        enum_error = str(e)
    def render():
        try:
            bpy.ops.render.render()
        except RuntimeError:  # raised after the engine's ERROR report (Blender's operator convention)
            pass
        return Engine.last_error
    p['samples'] = 0                                # stored around RNA (e.g. by a script or an old file)
    err = render()
    p['samples'] = 4
    p.method = 'POLYCHROMATIC'
    p.dispersion_splitting = True; p.method = 'RGB'  # valid alone, not together: the core says which
    err2 = render()
    emit(first=json.loads(first.to_json()), second=json.loads(second.to_json()), clamped=clamped,
         enum_error=enum_error, err=err, err2=err2)
    """,
    )
    r = check(proc, res)[0]
    first, second = r["first"], r["second"]
    assert first["samples"] == 64 and first["width"] == 8 and first["height"] == 6
    assert "max_bounces" not in first and "wavelength_count" not in first and "noise_threshold" not in first
    assert (second["max_bounces"], second["quality"], second["method"]) == (3, "PREVIEW", "RGB")
    assert r["clamped"] == 1
    # Blender's own message for a bad enum names the value and lists the schema's items
    methods = next(s for s in SCHEMA["settings"] if s["name"] == "method")["kind"]["items"]
    assert "HYPERSPECTRAL" in r["enum_error"] and all(i["name"] in r["enum_error"] for i in methods)
    assert r["err"] == "setting 'samples': 0 is below the minimum 1"
    assert "dispersion_splitting" in r["err2"]
