#!/usr/bin/env python3
"""Builds the Polychrome Blender extension zip: the add-on folder plus the polychrome
wheel under ``wheels/`` (listed in the zip's ``blender_manifest.toml``).

    python tools/build_blender_extension.py [--out dist] [--wheel path.whl]

Steps: ``maturin build --release`` (unless ``--wheel`` is given), copy
``addon/polychrome_blender`` to a staging folder, add the wheel and its manifest entry,
then ``blender_ext.py validate`` and ``build`` from the bpy wheel when it is installed
(otherwise a plain zip with the same layout). Install the result in Blender with
Edit > Preferences > Get Extensions > Install from Disk.
"""

from __future__ import annotations

import argparse
import importlib.util
import re
import shutil
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
ADDON = ROOT / "addon" / "polychrome_blender"


def find_blender_ext() -> Path | None:
    """bl_pkg's command-line tool inside the bpy wheel, found without importing bpy."""
    spec = importlib.util.find_spec("bpy")
    if spec is None or not spec.submodule_search_locations:
        return None
    base = Path(list(spec.submodule_search_locations)[0])
    for p in sorted(base.glob("*/scripts/addons_core/bl_pkg/cli/blender_ext.py")):
        return p
    return None


def build_wheel(out: Path) -> Path:
    maturin = shutil.which("maturin", path=str(Path(sys.executable).parent)) or shutil.which("maturin")
    if maturin is None:
        sys.exit("maturin is not installed (pip install maturin) and no --wheel was given")
    wheel_dir = out / "wheel"
    wheel_dir.mkdir(parents=True, exist_ok=True)
    subprocess.run([maturin, "build", "--release", "-q", "-o", str(wheel_dir)], cwd=ROOT, check=True)
    wheels = sorted(wheel_dir.glob("polychrome-*.whl"), key=lambda p: p.stat().st_mtime)
    if not wheels:
        sys.exit("maturin produced no polychrome wheel")
    return wheels[-1]


def platform_of(wheel: Path) -> str:
    tag = wheel.stem.split("-")[-1]
    if "x86_64" in tag and "linux" in tag:
        return "linux-x64"
    if "aarch64" in tag and "linux" in tag:
        return "linux-arm64"
    if "win_amd64" in tag:
        return "windows-x64"
    if "macosx" in tag:
        return "macos-arm64" if "arm64" in tag else "macos-x64"
    return "linux-x64"


def stage(wheel: Path, staging: Path) -> Path:
    dest = staging / "polychrome_blender"
    shutil.copytree(ADDON, dest, ignore=shutil.ignore_patterns("__pycache__", "*.pyc", "wheels"))
    (dest / "wheels").mkdir()
    shutil.copy2(wheel, dest / "wheels" / wheel.name)
    manifest = (dest / "blender_manifest.toml").read_text()
    manifest = re.sub(r"(?m)^platforms = .*$", f'platforms = ["{platform_of(wheel)}"]', manifest)
    manifest = manifest.replace("[permissions]", f'wheels = ["./wheels/{wheel.name}"]\n\n[permissions]', 1)
    (dest / "blender_manifest.toml").write_text(manifest)
    return dest


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=ROOT / "dist", help="output folder (default dist/)")
    ap.add_argument("--wheel", type=Path, help="use this polychrome wheel instead of building one")
    args = ap.parse_args(argv)
    out = args.out.resolve()
    out.mkdir(parents=True, exist_ok=True)
    wheel = args.wheel.resolve() if args.wheel else build_wheel(out)
    with tempfile.TemporaryDirectory() as tmp:
        src = stage(wheel, Path(tmp))
        tool = find_blender_ext()
        if tool is not None:
            subprocess.run([sys.executable, str(tool), "validate", str(src)], check=True)
            subprocess.run([sys.executable, str(tool), "build", "--source-dir", str(src), "--output-dir", str(out)], check=True)
            zips = sorted(out.glob("polychrome_blender-*.zip"), key=lambda p: p.stat().st_mtime)
            target = zips[-1]
        else:
            target = out / "polychrome_blender-0.1.0.zip"
            with zipfile.ZipFile(target, "w", zipfile.ZIP_DEFLATED) as z:
                for p in sorted(src.rglob("*")):
                    if p.is_file():
                        z.write(p, p.relative_to(src))
    print(target)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
