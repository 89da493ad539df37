"""Encoder resolution per wheel from straight runs and a tape measure (Eq. A4, A6)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from jackson.calibration.procedures.base import (
    MIN_TRAVEL_TICKS,
    CalibrationError,
    RunData,
    wheel_travel_m,
)
from jackson.host.estimation.odometry import RobotGeometry


def encoder_resolution(ticks_per_rev_0: float, d_odom_m: float, d_meas_m: float) -> float:
    """The corrected encoder resolution C_cal = C_0 d_odom / d_meas (Eq. A6).

    Since d_odom = 2 pi r N / C_0 (Eq. A4), this is C_cal = 2 pi r N / d_meas: the resolution
    that makes the wheel's counts read the measured floor distance with the wheel radius r.

    Parameters
    ----------
    ticks_per_rev_0 : float
        C_0, the resolution the odometry used [ticks/rev].
    d_odom_m : float
        Distance the odometry reported with C_0 [m].
    d_meas_m : float
        Distance measured on the floor [m].

    Returns
    -------
    float
        C_cal [ticks/rev]. The paper: 652 x 0.9525 = 621 (Eq. A7-A8).

    Raises
    ------
    CalibrationError
        A measured distance that is not > 0, or no odometry distance.
    """
    if not (math.isfinite(d_meas_m) and d_meas_m > 0.0):
        raise CalibrationError(f"the measured distance must be > 0 m, got {d_meas_m:g}")
    if not (math.isfinite(d_odom_m) and d_odom_m > 0.0):
        raise CalibrationError(f"the odometry distance must be > 0 m, got {d_odom_m:g}")
    return ticks_per_rev_0 * d_odom_m / d_meas_m


@dataclass(frozen=True)
class StraightRun:
    """One straight floor run: the count change of each wheel and the tape measurement."""

    name: str
    ticks_left: int
    ticks_right: int
    measured_m: float


@dataclass(frozen=True)
class EncoderCalibration:
    """C_cal per wheel averaged over runs (Eq. A6), with each run's value and ratio.

    Attributes
    ----------
    ticks_per_rev_left : float
        Mean C_cal of the left wheel [ticks/rev].
    ticks_per_rev_right : float
        Mean C_cal of the right wheel.
    per_run : tuple of tuple of float
        (C_left, C_right) of each run.
    ratio_left : float
        Mean d_odom / d_meas of the left wheel with C_0 (the paper: 0.9525).
    ratio_right : float
        The same for the right wheel.
    spread_left : float
        Sample standard deviation of the runs' C_left (0 for one run).
    spread_right : float
        The same for the right wheel.
    """

    ticks_per_rev_left: float
    ticks_per_rev_right: float
    per_run: tuple[tuple[float, float], ...]
    ratio_left: float
    ratio_right: float
    spread_left: float
    spread_right: float


def straight_run(run: RunData, measured_m: float) -> StraightRun:
    """The count change of each wheel over a run (first to last frame) and its measurement.

    Raises
    ------
    CalibrationError
        The run has fewer than two frames.
    """
    return StraightRun(run.name, *_count_change(run), measured_m)


def _count_change(run: RunData) -> tuple[int, int]:
    """Left and right count change from the run's first to its last telemetry frame."""
    if run.frames < 2:
        raise CalibrationError(f"run {run.name}: fewer than two telemetry frames")
    return int(run.enc_left[-1] - run.enc_left[0]), int(run.enc_right[-1] - run.enc_right[0])


def calibrate_encoders(runs: Sequence[StraightRun], geometry: RobotGeometry) -> EncoderCalibration:
    """Encoder resolution per wheel from straight runs (Eq. A4, A6), averaged over the runs.

    Per run and wheel i: d_odom,i = 2 pi r_i |N_i| / C_0,i (Eq. A4) with the configured
    resolution C_0,i and radius r_i, then C_cal,i = C_0,i d_odom,i / d_meas (Eq. A6). Runs may
    go forwards or backwards (the sign of the counts is dropped). On a straight run both wheels
    travel the distance of the axle midpoint, so one tape measurement serves both.

    Parameters
    ----------
    runs : sequence of StraightRun
        The straight runs, each with its measured floor distance d_meas.
    geometry : RobotGeometry
        The configured radii and C_0 per wheel.

    Returns
    -------
    EncoderCalibration
        The mean C_cal per wheel and the details.

    Raises
    ------
    CalibrationError
        No runs, a non-positive measurement, or a wheel that did not move.
    """
    if not runs:
        raise CalibrationError("no straight runs to calibrate the encoders from")
    per_run: list[tuple[float, float]] = []
    ratios: list[tuple[float, float]] = []
    for run in runs:
        if not (math.isfinite(run.measured_m) and run.measured_m > 0.0):
            raise CalibrationError(
                f"run {run.name}: the measured distance must be > 0 m, got {run.measured_m:g}"
            )
        out = []
        for side, ticks, c0, r in (
            ("left", run.ticks_left, geometry.ticks_per_rev_left, geometry.wheel_radius_left_m),
            ("right", run.ticks_right, geometry.ticks_per_rev_right, geometry.wheel_radius_right_m),
        ):
            if abs(ticks) < MIN_TRAVEL_TICKS:
                raise CalibrationError(
                    f"run {run.name}: the {side} wheel moved {abs(ticks)} ticks: the robot did "
                    "not drive (is the motor rail switched on?)"
                )
            d_odom = wheel_travel_m(abs(ticks), c0, r)
            out.append((encoder_resolution(c0, d_odom, run.measured_m), d_odom / run.measured_m))
        per_run.append((out[0][0], out[1][0]))
        ratios.append((out[0][1], out[1][1]))
    left = np.array([c[0] for c in per_run])
    right = np.array([c[1] for c in per_run])
    ddof = 1 if len(per_run) > 1 else 0
    return EncoderCalibration(
        ticks_per_rev_left=float(left.mean()),
        ticks_per_rev_right=float(right.mean()),
        per_run=tuple(per_run),
        ratio_left=float(np.mean([r[0] for r in ratios])),
        ratio_right=float(np.mean([r[1] for r in ratios])),
        spread_left=float(left.std(ddof=ddof)),
        spread_right=float(right.std(ddof=ddof)),
    )
