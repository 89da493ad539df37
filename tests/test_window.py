"""The exact running sums of common/window.py: the value math.fsum gives, bit for bit, as
samples enter and leave, with subnormals, huge values, signed zeros, infinities and NaNs."""

from __future__ import annotations

import math
import sys

import numpy as np

from jackson.common.window import SummedWindow


def _same(got: object, want: object) -> None:
    assert repr(got) == repr(want)


def _check(w: SummedWindow[tuple[float, float]], kept: list[tuple[float, float]]) -> None:
    for k, f in ((0, lambda x: x), (1, abs)):
        _same(w.sum(k), math.fsum(f(x[1]) for x in kept))
    assert len(w) == len(kept) and list(w) == kept


def test_running_sums_are_fsums_of_what_is_left() -> None:
    rng = np.random.default_rng(1)
    w: SummedWindow[tuple[float, float]] = SummedWindow(((1, False), (1, True)))
    kept: list[tuple[float, float]] = []
    pool = [5e-324, -5e-324, 1e200, -1e200, 0.0, -0.0, 0.1, -0.3, 1e-17, sys.float_info.max / 1e6]
    for i in range(5000):
        if kept and rng.random() < 0.45:
            assert w.popleft() == kept.pop(0)
        else:
            x = float(rng.choice(pool)) if rng.random() < 0.3 else float(rng.normal(0, 10))
            w.append((float(i), x))
            kept.append((float(i), x))
        _check(w, kept)
        if rng.random() < 0.002:
            w.clear()
            kept.clear()


def test_an_infinity_or_nan_in_the_window_sums_as_fsum_does_until_it_leaves() -> None:
    w: SummedWindow[tuple[float, float]] = SummedWindow(((1, False), (1, True)))
    kept = [(0.0, 1.0), (1.0, math.inf), (2.0, 2.0), (3.0, math.nan), (4.0, 3.0)]
    for item in kept:
        w.append(item)
    assert math.isnan(w.sum(0))
    w.popleft()
    w.popleft()
    assert math.isnan(w.sum(0))
    w.popleft()
    w.popleft()
    _check(w, kept[4:])
    assert w.sum(0) == 3.0


def test_a_window_summing_to_zero_keeps_fsums_sign() -> None:
    w: SummedWindow[tuple[float, float]] = SummedWindow(((1, False), (1, True)))
    w.append((0.0, -0.0))
    assert repr(w.sum(0)) == repr(math.fsum([-0.0]))
