"""The Python package: numpy in and out, files, checks, bad input."""

from __future__ import annotations

import json
import threading

import numpy as np
import pytest

import uvpin
from conftest import ASSETS, grid, shared_mesh

TOLERANCE = 1e-6


def assert_clean(vertices, faces, uv):
    """Fold-free and one-to-one, as uvpin's own check reads the UVs (per
    vertex, or per face corner: each corner its own vertex)."""
    if uv.ndim == 3:
        vertices, faces, uv = vertices[faces].reshape(-1, 3), np.arange(3 * len(faces)).reshape(-1, 3), uv.reshape(-1, 2)
    checked = uvpin.check(vertices, faces, uv)
    assert checked["clean"], checked
    assert all(c["flipped"] == 0 and c["zero_area"] == 0 for c in checked["charts"])
    assert checked["atlas"]["injective"]


def test_a_grid_reaches_its_pins_and_stays_fold_free():
    v, f = grid(20)
    pins = {210: (0.4, 0.5), 45: (0.3, 0.2), 330: (0.7, 0.8)}
    result = uvpin.solve(v, f, pins)
    assert result.status == "reached" and result.reached
    assert result.uv.shape == (400, 2) and result.uv.dtype == np.float64
    for (vertex, target), residual in zip(pins.items(), result.residuals):
        assert np.linalg.norm(result.uv[vertex] - target) <= TOLERANCE
        assert residual <= TOLERANCE
    assert result.report["orientation"] == {"flipped": 0, "zero_area": 0}
    assert_clean(v, f, result.uv)


def test_pins_as_arrays_and_a_free_boundary_inside_a_region():
    v, f = grid(16)
    ids = np.array([100, 140], dtype=np.int32)
    targets = np.array([[0.3, 0.35], [0.6, 0.62]])
    result = uvpin.solve(v, f, (ids, targets), boundary="free", region=(0.1, 0.1, 0.9, 0.9))
    assert result.status == "reached"
    assert np.allclose(result.uv[ids], targets, atol=TOLERANCE)
    assert result.uv.min() >= 0.1 - 1e-6 and result.uv.max() <= 0.9 + 1e-6
    assert result.report["boundary_mode"] == "free"
    assert_clean(v, f, result.uv)


def test_an_atlas_keeps_its_other_charts_bit_for_bit():
    # Two grids side by side, each its own chart in an existing atlas.
    v1, f1 = grid(8)
    v2, f2 = grid(8)
    v = np.r_[v1, v2 + [20.0, 0.0, 0.0]]
    f = np.r_[f1, f2 + len(v1)]
    uv1 = v1[:, :2] / 7 * [0.45, 1.0]
    uv2 = v2[:, :2] / 7 * [0.45, 1.0] + [0.55, 0.0]
    uvs = np.r_[uv1, uv2].astype(np.float32).astype(np.float64)
    result = uvpin.solve(v, f, {27: (0.2, 0.5)}, uvs=uvs, boundary="free", region=(0, 0, 0.5, 1))
    assert result.status == "reached"
    assert np.array_equal(result.uv[64:], uvs[64:]), "the other chart keeps its UVs"
    assert not np.array_equal(result.uv[:64], uvs[:64])
    assert_clean(v, f, result.uv)


def test_the_sample_solved_from_arrays_matches_the_file_solve(tmp_path):
    out = tmp_path / "face.glb"
    report = uvpin.solve_file(ASSETS / "face.uvpin.ron", out, report=tmp_path / "report.json")
    assert report["status"] == "reached"
    assert json.loads((tmp_path / "report.json").read_text())["status"] == "reached"
    source = uvpin.read_mesh(ASSETS / "face.glb")
    written = uvpin.read_mesh(out)
    assert np.array_equal(source.vertices, written.vertices) and np.array_equal(source.faces, written.faces)
    pins = {c["vertex"]: tuple(c["target"]) for c in report["constraints"]}
    corners = (1711, 168, 199, 1742)  # as the sample's constraint file gives them
    result = uvpin.solve(source.vertices, source.faces, pins, corners=corners)
    assert result.status == "reached"
    assert np.abs(result.uv - written.uvs).max() <= 1e-6
    checked = uvpin.check(out, constraints=ASSETS / "face.uvpin.ron")
    assert checked["clean"], checked


@pytest.mark.parametrize("name", ["face.glb", "lion.glb", "woody.glb", "camelhead.glb"])
def test_shared_meshes_reach_targets_of_a_warped_fold_free_layout(name):
    mesh = uvpin.read_mesh(shared_mesh(name))
    free = uvpin.solve(mesh.vertices, mesh.faces, {}, boundary="free")
    assert free.status == "reached"
    # Targets: the free layout under a gentle smooth warp (a fold-free
    # witness), at vertices off any seam (one UV each).
    corners = free.corner_uv.reshape(-1, 2)
    flat = mesh.faces.reshape(-1)
    per_vertex = np.full((len(mesh.vertices), 2), np.nan)
    per_vertex[flat] = corners
    on_seam = np.zeros(len(mesh.vertices), dtype=bool)
    on_seam[flat[np.any(per_vertex[flat] != corners, axis=1)]] = True
    rng = np.random.default_rng(len(name))
    used = np.setdiff1d(np.unique(mesh.faces), np.flatnonzero(on_seam))
    picks = rng.choice(used, size=12, replace=False)
    centre = per_vertex[used].mean(axis=0)
    warped = centre + (per_vertex[picks] - centre) * 0.9 + 0.02 * np.sin(3 * per_vertex[picks][:, ::-1])
    result = uvpin.solve(mesh.vertices, mesh.faces, (picks, np.clip(warped, 0, 1)), boundary="free")
    assert result.status in ("reached", "partial")
    if result.status == "reached":
        assert np.all(result.residuals <= TOLERANCE)
    used_faces = mesh.faces
    assert_clean(mesh.vertices, used_faces, result.uv)


def test_inspect_and_check_of_files():
    found = uvpin.inspect(ASSETS / "face.glb", boundary=True)
    # The outer loop, the eyes and the mouth.
    assert found["charts"] and found["charts"][0]["boundary_loops"] == 4
    assert "outer_loop" in found["charts"][0]
    near = uvpin.inspect(ASSETS / "face.glb", near=(0.0, 0.0, 1.0))
    assert near["near"]["nearest"]
    with pytest.raises(uvpin.InputError, match="uv_set 3"):
        uvpin.check(ASSETS / "face.glb", uv_set=3)


@pytest.mark.parametrize(
    "change, says",
    [
        (lambda v, f, p: (v[:, :2], f, p), r"vertices must have shape \(n, 3\)"),
        (lambda v, f, p: (np.where(v == 3.0, np.nan, v), f, p), r"vertices\[3\] is not finite"),
        (lambda v, f, p: (v, f[:, :2], p), r"faces must have shape \(m, 3\)"),
        (lambda v, f, p: (v, f + 1000, p), r"faces\[0\]\[0\] = 1000 is out of range"),
        (lambda v, f, p: (v, -f, p), r"faces\[0\]\[1\] = -1 is out of range"),
        (lambda v, f, p: (v, f + 0.5, p), r"faces must be integer vertex ids"),
        (lambda v, f, p: (v, f[:0], p), r"faces is empty"),
        (lambda v, f, p: (v, f, {999: (0.4, 0.5)}), r"pin ids\[0\] = 999 is out of range"),
        (lambda v, f, p: (v, f, {5: (1.5, 0.5)}), r"outside the unit square"),
        (lambda v, f, p: (v, f, {5: (np.nan, 0.5)}), r"pin targets\[0\] is not finite"),
        (lambda v, f, p: (v, f, ([1, 2], [[0.1, 0.1]])), r"2 pin ids for 1 targets"),
        (lambda v, f, p: (v, f, "nope"), r"pins must be a dict"),
        (lambda v, f, p: ("abc", f, p), r"vertices must be numbers"),
    ],
)
def test_bad_input_is_a_clear_input_error(change, says):
    v, f = grid(6)
    v, f, pins = change(v, f, {14: (0.4, 0.5)})
    with pytest.raises(uvpin.InputError, match=says):
        uvpin.solve(v, f, pins)


@pytest.mark.parametrize(
    "kwargs, says",
    [
        ({"boundary": "round"}, "boundary must be one of"),
        ({"region": (0.5, 0.5, 0.2, 0.9)}, "region"),
        ({"region": (0, 0, 1)}, r"region must be \(u0, v0, u1, v1\)"),
        ({"options": {"nope": 1}}, "options: unknown field `nope`"),
        ({"options": {"max_iterations": -1}}, "options: invalid value"),
        ({"options": {"tolerance": 0}}, "options: "),
        ({"uvs": np.zeros((3, 2))}, "uvs has 3 rows for 36 vertices"),
        ({"corners": (0, 1, 2)}, "corners must be 4 vertex ids"),
        ({"corners": (0, 5, 35, 99)}, r"corners\[3\] = 99 is out of range"),
    ],
)
def test_bad_options_are_clear_input_errors(kwargs, says):
    v, f = grid(6)
    with pytest.raises(uvpin.InputError, match=says):
        uvpin.solve(v, f, {14: (0.4, 0.5)}, **kwargs)


def test_a_bad_constraint_file_names_line_and_column_and_writes_nothing(tmp_path):
    ron = tmp_path / "bad.uvpin.ron"
    ron.write_text('(\n    asset: "face.glb",\n    constraints: [(vertex: 12, uv: (0.5, 0.5)),\n    ]\n    oops\n)\n')
    (tmp_path / "face.glb").write_bytes((ASSETS / "face.glb").read_bytes())
    out = tmp_path / "out.glb"
    with pytest.raises(uvpin.InputError, match=r"bad.uvpin.ron:5:5"):
        uvpin.solve_file(ron, out)
    assert not out.exists()
    with pytest.raises(uvpin.InputError, match="cannot read the constraint file: No such file"):
        uvpin.solve_file(tmp_path / "missing.uvpin.ron")


def test_the_gil_is_released_while_a_solve_runs():
    v, f = grid(120)
    done = threading.Event()
    result = {}

    def solve():
        result["r"] = uvpin.solve(v, f, {7260: (0.3, 0.6)})
        done.set()

    thread = threading.Thread(target=solve)
    ticks = 0
    thread.start()
    while not done.is_set():
        ticks += 1
    thread.join()
    assert result["r"].status == "reached"
    # A solve holding the GIL would leave this thread a handful of switches.
    assert ticks > 10_000, ticks


def test_a_closed_mesh_is_cut_open_and_its_uvs_come_per_corner():
    # A closed octahedron-like sphere: latitude rings and two poles.
    n_lat, n_lon = 10, 16
    verts = [[0.0, 0.0, 1.0]]
    for i in range(1, n_lat):
        t = np.pi * i / n_lat
        for j in range(n_lon):
            p = 2 * np.pi * j / n_lon
            verts.append([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)])
    verts.append([0.0, 0.0, -1.0])
    ring = lambda i, j: 1 + (i - 1) * n_lon + j % n_lon  # noqa: E731
    faces = [[0, ring(1, j), ring(1, j + 1)] for j in range(n_lon)]
    faces += [[ring(n_lat - 1, j), len(verts) - 1, ring(n_lat - 1, j + 1)] for j in range(n_lon)]
    for i in range(1, n_lat - 1):
        for j in range(n_lon):
            a, b, c, d = ring(i, j), ring(i, j + 1), ring(i + 1, j + 1), ring(i + 1, j)
            faces += [[a, d, c], [a, c, b]]
    v, f = np.array(verts), np.array(faces)
    front = [i for i in range(len(v)) if v[i, 1] < -0.6][:6]
    pins = {i: (0.5 + 0.3 * v[i, 0], 0.5 - 0.3 * v[i, 2]) for i in front}
    result = uvpin.solve(v, f, pins)
    assert result.status == "reached", result.report.get("message")
    assert result.uv.shape == (len(f), 3, 2), "a seam: UVs per corner"
    assert result.report["seam"]["n_edges"] > 0
    assert result.corner_uv.shape == (len(f), 3, 2)
    for fi, tri in enumerate(f):
        for k, vertex in enumerate(tri):
            if vertex in pins:
                assert tuple(result.corner_uv[fi, k]) == pytest.approx(pins[vertex], abs=1e-6)
    a, b, c = (result.corner_uv[:, k, :] for k in range(3))
    cross = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    assert np.all(cross < 0), "every triangle keeps its orientation (v down)"
