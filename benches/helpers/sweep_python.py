#!/usr/bin/env python3
"""The Python side of `cargo bench --bench sweep`; prints one JSON object.

    sweep_python.py ray SWEEP.ron WORKERS
        The sweep as Ray tasks on a local Ray of WORKERS CPUs, started first
        (its start is timed apart): {"start_s", "sweep_s", "runs"}.
    sweep_python.py overhead CONSTRAINTS.ron UVPIN_CLI ROUNDS OUT_DIR
        Per run, interleaved round by round: `uvpin solve` as a process,
        uvpin.solve_file and uvpin.solve on arrays in this process, and the
        library's own time (the report's total_ms): medians in ms.
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import time


def ray_sweep(path: str, workers: int) -> dict:
    import ray
    import uvpin.ray

    t0 = time.perf_counter()
    ray.init(num_cpus=workers, include_dashboard=False, logging_level="ERROR", log_to_driver=False)
    # The workers are up once a task per CPU has run.
    ray.get([ray.remote(lambda: os.getpid()).remote() for _ in range(workers)])
    start = time.perf_counter() - t0
    t0 = time.perf_counter()
    uvpin.ray.sweep(path, force=True, progress=False)
    sweep = time.perf_counter() - t0
    with open(os.path.join(os.path.dirname(path), "out", "runs.csv"), encoding="utf-8") as f:
        runs = sum(1 for _ in f) - 1
    ray.shutdown()
    return {"start_s": start, "sweep_s": sweep, "runs": runs}


def overhead(constraints: str, cli: str, rounds: int, out: str) -> dict:
    import numpy as np
    import uvpin

    report = uvpin.solve_file(constraints, None)
    folder = os.path.dirname(constraints)
    mesh = uvpin.read_mesh(os.path.join(folder, report["asset"]))
    pins = (
        np.array([c["vertex"] for c in report["constraints"]]),
        np.array([c["target"] for c in report["constraints"]]),
    )
    times: dict[str, list[float]] = {"cli": [], "solve_file": [], "solve": [], "library": []}
    for i in range(rounds):
        t0 = time.perf_counter()
        subprocess.run([cli, "solve", constraints, "-o", os.path.join(out, f"cli{i % 2}.glb")],
                       check=True, capture_output=True)
        times["cli"].append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        r = uvpin.solve_file(constraints, os.path.join(out, f"py{i % 2}.glb"))
        times["solve_file"].append(time.perf_counter() - t0)
        times["library"].append(r["total_ms"] / 1000)
        t0 = time.perf_counter()
        solved = uvpin.solve(mesh.vertices, mesh.faces, pins, corners=report["boundary"]["corners"])
        times["solve"].append(time.perf_counter() - t0)
        assert r["status"] == solved.status == "reached"
    return {k: 1000 * statistics.median(v) for k, v in times.items()}


def main() -> None:
    mode = sys.argv[1]
    if mode == "ray":
        result = ray_sweep(os.path.abspath(sys.argv[2]), int(sys.argv[3]))
    elif mode == "overhead":
        result = overhead(os.path.abspath(sys.argv[2]), sys.argv[3], int(sys.argv[4]), sys.argv[5])
    else:
        sys.exit(f"unknown mode {mode}")
    print(json.dumps(result))


main()
