"""``jackson daemon``: its options, the checks of what they ask for (before anything opens),
the devices opened (RPLIDAR, serial port, PCA9685), the :class:`~jackson.host.daemon.Daemon`
run, and the run's one-paragraph summary.

A wrong argument, a missing port or map is one line and exit status 2; a PCA9685 that does not
answer (yet) exits 1, so that systemd starts the daemon again.
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime as dt
import sys
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from jackson.common.args import (
    MAX_SECONDS,
    float_upto,
    host_port,
    int_in,
    output_folder,
    pose_text,
    positive_float,
)
from jackson.common.errors import JacksonError
from jackson.host.brake import bus_spec
from jackson.host.daemon_realtime import PRIORITY as REALTIME_PRIORITY
from jackson.host.daemon_realtime import make_realtime

if TYPE_CHECKING:  # the daemon, its devices and the navigation load when the command runs
    from jackson.host.actuation.output import MotorOutput
    from jackson.host.actuation.pca9685 import Pca9685
    from jackson.host.config import HostConfig
    from jackson.host.control.navigate import NavigateConfig, NavigateMission
    from jackson.host.daemon import Daemon
    from jackson.host.lidar.rplidar import RplidarDriver
    from jackson.host.nav.planner_server import Planner
    from jackson.host.service.navigation import NavigationService
    from jackson.host.service.settings import LiveViewSettings
    from jackson.host.transport import SerialTransport
    from jackson.protocol import Message

    Navigation = NavigateMission | NavigationService


class DaemonCliError(JacksonError):
    """What ``jackson daemon`` cannot do as asked: one line for the user, exit status 2."""


class _NoAnswerError(JacksonError):
    """Hardware that does not answer (yet): one line, exit status 1 so that systemd starts
    the daemon again (caught in :func:`cmd_daemon`)."""


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Register ``jackson daemon`` on the subcommand parsers ``sub``."""
    p = sub.add_parser("daemon", help="run the host daemon against the robot (or the twin)")
    p.add_argument("--config", type=Path, help="host YAML (default: host/config/jackson.yaml)")
    p.add_argument("--port", help="serial port of the MCU (default: serial.port of the config)")
    p.add_argument(
        "--i2c",
        type=bus_spec,
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
        type=pose_text,
        metavar="X,Y[,YAW]",
        help="navigate to this map pose [m, rad]; repeatable, visited in order (needs --lidar)",
    )
    p.add_argument(
        "--map",
        type=Path,
        help="localise on this map (map_server YAML); with --lidar and no --goal, serve goal "
        "after goal (the navigation service, docs/host.md); with --goal and without --map, map "
        "as it goes",
    )
    p.add_argument(
        "--start",
        type=pose_text,
        metavar="X,Y[,YAW]",
        help="the robot's pose in the map frame at the start (default: service.start of the "
        "config, 0,0,0)",
    )
    p.add_argument(
        "--socket",
        type=Path,
        help="the navigation service's control socket (default: service.socket of the config; "
        "auto: /run/jackson/daemon.sock as root or under systemd, else $XDG_RUNTIME_DIR/jackson/)",
    )
    p.add_argument("--run-dir", type=Path, help="run folder (default: RECORDING/<time>-<mission>)")
    p.add_argument("--no-record", action="store_true", help="do not write a run folder")
    p.add_argument(
        "--max-seconds", type=float_upto(MAX_SECONDS), help="stop after this much wall time"
    )
    p.add_argument(
        "--realtime",
        nargs="?",
        const=REALTIME_PRIORITY,
        type=int_in(1, 99),
        metavar="PRIORITY",
        help="read the port and write the motors on a SCHED_FIFO thread at PRIORITY (default "
        "40; needs root or CAP_SYS_NICE, else one line and normal priority; docs/jetson.md)",
    )
    p.add_argument(
        "--stall-timeout",
        type=positive_float,
        metavar="S",
        help="on a twin's pty: after S s of waiting without a telemetry frame, look at the twin; "
        "one gone, stopped or doing no work is a lockstep stall: brake and exit 75 (default 10; "
        "never on a serial port)",
    )
    p.add_argument(
        "--mission-timeout",
        type=float_upto(MAX_SECONDS),
        help="abort the mission after this many seconds of MCU time "
        "(default: square 150, figure8 300)",
    )
    p.add_argument(
        "--live-view",
        type=host_port,
        metavar="[HOST:]PORT",
        help="serve the navigation service live over the Foxglove WebSocket protocol (map, "
        "scan, pose, plans, goal, health; docs/host.md, The live view) on this port, bound "
        "to 127.0.0.1 unless HOST is given (default: service.live_view of the config)",
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


def cmd_daemon(args: argparse.Namespace) -> int:
    """Check the arguments, open the devices, run the daemon, print its summary; the exit
    status (0 done or stopped as asked, 1 aborted or hardware not answering)."""
    cfg, navigate, live_view = _checked(args)
    run_dir = _run_dir(args, cfg, navigate)
    lidar = _start_lidar(args)
    transport = _open_link(cfg, lidar)
    try:
        pca = _open_pca(cfg, transport)
    except _NoAnswerError as exc:
        print(f"jackson daemon: {exc}", file=sys.stderr)
        return 1
    daemon = _daemon(args, cfg, navigate, live_view, transport, lidar, _outputs(cfg, pca), run_dir)
    nav_mission = _nav_mission(navigate)
    if run_dir is not None:
        _write_run_files(run_dir, cfg, nav_mission)
    daemon.install_signals()
    print(
        f"daemon: {cfg.serial.port}, actuator {cfg.actuator}"
        + (f", mission {args.mission}" if args.mission else "")
        + (f", recording to {run_dir}" if run_dir else ""),
        flush=True,
    )
    from jackson.host.daemon import DaemonError
    from jackson.protocol import ProtocolError

    try:
        transport.send_hello()
        if args.realtime is not None:  # the frame loop's thread; the threads it starts stay normal
            print(f"daemon: {make_realtime(args.realtime)}", flush=True)
        status = daemon.run(args.max_seconds)
    except (ProtocolError, DaemonError) as exc:
        raise DaemonCliError(str(exc)) from exc
    finally:
        _close(transport, lidar)
        if nav_mission is not None and run_dir is not None:
            last = daemon.run_folder or run_dir  # the last folder of a split run
            if nav_mission.finish_map(last / "built_map.yaml") is not None:
                print(f"map: {last / 'built_map.yaml'} (+ .pgm, pose graph .graph.npz)", flush=True)
    return _summary(daemon, args, navigate, status)


# ---------------------------------------------------------------------- before anything opens


def _checked(args: argparse.Namespace) -> tuple[HostConfig, Navigation | None, LiveViewSettings]:
    """The config with ``--port`` and ``--i2c``, the navigation asked for and the live view's
    settings, all checked before anything opens."""
    from jackson.host.daemon import with_port

    cfg = _config(args.config)
    if args.ros:
        from jackson.host.ros.bridge import ros_available

        problem = ros_available()
        if problem is not None:
            raise DaemonCliError(problem)
    cfg = with_port(cfg, args.port)
    navigate = _navigate(args, cfg)
    live_view = _live_view(args, cfg, navigate)
    if args.i2c:
        cfg = dataclasses.replace(cfg, pca9685=dataclasses.replace(cfg.pca9685, bus=args.i2c))
    return cfg, navigate, live_view


def _config(path: Path | None) -> HostConfig:
    from jackson.host.config import DEFAULT_CONFIG, ConfigError, load_config

    try:
        return load_config(path or DEFAULT_CONFIG)
    except ConfigError as exc:
        raise DaemonCliError(str(exc)) from exc


def _navigate(args: argparse.Namespace, cfg: HostConfig) -> Navigation | None:
    """The navigation mission --goal asks for (None without), checked before anything opens."""
    from jackson.host.lidar.rplidar import start_mode

    if start_mode(args.lidar_mode) is not None and not args.lidar:
        raise DaemonCliError("--lidar-mode needs --lidar PORT (the RPLIDAR's port)")
    if not args.goal:
        if args.mission and (args.lidar or args.map):
            raise DaemonCliError(f"--mission {args.mission} drives without the LiDAR and map")
        if args.mission is None and _serves(args, cfg):
            return _service(args, cfg)
        if args.map is not None:
            raise DaemonCliError(
                "--map needs --lidar PORT (or service.lidar in the config) to serve goals"
            )
        if args.start is not None:
            raise DaemonCliError("--start needs --lidar and --map (or --goal)")
        return None
    if args.mission:
        raise DaemonCliError("--goal navigates: give it or --mission, not both")
    if not args.lidar:
        raise DaemonCliError("--goal needs --lidar PORT (the RPLIDAR's port)")
    from jackson.host.control.navigate import NavigateConfig, NavigateMission, parse_pose, poses
    from jackson.host.control.navigator_config import PLAN_DELAY_TICKS, NavigatorConfig
    from jackson.host.nav.grid import MapFileError, OccupancyGrid

    try:
        start = parse_pose(args.start or "0,0,0")
    except ValueError as exc:
        raise DaemonCliError(f"--start: {exc}") from exc
    try:
        goals = poses(args.goal)
    except ValueError as exc:
        raise DaemonCliError(f"--goal: {exc}") from exc
    grid = None
    if args.map is not None:
        try:
            grid = OccupancyGrid.load(args.map)
        except MapFileError as exc:
            raise DaemonCliError(f"--map: {exc}") from exc
    xs = [start.x] + [g.x for g in goals]
    ys = [start.y] + [g.y for g in goals]
    extent = (min(xs) - 3.0, min(ys) - 3.0, max(xs) + 3.0, max(ys) + 3.0)
    if grid is None:  # mapping as it goes, on a blank grid over the route: bound as a map file
        _check_mapped_extent(extent)
    config = NavigateConfig(
        start=start,
        goals=goals,
        localisation="amcl" if grid is not None else "slam",
        extent=extent,
        navigator=NavigatorConfig(plan_delay_ticks=PLAN_DELAY_TICKS),
    )
    from jackson.host.control.navigator import RouteError

    try:
        # a daemon runs for hours: its navigation keeps only its recent control ticks
        return NavigateMission(
            config,
            cfg.navigation_limits(),
            grid,
            keep_samples=False,
            planner=_planner(config, cfg),
        )
    except RouteError as exc:
        raise DaemonCliError(f"{exc} (--map {args.map})") from exc


def _planner(config: NavigateConfig, cfg: HostConfig) -> Planner:
    """The daemon's global planner: a worker process (:mod:`jackson.host.nav.planner_server`),
    so that no control tick runs a search. Its answers have the plan's delay in control
    periods of wall time before one not in counts against the worker."""
    from jackson.host.nav.planner_server import WorkerPlanner

    budget_s = config.navigator.plan_delay_ticks / cfg.serial.telemetry_rate_hz
    return WorkerPlanner(say=lambda line: print(f"daemon: {line}", flush=True), budget_s=budget_s)


def _check_mapped_extent(extent: tuple[float, float, float, float]) -> None:
    """A route mapped as it goes fits the largest grid a map file may hold."""
    from jackson.host.nav.grid import MAX_CELLS, MAX_SIDE
    from jackson.host.nav.slam.mapper import MappingConfig

    res = MappingConfig().resolution_m
    width_m, height_m = extent[2] - extent[0], extent[3] - extent[1]
    cols, rows = width_m / res, height_m / res
    if max(cols, rows) > MAX_SIDE or cols * rows > MAX_CELLS:
        raise DaemonCliError(
            f"--start and --goal span {width_m:.0f} m x {height_m:.0f} m with the 3 m margin; "
            f"mapping as it goes covers at most {MAX_SIDE * res:g} m a side and "
            f"{MAX_CELLS:,} cells of {res:g} m: give closer goals, or --map"
        )


def _live_view(
    args: argparse.Namespace, cfg: HostConfig, navigate: Navigation | None
) -> LiveViewSettings:
    """The live view's settings: the config's ``service.live_view``, or ``--live-view``'s
    (which needs the navigation service)."""
    from jackson.host.service.navigation import NavigationService

    settings = cfg.service.live_view
    if args.live_view is None:
        return settings
    if not isinstance(navigate, NavigationService):
        raise DaemonCliError(
            "--live-view shows the navigation service: give --lidar PORT and --map MAP (or "
            "service.lidar and service.map in the config), without --goal or --mission"
        )
    host, port = args.live_view
    return dataclasses.replace(settings, enabled=True, host=host, port=port)


def _serves(args: argparse.Namespace, cfg: HostConfig) -> bool:
    """The daemon runs the navigation service: a LiDAR and a map, from the command line or
    the config's ``service`` section."""
    return bool((args.lidar or cfg.service.lidar) and (args.map or cfg.service.map))


def _service(args: argparse.Namespace, cfg: HostConfig) -> NavigationService:
    """The navigation service the command line and the config ask for (their LiDAR port is
    in ``args.lidar`` afterwards), checked before anything opens."""
    from jackson.host.control.navigate import NavigateConfig, parse_pose
    from jackson.host.control.navigator import RouteError, check_route
    from jackson.host.control.navigator_config import PLAN_DELAY_TICKS, NavigatorConfig
    from jackson.host.nav.grid import MapFileError, OccupancyGrid
    from jackson.host.nav.types import Pose2D
    from jackson.host.service.navigation import NavigationService

    sv = cfg.service
    args.lidar = args.lidar or sv.lidar
    map_path = args.map or sv.map
    assert map_path is not None  # _serves
    where = "--map" if args.map else "service.map"
    try:
        start = parse_pose(args.start) if args.start is not None else Pose2D(*sv.start)
    except ValueError as exc:
        raise DaemonCliError(f"--start: {exc}") from exc
    try:
        grid = OccupancyGrid.load(map_path)
    except MapFileError as exc:
        raise DaemonCliError(f"{where}: {exc}") from exc
    config = NavigateConfig(
        start=start,
        goals=(),
        localisation="amcl",
        navigator=NavigatorConfig(plan_delay_ticks=PLAN_DELAY_TICKS),
    )
    try:
        check_route(grid, start, (), config.navigator)
        return NavigationService(config, cfg.navigation_limits(), grid, sv, _planner(config, cfg))
    except RouteError as exc:
        raise DaemonCliError(f"{exc} ({where} {map_path}; give --start X,Y,YAW)") from exc


def _run_dir(args: argparse.Namespace, cfg: HostConfig, navigate: Navigation | None) -> Path | None:
    """The run folder (None with ``--no-record``), checked to be a new one."""
    if args.no_record:
        return None
    stamp = dt.datetime.now().strftime("%Y%m%d-%H%M%S")
    run_dir: Path = (
        args.run_dir or Path(cfg.recording_folder) / f"{stamp}-{_run_name(args, navigate)}"
    )
    try:
        output_folder(run_dir, "--run-dir" if args.run_dir else "recording folder")
    except ValueError as exc:
        raise DaemonCliError(str(exc)) from exc
    return run_dir


def _run_name(args: argparse.Namespace, navigate: Navigation | None) -> str:
    """The run folder's name after its time stamp."""
    from jackson.host.service.navigation import NavigationService

    if isinstance(navigate, NavigationService):
        return "service"
    return str(args.mission or ("navigate" if navigate is not None else "drive"))


def _nav_mission(navigate: Navigation | None) -> NavigateMission | None:
    """The navigation that maps and localises: the service's, or the --goal mission."""
    from jackson.host.service.navigation import NavigationService

    return navigate.nav if isinstance(navigate, NavigationService) else navigate


# ---------------------------------------------------------------------- the devices


def _start_lidar(args: argparse.Namespace) -> RplidarDriver | None:
    """The RPLIDAR started in the scan mode asked for (None without ``--lidar``)."""
    if not args.lidar:
        return None
    from jackson.host.lidar.rplidar import LidarError, RplidarDriver, start_mode

    lidar = None
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
        raise DaemonCliError(str(exc)) from exc
    return lidar


def _open_link(cfg: HostConfig, lidar: RplidarDriver | None) -> SerialTransport:
    """The MCU's serial port, open; no HELLO yet."""
    from jackson.host.transport import LinkError, SerialTransport

    transport = SerialTransport(cfg.serial.port, cfg.serial.baudrate)
    try:
        # HELLO once the daemon is set up (ROS discovery, the bag): a session that starts
        # earlier streams into a port nobody reads, and a lockstep twin's clock runs off
        transport.open(reader_thread=False, hello=False)
    except LinkError as exc:
        if lidar is not None:
            lidar.close()
        raise DaemonCliError(str(exc)) from exc
    return transport


def _open_pca(cfg: HostConfig, transport: SerialTransport) -> Pca9685 | None:
    """The PCA9685, initialised (None with the MCU driving the motors). Raises
    :class:`_NoAnswerError` when it does not answer (the port closed)."""
    if cfg.actuator != "pca9685":
        return None
    from jackson.host.actuation.i2c import I2cError, I2cSpecError, open_bus
    from jackson.host.actuation.pca9685 import Pca9685

    try:
        pca = Pca9685(open_bus(cfg.pca9685.bus), cfg.pca9685.address)
        pca.init(cfg.pca9685.frequency_hz)
    except (I2cError, OSError) as exc:
        transport.close()
        if isinstance(exc, I2cSpecError):
            raise DaemonCliError(f"--i2c / pca9685.bus: {exc}") from exc
        # hardware that does not answer (yet): exit 1, so systemd starts the daemon again
        raise _NoAnswerError(
            f"PCA9685 at {cfg.pca9685.address:#04x} on {cfg.pca9685.bus}: {exc}"
        ) from exc
    return pca


def _outputs(
    cfg: HostConfig, pca: Pca9685 | None
) -> Callable[[Callable[[Message], object]], MotorOutput]:
    """The daemon's motor output: the PCA9685's (re-initialised after a bus fault) or the
    MCU's PWM commands."""
    from jackson.host.actuation.i2c import open_bus
    from jackson.host.actuation.output import McuOutput, ResilientPca9685Output

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

    return output_factory


def _close(transport: SerialTransport, lidar: RplidarDriver | None) -> None:
    transport.close()
    if lidar is not None:
        lidar.close()


# ---------------------------------------------------------------------- the run


def _daemon(
    args: argparse.Namespace,
    cfg: HostConfig,
    navigate: Navigation | None,
    live_view: LiveViewSettings,
    transport: SerialTransport,
    lidar: RplidarDriver | None,
    outputs: Callable[[Callable[[Message], object]], MotorOutput],
    run_dir: Path | None,
) -> Daemon:
    """The daemon set up, its run folder's meta.json written; a control socket that cannot
    be served closes the devices."""
    from jackson.host.control.navigate import navigate_meta
    from jackson.host.daemon import Daemon
    from jackson.host.sdnotify import notifier_from_env
    from jackson.host.service.control import ControlError
    from jackson.host.service.navigation import NavigationService, service_meta
    from jackson.host.service.settings import socket_path

    service = navigate if isinstance(navigate, NavigationService) else None
    nav_mission = _nav_mission(navigate)
    meta = {
        "mission": "service"
        if service is not None
        else ("navigate" if navigate is not None else args.mission),
        "navigate": navigate_meta(nav_mission.config) if nav_mission is not None else None,
        "service": service_meta(service) if service is not None else None,
        "config": str(args.config or "default"),
        "port": cfg.serial.port,
        "started": dt.datetime.now().isoformat(),
    }
    try:
        return Daemon(
            cfg,
            outputs,
            transport,
            mission_name=args.mission,
            run_folder=run_dir,
            meta=meta,
            rotate=True,  # split into run folders, kept under the budget (docs/recording.md)
            ros_args=(["--ros-args", *args.ros_args] if args.ros_args else [])
            if args.ros
            else None,
            mission_timeout_s=args.mission_timeout,
            notifier=notifier_from_env(),
            mission=navigate,
            lidar=lidar,
            stall_s=args.stall_timeout,
            control_socket=(args.socket or socket_path(cfg.service))
            if service is not None
            else None,
            live_view=live_view,
        )
    except ControlError as exc:
        _close(transport, lidar)
        raise DaemonCliError(str(exc)) from exc


def _write_run_files(run_dir: Path, cfg: HostConfig, nav_mission: NavigateMission | None) -> None:
    """The run folder's config.yaml, and the map a replay localises on."""
    import yaml

    from jackson.host.config import dump_config
    from jackson.host.control.navigate import MAP_NAME

    run_dir.mkdir(parents=True, exist_ok=True)
    (run_dir / "config.yaml").write_text(yaml.safe_dump(dump_config(cfg), sort_keys=False))
    if nav_mission is not None and nav_mission.static_map is not None:
        nav_mission.static_map.save(run_dir / f"{MAP_NAME}.yaml")  # the replay's map


def _summary(
    daemon: Daemon, args: argparse.Namespace, navigate: Navigation | None, status: int
) -> int:
    """The run's summary printed (CPU, then how it ended); the exit status."""
    from jackson.host.service.navigation import NavigationService

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
    if isinstance(navigate, NavigationService):
        counts = ", ".join(f"{n} {k}" for k, n in navigate.book.counts.items() if n)
        print(f"service stopped: goals {counts or 'none'}", flush=True)
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
