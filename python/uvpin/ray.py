"""Sweeps as Ray tasks: one task per run of the grid, retried when its
worker dies, rows streamed into ``runs.jsonl`` as they finish; at the end the
same ``runs.csv``, ``summary.md`` and contact sheet as ``uvpin sweep`` writes
on one machine (every column but ``time_ms`` identical).

The sweep file and the constraint files and assets it names must be readable
at the same path on every node (a shared file system); thumbnails travel back
with the rows, so only the driver writes the output folder.

    import uvpin.ray
    summary = uvpin.ray.sweep("assets/face.sweep.ron", address="auto")
"""

from __future__ import annotations

import json
import os
import sys
import tempfile
from pathlib import Path
from typing import Any, TextIO

import ray

from . import _native

# A worker keeps each sweep it has opened: its constraint files, assets and
# step-1 probes load once per process, not once per task.
_OPENED: dict[tuple[str, float], _native.Sweep] = {}

# Tests set this to a folder: the first task of run 0 then kills its worker
# (once, a marker file records it), so the retry is exercised for real.
_CRASH_ONCE = "UVPIN_TEST_RAY_CRASH_ONCE"


def _opened(path: str) -> _native.Sweep:
    key = (path, os.stat(path).st_mtime)
    if key not in _OPENED:
        _OPENED[key] = _native.Sweep(path)
    return _OPENED[key]


def _crash_once(index: int) -> None:
    folder = os.environ.get(_CRASH_ONCE)
    if not folder or index != 0:
        return
    try:
        fd = os.open(os.path.join(folder, "crashed"), os.O_CREAT | os.O_EXCL | os.O_WRONLY)
    except FileExistsError:
        return
    os.close(fd)
    os._exit(1)


def run_one(path: str, index: int) -> tuple[str, str | None, bytes | None]:
    """Solves run ``index`` of the sweep in ``path`` (absolute): its row as
    JSON, and its thumbnail's file name and PNG bytes (or None)."""
    _crash_once(index)
    sweep = _opened(path)
    with tempfile.TemporaryDirectory(prefix="uvpin-ray-") as tmp:
        row = sweep.run(index, tmp if sweep.thumbnails else None)
        name = json.loads(row).get("thumbnail")
        png = Path(tmp, name).read_bytes() if name else None
    return row, name, png


class _Progress:
    """A line per finished run on stderr (or nothing)."""

    def __init__(self, total: int, out: TextIO | None) -> None:
        self.total, self.done, self.out = total, 0, out

    def row(self, row: dict[str, Any]) -> None:
        self.done += 1
        if self.out is not None:
            print(
                f"[{self.done}/{self.total}] {row['id']}: {row['status']} ({row['time_ms']:.1f} ms)",
                file=self.out,
                flush=True,
            )


def sweep(
    path: str | os.PathLike[str],
    *,
    address: str | None = None,
    force: bool = False,
    max_retries: int = 3,
    progress: bool = True,
    runtime_env: dict[str, Any] | None = None,
) -> str:
    """Runs the sweep in ``path`` as Ray tasks and writes its outputs; returns
    the summary (Markdown). Runs already in ``runs.jsonl`` are skipped unless
    ``force``. ``address``: a Ray cluster (``"auto"``, ``"ray://host:10001"``);
    None starts or joins the local one. A task whose worker dies is retried up
    to ``max_retries`` times; a run that fails is a row with status ``error``.
    """
    sweep_path = os.path.abspath(os.fspath(path))
    plan = _native.Sweep(sweep_path)
    output = Path(plan.output)
    output.mkdir(parents=True, exist_ok=True)
    done = {} if force else {r["id"]: r for r in map(json.loads, plan.done())}
    pending = [index for index, run_id in plan.runs() if run_id not in done]
    if not ray.is_initialized():
        ray.init(address=address, runtime_env=runtime_env, logging_level="WARNING", log_to_driver=False)
    task = ray.remote(num_cpus=1, max_retries=max_retries)(run_one)
    refs = [task.remote(sweep_path, index) for index in pending]
    shown = _Progress(len(pending), sys.stderr if progress else None)
    rows = list(done.values())
    with open(output / "runs.jsonl", "w" if force else "a", encoding="utf-8") as journal:
        while refs:
            ready, refs = ray.wait(refs, num_returns=1)
            row_json, name, png = ray.get(ready[0])
            if name and png is not None:
                (output / "thumbs").mkdir(exist_ok=True)
                (output / "thumbs" / name).write_bytes(png)
            journal.write(row_json + "\n")
            journal.flush()
            row = json.loads(row_json)
            rows.append(row)
            shown.row(row)
    return plan.write([json.dumps(r) for r in rows])
