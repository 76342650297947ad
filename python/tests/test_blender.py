"""The Blender extension in headless Blender (the `bpy` wheel from PyPI, in
its own virtual environment without uvpin): the zip installs, its bundled
wheel is the uvpin that runs, and the operator lands pinned UVs exactly with
no fold, read back from Blender's own UV data."""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path

import pytest

from conftest import REPO

HERE = Path(__file__).resolve().parent


def needed(variable: str, default: Path, what: str) -> Path:
    path = Path(os.environ.get(variable, default))
    if not path.exists():
        message = f"{path} is absent ({what}; set {variable})"
        if os.environ.get("CI"):
            pytest.fail(message)
        pytest.skip(message)
    return path


@pytest.fixture(scope="module")
def blender(tmp_path_factory) -> dict:
    python = needed("UVPIN_BLENDER_PYTHON", REPO / ".tools" / "blender" / "bin" / "python",
                    "a Python with the bpy wheel")
    extension = needed("UVPIN_BLENDER_ZIP", REPO / "target" / "uvpin-blender.zip",
                       "the extension, built by blender/build.py")
    home = tmp_path_factory.mktemp("blender-home")
    ran = subprocess.run(
        [str(python), str(HERE / "blender_operator.py"), str(extension)],
        env=dict(os.environ, HOME=str(home), PYTHONNOUSERSITE="1"),
        capture_output=True,
        text=True,
        timeout=900,
    )
    lines = [line for line in ran.stdout.splitlines() if line.startswith("UVPIN-RESULT ")]
    assert ran.returncode == 0 and lines, ran.stdout[-3000:] + ran.stderr[-3000:]
    report = json.loads(lines[-1].removeprefix("UVPIN-RESULT "))
    report["stdout"] = ran.stdout
    report["home"] = str(home)
    return report


def test_the_extension_installs_and_runs_its_own_wheel(blender):
    assert Path(blender["uvpin_from"]).is_relative_to(blender["home"]), blender["uvpin_from"]
    assert "/extensions/" in blender["uvpin_from"]


def test_moved_pins_land_exactly_and_nothing_folds(blender):
    grid = blender["grid"]
    assert grid["result"] == ["FINISHED"]
    assert grid["pinned_loops"] == 20
    assert grid["pins_exact"] and grid["max_residual"] == 0.0
    assert grid["min_area"] > 0, "every triangle keeps Blender's orientation, none degenerate"
    assert grid["moved"] > 500 and grid["inside"]
    assert "Info: uvpin: reached, 5 pins" in blender["stdout"], "the status bar says reached"


def test_one_island_of_an_unwrap_is_solved_and_the_others_keep_their_bits(blender):
    sphere = blender["sphere"]
    assert sphere["result"] == ["FINISHED"]
    assert sphere["pins_exact"]
    assert sphere["min_area"] > 0
    assert sphere["others_identical"]
    assert sphere["island_loops"] < sphere["loops"], "Smart UV Project made several islands"
    assert sphere["overlaps_with_other_islands"] == 0
    assert sphere["overlaps_within_island"] == 0


def test_the_operator_is_one_undo_step(blender):
    assert blender["undo"] == {"undo_flag": True, "register_flag": True}


def test_without_pins_it_refuses_and_changes_nothing(blender):
    assert blender["unpinned"] == {"refused": True, "unchanged": True}
