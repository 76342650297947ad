"""Type stubs of the extension module (see uvpin/__init__.py for the API)."""

from os import PathLike
from typing import Sequence

import numpy as np
import numpy.typing as npt

class InputError(ValueError):
    """Bad input: a mesh, pins, options or file uvpin cannot use."""

def solve_mesh(
    vertices: npt.NDArray[np.float64],
    faces: npt.NDArray[np.int64],
    pin_ids: npt.NDArray[np.int64],
    pin_targets: npt.NDArray[np.float64],
    uvs: npt.NDArray[np.float64] | None = None,
    boundary: str = "auto",
    region: Sequence[float] | None = None,
    corners: Sequence[int] | None = None,
    options: str | None = None,
) -> tuple[npt.NDArray[np.float64] | None, npt.NDArray[np.float64] | None, str]: ...
def solve_file(path: str | PathLike[str], output: str | None = None, report: str | None = None) -> str: ...
def check_file(
    path: str | PathLike[str], uv_set: int = 0, mesh: str | None = None, constraints: str | None = None
) -> str: ...
def check_mesh(
    vertices: npt.NDArray[np.float64], faces: npt.NDArray[np.int64], uvs: npt.NDArray[np.float64]
) -> str: ...
def inspect(
    path: str | PathLike[str],
    mesh: str | None = None,
    uv_set: int = 0,
    near: Sequence[float] | None = None,
    boundary: bool = False,
) -> str: ...

def read_mesh(
    path: str | PathLike[str], mesh: str | None = None, uv_set: int = 0
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int64], npt.NDArray[np.float64] | None]: ...

def read_constraints(path: str | PathLike[str]) -> str: ...
def render_view(
    vertices: npt.NDArray[np.float64],
    faces: npt.NDArray[np.int64],
    view: Sequence[float],
    up: Sequence[float],
    size: int = 512,
    uvs: npt.NDArray[np.float64] | None = None,
    texture: npt.NDArray[np.uint8] | None = None,
) -> tuple[npt.NDArray[np.uint8], npt.NDArray[np.int64], npt.NDArray[np.float64]]: ...

class Sweep:
    """A sweep file's grid; its inputs load once per process, on first use."""

    def __init__(self, path: str | PathLike[str]) -> None: ...
    @property
    def output(self) -> str: ...
    @property
    def thumbnails(self) -> bool: ...
    def runs(self) -> list[tuple[int, str]]:
        """Every run of the grid: (index, id), in row order."""
    def run(self, index: int, thumbs: str | PathLike[str] | None = None) -> str:
        """Solves run `index`; returns its row as JSON."""
    def done(self) -> list[str]:
        """Rows already in the output's runs.jsonl (JSON)."""
    def write(self, rows: list[str]) -> str:
        """Writes the rows in grid order (runs.jsonl, runs.csv, summary.md, contact sheet); returns the summary."""
