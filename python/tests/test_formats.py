"""Scanner and CAD formats as another program writes them (trimesh): PLY
(binary and ASCII), STL (binary and ASCII) and OFF, read and solved."""

from __future__ import annotations

import subprocess

import numpy as np
import pytest
import trimesh

import uvpin
from conftest import grid


def as_written(tmp_path, mesh: trimesh.Trimesh, ext: str, **kwargs):
    path = tmp_path / f"mesh.{ext}"
    data = mesh.export(file_type=kwargs.pop("file_type", ext), **kwargs)
    path.write_bytes(data.encode() if isinstance(data, str) else data)
    return path


@pytest.mark.parametrize(
    "ext, kwargs",
    [("ply", {"encoding": "binary"}), ("ply", {"encoding": "ascii"}), ("off", {})],
)
def test_indexed_formats_keep_their_vertex_numbers(tmp_path, ext, kwargs):
    vertices, faces = grid(6)
    made = trimesh.Trimesh(vertices, faces, process=False)
    read = uvpin.read_mesh(as_written(tmp_path, made, ext, **kwargs))
    assert np.allclose(read.vertices, vertices)
    assert np.array_equal(read.faces, faces)


@pytest.mark.parametrize("kwargs", [{}, {"file_type": "stl_ascii"}])
def test_stl_soups_are_welded_by_position(tmp_path, kwargs):
    sphere = trimesh.creation.icosphere(subdivisions=2)
    path = as_written(tmp_path, sphere, "stl", **kwargs)
    read = uvpin.read_mesh(path)
    assert len(read.vertices) == len(sphere.vertices)
    assert len(read.faces) == len(sphere.faces)
    # The same triangles, corner for corner (as f32 positions).
    key = lambda v, f: sorted(map(tuple, np.round(np.asarray(v, dtype=np.float32)[f].reshape(-1, 9), 5)))
    assert key(read.vertices, read.faces) == key(sphere.vertices, sphere.faces)


def test_a_closed_ply_head_and_a_stl_part_are_solved_from_the_cli(tmp_path, uvpin_cli):
    sphere = trimesh.creation.icosphere(subdivisions=3)
    for ext in ["ply", "stl"]:
        path = as_written(tmp_path, sphere, ext)
        front = np.flatnonzero(sphere.vertices[:, 2] > 0.6)[:6]
        read = uvpin.read_mesh(path)
        # Vertex numbers as uvpin reads them (an STL's are its own).
        ids = [int(np.argmin(np.linalg.norm(read.vertices - sphere.vertices[v], axis=1))) for v in front]
        targets = 0.5 + 0.35 * sphere.vertices[front][:, :2]
        pins = ",\n".join(f"(vertex: {i}, uv: ({u}, {w}))" for i, (u, w) in zip(ids, targets))
        ron = tmp_path / f"{ext}.uvpin.ron"
        ron.write_text(f'(asset: "{path.name}", constraints: [{pins}])')
        out = tmp_path / f"{ext}-out.glb"
        ran = subprocess.run([str(uvpin_cli), "solve", str(ron), "-o", str(out)], capture_output=True, text=True)
        assert ran.returncode == 0, ran.stdout + ran.stderr
        assert out.is_file()


def test_broken_scanner_files_are_named_errors(tmp_path):
    bad = tmp_path / "bad.ply"
    bad.write_bytes(b"ply\nformat binary_little_endian 1.0\nelement vertex 999999999\nproperty float x\nend_header\n")
    with pytest.raises(uvpin.InputError, match="999999999 vertex elements"):
        uvpin.read_mesh(bad)
    off = tmp_path / "bad.off"
    off.write_text("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 9\n")
    with pytest.raises(uvpin.InputError, match="face 0: vertex 9 does not exist"):
        uvpin.read_mesh(off)
