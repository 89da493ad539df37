"""Confidence intervals of the mean that stay in the quantity's domain (metrics.mean_sd_ci)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from jackson.experiments.metrics import (
    CI_METHODS,
    MetricInputError,
    bootstrap_mean_ci,
    mean_sd_ci,
)


def test_the_default_is_the_papers_t_interval() -> None:
    s = mean_sd_ci([1.0, 2.0, 3.0, 4.0])
    assert s.method == "t" and s.n == 4
    assert (s.ci_low, s.ci_high) == (pytest.approx(0.445740, abs=1e-6), pytest.approx(4.554260))


def test_a_positive_quantity_gets_the_modified_cox_interval_by_hand() -> None:
    s = mean_sd_ci([8.0, 10.0], domain="positive")
    y = np.log([8.0, 10.0])
    s2 = float(np.var(y, ddof=1))
    half = 12.706205 * math.sqrt(s2 / 2 + s2**2 / 2)  # t_0.975,1
    centre = float(np.mean(y)) + s2 / 2
    assert s.method == "lognormal-cox"
    assert s.ci_low == pytest.approx(math.exp(centre - half), rel=1e-6)
    assert s.ci_high == pytest.approx(math.exp(centre + half), rel=1e-6)
    assert (s.mean, s.sd) == (9.0, pytest.approx(math.sqrt(2.0)))  # arithmetic, as the paper's
    assert mean_sd_ci([8.0, 10.0]).ci_low < 0.0 < s.ci_low  # where the t interval goes negative


def test_the_cox_interval_covers_a_log_normal_mean_95_percent_of_the_time() -> None:
    rng = np.random.default_rng(3)
    mu, sigma, n = 1.0, 0.5, 10
    true_mean = math.exp(mu + sigma**2 / 2)
    hits = 0
    for _ in range(2000):
        s = mean_sd_ci(rng.lognormal(mu, sigma, n), domain="positive")
        hits += s.ci_low <= true_mean <= s.ci_high
    assert 0.93 < hits / 2000 < 0.97


def test_a_positive_quantity_with_a_zero_falls_back_to_the_bootstrap() -> None:
    s = mean_sd_ci([0.0, 1.0, 2.0], domain="positive")
    assert s.method == "bootstrap-percentile" and 0.0 <= s.ci_low < s.ci_high <= 2.0


def test_a_share_of_time_stays_inside_the_runs_range_and_repeats() -> None:
    values = [0.9, 0.95, 1.0, 0.97, 0.99]
    s = mean_sd_ci(values, domain="unit_interval")
    assert s.method == "bootstrap-percentile"
    assert 0.9 <= s.ci_low < s.mean < s.ci_high <= 1.0
    assert mean_sd_ci(values, domain="unit_interval") == s  # a fixed seed: same runs, same CI
    assert bootstrap_mean_ci([0.0, 0.0]) == (0.0, 0.0)
    with pytest.raises(MetricInputError, match=r"\[0, 1\]"):
        mean_sd_ci([0.5, 1.5], domain="unit_interval")


def test_a_share_of_runs_gets_the_exact_binomial_interval() -> None:
    s = mean_sd_ci([1, 1, 1, 0, 1, 1, 1, 1, 1, 1], domain="binary")
    ci = stats.binomtest(9, 10).proportion_ci(method="exact")
    assert s.method == "clopper-pearson" and s.mean == 0.9
    assert (s.ci_low, s.ci_high) == (pytest.approx(ci.low), pytest.approx(ci.high))
    assert mean_sd_ci([1, 1], domain="binary").ci_low == pytest.approx(0.158114, abs=1e-6)
    with pytest.raises(MetricInputError):
        mean_sd_ci([0.5, 1.0], domain="binary")


def test_one_value_has_no_interval_and_every_method_is_described() -> None:
    for domain in ("real", "positive", "unit_interval"):
        s = mean_sd_ci([0.5], domain=domain)  # type: ignore[arg-type]
        assert s.n == 1 and math.isnan(s.sd) and math.isnan(s.ci_low), domain
        assert s.method in CI_METHODS
    with pytest.raises(MetricInputError, match="unknown domain"):
        mean_sd_ci([1.0, 2.0], domain="angle")  # type: ignore[arg-type]
