"""Our trials of each figure beside the paper's: statistics, verdicts and the agreement count.

A figure agrees when our mean lies within ``k`` of the paper's SDs of the paper's mean,

    z = (mean_ours - mean_paper) / sd_paper,    |z| <= k,

with k = 1 for Stage 1-2 and k = 2 for Stage 3's t_nav, d_min and path length; and its spread
agrees when ``sd_ours / sd_paper`` lies within 0.5-2 (:data:`SD_RATIO_RANGE`). Only completed
trials enter the statistics; completed / attempted is reported beside them.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from jackson.experiments.fidelity.figures import (
    FIGURES,
    PAPER_STAGE3_CONTACTS,
    SD_RATIO_RANGE,
    STAGE3_FIGURES,
    Figure,
)
from jackson.experiments.metrics import median_iqr


@dataclass(frozen=True)
class FigureResult:
    """Our trials of one figure beside the paper's.

    Attributes
    ----------
    figure : Figure
        The paper's figure.
    attempted, completed : int
        Trials of its campaign run and completed (0 attempted: the campaign was not run).
    values : tuple of float
        The metric of every completed trial that has a finite value.
    seeds : tuple of int
        The seed of each of ``values`` (empty when the trials did not say).
    """

    figure: Figure
    attempted: int
    completed: int
    values: tuple[float, ...]
    seeds: tuple[int, ...] = ()

    @property
    def n(self) -> int:
        """Trials in the statistics."""
        return len(self.values)

    @property
    def mean(self) -> float:
        """Our mean (NaN without a value)."""
        return float(np.mean(self.values)) if self.values else math.nan

    @property
    def sd(self) -> float:
        """Our sample SD, ddof = 1 (NaN below two values)."""
        return float(np.std(self.values, ddof=1)) if self.n > 1 else math.nan

    @property
    def z(self) -> float:
        """``(mean - paper_mean) / paper_sd``: our mean in the paper's SDs from its mean."""
        return (self.mean - self.figure.paper_mean) / self.figure.paper_sd

    @property
    def within(self) -> bool | None:
        """``|z| <= within_sd``; None without a value."""
        return None if not self.values else abs(self.z) <= self.figure.within_sd

    @property
    def sd_ratio(self) -> float:
        """Our SD over the paper's (NaN below two values)."""
        return self.sd / self.figure.paper_sd

    @property
    def sd_ok(self) -> bool | None:
        """The SD ratio within :data:`SD_RATIO_RANGE`; None below two values."""
        lo, hi = SD_RATIO_RANGE
        return None if not math.isfinite(self.sd_ratio) else lo <= self.sd_ratio <= hi

    @property
    def quartiles(self) -> tuple[float, float, float]:
        """Median, first and third quartile (NaN without a value)."""
        if not self.values:
            return math.nan, math.nan, math.nan
        q = median_iqr(self.values)  # the paper's Stage 3 summary, as every campaign's
        return q.median, q.q1, q.q3

    @property
    def missing(self) -> str | None:
        """Why there is no statistic: ``"not run"``, ``"no completed trial (0/10)"``; None when
        there is one."""
        if self.values:
            return None
        if self.attempted == 0:
            return "not run"
        if self.completed == 0:
            return f"no completed trial (0/{self.attempted})"
        return f"no value in {self.completed} completed trials"

    def as_json(self) -> dict[str, Any]:
        """Every number, NaN as null."""
        f = self.figure
        med, q1, q3 = self.quartiles
        return {
            "mission": f.mission,
            "key": f.key,
            "label": f.label,
            "table": f.table,
            "paper": {"mean": f.paper_mean, "sd": f.paper_sd, "isaac": f.isaac or None},
            "within_sd": f.within_sd,
            "attempted": self.attempted,
            "completed": self.completed,
            "n": self.n,
            "mean": _finite(self.mean),
            "sd": _finite(self.sd),
            "median": _finite(med),
            "q1": _finite(q1),
            "q3": _finite(q3),
            "z": _finite(self.z),
            "within": self.within,
            "sd_ratio": _finite(self.sd_ratio),
            "sd_ok": self.sd_ok,
            "missing": self.missing,
            "values": list(self.values),
        }


def _finite(value: float) -> float | None:
    return value if math.isfinite(value) else None


def figure_result(figure: Figure, results: Sequence[Mapping[str, Any]]) -> FigureResult:
    """Our trials of ``figure``: the completed ones with a finite value enter the statistics.

    Parameters
    ----------
    figure : Figure
        The paper's figure.
    results : sequence of mapping
        Every attempted trial of the figure's campaign (empty: not run).

    Returns
    -------
    FigureResult
    """
    done = [r for r in results if r.get("completed")]
    values, seeds = [], []
    for r in done:
        v = r.get(figure.key)
        if isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v):
            values.append(float(v))
            seeds.append(r.get("seed"))
    known = tuple(s for s in seeds if isinstance(s, int))
    return FigureResult(
        figure, len(results), len(done), tuple(values), known if len(known) == len(seeds) else ()
    )


def seed_set(row: FigureResult, first: int, last: int) -> FigureResult:
    """``row`` restricted to the trials of seeds ``first``-``last``."""
    keep = [i for i, s in enumerate(row.seeds) if first <= s <= last]
    return FigureResult(
        row.figure,
        len(keep),
        len(keep),
        tuple(row.values[i] for i in keep),
        tuple(row.seeds[i] for i in keep),
    )


@dataclass(frozen=True)
class SeedSet:
    """One set of consecutive seeds of a campaign, judged alone.

    Attributes
    ----------
    first, last : int
        Its seeds.
    agreement : Agreement
        Its figures within the paper's band (each from its completed trials of these seeds).
    """

    first: int
    last: int
    agreement: Agreement


def seed_sets(
    rows: Sequence[FigureResult], seed: int, trials: int, size: int = 10
) -> tuple[SeedSet, ...]:
    """The figures of each set of ``size`` consecutive seeds from ``seed``, judged alone: a
    campaign of 30 trials is three samples of ten, as the paper's.

    Parameters
    ----------
    rows : sequence of FigureResult
        The figures over every trial (each with its seeds).
    seed, trials : int
        The campaign's first seed and trials per stage.
    size : int
        Trials per set.

    Returns
    -------
    tuple of SeedSet
        One per set; empty below two sets, or when a row does not know its seeds.
    """
    if trials < 2 * size or any(r.values and not r.seeds for r in rows):
        return ()
    out = []
    for first in range(seed, seed + trials - size + 1, size):
        last = first + size - 1
        out.append(SeedSet(first, last, agreement([seed_set(r, first, last) for r in rows])))
    return tuple(out)


@dataclass(frozen=True)
class Agreement:
    """How many figures agree with the paper.

    Attributes
    ----------
    within : int
        Figures whose mean is within the paper's band.
    within_and_sd : int
        Of those, figures whose SD is also within :data:`SD_RATIO_RANGE` of the paper's.
    total : int
        Figures counted.
    sd_ok : int
        Figures whose SD is within :data:`SD_RATIO_RANGE` of the paper's, their mean within
        the band or not.
    """

    within: int
    within_and_sd: int
    total: int
    sd_ok: int = 0


def agreement(rows: Sequence[FigureResult]) -> Agreement:
    """Count the figures within the paper's band, and those with a fitting SD too.

    Parameters
    ----------
    rows : sequence of FigureResult
        The figures (a figure without a value counts as outside).

    Returns
    -------
    Agreement
    """
    within = [r for r in rows if r.within]
    return Agreement(
        len(within),
        sum(1 for r in within if r.sd_ok),
        len(rows),
        sum(1 for r in rows if r.sd_ok),
    )


@dataclass(frozen=True)
class NavOutcome:
    """Stage 3's discrete outcomes: goals reached and contacts over every attempted run.

    Attributes
    ----------
    attempted, completed : int
        Navigation runs started and successful (P_success = completed / attempted).
    contacts : int
        The twin's contacts over all runs (C_count).
    failure : str or None
        Why no navigation ran (the mapping run failed), None otherwise.
    """

    attempted: int
    completed: int
    contacts: int
    failure: str | None = None

    @property
    def success_within(self) -> bool:
        """Every attempted run reached the goal, as the paper's 10/10."""
        return self.attempted > 0 and self.completed == self.attempted

    @property
    def contacts_within(self) -> bool:
        """No contact, as the paper's 0."""
        return self.attempted > 0 and self.contacts == PAPER_STAGE3_CONTACTS


def nav_outcome(results: Sequence[Mapping[str, Any]], failure: str | None = None) -> NavOutcome:
    """Stage 3's success and contacts from the maze campaign's runs.

    Parameters
    ----------
    results : sequence of mapping
        Every attempted navigation run.
    failure : str or None
        Why none ran.

    Returns
    -------
    NavOutcome
    """
    done = sum(1 for r in results if r.get("completed"))
    contacts = sum(int(r.get("collisions", 0) or 0) for r in results)
    return NavOutcome(len(results), done, contacts, failure)


def agreement_line(a: Agreement) -> str:
    """``"N of 16 within the paper's mean ± 1 SD; M of them also with an SD within 0.5-2 times
    the paper's (K of 16 with such an SD)"`` (an en dash and a multiplication sign in the
    text)."""
    lo, hi = SD_RATIO_RANGE
    return (
        f"{a.within} of {a.total} within the paper's mean ± 1 SD; {a.within_and_sd} of them "
        f"also with an SD within {lo:g}\u2013{hi:g}\u00d7 the paper's ({a.sd_ok} of {a.total} "
        "with such an SD)"
    )


def assess(
    results: Mapping[str, Sequence[Mapping[str, Any]]], nav_failure: str | None = None
) -> tuple[tuple[FigureResult, ...], tuple[FigureResult, ...], NavOutcome]:
    """Every figure of the report from the campaigns' per-trial results.

    Parameters
    ----------
    results : mapping
        ``{"square": [...], "figure8": [...], "maze": [...]}``, every attempted trial; a
        stage that is missing was not run.
    nav_failure : str or None
        Why the maze campaign ran no navigation (its mapping run failed).

    Returns
    -------
    tuple
        The Stage 1-2 figures, Stage 3's continuous figures, Stage 3's success and contacts.
    """
    figures = tuple(figure_result(f, results.get(f.mission, ())) for f in FIGURES)
    maze = results.get("maze", ())
    stage3 = tuple(figure_result(f, maze) for f in STAGE3_FIGURES)
    return figures, stage3, nav_outcome(maze, nav_failure)
