"""``jackson campaign``: many trials on the twin in parallel, and a report like the paper's.

Each trial runs in a worker process (the twin in lockstep over a pty and the real host, see
:mod:`jackson.experiments.trial`) with its own run folder and seed ``seed + i``, so a campaign
is deterministic for a seed whatever the number of workers. The report folder holds per-run
metrics (``runs.csv``, ``runs.json``), ``summary.md`` and ``summary.json`` with the paper's
physical and Isaac Sim figures beside ours, the consistency of the EKF's covariance against the
twin's ground truth (:mod:`jackson.experiments.consistency`), and figures (``trajectories``,
``closure``, ``nees``; PNG and PDF), see :mod:`jackson.experiments.report`.

Progress goes to stderr (:class:`TrialProgress`): a bar on a terminal, one line per finished
trial otherwise (a log file, CI), e.g. ``[3/10] figure8 seed 2 (R03): completed, GT closure
9.1 cm, EKF closure 2.6 cm``.
"""

from __future__ import annotations

import csv
import json
import sys
import time
from pathlib import Path
from types import TracebackType
from typing import Any, TextIO

from jackson.experiments.cluster import map_trials
from jackson.experiments.consistency import run_consistency
from jackson.experiments.report import write_report
from jackson.experiments.trial import TrialSpec, run_trial


class TrialProgress:
    """A campaign's progress on stderr: a rich bar on a terminal, one line per trial otherwise.

    Off a terminal (a log file, a pipe, CI) a bar shows nothing useful, so each finished trial
    prints ``[k/N] <text>`` on its own line, flushed at once.

    Parameters
    ----------
    description : str
        The bar's label (``"figure8 x10"``).
    total : int
        Number of trials.
    enabled : bool
        False: nothing at all.
    stream : TextIO or None
        Where to write; ``sys.stderr`` (at construction) when None.
    """

    def __init__(
        self, description: str, total: int, *, enabled: bool = True, stream: TextIO | None = None
    ) -> None:
        self.stream = stream if stream is not None else sys.stderr
        self.total = total
        self.done = 0
        self.enabled = enabled
        self.tty = enabled and self.stream.isatty()
        self._bar: Any = None
        self._task: Any = None
        self._description = description

    def __enter__(self) -> TrialProgress:
        if self.tty:
            from rich.console import Console
            from rich.progress import Progress

            self._bar = Progress(console=Console(file=self.stream), transient=True)
            self._bar.__enter__()
            self._task = self._bar.add_task(self._description, total=self.total)
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        if self._bar is not None:
            self._bar.__exit__(exc_type, exc, tb)

    def advance(self, text: str) -> None:
        """One more trial done: the bar moves, or ``[k/N] text`` is printed.

        Parameters
        ----------
        text : str
            What the trial gave (:func:`trial_line`).
        """
        self.done += 1
        if self._bar is not None:
            self._bar.advance(self._task)
        elif self.enabled:
            print(f"[{self.done}/{self.total}] {text}", file=self.stream, flush=True)


def trial_line(result: dict[str, Any]) -> str:
    """One trial's progress text: mission, seed, run folder, outcome and closures.

    Parameters
    ----------
    result : dict
        The trial's metrics (:func:`run_scored_trial`).

    Returns
    -------
    str
        E.g. ``"figure8 seed 2 (R03): completed, GT closure 9.1 cm, EKF closure 2.6 cm"``.
    """
    head = f"{result.get('mission', '?')} seed {result.get('seed', '?')}"
    if "trial" in result:
        head += f" (R{int(result['trial']) + 1:02d})"
    parts = ["completed" if result.get("completed") else "not completed"]
    if result.get("stalled"):
        parts = ["lockstep stalled twice (the machine's failure, not the robot's)"]
    elif result.get("stall_retried"):
        parts.append("retried after a lockstep stall")
    for key, label in (("gt_closure_cm", "GT closure"), ("ekf_closure_cm", "EKF closure")):
        if isinstance(result.get(key), (int, float)):
            parts.append(f"{label} {result[key]:.1f} cm")
    return f"{head}: {', '.join(parts)}"


def run_campaign(
    mission: str,
    trials: int,
    out: Path,
    *,
    robot: str = "jackson_physical",
    world: str | None = None,
    seed: int = 0,
    workers: int = 2,
    config: Path | None = None,
    progress: bool = True,
    cluster: str | None = None,
) -> list[dict[str, Any]]:
    """Run ``trials`` trials of ``mission`` and write the report folder ``out``.

    Parameters
    ----------
    mission : str
        "square" or "figure8".
    trials : int
        Number of trials; trial i has seed ``seed + i`` and run folder ``out/runs/R<i+1>``.
    out : Path
        The report folder.
    robot : str
        The twin's robot (name or YAML).
    world : str or None
        The twin's world; None: ``square_room`` for the square, ``open_floor`` otherwise.
    seed : int
        Seed of the first trial.
    workers : int
        Worker processes.
    config : Path or None
        Host configuration YAML (None: the packaged defaults).
    progress : bool
        Progress on stderr (:class:`TrialProgress`).
    cluster : str or None
        None: the local pool; ``local``, ``auto`` or ``ray://HOST:PORT``: a Ray cluster
        (:func:`jackson.experiments.cluster.map_trials`; ``out`` and ``config`` are made
        absolute, every node must see them).

    Returns
    -------
    list of dict
        Per-trial metrics in trial order.
    """
    world = world or ("square_room" if mission == "square" else "open_floor")
    if cluster is not None:
        out, config = out.absolute(), config.absolute() if config is not None else None
        out.mkdir(parents=True, exist_ok=True)
    specs = [
        TrialSpec(mission, i, seed + i, robot, world, out / "runs" / f"R{i + 1:02d}", config)
        for i in range(trials)
    ]
    results: list[dict[str, Any]] = []
    wall0 = time.perf_counter()
    with TrialProgress(f"{mission} x{trials}", trials, enabled=progress) as bar:
        for _, result in map_trials(
            run_scored_trial, specs, workers=workers, cluster=cluster, folder=out
        ):
            results.append(result)
            bar.advance(trial_line(result))
    results.sort(key=lambda r: int(r["trial"]))
    wall = time.perf_counter() - wall0
    write_runs(out, results)
    write_report(
        out,
        mission,
        results,
        meta={
            "trials": trials,
            "robot": robot,
            "world": world,
            "seed": seed,
            "workers": workers,
            "wall_s": wall,
        },
    )
    return results


def run_scored_trial(spec: TrialSpec) -> dict[str, Any]:
    """One trial (:func:`jackson.experiments.trial.run_trial`) with the NEES figures added.

    The covariance's consistency (:meth:`jackson.experiments.consistency.RunConsistency.metrics`:
    ``nees_in_band_fraction``, ``nees_above_fraction``, ``nees_mean``,
    ``end_position_2sigma_cm``, ``end_error_covered``, ...) joins the trial's metrics, in the
    returned dict and in the run folder's ``metrics.json``.

    Parameters
    ----------
    spec : TrialSpec
        The trial.

    Returns
    -------
    dict
        The trial's metrics with the consistency figures.
    """
    result = run_trial(spec)
    if "nees_mean" not in result:  # the trial's own metrics may carry them already
        result.update(run_consistency(spec.out).metrics())
        (spec.out / "metrics.json").write_text(json.dumps(result, indent=2) + "\n")
    return result


def write_runs(out: Path, results: list[dict[str, Any]]) -> None:
    out.mkdir(parents=True, exist_ok=True)
    (out / "runs.json").write_text(json.dumps(results, indent=2) + "\n")
    # every run's columns, in the order they first appear: a run that failed has fewer
    # metrics than one that completed, and either may come first
    keys = list(dict.fromkeys(k for r in results for k in r))
    with (out / "runs.csv").open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys, restval="")
        w.writeheader()
        for r in results:
            w.writerow(r)
