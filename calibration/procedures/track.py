"""Wheel separation from in-place rotations (Eq. A12)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from jackson.calibration.procedures.base import (
    MIN_TRAVEL_TICKS,
    CalibrationError,
    RunData,
    wheel_angle_rad,
)
from jackson.calibration.procedures.encoders import _count_change
from jackson.host.estimation.odometry import RobotGeometry


def wheel_separation(
    wheel_radius_m: float, dphi_right_rad: float, dphi_left_rad: float, dtheta_rad: float
) -> float:
    """B = r (dphi_R - dphi_L) / dtheta (Eq. A12).

    Parameters
    ----------
    wheel_radius_m : float
        r [m].
    dphi_right_rad : float
        Accumulated right wheel rotation [rad].
    dphi_left_rad : float
        Accumulated left wheel rotation [rad].
    dtheta_rad : float
        True chassis rotation [rad], CCW positive.

    Returns
    -------
    float
        B [m]. The paper: 0.033 x 37.70 / 2 pi = 0.198 (Eq. A15).

    Raises
    ------
    CalibrationError
        A zero rotation.
    """
    if not (math.isfinite(dtheta_rad) and dtheta_rad != 0.0):
        raise CalibrationError(f"the true rotation must be nonzero, got {dtheta_rad:g} rad")
    return wheel_radius_m * (dphi_right_rad - dphi_left_rad) / dtheta_rad


@dataclass(frozen=True)
class RotationRun:
    """One in-place rotation: the count change of each wheel and the true rotation."""

    name: str
    ticks_left: int
    ticks_right: int
    true_rotation_rad: float


@dataclass(frozen=True)
class TrackCalibration:
    """Wheel separation B averaged over rotation runs (Eq. A12).

    Attributes
    ----------
    wheel_separation_m : float
        Mean B [m].
    per_run : tuple of float
        B of each run [m].
    wheel_rotation_difference_rad : tuple of float
        dphi_R - dphi_L of each run (the paper: 37.70 rad).
    spread_m : float
        Sample standard deviation of the runs' B (0 for one run).
    """

    wheel_separation_m: float
    per_run: tuple[float, ...]
    wheel_rotation_difference_rad: tuple[float, ...]
    spread_m: float


def rotation_run(run: RunData, true_rotation_rad: float) -> RotationRun:
    """The count change of each wheel over a run and the true rotation the user confirmed.

    Raises
    ------
    CalibrationError
        The run has fewer than two frames.
    """
    return RotationRun(run.name, *_count_change(run), true_rotation_rad)


def calibrate_track(runs: Sequence[RotationRun], geometry: RobotGeometry) -> TrackCalibration:
    """Wheel separation from in-place rotations (Eq. A12), averaged over the runs.

    dphi_i = 2 pi N_i / C_i with the (already calibrated) resolution of each wheel, and with
    per-wheel radii Eq. A12 reads B = (r_R dphi_R - r_L dphi_L) / dtheta. The true rotation is
    the user's count of full turns (or the twin's ground truth); its sign is taken from the
    wheels, so "2 turns" serves clockwise and counter-clockwise runs alike.

    Parameters
    ----------
    runs : sequence of RotationRun
        The rotation runs with their true rotation |dtheta| (the sign is ignored).
    geometry : RobotGeometry
        Radii and resolutions per wheel.

    Returns
    -------
    TrackCalibration
        The mean B and the details.

    Raises
    ------
    CalibrationError
        No runs, a zero rotation, or wheels that did not turn in place.
    """
    if not runs:
        raise CalibrationError("no rotation runs to calibrate the wheel separation from")
    values: list[float] = []
    diffs: list[float] = []
    for run in runs:
        if not (math.isfinite(run.true_rotation_rad) and run.true_rotation_rad != 0.0):
            raise CalibrationError(
                f"run {run.name}: the true rotation must be nonzero, got {run.true_rotation_rad:g}"
            )
        phi_l = float(wheel_angle_rad(run.ticks_left, geometry.ticks_per_rev_left))
        phi_r = float(wheel_angle_rad(run.ticks_right, geometry.ticks_per_rev_right))
        if min(abs(run.ticks_left), abs(run.ticks_right)) < MIN_TRAVEL_TICKS or phi_l * phi_r > 0:
            raise CalibrationError(
                f"run {run.name}: the wheels did not turn in opposite directions "
                f"({run.ticks_left} and {run.ticks_right} ticks): not an in-place rotation"
            )
        arc = geometry.wheel_radius_right_m * phi_r - geometry.wheel_radius_left_m * phi_l
        values.append(abs(arc) / abs(run.true_rotation_rad))
        diffs.append(phi_r - phi_l)
    arr = np.array(values)
    return TrackCalibration(
        wheel_separation_m=float(arr.mean()),
        per_run=tuple(values),
        wheel_rotation_difference_rad=tuple(diffs),
        spread_m=float(arr.std(ddof=1)) if len(values) > 1 else 0.0,
    )
