"""uvpin: constrained, fold-free texture mapping.

Chosen vertices land exactly on chosen texture positions, every triangle
keeps its orientation, and a free boundary keeps the chart one-to-one.

    >>> import numpy as np, uvpin
    >>> result = uvpin.solve(vertices, faces, {210: (0.4, 0.5)})
    >>> result.status, result.uv.shape
    ('reached', (n, 2))

Texture coordinates follow glTF: u to the right, v down, (0, 0) the top-left
corner of the image. Solves release the GIL, so threads run them in parallel.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from typing import Any, Mapping, NamedTuple, Sequence

import numpy as np

from . import _native
from ._native import InputError, Sweep

__all__ = [
    "InputError",
    "Mesh",
    "Result",
    "Sweep",
    "check",
    "inspect",
    "read_mesh",
    "solve",
    "solve_file",
]

_BOUNDARIES = ("auto", "square", "free")


@dataclass(frozen=True)
class Result:
    """A solved mesh.

    ``uv``: (n, 2) float64 texture coordinates, one per vertex of the input,
    or, when the mesh was cut open along seams (a closed mesh, a vertex with
    one UV per side of a seam), (m, 3, 2): one per corner of each face
    (``None`` when the status is ``"error"``: nothing could be laid out).
    ``corner_uv``: (m, 3, 2) per face corner, always (or ``None``).
    ``status``: ``"reached"`` (every pin on its target), ``"partial"``
    (fold-free, some pins short: see ``report["constraints"]``) or ``"error"``.
    ``report``: the JSON report as a dict (as ``uvpin solve --report``).
    ``residuals``: (k,) distance of each pin from its target, in pin order.
    """

    uv: np.ndarray | None
    status: str
    report: dict[str, Any] = field(repr=False)
    residuals: np.ndarray = field(repr=False)
    corner_uv: np.ndarray | None = field(default=None, repr=False)

    @property
    def reached(self) -> bool:
        """Every pin on its target, no triangle folded."""
        return self.status == "reached"


def _float_array(name: str, value: Any, columns: int) -> np.ndarray:
    try:
        a = np.ascontiguousarray(value, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise InputError(f"{name} must be numbers: {e}") from None
    if a.ndim != 2 or a.shape[1] != columns:
        raise InputError(f"{name} must have shape (n, {columns}), not {a.shape}")
    return a


def _int_array(name: str, value: Any, ndim: int) -> np.ndarray:
    a = np.asarray(value)
    if a.size == 0:
        a = a.astype(np.int64)
    if not np.issubdtype(a.dtype, np.integer):
        if np.issubdtype(a.dtype, np.floating) and np.all(np.isfinite(a)) and np.all(a == np.round(a)):
            a = a.astype(np.int64)
        else:
            raise InputError(f"{name} must be integer vertex ids, not {a.dtype}")
    a = np.ascontiguousarray(a, dtype=np.int64)
    if a.ndim != ndim:
        raise InputError(f"{name} must have {ndim} dimension(s), not shape {a.shape}")
    return a


def _pins(pins: Any) -> tuple[np.ndarray, np.ndarray]:
    """A dict {vertex: (u, v)} or a pair (ids (k,), targets (k, 2))."""
    if isinstance(pins, Mapping):
        ids = list(pins.keys())
        targets = [pins[i] for i in ids]
    elif isinstance(pins, (tuple, list)) and len(pins) == 2:
        ids, targets = pins
    else:
        raise InputError("pins must be a dict {vertex: (u, v)} or a pair (ids, targets)")
    ids = _int_array("pin ids", ids, 1)
    if len(ids) == 0 and len(targets) == 0:
        targets = np.zeros((0, 2))
    targets = _float_array("pin targets", targets, 2)
    if len(ids) != len(targets):
        raise InputError(f"{len(ids)} pin ids for {len(targets)} targets")
    return ids, targets


def solve(
    vertices: Any,
    faces: Any,
    pins: Mapping[int, Sequence[float]] | tuple[Any, Any],
    *,
    uvs: Any = None,
    boundary: str = "auto",
    region: Sequence[float] | None = None,
    corners: Sequence[int] | None = None,
    options: Mapping[str, Any] | None = None,
) -> Result:
    """Lays out a mesh so each pinned vertex lands exactly on its target.

    vertices: (n, 3) positions. faces: (m, 3) vertex ids (triangles).
    pins: ``{vertex: (u, v)}`` or ``(ids, targets)`` with targets (k, 2) in
    [0, 1]. uvs: (n, 2) existing texture coordinates (an atlas): vertices
    with the same position and UV are one, only the chart holding the pins is
    laid out again, the others keep theirs. boundary: ``"auto"`` (the
    default rule), ``"square"`` (the outer loop on the unit square) or
    ``"free"`` (free inside ``region``, one-to-one, clear of other charts).
    region: ``(u0, v0, u1, v1)`` for a free boundary. corners: the four
    outer-loop vertices on the square's corners (top_left, bottom_left,
    bottom_right, top_right; default: chosen from the loop). options: solver
    settings, the fields of a constraint file's ``solver`` section
    (e.g. ``{"time_budget_ms": 2000, "guard": "Exact"}``).

    Raises InputError on bad input (the message names the offending index).
    """
    if boundary not in _BOUNDARIES:
        raise InputError(f"boundary must be one of {_BOUNDARIES}, not {boundary!r}")
    v = _float_array("vertices", vertices, 3)
    f = _int_array("faces", faces, 2)
    ids, targets = _pins(pins)
    u = None if uvs is None else _float_array("uvs", uvs, 2)
    if region is not None:
        region = tuple(float(x) for x in region)
        if len(region) != 4:
            raise InputError(f"region must be (u0, v0, u1, v1), not {region}")
    if corners is not None:
        corners = tuple(_int_array("corners", corners, 1).tolist())
        if len(corners) != 4:
            raise InputError(f"corners must be 4 vertex ids, not {len(corners)}")
    opts = None if options is None else json.dumps(dict(options))
    uv, corner_uv, report_json = _native.solve_mesh(v, f, ids, targets, u, boundary, region, corners, opts)
    report = json.loads(report_json)
    if uv is not None and corner_uv is not None and not np.array_equal(uv[f], corner_uv):
        uv = corner_uv
    residuals = np.full(len(ids), np.nan)
    for c in report.get("constraints", []):
        residuals[c["index"]] = c["residual"]
    return Result(uv=uv, status=report["status"], report=report, residuals=residuals, corner_uv=corner_uv)


def solve_file(
    path: str | os.PathLike[str],
    output: str | os.PathLike[str] | None = None,
    *,
    report: str | os.PathLike[str] | None = None,
) -> dict[str, Any]:
    """Solves a constraint file (``*.uvpin.ron``) and writes ``output`` (the
    asset with its new UVs) and ``report`` (JSON) together, all or none.
    Returns the report as a dict; its ``status`` is ``"reached"``,
    ``"partial"`` or ``"error"``. Raises InputError on bad input (with
    line:column in the file)."""
    return json.loads(
        _native.solve_file(
            os.fspath(path),
            None if output is None else os.fspath(output),
            None if report is None else os.fspath(report),
        )
    )


def check(
    asset: Any,
    faces: Any = None,
    uvs: Any = None,
    *,
    uv_set: int = 0,
    mesh: str | int | None = None,
    constraints: str | os.PathLike[str] | None = None,
) -> dict[str, Any]:
    """Checks texture coordinates as stored, from uvpin or any tool: per
    chart, flipped and zero-area triangles and stretch; whether the atlas is
    one-to-one; ``clean`` when all is well.

    ``check("model.glb", uv_set=0, constraints="face.uvpin.ron")`` checks a
    file (glTF's TEXCOORD_n or an OBJ's vt); ``check(vertices, faces, uvs)``
    checks arrays (glTF's convention, v down)."""
    if isinstance(asset, (str, os.PathLike)):
        return json.loads(
            _native.check_file(
                os.fspath(asset),
                uv_set,
                None if mesh is None else str(mesh),
                None if constraints is None else os.fspath(constraints),
            )
        )
    if faces is None or uvs is None:
        raise InputError("check(vertices, faces, uvs): faces and uvs are needed with vertex arrays")
    return json.loads(
        _native.check_mesh(
            _float_array("vertices", asset, 3),
            _int_array("faces", faces, 2),
            _float_array("uvs", uvs, 2),
        )
    )


def inspect(
    path: str | os.PathLike[str],
    *,
    mesh: str | int | None = None,
    uv_set: int = 0,
    near: Sequence[float] | None = None,
    boundary: bool = False,
) -> dict[str, Any]:
    """What ``uvpin inspect`` prints, as a dict: meshes, primitives, charts
    (and their outer loops with ``boundary=True``), bounds, and the vertices
    nearest a 3D point ``near``."""
    point = None if near is None else tuple(float(x) for x in near)
    if point is not None and len(point) != 3:
        raise InputError(f"near must be a 3D point, not {point}")
    return json.loads(
        _native.inspect(os.fspath(path), None if mesh is None else str(mesh), uv_set, point, boundary)
    )


class Mesh(NamedTuple):
    """A mesh as arrays: positions (n, 3), triangles (m, 3), and texture
    coordinates (n, 2) or None."""

    vertices: np.ndarray
    faces: np.ndarray
    uvs: np.ndarray | None


def read_mesh(path: str | os.PathLike[str], *, mesh: str | int | None = None, uv_set: int = 0) -> Mesh:
    """Reads a glTF (.glb, .gltf) or OBJ mesh as arrays, all its primitives
    together; ``uvs`` is UV set ``uv_set`` when every primitive has it."""
    v, f, uv = _native.read_mesh(os.fspath(path), None if mesh is None else str(mesh), uv_set)
    return Mesh(v, f, uv)
