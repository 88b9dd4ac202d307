"""One settings schema (the core's, `_core.settings_schema()`): the Python RenderSettings
dataclass and the `polychrome render` flags expose exactly its names, defaults, ranges
and enum items; an out-of-range value gives an error naming the setting from Python, the
core and the CLI, with the same wording; docs/settings.md's table is the schema's.
(Blender's `scene.polychrome`: tests/blender/test_settings_blender.py.)"""

from __future__ import annotations

import argparse
import dataclasses
import json
from pathlib import Path
import sys

import pytest

import polychrome as pc
from polychrome import _core, cli, settings

ROOT = Path(__file__).resolve().parents[1]
SCHEMA = json.loads(_core.settings_schema())
BY_NAME = {s["name"]: s for s in SCHEMA["settings"]}


def render_parser() -> argparse.ArgumentParser:
    parser = cli.build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return sub.choices["render"]


def test_the_dataclass_has_exactly_the_schema_settings_and_defaults():
    fields = dataclasses.fields(pc.RenderSettings)
    assert [f.name for f in fields] == [s["name"] for s in SCHEMA["settings"]]
    defaults = pc.RenderSettings()
    for f in fields:
        s = BY_NAME[f.name]
        assert f.kw_only
        assert getattr(defaults, f.name) == s["default"], f.name
        assert s["help"] in pc.RenderSettings.__doc__
    # the core reads the defaults back as valid settings (41-sample grid without a scene)
    lam, _ = _core.wavelength_grid(pc.RenderSettings().to_json())
    assert len(lam) == 41
    render_module = sys.modules["polychrome.render"]  # (polychrome.render is also the function)
    assert set(render_module.QUALITY_FIELDS) == {k for k, s in BY_NAME.items() if s["from_quality"]}
    filled = set().union(*(set(p) - {"quality"} for p in SCHEMA["presets"]))
    assert filled <= set(render_module.QUALITY_FIELDS)


def test_enum_settings_accept_their_items_in_any_case_and_nothing_else():
    for name, s in BY_NAME.items():
        if s["kind"]["type"] != "enum":
            continue
        for item in s["kind"]["items"]:
            assert getattr(pc.RenderSettings(**{name: item["name"].lower()}), name) == item["name"]
        with pytest.raises(ValueError, match=f"setting '{name}': 'NOPE' is not one of"):
            pc.RenderSettings(**{name: "NOPE"})


def bad_values():
    """(setting, a value just outside its range) for every bounded number setting."""
    for name, s in BY_NAME.items():
        k = s["kind"]
        if k["type"] == "int":
            yield name, k["min"] - 1, f"setting '{name}': {k['min'] - 1} is below the minimum {k['min']}"
            yield name, k["max"] + 1, f"setting '{name}': {k['max'] + 1} is above the maximum {k['max']}"
        elif k["type"] == "float":
            low = k["min"] - 0.5
            yield name, low, f"setting '{name}': {low:g} is below the minimum {k['min']:g}"
            if k["max"] is not None:
                yield name, k["max"] + 0.5, f"setting '{name}': {k['max'] + 0.5:g} is above the maximum {k['max']:g}"


@pytest.mark.parametrize("name,value,message", list(bad_values()))
def test_out_of_range_values_name_the_setting_in_python_and_in_the_core(name, value, message):
    with pytest.raises(ValueError) as e:
        pc.RenderSettings(**{name: value})
    assert str(e.value) == message
    with pytest.raises(ValueError) as e:  # JSON straight to the core: the same check, the same words
        _core.wavelength_grid(json.dumps({name: value}))
    assert str(e.value) == message
    s = pc.RenderSettings()  # assigned after construction: caught when sent to the core
    setattr(s, name, value)
    with pytest.raises(ValueError, match=f"setting '{name}'"):
        s.to_json()


def test_lists_types_and_lengths_are_checked():
    with pytest.raises(ValueError, match=r"setting 'wavelengths': value 1 = 900 is outside 360..830"):
        pc.RenderSettings(wavelengths=[400, 900, 500, 600])
    with pytest.raises(ValueError, match=r"setting 'wavelengths': 2 values given, need 4..401"):
        pc.RenderSettings(wavelengths=[400, 500])
    with pytest.raises(ValueError, match=r"setting 'samples': 2.5 is not a whole number"):
        pc.RenderSettings(samples=2.5)
    with pytest.raises(ValueError, match=r"setting 'spectral_output': 'yes' is not true or false"):
        pc.RenderSettings(spectral_output="yes")
    with pytest.raises(ValueError, match=r"setting 'time_limit': inf is not finite"):
        pc.RenderSettings(time_limit=float("inf"))
    with pytest.raises(TypeError):
        pc.RenderSettings(no_such_setting=1)
    assert pc.RenderSettings(samples=8.0).samples == 8 and isinstance(pc.RenderSettings(samples=8.0).samples, int)


def test_every_setting_is_a_flag_with_the_schema_help_default_and_choices():
    actions = {a.dest: a for a in render_parser()._actions}
    for name, s in BY_NAME.items():
        a = actions[name]
        assert a.option_strings[0] == "--" + name.replace("_", "-")
        assert a.default is None  # not given: the scene's (or the schema's) value
        assert a.help.startswith(s["help"]) and f"(default: {settings.describe_default(s)})" in a.help
        if s["kind"]["type"] == "enum":
            assert a.metavar == "|".join(i["name"] for i in s["kind"]["items"])
        if s["kind"]["type"] == "bool":
            assert "--no-" + name.replace("_", "-") in a.option_strings
    non_settings = {a.dest for a in render_parser()._actions} - set(BY_NAME)
    # subdivision_level: a USD reader option (docs/usd.md), not a render setting.
    assert non_settings == {"help", "scene", "output", "passes", "quiet", "frames", "frame_step", "subdivision_level"}


@pytest.mark.parametrize("name,value,message", list(bad_values()))
def test_out_of_range_flags_name_the_flag(name, value, message):
    args = render_parser().parse_args(["s.usda", "-o", "o.exr", "--" + name.replace("_", "-"), str(value)])
    with pytest.raises(ValueError) as e:
        cli._render_overrides(args)
    assert str(e.value) == message.replace(f"setting '{name}'", "--" + name.replace("_", "-"))


def test_flags_reach_the_settings_with_their_types():
    argv = ["s.usda", "-o", "o.exr", "--samples", "8", "--noise-threshold", "0.5", "--method", "rgb"]
    argv += ["--no-dispersion-splitting", "--wavelengths", "400,500,600,700", "--seed", "3"]
    o = cli._render_overrides(render_parser().parse_args(argv))
    assert o == {
        "samples": 8,
        "noise_threshold": 0.5,
        "method": "RGB",
        "dispersion_splitting": False,
        "wavelengths": [400.0, 500.0, 600.0, 700.0],
        "seed": 3,
    }
    assert cli._render_overrides(render_parser().parse_args(["s", "-o", "o", "--wavelengths", "21"])) == {"wavelength_count": 21}


def test_generators_handle_every_kind_of_setting():
    """A made-up schema with a text setting and a preset-filled float: the dataclass,
    its checks and the docs table come out right (the core's schema has no text setting yet)."""
    fake = {
        "address": {
            "name": "address",
            "group": "System",
            "label": "Address",
            "help": "Where to send work",
            "kind": {"type": "string"},
            "default": "",
            "from_quality": False,
            "blender": {"property": True, "always": False, "default": ""},
            "applies_when": None,
            "see": None,
        },
        "gain": {
            "name": "gain",
            "group": "Sampling",
            "label": "Gain",
            "help": "A gain",
            "kind": {"type": "float", "min": 0.0, "max": 2.0, "soft_min": None, "soft_max": None, "unit": None},
            "default": None,
            "from_quality": True,
            "blender": {"property": True, "always": False, "default": 1.0},
            "applies_when": None,
            "see": None,
        },
    }
    cls = settings.make_settings_class(fake, "Fake")
    assert cls().address == "" and cls().gain is None and cls(address="tcp://x:8786").address == "tcp://x:8786"
    assert json.loads(cls(gain=1.5).to_json()) == {"address": "", "gain": 1.5}
    with pytest.raises(ValueError, match="setting 'address': 3 is not text"):
        cls(address=3)
    with pytest.raises(ValueError, match="setting 'gain': 2.5 is above the maximum 2"):
        cls(gain=2.5)
    table = settings.markdown_table({"settings": list(fake.values()), "presets": [{"quality": "AUTO", "gain": 1.0}]})
    assert "| `address` |  |  | ✓ | Where to send work |" in table
    assert "| `gain` | from quality (AUTO 1) | 0..2 | shows 1; passed once set | A gain |" in table


def test_docs_settings_table_is_the_schemas():
    text = (ROOT / "docs" / "settings.md").read_text()
    assert settings.docs_section() in text, "docs/settings.md is stale: run python -m polychrome.settings --write-docs"
