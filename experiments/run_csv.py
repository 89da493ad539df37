"""A run folder's CSVs of numbers: read (:func:`read_csv`) and the twin's truth written
(:func:`write_ground_truth`).

A module of its own, with nothing but numpy behind it, so that a process that only draws a
run's figure (:mod:`jackson.common.figure_worker`) reads the CSVs without importing the host.
"""

from __future__ import annotations

import csv
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray


def read_csv(path: Path) -> dict[str, NDArray[np.float64]]:
    """A run's numeric CSV (a header line, then numbers): column name -> values.

    numpy's own parser, about twice as fast as ``csv`` and ``float`` over a run's 10 000 rows
    of ground truth, and the same numbers (both round each text to the nearest double).
    """
    with path.open() as f:
        cols = next(csv.reader([f.readline()]))
        rest = f.read()
    data: NDArray[np.float64]
    if not rest.strip():
        data = np.empty((0, len(cols)))
    else:
        data = np.loadtxt(rest.splitlines(), delimiter=",", dtype=np.float64, ndmin=2)
    return {c: data[:, i] for i, c in enumerate(cols)}


def write_ground_truth(path: Path, truth: Sequence[Any]) -> None:
    """``ground_truth.csv``: the twin's 200 Hz truth, each number as ``repr`` writes it (read
    back, the same double), lines ended as the ``csv`` module ends them."""
    lines = ["t_s,x_m,y_m,yaw_rad,vx_m_s,vy_m_s,wz_rad_s"]
    lines += [f"{s.t_s!r},{s.x!r},{s.y!r},{s.yaw!r},{s.vx!r},{s.vy!r},{s.wz!r}" for s in truth]
    with path.open("w", newline="") as f:
        f.write("\r\n".join(lines) + "\r\n")
