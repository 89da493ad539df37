"""Estimator consistency: NEES of the pose against ground truth, its band, the 2-sigma radius."""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from jackson.experiments.metrics.inputs import FloatArray, MetricInputError, stats

NEES_CONFIDENCE = 0.95  # two-sided probability inside the NEES band
SINGULAR_RCOND = 1e-12  # a covariance whose eigenvalues span more than 1e12 is singular
# ---- estimator consistency (NEES) -------------------------------------------------------------


def nees(errors: npt.ArrayLike, covariances: npt.ArrayLike) -> FloatArray:
    """Normalised estimation error squared eps_k = e_k^T P_k^-1 e_k of each sample.

    The chi-square test of a filter's covariance (Bar-Shalom, Li and Kirubarajan, *Estimation
    with Applications to Tracking and Navigation*, Sec. 5.4.2): when the errors e_k are
    zero-mean Gaussian with the covariance P_k the filter states, eps_k is chi-square
    distributed with n = dim(e) degrees of freedom, mean n. Above the band
    (:func:`nees_band`) the filter claims more than it knows (optimistic), below it less
    (pessimistic).

    P_k is symmetrised, (P + P^T) / 2, and a sample is left out (NaN) when P_k is singular:
    not positive definite, or its smallest eigenvalue at most ``SINGULAR_RCOND`` times its
    largest; also when e_k or P_k is not finite.

    Parameters
    ----------
    errors : array_like, shape (N, n)
        Estimate minus truth, angles already wrapped (:func:`wrap_angle`).
    covariances : array_like, shape (N, n, n)
        The filter's covariance of the same components at the same samples.

    Returns
    -------
    numpy.ndarray, shape (N,)
        eps_k, NaN where it is undefined.
    """
    e = np.asarray(errors, dtype=np.float64)
    p = np.asarray(covariances, dtype=np.float64)
    if e.ndim != 2 or p.shape != (e.shape[0], e.shape[1], e.shape[1]):
        raise MetricInputError(
            f"errors (N, n) and covariances (N, n, n) expected, got {e.shape} and {p.shape}"
        )
    out = np.full(e.shape[0], math.nan)
    p = 0.5 * (p + np.swapaxes(p, 1, 2))
    finite = np.isfinite(e).all(axis=1) & np.isfinite(p).all(axis=(1, 2))
    eig = np.linalg.eigvalsh(p[finite])  # ascending
    regular = (eig[:, -1] > 0.0) & (eig[:, 0] > SINGULAR_RCOND * eig[:, -1])
    use = np.flatnonzero(finite)[regular]
    solved = np.linalg.solve(p[use], e[use][:, :, None])[:, :, 0]
    out[use] = np.einsum("ij,ij->i", e[use], solved)
    return out


def nees_band(dof: int, confidence: float = NEES_CONFIDENCE, runs: int = 1) -> tuple[float, float]:
    """Two-sided chi-square acceptance band of the NEES, or of its mean over N runs.

        single run:  [chi2_n^-1((1 - c) / 2), chi2_n^-1((1 + c) / 2)]
        N runs:      [chi2_Nn^-1((1 - c) / 2), chi2_Nn^-1((1 + c) / 2)] / N

    N eps_bar of N independent runs is chi-square with N n degrees of freedom (the average
    NEES, Bar-Shalom et al., Sec. 5.4.2), so the band of the mean narrows around n as N grows.
    For n = 3 and c = 0.95: [0.216, 9.348] for one run, [1.679, 4.698] for ten.

    Parameters
    ----------
    dof : int
        n, the dimension of the error (3 for [x, y, yaw]).
    confidence : float
        Two-sided probability inside the band.
    runs : int
        N, the runs averaged.

    Returns
    -------
    tuple of float
        (lower, upper) bound.
    """
    if dof < 1 or runs < 1 or not 0.0 < confidence < 1.0:
        raise MetricInputError(
            f"nees_band needs dof >= 1, runs >= 1 and 0 < confidence < 1, "
            f"got {dof}, {runs}, {confidence}"
        )
    k = dof * runs
    lo = float(stats().chi2.ppf(0.5 * (1.0 - confidence), k)) / runs
    hi = float(stats().chi2.ppf(0.5 * (1.0 + confidence), k)) / runs
    return lo, hi


def position_two_sigma(covariance_xy: npt.ArrayLike) -> float:
    """2-sigma radius of a position covariance: 2 sqrt(lambda_max(P_xy)) [m].

    The semi-major axis of the 2-sigma ellipse, the largest distance from the estimate at
    which the ellipse still reaches: an error inside the ellipse is within this radius (the
    converse does not hold across the minor axis).

    Parameters
    ----------
    covariance_xy : array_like, shape (2, 2)
        Covariance of (x, y) [m^2].

    Returns
    -------
    float
        2 sqrt of its largest eigenvalue [m]; NaN if it is not finite.
    """
    p = np.asarray(covariance_xy, dtype=np.float64)
    if p.shape != (2, 2):
        raise MetricInputError(f"covariance_xy must have shape (2, 2), got {p.shape}")
    if not np.isfinite(p).all():
        return math.nan
    lam = float(np.linalg.eigvalsh(0.5 * (p + p.T))[-1])
    return 2.0 * math.sqrt(max(lam, 0.0))
