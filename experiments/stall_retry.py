"""A trial cut by a lockstep stall is run once more, and told apart from the robot's failures.

A lockstep stall (:mod:`jackson.sim.lockstep`, :mod:`jackson.host.transport`) says the machine
running the twin and the host failed, not the robot: one end of the lockstep went away, was
stopped, or did no work for its backstop. A campaign that counted it as the robot's failure
would charge the robot for its machine. So a trial whose ``failure`` is a stall
(``not ended: lockstep stalled: ...``) is run again, once, into the same folder (emptied
first); the result then carries ``stall_retried`` (the first attempt's line), and ``stalled``
is True when the second attempt stalled too. Campaigns list stalled trials apart from the
robot's failures. A trial that did not stall has neither key, so its metrics are unchanged.
"""

from __future__ import annotations

import json
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

from jackson.common.liveness import STALL_EXIT

S = TypeVar("S")

STALL_FAILURE = "not ended: lockstep stalled: "


def stalled(result: dict[str, Any]) -> bool:
    """Whether a trial's result is a lockstep stall (an infrastructure failure)."""
    failure = result.get("failure")
    return isinstance(failure, str) and failure.startswith(STALL_FAILURE)


def retry_stalled(run: Callable[[S], dict[str, Any]], spec: S, folder: Path) -> dict[str, Any]:
    """``run(spec)``, and once more (``folder`` emptied first) when it stalled."""
    result = run(spec)
    if not stalled(result):
        return result
    first = result["failure"]
    shutil.rmtree(folder, ignore_errors=True)
    result = run(spec)
    result["stall_retried"] = first
    result["stalled"] = stalled(result)
    metrics = folder / "metrics.json"
    if metrics.exists():  # the folder's record says so too
        metrics.write_text(json.dumps(result, indent=2) + "\n")
    return result


def stall_lines(results: list[dict[str, Any]], name: Callable[[dict[str, Any]], str]) -> list[str]:
    """A summary's paragraph on stalls, apart from the robot's failures: the trials that
    stalled twice (infrastructure failures, no verdict on the robot) and those retried after
    one; empty when none stalled."""
    twice = [f"- {name(r)}: {r['failure']}" for r in results if r.get("stalled")]
    once = [
        f"- {name(r)}: {r['stall_retried']}"
        for r in results
        if r.get("stall_retried") and not r.get("stalled")
    ]
    lines: list[str] = []
    if twice:
        lines += ["", "Runs stalled twice (the machine's failure, not the robot's):", "", *twice]
    if once:
        lines += ["", "Runs retried after a lockstep stall (the retry counts):", "", *once]
    return lines


def exit_status(result: dict[str, Any]) -> int:
    """A command's exit status for a trial's result: 0 completed, 75 a lockstep stall
    (:data:`~jackson.common.liveness.STALL_EXIT`, the machine's failure), 1 otherwise."""
    if result.get("completed"):
        return 0
    return STALL_EXIT if stalled(result) else 1
