"""``jackson calibrate``'s argument parser: the options every procedure shares and one
function per procedure."""

from __future__ import annotations

import argparse
from pathlib import Path

from jackson.calibration.cli.commands import run
from jackson.common.args import (
    float_upto,
    fraction,
    int_in,
    nonneg_float,
    nonzero_float,
    positive_float,
)

Subparsers = argparse._SubParsersAction  # the type of add_subparsers()'s result


def _common(p: argparse.ArgumentParser, *, record: bool = True, truth: str = "") -> None:
    src = p.add_argument_group("where the runs come from")
    if record:
        src.add_argument("--port", help="record on the robot (or twin) at this serial port")
        src.add_argument(
            "--i2c", help="the PCA9685's bus, e.g. /dev/i2c-7 or unix:/path (default: config)"
        )
        src.add_argument(
            "--out", type=Path, help="where to write the recorded runs (default: RECORDING/...)"
        )
    src.add_argument(
        "--runs", nargs="+", type=Path, metavar="DIR", help="use these recorded run folders"
    )
    if truth:
        src.add_argument(
            "--twin-truth",
            type=Path,
            metavar="PATH",
            help=f"on the twin: take {truth} from the ground truth that jackson sim --truth "
            "PATH writes (by each run's MCU time)",
        )
    p.add_argument(
        "--config",
        type=Path,
        help="host YAML the robot runs with (default: the --write file, else the packaged one)",
    )
    p.add_argument(
        "--write", type=Path, metavar="CONFIG", help="write the result into this host YAML"
    )


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add ``calibrate`` and its procedures to the ``jackson`` command's subparsers."""
    p = sub.add_parser(
        "calibrate",
        help="calibrate encoders, track width, IMU, deadband; characterise; fit the twin",
        description="Calibration procedures of the paper's Appendix A and B. Each records its "
        "runs on a robot or twin (--port) or reads recorded run folders (--runs), prints the "
        "result, and with --write updates the host YAML (diff shown, backup kept).",
    )
    procs = p.add_subparsers(dest="procedure", metavar="PROCEDURE", required=True)
    _encoders(procs)
    _track(procs)
    _imu(procs)
    _deadband(procs)
    _characterise(procs)
    _step(procs)
    _twin_fit(procs)
    p.set_defaults(func=run)


# ------------------------------------------------------------------------- helpers


def _encoders(procs: Subparsers[argparse.ArgumentParser]) -> None:
    """``jackson calibrate encoders``."""
    p = procs.add_parser(
        "encoders",
        help="ticks per revolution per wheel from straight runs and a tape measure (Eq. A6)",
        description="Drives straight runs (alternately forward and back) and asks for the "
        "distance measured on the floor after each; C_cal = C_0 d_odom / d_meas per wheel.",
    )
    _common(p, truth="each run's distance (instead of a tape measure)")
    p.add_argument(
        "--count", type=int_in(1, 100), default=3, help="straight runs to record (default 3)"
    )
    p.add_argument(
        "--length", type=float_upto(50.0), default=1.0, help="metres per run (default 1.0)"
    )
    p.add_argument("--speed", type=float_upto(2.0), default=0.15, help="m/s (default 0.15)")
    p.add_argument(
        "--distance",
        type=positive_float,
        nargs="+",
        metavar="M",
        help="measured floor distance [m]: one for all runs or one per run (else "
        "--twin-truth, asked, or read from each run's calibration.json)",
    )


def _track(procs: Subparsers[argparse.ArgumentParser]) -> None:
    """``jackson calibrate track``."""
    p = procs.add_parser(
        "track",
        help="wheel separation from in-place rotations (Eq. A12)",
        description="Turns the robot in place (alternately CCW and CW) by --turns by its gyro "
        "and asks how many turns it really made; B = r (dphi_R - dphi_L) / dtheta.",
    )
    _common(p, truth="each run's true rotation (instead of counting turns)")
    p.add_argument(
        "--count", type=int_in(1, 100), default=2, help="rotations to record (default 2)"
    )
    p.add_argument(
        "--turns", type=float_upto(100.0), default=2.0, help="turns per rotation (default 2)"
    )
    p.add_argument(
        "--rate", type=float_upto(20.0), default=1.0, help="turn rate [rad/s] (default 1.0)"
    )
    p.add_argument(
        "--true-turns",
        type=nonzero_float,
        nargs="+",
        metavar="N",
        help="the true rotation in turns: one for all runs or one per run (else "
        "--twin-truth, asked, or read from each run's calibration.json)",
    )


def _imu(procs: Subparsers[argparse.ArgumentParser]) -> None:
    """``jackson calibrate imu``."""
    p = procs.add_parser(
        "imu",
        help="gyro bias, gravity scale, yaw-sign audit, noise sigmas",
        description="Records the robot standing still, then spinning CCW; writes "
        "imu.calibration (rotation, gyro_bias_rad_s, accel_scale).",
    )
    _common(p)
    p.add_argument(
        "--still", type=float_upto(3600.0), default=10.0, help="seconds standing still (10)"
    )
    p.add_argument("--spin", type=float_upto(600.0), default=4.0, help="seconds spinning CCW (4)")
    p.add_argument(
        "--rotation",
        help="sensor-to-base rotation, 9 numbers row by row, comma separated (default identity)",
    )


def _deadband(procs: Subparsers[argparse.ArgumentParser]) -> None:
    """``jackson calibrate deadband``."""
    p = procs.add_parser(
        "deadband",
        help="breakaway duty per wheel and direction from raw duty staircases",
        description="Raises one wheel's raw duty in steps (coarse, then finer) until its "
        "encoder moves, for each wheel and direction; the host's compensation is bypassed.",
    )
    _common(p)
    p.add_argument("--max-duty", type=fraction, default=0.6, help="give up above this duty (0.6)")
    p.add_argument(
        "--persist", type=int_in(1, 1000), default=3, help="frames a count change must persist (3)"
    )


def _characterise(procs: Subparsers[argparse.ArgumentParser]) -> None:
    """``jackson calibrate characterise``."""
    p = procs.add_parser(
        "characterise",
        help="top speed, time to 90 %% and stopping distance of a duty step",
        description="Both wheels at --duty (raw) for --seconds, then a short brake. Needs about "
        "1.5 m of free floor ahead. --write sets deadband.max_wheel_rad_s (full duty only).",
    )
    _common(p)
    p.add_argument("--duty", type=fraction, default=1.0, help="step duty (default 1.0)")
    p.add_argument(
        "--seconds", type=float_upto(600.0), default=3.0, help="step length [s] (default 3)"
    )
    p.add_argument(
        "--rate", type=int_in(1, 500), default=200, help="telemetry rate [Hz] while recording (200)"
    )


def _step(procs: Subparsers[argparse.ArgumentParser]) -> None:
    """``jackson calibrate step``."""
    p = procs.add_parser(
        "step",
        help="each wheel's motor model per direction from duty steps; per-wheel gains",
        description="Raw duty steps from rest, forward then back, at each --duty (both wheels, "
        "or --single-wheel one at a time), --seconds each; a first-order model is fitted per "
        "wheel and direction. About 0.4 m of free floor ahead. --write sets "
        "deadband.gain.<side>.<direction> and deadband.max_wheel_rad_s.",
    )
    _common(p)
    p.add_argument(
        "--duty", type=fraction, nargs="+", default=[0.35, 0.7], help="step duties (0.35 0.7)"
    )
    p.add_argument("--seconds", type=float_upto(600.0), default=1.5, help="step length [s] (1.5)")
    p.add_argument(
        "--single-wheel", action="store_true", help="one wheel at a time, the other braked"
    )
    p.add_argument(
        "--hold-breakaway",
        action="store_true",
        help="use the config's breakaway duties as d_0 instead of fitting (one --duty suffices)",
    )
    p.add_argument(
        "--rate", type=int_in(1, 500), default=200, help="telemetry rate [Hz] while recording (200)"
    )


def _twin_fit(procs: Subparsers[argparse.ArgumentParser]) -> None:
    """``jackson calibrate twin-fit``."""
    p = procs.add_parser(
        "twin-fit",
        help="effective wheel radius, track width, IMU yaw scale against references",
        description="Least squares of the dead-reckoned trajectory (wheels, gyro x yaw scale) "
        "against reference trajectories (CSV t_s,x_m,y_m,yaw_rad on the MCU clock). With "
        "--port it records an excitation run to fit later.",
    )
    _common(p, truth="the reference trajectories (instead of --reference)")
    p.add_argument("--reference", nargs="+", type=Path, metavar="CSV", help="one reference per run")
    p.add_argument(
        "--heading",
        choices=["wheel", "gyro"],
        default="wheel",
        help="heading the position is integrated with (default wheel)",
    )
    p.add_argument(
        "--yaw-weight",
        type=nonneg_float,
        default=0.5,
        help="metres of position residual per radian of heading residual (0.5)",
    )
    p.add_argument(
        "--fit-radius",
        action="store_true",
        help="also fit and write the wheel radius; by default it is held, so that the distance "
        "per count calibrate encoders measured against a tape stays as it is",
    )
