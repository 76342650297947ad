"""Shared fixtures: the repository's paths, procedural meshes, the CLI, and a
local Ray cluster (`ray start --head`, 2 CPUs) for the Ray tests."""

from __future__ import annotations

import os
import secrets
import shutil
import socket
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]
ASSETS = REPO / "assets"
SHARED_MESHES = REPO.parent / "shared" / "meshes"


def shared_mesh(name: str) -> Path:
    """A mesh of ../shared/meshes: absent, the test says so (and fails in CI)."""
    path = SHARED_MESHES / name
    if not path.is_file():
        message = f"{path} is absent (the third-party meshes live beside the repository)"
        if os.environ.get("CI"):
            pytest.fail(message)
        pytest.skip(message)
    return path


def grid(n: int) -> tuple[np.ndarray, np.ndarray]:
    """An n × n grid patch in the plane z = 0: vertices (n², 3), faces."""
    xs, ys = np.meshgrid(np.arange(n, dtype=float), np.arange(n, dtype=float))
    vertices = np.c_[xs.ravel(), ys.ravel(), np.zeros(n * n)]
    a = (np.arange(n - 1)[None, :] + n * np.arange(n - 1)[:, None]).ravel()
    faces = np.r_[np.c_[a, a + 1, a + n + 1], np.c_[a, a + n + 1, a + n]]
    return vertices, faces


@pytest.fixture(scope="session")
def uvpin_cli() -> Path:
    """The uvpin binary (UVPIN_BIN, else the release build of this repository)."""
    path = Path(os.environ.get("UVPIN_BIN", REPO / "target" / "release" / "uvpin"))
    if not path.is_file():
        pytest.fail(f"{path} is absent: build it with `cargo build --release`")
    return path


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture(scope="session")
def ray_cluster(tmp_path_factory: pytest.TempPathFactory):
    """A local Ray cluster, as `ray start --head` starts one on a machine; its address."""
    ray_bin = Path(sys.executable).with_name("ray")
    port = free_port()
    temp = tmp_path_factory.mktemp("ray")
    # Token authentication, as Ray starts clusters: the cluster and every
    # client of this session (the tests' subprocesses too) share the token.
    token = temp / "auth_token"
    token.write_text(secrets.token_hex(32))
    os.environ.update(RAY_AUTH_MODE="token", RAY_AUTH_TOKEN_PATH=str(token), RAY_USAGE_STATS_ENABLED="0")
    env = dict(os.environ)
    start = [
        str(ray_bin), "start", "--head", f"--port={port}", "--num-cpus=2",
        "--include-dashboard=false", "--disable-usage-stats", f"--temp-dir={temp}",
    ]
    subprocess.run(start, check=True, env=env, capture_output=True, timeout=300)
    try:
        yield f"127.0.0.1:{port}"
    finally:
        subprocess.run([str(ray_bin), "stop", "--force"], env=env, capture_output=True, timeout=300)
        shutil.rmtree(temp, ignore_errors=True)
