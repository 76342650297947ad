"""The README's Python example, run as a new user would: the built wheel
installed with pip into a fresh virtual environment, the example run from a
folder holding the sample assets."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import venv
from pathlib import Path

import pytest

from conftest import ASSETS, REPO


def readme_example() -> str:
    text = (REPO / "README.md").read_text(encoding="utf-8")
    marker = "<!-- python-example"
    assert marker in text, "the README marks its Python example"
    block = text.split(marker, 1)[1].split("```python\n", 1)[1]
    return block.split("```", 1)[0]


def the_wheel() -> Path:
    given = os.environ.get("UVPIN_WHEEL")
    wheels = [Path(given)] if given else sorted((REPO / "target" / "wheels").glob("uvpin-*.whl"))
    if len(wheels) != 1 or not wheels[0].is_file():
        message = f"no single built wheel ({wheels}): python/run-tests builds it"
        if os.environ.get("CI"):
            pytest.fail(message)
        pytest.skip(message)
    return wheels[0]


def test_the_readme_example_runs_from_a_fresh_install_of_the_wheel(tmp_path):
    wheel = the_wheel()
    env_dir = tmp_path / "venv"
    venv.create(env_dir, with_pip=True)
    python = env_dir / "bin" / "python"
    install = subprocess.run(
        [str(python), "-m", "pip", "install", "--quiet", "--disable-pip-version-check", str(wheel)],
        capture_output=True, text=True, timeout=900,
    )
    assert install.returncode == 0, install.stderr
    work = tmp_path / "work"
    shutil.copytree(ASSETS, work / "assets")
    (work / "example.py").write_text(readme_example(), encoding="utf-8")
    ran = subprocess.run(
        [str(python), "example.py"], cwd=work, capture_output=True, text=True, timeout=600,
        env={k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")},
    )
    assert ran.returncode == 0, ran.stderr
    lines = ran.stdout.splitlines()
    assert lines[0] == "reached (400, 2) [0. 0.]", lines
    assert 1.0 <= float(lines[1]) < 1.2, "a grid patch laid out nearly isometrically"
    assert lines[2] == "reached True", "the sample solved and its output checked clean"
    assert "400" in lines[3] and "out of range" in lines[3], lines[3]
    assert (work / "out" / "face.glb").is_file() and (work / "out" / "report.json").is_file()
    where = subprocess.run(
        [str(python), "-c", "import uvpin; print(uvpin.__file__)"], cwd=tmp_path, capture_output=True, text=True
    )
    assert Path(where.stdout.strip()).is_relative_to(env_dir), "the installed wheel, not the sources"
    assert sys.version_info >= (3, 11)
