"""One command per calibration procedure: record or load its runs, run the procedure, print
the result beside the paper's values, and write it with ``--write``."""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from jackson.calibration.yaml_update import YamlUpdateError
from jackson.host.config import IDENTITY, ConfigError
from jackson.protocol import ProtocolMismatchError

if TYPE_CHECKING:  # numpy, scipy and the host's daemon load when a procedure runs
    from jackson.calibration import procedures as proc


from jackson.calibration.cli.errors import CalibrateCliError
from jackson.calibration.cli.support import (
    ask_float,
    exclusive,
    host_config,
    load_runs,
    measured,
    open_link,
    out_folder,
    per_run,
    run_source,
    truth_references,
    write_updates,
)

TWO_PI = 2.0 * math.pi
TWIN_FIT_RADIUS_WARN = 0.01  # a held radius the trajectories contradict by more: say so


def cmd_encoders(args: argparse.Namespace) -> int:
    from jackson.calibration import procedures as proc
    from jackson.calibration import runs

    cfg = host_config(args)
    if args.count < 1 or args.length <= 0 or args.speed <= 0:
        raise CalibrateCliError("--count, --length and --speed must be > 0")
    exclusive(args, "--distance", "distance")
    truth = args.twin_truth
    if run_source(args) == "record":
        given = per_run(args.distance, args.count, "--distance")
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
                (ref,) = truth_references([folder], load_runs([folder]), truth)
                return runs.truth_distance_m(ref)
            return ask_float(f"run {index + 1}: distance the axle midpoint moved [m]: ")

        folders = runs.record_straight_runs(
            open_link(args, cfg),
            out_folder(args, cfg),
            measure,
            count=args.count,
            distance_m=args.length,
            speed_m_s=args.speed,
        )
    else:
        folders = list(args.runs)
    data = load_runs(folders)
    if truth is not None:
        refs = truth_references(folders, data, truth)
        distances = [runs.truth_distance_m(ref) for ref in refs]
        print(f"measured distances: the twin's ground truth {truth}")
    else:
        given = per_run(args.distance, len(data), "--distance")
        distances = measured(data, given, "measured_distance_m", "measured distance", "--distance")
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
    write_updates(
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

    cfg = host_config(args)
    if args.count < 1 or args.turns <= 0 or args.rate <= 0:
        raise CalibrateCliError("--count, --turns and --rate must be > 0")
    exclusive(args, "--true-turns", "true_turns")
    truth = args.twin_truth
    if run_source(args) == "record":
        given = per_run(args.true_turns, args.count, "--true-turns")
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
                (ref,) = truth_references([folder], load_runs([folder]), truth)
                return runs.truth_rotation_rad(ref)
            turns = ask_float(
                f"run {index + 1}: turns the robot really made [{args.turns:g}]: ", args.turns
            )
            return turns * TWO_PI

        folders = runs.record_rotation_runs(
            open_link(args, cfg),
            out_folder(args, cfg),
            true_rotation,
            count=args.count,
            turns=args.turns,
            w_rad_s=args.rate,
        )
    else:
        folders = list(args.runs)
    data = load_runs(folders)
    if truth is not None:
        refs = truth_references(folders, data, truth)
        true_rad = [runs.truth_rotation_rad(ref) for ref in refs]
        print(f"true rotations: the twin's ground truth {truth}")
    else:
        given = per_run(args.true_turns, len(data), "--true-turns")
        if given is not None:
            given = [turns * TWO_PI for turns in given]
        true_rad = measured(data, given, "true_rotation_rad", "true rotation", "--true-turns")
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
    write_updates(args, {"robot.wheel_separation_m": round(res.wheel_separation_m, 5)})
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

    cfg = host_config(args)
    rotation = _parse_rotation(args.rotation)
    if run_source(args) == "record":
        if args.still <= 1.0 or args.spin <= 0:
            raise CalibrateCliError("--still must be > 1 s and --spin > 0 s")
        print("Leave the robot alone on a level floor; it then spins in place for a moment.")
        folders = runs.record_imu_runs(
            open_link(args, cfg), out_folder(args, cfg), still_s=args.still, spin_s=args.spin
        )
    else:
        folders = list(args.runs)
    data = load_runs(folders)
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
    write_updates(
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

    cfg = host_config(args)
    if args.persist < 1 or not 0.0 < args.max_duty <= 1.0:
        raise CalibrateCliError("--persist must be >= 1 and --max-duty in (0, 1]")
    if run_source(args) == "record":
        print("Leave room around the robot: each wheel in turn creeps forward and back.")
        script = runs.DeadbandScript(max_duty=args.max_duty, persist_frames=args.persist)
        folders = [runs.record_deadband_run(open_link(args, cfg), out_folder(args, cfg), script)]
    else:
        folders = list(args.runs)
    res = proc.calibrate_deadband(load_runs(folders), args.persist)
    print("PWM deadband: breakaway duty (between the last still and the first moving level)")
    for key in ("forward_left", "reverse_left", "forward_right", "reverse_right"):
        br = res.brackets[key]
        direction, side = key.split("_")
        print(f"  {side:5s} {direction:7s} {br.mid:.4f} (in {br.lo:.4f}..{br.hi:.4f})")
    write_updates(
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

    cfg = host_config(args)
    if not 0.0 < abs(args.duty) <= 1.0 or args.seconds <= 0.5:
        raise CalibrateCliError("--duty must be in (0, 1] and --seconds > 0.5")
    if run_source(args) == "record":
        print("The robot drives straight ahead at the step duty: leave 1.5 m of free floor.")
        script = runs.StepScript(args.duty, args.seconds)
        if not 1 <= args.rate <= 500:
            raise CalibrateCliError("--rate must be 1-500 Hz")
        link = open_link(args, cfg)
        folders = [runs.record_step_run(link, out_folder(args, cfg), script, rate_hz=args.rate)]
    else:
        folders = list(args.runs)
    rotation = cfg.imu.calibration.rotation if cfg.imu.calibration is not None else IDENTITY
    results = [proc.characterise(r, cfg.robot, rotation) for r in load_runs(folders)]
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
        write_updates(args, {"deadband.max_wheel_rad_s": round(w / (2 * len(full)), 3)})
    return 0


def cmd_step(args: argparse.Namespace) -> int:
    from jackson.calibration import procedures as proc
    from jackson.calibration import runs

    cfg = host_config(args)
    if run_source(args) == "record":
        print("The robot drives straight ahead and back at each duty: leave 0.4 m of free floor.")
        script = proc.WheelStepScript(
            proc.step_plan(args.duty, args.seconds, single_wheel=args.single_wheel)
        )
        link = open_link(args, cfg)
        folders = [
            runs.record_wheel_step_run(link, out_folder(args, cfg), script, rate_hz=args.rate)
        ]
    else:
        folders = list(args.runs)
    ident = proc.identify_steps(
        load_runs(folders),
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
    write_updates(args, hg.yaml_updates())
    return 0


def cmd_twin_fit(args: argparse.Namespace) -> int:
    from jackson.calibration import procedures as proc
    from jackson.calibration import runs

    cfg = host_config(args)
    exclusive(args, "--reference", "reference")
    if run_source(args) == "record":
        folder = runs.record_excitation_run(open_link(args, cfg), out_folder(args, cfg))
        print(f"recorded {folder}")
        if not args.reference and args.twin_truth is None:
            print(f"fit it with: jackson calibrate twin-fit --runs {folder} --reference REF.csv")
            return 0
        folders = [folder]
    else:
        folders = list(args.runs)
    data = load_runs(folders)
    if args.twin_truth is not None:
        references = truth_references(folders, data, args.twin_truth)
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
    write_updates(args, updates)
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
