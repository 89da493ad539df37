"""The paper's summaries (Sec. 2.5.5): mean +- SD with a confidence interval, median [IQR]."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
import numpy.typing as npt

from jackson.experiments.metrics.inputs import MetricInputError, as_series, stats

BOOTSTRAP_RESAMPLES = 9999  # resamples of a percentile bootstrap interval
BOOTSTRAP_SEED = 0  # its random generator's seed: the same runs give the same interval
# ---- summaries (Sec. 2.5.5) --------------------------------------------------------------------


Domain = Literal["real", "positive", "unit_interval", "binary"]
"""Where a per-run quantity lives, which picks its confidence interval (:func:`mean_sd_ci`)."""

CI_METHODS: dict[str, str] = {
    "t": "t-based interval of the mean, mean -+ t_{n-1} sd / sqrt(n)",
    "lognormal-cox": (
        "log-normal interval of the mean (modified Cox): "
        "exp(ybar + s^2/2 -+ t_{n-1} sqrt(s^2/n + s^4/(2(n-1)))), y = ln x"
    ),
    "bootstrap-percentile": (
        f"percentile bootstrap of the mean ({BOOTSTRAP_RESAMPLES} resamples, fixed seed)"
    ),
    "clopper-pearson": "exact (Clopper-Pearson) binomial interval of the share of runs",
}
"""Every confidence-interval method :func:`mean_sd_ci` uses, by name, with its formula."""


@dataclass(frozen=True)
class MeanSdCi:
    """Mean, sample SD (ddof = 1) and a confidence interval of the mean.

    Attributes
    ----------
    mean, sd : float
        Arithmetic mean and sample SD (ddof = 1; NaN for one value).
    ci_low, ci_high : float
        The interval of the mean (NaN where ``method`` cannot give one).
    n : int
        Number of values (0 when unknown: a summary built by hand).
    method : str
        A key of :data:`CI_METHODS`.
    """

    mean: float
    sd: float
    ci_low: float
    ci_high: float
    n: int = 0
    method: str = "t"

    @property
    def half_width(self) -> float:
        """Half-width of the confidence interval (t_0.975,n-1 sd / sqrt(n) for ``"t"``)."""
        return 0.5 * (self.ci_high - self.ci_low)


@dataclass(frozen=True)
class MedianIqr:
    """Median and the first and third quartiles (the paper's "median [IQR]")."""

    median: float
    q1: float
    q3: float


def mean_sd_ci(
    values: npt.ArrayLike, confidence: float = 0.95, domain: Domain = "real"
) -> MeanSdCi:
    """Mean +- SD with a confidence interval of the mean that stays in the quantity's domain.

    The Stage 1-2 summary (Sec. 2.5.5) is mean +- SD with a t-based CI,

        CI = mean -+ t_{(1 + confidence)/2, n-1} sd / sqrt(n),   sd with ddof = 1

    which, with few runs, reaches below zero for a closure or an RMSE. ``domain`` picks an
    interval that cannot leave the quantity's range (:data:`CI_METHODS`):

    - ``"real"``: the t-based interval above (a signed quantity: the optimism gap).
    - ``"positive"``: the modified Cox interval of a log-normal mean (Olsson 2005),
      exp(ybar + s^2/2 -+ t_{n-1} sqrt(s^2/n + s^4 / (2 (n - 1)))) with y = ln x, strictly
      positive; a value <= 0 falls back to the percentile bootstrap.
    - ``"unit_interval"``: a share in [0, 1] per run: the percentile bootstrap of the mean,
      inside [min, max] of the values (:func:`bootstrap_mean_ci`).
    - ``"binary"``: 0/1 per run: the exact Clopper-Pearson interval of the share of runs.

    The mean and the SD are the arithmetic ones whatever the domain, as the paper reports.

    Parameters
    ----------
    values : array_like, shape (n,)
        Per-run values, n >= 1; with n = 1 the SD is NaN, and so is the CI but for
        ``"binary"``.
    confidence : float
        Two-sided confidence level.
    domain : {"real", "positive", "unit_interval", "binary"}
        Where the quantity lives.

    Returns
    -------
    MeanSdCi

    Raises
    ------
    MetricInputError
        A value outside ``domain`` ("unit_interval", "binary") or an unknown domain.
    """
    x = as_series("values", values, min_len=1)
    n = x.shape[0]
    mean = float(np.mean(x))
    if domain == "binary":
        if not np.all((x == 0.0) | (x == 1.0)):
            raise MetricInputError("binary values must be 0 or 1")
        k = int(np.count_nonzero(x))
        ci = stats().binomtest(k, n).proportion_ci(confidence_level=confidence, method="exact")
        sd = float(np.std(x, ddof=1)) if n > 1 else math.nan
        return MeanSdCi(mean, sd, float(ci.low), float(ci.high), n, "clopper-pearson")
    if domain == "unit_interval" and not np.all((x >= 0.0) & (x <= 1.0)):
        raise MetricInputError("unit_interval values must lie in [0, 1]")
    if domain not in ("real", "positive", "unit_interval"):
        raise MetricInputError(f"unknown domain {domain!r}")
    if n == 1:
        method = {"real": "t", "positive": "lognormal-cox"}.get(domain, "bootstrap-percentile")
        return MeanSdCi(mean, math.nan, math.nan, math.nan, 1, method)
    sd = float(np.std(x, ddof=1))
    t = float(stats().t.ppf(0.5 + 0.5 * confidence, n - 1))
    if domain == "real":
        half = t * sd / math.sqrt(n)
        return MeanSdCi(mean, sd, mean - half, mean + half, n, "t")
    if domain == "positive" and np.all(x > 0.0):
        y = np.log(x)
        y_bar, s2 = float(np.mean(y)), float(np.var(y, ddof=1))
        centre = y_bar + 0.5 * s2
        half = t * math.sqrt(s2 / n + s2 * s2 / (2.0 * (n - 1)))
        return MeanSdCi(
            mean, sd, math.exp(centre - half), math.exp(centre + half), n, "lognormal-cox"
        )
    low, high = bootstrap_mean_ci(x, confidence)
    return MeanSdCi(mean, sd, low, high, n, "bootstrap-percentile")


def bootstrap_mean_ci(
    values: npt.ArrayLike, confidence: float = 0.95, seed: int = BOOTSTRAP_SEED
) -> tuple[float, float]:
    """Percentile bootstrap interval of the mean (``scipy.stats.bootstrap``), reproducible.

    The interval's ends are means of resamples of the values, so they lie inside
    [min, max] of the values and keep a bounded quantity in its bounds. With few values it is
    too narrow (n = 2 gives about [min, max]); equal values give [value, value].

    Parameters
    ----------
    values : array_like, shape (n,)
        Per-run values, n >= 2.
    confidence : float
        Two-sided confidence level.
    seed : int
        Seed of the resampling (:data:`BOOTSTRAP_SEED`): a report is the same for the same
        runs.

    Returns
    -------
    tuple of float
        (low, high).
    """
    x = as_series("values", values, min_len=2)
    if np.all(x == x[0]):
        return float(x[0]), float(x[0])
    res = stats().bootstrap(
        (x,),
        np.mean,
        n_resamples=BOOTSTRAP_RESAMPLES,
        confidence_level=confidence,
        method="percentile",
        rng=np.random.default_rng(seed),
    )
    return float(res.confidence_interval.low), float(res.confidence_interval.high)


def median_iqr(values: npt.ArrayLike) -> MedianIqr:
    """Median [Q1, Q3], the continuous Stage 3 summary (Sec. 2.5.5).

    Quartiles by linear interpolation between order statistics (NumPy's default).

    Parameters
    ----------
    values : array_like, shape (n,)
        Per-run values, n >= 1.

    Returns
    -------
    MedianIqr
    """
    x = as_series("values", values, min_len=1)
    q1, median, q3 = np.percentile(x, [25.0, 50.0, 75.0])
    return MedianIqr(float(median), float(q1), float(q3))


def format_mean_sd(
    x: MeanSdCi | npt.ArrayLike, scale: float = 100.0, unit: str = "cm", decimals: int = 2
) -> str:
    """Format a summary as "mean ± SD unit" in display units, e.g. "1.18 ± 0.96 cm".

    Parameters
    ----------
    x : MeanSdCi or array_like
        A summary, or the per-run values to summarise (:func:`mean_sd_ci`), in SI units.
    scale : float
        Factor to the display unit (100: m -> cm).
    unit : str
        Appended after a space; "" for the bare "1.18 ± 0.96" of a table with the unit in
        its header.
    decimals : int
        Digits after the point.

    Returns
    -------
    str
    """
    s = x if isinstance(x, MeanSdCi) else mean_sd_ci(x)
    text = f"{s.mean * scale:.{decimals}f} ± {s.sd * scale:.{decimals}f}"
    return f"{text} {unit}" if unit else text
