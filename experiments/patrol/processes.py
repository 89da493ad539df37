"""What a patrol reads of the processes it runs: the twin's ground truth as it grows, and each
process's memory and CPU time from ``/proc``."""

from __future__ import annotations

import math
import os
from collections import deque
from pathlib import Path


class TruthTail:
    """The twin's ground-truth file read as it grows; the last 30 s of MCU time kept."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self._pos = 0
        self._partial = ""
        self.rows: deque[tuple[float, float, float]] = deque(maxlen=600 * 2)

    def poll(self) -> float | None:
        """Read what is new; the newest MCU time [s] (None before a row)."""
        try:
            with self.path.open("r", encoding="ascii") as f:
                f.seek(self._pos)
                chunk = f.read()
                self._pos = f.tell()
        except OSError:
            return None
        text = self._partial + chunk
        lines = text.split("\n")
        self._partial = lines.pop()
        for line in lines:
            if not line or line[0] not in "0123456789":
                continue
            parts = line.split(",")
            self.rows.append((float(parts[1]), float(parts[2]), float(parts[3])))
        return self.rows[-1][0] if self.rows else None

    def at(self, t_s: float) -> tuple[float, float] | None:
        """The truth position at MCU time ``t_s`` (the nearest kept row)."""
        if not self.rows:
            return None
        best = min(self.rows, key=lambda r: abs(r[0] - t_s))
        return best[1], best[2]

    def moved_since(self, t_s: float) -> float:
        """How far the robot moved from MCU time ``t_s`` to the newest row [m]."""
        then = self.at(t_s)
        if then is None or not self.rows:
            return math.inf
        return math.hypot(self.rows[-1][1] - then[0], self.rows[-1][2] - then[1])


def children(pid: int) -> list[int]:
    """The processes ``pid`` started and that still run (the daemon's planner worker)."""
    out: list[int] = []
    try:
        tasks = list(Path(f"/proc/{pid}/task").iterdir())
    except OSError:
        return out
    for task in tasks:
        try:
            out += [int(c) for c in (task / "children").read_text().split()]
        except (OSError, ValueError):
            continue
    return out


def rss_mb(pid: int, with_children: bool = False) -> float:
    """The resident set of process ``pid`` [MB] (``VmRSS``; NaN once it has ended), with its
    children's (:func:`children`) when asked."""
    total = _rss_mb(pid)
    if with_children and not math.isnan(total):
        total += sum(x for x in map(_rss_mb, children(pid)) if not math.isnan(x))
    return total


def _rss_mb(pid: int) -> float:
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return math.nan


def cpu_s(pid: int, with_children: bool = False) -> float:
    """The CPU time process ``pid`` has used, user and system [s] (NaN once it has ended),
    with that of its running children (:func:`children`) when asked."""
    total = _cpu_s(pid)
    if with_children and not math.isnan(total):
        total += sum(x for x in map(_cpu_s, children(pid)) if not math.isnan(x))
    return total


def _cpu_s(pid: int) -> float:
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    except (OSError, IndexError, ValueError):
        return math.nan
