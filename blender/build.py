"""Builds the Blender extension: `python blender/build.py [--wheel WHEEL] [-o ZIP]`.

Without --wheel, builds uvpin's wheel first (`maturin build --release` in
python/; maturin must be installed). Writes `target/uvpin-blender.zip`: the
Blender 4.2+ extension (blender_manifest.toml, the add-on, the wheel under
wheels/), ready for Edit > Preferences > Get Extensions > Install from Disk,
or `blender --command extension install-file -r user_default ZIP`.
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
ADDON = HERE / "uvpin_blender"

# A wheel's platform tag and the Blender platform it runs on.
PLATFORMS = [
    (re.compile(r"manylinux.*_x86_64|linux_x86_64"), "linux-x64"),
    (re.compile(r"manylinux.*_aarch64|linux_aarch64"), "linux-arm64"),
    (re.compile(r"macosx_.*_arm64"), "macos-arm64"),
    (re.compile(r"macosx_.*_x86_64"), "macos-x64"),
    (re.compile(r"win_amd64"), "windows-x64"),
    (re.compile(r"win_arm64"), "windows-arm64"),
]


def version() -> str:
    text = (REPO / "python" / "pyproject.toml").read_text(encoding="utf-8")
    found = re.search(r'^version\s*=\s*"([^"]+)"', text, re.MULTILINE)
    if not found:
        sys.exit("error: python/pyproject.toml names no version")
    return found.group(1)


def platform_of(wheel: Path) -> str:
    tag = wheel.stem.split("-")[-1]
    for pattern, platform in PLATFORMS:
        if pattern.search(tag):
            return platform
    sys.exit(f"error: {wheel.name}: no Blender platform for the wheel tag {tag}")


def build_wheel(out: Path) -> Path:
    """uvpin's abi3 wheel, built by maturin into `out`."""
    subprocess.run(
        [sys.executable, "-m", "maturin", "build", "--release", "--quiet", "-o", str(out)],
        cwd=REPO / "python",
        check=True,
    )
    wheels = sorted(out.glob("uvpin-*.whl"))
    if len(wheels) != 1:
        sys.exit(f"error: maturin left {len(wheels)} wheels in {out}")
    return wheels[0]


def package(wheel: Path, output: Path) -> None:
    manifest = (ADDON / "blender_manifest.toml.in").read_text(encoding="utf-8")
    manifest = (
        manifest.replace("@VERSION@", version())
        .replace("@PLATFORM@", platform_of(wheel))
        .replace("@WHEEL@", wheel.name)
    )
    output.parent.mkdir(parents=True, exist_ok=True)
    partial = output.with_name(output.name + ".tmp")
    with zipfile.ZipFile(partial, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("blender_manifest.toml", manifest)
        for source in sorted(ADDON.glob("*.py")):
            z.write(source, source.name)
        z.write(wheel, f"wheels/{wheel.name}")
    partial.replace(output)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--wheel", type=Path, help="uvpin's wheel (default: build it with maturin)")
    parser.add_argument("-o", "--output", type=Path, default=REPO / "target" / "uvpin-blender.zip")
    args = parser.parse_args()
    if args.wheel is not None:
        if not args.wheel.is_file():
            sys.exit(f"error: {args.wheel}: no such wheel")
        package(args.wheel, args.output)
    else:
        with tempfile.TemporaryDirectory() as tmp:
            package(build_wheel(Path(tmp)), args.output)
    print(args.output)


if __name__ == "__main__":
    main()
