"""A sliding window of samples whose sums are kept as samples come and go, exactly.

A windowed test that re-sums its window every sample costs the window's length each time: at
20 Hz a second is 20 samples, at 200 Hz 200, so the test grows with the square of the rate.
:class:`SummedWindow` keeps the sums of chosen fields instead, updated by each sample that
enters or leaves. Floating-point running sums drift (a sum after many additions and
subtractions is not the sum of what is left), so the sums are kept as integers: every finite
double is an integer multiple of 2**-1074, so ``x * 2**1074`` is an exact integer, and
Python's integers add without rounding. :meth:`SummedWindow.sum` divides the integer back
with Python's correctly rounded integer division: the result is the correctly rounded sum of
the window's values, the value ``math.fsum`` gives, bit for bit. A window holding an infinity
or a NaN, whose exact sum is zero (fsum keeps the sign of ``-0.0``) or beyond the largest double, is
summed by ``math.fsum`` itself.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Iterator, Sequence
from typing import Generic, TypeVar

_SCALE_BITS = 1074  # 2**-1074: the smallest positive double
_SCALE = 1 << _SCALE_BITS

T = TypeVar("T", bound=tuple[float, ...])


def _exact(x: float) -> int | None:
    """``x * 2**1074`` as an integer (None for an infinity or a NaN)."""
    if not math.isfinite(x):
        return None
    num, den = x.as_integer_ratio()  # den is a power of two, at most 2**1074
    return num << (_SCALE_BITS + 1 - den.bit_length())


class SummedWindow(Generic[T]):
    """A deque of tuples with the exact sums of some of their fields.

    Parameters
    ----------
    fields : sequence of (int, bool)
        The summed fields: (index in the tuple, sum its absolute value).

    Examples
    --------
    >>> w = SummedWindow[tuple[float, float]](((1, False), (1, True)))
    >>> w.append((0.0, 0.1)); w.append((0.05, -0.3))
    >>> w.sum(0), w.sum(1), len(w)
    (-0.19999999999999998, 0.4, 2)
    """

    def __init__(self, fields: Sequence[tuple[int, bool]]) -> None:
        self._fields = tuple(fields)
        self._items: deque[T] = deque()
        self._exact: deque[tuple[int | None, ...]] = deque()
        self._sums = [0] * len(self._fields)
        self._special = [0] * len(self._fields)  # values that are not finite

    def _values(self, item: T) -> tuple[int | None, ...]:
        return tuple(_exact(abs(item[i]) if a else item[i]) for i, a in self._fields)

    def append(self, item: T) -> None:
        """Add a sample at the right."""
        values = self._values(item)
        self._items.append(item)
        self._exact.append(values)
        for k, v in enumerate(values):
            if v is None:
                self._special[k] += 1
            else:
                self._sums[k] += v

    def popleft(self) -> T:
        """Remove and return the oldest sample."""
        values = self._exact.popleft()
        for k, v in enumerate(values):
            if v is None:
                self._special[k] -= 1
            else:
                self._sums[k] -= v
        return self._items.popleft()

    def clear(self) -> None:
        """Forget every sample."""
        self._items.clear()
        self._exact.clear()
        self._sums = [0] * len(self._fields)
        self._special = [0] * len(self._fields)

    def sum(self, k: int) -> float:
        """The sum of summed field ``k`` over the window, as ``math.fsum`` gives it."""
        if not self._special[k] and self._sums[k] != 0:
            try:
                return self._sums[k] / _SCALE
            except OverflowError:
                pass  # beyond the largest double: as fsum answers it
        i, a = self._fields[k]
        return math.fsum(abs(x[i]) if a else x[i] for x in self._items)

    def __len__(self) -> int:
        return len(self._items)

    def __bool__(self) -> bool:
        return bool(self._items)

    def __iter__(self) -> Iterator[T]:
        return iter(self._items)

    def __getitem__(self, i: int) -> T:
        return self._items[i]
