"""PWM deadband per wheel and direction from slow duty staircases."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np

from jackson.calibration.procedures.base import CalibrationError, FloatArray, IntArray, RunData


@dataclass(frozen=True)
class Bracket:
    """The breakaway duty lies in (lo, hi]; hi is inf when the wheel never moved."""

    lo: float
    hi: float

    @property
    def width(self) -> float:
        return self.hi - self.lo

    @property
    def mid(self) -> float:
        return 0.5 * (self.lo + self.hi)


def breakaway_bracket(
    duty: Sequence[float] | FloatArray,
    counts: Sequence[int] | IntArray,
    persist_frames: int = 3,
) -> Bracket:
    """Where one wheel breaks away during one duty ramp of one sign.

    ``duty[k]`` is written after frame k and acts until frame k + 1, so a count change first
    seen at frame m was caused by ``duty[m - 1]``. The wheel *moved* at the first frame m
    whose count differs from the count at the ramp's start in the ramp's direction and keeps
    differing for ``persist_frames`` frames (a one-tick jitter that returns is not motion).
    The breakaway duty is then above the last lower duty level held before ``duty[m - 1]``
    and at most ``|duty[m - 1]|``. On a staircase held long enough for one tick at any excess
    torque, that bracket is one step wide; on a continuous ramp the response lag biases it up.

    Parameters
    ----------
    duty : sequence of float or numpy.ndarray
        Signed duty of this wheel per frame of the ramp (one sign, |duty| rising).
    counts : sequence of int or numpy.ndarray
        The wheel's cumulative counts per frame, one frame longer than ``duty`` or as
        long (the frame after the last duty, when present, shows that duty's effect).
    persist_frames : int
        N, frames the change must persist.

    Returns
    -------
    Bracket
        The bracket; ``hi`` is inf and ``lo`` the largest duty held when it never moved.

    Raises
    ------
    ValueError
        Empty ramp, mixed signs, or counts shorter than the duties.
    """
    d = np.asarray(duty, dtype=np.float64)
    c = np.asarray(counts, dtype=np.int64)
    if len(d) == 0:
        raise ValueError("empty ramp")
    if len(c) < len(d):
        raise ValueError("need a count for every frame of the ramp")
    sign = float(np.sign(d[np.argmax(np.abs(d))]))
    if sign == 0.0 or np.any(d * sign < 0.0):
        raise ValueError("a ramp has one sign of duty")
    mag = np.abs(d)
    moved = sign * (c - c[0]) >= 1
    n = len(c)
    last = min(n, len(d) + 1)  # counts that can show an effect of this ramp's duties
    for m in range(1, last):
        end = min(m + persist_frames, last)
        if end - m < persist_frames:
            break  # too few frames left to see a change persist
        if np.all(moved[m:end]):
            hi = float(mag[m - 1])
            lower = mag[: m - 1][mag[: m - 1] < hi]
            lo = float(lower.max()) if len(lower) else 0.0
            return Bracket(lo, hi)
    return Bracket(float(mag.max()), math.inf)


def combine_brackets(brackets: Sequence[Bracket]) -> Bracket:
    """The intersection of the ramps' brackets, or the narrowest one if they disagree."""
    if not brackets:
        raise ValueError("no brackets")
    lo = max(b.lo for b in brackets)
    hi = min(b.hi for b in brackets)
    if lo < hi:
        return Bracket(lo, hi)
    return min(brackets, key=lambda b: b.width)


@dataclass(frozen=True)
class Ramp:
    """One ramp of one wheel in one direction: frames [start, stop) of a run."""

    side: Literal["left", "right"]
    direction: Literal["forward", "reverse"]
    start: int
    stop: int


def find_ramps(run: RunData) -> list[Ramp]:
    """Blocks of frames in which exactly one wheel has a nonzero duty of one sign."""
    out: list[Ramp] = []
    dl = np.nan_to_num(run.duty_left)
    dr = np.nan_to_num(run.duty_right)
    key: list[tuple[str, str] | None] = []
    for a, b in zip(dl, dr, strict=True):
        if a != 0.0 and b == 0.0:
            key.append(("left", "forward" if a > 0 else "reverse"))
        elif b != 0.0 and a == 0.0:
            key.append(("right", "forward" if b > 0 else "reverse"))
        else:
            key.append(None)
    k = 0
    while k < len(key):
        kk = key[k]
        if kk is None:
            k += 1
            continue
        j = k
        while j < len(key) and key[j] == kk:
            j += 1
        side: Literal["left", "right"] = "left" if kk[0] == "left" else "right"
        direction: Literal["forward", "reverse"] = "forward" if kk[1] == "forward" else "reverse"
        out.append(Ramp(side, direction, k, j))
        k = j
    return out


@dataclass(frozen=True)
class DeadbandCalibration:
    """Breakaway duty per wheel and direction: the midpoints of the combined brackets."""

    forward_left: float
    reverse_left: float
    forward_right: float
    reverse_right: float
    brackets: Mapping[str, Bracket]


def calibrate_deadband(runs: Sequence[RunData], persist_frames: int = 3) -> DeadbandCalibration:
    """The PWM deadband of each wheel and direction from raw duty ramps (Sec. 2.2.3).

    Every ramp (:func:`find_ramps`) gives a bracket (:func:`breakaway_bracket`); the brackets
    of one wheel and direction are intersected (:func:`combine_brackets`), so a coarse ramp
    followed by a fine one narrows the answer to the fine step. The result is the midpoint.

    Parameters
    ----------
    runs : sequence of RunData
        Runs with raw duties (commands.csv) and counts.
    persist_frames : int
        N of :func:`breakaway_bracket`.

    Returns
    -------
    DeadbandCalibration
        The four breakaway duties.

    Raises
    ------
    CalibrationError
        A wheel/direction without a ramp, or one that never moved.
    """
    found: dict[str, list[Bracket]] = {}
    for run in runs:
        for ramp in find_ramps(run):
            counts = run.enc_left if ramp.side == "left" else run.enc_right
            duty = run.duty_left if ramp.side == "left" else run.duty_right
            stop = min(ramp.stop + 1, run.frames)
            b = breakaway_bracket(
                duty[ramp.start : ramp.stop], counts[ramp.start : stop], persist_frames
            )
            found.setdefault(f"{ramp.direction}_{ramp.side}", []).append(b)
    out: dict[str, Bracket] = {}
    for key in ("forward_left", "reverse_left", "forward_right", "reverse_right"):
        direction, side = key.split("_")
        if key not in found:
            raise CalibrationError(f"no {side} {direction} duty ramp in the runs")
        b = combine_brackets(found[key])
        if math.isinf(b.hi):
            raise CalibrationError(
                f"the {side} wheel never moved {direction} up to duty {b.lo:.3f}: is the motor "
                "rail on? (raise --max-duty)"
            )
        out[key] = b
    return DeadbandCalibration(
        forward_left=out["forward_left"].mid,
        reverse_left=out["reverse_left"].mid,
        forward_right=out["forward_right"].mid,
        reverse_right=out["reverse_right"].mid,
        brackets=out,
    )
