"""Tables and plots of a campaign, laid out like the paper's (Tables 5-8, Figures 5-11).

``summary.json`` holds numbers: per metric its label, unit, n, mean, SD, the 95 % CI of the
mean (from a method that keeps the interval in the quantity's domain,
:func:`jackson.experiments.metrics.mean_sd_ci`) and the paper's figures beside ours;
``summary.md`` the same as text. Every figure is written twice (:func:`save_figure`): a PNG at
:data:`FIGURE_DPI` and a PDF beside it.

Beside the paper's figures, the consistency of the EKF's covariance (NEES against the twin's
ground truth, :mod:`jackson.experiments.consistency`): rows of the table and ``nees.png``.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from jackson.common.figures import FIGURE_DPI as FIGURE_DPI  # re-exported
from jackson.common.figures import save_figure
from jackson.common.figures import vector_path as vector_path  # re-exported
from jackson.experiments import metrics as m
from jackson.experiments.consistency import (
    PAPER_OPTIMISM_GAP_CM,
    CampaignConsistency,
    ConsistencyError,
    campaign_consistency,
    plot_consistency,
    run_consistency,
    significant,
)
from jackson.experiments.trial import read_csv

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

FloatArray = npt.NDArray[np.float64]

CONFIDENCE = 0.95  # two-sided level of every CI of the summary
TRACE_STEP_M = 0.005  # [m] arc-length spacing of the plotted trajectories (a 0.5 m arc: 6 um off)
ZOOM_MIN_HALF_M = 0.01  # [m] the closure zoom spans at least 2 cm
ZOOM_MARGIN = 1.35  # the zoom's half-width over half the end points' extent


@dataclass(frozen=True)
class PaperFigure:
    """One of the paper's figures: mean ± SD, or a single value (``sd`` None).

    Attributes
    ----------
    mean : float
        The paper's mean (or its only value).
    sd : float or None
        Its SD, None when the paper gives none.
    decimals : int
        Digits after the point as the paper prints them.
    note : str
        What differs from ours ("floor": a floor-tape measurement, not ground truth).
    """

    mean: float
    sd: float | None = None
    decimals: int = 2
    note: str = ""

    @property
    def text(self) -> str:
        """As the paper prints it, e.g. ``"11.59 ± 3.14 (floor)"``."""
        d = self.decimals
        out = f"{self.mean:.{d}f}" + (f" ± {self.sd:.{d}f}" if self.sd is not None else "")
        return f"{out} ({self.note})" if self.note else out

    def as_json(self) -> dict[str, Any]:
        """``{"mean", "sd", "note"}`` (sd null when the paper gives none)."""
        return {"mean": self.mean, "sd": self.sd, "note": self.note or None}


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

_GAP_MEAN_CM, _GAP_SD_CM = PAPER_OPTIMISM_GAP_CM

# The paper's figures (REFERENCE.md, "Results to compare against"): (physical, Isaac twin).
PAPER: dict[str, dict[str, tuple[PaperFigure | None, PaperFigure | None]]] = {
    "square": {
        "ekf_closure_cm": (PaperFigure(1.18, 0.96), PaperFigure(0.95, 0.17)),
        "gt_closure_cm": (None, PaperFigure(3.39, 0.90)),
        "odom_closure_cm": (PaperFigure(36.35, 13.90), None),
        "ekf_final_heading_deg": (PaperFigure(1.41, 1.02), None),
        "odom_final_heading_deg": (PaperFigure(25.97, 10.21), None),
        "ekf_cross_track_rmse_cm": (PaperFigure(2.46, 0.36), None),
        "ekf_position_rmse_vs_gt_cm": (None, PaperFigure(1.70, 0.55)),
        "ekf_yaw_rmse_vs_gt_deg": (None, PaperFigure(0.97, 0.24)),
        "ekf_path_m": (
            PaperFigure(4.133, 0.020, decimals=3),
            PaperFigure(3.9877, 0.0109, decimals=4),
        ),
        "duration_s": (PaperFigure(47.52, 0.26), PaperFigure(67.17, 0.15)),
    },
    "figure8": {
        "gt_loop_diameter_ccw_m": (
            PaperFigure(1.0795, 0.0167, decimals=4, note="floor"),
            PaperFigure(1.0429, decimals=4),
        ),
        "gt_loop_diameter_cw_m": (
            PaperFigure(1.1280, 0.0322, decimals=4, note="floor"),
            PaperFigure(1.0187, decimals=4),
        ),
        "gt_closure_cm": (PaperFigure(11.59, 3.14, note="floor"), PaperFigure(7.08, 0.41)),
        "ekf_closure_cm": (PaperFigure(6.90, 0.73), PaperFigure(1.92, 0.10)),
        "odom_closure_cm": (PaperFigure(207.0, 26.0, decimals=0), None),
        "optimism_gap_cm": (PaperFigure(_GAP_MEAN_CM, _GAP_SD_CM), PaperFigure(5.16, 0.41)),
        "ekf_final_heading_deg": (PaperFigure(1.42, 0.22), PaperFigure(1.41, 0.15)),
        "ekf_max_cross_track_cm": (PaperFigure(22.52, 3.04), None),
        "ekf_path_m": (PaperFigure(6.96, 0.11), None),
        "duration_s": (PaperFigure(96.43, 2.07), PaperFigure(98.26, 0.04)),
    },
}
"""The paper's physical robot and Isaac Sim twin per mission and metric (None: not given)."""

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
    consistency: CampaignConsistency | None = None
    try:
        consistency = campaign_consistency([run_consistency(run) for run in runs])
    except ConsistencyError as exc:
        consistency_lines = [f"Not computed: {exc}."]
    else:
        consistency_lines = consistency_section(consistency)
        plot_nees(out / "nees.png", consistency, title=mission)
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
        f"(30 Hz), all {summary['rows']} rows of the {n} runs pooled; the two-sided 95 % "
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
        f"| rows left out: uninitialised, without truth, singular P | {skipped['uninitialised']}, "
        f"{skipped['without_truth']}, {skipped['singular']} |",
        "",
        "![NEES over time and the end point per run](nees.png)",
    ]


# ---- figures -----------------------------------------------------------------------------------


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_nees(png: Path, campaign: CampaignConsistency, title: str = "") -> None:
    """``nees.png`` (:func:`jackson.experiments.consistency.plot_consistency`) and its PDF.

    Parameters
    ----------
    png : Path
        The PNG; the PDF is :func:`vector_path` of it.
    campaign : CampaignConsistency
        The runs.
    title : str
        Title of the top panel.
    """
    plot_consistency(png, campaign, title=title)  # draws once, saves both (save_figure)


@dataclass(frozen=True)
class Trace:
    """A trajectory anchored at (0, 0, 0) (its first pose), thinned for plotting.

    Attributes
    ----------
    x_m, y_m : ndarray, shape (N,)
        Positions [m], the first at the origin, the last the true end point.
    """

    x_m: FloatArray
    y_m: FloatArray

    @property
    def end(self) -> tuple[float, float]:
        """The end point [m]; its distance to the origin is the closure error."""
        return float(self.x_m[-1]), float(self.y_m[-1])


def anchored_trace(csv_path: Path, step_m: float = TRACE_STEP_M) -> Trace:
    """A pose CSV anchored at its first pose (as the metrics do) and thinned by arc length.

    Consecutive points closer than ``step_m`` along the path are dropped (the first and last
    are kept), so the 200 Hz ground truth of a 4 m square plots as about 800 points.

    Parameters
    ----------
    csv_path : Path
        ``ground_truth.csv``, ``ekf.csv`` or ``odometry.csv`` (columns x_m, y_m, yaw_rad).
    step_m : float
        Arc-length spacing of the kept points [m].

    Returns
    -------
    Trace
    """
    d = read_csv(csv_path)
    x, y = d["x_m"] - d["x_m"][0], d["y_m"] - d["y_m"][0]
    c, s = math.cos(-d["yaw_rad"][0]), math.sin(-d["yaw_rad"][0])
    ax_m, ay_m = c * x - s * y, s * x + c * y
    arc = np.concatenate(([0.0], np.cumsum(np.hypot(np.diff(ax_m), np.diff(ay_m)))))
    _, first = np.unique(np.floor(arc / step_m), return_index=True)
    keep = np.union1d(first, [len(arc) - 1])
    return Trace(np.asarray(ax_m[keep], np.float64), np.asarray(ay_m[keep], np.float64))


SOURCES = (  # (file, label, line style, end marker, colour of a single run)
    ("ground_truth.csv", "ground truth", "-", "o", "C0"),
    ("ekf.csv", "EKF", "--", "s", "C2"),
    ("odometry.csv", "raw wheel odometry", ":", "^", "C3"),
)


def run_colours(n: int) -> list[Any]:
    """One colour per run: tab10 up to 10 runs, tab20 up to 20, viridis beyond.

    Parameters
    ----------
    n : int
        Number of runs.

    Returns
    -------
    list
        RGBA colours, run order.
    """
    import matplotlib

    if n <= 10:
        return [matplotlib.colormaps["tab10"](i) for i in range(n)]
    if n <= 20:
        return [matplotlib.colormaps["tab20"](i) for i in range(n)]
    return [matplotlib.colormaps["viridis"](i / (n - 1)) for i in range(n)]


def _run_colourbar(fig: Figure, axes: list[Axes], names: Sequence[str]) -> None:
    """A discrete colourbar naming the runs (every k-th label when there are many)."""
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import BoundaryNorm, ListedColormap

    n = len(names)
    cmap = ListedColormap(run_colours(n))
    norm = BoundaryNorm(np.arange(n + 1) - 0.5, n)
    bar = fig.colorbar(
        ScalarMappable(norm=norm, cmap=cmap), ax=axes, shrink=0.8, pad=0.02, aspect=30
    )
    every = max(1, math.ceil(n / 12))
    ticks = list(range(0, n, every))
    bar.set_ticks(ticks, labels=[names[i] for i in ticks])
    bar.ax.tick_params(labelsize=8, length=0)
    bar.ax.invert_yaxis()
    bar.set_label("run", fontsize=9)


def closure_zoom(ends: Sequence[tuple[float, float]]) -> tuple[float, float, float]:
    """The square window around the start and the end points: (centre x, centre y, half) [m].

    Centred on the box holding the origin (every run's start) and ``ends``, its half-width
    :data:`ZOOM_MARGIN` times half the box's larger side, at least :data:`ZOOM_MIN_HALF_M`:
    a window a few centimetres across, scaled to the closure errors.

    Parameters
    ----------
    ends : sequence of (x, y)
        End points of the traces the zoom must show [m].

    Returns
    -------
    tuple of float
    """
    pts = np.array([(0.0, 0.0), *ends], dtype=np.float64)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    centre = 0.5 * (lo + hi)
    half = max(ZOOM_MIN_HALF_M, ZOOM_MARGIN * 0.5 * float(np.max(hi - lo)))
    return float(centre[0]), float(centre[1]), half


def plot_trajectories(png: Path, mission: str, runs: list[Path]) -> None:
    """Ground truth, EKF and raw wheel odometry of every run, with a zoom at the closure.

    Left, the whole path (every run anchored at (0, 0, 0), the nominal path under them);
    right, a window a few centimetres across around the start and the ground-truth and EKF
    end points (:func:`closure_zoom`), marked on the left, where the centimetres between
    ground truth and EKF that the closure errors measure are visible. Line style tells the
    source (ground truth solid, EKF dashed, odometry dotted), the end marker too (circle,
    square, triangle), the start is a star; with several runs, colour tells the run (a
    colourbar names them), with one the source. Written as PNG and PDF (:func:`save_figure`).

    Parameters
    ----------
    png : Path
        The PNG (``trajectories.png`` of a campaign, ``trajectory.png`` of a run).
    mission : str
        "square" or "figure8" (the nominal path).
    runs : list of Path
        Run folders with ``ground_truth.csv``, ``ekf.csv`` and ``odometry.csv``.
    """
    plt = _pyplot()
    from matplotlib.lines import Line2D
    from matplotlib.ticker import FuncFormatter

    n = len(runs)
    traces = [[anchored_trace(run / f) for f, *_ in SOURCES] for run in runs]
    colours = run_colours(n)
    path = m.square_path() if mission == "square" else m.figure_eight_path()
    fig, (ax, zx) = plt.subplots(
        1, 2, figsize=(11.0, 6.2), layout="constrained", gridspec_kw={"width_ratios": [1, 1]}
    )
    gt_ends = [t[0].end for t in traces]
    ekf_ends = [t[1].end for t in traces]
    cx, cy, half = closure_zoom(gt_ends + ekf_ends)
    for panel, lw in ((ax, 0.8), (zx, 1.3)):
        panel.plot(path[:, 0], path[:, 1], color="0.75", lw=3.0 if panel is ax else 5.0, zorder=0)
        for i, run_traces in enumerate(traces):
            for trace, (_, _, style, marker, source_colour) in zip(
                run_traces, SOURCES, strict=True
            ):
                colour = source_colour if n == 1 else colours[i]
                panel.plot(trace.x_m, trace.y_m, style, color=colour, lw=lw, alpha=0.9)
                panel.plot(
                    *trace.end,
                    marker,
                    color=colour,
                    mec="k",
                    mew=0.6,
                    ms=5 if panel is ax else 8,
                    zorder=4,
                )
        panel.plot(0.0, 0.0, "*", color="gold", mec="k", mew=0.8, ms=11 if panel is ax else 16)
        panel.set_aspect("equal")
        panel.grid(alpha=0.3)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    zx.set_xlim(cx - half, cx + half)
    zx.set_ylim(cy - half, cy + half)
    cm = FuncFormatter(lambda v, _: f"{v * 100:.3g}")
    zx.xaxis.set_major_formatter(cm)
    zx.yaxis.set_major_formatter(cm)
    zx.set_xlabel("x (cm)")
    zx.set_ylabel("y (cm)")
    ax.indicate_inset_zoom(zx, edgecolor="k", alpha=0.8)
    gt_cm = [math.hypot(*e) * 100 for e in gt_ends]
    ekf_cm = [math.hypot(*e) * 100 for e in ekf_ends]

    def spread(v: list[float]) -> str:
        return f"{np.mean(v):.1f} ± {np.std(v, ddof=1):.1f} cm" if len(v) > 1 else f"{v[0]:.1f} cm"

    zx.set_title(
        f"at the closure ({2 * half * 100:.3g} cm across): ground truth {spread(gt_cm)}, "
        f"EKF {spread(ekf_cm)}",
        fontsize=9,
    )
    odom_out = sum(1 for t in traces if max(abs(t[2].end[0] - cx), abs(t[2].end[1] - cy)) > half)
    if odom_out:
        zx.text(
            0.02,
            0.02,
            f"raw odometry ends outside this window in {odom_out}/{n} runs",
            transform=zx.transAxes,
            fontsize=8,
            color="0.3",
        )
    runs_text = f"{n} runs" if n > 1 else "one run"
    name = {"square": "1 m square", "figure8": "figure-eight"}.get(mission, mission)
    fig.suptitle(f"{name} on the twin, {runs_text}", fontsize=11)
    handles = [
        Line2D([], [], color="0.75", lw=3, label="nominal path"),
        Line2D([], [], color="gold", marker="*", mec="k", ls="none", ms=11, label="start"),
    ]
    for _, label, style, marker, source_colour in SOURCES:
        colour = source_colour if n == 1 else "k"
        handles.append(Line2D([], [], color=colour, ls=style, lw=1.2, label=label))
        handles.append(
            Line2D(
                [],
                [],
                color=colour if n == 1 else "w",
                marker=marker,
                mec="k",
                ls="none",
                ms=7,
                label=f"{label} end",
            ),
        )
    fig.legend(handles=handles, loc="outside lower center", ncol=4, fontsize=8, frameon=False)
    if n > 1:
        _run_colourbar(fig, [ax, zx], [run.name for run in runs])
    save_figure(fig, png)


def _bar_label(ax: Axes, x: float, top: float, text: str) -> None:
    ax.annotate(text, (x, top), xytext=(0, 4), textcoords="offset points", ha="center", fontsize=7)


CLOSURE_BARS = (  # (which, face colour, hatch, legend): light faces, so run-coloured dots show
    ("ours", "#c6dbef", "", "ours, twin"),
    ("physical", "#d9d9d9", "//", "paper, physical robot"),
    ("isaac", "#fdd0a2", "\\\\", "paper, Isaac Sim twin"),
)


def plot_closure(png: Path, mission: str, results: Sequence[dict[str, Any]]) -> None:
    """Closure errors on linear axes: ours (mean ± SD and each run) beside the paper's.

    Left, ground-truth closure, EKF closure and the optimism gap between them (cm); right,
    the raw wheel odometry's closure on its own axis (it is ten to a hundred times larger).
    Per metric three bars, mean ± SD: ours on the twin, the paper's physical robot, its
    Isaac Sim twin ("n/a" where the paper gives none); our runs are dots over our bar,
    coloured as in the trajectory plot. Written as PNG and PDF (:func:`save_figure`).

    Parameters
    ----------
    png : Path
        ``closure.png``.
    mission : str
        "square" or "figure8" (selects the paper's figures).
    results : sequence of dict
        Per-run metrics in run order.
    """
    plt = _pyplot()
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    n = len(results)
    colours = run_colours(n)
    paper = PAPER.get(mission, {})
    panels = (("gt_closure_cm", "ekf_closure_cm", "optimism_gap_cm"), ("odom_closure_cm",))
    names = {
        "gt_closure_cm": "ground-truth\nclosure",
        "ekf_closure_cm": "EKF\nclosure",
        "optimism_gap_cm": "optimism gap\nGT - EKF",
        "odom_closure_cm": "raw wheel-odometry\nclosure",
    }
    width = 0.26
    rng = np.random.default_rng(0)
    fig, axes = plt.subplots(
        1, 2, figsize=(9.0, 4.4), layout="constrained", gridspec_kw={"width_ratios": [3, 1.25]}
    )
    floor_note = False
    for ax, keys in zip(axes, panels, strict=True):
        for g, key in enumerate(keys):
            values = np.array(
                [float(r[key]) for r in results if r.get(key) is not None], dtype=np.float64
            )
            phys, isaac = paper.get(key, (None, None))
            for b, (which, face, hatch, _) in enumerate(CLOSURE_BARS):
                x = g + (b - 1) * width
                if which == "ours":
                    if not values.size:
                        continue
                    mean = float(np.mean(values))
                    sd = float(np.std(values, ddof=1)) if values.size > 1 else math.nan
                    text = f"{mean:.2f}" if abs(mean) < 100 else f"{mean:.0f}"
                else:
                    figure = phys if which == "physical" else isaac
                    if figure is None:
                        ax.text(x, 0, "n/a", ha="center", va="bottom", fontsize=7, color="0.4")
                        continue
                    mean, sd = figure.mean, figure.sd if figure.sd is not None else math.nan
                    text = f"{figure.mean:.{figure.decimals}f}"
                    floor_note |= figure.note == "floor"
                err = sd if math.isfinite(sd) else 0.0
                ax.bar(x, mean, width, color=face, hatch=hatch, edgecolor="k", lw=0.6)
                if err:
                    ax.errorbar(x, mean, yerr=err, color="k", capsize=3, lw=1.0)
                top = max(mean + err, float(np.max(values)) if which == "ours" else 0.0, 0.0)
                _bar_label(ax, x, top, text)
                if which == "ours":
                    jitter = rng.uniform(-0.3, 0.3, values.size) * width
                    ax.scatter(
                        x + jitter,
                        values,
                        s=18,
                        c=colours[: values.size],
                        edgecolors="k",
                        linewidths=0.5,
                        zorder=5,
                    )
        ax.set_xticks(range(len(keys)), [names[k] for k in keys], fontsize=9)
        ax.set_xlim(-0.5, len(keys) - 0.5)
        ax.axhline(0.0, color="k", lw=0.6)
        ax.set_ylabel("cm")
        ax.grid(axis="y", alpha=0.3)
        ax.margins(y=0.12)
    handles: list[Any] = [
        Patch(facecolor=face, hatch=hatch, edgecolor="k", lw=0.6, label=label)
        for _, face, hatch, label in CLOSURE_BARS
    ]
    handles.append(
        Line2D([], [], marker="o", ls="none", mfc="0.6", mec="k", label="each of our runs")
    )
    fig.legend(handles=handles, loc="outside lower center", ncol=4, fontsize=8, frameon=False)
    runs_text = f"{n} runs" if n > 1 else "one run"
    name = {"square": "1 m square", "figure8": "figure-eight"}.get(mission, mission)
    fig.suptitle(f"{name}: closure error, mean ± SD (ours over {runs_text})", fontsize=10)
    if floor_note:
        axes[0].set_title(
            "the physical robot's ground-truth closure is a floor measurement", fontsize=8
        )
    save_figure(fig, png)
