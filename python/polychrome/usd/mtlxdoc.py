""".mtlx documents referenced from USD stages, without USD's usdMtlx plugin.

usd-core's wheels do not ship the usdMtlx file format (``Sdf.FileFormat.FindByExtension
("mtlx")`` is None), so a reference to ``looks.mtlx</MaterialX/Materials>`` (usd-wg/assets'
StandardShaderBall, Houdini and MaterialX exports) composes to nothing. This module reads
such a document (XML, MaterialX 1.38/1.39) into an anonymous USD layer laid out as usdMtlx
lays it out — ``/MaterialX/Materials/<material>`` with its surface on
``outputs:mtlx:surface`` — and adds, in the stage's session layer, the same reference to
that layer on every prim whose (active) reference names the document. The nodes become
UsdShade Shaders with MaterialX node ids (``ND_<category>_<type>``, the ``FA`` and
two-type variants chosen from the inputs' types, or the element's ``nodedef``), which
``materialx.py`` translates like any MaterialX network in USD. Each material carries a copy
of the nodes and node graphs it uses, so every connection stays inside the referenced
prim. Filenames are resolved against ``fileprefix`` and the document's directory;
``colorspace`` (inherited from enclosing elements) becomes the file input's ``colorSpace``.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

_TYPES = {
    "float": "Float",
    "integer": "Int",
    "boolean": "Bool",
    "color3": "Color3f",
    "color4": "Color4f",
    "vector2": "Float2",
    "vector3": "Float3",
    "vector4": "Float4",
    "string": "String",
    "filename": "Asset",
    "surfaceshader": "Token",
    "displacementshader": "Token",
    "volumeshader": "Token",
}
_FA = {"add", "subtract", "multiply", "divide", "min", "max", "power", "clamp", "invert", "modulo"}
_STRUCTURE = {"nodedef", "nodegraph", "surfacematerial", "volumematerial", "look", "materialassign", "collection", "typedef", "implementation", "output", "input", "backdrop", "geominfo", "token", "propertyset", "variantset", "lookgroup"}  # fmt: skip

#: Translated documents: (path, mtime) → (in-memory stage, its anonymous root layer).
_CACHE: dict[tuple[str, float], Any] = {}


def node_id(elem, inputs: dict[str, Any]) -> str:
    if elem.get("nodedef"):
        return str(elem.get("nodedef"))
    cat, ty = elem.tag, elem.get("type", "float")

    def in_type(n):
        e = inputs.get(n)
        return None if e is None else e.get("type")

    if cat in _FA and ty not in ("float", "integer"):
        second = {"clamp": ("low", "high"), "invert": ("amount",)}.get(cat, ("in2",))
        if any(in_type(n) == "float" for n in second):
            return f"ND_{cat}_{ty}FA"
    if cat == "mix" and ty not in ("float",) and in_type("mix") not in (None, "float"):
        return f"ND_mix_{ty}_{in_type('mix')}"
    if cat in ("convert", "swizzle"):
        return f"ND_{cat}_{in_type('in') or 'float'}_{ty}"
    if cat in ("extract", "separate2", "separate3", "separate4"):
        return f"ND_{cat}_{in_type('in') or 'color3'}"
    if cat == "normalmap":
        return "ND_normalmap"
    if cat == "place2d":
        return "ND_place2d_vector2"
    return f"ND_{cat}_{ty}"


def _values(text: str, ty: str):
    if ty in ("string", "filename"):
        return text
    parts = [p for p in text.replace(",", " ").split()]
    if ty == "boolean":
        return text.strip().lower() == "true"
    if ty == "integer":
        return int(float(parts[0]))
    nums = [float(p) for p in parts]
    return nums[0] if ty == "float" else tuple(nums)


class _Translator:
    def __init__(self, path: Path, warn):
        from pxr import Gf, Sdf, Usd, UsdShade

        self.Gf, self.Sdf, self.UsdShade = Gf, Sdf, UsdShade
        self.path = path
        self.warn = warn
        self.stage = Usd.Stage.CreateInMemory(f"{path.name}.usda")
        self.root = ET.parse(path).getroot()
        self.parent = {c: p for p in self.root.iter() for c in p}
        self.top = {e.get("name"): e for e in self.root if e.get("name")}

    def inherited(self, elem, attr: str, default: str = "") -> str:
        while elem is not None:
            if elem.get(attr) is not None:
                return str(elem.get(attr))
            elem = self.parent.get(elem)
        return default

    def set_value(self, inp, elem):
        ty = elem.get("type", "float")
        text = elem.get("value")
        if text is None:
            return
        try:
            v = _values(text, ty)
        except ValueError:
            self.warn(f"{self.path}: input {elem.get('name')} value {text!r} is not a {ty}; ignored")
            return
        Gf, Sdf = self.Gf, self.Sdf
        if ty == "filename":
            p = Path(self.inherited(elem, "fileprefix") + v)
            v = Sdf.AssetPath(str(p if p.is_absolute() else (self.path.parent / p)))
            cs = self.inherited(elem, "colorspace")
            if cs:
                inp.GetAttr().SetColorSpace(cs)
        elif ty in ("color3", "vector3"):
            v = Gf.Vec3f(*(list(v) + [0.0] * 3)[:3])
        elif ty in ("color4", "vector4"):
            v = Gf.Vec4f(*(list(v) + [0.0] * 4)[:4])
        elif ty == "vector2":
            v = Gf.Vec2f(*(list(v) + [0.0] * 2)[:2])
        inp.Set(v)

    def value_type(self, ty: str):
        return getattr(self.Sdf.ValueTypeNames, _TYPES.get(ty, "Token"))

    def node(self, scope: str, elem, graph_elem=None, made=None):
        """The Shader for `elem` under `scope` (made once per scope), connected to the
        nodes and node graphs it names."""
        key = (scope, elem.get("name"))
        if key in made:
            return made[key]
        UsdShade = self.UsdShade
        sh = UsdShade.Shader.Define(self.stage, f"{scope}/{elem.get('name')}")
        made[key] = sh
        inputs = {i.get("name"): i for i in elem.findall("input")}
        sh.CreateIdAttr(node_id(elem, inputs))
        for name, i in inputs.items():
            inp = sh.CreateInput(name, self.value_type(i.get("type", "float")))
            self.set_value(inp, i)
            self.connect(inp, i, scope, graph_elem, made)
        outputs = elem.findall("output") or [ET.Element("output", name="out", type=elem.get("type", "float"))]
        for o in outputs:
            sh.CreateOutput(o.get("name"), self.value_type(o.get("type", elem.get("type", "float"))))
        return sh

    def connect(self, inp, i, scope, graph_elem, made):
        UsdShade = self.UsdShade
        if i.get("nodename"):
            siblings = {e.get("name"): e for e in (graph_elem if graph_elem is not None else self.root) if e.get("name")}
            src = siblings.get(i.get("nodename"))
            if src is None or src.tag in _STRUCTURE:
                self.warn(f"{self.path}: node '{i.get('nodename')}' is not in the document; {i.get('name')} is left unconnected")
                return
            up = self.node(scope, src, graph_elem, made)
            out = i.get("output") or "out"
            inp.ConnectToSource(up.GetOutput(out) or up.CreateOutput(out, self.value_type(src.get("type", "float"))))
        elif i.get("nodegraph"):
            ng = self.graph(scope, i.get("nodegraph"), made)
            if ng is not None:
                inp.ConnectToSource(ng.GetOutput(i.get("output") or "out"))
        elif i.get("interfacename") and graph_elem is not None:
            g = UsdShade.NodeGraph.Get(self.stage, scope)
            gi = g.GetInput(i.get("interfacename")) if g else None
            if gi:
                inp.ConnectToSource(gi)

    def graph(self, scope: str, name: str, made):
        key = (scope, "graph:" + name)
        if key in made:
            return made[key]
        elem = self.top.get(name)
        if elem is None or elem.tag != "nodegraph":
            self.warn(f"{self.path}: node graph '{name}' is not in the document; the input is left unconnected")
            made[key] = None
            return None
        UsdShade = self.UsdShade
        path = f"{scope}/{name}"
        ng = UsdShade.NodeGraph.Define(self.stage, path)
        made[key] = ng
        for i in elem.findall("input"):
            self.set_value(ng.CreateInput(i.get("name"), self.value_type(i.get("type", "float"))), i)
        inner: dict = {}
        for o in elem.findall("output"):
            out = ng.CreateOutput(o.get("name"), self.value_type(o.get("type", "float")))
            self.connect(out, o, path, elem, inner)
        return ng

    def translate(self):
        UsdShade = self.UsdShade
        self.stage.SetDefaultPrim(self.stage.DefinePrim("/MaterialX", "Scope"))
        self.stage.DefinePrim("/MaterialX/Materials", "Scope")
        for elem in self.root:
            if elem.tag == "surfacematerial" and elem.get("name"):
                mpath = f"/MaterialX/Materials/{elem.get('name')}"
                mat = UsdShade.Material.Define(self.stage, mpath)
                s = next((i for i in elem.findall("input") if i.get("name") == "surfaceshader"), None)
                if s is None:
                    continue
                out = mat.CreateSurfaceOutput("mtlx")
                made: dict = {}
                if s.get("nodegraph"):
                    ng = self.graph(mpath, s.get("nodegraph"), made)
                    if ng is not None:
                        out.ConnectToSource(ng.GetOutput(s.get("output") or "out"))
                elif s.get("nodename") in self.top:
                    sh = self.node(mpath, self.top[s.get("nodename")], None, made)
                    out.ConnectToSource(sh.GetOutput("out"))
            elif elem.tag == "nodedef":
                self.warn(f"{self.path}: custom node definition '{elem.get('name')}' is not supported; its nodes warn where used")
        return self.stage.GetRootLayer()


def translate(path: Path, warn):
    """The anonymous layer of ``path`` (cached per file and modification time)."""
    key = (str(path), path.stat().st_mtime)
    if key not in _CACHE:
        t = _Translator(path, warn)
        _CACHE[key] = (t.stage, t.translate())  # the in-memory stage owns the layer
    return _CACHE[key][1]


def attach(stage, warn) -> set[str]:
    """Adds the translated .mtlx documents that `stage`'s active references name, in its
    session layer, on the stage prims those references compose into; returns the documents
    handled (absolute paths)."""
    from pxr import Sdf, Usd

    found = []  # (layer, spec path in that layer, absolute document path, reference)
    for layer in stage.GetUsedLayers():
        # Cheap first: only layers that name a .mtlx asset are traversed (spec by spec).
        if layer.anonymous or not any(str(d).lower().endswith(".mtlx") for d in layer.GetCompositionAssetDependencies()):
            continue

        def visit(path, layer=layer):
            if not (path.IsPrimPath() or path.IsPrimVariantSelectionPath()):
                return
            spec = layer.GetPrimAtPath(path)
            if spec is None:
                return
            for ref in (
                list(spec.referenceList.GetAddedOrExplicitItems())
                + list(spec.referenceList.prependedItems)
                + list(spec.referenceList.appendedItems)
            ):
                if ref.assetPath.lower().endswith(".mtlx"):
                    found.append((layer, path, layer.ComputeAbsolutePath(ref.assetPath), ref))

        layer.Traverse(Sdf.Path.absoluteRootPath, visit)
    if not found:
        return set()
    # Where each spec composes: the stage prims whose prim stack holds it. A spec of a
    # referenced or payloaded layer sits under another path on the stage than in its layer
    # (usd-wg's OpenChessSet: Pawn_look.usd's /Pawn/Materials is /ChessSet/Black/Pawns/Pawn/
    # Materials); a spec inside a variant the stage has not selected is in no prim stack.
    wanted = {(layer.identifier, path) for layer, path, _, _ in found}
    targets: dict = {}
    for prim in Usd.PrimRange.Stage(stage, Usd.TraverseInstanceProxies(Usd.PrimAllPrimsPredicate)):
        for spec in prim.GetPrimStack():
            key = (spec.layer.identifier, spec.path)
            if key in wanted:
                targets.setdefault(key, []).append(prim)
    handled: set[str] = set()
    session = stage.GetSessionLayer()
    seen = set()
    for layer, spec_path, doc, ref in found:
        for prim in targets.get((layer.identifier, spec_path), []):
            ns = prim.GetPath()
            if (str(ns), doc, str(ref.primPath)) in seen:
                continue
            seen.add((str(ns), doc, str(ref.primPath)))
            p = Path(doc)
            if not p.is_file():
                continue  # USD's own warning names the file
            if prim.IsInstanceProxy():
                warn(f"prim {ns}: MaterialX document {p} is referenced inside an instance; its materials are missing")
                continue
            try:
                translated = translate(p, warn)
            except (ET.ParseError, OSError, ValueError) as e:
                warn(f"prim {ns}: cannot read MaterialX document {p} ({e}); its materials are missing")
                continue
            with Usd.EditContext(stage, session):
                stage.OverridePrim(ns).GetReferences().AddReference(Sdf.Reference(translated.identifier, ref.primPath))
            handled.add(str(p))
    return handled
