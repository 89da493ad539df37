"""The benchmark record every suite returns (``jackson bench`` collects and prints them).

On a shared machine whose speed swings threefold an absolute time says little, so each figure is
a ratio of two things timed side by side in the same run, interleaved (A, B, A, B, ...) and
best of N: our code against a peer doing the same work, or against the period it must fit in.
The figure's :attr:`BenchResult.value` is that ratio and its target is on the ratio; the
absolute time stays beside it for information, with the speed of a fixed reference loop
(:func:`reference_loop_us`, ``sum(range(10000))``) timed on the same machine in the same run.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Literal

REFERENCE_LOOP = "sum(range(10000))"
"""The machine's reference loop, timed beside every suite."""


@dataclass(frozen=True)
class BenchResult:
    """One measured figure and the target it is judged against.

    Attributes
    ----------
    name : str
        Dotted figure name (``suite.figure``).
    value : float
        The judged figure: a ratio of two things measured side by side (see :attr:`reference`).
    unit : str
        What the ratio means, e.g. ``"x pymavlink's speed"`` or ``"of the 5 ms frame period"``.
    target : float or None
        The value :attr:`value` must reach (``better == "higher"``) or stay under (``"lower"``);
        None for a figure reported for information (its reference is itself being optimised,
        so its ratio judges nothing on its own).
    better : {"higher", "lower"}
        Which side of :attr:`target` meets it.
    reference : str
        What the ratio is taken against, in words.
    absolute : float or None
        Our own absolute measurement behind the ratio, for information only.
    absolute_unit : str
        Unit of :attr:`absolute`.
    reference_absolute : float or None
        The reference's absolute measurement in the same run (same unit), when it was timed.
    machine_loop_us : float or None
        Best time of :data:`REFERENCE_LOOP` in the same run [us]: the machine's speed then.
    """

    name: str
    value: float
    unit: str
    target: float | None
    better: Literal["higher", "lower"]
    reference: str = ""
    absolute: float | None = None
    absolute_unit: str = ""
    reference_absolute: float | None = None
    machine_loop_us: float | None = None

    @property
    def met(self) -> bool:
        """Whether :attr:`value` meets :attr:`target`.

        Returns
        -------
        bool
            ``value >= target`` for ``better == "higher"``, ``value <= target`` otherwise;
            True for a figure without a target.
        """
        if self.target is None:
            return True
        return self.value >= self.target if self.better == "higher" else self.value <= self.target


def reference_loop_us(repeats: int = 20) -> float:
    """Best time of :data:`REFERENCE_LOOP` over ``repeats`` tries on this machine, now.

    Parameters
    ----------
    repeats : int
        Number of tries; the fastest is kept, as ``timeit`` does.

    Returns
    -------
    float
        The best time [us].
    """
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        sum(range(10_000))
        best = min(best, time.perf_counter() - t0)
    return best * 1e6


def interleaved_best(
    candidates: Mapping[str, Callable[[], object]], repeats: int, self_timed: bool = False
) -> tuple[dict[str, float], float]:
    """Time several callables side by side: A, B, ..., A, B, ... and keep each one's best.

    Load from other tenants slows whole stretches of a run; interleaving gives every candidate
    the same chances, and the best of ``repeats`` is the run least disturbed. The reference loop
    is timed in each round too.

    Parameters
    ----------
    candidates : Mapping[str, Callable[[], object]]
        Name -> work to time (called once per round).
    repeats : int
        Number of rounds.
    self_timed : bool
        The callables time their own measured section (set-up excluded) and return it [s]
        as a float; otherwise the whole call is timed.

    Returns
    -------
    best_s : dict[str, float]
        Name -> the best wall time of one call [s].
    machine_loop_us : float
        Best time of :data:`REFERENCE_LOOP` over the rounds [us].
    """
    best = dict.fromkeys(candidates, float("inf"))
    loop_us = float("inf")
    for _ in range(repeats):
        for name, fn in candidates.items():
            t0 = time.perf_counter()
            out = fn()
            elapsed = time.perf_counter() - t0
            if self_timed:
                if not isinstance(out, float):
                    raise TypeError(f"{name}: a self-timed candidate returns its time [s]")
                elapsed = out
            best[name] = min(best[name], elapsed)
        loop_us = min(loop_us, reference_loop_us(3))
    return best, loop_us


def interleaved_slices(
    make_round: Callable[[], Mapping[str, Sequence[Callable[[], object]]]], repeats: int
) -> tuple[dict[str, float], float]:
    """Time several workloads cut into slices, slice by slice: A0, B0, A1, B1, ...

    Finer than :func:`interleaved_best`: a change in the machine's load within a run hits every
    candidate's neighbouring slices alike, so the ratio of their sums hardly moves. Each round
    is made afresh (new decoders, new twins) and does the same work slice for slice; a
    candidate's figure is the sum over its slices of each slice's best time over the rounds
    (a preemption spoils one slice of one round, not the figure).

    Parameters
    ----------
    make_round : Callable[[], Mapping[str, Sequence[Callable[[], object]]]]
        Makes one round: name -> the candidate's slices, all candidates with as many slices,
        run in the mapping's order for each slice index.
    repeats : int
        Number of rounds.

    Returns
    -------
    best_s : dict[str, float]
        Name -> the sum of the best times of its slices [s].
    machine_loop_us : float
        Best time of :data:`REFERENCE_LOOP` over the rounds [us].
    """
    best: dict[str, list[float]] = {}
    loop_us = float("inf")
    for _ in range(repeats):
        work = make_round()
        counts = {len(slices) for slices in work.values()}
        if len(counts) != 1:
            raise ValueError(f"candidates with different slice counts: {sorted(counts)}")
        n = counts.pop()
        for i in range(n):
            for name, slices in work.items():
                t0 = time.perf_counter()
                slices[i]()
                elapsed = time.perf_counter() - t0
                per_slice = best.setdefault(name, [float("inf")] * n)
                per_slice[i] = min(per_slice[i], elapsed)
        loop_us = min(loop_us, reference_loop_us(3))
    return {name: math.fsum(times) for name, times in best.items()}, loop_us
