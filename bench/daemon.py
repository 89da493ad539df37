"""``jackson bench`` suite ``daemon``: the CPU of the process a user runs, ``jackson daemon``.

The daemon runs as users run it: its own process, on the pty of a ``jackson sim`` process
(lockstep), the PCA9685 on the twin's I2C socket, recording on (CSVs, log.jrec, the bag),
once driving the paper's square (no LiDAR) and three times navigating the maze with the twin's
RPLIDAR in its densest mode on a map of the maze (the median run counts). Its figures come from the
run's own ``health.json`` (:class:`jackson.host.cpu.CpuMeter`): the process's CPU over the robot's
time from the first telemetry frame to the last, as a share of one core (every thread: the bag,
ROS, the LiDAR), and the CPU per frame on the daemon's thread, median and p99, over the 50 ms
telemetry period. These are ratios to the robot's own clock, which a slower machine cannot
stretch: a regression anywhere in the frame path raises them.

Beside them, the daemon's frame latency idle and loaded, at the normal policy and with
``--realtime`` (:mod:`jackson.bench.daemon_latency`): the figure a busy machine does stretch.

Beside them, what the navigating run writes per robot-hour (its run folder's size over the
robot's time), target 250 MB.

Targets: with navigation and recording, 5 % of a core (about 15 % of a Jetson-class core),
the p99 frame within half the period; the square, 2 % of a core at 20 Hz telemetry and 20 % at
200 Hz (the config's ``serial.telemetry_rate_hz``), each frame at 200 Hz at most 1.2 times the
CPU of one at 20 Hz (linear, not quadratic, in the rate).
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

from jackson.bench import daemon_latency
from jackson.common.bench import BenchResult, reference_loop_us
from jackson.host.recording.budget import folder_bytes

TELEMETRY_HZ = 20.0
NAV_SHARE_TARGET = 0.05  # of one core, navigating and recording
SQUARE_SHARE_TARGET = 0.02  # of one core, the square and recording
P99_TARGET = 0.5  # of the telemetry period
FAST_HZ = 200  # the firmware's top telemetry rate
LINEAR_TARGET = 1.2  # a frame at 200 Hz over one at 20 Hz: linear in the rate
DISK_TARGET_MB_PER_H = 250.0  # a navigating robot-hour's run folder (bag, log, CSVs)
RUN_TIMEOUT_S = 600.0
NAV_RUNS = 3  # navigations whose median figures count (one in quick mode): one run of about
# 11 robot-seconds spreads by +-0.03 of a core between runs of the same code
GOAL = "1.2091,-0.0364"
START = "-0.6909,-0.0364,0"


def _jackson() -> str:
    return str(Path(sys.executable).parent / "jackson")


def _maze_map(folder: Path) -> Path:
    """A map of the maze from the twin's world file (no survey needed), map_server YAML."""
    from jackson.experiments.stage3 import world_grid
    from jackson.sim.config import load_world

    path = folder / "maze.yaml"
    world_grid(load_world("maze")).save(path)
    return path


def _ports(sim: subprocess.Popen[str], lidar: bool) -> dict[str, str]:
    """The ``name: path`` lines ``jackson sim`` prints before it serves."""
    assert sim.stdout is not None
    wanted = {"serial", "i2c", "lidar"} if lidar else {"serial", "i2c"}
    ports: dict[str, str] = {}
    while not wanted <= ports.keys():
        line = sim.stdout.readline()
        if not line:
            raise RuntimeError("daemon bench: jackson sim ended before it printed its ports")
        name, _, value = line.strip().partition(": ")
        if name in wanted:
            ports[name] = value
    return ports


def daemon_run(
    world: str,
    daemon_args: list[str],
    folder: Path,
    sim_args: tuple[str, ...] = (),
    report: str = "cpu",
    aborted_ok: bool = False,
) -> dict[str, Any]:
    """``jackson sim --world WORLD`` (with ``sim_args``) and ``jackson daemon`` on it with
    ``daemon_args``; the run's ``health.json`` ``report`` entry (``cpu``, ``latency``), with
    the daemon's printed lines under ``"said"`` and its exit status under ``"status"``
    (``aborted_ok``: a mission aborted, exit 1, still counts)."""
    lidar = "--lidar" in daemon_args
    sim_argv = [_jackson(), "sim", "--world", world, *([] if lidar else ["--no-lidar"])]
    sim = subprocess.Popen(
        [*sim_argv, *sim_args], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True
    )
    try:
        ports = _ports(sim, lidar)
        argv = [_jackson(), "daemon", "--port", ports["serial"], "--i2c", ports["i2c"]]
        argv += [ports["lidar"] if a == "LIDAR" else a for a in daemon_args]
        run = folder / "run"
        done = subprocess.run(
            [*argv, "--run-dir", str(run)],
            capture_output=True,
            text=True,
            timeout=RUN_TIMEOUT_S,
        )
        if done.returncode not in ((0, 1) if aborted_ok else (0,)):
            raise RuntimeError(f"daemon bench: jackson daemon failed: {done.stdout}{done.stderr}")
        entry: dict[str, Any] = json.loads((run / "health.json").read_text())[report]
        return {
            **entry, "said": done.stdout, "status": done.returncode,
            "disk_bytes": folder_bytes(run),
        }  # fmt: skip
    finally:
        sim.terminate()
        sim.wait(timeout=30)


def _config_at(folder: Path, rate_hz: int) -> Path:
    """The shipped host config with ``serial.telemetry_rate_hz`` set to ``rate_hz``."""
    import yaml

    from jackson.host.config import DEFAULT_CONFIG

    data = yaml.safe_load(Path(DEFAULT_CONFIG).read_text())
    data["serial"]["telemetry_rate_hz"] = rate_hz
    path = folder / f"jackson_{rate_hz}hz.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def _results(
    label: str,
    cpu: dict[str, Any],
    share_target: float,
    loop_us: float,
    rate_hz: float = TELEMETRY_HZ,
) -> list[BenchResult]:
    period_ms = 1e3 / rate_hz
    return [
        BenchResult(
            f"daemon.cpu_share_{label}",
            float(cpu["share_of_core"]),
            "of one core",
            share_target,
            "lower",
            f"the robot's time: the jackson daemon process's CPU (every thread) from the first "
            f"telemetry frame to the last over the MCU time between them ({label}, recording "
            f"on, {rate_hz:g} Hz telemetry, against jackson sim over a pty)",
            float(cpu["process_s"]),
            "s (CPU; reference: robot time)",
            float(cpu["robot_s"]),
            loop_us,
        ),
        BenchResult(
            f"daemon.frame_p99_{label}",
            float(cpu["frame_share_of_period"]["p99"]),
            f"of the {period_ms:g} ms frame period",
            P99_TARGET,
            "lower",
            f"the telemetry period: the 99th percentile of the daemon thread's CPU per frame "
            f"({label}; median {cpu['frame_us']['median'] / 1e3:.2f} ms, "
            f"{cpu['frames']} frames)",
            float(cpu["frame_us"]["p99"]) / 1e3,
            "ms",
            period_ms,
            loop_us,
        ),
    ]


def _disk(run: dict[str, Any], loop_us: float) -> BenchResult:
    """What a navigating robot-hour writes: the run folder's bytes over the robot's time."""
    mb = float(run["disk_bytes"]) / 1e6
    hours = float(run["robot_s"]) / 3600.0
    return BenchResult(
        "daemon.disk_mb_per_robot_hour_navigating",
        mb / hours,
        "MB per robot-hour",
        DISK_TARGET_MB_PER_H,
        "lower",
        "the robot's time: the navigating run's whole folder (bag, log.jrec, CSVs, map, "
        "config) over the MCU time from its first telemetry frame to its last (the median "
        f"run by CPU, {float(run['robot_s']):.1f} robot-seconds)",
        mb,
        "MB",
        None,
        loop_us,
    )


def _median_run(cpus: list[dict[str, Any]]) -> dict[str, Any]:
    """The run whose share of a core is the median of ``cpus`` (an odd number of runs): its
    share and its own frame statistics, so the figures belong to one run."""
    ranked = sorted(cpus, key=lambda c: float(c["share_of_core"]))
    return ranked[len(ranked) // 2]


def run(quick: bool = False) -> list[BenchResult]:
    """The daemon's CPU, navigating the maze (the median of :data:`NAV_RUNS` runs) and driving
    the square (one run each); the figures are ratios to the robot's clock, which load does not
    stretch."""
    loop_us = reference_loop_us()
    with tempfile.TemporaryDirectory(prefix="jackson-daemon-bench-") as tmp:
        folder = Path(tmp)
        nav = folder / "nav"
        nav.mkdir()
        map_yaml = _maze_map(folder)
        nav_args = ["--lidar", "LIDAR", "--map", str(map_yaml), f"--start={START}"]
        cpus = []
        for i in range(1 if quick else NAV_RUNS):
            (nav / str(i)).mkdir()
            cpus.append(daemon_run("maze", [*nav_args, f"--goal={GOAL}"], nav / str(i)))
        nav_cpu = _median_run(cpus)
        results = _results("navigating", nav_cpu, NAV_SHARE_TARGET, loop_us)
        results.append(_disk(nav_cpu, loop_us))
        results += daemon_latency.measure(
            folder, [*nav_args, f"--goal={GOAL}"], loop_us, daemon_run
        )
        if not quick:
            square = folder / "square"
            square.mkdir()
            sq_cpu = daemon_run("square_room", ["--mission", "square"], square)
            results += _results("square", sq_cpu, SQUARE_SHARE_TARGET, loop_us)
            # the same square at the firmware's top telemetry rate: the share 10 times the
            # 20 Hz one at most (linear in the rate), each frame no dearer than at 20 Hz
            fast = folder / "square_200hz"
            fast.mkdir()
            config = _config_at(folder, FAST_HZ)
            fast_cpu = daemon_run(
                "square_room", ["--mission", "square", "--config", str(config)], fast
            )
            results += _results(
                f"square_{FAST_HZ}Hz", fast_cpu, SQUARE_SHARE_TARGET * FAST_HZ / TELEMETRY_HZ,
                loop_us, FAST_HZ,
            )  # fmt: skip
            fast_us = float(fast_cpu["frame_us"]["median"])
            slow_us = float(sq_cpu["frame_us"]["median"])
            results.append(
                BenchResult(
                    f"daemon.frame_cost_{FAST_HZ}Hz_over_20Hz",
                    fast_us / slow_us,
                    "x the 20 Hz frame's CPU",
                    LINEAR_TARGET,
                    "lower",
                    f"the same square at 20 Hz telemetry in the same run: the daemon thread's "
                    f"median CPU per frame at {FAST_HZ} Hz over it at 20 Hz (linear in the rate "
                    f"is 1; a cost that grows with the frames in a window, above 1)",
                    fast_us / 1e3,
                    "ms",
                    slow_us / 1e3,
                    loop_us,
                )
            )
    return results
