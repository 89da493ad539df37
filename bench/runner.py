"""``jackson bench``: run the suites of :data:`jackson.bench.suites.SUITES`.

Each suite returns its figures (:class:`jackson.common.bench.BenchResult`); every figure is a
ratio measured side by side in the same run (:mod:`jackson.common.bench`). The runner gives
each figure the machine's reference-loop time of the suite's run where the suite has not set
one; :mod:`jackson.bench.report` prints the table and writes the JSON file.
"""

from __future__ import annotations

import dataclasses

from jackson.bench.suites import SUITES
from jackson.common.bench import BenchResult, reference_loop_us


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
    results = SUITES[name](quick)
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
