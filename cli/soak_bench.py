"""Memory over a long run: the resident memory of ``jackson daemon`` and ``jackson sim`` while
the robot navigates the maze back and forth, recording on (``jackson bench`` suite ``soak``).

Both processes run as users run them (the daemon on the twin's pty, lockstep, the twin's
RPLIDAR in its densest mode, a map of the maze); the daemon is given goals at the maze's two
ends in turn, as many as the soak needs, and stopped with SIGTERM (it brakes, closes its run
folder) once the robot's clock reaches the soak's length. Once per wall second the soak reads
each process's resident set (``VmRSS`` of ``/proc/PID/status``) and the robot's time (the last
row of the run's ``ekf.csv``, flushed once per second of MCU time). The figure is the slope of
a least-squares line through the resident set against the robot's time after the first tenth
of the soak (start-up, the first map and plan), in MB per robot-hour: flat memory is 0, a list
that keeps every 20 Hz sample grows by megabytes. Target: 1 MB per robot-hour, each process.

``jackson bench`` soaks 30 robot-minutes (``--quick``: 5). For the 8-hour soak::

    .venv/bin/python -m jackson.soak_bench --robot-hours 8 --out build/soak

which writes ``rss.csv`` as it goes (a soak cut short keeps its samples), ``rss.png`` and the
figures at the end.
"""

from __future__ import annotations

import argparse
import csv
import math
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from jackson.common.bench import BenchResult, reference_loop_us
from jackson.daemon_bench import GOAL, START, _jackson, _maze_map, _ports

GROWTH_TARGET_MB_H = 1.0
WARM_UP_FRACTION = 0.1
LEG_S = 6.0  # robot seconds a leg takes at least (the maze's route takes about 8 s)
SAMPLE_S = 1.0


@dataclass(frozen=True)
class Soak:
    """A soak's samples: robot time [s], daemon and twin resident set [MB], per wall second."""

    robot_s: list[float]
    daemon_mb: list[float]
    twin_mb: list[float]

    def growth_mb_per_h(self, which: str) -> float:
        """The slope of ``which`` (``daemon`` or ``twin``) against robot time after the warm-up
        [MB per robot-hour]."""
        t = np.asarray(self.robot_s)
        mb = np.asarray(self.daemon_mb if which == "daemon" else self.twin_mb)
        keep = t >= WARM_UP_FRACTION * t[-1]
        if np.count_nonzero(keep) < 3 or np.ptp(t[keep]) <= 0.0:
            raise RuntimeError("soak: too few samples after the warm-up to fit a slope")
        slope = float(np.polyfit(t[keep], mb[keep], 1)[0])
        return slope * 3600.0


def rss_mb(pid: int) -> float:
    """The resident set of process ``pid`` [MB] (``VmRSS``; NaN once it has ended)."""
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return math.nan


def robot_time_s(ekf_csv: Path) -> float | None:
    """The MCU time of the last whole row of a growing ``ekf.csv`` (None before one)."""
    try:
        with ekf_csv.open("rb") as f:
            f.seek(0, 2)
            size = f.tell()
            f.seek(max(0, size - 4096))
            tail = f.read().decode(errors="replace")
    except OSError:
        return None
    for line in reversed(tail.splitlines()[:-1] if not tail.endswith("\n") else tail.splitlines()):
        head = line.split(",", 1)[0]
        try:
            return float(head)
        except ValueError:
            continue
    return None


def soak(robot_s: float, out: Path, progress: bool = True) -> Soak:
    """Navigate the maze back and forth for ``robot_s`` of robot time; ``out/rss.csv`` as it goes.

    Raises
    ------
    RuntimeError
        A process ended early or the robot's clock stopped.
    """
    from rich.progress import Progress

    out.mkdir(parents=True, exist_ok=True)
    map_yaml = _maze_map(out)
    legs = math.ceil(robot_s / LEG_S) + 2
    goals = [f"--goal={GOAL if i % 2 == 0 else START}" for i in range(legs)]
    sim = subprocess.Popen(
        [_jackson(), "sim", "--world", "maze"],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
    )
    daemon: subprocess.Popen[bytes] | None = None
    samples = Soak([], [], [])
    run = out / "run"
    try:
        ports = _ports(sim, lidar=True)
        argv = [_jackson(), "daemon", "--port", ports["serial"], "--i2c", ports["i2c"]]
        argv += ["--lidar", ports["lidar"], "--map", str(map_yaml), f"--start={START}", *goals]
        argv += ["--run-dir", str(run), "--mission-timeout", str(robot_s + 600.0)]
        daemon = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        bar = Progress(disable=not progress)
        task = bar.add_task("soak (robot seconds)", total=robot_s)
        bar.start()
        last_t, last_change = -1.0, time.monotonic()
        with (out / "rss.csv").open("w", newline="") as f:
            writer = csv.writer(f)
            writer.writerow(["robot_s", "daemon_rss_mb", "twin_rss_mb"])
            while True:
                time.sleep(SAMPLE_S)  # the sampling period of a measurement, not a wait
                if daemon.poll() is not None:
                    err = daemon.stderr.read().decode() if daemon.stderr else ""
                    raise RuntimeError(f"soak: jackson daemon ended early: {err.strip()[-500:]}")
                t = robot_time_s(run / "ekf.csv")
                if t is None:
                    continue
                if t != last_t:
                    last_t, last_change = t, time.monotonic()
                elif time.monotonic() - last_change > 60.0:
                    raise RuntimeError("soak: the robot's clock stopped for 60 s")
                row = (t, rss_mb(daemon.pid), rss_mb(sim.pid))
                writer.writerow([f"{row[0]:.2f}", f"{row[1]:.2f}", f"{row[2]:.2f}"])
                f.flush()
                samples.robot_s.append(row[0])
                samples.daemon_mb.append(row[1])
                samples.twin_mb.append(row[2])
                bar.update(task, completed=min(t, robot_s))
                if t >= robot_s:
                    break
        bar.stop()
    finally:
        if daemon is not None and daemon.poll() is None:
            daemon.send_signal(signal.SIGTERM)  # (SIGINT is ignored by background jobs)
            try:
                daemon.wait(timeout=60)
            except subprocess.TimeoutExpired:
                daemon.kill()
        sim.terminate()
        sim.wait(timeout=30)
    return samples


def plot(s: Soak, path: Path) -> None:
    """The two resident sets against robot time, the fitted lines over the judged span."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t_h = np.asarray(s.robot_s) / 3600.0
    fig, ax = plt.subplots(figsize=(7, 4), layout="constrained")
    for which, series in (("daemon", s.daemon_mb), ("twin", s.twin_mb)):
        name = "daemon" if which == "daemon" else "sim (the twin)"
        ax.plot(t_h, series, lw=1, label=f"jackson {name} ({s.growth_mb_per_h(which):+.2f} MB/h)")
    ax.axvline(WARM_UP_FRACTION * t_h[-1], color="0.6", ls=":", lw=1, label="end of warm-up")
    ax.set_xlabel("robot time [h]")
    ax.set_ylabel("resident set [MB]")
    ax.set_title("Memory while navigating the maze back and forth, recording on")
    ax.legend(loc="lower right")
    fig.savefig(path, dpi=120)
    plt.close(fig)


def figures(s: Soak, loop_us: float) -> list[BenchResult]:
    """The soak's figures: each process's growth in MB per robot-hour."""
    hours = s.robot_s[-1] / 3600.0
    return [
        BenchResult(
            f"soak.{which}_rss_growth",
            s.growth_mb_per_h(which),
            "MB per robot-hour",
            GROWTH_TARGET_MB_H,
            "lower",
            f"the robot's clock: the least-squares slope of the {which} process's resident set "
            f"over {hours * 60:.0f} robot-minutes of navigating the maze back and forth, "
            f"recording on, after the first tenth",
            series[-1],
            "MB at the end",
            series[0],
            loop_us,
        )
        for which, series in (("daemon", s.daemon_mb), ("twin", s.twin_mb))
    ]


def run(quick: bool = False) -> list[BenchResult]:
    """Soak 30 robot-minutes (quick: 5)."""
    loop_us = reference_loop_us()
    with tempfile.TemporaryDirectory(prefix="jackson-soak-") as tmp:
        s = soak((5.0 if quick else 30.0) * 60.0, Path(tmp), progress=False)
    return figures(s, loop_us)


def main(argv: list[str] | None = None) -> int:
    """``python -m jackson.soak_bench``: a soak of any length, its CSV, plot and figures."""
    parser = argparse.ArgumentParser(
        prog="python -m jackson.soak_bench",
        description="Navigate the twin's maze back and forth with recording on and follow the "
        "resident memory of jackson daemon and jackson sim.",
    )
    parser.add_argument("--robot-hours", type=float, default=8.0, help="soak length (8)")
    parser.add_argument("--out", type=Path, required=True, help="folder for rss.csv, rss.png")
    args = parser.parse_args(argv)
    if not 0.01 <= args.robot_hours <= 1000.0:
        parser.error(f"--robot-hours must be in [0.01, 1000], got {args.robot_hours}")
    loop_us = reference_loop_us()
    try:
        s = soak(args.robot_hours * 3600.0, args.out)
    except RuntimeError as e:
        print(f"soak: {e}", file=sys.stderr)
        return 1
    plot(s, args.out / "rss.png")
    for r in figures(s, loop_us):
        print(
            f"{r.name}: {r.value:+.3f} {r.unit} (target <= {r.target:g}; end {r.absolute:.1f} MB)"
        )
    print(f"wrote {args.out / 'rss.csv'} and {args.out / 'rss.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
