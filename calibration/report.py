"""Tables and plots of a campaign, laid out like the paper's (Tables 5-8, Figures 5-11).

Beside the paper's figures, the consistency of the EKF's covariance (NEES against the twin's
ground truth, :mod:`jackson.calibration.consistency`): rows of the table and ``nees.png``.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from jackson.calibration import metrics as m
from jackson.calibration.consistency import (
    CampaignConsistency,
    ConsistencyError,
    campaign_consistency,
    plot_consistency,
    run_consistency,
    significant,
)
from jackson.calibration.trial import read_csv

# The paper's figures (REFERENCE.md, "Results to compare against"): (physical, Isaac twin).
PAPER: dict[str, dict[str, tuple[str, str]]] = {
    "square": {
        "ekf_closure_cm": ("1.18 ± 0.96", "0.95 ± 0.17"),
        "gt_closure_cm": ("—", "3.39 ± 0.90"),
        "odom_closure_cm": ("36.35 ± 13.90", "—"),
        "ekf_final_heading_deg": ("1.41 ± 1.02", "—"),
        "odom_final_heading_deg": ("25.97 ± 10.21", "—"),
        "ekf_cross_track_rmse_cm": ("2.46 ± 0.36", "—"),
        "ekf_position_rmse_vs_gt_cm": ("—", "1.70 ± 0.55"),
        "ekf_yaw_rmse_vs_gt_deg": ("—", "0.97 ± 0.24"),
        "duration_s": ("47.52 ± 0.26", "67.17 ± 0.15"),
    },
    "figure8": {
        "gt_loop_diameter_ccw_m": ("1.0795 ± 0.0167 (floor)", "1.0429"),
        "gt_loop_diameter_cw_m": ("1.1280 ± 0.0322 (floor)", "1.0187"),
        "gt_closure_cm": ("11.59 ± 3.14 (floor)", "7.08 ± 0.41"),
        "ekf_closure_cm": ("6.90 ± 0.73", "1.92 ± 0.10"),
        "odom_closure_cm": ("207 ± 26", "—"),
        "optimism_gap_cm": ("4.69 ± 2.82", "5.16 ± 0.41"),
        "ekf_final_heading_deg": ("1.42 ± 0.22", "1.41 ± 0.15"),
        "duration_s": ("96.43 ± 2.07", "98.26 ± 0.04"),
    },
}
LABELS = {
    "gt_closure_cm": "Ground-truth closure (cm)",
    "ekf_closure_cm": "EKF closure (cm)",
    "odom_closure_cm": "Raw wheel-odometry closure (cm)",
    "optimism_gap_cm": "Estimator optimism gap, GT - EKF (cm)",
    "nees_in_band_fraction": "NEES of [x, y, yaw] inside the 95 % band (share of time)",
    "nees_above_fraction": "NEES above the band: optimistic (share of time)",
    "nees_below_fraction": "NEES below the band: pessimistic (share of time)",
    "nees_mean": "Mean NEES (3 when the covariance is right)",
    "nees_xy_mean": "Mean NEES of the position alone (2 when right)",
    "nees_yaw_mean": "Mean NEES of the heading alone (1 when right)",
    "end_error_cm": "EKF end-point error vs ground truth (cm)",
    "end_position_2sigma_cm": "Covariance 2-sigma of the end position (cm)",
    "end_error_covered": "End-point error within that 2-sigma (share of runs)",
    "ekf_final_heading_deg": "EKF final heading error (deg)",
    "gt_final_heading_deg": "Ground-truth final heading error (deg)",
    "odom_final_heading_deg": "Raw-odometry final heading error (deg)",
    "ekf_cross_track_rmse_cm": "EKF cross-track RMSE (cm)",
    "gt_cross_track_rmse_cm": "Ground-truth cross-track RMSE (cm)",
    "odom_cross_track_rmse_cm": "Raw-odometry cross-track RMSE (cm)",
    "ekf_position_rmse_vs_gt_cm": "EKF position RMSE vs ground truth (cm)",
    "ekf_yaw_rmse_vs_gt_deg": "EKF yaw RMSE vs ground truth (deg)",
    "gt_loop_diameter_ccw_m": "CCW loop diameter, ground truth (m)",
    "gt_loop_diameter_cw_m": "CW loop diameter, ground truth (m)",
    "duration_s": "Duration from time zero (s)",
    "real_time_factor": "Real-time factor of the trial",
}
# figures that span decades: three significant digits instead of two decimals
SIGNIFICANT = frozenset({"nees_mean", "nees_xy_mean", "nees_yaw_mean", "end_position_2sigma_cm"})


def _number(key: str, value: float) -> str:
    return significant(value) if key in SIGNIFICANT else f"{value:.2f}"


def summary_rows(
    mission: str, results: list[dict[str, Any]]
) -> list[tuple[str, str, str, str, str]]:
    """(metric, ours mean ± SD, 95 % CI, paper physical, paper Isaac) per metric."""
    rows = []
    for key, label in LABELS.items():
        values = [float(r[key]) for r in results if key in r]
        if not values:
            continue
        s = m.mean_sd_ci(values)
        if len(values) > 1:
            ours = f"{_number(key, s.mean)} ± {_number(key, s.sd)}"
            ci = f"[{_number(key, s.ci_low)}, {_number(key, s.ci_high)}]"
        else:
            ours, ci = _number(key, s.mean), "—"
        phys, isaac = PAPER.get(mission, {}).get(key, ("—", "—"))
        rows.append((label, ours, ci, phys, isaac))
    return rows


def write_report(
    out: Path, mission: str, results: list[dict[str, Any]], meta: dict[str, Any]
) -> None:
    """summary.md, summary.json and the plots of a campaign folder."""
    out.mkdir(parents=True, exist_ok=True)
    rows = summary_rows(mission, results)
    runs = [out / "runs" / f"R{i + 1:02d}" for i in range(len(results))]
    consistency: CampaignConsistency | None = None
    try:
        consistency = campaign_consistency([run_consistency(run) for run in runs])
    except ConsistencyError as exc:
        consistency_lines = [f"Not computed: {exc}."]
    else:
        consistency_lines = consistency_section(consistency)
        plot_consistency(out / "nees.png", consistency, title=mission)
    done = sum(1 for r in results if r.get("completed"))
    title = {"square": "Stage 1, 1 m square", "figure8": "Stage 2, figure-eight"}[mission]
    lines = [
        f"# {title}: {len(results)} trials on the twin",
        "",
        f"Robot `{meta['robot']}`, world `{meta['world']}`, seed {meta['seed']}, "
        f"{meta['workers']} workers, {meta['wall_s']:.1f} s wall time; {done}/{len(results)} "
        "completed. Ours: mean ± SD with the t-based 95 % CI; the paper's physical robot and "
        "Isaac Sim twin beside them.",
        "",
        "| metric | ours | 95 % CI | paper, physical | paper, Isaac twin |",
        "|---|---|---|---|---|",
        *[f"| {a} | {b} | {c} | {d} | {e} |" for a, b, c, d, e in rows],
        "",
        "![trajectories](trajectories.png)",
        "",
        "![per-run closure](closure.png)",
        "",
        "## Consistency of the EKF's covariance",
        "",
        *consistency_lines,
        "",
    ]
    (out / "summary.md").write_text("\n".join(lines))
    (out / "summary.json").write_text(
        json.dumps(
            {
                "meta": meta,
                "rows": [
                    dict(
                        zip(
                            ("metric", "ours", "ci95", "paper_physical", "paper_isaac"),
                            r,
                            strict=True,
                        )
                    )
                    for r in rows
                ],
                "consistency": consistency.summary() if consistency is not None else None,
            },
            indent=2,
        )
        + "\n"
    )
    plot_trajectories(out / "trajectories.png", mission, runs)
    plot_closure(out, results)


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


def plot_trajectories(png: Path, mission: str, runs: list[Path]) -> None:
    """Ground truth vs raw wheel odometry vs EKF, every run anchored at (0, 0, 0)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 6.0))
    path = m.square_path() if mission == "square" else m.figure_eight_path()
    ax.plot(path[:, 0], path[:, 1], "k:", lw=1, label="nominal path")
    for i, run in enumerate(runs):
        for name, style, label in (
            ("ground_truth.csv", "C0-", "ground truth"),
            ("odometry.csv", "C3--", "raw wheel odometry"),
            ("ekf.csv", "C2-", "EKF"),
        ):
            d = read_csv(run / name)
            x, y = d["x_m"] - d["x_m"][0], d["y_m"] - d["y_m"][0]
            c, s = np.cos(-d["yaw_rad"][0]), np.sin(-d["yaw_rad"][0])
            ax.plot(
                c * x - s * y,
                s * x + c * y,
                style,
                lw=0.8,
                alpha=0.8,
                label=label if i == 0 else None,
            )
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.grid(alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    runs_text = f"{len(runs)} runs" if len(runs) > 1 else "one run"
    ax.set_title(f"{mission} on the twin: ground truth, raw odometry and EKF ({runs_text})")
    fig.tight_layout()
    fig.savefig(png, dpi=110)
    plt.close(fig)


def plot_closure(out: Path, results: list[dict[str, Any]]) -> None:
    """Per-run closure error bars: ground truth, EKF, raw odometry."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = len(results)
    idx = np.arange(n)
    fig, ax = plt.subplots(figsize=(7.0, 3.6))
    for k, (key, label, color) in enumerate(
        (
            ("gt_closure_cm", "ground truth", "C0"),
            ("ekf_closure_cm", "EKF", "C2"),
            ("odom_closure_cm", "raw odometry", "C3"),
        )
    ):
        ax.bar(idx + (k - 1) * 0.27, [r[key] for r in results], 0.27, label=label, color=color)
    ax.set_xticks(idx, [f"R{i + 1:02d}" for i in idx])
    ax.set_ylabel("closure error (cm)")
    ax.set_yscale("log")
    ax.grid(axis="y", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "closure.png", dpi=110)
    plt.close(fig)
