"""The figures of a campaign's report, laid out like the paper's (Figures 5-11).

Trajectories with a zoom at the closure (:func:`plot_trajectories`), closure errors beside the
paper's (:func:`plot_closure`) and the EKF's consistency (:func:`plot_nees`). Every figure of a
campaign is written twice (:func:`jackson.common.figures.save_figure`): a PNG at
:data:`jackson.common.figures.FIGURE_DPI` and a PDF beside it (``jackson run``'s plot: the PDF
with ``--pdf``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from jackson.common.figures import save_figure
from jackson.experiments import metrics as m
from jackson.experiments.consistency import CampaignConsistency, plot_consistency
from jackson.experiments.paper_figures import PAPER
from jackson.experiments.run_csv import read_csv

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

FloatArray = npt.NDArray[np.float64]

TRACE_STEP_M = 0.005  # [m] arc-length spacing of the plotted trajectories (a 0.5 m arc: 6 um off)
ZOOM_MIN_HALF_M = 0.01  # [m] the closure zoom spans at least 2 cm
ZOOM_MARGIN = 1.35  # the zoom's half-width over half the end points' extent


def pyplot() -> Any:
    """Matplotlib's pyplot on the Agg backend: figures are written to files, never shown."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_nees(
    png: Path, campaign: CampaignConsistency, title: str = "", closed_path: bool = True
) -> None:
    """``nees.png`` (:func:`jackson.experiments.consistency.plot_consistency`) and its PDF.

    Parameters
    ----------
    png : Path
        The PNG; the PDF is :func:`jackson.common.figures.vector_path` of it.
    campaign : CampaignConsistency
        The runs.
    title : str
        Title of the top panel.
    closed_path : bool
        The runs end where they started (False: a navigation, without closures).
    """
    plot_consistency(png, campaign, title=title, closed_path=closed_path)  # saves PNG and PDF


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


def plot_trajectories(png: Path, mission: str, runs: list[Path], vector: bool = True) -> None:
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
    vector : bool
        Also write the PDF (False: the PNG only).
    """
    plt = pyplot()
    from matplotlib.ticker import FuncFormatter

    n = len(runs)
    traces = [[anchored_trace(run / f) for f, *_ in SOURCES] for run in runs]
    colours = run_colours(n)
    path = m.square_path() if mission == "square" else m.figure_eight_path()
    # one run's figure (jackson run's, drawn while the command waits) in fixed margins: the
    # constrained layout measured every tick label first, a third of its 0.5 s; a campaign's
    # figure keeps it, for its colour bar of runs
    fig, (ax, zx) = plt.subplots(
        1,
        2,
        figsize=(11.0, 6.2),
        layout="constrained" if n > 1 else None,
        gridspec_kw={"width_ratios": [1, 1]},
    )
    if n == 1:
        fig.subplots_adjust(left=0.065, right=0.985, bottom=0.15, top=0.9, wspace=0.17)
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
    _trajectory_legend(fig, n)
    if n > 1:
        _run_colourbar(fig, [ax, zx], [run.name for run in runs])
    save_figure(fig, png, vector=vector)


def _trajectory_legend(fig: Figure, n: int) -> None:
    """The legend under :func:`plot_trajectories`' panels: the sources' lines and ends, in
    their colours for one run (in black, the runs coloured by the colour bar, for several)."""
    from matplotlib.lines import Line2D

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
    where = "outside lower center" if n > 1 else "lower center"
    fig.legend(handles=handles, loc=where, ncol=4, fontsize=8, frameon=False)


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
    plt = pyplot()
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
