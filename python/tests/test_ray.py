"""Sweeps as Ray tasks on a local cluster: the rows of `uvpin sweep`, and a
worker killed mid-sweep is retried."""

from __future__ import annotations

import csv
import os
import shutil
import subprocess
import sys
from pathlib import Path

from conftest import ASSETS

SWEEP = """(
    constraints: ["face.uvpin.ron"],
    output: "OUTPUT",
    blend: (from: 0.0, to: 1.0, steps: 3),
    jitter: (seed: 5, amplitude: 0.04, samples: 1),
    settings: [(name: "uvpin"), (name: "paper guard", solver: (guard: Paper))],
    thumbnails: true,
    thumbnail_size: 48,
)"""


def sweep_folder(tmp_path: Path) -> Path:
    for name in ["face.glb", "face.uvpin.ron", "face-guide.png"]:
        shutil.copy(ASSETS / name, tmp_path / name)
    for output in ["cli", "ray", "crash"]:
        (tmp_path / f"{output}.sweep.ron").write_text(SWEEP.replace("OUTPUT", f"out-{output}"))
    return tmp_path


def rows_without_time(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    for row in rows:
        del row["time_ms"]
    return rows


def test_a_ray_sweep_gives_the_rows_of_one_machine(tmp_path, uvpin_cli, ray_cluster):
    folder = sweep_folder(tmp_path)
    subprocess.run([str(uvpin_cli), "sweep", "cli.sweep.ron", "-q"], cwd=folder, check=True, capture_output=True)
    ran = subprocess.run(
        [sys.executable, "-m", "uvpin.ray_sweep", "ray.sweep.ron", "--address", ray_cluster],
        cwd=folder,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert ran.returncode == 0, ran.stderr
    assert "| uvpin | 3 |" in ran.stdout and "| paper guard | 3 |" in ran.stdout
    assert "[6/6]" in ran.stderr, "progress, a line per finished run"
    ray_rows = rows_without_time(folder / "out-ray" / "runs.csv")
    assert len(ray_rows) == 6
    assert ray_rows == rows_without_time(folder / "out-cli" / "runs.csv")
    sheet = lambda out: (folder / out / "contact_sheet.png").read_bytes()  # noqa: E731
    assert sheet("out-ray") == sheet("out-cli"), "the same thumbnails, the same contact sheet"

    # Again: every run is already in runs.jsonl, nothing runs.
    again = subprocess.run(
        [sys.executable, "-m", "uvpin.ray_sweep", "ray.sweep.ron", "--address", ray_cluster],
        cwd=folder,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert again.returncode == 0 and "[1/" not in again.stderr, again.stderr
    assert rows_without_time(folder / "out-ray" / "runs.csv") == ray_rows


def test_a_worker_killed_mid_sweep_is_retried(tmp_path, uvpin_cli, ray_cluster):
    folder = sweep_folder(tmp_path)
    subprocess.run([str(uvpin_cli), "sweep", "cli.sweep.ron", "-q"], cwd=folder, check=True, capture_output=True)
    marker = tmp_path / "crash-marker"
    marker.mkdir()
    code = (
        "import uvpin.ray, sys; "
        f"uvpin.ray.sweep('crash.sweep.ron', address={ray_cluster!r}, progress=False, "
        f"runtime_env={{'env_vars': {{'UVPIN_TEST_RAY_CRASH_ONCE': {str(marker)!r}}}}})"
    )
    ran = subprocess.run([sys.executable, "-c", code], cwd=folder, capture_output=True, text=True, timeout=600)
    assert ran.returncode == 0, ran.stderr
    assert (marker / "crashed").is_file(), "run 0's first worker died"
    assert rows_without_time(folder / "out-crash" / "runs.csv") == rows_without_time(folder / "out-cli" / "runs.csv")


def test_a_bad_sweep_file_exits_1_with_its_line_and_column(tmp_path):
    bad = tmp_path / "bad.sweep.ron"
    bad.write_text("(\n    constraints: [\"x.uvpin.ron\"],\n    blend: oops,\n)")
    ran = subprocess.run(
        [sys.executable, "-m", "uvpin.ray_sweep", str(bad)], capture_output=True, text=True, timeout=120,
        env=dict(os.environ, RAY_ADDRESS=""),
    )
    assert ran.returncode == 1
    assert "bad.sweep.ron:3:" in ran.stderr, ran.stderr
