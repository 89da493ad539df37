"""Low-variance (systematic) resampling: which particles survive a resampling step.

One uniform draw places a comb of evenly spaced teeth over the cumulative weights
(Probabilistic Robotics, Table 4.4), so a particle is drawn in proportion to its weight with the
least possible variance in its count. The filter shuffles the draws and lets KLD sampling
(:mod:`jackson.host.nav.amcl.kld`) decide how many of them to keep.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


def systematic_resample(weights: FloatArray, count: int, rng: np.random.Generator) -> IntArray:
    """Indices of ``count`` draws by low-variance (systematic) resampling (Table 4.4).

    One uniform offset ``r`` in [0, 1/count) and the comb ``r + m / count`` through the
    cumulative weights: a particle of weight w is drawn ``floor`` or ``ceil`` of ``w count``
    times, never more or fewer.

    Parameters
    ----------
    weights : ndarray of float, shape (N,)
        Normalised weights (sum 1).
    count : int
        Draws.
    rng : numpy.random.Generator
        Source of the offset.

    Returns
    -------
    ndarray of int, shape (count,)
        Indices into ``weights``, ascending.
    """
    comb = (rng.random() + np.arange(count, dtype=np.float64)) / count
    cumulative = np.cumsum(weights)
    cumulative[-1] = 1.0  # no draw past the end from rounding
    return np.searchsorted(cumulative, comb, side="right").astype(np.int64)
