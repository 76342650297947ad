#!/usr/bin/env python3
"""SLIM (Rabinovich et al. 2017, libigl) for uvpin's benchmarks.

Usage: slim.py CASE.json ITERATIONS > RESULT.json

CASE.json: {"v": [[x, y, z], ...], "f": [[a, b, c], ...],
            "b": [vertex, ...], "bc": [[x, y], ...]}  (targets in layout
coordinates; `v` scaled so the mesh's area is the targets' layout area,
SLIM's isometry at their scale). Starts from Tutte's embedding on a circle
(libigl's tutorial) moved by the similarity that best fits its landmarks to
their targets, minimises symmetric Dirichlet with the landmarks as soft
constraints (libigl's default penalty), and prints {"uv": [[x, y], ...],
"ms": total, "iterations": n}. Holes are fan-filled for the embedding only
(a hole left open there can come out inside out, and SLIM keeps it so).
SLIM's free boundary keeps triangles from flipping but not the boundary
from crossing itself.
"""
import json, sys, time
import numpy as np
import igl

case = json.load(open(sys.argv[1]))
iterations = int(sys.argv[2])
v = np.asarray(case["v"], dtype=np.float64, order="F")
f = np.asarray(case["f"], dtype=np.int32, order="F")
b = np.asarray(case["b"], dtype=np.int32)
bc = np.asarray(case["bc"], dtype=np.float64, order="F")


def boundary_loops(f):
    """Every boundary loop of the faces, as vertex lists in their winding."""
    directed = {(int(a), int(b)) for t in f for a, b in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0]))}
    nxt = {a: b for a, b in directed if (b, a) not in directed}
    loops = []
    while nxt:
        start, _ = next(iter(nxt.items()))
        lp, at = [], start
        while at in nxt:
            lp.append(at)
            at = nxt.pop(at)
        loops.append(lp)
    return loops


def filled(v, f, outer):
    """The mesh with every hole closed by a fan around its centroid."""
    vs, fs = [v], [f]
    n = len(v)
    for lp in boundary_loops(f):
        if set(lp) == set(outer):
            continue
        vs.append(v[lp].mean(axis=0, keepdims=True))
        fs.append(np.array([[lp[(k + 1) % len(lp)], lp[k], n] for k in range(len(lp))], dtype=np.int32))
        n += 1
    return np.asfortranarray(np.vstack(vs)), np.asfortranarray(np.vstack(fs))


t0 = time.perf_counter()
loop = igl.boundary_loop(f)
circle = igl.map_vertices_to_circle(v, loop)
fv, ff = filled(v, f, loop.tolist())
init = igl.harmonic(fv, ff, loop, circle, 1)[: len(v)]
# The circle's winding may mirror the mesh: SLIM keeps the start's orientation.
p, q, r = (init[f[:, k]] for k in range(3))
area = 0.5 * np.sum((q[:, 0] - p[:, 0]) * (r[:, 1] - p[:, 1]) - (r[:, 0] - p[:, 0]) * (q[:, 1] - p[:, 1]))
if area < 0:
    init[:, 0] = -init[:, 0]
# Moved by the similarity that best fits the landmarks to their targets
# (complex least squares), as uvpin fits its own start.
z = init[b, 0] + 1j * init[b, 1]
w = bc[:, 0] + 1j * bc[:, 1]
zc, wc = z - z.mean(), w - w.mean()
s = np.vdot(zc, wc) / np.vdot(zc, zc)
moved = s * ((init[:, 0] + 1j * init[:, 1]) - z.mean()) + w.mean()
init = np.c_[moved.real, moved.imag]
data = igl.slim_precompute(v, f, np.asfortranarray(init), igl.MappingEnergyType.SYMMETRIC_DIRICHLET, b, bc, 1e5)
uv = igl.slim_solve(data, iterations)
ms = (time.perf_counter() - t0) * 1e3
print(json.dumps({"uv": uv[:, :2].tolist(), "ms": ms, "iterations": iterations}))
