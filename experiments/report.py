"""Tables of a campaign, laid out like the paper's (Tables 5-8), and its report folder.

``summary.json`` holds numbers: per metric its label, unit, n, mean, SD, the 95 % CI of the
mean (from a method that keeps the interval in the quantity's domain,
:func:`jackson.experiments.metrics.mean_sd_ci`) and the paper's figures beside ours
(:data:`jackson.experiments.paper_figures.PAPER`); ``summary.md`` the same as text, with the
figures of :mod:`jackson.experiments.report_plots` (Figures 5-11), each a PNG at
:data:`FIGURE_DPI` and a PDF beside it (:func:`save_figure`).

Beside the paper's figures, the consistency of the EKF's covariance (NEES against the twin's
ground truth, :mod:`jackson.experiments.consistency`): rows of the table and ``nees.png``.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from jackson.common.figures import FIGURE_DPI as FIGURE_DPI  # re-exported
from jackson.common.figures import save_figure as save_figure  # re-exported
from jackson.common.figures import vector_path as vector_path  # re-exported
from jackson.experiments import metrics as m
from jackson.experiments.consistency import (
    CampaignConsistency,
    ConsistencyError,
    campaign_consistency,
    run_consistency,
    significant,
)
from jackson.experiments.paper_figures import PAPER as PAPER  # re-exported
from jackson.experiments.paper_figures import PaperFigure as PaperFigure  # re-exported
from jackson.experiments.report_plots import plot_closure, plot_nees, plot_trajectories
from jackson.experiments.stall_retry import stall_lines

CONFIDENCE = 0.95  # two-sided level of every CI of the summary


@dataclass(frozen=True)
class MetricSpec:
    """A per-run metric of a campaign: how it is named, its unit, where its values live.

    Attributes
    ----------
    label : str
        Name in the tables and plots, without the unit.
    unit : str
        "cm", "deg", "m", "s", or "1" for a dimensionless figure.
    domain : str
        :data:`jackson.experiments.metrics.Domain`: picks the CI (:func:`m.mean_sd_ci`).
    """

    label: str
    unit: str
    domain: m.Domain

    @property
    def heading(self) -> str:
        """The label with its unit, e.g. ``"EKF closure (cm)"``."""
        return self.label if self.unit == "1" else f"{self.label} ({self.unit})"


METRICS: dict[str, MetricSpec] = {
    "gt_closure_cm": MetricSpec("Ground-truth closure", "cm", "positive"),
    "ekf_closure_cm": MetricSpec("EKF closure", "cm", "positive"),
    "odom_closure_cm": MetricSpec("Raw wheel-odometry closure", "cm", "positive"),
    "optimism_gap_cm": MetricSpec("Estimator optimism gap, GT - EKF", "cm", "real"),
    "nees_in_band_fraction": MetricSpec(
        "NEES of [x, y, yaw] inside the 95 % band (share of time)", "1", "unit_interval"
    ),
    "nees_above_fraction": MetricSpec(
        "NEES above the band: optimistic (share of time)", "1", "unit_interval"
    ),
    "nees_below_fraction": MetricSpec(
        "NEES below the band: pessimistic (share of time)", "1", "unit_interval"
    ),
    "nees_mean": MetricSpec("Mean NEES (3 when the covariance is right)", "1", "positive"),
    "nees_xy_mean": MetricSpec("Mean NEES of the position alone (2 when right)", "1", "positive"),
    "nees_yaw_mean": MetricSpec("Mean NEES of the heading alone (1 when right)", "1", "positive"),
    "end_error_cm": MetricSpec("EKF end-point error vs ground truth", "cm", "positive"),
    "end_position_2sigma_cm": MetricSpec(
        "Covariance 2-sigma of the end position", "cm", "positive"
    ),
    "end_error_covered": MetricSpec(
        "End-point error within that 2-sigma (share of runs)", "1", "binary"
    ),
    "ekf_final_heading_deg": MetricSpec("EKF final heading error", "deg", "positive"),
    "gt_final_heading_deg": MetricSpec("Ground-truth final heading error", "deg", "positive"),
    "odom_final_heading_deg": MetricSpec("Raw-odometry final heading error", "deg", "positive"),
    "ekf_cross_track_rmse_cm": MetricSpec("EKF cross-track RMSE", "cm", "positive"),
    "gt_cross_track_rmse_cm": MetricSpec("Ground-truth cross-track RMSE", "cm", "positive"),
    "odom_cross_track_rmse_cm": MetricSpec("Raw-odometry cross-track RMSE", "cm", "positive"),
    "ekf_max_cross_track_cm": MetricSpec("EKF largest cross-track deviation", "cm", "positive"),
    "ekf_path_m": MetricSpec("EKF path length", "m", "positive"),
    "ekf_position_rmse_vs_gt_cm": MetricSpec("EKF position RMSE vs ground truth", "cm", "positive"),
    "ekf_yaw_rmse_vs_gt_deg": MetricSpec("EKF yaw RMSE vs ground truth", "deg", "positive"),
    "gt_loop_diameter_ccw_m": MetricSpec("CCW loop diameter, ground truth", "m", "positive"),
    "gt_loop_diameter_cw_m": MetricSpec("CW loop diameter, ground truth", "m", "positive"),
    "duration_s": MetricSpec("Duration from time zero", "s", "positive"),
    "real_time_factor": MetricSpec("Real-time factor of the trial", "1", "positive"),
}
"""Every metric a campaign summarises, in the order of its table."""

CI_NAMES = {
    "t": "t-based",
    "lognormal-cox": "log-normal",
    "bootstrap-percentile": "bootstrap",
    "clopper-pearson": "exact binomial",
}
"""Short name of each CI method in ``summary.md``."""

# figures that span decades: three significant digits instead of two decimals
SIGNIFICANT = frozenset({"nees_mean", "nees_xy_mean", "nees_yaw_mean", "end_position_2sigma_cm"})


def _number(key: str, value: float) -> str:
    return significant(value) if key in SIGNIFICANT else f"{value:.2f}"


def _finite(value: float) -> float | None:
    return value if math.isfinite(value) else None


@dataclass(frozen=True)
class MetricSummary:
    """One metric of a campaign: our runs summarised and the paper's figures.

    Attributes
    ----------
    key : str
        Its key in a run's metrics (``"gt_closure_cm"``).
    spec : MetricSpec
        Label, unit, domain.
    stats : MeanSdCi
        Mean, SD and the CI of the mean over the runs that have the metric.
    physical, isaac : PaperFigure or None
        The paper's physical robot and Isaac Sim twin (None: not in the paper).
    """

    key: str
    spec: MetricSpec
    stats: m.MeanSdCi
    physical: PaperFigure | None
    isaac: PaperFigure | None

    def as_json(self) -> dict[str, Any]:
        """Numbers only (NaN as null): summary.json's entry for this metric."""
        s = self.stats
        return {
            "label": self.spec.label,
            "unit": self.spec.unit,
            "n": s.n,
            "mean": _finite(s.mean),
            "sd": _finite(s.sd),
            "ci_low": _finite(s.ci_low),
            "ci_high": _finite(s.ci_high),
            "ci_method": s.method,
            "paper": {
                "physical": self.physical.as_json() if self.physical else None,
                "isaac": self.isaac.as_json() if self.isaac else None,
            },
        }

    def markdown_row(self) -> str:
        """``| metric | mean ± SD | 95 % CI | CI method | physical | Isaac |``."""
        s, k = self.stats, self.key
        ours = _number(k, s.mean)
        if s.n > 1:
            ours += f" ± {_number(k, s.sd)}"
        ci = (
            f"[{_number(k, s.ci_low)}, {_number(k, s.ci_high)}]"
            if math.isfinite(s.ci_low) and math.isfinite(s.ci_high)
            else "—"
        )
        cells = (
            self.spec.heading,
            ours,
            ci,
            CI_NAMES[s.method] if ci != "—" else "—",
            self.physical.text if self.physical else "—",
            self.isaac.text if self.isaac else "—",
        )
        return "| " + " | ".join(cells) + " |"


def summarise(mission: str, results: Sequence[dict[str, Any]]) -> list[MetricSummary]:
    """Every metric of :data:`METRICS` the runs have, summarised with the paper beside it.

    Parameters
    ----------
    mission : str
        "square" or "figure8" (selects the paper's figures).
    results : sequence of dict
        Per-run metrics (a run without a metric is left out of that metric's n).

    Returns
    -------
    list of MetricSummary
        In the order of :data:`METRICS`.
    """
    rows = []
    for key, spec in METRICS.items():
        values = [float(r[key]) for r in results if key in r and r[key] is not None]
        if not values:
            continue
        stats = m.mean_sd_ci(values, CONFIDENCE, spec.domain)
        phys, isaac = PAPER.get(mission, {}).get(key, (None, None))
        rows.append(MetricSummary(key, spec, stats, phys, isaac))
    return rows


def ci_note(rows: Sequence[MetricSummary]) -> list[str]:
    """The summary's lines saying which CI each metric has and why.

    Parameters
    ----------
    rows : sequence of MetricSummary
        The campaign's table.

    Returns
    -------
    list of str
        Markdown lines, one per CI method in use.
    """
    why = {
        "t": "for a signed quantity (as the paper's Stage 1-2 summaries)",
        "lognormal-cox": (
            "for strictly positive quantities (closures, RMSEs, heading errors, diameters, "
            "durations, NEES), never below zero; wide when the runs spread over a decade and "
            "n is small"
        ),
        "bootstrap-percentile": (
            "for shares of time in [0, 1] (and a positive quantity with a zero among its runs): "
            "its ends lie inside [min, max] of the runs, too narrow with few runs"
        ),
        "clopper-pearson": "for a share of runs (k of n)",
    }
    used = sorted({r.stats.method for r in rows if math.isfinite(r.stats.ci_low)})
    return [f"- {CI_NAMES[k]}, {why[k]}: {m.CI_METHODS[k]}." for k in used]


def write_report(
    out: Path, mission: str, results: list[dict[str, Any]], meta: dict[str, Any]
) -> None:
    """summary.md, summary.json and the figures of a campaign folder.

    Parameters
    ----------
    out : Path
        The report folder, with the runs in ``runs/R01 ...``.
    mission : str
        "square" or "figure8".
    results : list of dict
        Per-run metrics in run order.
    meta : dict
        Robot, world, seed, workers, wall_s (and whatever else describes the campaign).
    """
    out.mkdir(parents=True, exist_ok=True)
    rows = summarise(mission, results)
    runs = [out / "runs" / f"R{i + 1:02d}" for i in range(len(results))]
    consistency, consistency_lines = judge_consistency(out, runs, mission)
    done = sum(1 for r in results if r.get("completed"))
    title = {"square": "Stage 1, 1 m square", "figure8": "Stage 2, figure-eight"}[mission]
    lines = [
        f"# {title}: {len(results)} trials on the twin",
        "",
        f"Robot `{meta['robot']}`, world `{meta['world']}`, seed {meta['seed']}, "
        f"{meta['workers']} workers, {meta['wall_s']:.1f} s wall time; {done}/{len(results)} "
        f"completed. Ours: mean ± SD over the runs and the {CONFIDENCE * 100:.0f} % CI of the "
        "mean; the "
        "paper's physical robot and Isaac Sim twin beside them (mean ± SD).",
        "",
        "| metric | ours | 95 % CI | CI method | paper, physical | paper, Isaac twin |",
        "|---|---|---|---|---|---|",
        *[r.markdown_row() for r in rows],
        "",
        "Confidence intervals of the mean, chosen so that they stay where the quantity lives:",
        "",
        *ci_note(rows),
        "",
        "Figures (each a PNG and a PDF beside it):",
        "",
        "![trajectories](trajectories.png)",
        "",
        "![closure](closure.png)",
        "",
        "## Consistency of the EKF's covariance",
        "",
        *consistency_lines,
        "",
    ]
    named = [{**r, "run": f"R{i + 1:02d}"} for i, r in enumerate(results)]
    stalls = stall_lines(named, lambda r: str(r["run"]))
    lines += ["## Lockstep stalls (the machine's failures, not the robot's)", ""]
    lines += [*stalls[1:], ""] if stalls else ["None.", ""]
    (out / "summary.md").write_text("\n".join(lines))
    summary = {
        "meta": meta,
        "confidence": CONFIDENCE,
        "ci_methods": {k: m.CI_METHODS[k] for k in sorted({r.stats.method for r in rows})},
        "metrics": {r.key: r.as_json() for r in rows},
        "consistency": consistency.summary() if consistency is not None else None,
    }
    (out / "summary.json").write_text(json.dumps(summary, indent=2, allow_nan=False) + "\n")
    plot_trajectories(out / "trajectories.png", mission, runs)
    plot_closure(out / "closure.png", mission, results)


def judge_consistency(
    out: Path, runs: Sequence[Path], title: str, closed_path: bool = True
) -> tuple[CampaignConsistency | None, list[str]]:
    """The EKF's covariance over a campaign's run folders: pooled, ``nees.png`` drawn in
    ``out``, and the summary's lines (or why it could not be judged).

    Parameters
    ----------
    out : Path
        The campaign folder.
    runs : sequence of Path
        The run folders.
    title : str
        The figure's title.
    closed_path : bool
        The runs end where they started (False: navigations, without closures).

    Returns
    -------
    consistency : CampaignConsistency or None
        None when it could not be computed.
    lines : list of str
        Markdown lines for the summary.
    """
    try:
        c = campaign_consistency([run_consistency(run) for run in runs])
    except ConsistencyError as exc:
        return None, [f"Not computed: {exc}."]
    plot_nees(out / "nees.png", c, title=title, closed_path=closed_path)
    return c, consistency_section(c)


def consistency_section(c: CampaignConsistency) -> list[str]:
    """The summary's lines on the covariance's consistency: pooled figures and ``nees.png``.

    Parameters
    ----------
    c : CampaignConsistency
        The campaign's runs pooled.

    Returns
    -------
    list of str
        Markdown lines.
    """
    lo, hi = c.runs[0].band
    a_lo, a_hi = c.average_band
    n = len(c.runs)
    summary = c.summary()
    skipped = summary["rows_skipped"]
    return [
        f"NEES e^T P^-1 e of the pose [x, y, yaw] against ground truth at every EKF output "
        f"(30 Hz) from the robot's first motion on, all {summary['rows']} rows of the {n} "
        "runs pooled; the two-sided 95 % "
        f"chi-square band with 3 degrees of freedom is [{lo:.3f}, {hi:.3f}] "
        "(docs/estimation.md).",
        "",
        "| figure | value |",
        "|---|---|",
        f"| inside the band | {c.in_band_fraction:.1%} |",
        f"| above (optimistic) | {c.above_fraction:.1%} |",
        f"| below (pessimistic) | {c.below_fraction:.1%} |",
        f"| mean NEES (3 when right) | {significant(c.nees_mean)} |",
        f"| the {n}-run average NEES inside its band [{a_lo:.3f}, {a_hi:.3f}] "
        f"| {c.average_in_band_fraction:.1%} of the time |",
        f"| end-point error within the end position's 2-sigma | {c.covered}/{n} runs |",
        "| rows left out: uninitialised, without truth, before the first motion, singular P "
        f"| {skipped['uninitialised']}, {skipped['without_truth']}, "
        f"{skipped['before_motion']}, {skipped['singular']} |",
        "",
        "![NEES over time and the end point per run](nees.png)",
    ]
