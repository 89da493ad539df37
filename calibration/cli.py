"""``jackson calibrate``: the calibration procedures of Appendix A and B on the command line.

Each procedure either records the runs it needs on a connected robot or twin
(``--port P [--i2c BUS]``) or works from run folders recorded before (``--runs DIR...``),
prints its result next to the paper's values, and with ``--write CONFIG`` writes the new values
into the host YAML (showing the diff, keeping ``CONFIG.bak-<time>``, keeping the comments).

    jackson calibrate encoders      straight floor runs and a tape measure: ticks_per_rev
    jackson calibrate track         in-place rotations: wheel_separation_m
    jackson calibrate imu           standing still and a spin: imu.calibration, yaw-sign audit
    jackson calibrate deadband      raw duty staircases: deadband.{left,right}.{forward,reverse}
    jackson calibrate characterise  a full-duty step and a brake: top speed, t90, stopping
    jackson calibrate twin-fit      runs and reference trajectories: effective r, B, yaw scale

On the twin, ``--twin-truth PATH`` (the file ``jackson sim --truth PATH`` writes) answers the
tape measure and the turn count of ``encoders`` and ``track`` and is the reference of
``twin-fit``, read for each run by its MCU time, from another process as well.

Errors a user can cause end as one line and exit status 2; so does a result that is not a
number (it is never printed or written as one).
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime as dt
import math
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from jackson.calibration.yaml_update import Updates, YamlUpdateError, update_config
from jackson.common.args import (
    float_upto,
    fraction,
    int_in,
    nonneg_float,
    nonzero_float,
    positive_float,
)
from jackson.common.errors import JacksonError
from jackson.host.config import DEFAULT_CONFIG, IDENTITY, ConfigError, HostConfig, load_config
from jackson.protocol import ProtocolMismatchError

if TYPE_CHECKING:  # numpy, scipy and the host's daemon load when a procedure runs
    from jackson.calibration import procedures as proc
    from jackson.calibration import runs

TWO_PI = 2.0 * math.pi


class CalibrateCliError(JacksonError):
    """A bad combination of options or answers: one line, exit status 2."""


# ------------------------------------------------------------------------- the parser


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

    e = procs.add_parser(
        "encoders",
        help="ticks per revolution per wheel from straight runs and a tape measure (Eq. A6)",
        description="Drives straight runs (alternately forward and back) and asks for the "
        "distance measured on the floor after each; C_cal = C_0 d_odom / d_meas per wheel.",
    )
    _common(e, truth="each run's distance (instead of a tape measure)")
    e.add_argument(
        "--count", type=int_in(1, 100), default=3, help="straight runs to record (default 3)"
    )
    e.add_argument(
        "--length", type=float_upto(50.0), default=1.0, help="metres per run (default 1.0)"
    )
    e.add_argument("--speed", type=float_upto(2.0), default=0.15, help="m/s (default 0.15)")
    e.add_argument(
        "--distance",
        type=positive_float,
        nargs="+",
        metavar="M",
        help="measured floor distance [m]: one for all runs or one per run (else "
        "--twin-truth, asked, or read from each run's calibration.json)",
    )

    t = procs.add_parser(
        "track",
        help="wheel separation from in-place rotations (Eq. A12)",
        description="Turns the robot in place (alternately CCW and CW) by --turns by its gyro "
        "and asks how many turns it really made; B = r (dphi_R - dphi_L) / dtheta.",
    )
    _common(t, truth="each run's true rotation (instead of counting turns)")
    t.add_argument(
        "--count", type=int_in(1, 100), default=2, help="rotations to record (default 2)"
    )
    t.add_argument(
        "--turns", type=float_upto(100.0), default=2.0, help="turns per rotation (default 2)"
    )
    t.add_argument(
        "--rate", type=float_upto(20.0), default=1.0, help="turn rate [rad/s] (default 1.0)"
    )
    t.add_argument(
        "--true-turns",
        type=nonzero_float,
        nargs="+",
        metavar="N",
        help="the true rotation in turns: one for all runs or one per run (else "
        "--twin-truth, asked, or read from each run's calibration.json)",
    )

    i = procs.add_parser(
        "imu",
        help="gyro bias, gravity scale, yaw-sign audit, noise sigmas",
        description="Records the robot standing still, then spinning CCW; writes "
        "imu.calibration (rotation, gyro_bias_rad_s, accel_scale).",
    )
    _common(i)
    i.add_argument(
        "--still", type=float_upto(3600.0), default=10.0, help="seconds standing still (10)"
    )
    i.add_argument("--spin", type=float_upto(600.0), default=4.0, help="seconds spinning CCW (4)")
    i.add_argument(
        "--rotation",
        help="sensor-to-base rotation, 9 numbers row by row, comma separated (default identity)",
    )

    d = procs.add_parser(
        "deadband",
        help="breakaway duty per wheel and direction from raw duty staircases",
        description="Raises one wheel's raw duty in steps (coarse, then finer) until its "
        "encoder moves, for each wheel and direction; the host's compensation is bypassed.",
    )
    _common(d)
    d.add_argument("--max-duty", type=fraction, default=0.6, help="give up above this duty (0.6)")
    d.add_argument(
        "--persist", type=int_in(1, 1000), default=3, help="frames a count change must persist (3)"
    )

    c = procs.add_parser(
        "characterise",
        help="top speed, time to 90 %% and stopping distance of a duty step",
        description="Both wheels at --duty (raw) for --seconds, then a short brake. Needs about "
        "1.5 m of free floor ahead. --write sets deadband.max_wheel_rad_s (full duty only).",
    )
    _common(c)
    c.add_argument("--duty", type=fraction, default=1.0, help="step duty (default 1.0)")
    c.add_argument(
        "--seconds", type=float_upto(600.0), default=3.0, help="step length [s] (default 3)"
    )
    c.add_argument(
        "--rate", type=int_in(1, 500), default=200, help="telemetry rate [Hz] while recording (200)"
    )

    st = procs.add_parser(
        "step",
        help="each wheel's motor model per direction from duty steps; per-wheel gains",
        description="Raw duty steps from rest, forward then back, at each --duty (both wheels, "
        "or --single-wheel one at a time), --seconds each; a first-order model is fitted per "
        "wheel and direction. About 0.4 m of free floor ahead. --write sets "
        "deadband.gain.<side>.<direction> and deadband.max_wheel_rad_s.",
    )
    _common(st)
    st.add_argument(
        "--duty", type=fraction, nargs="+", default=[0.35, 0.7], help="step duties (0.35 0.7)"
    )
    st.add_argument("--seconds", type=float_upto(600.0), default=1.5, help="step length [s] (1.5)")
    st.add_argument(
        "--single-wheel", action="store_true", help="one wheel at a time, the other braked"
    )
    st.add_argument(
        "--hold-breakaway",
        action="store_true",
        help="use the config's breakaway duties as d_0 instead of fitting (one --duty suffices)",
    )
    st.add_argument(
        "--rate", type=int_in(1, 500), default=200, help="telemetry rate [Hz] while recording (200)"
    )

    f = procs.add_parser(
        "twin-fit",
        help="effective wheel radius, track width, IMU yaw scale against references",
        description="Least squares of the dead-reckoned trajectory (wheels, gyro x yaw scale) "
        "against reference trajectories (CSV t_s,x_m,y_m,yaw_rad on the MCU clock). With "
        "--port it records an excitation run to fit later.",
    )
    _common(f, truth="the reference trajectories (instead of --reference)")
    f.add_argument("--reference", nargs="+", type=Path, metavar="CSV", help="one reference per run")
    f.add_argument(
        "--heading",
        choices=["wheel", "gyro"],
        default="wheel",
        help="heading the position is integrated with (default wheel)",
    )
    f.add_argument(
        "--yaw-weight",
        type=nonneg_float,
        default=0.5,
        help="metres of position residual per radian of heading residual (0.5)",
    )
    f.add_argument(
        "--fit-radius",
        action="store_true",
        help="also fit and write the wheel radius; by default it is held, so that the distance "
        "per count calibrate encoders measured against a tape stays as it is",
    )
    p.set_defaults(func=run)


# ------------------------------------------------------------------------- helpers


TWIN_FIT_RADIUS_WARN = 0.01  # a held radius the trajectories contradict by more: say so


def _config(args: argparse.Namespace) -> HostConfig:
    path = args.config or args.write or DEFAULT_CONFIG
    cfg = load_config(path)
    if getattr(args, "i2c", None):
        cfg = dataclasses.replace(cfg, pca9685=dataclasses.replace(cfg.pca9685, bus=args.i2c))
    return cfg


def _source(args: argparse.Namespace) -> str:
    port = getattr(args, "port", None)
    if port and args.runs:
        raise CalibrateCliError("give either --port (record) or --runs (recorded), not both")
    if not port and not args.runs:
        raise CalibrateCliError("give --port PORT to record, or --runs DIR... to use recordings")
    return "record" if port else "runs"


def _link(args: argparse.Namespace, cfg: HostConfig) -> runs.Link:
    from rich.console import Console

    from jackson.calibration import runs

    return runs.Link(args.port, cfg, Console(stderr=True))


def _out(args: argparse.Namespace, cfg: HostConfig) -> Path:
    if args.out is not None:
        return Path(args.out)
    stamp = dt.datetime.now().strftime("%Y%m%d-%H%M%S")
    return Path(cfg.recording_folder) / f"{stamp}-calibrate-{args.procedure}"


def _ask_float(prompt: str, default: float | None = None) -> float:
    """A number from standard input (Enter takes the default)."""
    while True:
        try:
            text = input(prompt).strip()
        except EOFError as exc:
            raise CalibrateCliError(
                "no answer on standard input: give the value as an option"
            ) from exc
        if not text and default is not None:
            return default
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        if math.isfinite(value):
            return value
        print("  a number, please", file=sys.stderr)


def _per_run(values: Sequence[float] | None, n: int, option: str) -> list[float] | None:
    if values is None:
        return None
    if len(values) == 1:
        return list(values) * n
    if len(values) != n:
        raise CalibrateCliError(
            f"{option}: give one value, or one per run ({n}), not {len(values)}"
        )
    return list(values)


def _measured(
    data: Sequence[proc.RunData], given: list[float] | None, note: str, what: str, option: str
) -> list[float]:
    """Each run's measured value: from the command line, else from the note its recording
    kept (the value the user typed in during the run)."""
    if given is not None:
        return given
    missing = next((r for r in data if note not in r.notes), None)
    if missing is not None:
        raise CalibrateCliError(f"run {missing.name}: no {what}: give {option}")
    return [float(r.notes[note]) for r in data]


def _load(folders: Sequence[Path]) -> list[proc.RunData]:
    from jackson.calibration import procedures as proc
    from jackson.calibration import runs

    data = [runs.load_run(f) for f in folders]
    for run in data:
        proc.check_frames(run)
    return data


def _truth_references(
    folders: Sequence[Path], data: Sequence[proc.RunData], path: Path
) -> list[proc.Reference]:
    """Each run's true poses from the twin's ground-truth file (``jackson sim --truth``)."""
    from jackson.calibration import runs

    truth = runs.load_twin_truth(path)
    return [
        runs.truth_reference(run, truth, runs.run_boot_ids(folder))
        for folder, run in zip(folders, data, strict=True)
    ]


def _exclusive(args: argparse.Namespace, option: str, dest: str) -> None:
    if args.twin_truth is not None and getattr(args, dest) is not None:
        raise CalibrateCliError(f"give either {option} or --twin-truth, not both")


def _finite(updates: Updates) -> None:
    """Refuse a result that is not a number: it is neither printed nor written as one."""
    for key, value in updates.items():
        values = value if isinstance(value, list) else [value]
        if any(isinstance(v, float) and not math.isfinite(v) for v in values):
            raise CalibrateCliError(f"{key}: the result is not a number ({value}); nothing written")


def _write(args: argparse.Namespace, updates: Updates) -> None:
    _finite(updates)
    if args.write is None:
        print("(not written: add --write CONFIG to update the host YAML)")
        return
    result = update_config(args.write, updates)
    if result.backup is None:
        print(f"{result.path} already holds these values: not written")
        return
    print(f"wrote {result.path} (backup {result.backup}):")
    for line in result.changes:
        print(f"  {line}")
    if result.diff:
        print(result.diff, end="" if result.diff.endswith("\n") else "\n")


# ------------------------------------------------------------------------- procedures


def cmd_encoders(args: argparse.Namespace) -> int:
    from jackson.calibration import procedures as proc
    from jackson.calibration import runs

    cfg = _config(args)
    if args.count < 1 or args.length <= 0 or args.speed <= 0:
        raise CalibrateCliError("--count, --length and --speed must be > 0")
    _exclusive(args, "--distance", "distance")
    truth = args.twin_truth
    if _source(args) == "record":
        given = _per_run(args.distance, args.count, "--distance")
        print(
            f"Mark the floor under the axle midpoint. The robot drives {args.count} x "
            f"{args.length:g} m, alternately forward and back; measure each run with a tape."
            if truth is None
            else f"The robot drives {args.count} x {args.length:g} m, alternately forward and "
            f"back; the twin's ground truth {truth} measures each run."
        )

        def measure(folder: Path, index: int) -> float:
            print(f"run {index + 1} recorded in {folder}")
            if given is not None:
                return given[index]
            if truth is not None:
                (ref,) = _truth_references([folder], _load([folder]), truth)
                return runs.truth_distance_m(ref)
            return _ask_float(f"run {index + 1}: distance the axle midpoint moved [m]: ")

        folders = runs.record_straight_runs(
            _link(args, cfg),
            _out(args, cfg),
            measure,
            count=args.count,
            distance_m=args.length,
            speed_m_s=args.speed,
        )
    else:
        folders = list(args.runs)
    data = _load(folders)
    if truth is not None:
        refs = _truth_references(folders, data, truth)
        distances = [runs.truth_distance_m(ref) for ref in refs]
        print(f"measured distances: the twin's ground truth {truth}")
    else:
        given = _per_run(args.distance, len(data), "--distance")
        distances = _measured(data, given, "measured_distance_m", "measured distance", "--distance")
    straight = [proc.straight_run(r, d) for r, d in zip(data, distances, strict=True)]
    g = cfg.robot
    res = proc.calibrate_encoders(straight, g)
    print(f"encoder resolution (Eq. A6, C_0 = {g.ticks_per_rev_left:g}/{g.ticks_per_rev_right:g})")
    for s, (cl, cr) in zip(straight, res.per_run, strict=True):
        print(f"  {s.name}: measured {s.measured_m:.4f} m, C_cal left {cl:.1f} right {cr:.1f}")
    print(
        f"  left  {res.ticks_per_rev_left:.1f} TPR (d_odom/d_meas {res.ratio_left:.4f}, "
        f"spread {res.spread_left:.1f})"
    )
    print(
        f"  right {res.ticks_per_rev_right:.1f} TPR (d_odom/d_meas {res.ratio_right:.4f}, "
        f"spread {res.spread_right:.1f})"
    )
    print("  paper: 652 x 0.9525 = 621 TPR (Eq. A8), history 617 left / 621 right")
    _write(
        args,
        {
            "robot.ticks_per_rev.left": round(res.ticks_per_rev_left, 1),
            "robot.ticks_per_rev.right": round(res.ticks_per_rev_right, 1),
        },
    )
    return 0


def cmd_track(args: argparse.Namespace) -> int:
    from jackson.calibration import procedures as proc
    from jackson.calibration import runs

    cfg = _config(args)
    if args.count < 1 or args.turns <= 0 or args.rate <= 0:
        raise CalibrateCliError("--count, --turns and --rate must be > 0")
    _exclusive(args, "--true-turns", "true_turns")
    truth = args.twin_truth
    if _source(args) == "record":
        given = _per_run(args.true_turns, args.count, "--true-turns")
        print(
            f"Mark the robot's heading on the floor. It turns {args.count} x {args.turns:g} "
            "turns in place, alternately CCW and CW; count the turns it really makes."
            if truth is None
            else f"The robot turns {args.count} x {args.turns:g} turns in place, alternately "
            f"CCW and CW; the twin's ground truth {truth} counts the turns."
        )

        def true_rotation(folder: Path, index: int) -> float:
            print(f"run {index + 1} recorded in {folder}")
            if given is not None:
                return given[index] * TWO_PI
            if truth is not None:
                (ref,) = _truth_references([folder], _load([folder]), truth)
                return runs.truth_rotation_rad(ref)
            turns = _ask_float(
                f"run {index + 1}: turns the robot really made [{args.turns:g}]: ", args.turns
            )
            return turns * TWO_PI

        folders = runs.record_rotation_runs(
            _link(args, cfg),
            _out(args, cfg),
            true_rotation,
            count=args.count,
            turns=args.turns,
            w_rad_s=args.rate,
        )
    else:
        folders = list(args.runs)
    data = _load(folders)
    if truth is not None:
        refs = _truth_references(folders, data, truth)
        true_rad = [runs.truth_rotation_rad(ref) for ref in refs]
        print(f"true rotations: the twin's ground truth {truth}")
    else:
        given = _per_run(args.true_turns, len(data), "--true-turns")
        if given is not None:
            given = [turns * TWO_PI for turns in given]
        true_rad = _measured(data, given, "true_rotation_rad", "true rotation", "--true-turns")
    rotations = [proc.rotation_run(r, rot) for r, rot in zip(data, true_rad, strict=True)]
    g = cfg.robot
    res = proc.calibrate_track(rotations, g)
    print(f"wheel separation (Eq. A12, r = {g.wheel_radius_left_m:g}/{g.wheel_radius_right_m:g} m)")
    for rr, b, dphi in zip(rotations, res.per_run, res.wheel_rotation_difference_rad, strict=True):
        print(
            f"  {rr.name}: true {rr.true_rotation_rad / TWO_PI:+.3f} turns, "
            f"dphi_R - dphi_L {dphi:+.2f} rad, B {b:.5f} m"
        )
    print(f"  B = {res.wheel_separation_m:.5f} m (spread {res.spread_m * 1000:.2f} mm)")
    print("  paper: 0.033 x 37.70 / 2 pi = 0.198 m (Eq. A15); twin V16/V17 effective 0.210481 m")
    _write(args, {"robot.wheel_separation_m": round(res.wheel_separation_m, 5)})
    return 0


def _parse_rotation(text: str | None) -> tuple[float, ...]:
    from jackson.calibration import procedures as proc

    if text is None:
        return IDENTITY
    try:
        values = tuple(float(x) for x in text.replace(",", " ").split())
    except ValueError:
        values = ()
    if len(values) != 9 or not all(math.isfinite(v) for v in values):
        raise CalibrateCliError(f"--rotation: expected 9 finite numbers, got {text!r}")
    try:
        proc.rotation_matrix(values)  # refuses a non-rotation
    except proc.CalibrationError as exc:
        raise CalibrateCliError(f"--rotation: {exc}") from exc
    return values


def cmd_imu(args: argparse.Namespace) -> int:
    import numpy as np

    from jackson.calibration import procedures as proc
    from jackson.calibration import runs

    cfg = _config(args)
    rotation = _parse_rotation(args.rotation)
    if _source(args) == "record":
        if args.still <= 1.0 or args.spin <= 0:
            raise CalibrateCliError("--still must be > 1 s and --spin > 0 s")
        print("Leave the robot alone on a level floor; it then spins in place for a moment.")
        folders = runs.record_imu_runs(
            _link(args, cfg), _out(args, cfg), still_s=args.still, spin_s=args.spin
        )
    else:
        folders = list(args.runs)
    data = _load(folders)
    still = [r for r in data if r.still_frames > 0]
    moving = [r for r in data if r.moved]
    if not still:
        raise CalibrateCliError(
            "no run stands still: the IMU profile needs the robot at rest (a still run, or "
            "the standstill at the start of a run)"
        )
    gyro = np.concatenate([r.gyro_rad_s[: r.still_frames] for r in still])
    accel = np.concatenate([r.accel_m_s2[: r.still_frames] for r in still])
    prof = proc.imu_profile(gyro, accel, rotation)
    noise = proc.datasheet_noise()
    wide = proc.datasheet_noise(proc.DLPF_BANDWIDTH_HZ * proc.FIRST_ORDER_NOISE_FACTOR)
    b = prof.gyro_bias_rad_s
    print(f"IMU at rest ({prof.samples} samples from {', '.join(r.name for r in still)})")
    print(f"  gyro bias (base frame): [{b[0]:+.6f}, {b[1]:+.6f}, {b[2]:+.6f}] rad/s")
    print(
        f"  |g| measured {prof.gravity_measured_m_s2:.4f} m/s^2, accel_scale 9.81/|g| = "
        f"{prof.accel_scale:.4f} (paper: 9.81/9.299 = 1.0549, quoted x1.054)"
    )
    gs, acs = prof.gyro_sigma_rad_s, prof.accel_sigma_m_s2
    print(f"  noise measured: gyro sigma {max(gs):.3e} rad/s, accel sigma {max(acs):.3e} m/s^2")
    print(
        f"  datasheet at {noise.bandwidth_hz:g} Hz: {noise.gyro_sigma_rad_s:.4g} rad/s, "
        f"{noise.accel_sigma_m_s2:.5g} m/s^2 (the paper's 3.999e-4 and 1.7976e-2); "
        f"a one-pole noise bandwidth ({wide.bandwidth_hz:.1f} Hz) would give "
        f"{wide.gyro_sigma_rad_s:.4g} and {wide.accel_sigma_m_s2:.4g}"
    )
    if not prof.gravity_on_z:
        g_b = prof.gravity_base_m_s2
        raise CalibrateCliError(
            f"gravity reads ({g_b[0]:+.2f}, {g_b[1]:+.2f}, {g_b[2]:+.2f}) m/s^2 in the base "
            "frame, not along +z: give the IMU's mounting with --rotation"
        )
    audit: proc.YawAudit | None = None
    if moving:
        gz: list[float] = []
        wz: list[float] = []
        r = proc.rotation_matrix(rotation)
        for run_data in moving:
            gz.extend(((run_data.gyro_rad_s @ r.T)[:, 2] - b[2]).tolist())
            wz.extend(proc.odometry_yaw_rate(run_data, cfg.robot).tolist())
        audit = proc.yaw_sign_audit(np.array(gz), np.array(wz))
        verdict = "OK (CCW positive, REP-103)" if audit.ok else "WRONG SIGN"
        print(
            f"  yaw-sign audit: gyro z vs odometry yaw rate correlation {audit.correlation:+.3f}, "
            f"slope {audit.slope:+.3f}: {verdict}"
        )
    else:
        print("  yaw-sign audit: skipped (no run with the wheels turning)")
    if audit is not None and not audit.ok and args.write is not None:
        raise CalibrateCliError(
            "the gyro's z axis points down in the base frame (yaw sign audit failed): give "
            "--rotation, e.g. 1,0,0,0,-1,0,0,0,-1 for an IMU mounted upside down"
        )
    _write(
        args,
        {
            "imu.calibration.rotation": [float(x) for x in prof.rotation],
            "imu.calibration.gyro_bias_rad_s": [round(x, 6) for x in b],
            "imu.calibration.accel_scale": round(prof.accel_scale, 4),
        },
    )
    return 0


def cmd_deadband(args: argparse.Namespace) -> int:
    from jackson.calibration import procedures as proc
    from jackson.calibration import runs

    cfg = _config(args)
    if args.persist < 1 or not 0.0 < args.max_duty <= 1.0:
        raise CalibrateCliError("--persist must be >= 1 and --max-duty in (0, 1]")
    if _source(args) == "record":
        print("Leave room around the robot: each wheel in turn creeps forward and back.")
        script = runs.DeadbandScript(max_duty=args.max_duty, persist_frames=args.persist)
        folders = [runs.record_deadband_run(_link(args, cfg), _out(args, cfg), script)]
    else:
        folders = list(args.runs)
    res = proc.calibrate_deadband(_load(folders), args.persist)
    print("PWM deadband: breakaway duty (between the last still and the first moving level)")
    for key in ("forward_left", "reverse_left", "forward_right", "reverse_right"):
        br = res.brackets[key]
        direction, side = key.split("_")
        print(f"  {side:5s} {direction:7s} {br.mid:.4f} (in {br.lo:.4f}..{br.hi:.4f})")
    _write(
        args,
        {
            "deadband.left.forward": round(res.forward_left, 4),
            "deadband.left.reverse": round(res.reverse_left, 4),
            "deadband.right.forward": round(res.forward_right, 4),
            "deadband.right.reverse": round(res.reverse_right, 4),
        },
    )
    return 0


def _or_unmeasured(value: float, fmt: str) -> str:
    """``value`` formatted, or "not measured" when it is not finite."""
    return fmt.format(value) if math.isfinite(value) else "not measured"


def cmd_characterise(args: argparse.Namespace) -> int:
    from jackson.calibration import procedures as proc
    from jackson.calibration import runs

    cfg = _config(args)
    if not 0.0 < abs(args.duty) <= 1.0 or args.seconds <= 0.5:
        raise CalibrateCliError("--duty must be in (0, 1] and --seconds > 0.5")
    if _source(args) == "record":
        print("The robot drives straight ahead at the step duty: leave 1.5 m of free floor.")
        script = runs.StepScript(args.duty, args.seconds)
        if not 1 <= args.rate <= 500:
            raise CalibrateCliError("--rate must be 1-500 Hz")
        link = _link(args, cfg)
        folders = [runs.record_step_run(link, _out(args, cfg), script, rate_hz=args.rate)]
    else:
        folders = list(args.runs)
    rotation = cfg.imu.calibration.rotation if cfg.imu.calibration is not None else IDENTITY
    results = [proc.characterise(r, cfg.robot, rotation) for r in _load(folders)]
    for name, c in zip((Path(f).name for f in folders), results, strict=True):
        print(f"{name}: duty step {c.duty:+.2f}")
        print(
            f"  top speed {c.top_speed_m_s:.4f} m/s (wheels {c.top_wheel_speed_left_rad_s:.3f} / "
            f"{c.top_wheel_speed_right_rad_s:.3f} rad/s; 100 RPM no-load = 10.47 rad/s)"
        )
        chassis_t90 = _or_unmeasured(c.time_to_90_s, "{:.3f} s")
        print(
            f"  time to 90 %: chassis {chassis_t90} (accelerometer), "
            f"wheels {c.wheel_time_to_90_s:.3f} s (encoders)"
        )
        chassis_stop = (
            f"{c.stopping_distance_m * 100:.2f} cm in {c.stopping_time_s:.3f} s"
            if math.isfinite(c.stopping_distance_m) and math.isfinite(c.stopping_time_s)
            else "not measured"
        )
        print(
            f"  stopping distance: chassis {chassis_stop} (accelerometer), wheels "
            f"{c.wheel_stopping_distance_m * 100:.2f} cm in {c.wheel_stopping_time_s:.3f} s "
            "(encoders; shorter when they skid)"
        )
        missing = [k for k, v in dataclasses.asdict(c).items() if not math.isfinite(v)]
        if missing:
            # the accelerometer's figures are for information; what --write sets is the
            # encoders' top speed, so the run still counts
            print(
                f"  not measured: {', '.join(missing)}: the accelerometer's samples are "
                "missing, or the chassis speed it integrates never reached 90 % of the wheels' "
                "top speed (tyres that creep) or never came back to zero",
                file=sys.stderr,
            )
    full = [c for c in results if abs(c.duty) == 1.0]
    if args.write is not None and not full:
        raise CalibrateCliError("--write sets deadband.max_wheel_rad_s: it needs a full-duty step")
    if full:
        w = sum(
            abs(c.top_wheel_speed_left_rad_s) + abs(c.top_wheel_speed_right_rad_s) for c in full
        )
        _write(args, {"deadband.max_wheel_rad_s": round(w / (2 * len(full)), 3)})
    return 0


def cmd_step(args: argparse.Namespace) -> int:
    from jackson.calibration import procedures as proc
    from jackson.calibration import runs

    cfg = _config(args)
    if _source(args) == "record":
        print("The robot drives straight ahead and back at each duty: leave 0.4 m of free floor.")
        script = proc.WheelStepScript(
            proc.step_plan(args.duty, args.seconds, single_wheel=args.single_wheel)
        )
        link = _link(args, cfg)
        folders = [runs.record_wheel_step_run(link, _out(args, cfg), script, rate_hz=args.rate)]
    else:
        folders = list(args.runs)
    ident = proc.identify_steps(
        _load(folders),
        cfg.robot,
        breakaway=cfg.deadband if args.hold_breakaway else None,
        expected=cfg.deadband,
    )
    print("Motor model per wheel and direction: omega = K (|d| - d_0) (1 - exp(-(t - t_d) / tau))")
    for m in ident.models:
        print(
            f"  {m.side:5s} {m.direction:7s} K {m.gain_rad_s:.3f} +- {m.gain_sd_rad_s:.3f} "
            f"rad/s, d_0 {m.breakaway_duty:.4f}{'' if m.breakaway_fitted else ' (config)'}, "
            f"tau {m.time_constant_s * 1e3:.1f} ms, t_d {m.dead_time_s * 1e3:.1f} ms, "
            f"rms {m.rms_residual_rad:.4f} rad"
        )
    hg = ident.host_gains(cfg.deadband)
    print(
        f"  host gains: reference {' '.join(hg.reference)}, max_wheel_rad_s "
        f"{hg.max_wheel_rad_s:.3f}; "
        + ", ".join(f"{side} {d} {g:.4f}" for (side, d), g in hg.gains.items())
    )
    _write(args, hg.yaml_updates())
    return 0


def cmd_twin_fit(args: argparse.Namespace) -> int:
    from jackson.calibration import procedures as proc
    from jackson.calibration import runs

    cfg = _config(args)
    _exclusive(args, "--reference", "reference")
    if _source(args) == "record":
        folder = runs.record_excitation_run(_link(args, cfg), _out(args, cfg))
        print(f"recorded {folder}")
        if not args.reference and args.twin_truth is None:
            print(f"fit it with: jackson calibrate twin-fit --runs {folder} --reference REF.csv")
            return 0
        folders = [folder]
    else:
        folders = list(args.runs)
    data = _load(folders)
    if args.twin_truth is not None:
        references = _truth_references(folders, data, args.twin_truth)
        print(f"references: the twin's ground truth {args.twin_truth}")
    elif not args.reference or len(args.reference) != len(folders):
        raise CalibrateCliError(
            f"--reference: give one reference trajectory per run ({len(folders)}), or "
            "--twin-truth on the twin"
        )
    else:
        references = [runs.load_reference(ref) for ref in args.reference]
    g = cfg.robot
    rotation = cfg.imu.calibration.rotation if cfg.imu.calibration is not None else IDENTITY
    segments = [
        proc.fit_segment(run, ref, (g.ticks_per_rev_left, g.ticks_per_rev_right), rotation)
        for run, ref in zip(data, references, strict=True)
    ]
    r0 = 0.5 * (g.wheel_radius_left_m + g.wheel_radius_right_m)

    def fit_with(fit_radius: bool) -> proc.TwinFit:
        return proc.fit_twin(
            segments,
            r0,
            g.wheel_separation_m,
            heading=args.heading,
            yaw_weight_m_per_rad=args.yaw_weight,
            fit_radius=fit_radius,
        )

    free = fit_with(True)  # what the trajectories alone say of r: a check on the encoders
    fit = free if args.fit_radius else fit_with(False)
    print(f"twin fit over {fit.samples} frames (heading from the {fit.heading}s)")
    sd = fit.sigma
    scale = free.wheel_radius_m / r0 - 1.0
    if args.fit_radius:
        print(f"  wheel radius     {fit.wheel_radius_m:.6f} m (+- {sd[0]:.1e}; V16/V17 0.031650)")
        print(
            f"    the distance per count changes by {scale * 100:+.2f} % from the config's "
            "(the one calibrate encoders measured, if it ran)"
        )
    else:
        print(
            f"  wheel radius     {r0:.6f} m held (--fit-radius to fit it); the trajectories alone "
            f"give {free.wheel_radius_m:.6f} m, {scale * 100:+.2f} % in distance per count"
        )
        if abs(scale) > TWIN_FIT_RADIUS_WARN:
            print(
                f"    more than {TWIN_FIT_RADIUS_WARN * 100:g} % apart: check the wheel radius "
                "and run calibrate encoders again"
            )
    print(f"  wheel separation {fit.wheel_separation_m:.6f} m (+- {sd[1]:.1e}; V16/V17 0.210481)")
    print(f"  IMU yaw scale    {fit.yaw_scale:.4f}     (+- {sd[2]:.1e}; V16/V17 0.6953)")
    print(
        f"  RMS position {fit.initial_rms_position_m * 100:.2f} cm -> "
        f"{fit.rms_position_m * 100:.2f} cm; heading wheel "
        f"{math.degrees(fit.rms_yaw_wheel_rad):.2f} deg, gyro "
        f"{math.degrees(fit.rms_yaw_gyro_rad):.2f} deg"
    )
    updates: dict[str, float] = {"robot.wheel_separation_m": round(fit.wheel_separation_m, 6)}
    if args.fit_radius:
        updates["robot.wheel_radius_m"] = round(fit.wheel_radius_m, 6)
        print("  (no IMU yaw scale in the host config: --write sets the radius and the separation)")
    else:
        print("  (no IMU yaw scale in the host config: --write sets the separation)")
    _write(args, updates)
    return 0


COMMANDS: dict[str, Callable[[argparse.Namespace], int]] = {
    "encoders": cmd_encoders,
    "track": cmd_track,
    "imu": cmd_imu,
    "deadband": cmd_deadband,
    "characterise": cmd_characterise,
    "step": cmd_step,
    "twin-fit": cmd_twin_fit,
}


def run(args: argparse.Namespace) -> int:
    """Run the chosen procedure; user errors print one line and return 2."""
    from jackson.calibration import procedures as proc
    from jackson.calibration import runs

    try:
        return COMMANDS[args.procedure](args)
    except (
        CalibrateCliError,
        proc.CalibrationError,
        runs.RunError,
        YamlUpdateError,
        ConfigError,
        ProtocolMismatchError,
    ) as exc:
        print(f"jackson calibrate {args.procedure}: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"jackson calibrate {args.procedure}: interrupted (motors braked)", file=sys.stderr)
        return 130
