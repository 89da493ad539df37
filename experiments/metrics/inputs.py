"""What every metric checks of its inputs, and the errors it raises."""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from jackson.common.errors import JacksonError
from jackson.common.geometry import wrap_angles

wrap_angle = wrap_angles  # the metrics' name for the elementwise wrap (common/geometry.py)

FloatArray = npt.NDArray[np.float64]


def stats() -> Any:  # (scipy has no type information)
    """``scipy.stats``, imported on first use: half a second that a single run (``jackson run``
    computes its metrics from this module) never needs."""
    from scipy import stats

    return stats


class MetricInputError(JacksonError, ValueError):
    """An input a metric cannot be computed from (wrong shape, too few samples, ...)."""


class NoMotionError(MetricInputError):
    """No commanded speed exceeds the time-zero threshold: the run never started."""


# ---- input checks ------------------------------------------------------------------------------


def as_points(name: str, value: npt.ArrayLike, min_rows: int = 1) -> FloatArray:
    """value as a float (N, 2) array with N >= min_rows."""
    arr = np.asarray(value, dtype=np.float64)
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise MetricInputError(f"{name} must have shape (N, 2), got {arr.shape}")
    if arr.shape[0] < min_rows:
        raise MetricInputError(f"{name} needs at least {min_rows} points, got {arr.shape[0]}")
    return arr


def as_series(name: str, value: npt.ArrayLike, min_len: int = 1) -> FloatArray:
    """value as a float (N,) array with N >= min_len."""
    arr = np.asarray(value, dtype=np.float64)
    if arr.ndim != 1:
        raise MetricInputError(f"{name} must be one-dimensional, got shape {arr.shape}")
    if arr.shape[0] < min_len:
        raise MetricInputError(f"{name} needs at least {min_len} samples, got {arr.shape[0]}")
    return arr


def check_same_length(name_a: str, a: FloatArray, name_b: str, b: FloatArray) -> None:
    if a.shape[0] != b.shape[0]:
        raise MetricInputError(
            f"{name_a} and {name_b} must be synchronised (same length), "
            f"got {a.shape[0]} and {b.shape[0]}"
        )
