"""``jackson daemon``, ``jackson monitor`` and ``jackson replay``."""

from __future__ import annotations

import argparse
import datetime as dt
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

from jackson.common.args import (
    MAX_SECONDS,
    float_upto,
    output_folder,
    positive_float,
    positive_int,
)
from jackson.common.errors import JacksonError


class HostCliError(JacksonError):
    """One line for the user, exit status 2."""


def add_parsers(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("daemon", help="run the host daemon against the robot (or the twin)")
    p.add_argument("--config", type=Path, help="host YAML (default: host/config/jackson.yaml)")
    p.add_argument("--port", help="serial port of the MCU (default: serial.port of the config)")
    p.add_argument(
        "--i2c",
        help="I2C bus of the PCA9685, e.g. /dev/i2c-7 or unix:/path (the "
        "twin's socket); default: pca9685.bus of the config",
    )
    p.add_argument(
        "--mission",
        choices=["square", "figure8"],
        help="drive a mission, report and exit (else wait for velocity commands)",
    )
    p.add_argument(
        "--lidar",
        metavar="PORT",
        help="the RPLIDAR's port (/dev/jackson-lidar, or the twin's lidar: pty); with --goal, "
        "navigate (docs/stage3.md)",
    )
    p.add_argument(
        "--lidar-mode",
        metavar="MODE",
        default="densest",
        help="the RPLIDAR's scan mode: densest (the default: Sensitivity on an A1M8), standard, "
        "or a mode's name as the device reports it (Express, Boost, Stability...; docs/lidar.md)",
    )
    p.add_argument(
        "--goal",
        action="append",
        metavar="X,Y[,YAW]",
        help="navigate to this map pose [m, rad]; repeatable, visited in order (needs --lidar)",
    )
    p.add_argument(
        "--map",
        type=Path,
        help="localise on this map (map_server YAML); without it, map as it goes",
    )
    p.add_argument(
        "--start",
        metavar="X,Y[,YAW]",
        default="0,0,0",
        help="the robot's pose in the map frame at the start (default 0,0,0)",
    )
    p.add_argument("--run-dir", type=Path, help="run folder (default: RECORDING/<time>-<mission>)")
    p.add_argument("--no-record", action="store_true", help="do not write a run folder")
    p.add_argument(
        "--max-seconds", type=float_upto(MAX_SECONDS), help="stop after this much wall time"
    )
    p.add_argument(
        "--stall-timeout",
        type=positive_float,
        metavar="S",
        help="on a twin's pty: give up after S s of waiting without a telemetry frame (the twin "
        "stopped in lockstep), brake and exit 1 (default 10; never on a serial port)",
    )
    p.add_argument(
        "--mission-timeout",
        type=float_upto(MAX_SECONDS),
        help="abort the mission after this many seconds of MCU time "
        "(default: square 150, figure8 300)",
    )
    p.add_argument(
        "--ros",
        action="store_true",
        help="also run the ROS 2 node: topics, TF, /cmd_vel (docs/ros2.md)",
    )
    p.add_argument(
        "--ros-args",
        nargs=argparse.REMAINDER,
        default=[],
        help="arguments for rclpy after this flag, e.g. -p cmd_vel_stamped:=true",
    )
    p.set_defaults(func=cmd_daemon)

    p = sub.add_parser("monitor", help="live view of the link: rate, errors, counts, IMU, health")
    p.add_argument("--port", required=True, help="serial port (the robot's or the twin's)")
    p.add_argument("--baudrate", type=positive_int, default=921600)
    p.add_argument("--duration", type=float_upto(MAX_SECONDS), help="stop after this many seconds")
    p.set_defaults(func=cmd_monitor)

    p = sub.add_parser("replay", help="feed a run folder back through the host, offline")
    p.add_argument("run", type=Path, help="run folder written by jackson daemon")
    p.add_argument("--out", type=Path, help="where to write the replayed outputs (default: temp)")
    p.set_defaults(func=cmd_replay)


def _load(path: Path | None) -> object:
    from jackson.host.config import DEFAULT_CONFIG, ConfigError, load_config

    try:
        return load_config(path or DEFAULT_CONFIG)
    except ConfigError as exc:
        raise HostCliError(str(exc)) from exc


def cmd_daemon(args: argparse.Namespace) -> int:
    import dataclasses

    from jackson.host.actuation.i2c import I2cError, I2cSpecError, open_bus
    from jackson.host.actuation.output import McuOutput, MotorOutput, ResilientPca9685Output
    from jackson.host.actuation.pca9685 import Pca9685
    from jackson.host.config import HostConfig
    from jackson.host.control.navigate import MAP_NAME, navigate_meta
    from jackson.host.daemon import Daemon, DaemonError, with_port
    from jackson.host.sdnotify import notifier_from_env
    from jackson.host.transport import LinkError, SerialTransport
    from jackson.protocol import Message, ProtocolError

    cfg = _load(args.config)
    assert isinstance(cfg, HostConfig)
    if args.ros:
        from jackson.host.ros.bridge import ros_available

        problem = ros_available()
        if problem is not None:
            raise HostCliError(problem)
    cfg = with_port(cfg, args.port)
    navigate = _navigate(args, cfg)
    if args.i2c:
        cfg = dataclasses.replace(cfg, pca9685=dataclasses.replace(cfg.pca9685, bus=args.i2c))

    def output_factory(send: Callable[[Message], object]) -> MotorOutput:
        if pca is not None:
            p = cfg.pca9685
            return ResilientPca9685Output(
                lambda: open_bus(p.bus),
                p.address,
                p.frequency_hz,
                p.left,
                p.right,
                p.stby_channel,
                pca=pca,
            )
        return McuOutput(send)

    run_dir = None
    if not args.no_record:
        stamp = dt.datetime.now().strftime("%Y%m%d-%H%M%S")
        run_dir = args.run_dir or Path(cfg.recording_folder) / f"{stamp}-{args.mission or 'drive'}"
        try:
            output_folder(run_dir, "--run-dir" if args.run_dir else "recording folder")
        except ValueError as exc:
            raise HostCliError(str(exc)) from exc
    lidar = None
    if args.lidar:
        from jackson.host.lidar.rplidar import LidarError, RplidarDriver, start_mode

        try:
            lidar = RplidarDriver(args.lidar)
            lidar.start(start_mode(args.lidar_mode))
            print(
                f"daemon: LiDAR on {args.lidar}: {lidar.mode.name if lidar.mode else '?'} scan, "
                f"{lidar.samples_per_revolution_expected or 0:.0f} samples a turn",
                flush=True,
            )
        except LidarError as exc:
            if lidar is not None:
                lidar.close()
            raise HostCliError(str(exc)) from exc
    transport = SerialTransport(cfg.serial.port, cfg.serial.baudrate)
    try:
        # HELLO once the daemon is set up (ROS discovery, the bag): a session that starts
        # earlier streams into a port nobody reads, and a lockstep twin's clock runs off
        transport.open(reader_thread=False, hello=False)
    except LinkError as exc:
        if lidar is not None:
            lidar.close()
        raise HostCliError(str(exc)) from exc
    pca = None
    if cfg.actuator == "pca9685":
        try:
            pca = Pca9685(open_bus(cfg.pca9685.bus), cfg.pca9685.address)
            pca.init(cfg.pca9685.frequency_hz)
        except (I2cError, OSError) as exc:
            transport.close()
            if isinstance(exc, I2cSpecError):
                raise HostCliError(f"--i2c / pca9685.bus: {exc}") from exc
            # hardware that does not answer (yet): exit 1, so systemd starts the daemon again
            print(
                f"jackson daemon: PCA9685 at {cfg.pca9685.address:#04x} on {cfg.pca9685.bus}: "
                f"{exc}",
                file=sys.stderr,
            )
            return 1
    meta = {
        "mission": "navigate" if navigate is not None else args.mission,
        "navigate": navigate_meta(navigate.config) if navigate is not None else None,
        "config": str(args.config or "default"),
        "port": cfg.serial.port,
        "started": dt.datetime.now().isoformat(),
    }
    daemon = Daemon(
        cfg,
        output_factory,
        transport,
        mission_name=args.mission,
        run_folder=run_dir,
        meta=meta,
        ros_args=(["--ros-args", *args.ros_args] if args.ros_args else []) if args.ros else None,
        mission_timeout_s=args.mission_timeout,
        notifier=notifier_from_env(),
        mission=navigate,
        lidar=lidar,
        stall_s=args.stall_timeout,
    )
    if run_dir is not None:
        import yaml

        from jackson.host.config import dump_config

        run_dir.mkdir(parents=True, exist_ok=True)
        (run_dir / "config.yaml").write_text(yaml.safe_dump(dump_config(cfg), sort_keys=False))
        if navigate is not None and navigate.static_map is not None:
            navigate.static_map.save(run_dir / f"{MAP_NAME}.yaml")  # the replay's map
    daemon.install_signals()
    print(
        f"daemon: {cfg.serial.port}, actuator {cfg.actuator}"
        + (f", mission {args.mission}" if args.mission else "")
        + (f", recording to {run_dir}" if run_dir else ""),
        flush=True,
    )
    try:
        transport.send_hello()
        status = daemon.run(args.max_seconds)
    except (ProtocolError, DaemonError) as exc:
        raise HostCliError(str(exc)) from exc
    finally:
        transport.close()
        if lidar is not None:
            lidar.close()
        if navigate is not None and run_dir is not None:
            built = navigate.built_map()
            if built is not None:
                built.save(run_dir / "built_map.yaml")
                print(f"map: {run_dir / 'built_map.yaml'}", flush=True)
    if daemon.cpu.frames > 1:
        print(daemon.cpu.line(), flush=True)
    core = daemon.core
    e = core.ekf
    if core.abort_reason is not None:
        print(
            f"{f'mission {core.mission.name}' if core.mission else 'daemon'} aborted: "
            f"{core.abort_reason}; "
            f"braked at EKF pose x={e.x_m:+.4f} m y={e.y_m:+.4f} m",
            flush=True,
        )
        return status
    if navigate is not None:
        pose = navigate.pose_map()
        goal = navigate.config.goals[-1]
        state = (
            f"failed: {navigate.failure}"
            if navigate.failure
            else ("reached the goal" if navigate.done else "stopped before the goal")
        )
        print(
            f"navigation {state}: {core.frames} frames, {navigate.scans} scans, map pose "
            f"x={pose.x:+.4f} m y={pose.y:+.4f} m yaw={pose.yaw:+.4f} rad, "
            f"{pose.distance(goal) * 100:.1f} cm from the goal, recoveries "
            f"{sum(navigate.recoveries.values())}",
            flush=True,
        )
        return 0 if navigate.done and navigate.failure is None else 1
    if core.mission is not None:
        state = "done" if core.mission.done else "stopped before the end"
        print(
            f"mission {core.mission.name} {state}: {core.frames} frames, EKF pose "
            f"x={e.x_m:+.4f} m y={e.y_m:+.4f} m yaw={e.yaw_rad:+.4f} rad, "
            f"closure {(e.x_m**2 + e.y_m**2) ** 0.5 * 100:.2f} cm",
            flush=True,
        )
    return 0 if core.mission is None or core.mission.done else 1


def _navigate(args: argparse.Namespace, cfg: Any) -> Any:
    """The navigation mission --goal asks for (None without), checked before anything opens."""
    from jackson.host.lidar.rplidar import start_mode

    if start_mode(args.lidar_mode) is not None and not args.lidar:
        raise HostCliError("--lidar-mode needs --lidar PORT (the RPLIDAR's port)")
    if not args.goal:
        for name in ("map", "lidar"):
            if name == "map" and getattr(args, name) is not None:
                raise HostCliError("--map needs --goal (and --lidar)")
        return None
    if args.mission:
        raise HostCliError("--goal navigates: give it or --mission, not both")
    if not args.lidar:
        raise HostCliError("--goal needs --lidar PORT (the RPLIDAR's port)")
    from jackson.host.control.navigate import NavigateConfig, NavigateMission, parse_pose, poses
    from jackson.host.nav.grid import MapFileError, OccupancyGrid

    try:
        start = parse_pose(args.start)
    except ValueError as exc:
        raise HostCliError(f"--start: {exc}") from exc
    try:
        goals = poses(args.goal)
    except ValueError as exc:
        raise HostCliError(f"--goal: {exc}") from exc
    grid = None
    if args.map is not None:
        try:
            grid = OccupancyGrid.load(args.map)
        except MapFileError as exc:
            raise HostCliError(f"--map: {exc}") from exc
    xs = [start.x] + [g.x for g in goals]
    ys = [start.y] + [g.y for g in goals]
    extent = (min(xs) - 3.0, min(ys) - 3.0, max(xs) + 3.0, max(ys) + 3.0)
    if grid is None:  # mapping as it goes, on a blank grid over the route: bound as a map file
        from jackson.host.nav.grid import MAX_CELLS, MAX_SIDE
        from jackson.host.nav.mapping import MappingConfig

        res = MappingConfig().resolution_m
        width_m, height_m = extent[2] - extent[0], extent[3] - extent[1]
        cols, rows = width_m / res, height_m / res
        if max(cols, rows) > MAX_SIDE or cols * rows > MAX_CELLS:
            raise HostCliError(
                f"--start and --goal span {width_m:.0f} m x {height_m:.0f} m with the 3 m margin; "
                f"mapping as it goes covers at most {MAX_SIDE * res:g} m a side and "
                f"{MAX_CELLS:,} cells of {res:g} m: give closer goals, or --map"
            )
    config = NavigateConfig(
        start=start,
        goals=goals,
        localisation="amcl" if grid is not None else "slam",
        extent=extent,
    )
    from jackson.host.control.navigator import RouteError

    try:
        # a daemon runs for hours: its navigation keeps only its recent control ticks
        return NavigateMission(config, cfg.navigation_limits(), grid, keep_samples=False)
    except RouteError as exc:
        raise HostCliError(f"{exc} (--map {args.map})") from exc


def cmd_monitor(args: argparse.Namespace) -> int:
    from jackson.host.monitor import run_monitor
    from jackson.host.transport import LinkError
    from jackson.protocol import FrameVersionError, ProtocolMismatchError

    try:
        run_monitor(args.port, args.baudrate, args.duration)
    except (LinkError, ProtocolMismatchError, FrameVersionError) as exc:
        raise HostCliError(str(exc)) from exc
    return 0


def cmd_replay(args: argparse.Namespace) -> int:
    from jackson.common.args import output_folder
    from jackson.host.config import ConfigError
    from jackson.host.recording import RecordingError
    from jackson.host.replay import replay

    try:
        out = (
            output_folder(args.out)
            if args.out
            else Path(tempfile.mkdtemp(prefix="jackson-replay-"))
        )
        r = replay(args.run, out)
    except (RecordingError, ConfigError, ValueError) as exc:
        raise HostCliError(str(exc)) from exc
    how = r.how()
    print(
        f"replayed {r.frames} telemetry frames and {r.commands} commands of {args.run}, "
        f"{r.span()}; the run was {how}"
    )
    for name, (kept, made) in r.rows.items():
        extra = "" if r.complete or made == kept else f" (the log held {made - kept:+d} more)"
        print(f"  {name}: {kept} rows in the run, {made} replayed{extra}")
    if r.differ:
        print(f"replay differs from the run in {', '.join(r.differ)} (outputs in {out})")
        return 1
    what = "bit for bit" if r.complete else "on every row the run kept"
    print(f"replay reproduces odometry, EKF and commands {what} ({out})")
    return 0
