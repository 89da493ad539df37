"""The host's commands: ``jackson daemon`` (:mod:`jackson.host.daemon_cli`), ``jackson goal``,
``cancel``, ``status`` and ``localise`` to a running navigation service, ``jackson monitor`` and
``jackson replay``."""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
from pathlib import Path
from typing import Any

from jackson.common.args import MAX_SECONDS, float_upto, positive_int
from jackson.common.errors import JacksonError
from jackson.host.daemon_cli import add_parser as add_daemon_parser


class HostCliError(JacksonError):
    """One line for the user, exit status 2."""


def add_parsers(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    add_daemon_parser(sub)

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
    if lat := st.get("latency_ms"):  # telemetry read to its HEARTBEAT written
        out.append(f"latency: median {lat['median']:.1f} ms, p99 {lat['p99']:.1f} ms, "
                   f"max {lat['max']:.1f} ms")  # fmt: skip
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


def _load(path: Path | None) -> object:
    from jackson.host.config import DEFAULT_CONFIG, ConfigError, load_config

    try:
        return load_config(path or DEFAULT_CONFIG)
    except ConfigError as exc:
        raise HostCliError(str(exc)) from exc


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
        extra = "" if r.complete or made <= kept else f" (the log held {made - kept} more)"
        print(f"  {name}: {kept} rows in the run, {made} replayed{extra}")
    if r.differ:
        print(f"replay differs from the run in {', '.join(r.differ)} (outputs in {out})")
        return 1
    what = "bit for bit" if r.complete else "on every row the run kept"
    if args.out:
        print(f"replay reproduces odometry, EKF and commands {what} ({out})")
    else:  # the outputs equal the run's own: a temporary copy is not kept
        shutil.rmtree(out, ignore_errors=True)
        print(f"replay reproduces odometry, EKF and commands {what} (--out DIR keeps the outputs)")
    return 0
