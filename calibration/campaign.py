"""``jackson campaign``: many trials on the twin in parallel, and a report like the paper's.

Each trial runs in a worker process (the twin in lockstep over a pty and the real host, see
:mod:`jackson.calibration.trial`) with its own run folder and seed ``seed + i``, so a campaign
is deterministic for a seed whatever the number of workers. The report folder holds per-run
metrics (``runs.csv``, ``runs.json``), ``summary.md`` with the paper's physical and Isaac Sim
figures beside ours, the consistency of the EKF's covariance against the twin's ground truth
(:mod:`jackson.calibration.consistency`), and plots (``trajectories.png``, ``closure.png``,
``nees.png``).
"""

from __future__ import annotations

import csv
import json
import multiprocessing as mp
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Any

from jackson.calibration.consistency import run_consistency
from jackson.calibration.report import write_report
from jackson.calibration.trial import TrialSpec, run_trial


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
) -> list[dict[str, Any]]:
    """Run ``trials`` trials of ``mission`` and write the report folder ``out``."""
    from rich.progress import Progress

    world = world or ("square_room" if mission == "square" else "open_floor")
    specs = [
        TrialSpec(mission, i, seed + i, robot, world, out / "runs" / f"R{i + 1:02d}", config)
        for i in range(trials)
    ]
    results: list[dict[str, Any]] = []
    wall0 = time.perf_counter()
    ctx = mp.get_context("forkserver")
    with (
        Progress(disable=not progress, transient=True) as bar,
        ProcessPoolExecutor(max_workers=workers, mp_context=ctx) as pool,
    ):
        task = bar.add_task(f"{mission} x{trials}", total=trials)
        futures = [pool.submit(run_scored_trial, s) for s in specs]
        for fut in as_completed(futures):
            results.append(fut.result())
            bar.advance(task)
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
    """One trial (:func:`jackson.calibration.trial.run_trial`) with the NEES figures added.

    The covariance's consistency (:meth:`jackson.calibration.consistency.RunConsistency.metrics`:
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
    keys = list(results[0]) if results else []
    with (out / "runs.csv").open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        for r in results:
            w.writerow(r)
