#!/usr/bin/env python3
"""xatlas (PyPI `xatlas`) for uvpin's cut benchmark.

Usage: xatlas_run.py CASE.json > RESULT.json

CASE.json: {"v": [[x, y, z], ...], "f": [[a, b, c], ...]}. Runs
xatlas.parametrize (its own seams, charts and packing, no landmarks) and
prints {"vmapping": [...], "f": [[...]], "uv": [[u, v], ...], "ms": t}:
each new vertex's original vertex, the faces over the new vertices, and
their UVs.
"""
import json, sys, time
import numpy as np
import xatlas

case = json.load(open(sys.argv[1]))
v = np.asarray(case["v"], dtype=np.float32)
f = np.asarray(case["f"], dtype=np.uint32)
t0 = time.perf_counter()
vmapping, indices, uvs = xatlas.parametrize(v, f)
ms = 1000 * (time.perf_counter() - t0)
print(json.dumps({"vmapping": vmapping.tolist(), "f": indices.tolist(), "uv": uvs.tolist(), "ms": ms}))
