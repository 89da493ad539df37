"""Memory over a long run: the resident memory of ``jackson daemon`` and ``jackson sim`` while
the navigation service serves goal after goal, recording on (``jackson bench`` suite ``soak``).

The soak is a patrol (:mod:`jackson.experiments.patrol`, docs/patrol.md): both processes run as
users run them (the daemon in service mode on the twin's pty, lockstep, the twin's RPLIDAR in
its densest mode, a map of the floor, recording split per goal under its budget); one daemon
process takes random goals, cancels, preemptions and teleop bursts on the office floor while
obstacles drop and leave, until the robot's clock reaches the soak's length. Every two wall
seconds the patrol reads each process's resident set (``VmRSS`` of ``/proc/PID/status``) and
the robot's time (``jackson status``). The figure is the slope of a least-squares line through
the resident set against the robot's time after the first hour of the soak, or its first half
when shorter (start-up, the first split's snapshot and the allocator's arenas), in MB per
robot-hour: flat memory is 0, a list that keeps every 20 Hz sample
grows by megabytes. Target: 1 MB per robot-hour, each process.

``jackson bench`` soaks 30 robot-minutes (``--quick``: 5). For the 8-hour soak: ``make soak``
(``jackson patrol --robot-hours 8``), or ``python -m jackson.bench.soak --robot-hours 8 --out
build/soak``, which writes ``rss.csv``, ``rss.png`` and the figures at the end.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from jackson.common.bench import BenchResult, reference_loop_us

GROWTH_TARGET_MB_H = 1.0
WARM_UP_S = 3600.0  # [s] of robot time judged as start-up: the "after the first hour"


def warm_up_s(span_s: float) -> float:
    """The robot time left out of the slope: the first hour, or the first half of a shorter
    soak (the first split's snapshot, the bag's buffers and the allocator's arenas settle in
    the first ten robot-minutes: 110 -> 150-180 MB)."""
    return min(WARM_UP_S, 0.5 * span_s)


SAMPLE_S = 2.0  # [s] of wall time between samples


@dataclass(frozen=True)
class Soak:
    """A soak's samples: robot time [s], daemon and twin resident set [MB], per wall second."""

    robot_s: list[float]
    daemon_mb: list[float]
    twin_mb: list[float]
    summary: dict[str, Any] = field(default_factory=dict)  # the patrol's (summary.json)

    def growth_mb_per_h(self, which: str) -> float:
        """The slope of ``which`` (``daemon`` or ``twin``) against robot time after the warm-up
        [MB per robot-hour]."""
        t = np.asarray(self.robot_s)
        mb = np.asarray(self.daemon_mb if which == "daemon" else self.twin_mb)
        keep = t >= warm_up_s(t[-1])
        if np.count_nonzero(keep) < 3 or np.ptp(t[keep]) <= 0.0:
            raise RuntimeError("soak: too few samples after the warm-up to fit a slope")
        slope = float(np.polyfit(t[keep], mb[keep], 1)[0])
        return slope * 3600.0


def soak(robot_s: float, out: Path, progress: bool = True) -> Soak:
    """A patrol of ``robot_s`` of robot time on the office floor; ``out/rss.csv`` at its end.

    Raises
    ------
    RuntimeError
        The patrol failed (a process ended early, the daemon stopped answering).
    """
    from jackson.experiments.patrol import Patrol, PatrolSpec

    spec = PatrolSpec("office_floor", out, seed=3, robot_hours=robot_s / 3600.0, sample_s=SAMPLE_S)
    result = Patrol(spec).run()
    if result.failure is not None:
        raise RuntimeError(f"soak: {result.failure}")
    samples = Soak(
        [x.robot_s for x in result.samples],
        [x.daemon_rss_mb for x in result.samples],
        [x.twin_rss_mb for x in result.samples],
        json.loads((out / "summary.json").read_text()),
    )
    with (out / "rss.csv").open("w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["robot_s", "daemon_rss_mb", "twin_rss_mb"])
        for row in zip(samples.robot_s, samples.daemon_mb, samples.twin_mb, strict=True):
            writer.writerow([f"{row[0]:.2f}", f"{row[1]:.2f}", f"{row[2]:.2f}"])
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
    ax.axvline(warm_up_s(s.robot_s[-1]) / 3600.0, color="0.6", ls=":", lw=1, label="end of warm-up")
    ax.set_xlabel("robot time [h]")
    ax.set_ylabel("resident set [MB]")
    ax.set_title("Memory while the navigation service serves goals, recording on")
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
            f"over {hours * 60:.0f} robot-minutes of one navigation service's patrol of the "
            f"office floor (goals, cancels, preemptions, teleop), recording on, after the "
            f"first hour (or the first half of a shorter soak)",
            series[-1],
            "MB at the end",
            series[0],
            loop_us,
        )
        for which, series in (("daemon", s.daemon_mb), ("twin", s.twin_mb))
    ] + patrol_figures(s.summary, loop_us)


def _fraction(text: str) -> tuple[float, int]:
    """``"57/57"`` as (1.0, 57); (nan, 0) for none sent."""
    done, sent = (int(x) for x in text.split("/"))
    return (done / sent if sent else math.nan), sent


def patrol_figures(summary: dict[str, Any], loop_us: float) -> list[BenchResult]:
    """The patrol's own targets (issue: a robot that serves all day): every reachable goal
    reached on the ground truth, every unreachable one answered within 15 s of MCU time, no
    contact, the recordings within their budget."""
    reached, sent = _fraction(summary["reachable_reached"])
    answered, asked = _fraction(summary["unreachable_answered"])
    disk = summary.get("disk_mb") or {}
    where = f"one daemon process's patrol of the office floor, {summary['steps']} steps"
    return [
        BenchResult("soak.goals_reached", reached, f"of {sent} reachable goals (ground truth)",
                    1.0, "higher", where, reached * sent, "goals", sent, loop_us),
        BenchResult("soak.unreachable_answered", answered, f"of {asked} unreachable goals",
                    1.0, "higher", where, summary.get("unreachable_answer_max_s"),
                    "s of MCU time at most", 15.0, loop_us),
        BenchResult("soak.contacts", float(summary["contacts"] or 0), "contacts", 0.0, "lower",
                    where, None, "", None, loop_us),
        BenchResult("soak.recordings_of_budget",
                    float(disk.get("max", 0.0)) / float(disk.get("budget", 1.0)),
                    "of the recording budget at most", 1.0, "lower", where,
                    disk.get("max"), "MB", disk.get("budget"), loop_us),
    ]  # fmt: skip


def run(quick: bool = False) -> list[BenchResult]:
    """Soak 30 robot-minutes (quick: 5)."""
    loop_us = reference_loop_us()
    with tempfile.TemporaryDirectory(prefix="jackson-soak-") as tmp:
        s = soak((5.0 if quick else 30.0) * 60.0, Path(tmp), progress=False)
    return figures(s, loop_us)


def main(argv: list[str] | None = None) -> int:
    """``python -m jackson.bench.soak``: a soak of any length, its CSV, plot and figures."""
    parser = argparse.ArgumentParser(
        prog="python -m jackson.bench.soak",
        description="Patrol the twin's office floor with the navigation service, recording on, "
        "and follow the resident memory of jackson daemon and jackson sim.",
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
