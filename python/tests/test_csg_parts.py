"""CAD parts of every genus as a CSG package makes them: plates and brackets
with N through-holes (trimesh's booleans on manifold3d), written as binary
STL soups, photographed at a slant (12 landmarks on vertices no surface
hides), solved by the command line with the default boundary and free.

Every run ends reached or partial, never refused, never a crash; exit 0 is
confirmed by `uvpin check` against the constraints, and every written set
is fold-free and one-to-one. Today the plates with two bores are reached;
the others end partial (see docs/benchmarks.md)."""

from __future__ import annotations

import json
import subprocess

import numpy as np
import pytest
import trimesh

LANDMARKS = 12


def cylinder(radius: float, height: float, at, axis: str = "z") -> trimesh.Trimesh:
    c = trimesh.creation.cylinder(radius=radius, height=height, sections=24)
    if axis == "x":
        c.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [0, 1, 0]))
    elif axis == "y":
        c.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0]))
    return c.apply_translation(at)


def plate(holes: int) -> trimesh.Trimesh:
    """A 6 × 4 plate, 0.8 thick, with `holes` bores in a row: genus `holes`."""
    body = trimesh.creation.box(extents=[6, 4, 0.8])
    if holes == 0:
        # A blind pocket instead (genus 0, and vertices enough to photograph).
        return trimesh.boolean.difference([body, cylinder(0.8, 0.8, [0, 0, 0.4])], engine="manifold")
    xs = np.linspace(-2, 2, holes) if holes > 1 else [0.0]
    return trimesh.boolean.difference([body] + [cylinder(0.45, 2, [x, 0, 0]) for x in xs], engine="manifold")


def bracket() -> trimesh.Trimesh:
    """An L bracket, a bore through each leg: genus 2."""
    base = trimesh.creation.box(extents=[4, 3, 0.6]).apply_translation([0, 0, 0.3])
    wall = trimesh.creation.box(extents=[0.6, 3, 3]).apply_translation([-1.7, 0, 1.5])
    body = trimesh.boolean.union([base, wall], engine="manifold")
    bores = [cylinder(0.4, 2, [0.8, 0, 0.3]), cylinder(0.4, 2, [-1.7, 0, 1.8], axis="x")]
    return trimesh.boolean.difference([body] + bores, engine="manifold")


def cross_block() -> trimesh.Trimesh:
    """A cube with two crossing bores: genus 3 (a cube with holes)."""
    body = trimesh.creation.box(extents=[3, 3, 3])
    bores = [cylinder(0.6, 4, [0, 0, 0], axis="x"), cylinder(0.6, 4, [0, 0, 0], axis="y")]
    return trimesh.boolean.difference([body] + bores, engine="manifold")


PARTS = {
    "pocket": lambda: plate(0),
    "plate-1": lambda: plate(1),
    "plate-2": lambda: plate(2),
    "plate-4": lambda: plate(4),
    "bracket": bracket,
    "cross-block": cross_block,
}


def unhidden_landmarks(mesh: trimesh.Trimesh, view: np.ndarray, up: np.ndarray):
    """12 vertices a photograph along `view` shows (on a triangle turned
    towards it, behind no triangle), spread over the picture, and their
    targets where it shows them, fitted into 15–85 % of the texture."""
    view = view / np.linalg.norm(view)
    right = np.cross(view, up)
    right /= np.linalg.norm(right)
    up = np.cross(right, view)
    v = np.asarray(mesh.vertices)
    f = np.asarray(mesh.faces)
    x, y, depth = v @ right, v @ up, v @ view
    normals = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    front = normals @ -view > 0
    on_front = np.zeros(len(v), bool)
    on_front[f[front].ravel()] = True
    scale = np.ptp(v, axis=0).max()
    seen = []
    for i in np.flatnonzero(on_front):
        a, b, c = (np.c_[x[f[:, k]], y[f[:, k]]] for k in range(3))
        p = np.array([x[i], y[i]])
        twice = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
        ok = np.abs(twice) > 1e-12
        with np.errstate(divide="ignore", invalid="ignore"):
            wa = ((b[:, 0] - p[0]) * (c[:, 1] - p[1]) - (b[:, 1] - p[1]) * (c[:, 0] - p[0])) / twice
            wb = ((c[:, 0] - p[0]) * (a[:, 1] - p[1]) - (c[:, 1] - p[1]) * (a[:, 0] - p[0])) / twice
        wc = 1 - wa - wb
        inside = ok & (wa >= 0) & (wb >= 0) & (wc >= 0) & ~np.any(f == i, axis=1)
        d = wa * depth[f[:, 0]] + wb * depth[f[:, 1]] + wc * depth[f[:, 2]]
        if not np.any(inside & (d < depth[i] - 0.01 * scale)):
            seen.append(i)
    seen = np.array(seen)
    assert len(seen) >= LANDMARKS, f"{len(seen)} vertices seen"
    screen = np.c_[x[seen], y[seen]]
    chosen = [len(seen) // 2]
    nearest = np.full(len(seen), np.inf)
    while len(chosen) < LANDMARKS:
        nearest = np.minimum(nearest, np.linalg.norm(screen - screen[chosen[-1]], axis=1))
        chosen.append(int(np.argmax(nearest)))
    picked = screen[chosen]
    lo, hi = picked.min(axis=0), picked.max(axis=0)
    s = 0.7 / (hi - lo).max()
    centre = (lo + hi) / 2
    targets = np.c_[0.5 + s * (picked[:, 0] - centre[0]), 0.5 - s * (picked[:, 1] - centre[1])]
    return v[seen[chosen]], targets


def solve(uvpin_cli, tmp_path, name: str, mesh: trimesh.Trimesh, free: bool):
    stl = tmp_path / f"{name}.stl"
    stl.write_bytes(mesh.export(file_type="stl"))
    points, targets = unhidden_landmarks(mesh, np.array([0.45, 0.6, -1.0]), np.array([0.0, 0.0, 1.0]))
    marks = ",\n".join(
        f"(near: ({float(p[0])!r}, {float(p[1])!r}, {float(p[2])!r}), uv: ({t[0]:.6f}, {t[1]:.6f}))"
        for p, t in zip(points, targets)
    )
    mode = "free" if free else "default"
    ron = tmp_path / f"{name}-{mode}.uvpin.ron"
    ron.write_text(f'(asset: "{stl.name}", constraints: [{marks}]{", boundary: Free" if free else ""})')
    out = tmp_path / f"{name}-{mode}.glb"
    ran = subprocess.run(
        [str(uvpin_cli), "solve", str(ron), "-o", str(out), "--report", "-", "--quiet"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    return ran, ron, out


@pytest.mark.parametrize("name", list(PARTS))
def test_a_csg_part_as_an_stl_soup_is_solved_or_left_partial_fold_free(tmp_path, uvpin_cli, name):
    mesh = PARTS[name]()
    assert mesh.is_watertight
    genus = 1 - mesh.euler_number // 2
    outcomes = []
    for free in [False, True]:
        ran, ron, out = solve(uvpin_cli, tmp_path, name, mesh, free)
        assert ran.returncode in (0, 2), f"genus {genus}, free {free}: exit {ran.returncode}\n{ran.stderr}"
        assert "panicked" not in ran.stderr
        report = json.loads(ran.stdout)
        proven = report.get("unreachable_proof") is not None
        outcomes.append("proven unreachable" if proven else report["status"])
        check = [str(uvpin_cli), "check", str(out), "--json"]
        if ran.returncode == 0:
            check += ["--constraints", str(ron)]
        checked = subprocess.run(check, capture_output=True, text=True)
        found = json.loads(checked.stdout)
        # Exit 0: every landmark on target as the file says; either way the
        # written set is fold-free and one-to-one.
        assert ran.returncode != 0 or checked.returncode == 0, checked.stdout + checked.stderr
        assert all(c["flipped"] == 0 and c["zero_area"] == 0 for c in found["charts"]), found["charts"]
        assert found["atlas"]["injective"], found["atlas"]
        print(f"{name} (genus {genus}, {'free' if free else 'default'}): {outcomes[-1]}")
    # A part without a handle (a plate with a pocket) is reached, or the
    # landmarks alone prove it cannot be: a photo's corner landmarks on a
    # long facet turned away (three of them on one triangle, mirrored).
    if genus == 0:
        assert all(o in ("reached", "proven unreachable") for o in outcomes), outcomes
