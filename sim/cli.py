"""``jackson sim``: start the twin and print where the host connects.

It prints ``serial: PATH`` and ``i2c: unix:PATH`` first, in that order (tools read them), then
``lidar: PATH`` (the emulated RPLIDAR's pty) unless the twin runs without a LiDAR, then
``truth: PATH`` with ``--truth`` (the ground-truth file ``jackson calibrate --twin-truth``
reads, :class:`jackson.sim.runner.TruthStream`).

``--fault KIND@AT_S[+DURATION_S][:key=value,...]`` (repeatable) injects a fault besides the
robot file's (:mod:`jackson.sim.faults`); the twin prints ``fault: ...`` for each at the start
and what each injected on the way out.

In lockstep, a twin that has waited ``--stall-timeout`` seconds for one HEARTBEAT (possible
when ``--heartbeat-timeout`` is longer) looks at the host, and when it is gone, stopped or
does no work (:mod:`jackson.sim.lockstep`) gives up: it prints its summary, then one line on
stderr (``jackson sim: lockstep stalled: the twin waited ...``), and exits with status 75.
A host that does not answer within ``--heartbeat-timeout`` and is not working on its answer
counts as gone: the twin says so on stderr (``jackson sim: no HEARTBEAT for 3.0 s after frame
N ... and the host used 0 ms of CPU in 0.50 s: the twin runs on in real time ...``), and says
again when the host is back in lockstep (a HEARTBEAT, or a HELLO that begins a session).
"""

from __future__ import annotations

import argparse
import signal
import sys
import tempfile
import threading
from collections.abc import Callable
from pathlib import Path
from types import FrameType
from typing import TYPE_CHECKING

from jackson.common.args import (
    MAX_SECONDS,
    float_upto,
    host_port,
    int_in,
    nonneg_float,
    nonneg_int,
    os_error_line,
    positive_float,
)
from jackson.common.liveness import STALL_EXIT
from jackson.common.spin import DEFAULT_SPIN_S
from jackson.sim.config import ConfigError, load_robot, load_world
from jackson.sim.faults import FaultError, FaultSpec, format_fault, parse_fault, summary
from jackson.sim.fil import FirmwareError
from jackson.sim.firmware_core import McuBuildError
from jackson.sim.i2c_server import I2cServerError

if TYPE_CHECKING:
    from jackson.sim.liveview import TwinLiveView
    from jackson.sim.ros import TwinRosPublisher
    from jackson.sim.runner import RunnerStats, TwinRunner
    from jackson.sim.twin import Twin


def fault_arg(text: str) -> FaultSpec:
    """``--fault``'s type: :func:`jackson.sim.faults.parse_fault`, its error as argparse's.

    Parameters
    ----------
    text : str
        ``KIND@AT_S[+DURATION_S][:key=value,...]``.

    Returns
    -------
    FaultSpec
        The fault.

    Raises
    ------
    argparse.ArgumentTypeError
        One line naming the problem and the valid kinds or keys.
    """
    try:
        return parse_fault(text)
    except FaultError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


FAULT_HELP = (
    "inject a fault besides the robot file's (repeatable): KIND@AT_S[+DURATION_S][:key=value,"
    "...] on MCU time, e.g. imu_bias_step@20:magnitude_rad_s=0.05, encoder_dropout@15+5:"
    "side=left, frame_loss@0:probability=0.05 (kinds and keys: docs/sim.md, Faults)"
)

STALL_TIMEOUT_S = 10.0
"""``--stall-timeout``'s default: :data:`jackson.sim.runner.STALL_S` (not imported here, so
``jackson --help`` does not load the physics)."""

SCAN_HISTORY = 64
"""Scans ``jackson sim`` keeps (8.6 s at 7.43 Hz): enough for the /twin/scan publisher, which takes
them after every advance of the clock, and a constant memory use however long it runs."""


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "sim",
        help="start the digital twin: a robot on a virtual serial port and a virtual I2C bus",
        description="Start the digital twin. It prints the serial port and the I2C socket a host "
        "connects to, and runs until SIGINT or SIGTERM (or --duration).",
    )
    p.add_argument("--world", default="open_floor", help="world name in sim/worlds or a YAML path")
    p.add_argument("--robot", default="jackson", help="robot name in sim/robots or a YAML path")
    p.add_argument("--realtime", action="store_true", help="pace on the wall clock (else lockstep)")
    p.add_argument(
        "--firmware",
        action="store_true",
        help="run the MCU as the POSIX firmware process (its own pty) instead of the same core "
        "in this process",
    )
    p.add_argument(
        "--mcu-motors",
        action="store_true",
        help="the MCU drives the motors (MOTOR_PWM) instead of the PCA9685",
    )
    p.add_argument("--seed", type=nonneg_int, default=0, help="noise seed (runs are deterministic)")
    p.add_argument(
        "--boot-id",
        type=int_in(1, (1 << 32) - 1),
        help="the MCU's boot_id in INFO (default: random, as each boot of the robot)",
    )
    p.add_argument("--i2c", type=Path, help="I2C socket path (default: a fresh temporary path)")
    p.add_argument("--link", help="also make this symlink to the serial port (e.g. /tmp/robot)")
    p.add_argument("--no-lidar", action="store_true", help="do not simulate the LiDAR")
    p.add_argument(
        "--lidar-link",
        help="also make this symlink to the emulated RPLIDAR's port (e.g. /tmp/lidar)",
    )
    p.add_argument(
        "--ros",
        action="store_true",
        help="publish /twin/scan, /ground_truth/odom and /clock (sim time) over ROS 2",
    )
    p.add_argument(
        "--live-view",
        type=host_port,
        metavar="[HOST:]PORT",
        help="serve the ground truth live over the Foxglove WebSocket protocol (world, true "
        "pose, true scan; docs/sim.md) on this port, bound to 127.0.0.1 unless HOST is given",
    )
    p.add_argument(
        "--truth",
        type=Path,
        metavar="PATH",
        help="write the ground truth here as it happens (CSV t_us,t_s,x_m,y_m,yaw_rad, one row "
        "per telemetry instant; for jackson calibrate --twin-truth)",
    )
    p.add_argument(
        "--fault", type=fault_arg, action="append", default=[], metavar="SPEC", help=FAULT_HELP
    )
    p.add_argument(
        "--duration", type=float_upto(MAX_SECONDS), help="stop after this many simulated seconds"
    )
    p.add_argument(
        "--heartbeat-timeout",
        type=positive_float,
        default=1.0,
        help="lockstep: wall seconds to wait for the host before moving on",
    )
    p.add_argument(
        "--stall-timeout",
        type=positive_float,
        default=STALL_TIMEOUT_S,
        metavar="S",
        help="lockstep: wall seconds of waiting for one HEARTBEAT, the clock standing still, "
        "before the twin looks at the host: a host gone, stopped or idle ends the twin with "
        "exit status 75 (applies when shorter than --heartbeat-timeout; default %(default)g)",
    )
    p.add_argument(
        "--spin-us",
        type=nonneg_float,
        default=DEFAULT_SPIN_S * 1e6,
        help="lockstep: poll this many microseconds for the host before blocking "
        "(0: block at once; the polling pauses by itself while other processes keep the "
        "cores busy; default %(default).0f)",
    )


def _replaceable_truth(path: Path) -> bool:
    """Whether ``--truth`` may write ``path``: a new path, an empty file, or a ground-truth
    file of before."""
    from jackson.sim.runner import TRUTH_MAGIC

    if not path.exists() and not path.is_symlink():
        return True
    if not path.is_file():
        return False
    try:
        with path.open("rb") as f:
            head = f.read(len(TRUTH_MAGIC))
    except OSError:
        return False
    return head in (b"", TRUTH_MAGIC.encode("ascii"))


def _live_view(twin: Twin, where: tuple[str, int]) -> TwinLiveView | None:
    """The twin's live view, serving; None (with one line on stderr) when it cannot be: the
    twin goes on without it."""
    from jackson.common.liveview import LiveServer, LiveViewError
    from jackson.sim.liveview import TwinLiveView

    try:
        live = TwinLiveView(twin, LiveServer("jackson sim", *where))
        live.start()
    except LiveViewError as exc:
        print(f"jackson sim: {exc}; going on without it", file=sys.stderr, flush=True)
        return None
    return live


def run(args: argparse.Namespace) -> int:
    """``jackson sim``: check the options, start the twin and its runner, serve until a signal
    (or ``--duration``), then print the summary.

    Returns
    -------
    int
        0; 75 when lockstep stalled; 2 for a problem with the options or the files.
    """
    from jackson.sim.twin import Twin

    try:
        world = load_world(args.world)
        robot = load_robot(args.robot)
    except ConfigError as exc:
        print(f"jackson sim: {exc}", file=sys.stderr)
        return 2
    problem = _refusal(args)
    if problem is not None:
        print(f"jackson sim: {problem}", file=sys.stderr)
        return 2
    try:
        twin = Twin(
            world,
            robot,
            seed=args.seed,
            lidar=False if args.no_lidar else None,
            record_truth=False,  # a long-running twin keeps no history (the host records it)
            scan_history=SCAN_HISTORY,
            faults=args.fault,
        )
    except ConfigError as exc:
        print(f"jackson sim: {exc}", file=sys.stderr)
        return 2
    if args.lidar_link is not None and twin._lidar is None:
        print(
            f"jackson sim: --lidar-link: robot {robot.name} has no LiDAR (lidar.enabled is "
            "false in its file)",
            file=sys.stderr,
        )
        return 2
    tmp = None
    i2c_path = args.i2c
    if i2c_path is None:
        tmp = tempfile.TemporaryDirectory(prefix="jackson-twin-")
        i2c_path = Path(tmp.name) / "i2c.sock"
    publisher = None
    if args.ros:
        from jackson.sim.ros import TwinRosPublisher

        publisher = TwinRosPublisher(twin)
    live = _live_view(twin, args.live_view) if args.live_view is not None else None
    try:
        runner = _runner(args, twin, i2c_path, _observer(publisher, live))
    except (I2cServerError, FirmwareError, McuBuildError, FaultError, OSError) as exc:
        _close(publisher, live, tmp)
        text = os_error_line(exc) if isinstance(exc, OSError) else str(exc)
        print(f"jackson sim: {text}", file=sys.stderr)
        return 2
    runner.watch.tell = _tell
    stop = threading.Event()

    def on_signal(signum: int, frame: FrameType | None) -> None:
        stop.set()

    signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGTERM, on_signal)
    _announce(runner, twin, i2c_path, publisher, live)
    print(
        f"twin: world {world.name}, robot {robot.name}, {_what_runs(args)}; waiting for HELLO",
        flush=True,
    )
    try:
        stats = runner.run(args.duration, stop)
    finally:
        runner.close()
        _close(publisher, live, tmp)
    return _summary(stats, twin)


def _runner(
    args: argparse.Namespace, twin: Twin, i2c_path: Path, observer: Callable[[Twin], None] | None
) -> TwinRunner:
    """The twin's runner as the options ask: its ports, clock, MCU and LiDAR."""
    from jackson.sim.runner import TwinRunner

    return TwinRunner(
        twin,
        i2c_path=i2c_path,
        lockstep=not args.realtime,
        firmware=args.firmware,
        mcu_motors=args.mcu_motors,
        heartbeat_timeout_s=args.heartbeat_timeout,
        serial_link=args.link,
        observer=observer,
        spin_s=0.0 if args.realtime else max(0.0, args.spin_us) / 1e6,
        boot_id=args.boot_id,
        lidar=not args.no_lidar,
        lidar_link=args.lidar_link,
        truth=args.truth,
        stall_s=args.stall_timeout,
    )


def _refusal(args: argparse.Namespace) -> str | None:
    """Why the options cannot start a twin, in one line, found before anything starts (None:
    they can)."""
    if args.ros:
        from jackson.sim.ros import ros_available

        problem = ros_available()
        if problem is not None:
            return problem
    for option, link in (("--link", args.link), ("--lidar-link", args.lidar_link)):
        if link is not None and Path(link).exists() and not Path(link).is_symlink():
            return (
                f"{option} {link}: is there and is not a symlink; give a new path "
                "(it is never replaced)"
            )
    if args.truth is not None and not _replaceable_truth(args.truth):
        return (
            f"--truth {args.truth}: is there and is not a ground-truth file of "
            "jackson sim; give a new path (only an old ground-truth file is replaced)"
        )
    if args.lidar_link is not None and args.no_lidar:
        return "--lidar-link needs the LiDAR: drop --no-lidar"
    return None


def _observer(
    publisher: TwinRosPublisher | None, live: TwinLiveView | None
) -> Callable[[Twin], None] | None:
    """What the runner calls after each advance of the clock: the ROS publisher's and the live
    view's ``on_advance`` (None: neither runs)."""
    observers: list[Callable[[Twin], None]] = []
    if publisher is not None:
        observers.append(publisher.on_advance)
    if live is not None:
        observers.append(live.on_advance)
    if len(observers) <= 1:
        return observers[0] if observers else None

    def observe(t: Twin) -> None:
        for observer in observers:
            observer(t)

    return observe


def _close(
    publisher: TwinRosPublisher | None,
    live: TwinLiveView | None,
    tmp: tempfile.TemporaryDirectory[str] | None,
) -> None:
    """Stop what ran beside the runner and remove the temporary I2C socket's folder."""
    if publisher is not None:
        publisher.close()
    if live is not None:
        live.stop()
    if tmp is not None:
        tmp.cleanup()


def _announce(
    runner: TwinRunner,
    twin: Twin,
    i2c_path: Path,
    publisher: TwinRosPublisher | None,
    live: TwinLiveView | None,
) -> None:
    """Print where the host connects (``serial:`` and ``i2c:`` first, tools read them), then
    the faults, the live view and the ROS topics."""
    print(f"serial: {runner.serial_path}", flush=True)
    print(f"i2c: unix:{i2c_path}", flush=True)
    if runner.lidar_path is not None:
        print(f"lidar: {runner.lidar_path}", flush=True)
    if runner.truth is not None:
        print(f"truth: {runner.truth.path}", flush=True)
    if twin.faults is not None:
        for f in twin.faults.faults:
            print(f"fault: {format_fault(f)}", flush=True)
    if live is not None:
        print(f"live view: {live.server.url} (Foxglove: Open connection)", flush=True)
    if publisher is not None:
        scan = ", /twin/scan" if publisher.scan_pub is not None else ""
        topics = f"/clock, /ground_truth/odom{scan}"
        print(f"ros: publishing {topics} on sim time", flush=True)


def _tell(line: str) -> None:
    """A line of the lockstep's own (the host judged gone, back again), on stderr."""
    print(f"jackson sim: {line}", file=sys.stderr, flush=True)


def _what_runs(args: argparse.Namespace) -> str:
    """The clock, the MCU and the physics in use, e.g. ``lockstep, firmware core in process,
    compiled physics``."""
    from jackson.sim.compiled import SELECTION

    mode = "real time" if args.realtime else "lockstep"
    mcu = "POSIX firmware process" if args.firmware else "firmware core in process"
    physics = "compiled physics" if SELECTION.compiled else "interpreted physics"
    return f"{mode}, {mcu}, {physics}"


def _summary(stats: RunnerStats, twin: Twin) -> int:
    """Print what the run did and what each fault injected; the exit status (75: lockstep
    stalled)."""
    print(
        f"twin: {stats.sim_s:.2f} s simulated in {stats.wall_s:.2f} s "
        f"(x{stats.real_time_factor:.0f}), {stats.frames} telemetry frames, "
        f"{twin.collisions} collisions, CPU {stats.cpu_s:.3f} s "
        f"({stats.spun_s:.3f} s of it polling for the host)",
        flush=True,
    )
    for contact in twin.world.contacts:
        print(f"twin: {contact.line()}", flush=True)
    if twin.faults is not None:
        for entry in twin.faults.record():
            print(f"fault: {entry['fault']}: {summary(entry)}", flush=True)
    if stats.stalled is not None:
        print(f"jackson sim: {stats.stalled}", file=sys.stderr, flush=True)
        return STALL_EXIT
    return 0
