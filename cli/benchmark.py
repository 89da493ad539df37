"""``jackson bench``: run every benchmark suite, print a table, write build/bench.json.

Each suite is a module with ``run(quick: bool) -> list[BenchResult]``. The JSON file
is a list of ``{"name", "value", "unit", "target", "better"}`` objects, one per figure;
later subsystems add their suites to :data:`SUITES`.
"""

from __future__ import annotations

import importlib
import json
from collections.abc import Callable
from dataclasses import asdict
from pathlib import Path

from jackson.common.bench import BenchResult as BenchResult  # re-exported for the suites

SUITES: dict[str, str] = {
    "protocol": "jackson.protocol.bench",
    "firmware": "jackson.firmware_bench",
    "twin": "jackson.sim.bench",
    "lidar": "jackson.sim.bench_lidar",
    "lockstep": "jackson.lockstep_bench",
    "host": "jackson.host_bench",
    "campaign": "jackson.calibration.bench",
    "stage3": "jackson.calibration.bench_stage3",
    "ros": "jackson.ros_bench",
}
"""Suite name -> module with a ``run(quick)`` function, in the order they run."""


def run_all(quick: bool = False, only: list[str] | None = None) -> list[BenchResult]:
    """Run the named suites (all by default) with a progress bar."""
    from rich.progress import Progress

    names = only or list(SUITES)
    results: list[BenchResult] = []
    with Progress(transient=True) as progress:
        task = progress.add_task("benchmarks", total=len(names))
        for name in names:
            progress.update(task, description=f"bench {name}")
            run: Callable[[bool], list[BenchResult]] = importlib.import_module(SUITES[name]).run
            results.extend(run(quick))
            progress.advance(task)
    return results


def write_json(results: list[BenchResult], path: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps([asdict(r) for r in results], indent=2) + "\n", encoding="utf-8")


def print_table(results: list[BenchResult]) -> None:
    from rich.console import Console
    from rich.table import Table

    table = Table(title="jackson bench")
    for col in ("figure", "value", "unit", "target", "met"):
        table.add_column(col, justify="right" if col in ("value", "target") else "left")
    for r in results:
        sign = ">=" if r.better == "higher" else "<="
        table.add_row(
            r.name, f"{r.value:.4g}", r.unit, f"{sign} {r.target:.4g}", "yes" if r.met else "NO"
        )
    Console().print(table)
