"""``jackson bench`` suite ``sil``: what a user gets from software-in-the-loop, ``jackson run``.

Runs the two commands a newcomer runs (``make demo``), each as its own process, as a user runs
them: ``jackson run square`` (the twin and the host daemon over a pty drive the paper's 1 m
square) and ``jackson run maze`` (the host maps the maze, then navigates it). Figures:

- the real-time factor inside the run: the twin's simulated seconds over the run's wall seconds
  (the run's ``metrics.json``: ``sim_s / wall_s``); its reference is the robot's own clock, so
  it is this machine's speed (the reference loop beside it says how fast the machine was).
  Targets: the square 100x, the maze navigation 30x;
- what the whole command adds to its runs' wall time: start-up (the interpreter, the imports),
  the report, the plots and the CSVs. For the square, whose run lasts about a second at the
  target, in seconds (target: at most 1.5 s beyond the run; a ratio to a run that short says
  more about the run than about the command); for the maze, as a ratio to its mapping and
  navigation runs together (target 1.5x).
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from jackson.common.bench import BenchResult, reference_loop_us

SQUARE_RTF_TARGET = 100.0
MAZE_RTF_TARGET = 30.0
COMMAND_OVER_RUN_TARGET = 1.5
COMMAND_OVERHEAD_S_TARGET = 1.5  # [s] beyond the run, for a command whose run is short
TIMEOUT_S = 900.0


def _jackson() -> str:
    return str(Path(sys.executable).parent / "jackson")


def timed_run(mission: str, out: Path) -> float:
    """``jackson run MISSION --out OUT`` in its own process; its wall time [s]."""
    t0 = time.perf_counter()
    done = subprocess.run(
        [_jackson(), "run", mission, "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=TIMEOUT_S,
    )
    wall = time.perf_counter() - t0
    if done.returncode != 0:
        raise RuntimeError(f"sil bench: jackson run {mission} failed: {done.stdout}{done.stderr}")
    return wall


def figures(
    mission: str,
    command_s: float,
    runs: list[dict[str, Any]],
    rtf_target: float,
    loop_us: float,
    judged: str = "",
    overhead_in_seconds: bool = False,
) -> list[BenchResult]:
    """The suite's two figures for one command from its wall time and its runs' metrics.

    Parameters
    ----------
    mission : str
        ``square`` or ``maze``.
    command_s : float
        The command's wall time [s].
    runs : list of dict
        The ``metrics.json`` of each run the command made (``sim_s``, ``wall_s``).
    rtf_target : float
        The real-time factor the judged run must reach.
    loop_us : float
        The reference loop in the same run [us].
    judged : str
        The name of the run whose real-time factor is judged (its ``mission``-less label; the
        last run by default).
    overhead_in_seconds : bool
        Judge what the command adds to its runs in seconds (``sil.MISSION_command_overhead_s``)
        instead of as a ratio to them (``sil.MISSION_command_over_run``).

    Returns
    -------
    list of BenchResult
    """
    last = runs[-1]
    run_wall = sum(float(r["wall_s"]) for r in runs)
    label = f"{mission}{'_' + judged if judged else ''}"
    if overhead_in_seconds:
        name, value, unit, target = (
            "overhead_s",
            command_s - run_wall,
            "s beyond",
            COMMAND_OVERHEAD_S_TARGET,
        )
        how = "less"
    else:
        name, value, unit, target = "over_run", command_s / run_wall, "x", COMMAND_OVER_RUN_TARGET
        how = "over"
    return [
        BenchResult(
            f"sil.{label}_real_time_factor",
            float(last["sim_s"]) / float(last["wall_s"]),
            "x real time",
            rtf_target,
            "higher",
            f"the robot's clock: the twin's simulated time over the run's wall time inside "
            f"jackson run {mission}",
            float(last["wall_s"]),
            "s (wall; reference: simulated time)",
            float(last["sim_s"]),
            loop_us,
        ),
        BenchResult(
            f"sil.{mission}_command_{name}",
            value,
            f"{unit} the run's wall time",
            target,
            "lower",
            f"the runs inside the command: jackson run {mission}'s whole wall time (start-up, "
            f"report, plots, CSVs) {how} the wall time of its {len(runs)} run(s)",
            command_s,
            "s",
            run_wall,
            loop_us,
        ),
    ]


def run(quick: bool = False) -> list[BenchResult]:
    """``jackson run square`` and (unless quick) ``jackson run maze``, once each."""
    loop_us = reference_loop_us()
    with tempfile.TemporaryDirectory(prefix="jackson-sil-bench-") as tmp:
        out = Path(tmp)
        wall = timed_run("square", out / "square")
        square = json.loads((out / "square" / "metrics.json").read_text())
        results = figures(
            "square", wall, [square], SQUARE_RTF_TARGET, loop_us, overhead_in_seconds=True
        )
        if not quick:
            wall = timed_run("maze", out / "maze")
            runs = [
                json.loads((out / "maze" / r / "metrics.json").read_text()) for r in ("map", "nav")
            ]
            results += figures("maze", wall, runs, MAZE_RTF_TARGET, loop_us, judged="nav")
    return results
