"""``jackson bench``'s output: the table on screen and build/bench.json.

The JSON file is a list of objects, one per figure: ``name``, ``value`` (the ratio), ``unit``,
``target``, ``better``, ``reference`` (what the ratio is against), ``absolute`` and
``absolute_unit`` (our own time), ``reference_absolute`` (the reference's, same unit) and
``machine_loop_us`` (the machine's reference loop in the same run).
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

from jackson.common.bench import REFERENCE_LOOP, BenchResult


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
