"""The render settings' schema, read from the core (``_core.settings_schema()``), and what
is generated from it at import time: the :class:`polychrome.RenderSettings` dataclass
(fields, defaults, docstring, validation), the ``polychrome render`` flags (cli.py), the
Blender ``scene.polychrome`` properties and panel (polychrome_blender/properties.py,
ui.py) and the table in docs/settings.md (``python -m polychrome.settings --write-docs``).

A setting is declared once, in rust/core/src/render/settings.rs; nothing here names one
(docs/architecture.md, "Where a new setting goes").
"""

from __future__ import annotations

import dataclasses
import json
import math
import numbers
from pathlib import Path
from typing import Any

from . import _core

#: The schema as the core exports it: ``{"settings": [...], "presets": {...}}``.
SCHEMA: dict[str, Any] = json.loads(_core.settings_schema())
#: Each setting's schema entry by name, in the schema's order.
SETTINGS: dict[str, dict[str, Any]] = {s["name"]: s for s in SCHEMA["settings"]}
#: What each quality preset fills, in the schema's order: ``PRESETS["AUTO"]["samples"]``
#: etc. (``wavelength_count`` None: fitted to the scene).
PRESETS: dict[str, dict[str, Any]] = {p["quality"]: {k: v for k, v in p.items() if k != "quality"} for p in SCHEMA["presets"]}


def choices(name: str) -> tuple[str, ...]:
    """The values of enum setting ``name``."""
    return tuple(item["name"] for item in SETTINGS[name]["kind"]["items"])


def _number(x: Any) -> str:
    """A number as the core writes it in messages (1, 0.5, 1e-05)."""
    return str(int(x)) if isinstance(x, float) and x.is_integer() else str(x)


def check(name: str, value: Any, schema: dict[str, dict[str, Any]] | None = None) -> Any:
    """``value`` for setting ``name`` normalised (enum names upper case, whole numbers as
    int, lists as floats), or ValueError "setting 'name': ..." with the same problem the
    core reports. None (unset) is returned as is where a quality preset fills the setting."""
    spec = (schema or SETTINGS)[name]
    kind = spec["kind"]
    t = kind["type"]

    def fail(problem: str) -> ValueError:
        return ValueError(f"setting '{name}': {problem}")

    if value is None:
        if spec["from_quality"] or spec["default"] is None:
            return None
        raise fail("must be set (it has no quality preset)")
    if t == "enum":
        allowed = [item["name"] for item in kind["items"]]
        v = str(value).upper()
        if v not in allowed:
            raise fail(f"'{value}' is not one of {', '.join(allowed)}")
        return v
    if t == "bool":
        if isinstance(value, bool) or (isinstance(value, numbers.Integral) and value in (0, 1)):
            return bool(value)
        if type(value).__name__ == "bool_":  # numpy.bool_
            return bool(value)
        raise fail(f"{value!r} is not true or false")
    if t == "string":
        if not isinstance(value, str):
            raise fail(f"{value!r} is not text")
        return value
    if t == "int":
        if isinstance(value, bool) or not (isinstance(value, numbers.Integral) or (isinstance(value, float) and value.is_integer())):
            raise fail(f"{value!r} is not a whole number")
        v = int(value)
        if v < kind["min"]:
            raise fail(f"{v} is below the minimum {kind['min']}")
        if v > kind["max"]:
            raise fail(f"{v} is above the maximum {kind['max']}")
        return v
    if t == "float":
        if isinstance(value, bool) or not isinstance(value, numbers.Real):
            raise fail(f"{value!r} is not a number")
        v = float(value)
        if not math.isfinite(v):
            raise fail(f"{value} is not finite")
        if v < kind["min"]:
            raise fail(f"{_number(v)} is below the minimum {_number(kind['min'])}")
        if kind["max"] is not None and v > kind["max"]:
            raise fail(f"{_number(v)} is above the maximum {_number(kind['max'])}")
        return v
    if t == "float_list":
        try:
            values = [float(x) for x in value]
        except (TypeError, ValueError):
            raise fail(f"{value!r} is not a list of numbers") from None
        lo, hi = kind["min_len"], kind["max_len"]
        if not lo <= len(values) <= hi:
            raise fail(f"{len(values)} values given, need {lo}..{hi}")
        for i, x in enumerate(values):
            if not (math.isfinite(x) and kind["min"] <= x <= kind["max"]):
                raise fail(f"value {i} = {_number(x)} is outside {_number(kind['min'])}..{_number(kind['max'])}")
        return values
    raise fail(f"unknown setting type '{t}'")  # pragma: no cover - a schema newer than this file


def python_type(spec: dict[str, Any]) -> Any:
    """The annotation of a setting's dataclass field."""
    base = {"int": int, "float": float, "bool": bool, "enum": str, "string": str, "float_list": list[float]}[spec["kind"]["type"]]
    return base | None if spec["default"] is None else base


def describe_default(spec: dict[str, Any], presets: dict[str, Any] | None = None) -> str:
    """The default in words: its value, or what the quality presets fill."""
    presets = PRESETS if presets is None else presets
    if isinstance(presets, list):
        presets = {p["quality"]: p for p in presets}
    if spec["default"] is None:
        if spec["from_quality"]:
            values = []
            for q, p in presets.items():
                v = p.get(spec["name"])
                values.append(f"{q} {_value_text(v) if v is not None else 'fitted'}")
            return "from quality (" + ", ".join(values) + ")" if any(spec["name"] in p for p in presets.values()) else "from quality"
        return "none"
    return _value_text(spec["default"])


def _value_text(v: Any) -> str:
    if isinstance(v, bool):
        return "on" if v else "off"
    if isinstance(v, float):
        return _number(v)
    return str(v)


def make_settings_class(schema: dict[str, dict[str, Any]] | None = None, name: str = "RenderSettings") -> type:
    """The settings dataclass for ``schema`` (default: the core's): one keyword field per
    setting with its default and type, validated on construction (and by
    ``dataclasses.replace``), ``to_json()`` for the core."""
    schema = SETTINGS if schema is None else schema
    fields = []
    for s in schema.values():
        default = s["default"]
        f = dataclasses.field(default=list(default) if isinstance(default, list) else default, metadata={"schema": s})
        fields.append((s["name"], python_type(s), f))

    def __post_init__(self) -> None:
        for s in schema.values():
            object.__setattr__(self, s["name"], check(s["name"], getattr(self, s["name"]), schema))

    def to_json(self) -> str:
        """The settings as the core reads them (unset ones left out: the preset fills them)."""
        for s in schema.values():  # fields may have been assigned after construction
            check(s["name"], getattr(self, s["name"]), schema)
        d = {k: check(k, v, schema) for k, v in dataclasses.asdict(self).items() if v is not None}
        return json.dumps(d)

    lines = [
        "Everything that controls a render; generated from the core's settings schema, so the",
        "names, defaults and ranges are those of the ``polychrome render`` flags and Blender's",
        "``scene.polychrome``. A value of None is filled by ``quality``; a bad value raises",
        "ValueError naming the setting.",
        "",
        "Attributes:",
    ]
    for s in schema.values():
        lines.append(f"    {s['name']}: {s['help']}. Default: {describe_default(s)}.")
    cls = dataclasses.make_dataclass(
        name,
        fields,
        namespace={"__post_init__": __post_init__, "to_json": to_json, "__doc__": "\n".join(lines)},
        kw_only=True,
    )
    cls.__module__ = "polychrome.render"
    return cls


# ------------------------------------------------------------------ docs/settings.md

DOC_BEGIN = "<!-- settings table: generated from the schema by `python -m polychrome.settings --write-docs`; do not edit -->"
DOC_END = "<!-- end of the settings table -->"


def _range_text(spec: dict[str, Any]) -> str:
    k = spec["kind"]
    t = k["type"]
    if t == "enum":
        return ", ".join(f"`{i['name']}`" for i in k["items"])
    if t == "int":
        return f"{k['min']}..{k['max']}"
    if t == "float":
        unit = f" {k['unit']}" if k.get("unit") else ""
        return f"≥ {_number(k['min'])}{unit}" if k["max"] is None else f"{_number(k['min'])}..{_number(k['max'])}{unit}"
    if t == "float_list":
        return f"{k['min_len']}..{k['max_len']} values in {_number(k['min'])}..{_number(k['max'])} {k.get('unit') or ''}".rstrip()
    return ""


def markdown_table(schema: dict[str, Any] | None = None) -> str:
    """docs/settings.md's table, from the schema."""
    schema = SCHEMA if schema is None else schema
    rows = [
        "| setting | default | range | Blender | meaning |",
        "| --- | --- | --- | --- | --- |",
    ]
    for s in schema["settings"]:
        b = s["blender"]
        if not b["property"]:
            blender = b["elsewhere"]
        elif b["always"]:
            blender = f"default {_value_text(b['default'])} (always passed)"
        elif s["from_quality"]:
            blender = f"shows {_value_text(b['default'])}; passed once set"
        else:
            blender = "✓"
        meaning = s["help"]
        if s["applies_when"]:
            meaning += f"; {s['applies_when']['value']} only"
        if s["see"]:
            meaning += f"; see [{s['see']}]({s['see']})"
        default = describe_default(s, schema["presets"])
        rows.append(f"| `{s['name']}` | {default} | {_range_text(s)} | {blender} | {meaning} |")
    return "\n".join(rows)


def docs_section(schema: dict[str, Any] | None = None) -> str:
    return f"{DOC_BEGIN}\n{markdown_table(schema)}\n{DOC_END}"


def write_docs(path: Path) -> bool:
    """Replaces the generated table in ``path``; returns whether it changed."""
    text = path.read_text()
    start, end = text.index(DOC_BEGIN), text.index(DOC_END) + len(DOC_END)
    new = text[:start] + docs_section() + text[end:]
    if new != text:
        path.write_text(new)
    return new != text


if __name__ == "__main__":  # pragma: no cover - a maintenance command
    import sys

    docs = Path(__file__).resolve().parents[2] / "docs" / "settings.md"
    if sys.argv[1:] == ["--write-docs"]:
        print(f"{docs}: {'updated' if write_docs(docs) else 'already current'}")
    else:
        print(markdown_table())
