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
    host_port,
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
        help="localise on this map (map_server YAML); with --lidar and no --goal, serve goal "
        "after goal (the navigation service, docs/host.md); with --goal and without --map, map "
        "as it goes",
    )
    p.add_argument(
        "--start",
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

    _add_service_parsers(sub)

    p = sub.add_parser("monitor", help="live view of the link: rate, errors, counts, IMU, health")
    p.add_argument("--port", required=True, help="serial port (the robot's or the twin's)")
    p.add_argument("--baudrate", type=positive_int, default=921600)
    p.add_argument("--duration", type=float_upto(MAX_SECONDS), help="stop after this many seconds")
    p.set_defaults(func=cmd_monitor)

    p = sub.add_parser("replay", help="feed a run folder back through the host, offline")
    p.add_argument("run", type=Path, help="run folder written by jackson daemon")
    p.add_argument("--out", type=Path, help="where to write the replayed outputs (default: temp)")
    p.set_defaults(func=cmd_replay)


def _add_service_parsers(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """``jackson goal``, ``cancel``, ``status``, ``localise``: a running navigation service."""

    def socket_option(p: argparse.ArgumentParser) -> None:
        p.add_argument(
            "--socket",
            type=Path,
            help="the daemon's control socket (default: $JACKSON_SOCKET, else the daemon's "
            "default: /run/jackson/daemon.sock, or $XDG_RUNTIME_DIR/jackson/daemon.sock)",
        )
        p.add_argument("--config", type=Path, help="host YAML naming service.socket")

    p = sub.add_parser("goal", help="send a running robot to a map pose (the navigation service)")
    p.add_argument("pose", metavar="X,Y[,YAW]", help="the goal in the map frame [m, m, rad]")
    p.add_argument(
        "--wait",
        action="store_true",
        help="wait for the goal's end, showing progress; exit 0 when reached, 1 otherwise",
    )
    socket_option(p)
    p.set_defaults(func=cmd_goal)
    p = sub.add_parser("cancel", help="cancel the running robot's goal: it brakes and idles")
    p.add_argument("--id", type=positive_int, default=0, help="the goal's id (default: the active)")
    socket_option(p)
    p.set_defaults(func=cmd_cancel)
    p = sub.add_parser(
        "status", help="the running robot: state, goal, pose, health, CPU, disk (one screen)"
    )
    p.add_argument("--json", action="store_true", help="print the daemon's answer as JSON")
    socket_option(p)
    p.set_defaults(func=cmd_status)
    p = sub.add_parser(
        "localise", help="tell the running robot where it is (as RViz's 2D Pose Estimate)"
    )
    p.add_argument("pose", metavar="X,Y[,YAW]", help="the robot's pose in the map frame")
    socket_option(p)
    p.set_defaults(func=cmd_localise)


def _socket(args: argparse.Namespace) -> Path:
    from jackson.host.service.settings import ServiceSettings, socket_path

    if args.socket is not None:
        return Path(args.socket)
    if args.config is not None:
        cfg = _load(args.config)
        return socket_path(cfg.service)  # type: ignore[attr-defined]
    return socket_path(ServiceSettings())


def _ask(args: argparse.Namespace, request: dict[str, Any], timeout_s: float | None = 10.0) -> Any:
    from jackson.host.service.control import ControlError, ask

    try:
        yield from ask(_socket(args), request, timeout_s)
    except ControlError as exc:
        raise HostCliError(str(exc)) from exc


def _pose_arg(text: str) -> Any:
    from jackson.host.control.navigate import parse_pose

    try:
        return parse_pose(text)
    except ValueError as exc:
        raise HostCliError(f"pose: {exc}") from exc


def _goal_line(g: dict[str, Any]) -> str:
    where = f"({g['x']:.2f}, {g['y']:.2f}, {g['yaw']:.2f})"
    text = f"goal {g['id']} {where}: {g['status']}"
    if g.get("reason"):
        text += f": {g['reason']}"
    if g.get("t_end_s") is not None and g.get("t_start_s") is not None:
        text += f" ({g['navigation_time_s']:.1f} s"
        text += f", {g['recoveries']} recoveries)" if g.get("recoveries") else ")"
    return text


def cmd_goal(args: argparse.Namespace) -> int:
    import contextlib

    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    pose = _pose_arg(args.pose)
    request = {"op": "goal", "x": pose.x, "y": pose.y, "yaw": pose.yaw, "wait": args.wait}
    result: dict[str, Any] | None = None
    progress = Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        TextColumn("{task.fields[left]}"),
        TimeElapsedColumn(),
        transient=True,
        disable=not sys.stdout.isatty(),
    )
    task = None
    with progress if args.wait else contextlib.nullcontext():
        for answer in _ask(args, request, None if args.wait else 10.0):
            if "ok" in answer:
                if not answer["ok"]:
                    raise HostCliError(answer["error"])
                progress.console.print(_goal_line(answer["goal"]))
            elif "feedback" in answer:
                fb = answer["feedback"]
                left = fb.get("distance_remaining_m")
                if left is None:
                    continue
                if task is None:
                    task = progress.add_task(f"goal {fb['id']}", total=max(left, 0.01), left="")
                eta = fb.get("eta_s")
                progress.update(
                    task,
                    completed=max(0.0, (progress.tasks[0].total or 0.0) - left),
                    left=f"{left:.1f} m left" + (f", ~{eta:.0f} s" if eta else ""),
                )
            elif "result" in answer:
                result = answer["result"]
    if not args.wait:
        return 0
    if result is None:
        raise HostCliError("the daemon went away before the goal ended")
    print(_goal_line(result), flush=True)
    return 0 if result.get("status") == "succeeded" else 1


def cmd_cancel(args: argparse.Namespace) -> int:
    for answer in _ask(args, {"op": "cancel", "id": args.id}):
        if not answer.get("ok"):
            raise HostCliError(answer.get("error", "the daemon refused"))
        print(f"canceling goal {answer['goal']['id']}: the robot brakes and idles", flush=True)
    return 0


def cmd_localise(args: argparse.Namespace) -> int:
    pose = _pose_arg(args.pose)
    for answer in _ask(args, {"op": "localise", "x": pose.x, "y": pose.y, "yaw": pose.yaw}):
        if not answer.get("ok"):
            raise HostCliError(answer.get("error", "the daemon refused"))
        print(f"localising from ({pose.x:.2f}, {pose.y:.2f}, {pose.yaw:.2f})", flush=True)
    return 0


def cmd_status(args: argparse.Namespace) -> int:
    import json

    for answer in _ask(args, {"op": "status"}):
        if not answer.get("ok"):
            raise HostCliError(answer.get("error", "the daemon refused"))
        st = answer["status"]
        if args.json:
            print(json.dumps(st, indent=2))
            continue
        for line in status_lines(st):
            print(line)
    return 0


def status_lines(st: dict[str, Any]) -> list[str]:
    """``jackson status`` as the operator reads it."""
    out = []
    t = st.get("t_s")
    head = f"state: {st.get('state', 'velocity commands only')}"
    if st.get("unavailable"):
        head += f" (goals refused: {st['unavailable']})"
    out.append(head + (f"; MCU time {t:.1f} s" if t is not None else "; no telemetry yet"))
    pose = st.get("pose")
    if pose is not None:
        cov = pose["covariance"]
        out.append(
            f"pose: x {pose['x']:+.2f} m, y {pose['y']:+.2f} m, yaw {pose['yaw']:+.2f} rad "
            f"(std {max(cov[0], 0) ** 0.5:.2f} m, {max(cov[4], 0) ** 0.5:.2f} m, "
            f"{max(cov[8], 0) ** 0.5:.2f} rad)"
        )
    goal = st.get("goal")
    if goal is not None:
        left = goal.get("distance_remaining_m")
        eta = st.get("eta_s")
        extra = f", {left:.1f} m left" if left is not None else ""
        extra += f", ~{eta:.0f} s" if eta is not None else ""
        out.append(_goal_line(goal) + extra)
    elif "goals" in st:
        last = st.get("last_goal")
        out.append("goal: none" + (f"; last {_goal_line(last)}" if last else ""))
    if "goals" in st:
        counts = ", ".join(f"{n} {k}" for k, n in st["goals"].items() if n)
        out.append(f"goals so far: {counts or 'none'}")
    sensors = st.get("sensors") or {}
    if sensors:
        out.append("sensors: " + ", ".join(f"{k} {v}" for k, v in sensors.items()))
    out.append("link: " + ("; ".join(st.get("problems") or []) or "ok"))
    cpu = st.get("cpu") or {}
    out.append(
        f"CPU: {cpu.get('share_of_core', 0) * 100:.1f} % of a core over "
        f"{cpu.get('robot_s', 0):.0f} s of robot time "
        f"(frame p99 {cpu.get('frame_p99_ms', 0):.1f} ms)"
    )
    d = st.get("disk") or {}
    if d:
        budget = (
            f" of a {d['budget_mb']:.0f} MB budget ({d['left_mb']:.0f} MB left)"
            if d.get("budget_mb")
            else ""
        )
        out.append(
            f"disk: recordings {d['used_mb']:.0f} MB{budget} in {d['folder']}; "
            f"{d['free_mb'] / 1e3:.1f} GB free" + ("" if d.get("recording") else " (not recording)")
        )
    return out


def _run_name(args: argparse.Namespace, navigate: Any) -> str:
    """The run folder's name after its time stamp."""
    from jackson.host.service.navigation import NavigationService

    if isinstance(navigate, NavigationService):
        return "service"
    return str(args.mission or ("navigate" if navigate is not None else "drive"))


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
    live_view = _live_view(args, cfg, navigate)
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
        run_dir = (
            args.run_dir or Path(cfg.recording_folder) / f"{stamp}-{_run_name(args, navigate)}"
        )
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
    from jackson.host.service.control import ControlError
    from jackson.host.service.navigation import NavigationService, service_meta
    from jackson.host.service.settings import socket_path

    service = navigate if isinstance(navigate, NavigationService) else None
    nav_mission = service.nav if service is not None else navigate
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
        daemon = Daemon(
            cfg,
            output_factory,
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
        transport.close()
        if lidar is not None:
            lidar.close()
        raise HostCliError(str(exc)) from exc
    if run_dir is not None:
        import yaml

        from jackson.host.config import dump_config

        run_dir.mkdir(parents=True, exist_ok=True)
        (run_dir / "config.yaml").write_text(yaml.safe_dump(dump_config(cfg), sort_keys=False))
        if nav_mission is not None and nav_mission.static_map is not None:
            nav_mission.static_map.save(run_dir / f"{MAP_NAME}.yaml")  # the replay's map
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
        if nav_mission is not None and run_dir is not None:
            built = nav_mission.built_map()
            last = daemon.run_folder or run_dir  # the last folder of a split run
            if built is not None:
                built.save(last / "built_map.yaml")
                print(f"map: {last / 'built_map.yaml'}", flush=True)
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
    if service is not None:
        counts = ", ".join(f"{n} {k}" for k, n in service.book.counts.items() if n)
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


def _navigate(args: argparse.Namespace, cfg: Any) -> Any:
    """The navigation mission --goal asks for (None without), checked before anything opens."""
    from jackson.host.lidar.rplidar import start_mode

    if start_mode(args.lidar_mode) is not None and not args.lidar:
        raise HostCliError("--lidar-mode needs --lidar PORT (the RPLIDAR's port)")
    if not args.goal:
        if args.mission and (args.lidar or args.map):
            raise HostCliError(f"--mission {args.mission} drives without the LiDAR and map")
        if args.mission is None and _serves(args, cfg):
            return _service(args, cfg)
        if args.map is not None:
            raise HostCliError(
                "--map needs --lidar PORT (or service.lidar in the config) to serve goals"
            )
        if args.start is not None:
            raise HostCliError("--start needs --lidar and --map (or --goal)")
        return None
    if args.mission:
        raise HostCliError("--goal navigates: give it or --mission, not both")
    if not args.lidar:
        raise HostCliError("--goal needs --lidar PORT (the RPLIDAR's port)")
    from jackson.host.control.navigate import NavigateConfig, NavigateMission, parse_pose, poses
    from jackson.host.nav.grid import MapFileError, OccupancyGrid

    try:
        start = parse_pose(args.start or "0,0,0")
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


def _live_view(args: argparse.Namespace, cfg: Any, navigate: Any) -> Any:
    """The live view's settings: the config's ``service.live_view``, or ``--live-view``'s
    (which needs the navigation service)."""
    import dataclasses

    from jackson.host.service.navigation import NavigationService

    settings = cfg.service.live_view
    if args.live_view is None:
        return settings
    if not isinstance(navigate, NavigationService):
        raise HostCliError(
            "--live-view shows the navigation service: give --lidar PORT and --map MAP (or "
            "service.lidar and service.map in the config), without --goal or --mission"
        )
    host, port = args.live_view
    return dataclasses.replace(settings, enabled=True, host=host, port=port)


def _serves(args: argparse.Namespace, cfg: Any) -> bool:
    """The daemon runs the navigation service: a LiDAR and a map, from the command line or
    the config's ``service`` section."""
    return bool((args.lidar or cfg.service.lidar) and (args.map or cfg.service.map))


def _service(args: argparse.Namespace, cfg: Any) -> Any:
    """The navigation service the command line and the config ask for (their LiDAR port is
    in ``args.lidar`` afterwards), checked before anything opens."""
    from jackson.host.control.navigate import NavigateConfig, parse_pose
    from jackson.host.control.navigator import RouteError, check_route
    from jackson.host.nav.grid import MapFileError, OccupancyGrid
    from jackson.host.nav.types import Pose2D
    from jackson.host.service.navigation import NavigationService

    sv = cfg.service
    args.lidar = args.lidar or sv.lidar
    map_path = args.map or sv.map
    where = "--map" if args.map else "service.map"
    try:
        start = parse_pose(args.start) if args.start is not None else Pose2D(*sv.start)
    except ValueError as exc:
        raise HostCliError(f"--start: {exc}") from exc
    try:
        grid = OccupancyGrid.load(map_path)
    except MapFileError as exc:
        raise HostCliError(f"{where}: {exc}") from exc
    config = NavigateConfig(start=start, goals=(), localisation="amcl")
    try:
        check_route(grid, start, (), config.navigator)
        return NavigationService(config, cfg.navigation_limits(), grid, sv)
    except RouteError as exc:
        raise HostCliError(f"{exc} ({where} {map_path}; give --start X,Y,YAW)") from exc


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
    if r.snapshot is not None:
        print(
            f"  started from the core's snapshot of the split ({r.snapshot.get('reason')}) "
            f"after frame {r.snapshot.get('frames')}"
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
