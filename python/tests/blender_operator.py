"""Runs inside Blender's Python (the `bpy` wheel): installs the extension zip
given as argv[1], builds meshes, pins and moves UVs, runs the operator, and
prints what Blender's own UV data says afterwards as one JSON line (the
pytest side asserts on it)."""

from __future__ import annotations

import json
import math
import sys

import bpy  # first: bmesh is importable once bpy is
import bmesh
import numpy as np


def install(zip_path: str) -> str:
    bpy.ops.extensions.package_install_files(filepath=zip_path, repo="user_default", enable_on_install=True)
    import uvpin

    return uvpin.__file__


def fresh_object(name: str, build) -> bpy.types.Object:
    """A new mesh object made by `build(bmesh)`, active and selected."""
    bpy.ops.object.select_all(action="DESELECT")
    mesh = bpy.data.meshes.new(name)
    bm = bmesh.new()
    build(bm)
    bm.to_mesh(mesh)
    bm.free()
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.view_layer.objects.active = obj
    obj.select_set(True)
    return obj


def wavy_grid(bm, n: int = 14) -> None:
    """An n × n grid of quads on a wavy sheet, with a planar-projection UV map."""
    verts = [
        [bm.verts.new((i / (n - 1), j / (n - 1), 0.15 * math.sin(3 * i / (n - 1)) * math.cos(2 * j / (n - 1))))
         for i in range(n)]
        for j in range(n)
    ]
    uv = bm.loops.layers.uv.new("UVMap")
    for j in range(n - 1):
        for i in range(n - 1):
            face = bm.faces.new((verts[j][i], verts[j][i + 1], verts[j + 1][i + 1], verts[j + 1][i]))
            for loop in face.loops:
                x, y, _ = loop.vert.co
                loop[uv].uv = (0.1 + 0.8 * x, 0.1 + 0.8 * y)


def smart_projected_sphere() -> bpy.types.Object:
    """A UV sphere unwrapped by Blender's Smart UV Project: several islands."""
    bpy.ops.object.select_all(action="DESELECT")
    bpy.ops.mesh.primitive_uv_sphere_add(segments=24, ring_count=12)
    obj = bpy.context.active_object
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="SELECT")
    bpy.ops.uv.smart_project(angle_limit=math.radians(66), island_margin=0.02)
    bpy.ops.object.mode_set(mode="OBJECT")
    return obj


def uv_arrays(mesh):
    n = len(mesh.loops)
    uv = np.empty(2 * n, dtype=np.float32)
    mesh.uv_layers.active.uv.foreach_get("vector", uv)
    pin = np.zeros(n, dtype=bool)
    if len(mesh.uv_layers.active.pin) == n:
        mesh.uv_layers.active.pin.foreach_get("value", pin)
    return uv.reshape(-1, 2), pin


def loop_triangles(mesh, uv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Blender's loop triangles: their loops (m, 3) and UVs (m, 3, 2)."""
    mesh.calc_loop_triangles()
    tri = np.empty(3 * len(mesh.loop_triangles), dtype=np.int64)
    mesh.loop_triangles.foreach_get("loops", tri)
    tri = tri.reshape(-1, 3)
    return tri, uv[tri].astype(np.float64)


def signed_areas(mesh, uv: np.ndarray) -> np.ndarray:
    """Twice the signed UV area of each of Blender's loop triangles."""
    _, t = loop_triangles(mesh, uv)
    a, b, c = t[:, 0], t[:, 1], t[:, 2]
    return (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])


def pin_and_move(mesh, targets: dict[int, tuple[float, float]], loops: set[int] | None = None) -> None:
    """Pins the loops of each target vertex (those in `loops`, or all) and
    moves their UVs onto the target, as an artist does in the UV editor
    (through bmesh: Blender makes the pin layer when a pin is first set)."""
    bm = bmesh.new()
    bm.from_mesh(mesh)
    uv = bm.loops.layers.uv.active
    for face in bm.faces:
        for loop in face.loops:
            if loop.vert.index in targets and (loops is None or loop.index in loops):
                loop[uv].pin_uv = True
                loop[uv].uv = targets[loop.vert.index]
    bm.to_mesh(mesh)
    bm.free()
    mesh.update()


def run_operator(obj, **kwargs) -> dict:
    before, _ = uv_arrays(obj.data)
    result = bpy.ops.uv.uvpin_solve_pinned(**kwargs)
    after, pin = uv_arrays(obj.data)
    areas = signed_areas(obj.data, after)
    # The pins as Blender stores them (float32) before and after: exact means
    # the same bits.
    residual = np.hypot(*(after[pin].astype(np.float64) - before[pin].astype(np.float64)).T)
    return {
        "result": sorted(result),
        "before": before,
        "after": after,
        "pin": pin,
        "areas": areas,
        "pins_exact": bool(np.array_equal(after[pin].view(np.int32), before[pin].view(np.int32))),
        "max_residual": float(residual.max()) if residual.size else None,
    }


def grid_case() -> dict:
    obj = fresh_object("grid", wavy_grid)
    mesh = obj.data
    n = 14
    vid = lambda i, j: j * n + i  # noqa: E731
    targets = {
        vid(3, 3): (0.22, 0.30),
        vid(10, 3): (0.80, 0.20),
        vid(10, 10): (0.72, 0.85),
        vid(3, 10): (0.25, 0.70),
        vid(7, 7): (0.58, 0.47),
    }
    pin_and_move(mesh, targets)
    orientation = np.sign(np.median(signed_areas(mesh, uv_arrays(mesh)[0])))
    out = run_operator(obj, boundary="FREE")
    after = out["after"]
    return {
        "result": out["result"],
        "pinned_loops": int(out["pin"].sum()),
        "max_residual": out["max_residual"],
        "pins_exact": out["pins_exact"],
        "min_area": float((orientation * out["areas"]).min()),
        "moved": int(np.any(out["before"] != after, axis=1).sum()),
        "inside": bool(np.all((after >= 0) & (after <= 1))),
    }


def sphere_case() -> dict:
    """Pins on one island of Blender's own sphere unwrap: that island is laid
    out again, the others keep their UVs bit for bit."""
    obj = smart_projected_sphere()
    mesh = obj.data
    uv, _ = uv_arrays(mesh)
    # The island of the sphere's first face: the loops reachable through
    # edges whose two loops share their UVs.
    island = island_loops(mesh, uv, start_face=len(mesh.polygons) // 2)
    vertices = sorted({mesh.loops[i].vertex_index for i in island})
    chosen = [vertices[len(vertices) * k // 4] for k in (1, 2, 3)]
    # Reachable by construction: the island turned by 0.1 rad and shrunk to
    # 90 % about its centre is a fold-free layout inside its old footprint,
    # clear of the other islands, with these pins on their targets.
    loops = np.array(sorted(island))
    centre = uv[loops].astype(np.float64).mean(axis=0)
    c, s_ = math.cos(0.1), math.sin(0.1)
    targets = {}
    for v in chosen:
        loop = next(i for i in island if mesh.loops[i].vertex_index == v)
        d = uv[loop].astype(np.float64) - centre
        targets[v] = tuple(centre + 0.9 * np.array([c * d[0] - s_ * d[1], s_ * d[0] + c * d[1]]))
    pin_and_move(mesh, targets, island)
    orientation = np.sign(np.median(signed_areas(mesh, uv_arrays(mesh)[0])))
    out = run_operator(obj, boundary="FREE")
    after, before = out["after"], out["before"]
    outside = np.setdiff1d(np.arange(len(mesh.loops)), np.array(sorted(island)))
    tri_loops, tri_uv = loop_triangles(mesh, after)
    in_island = np.isin(tri_loops, np.array(sorted(island))).all(axis=1)
    inside, rest = tri_uv[in_island], tri_uv[~in_island]
    return {
        "result": out["result"],
        "max_residual": out["max_residual"],
        "pins_exact": out["pins_exact"],
        "min_area": float((orientation * out["areas"]).min()),
        "island_triangles": int(in_island.sum()),
        "overlaps_with_other_islands": overlapping_pairs(inside, rest),
        "overlaps_within_island": (overlapping_pairs(inside, inside) - len(inside)) // 2,
        "others_identical": bool(np.array_equal(before[outside].view(np.int32), after[outside].view(np.int32))),
        "island_loops": len(island),
        "loops": len(mesh.loops),
    }


def island_loops(mesh, uv: np.ndarray, start_face: int) -> set[int]:
    """The loops of the UV island holding `start_face`."""
    by_edge: dict[int, list[int]] = {}
    for poly in mesh.polygons:
        for li in poly.loop_indices:
            by_edge.setdefault(mesh.loops[li].edge_index, []).append(poly.index)
    corner = {(p.index, mesh.loops[li].vertex_index): li for p in mesh.polygons for li in p.loop_indices}
    seen, todo = {start_face}, [start_face]
    while todo:
        p = mesh.polygons[todo.pop()]
        for li in p.loop_indices:
            edge = mesh.edges[mesh.loops[li].edge_index]
            for q in by_edge[edge.index]:
                if q in seen:
                    continue
                same = all(
                    np.array_equal(uv[corner[(p.index, v)]], uv[corner[(q, v)]]) for v in edge.vertices
                )
                if same:
                    seen.add(q)
                    todo.append(q)
    return {li for f in seen for li in mesh.polygons[f].loop_indices}


def undo_case() -> dict:
    """The solve is one undo step. Blender without a window has no undo
    stack to step back through, so this checks what makes it one: the
    operator registers with UNDO and changes the mesh once, in execute."""
    op = bpy.types.Operator.bl_rna_get_subclass_py("UV_OT_uvpin_solve_pinned")
    return {"undo_flag": "UNDO" in op.bl_options, "register_flag": "REGISTER" in op.bl_options}


def unpinned_case() -> dict:
    """Without pins the operator refuses and changes nothing."""
    obj = fresh_object("unpinned", wavy_grid)
    before, _ = uv_arrays(obj.data)
    try:
        bpy.ops.uv.uvpin_solve_pinned(boundary="FREE")
        refused = False
    except RuntimeError as e:
        refused = "no pinned UVs" in str(e)
    after, _ = uv_arrays(obj.data)
    return {"refused": refused, "unchanged": bool(np.array_equal(before, after))}


def overlapping_pairs(tri: np.ndarray, others: np.ndarray, eps: float = 1e-9) -> int:
    """Pairs of UV triangles (k, 3, 2) × (l, 3, 2) whose interiors overlap
    (by the separating axis test: two convex polygons with disjoint interiors
    are separated along one of their edges' normals)."""
    def axes(t):
        e = np.roll(t, -1, axis=1) - t
        return np.stack([-e[..., 1], e[..., 0]], axis=-1)  # (n, 3, 2)

    a, b = tri[:, None], others[None, :]  # broadcast pairs
    overlap = np.ones((len(tri), len(others)), dtype=bool)
    for normals in (np.broadcast_to(axes(tri)[:, None], (len(tri), len(others), 3, 2)),
                    np.broadcast_to(axes(others)[None, :], (len(tri), len(others), 3, 2))):
        for k in range(3):
            n = normals[:, :, k][:, :, None, :]
            pa = np.sum(np.broadcast_to(a, (len(tri), len(others), 3, 2)) * n, axis=-1)
            pb = np.sum(np.broadcast_to(b, (len(tri), len(others), 3, 2)) * n, axis=-1)
            scale = np.linalg.norm(n[..., 0, :], axis=-1)
            gap = np.minimum(pa.max(-1), pb.max(-1)) - np.maximum(pa.min(-1), pb.min(-1))
            overlap &= gap > eps * np.maximum(scale, 1e-30)
    return int(overlap.sum())


def main() -> None:
    report = {"uvpin_from": install(sys.argv[1]), "blender": bpy.app.version_string}
    report["grid"] = grid_case()
    report["sphere"] = sphere_case()
    report["undo"] = undo_case()
    report["unpinned"] = unpinned_case()
    print("UVPIN-RESULT " + json.dumps(report), flush=True)


main()
