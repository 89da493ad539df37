"""``jackson bench``: run every benchmark suite, print a table, write build/bench.json.

Each suite is a module with ``run(quick: bool) -> list[BenchResult]``. Every figure is a ratio
measured side by side in the same run (:mod:`jackson.common.bench`); the JSON file is a list of
objects, one per figure: ``name``, ``value`` (the ratio), ``unit``, ``target``, ``better``,
``reference`` (what the ratio is against), ``absolute`` and ``absolute_unit`` (our own time),
``reference_absolute`` (the reference's, same unit) and ``machine_loop_us`` (the machine's
reference loop in the same run). Later subsystems add their suites to :data:`SUITES`.
"""

from __future__ import annotations

import dataclasses
import importlib
import json
from collections.abc import Callable
from pathlib import Path

from jackson.common.bench import REFERENCE_LOOP, reference_loop_us
from jackson.common.bench import BenchResult as BenchResult  # re-exported for the suites

SUITES: dict[str, str] = {
    "protocol": "jackson.protocol.bench",
    "firmware": "jackson.firmware_bench",
    "twin": "jackson.sim.bench",
    "lidar": "jackson.sim.bench_lidar",
    "lockstep": "jackson.lockstep_bench",
    "host": "jackson.host_bench",
    "daemon": "jackson.daemon_bench",
    "sil": "jackson.sil_bench",
    "soak": "jackson.soak_bench",
    "campaign": "jackson.experiments.bench",
    "stage3": "jackson.experiments.bench_stage3",
    "ros": "jackson.ros_bench",
}
"""Suite name -> module with a ``run(quick)`` function, in the order they run."""


def run_suite(name: str, quick: bool) -> list[BenchResult]:
    """Run one suite; give its figures the machine's reference-loop time where they have none.

    The loop is timed just before and just after the suite, and the faster time kept.

    Parameters
    ----------
    name : str
        A key of :data:`SUITES`.
    quick : bool
        Smaller workloads.

    Returns
    -------
    list[BenchResult]
        The suite's figures, each with :attr:`BenchResult.machine_loop_us` set.
    """
    before = reference_loop_us()
    run: Callable[[bool], list[BenchResult]] = importlib.import_module(SUITES[name]).run
    results = run(quick)
    loop_us = min(before, reference_loop_us())
    return [
        r if r.machine_loop_us is not None else dataclasses.replace(r, machine_loop_us=loop_us)
        for r in results
    ]


def run_all(quick: bool = False, only: list[str] | None = None) -> list[BenchResult]:
    """Run the named suites (all by default) with a progress bar.

    Parameters
    ----------
    quick : bool
        Smaller workloads (seconds, noisier).
    only : list[str] or None
        Suite names to run; None runs all of :data:`SUITES` in order.

    Returns
    -------
    list[BenchResult]
        Every figure of every suite run.
    """
    from rich.progress import Progress

    names = only or list(SUITES)
    results: list[BenchResult] = []
    with Progress(transient=True) as progress:
        task = progress.add_task("benchmarks", total=len(names))
        for name in names:
            progress.update(task, description=f"bench {name}")
            results.extend(run_suite(name, quick))
            progress.advance(task)
    return results


def write_json(results: list[BenchResult], path: Path) -> None:
    """Write the figures as a JSON list of objects, one per figure.

    Parameters
    ----------
    results : list[BenchResult]
        The figures.
    path : Path
        The JSON file (its folder is created).
    """
    path.parent.mkdir(parents=True, exist_ok=True)
    records = [dataclasses.asdict(r) for r in results]
    path.write_text(json.dumps(records, indent=2) + "\n", encoding="utf-8")


def _num(x: float | None) -> str:
    return "" if x is None else f"{x:.4g}"


def print_table(results: list[BenchResult]) -> None:
    """Print the ratios against their targets, whether each is met, and the absolute times.

    Parameters
    ----------
    results : list[BenchResult]
        The figures.
    """
    from rich.console import Console
    from rich.table import Table

    table = Table(title="jackson bench: ratios measured side by side in the same run")
    for col in ("figure", "ratio", "target", "met", "unit", "ours", "reference"):
        table.add_column(col, justify="right" if col in ("ratio", "target") else "left")
    for r in results:
        sign = ">=" if r.better == "higher" else "<="
        table.add_row(
            r.name,
            f"{r.value:.4g}",
            f"{sign} {r.target:.4g}" if r.target is not None else "(info)",
            ("yes" if r.met else "NO") if r.target is not None else "-",
            r.unit,
            f"{_num(r.absolute)} {r.absolute_unit}".strip(),
            f"{_num(r.reference_absolute)} {r.absolute_unit}".strip()
            if r.reference_absolute is not None
            else "",
        )
    console = Console()
    if not console.is_terminal:
        console = Console(width=180)
    console.print(table)
    loops = [r.machine_loop_us for r in results if r.machine_loop_us is not None]
    judged = [r for r in results if r.target is not None]
    met = sum(r.met for r in judged)
    if loops:
        console.print(
            f"machine: {REFERENCE_LOOP} took {min(loops):.1f}-{max(loops):.1f} us in this run"
        )
    console.print(f"targets met: {met}/{len(judged)}")
