"""The extension manifest validates with Blender's own tool, and the zip built by
tools/build_blender_extension.py installs as an extension and renders."""

import importlib.util
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from .bhelper import ROOT, check, run_bpy

pytestmark = pytest.mark.blender


def blender_ext():
    spec = importlib.util.find_spec("bpy")
    if spec is None or not spec.submodule_search_locations:
        pytest.skip("bpy is not installed")
    found = sorted(Path(list(spec.submodule_search_locations)[0]).glob("*/scripts/addons_core/bl_pkg/cli/blender_ext.py"))
    if not found:
        pytest.skip("bpy has no blender_ext.py")
    return found[0]


def fake_wheel(folder: Path) -> Path:
    """A tiny valid pure-Python wheel, standing in for the polychrome wheel (building the
    real one takes about a minute; the venv's polychrome serves the render)."""
    name = "polychrome_pkgtest"
    whl = folder / f"{name}-0.0.1-py3-none-any.whl"
    di = f"{name}-0.0.1.dist-info"
    with zipfile.ZipFile(whl, "w") as z:
        z.writestr(f"{name}/__init__.py", "VALUE = 42\n")
        z.writestr(f"{di}/METADATA", f"Metadata-Version: 2.1\nName: {name}\nVersion: 0.0.1\n")
        z.writestr(f"{di}/WHEEL", "Wheel-Version: 1.0\nGenerator: test\nRoot-Is-Purelib: true\nTag: py3-none-any\n")
        z.writestr(f"{di}/RECORD", "")
    return whl


def test_manifest_validates():
    proc = subprocess.run(
        [sys.executable, str(blender_ext()), "validate", str(ROOT / "addon" / "polychrome_blender")],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr


def test_extension_zip_installs_and_renders(tmp_path):
    blender_ext()
    whl = fake_wheel(tmp_path)
    out = tmp_path / "dist"
    proc = subprocess.run(
        [sys.executable, str(ROOT / "tools" / "build_blender_extension.py"), "--out", str(out), "--wheel", str(whl)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr
    zips = list(out.glob("polychrome_blender-*.zip"))
    assert len(zips) == 1
    with zipfile.ZipFile(zips[0]) as z:
        names = z.namelist()
        manifest = z.read("blender_manifest.toml").decode()
    assert f"wheels/{whl.name}" in names and "engine.py" in names and "export/meshes.py" in names
    assert f'wheels = ["./wheels/{whl.name}"]' in manifest
    proc, res = run_bpy(
        tmp_path,
        f"""
    polychrome_blender.unregister()            # use the installed copy, not the source tree
    import addon_utils
    mod = 'bl_ext.user_default.polychrome_blender'
    r = bpy.ops.extensions.package_install_files(filepath={str(zips[0])!r}, repo='user_default', enable_on_install=True)
    atexit.register(addon_utils.disable, mod, default_set=True)
    enabled = mod in bpy.context.preferences.addons
    import polychrome_pkgtest                  # the bundled wheel is on sys.path
    sc = bpy.context.scene
    sc.render.engine = 'POLYCHROME'
    sc.render.resolution_x, sc.render.resolution_y, sc.render.resolution_percentage = 16, 12, 100
    sc.polychrome.samples = 2
    sc.render.filepath = os.path.abspath('inst.png')
    rr = bpy.ops.render.render(write_still=True)
    eng = sys.modules[mod + '.engine'].PolychromeRenderEngine
    emit(r=list(r), enabled=enabled, value=polychrome_pkgtest.VALUE, rr=list(rr), err=eng.last_error,
         png=os.path.exists('inst.png'))
    addon_utils.disable(mod, default_set=True)
    """,
    )
    r = check(proc, res)[0]
    assert r["r"] == ["FINISHED"] and r["enabled"] and r["value"] == 42
    assert r["rr"] == ["FINISHED"] and r["err"] is None and r["png"]
