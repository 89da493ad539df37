"""``fidelity.png``: one small panel per figure, our trials beside the paper's band."""

from __future__ import annotations

import math
import textwrap
from pathlib import Path
from typing import Any

import numpy as np

from jackson.experiments.fidelity.report import FidelityReport, seeds_text
from jackson.experiments.fidelity.verdicts import FigureResult, agreement_line

PNG_DPI = 120  # the overview's 20 panels at 1500 x 1650 pixels
TITLE_CHARS = 48  # a panel's title wraps after this many characters
WITHIN_COLOUR = "tab:green"
OUTSIDE_COLOUR = "tab:red"
NO_VALUE_COLOUR = "0.6"
BAND_1SD = "0.82"
BAND_2SD = "0.92"


def _marker_colour(row: FigureResult) -> str:
    if row.within is None:
        return NO_VALUE_COLOUR
    return WITHIN_COLOUR if row.within else OUTSIDE_COLOUR


def _panel(ax: Any, row: FigureResult, rng: np.random.Generator) -> None:
    """One figure: the paper's band and mean, our trials (jittered) and our mean ± SD."""
    f = row.figure
    mean, sd = f.paper_mean, f.paper_sd
    if f.within_sd > 1.0:
        k = f.within_sd
        ax.axhspan(mean - k * sd, mean + k * sd, color=BAND_2SD, lw=0, zorder=0)
    ax.axhspan(mean - sd, mean + sd, color=BAND_1SD, lw=0, zorder=1)
    ax.axhline(mean, color="0.3", lw=1.0, zorder=2)
    if row.values:
        x = rng.uniform(-0.22, 0.22, row.n)
        ax.scatter(x, row.values, s=13, color="tab:blue", alpha=0.8, lw=0, zorder=3)
        err = row.sd if math.isfinite(row.sd) else None
        ax.errorbar(
            1.0,
            row.mean,
            yerr=err,
            fmt="s",
            color=OUTSIDE_COLOUR if not row.within else "k",
            ms=5,
            capsize=4,
            lw=1.3,
            zorder=4,
        )
        detail = f"z {row.z:+.2f}"
        if row.sd_ok is not None:
            detail += f", SD \u00d7{row.sd_ratio:.2f}"
    else:
        ax.text(
            0.5,
            0.5,
            row.missing,
            transform=ax.transAxes,
            ha="center",
            va="center",
            fontsize=8,
            color="0.3",
        )
        detail = "no value"
    ax.set_xlim(-0.6, 1.5)
    ax.set_xticks([0.0, 1.0], ["trials", "ours"], fontsize=7)
    ax.tick_params(axis="y", labelsize=7)
    ax.grid(axis="y", alpha=0.25)
    head = textwrap.fill(f"{f.stage}: {f.label}", TITLE_CHARS)
    title = ax.set_title(f"{head}\n({f.table}) {detail}", fontsize=7.5)
    ax.annotate(
        "●",
        xy=(0.0, 0.5),
        xycoords=title,
        xytext=(-3, 0),
        textcoords="offset points",
        ha="right",
        va="center",
        fontsize=11,
        color=_marker_colour(row),
    )


def plot_fidelity(png: Path, report: FidelityReport) -> None:
    """``fidelity.png``: one small panel per figure (16 Stage 1-2, 3 Stage 3) and a legend.

    Each panel: the paper's mean (line) and mean ± SD (grey band; Stage 3 also ± 2 SD, lighter),
    our completed trials as dots (jittered), our mean ± SD as an error bar, and a dot before
    the title: green when our mean is within the paper's band, red outside, grey without a
    value. The title's second line gives z and our SD over the paper's.

    Parameters
    ----------
    png : Path
        The PNG to write.
    report : FidelityReport
        The figures.
    """
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    from jackson.experiments.report_plots import pyplot

    plt = pyplot()
    rows = [*report.figures, *report.stage3]
    ncols = 4
    nrows = math.ceil((len(rows) + 1) / ncols)
    fig, axes = plt.subplots(
        nrows, ncols, figsize=(12.5, 2.6 * nrows + 0.6), layout="constrained", squeeze=False
    )
    rng = np.random.default_rng(0)
    flat = list(axes.flat)
    for ax, row in zip(flat, rows, strict=False):
        _panel(ax, row, rng)
    for ax in flat[len(rows) :]:
        ax.axis("off")
    legend = flat[len(rows)]
    handles = [
        Line2D([], [], color="0.3", lw=1.0, label="the paper's mean"),
        Patch(color=BAND_1SD, label="the paper's mean ± 1 SD"),
        Patch(color=BAND_2SD, label="± 2 SD (Stage 3's criterion)"),
        Line2D([], [], marker="o", ls="none", color="tab:blue", ms=4, label="our trials"),
        Line2D([], [], marker="s", color="k", ms=5, label="our mean ± SD (red: outside)"),
        Line2D([], [], marker="o", ls="none", color=WITHIN_COLOUR, ms=7, label="within"),
        Line2D([], [], marker="o", ls="none", color=OUTSIDE_COLOUR, ms=7, label="outside"),
    ]
    legend.legend(handles=handles, loc="upper left", fontsize=8, frameon=False)
    legend.text(
        0.0,
        0.02,
        textwrap.fill(agreement_line(report.agreement), 44),
        transform=legend.transAxes,
        fontsize=8,
        va="bottom",
        wrap=True,
    )
    seeds = seeds_text(report.seed, report.trials)
    fig.suptitle(
        f"{report.robot} on the twin against the paper's physical robot: {report.trials} "
        f"trials per stage ({seeds})",
        fontsize=10,
    )
    png.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(png, dpi=PNG_DPI)
    plt.close(fig)
