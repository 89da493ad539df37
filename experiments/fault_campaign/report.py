"""The fault campaign's report: its markdown tables and its figure."""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from jackson.experiments.fault_campaign.cases import (
    BLIND_LIMIT_M,
    CONFIDENCE,
    DETECTION_TARGET,
    SENSORS,
)
from jackson.experiments.fault_campaign.records import RunRecord
from jackson.experiments.stall_retry import stall_lines

if TYPE_CHECKING:  # the twin and the host load when a campaign runs, not for jackson --help
    pass


# --------------------------------------------------------------------------- report


def write_report(out: Path, summary: Mapping[str, Any], records: Sequence[RunRecord]) -> None:
    """``runs.json``, ``summary.json``, ``summary.md`` and ``faults.png`` in ``out``.

    Parameters
    ----------
    out : Path
        The report folder.
    summary : Mapping
        :func:`summarise`'s result.
    records : sequence of RunRecord
        Every run.
    """
    runs = [dataclasses.asdict(r) | {"ended": r.ended} for r in records]
    for r in runs:
        r["transitions"] = [t._asdict() for t in r["transitions"]]
    (out / "runs.json").write_text(json.dumps(runs, indent=2) + "\n")
    (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    (out / "summary.md").write_text(summary_markdown(summary))
    plot_faults(out / "faults.png", summary)


def _pm(s: Mapping[str, Any], digits: int = 2) -> str:
    if s["mean"] is None:
        return "-"
    sd = "" if s["sd"] is None else f" ± {s['sd']:.{digits}f}"
    return f"{s['mean']:.{digits}f}{sd} ({s['n']})"


def _seconds(x: float | None) -> str:
    return "-" if x is None else f"{x:.2f}"


def _per_h(rate: Mapping[str, Any]) -> str:
    if rate["per_hour"] is None:
        return "- (no driving)"
    upper = rate["upper_per_hour"]
    return f"{rate['count']} ({rate['per_hour']:.2f} /h, ≤ {upper:.2f} /h at {CONFIDENCE:.0%})"


def summary_markdown(summary: Mapping[str, Any]) -> str:
    """The report's tables (detection, closure, false alarms) as Markdown.

    Parameters
    ----------
    summary : Mapping
        :func:`summarise`'s result.

    Returns
    -------
    str
        ``summary.md``.
    """
    cases = summary["cases"]
    maze = [c for c in cases if c["mission"] == "maze"]
    lines = _detection_lines(summary["meta"], cases, maze)
    lines += _closure_lines([c for c in cases if c["mission"] != "maze"])  # the maze: no loop
    if maze:
        lines += _navigation_markdown(maze)
    lines += _false_alarm_lines(summary["false_alarms"])
    stalls = summary.get("stalls", [])
    lines += ["", "## Lockstep stalls (the machine's failures, not the robot's)", ""]
    lines += stall_lines(stalls, lambda r: str(r["run"]))[1:] if stalls else ["None."]
    missed = summary["missed"]
    lines += [
        "",
        "All cases met their target."
        if summary["all_met"]
        else "Missed: " + "; ".join(f"{k}: {', '.join(v)}" for k, v in missed.items()) + ".",
        "",
    ]
    return "\n".join(lines)


def _detection_lines(
    meta: Mapping[str, Any], cases: Sequence[Mapping[str, Any]], maze: Sequence[Mapping[str, Any]]
) -> list[str]:
    """The page's head and its detection table, with the spikes gated, how far a blind robot
    drove, the alarms before the onset and the runs to look at."""
    onsets = f"faults at {meta['onset_s']:g} s of MCU time"
    if maze:
        onsets = (
            f"faults at {meta['onset_s']:g} s of MCU time on the square and the figure-eight, "
            f"LiDAR faults at {meta['maze_onset_s']:g} s into the maze's navigation trial "
            f"(map `{meta['map']}`)"
        )
    lines = [
        "# Fault campaign",
        "",
        f"{meta['trials']} seeds per case from seed {meta['seed']} on `{meta['robot']}`, each "
        f"with and without the health monitor; {onsets}; "
        f"{meta['runs']} runs in {meta['wall_s'] / 60:.1f} min on {meta['workers']} workers.",
        "",
        "## Detection (runs with the monitor)",
        "",
        "| case | mission | fault | blame | detected | isolated (first out otherwise) | "
        "time to detect median / max [s] | excluded | time to exclude median / max [s] | "
        "first excluded | others excluded | monitor: completed / aborted / not ended | "
        "no monitor: completed / aborted / not ended | target |",
        "|---|---|---|---|---:|---|---:|---:|---:|---:|---|---:|---:|---|",
    ]
    lines += [_detection_row(c) for c in cases]
    for c in cases:
        if c["spikes"]:
            lines.append(
                f"\n{c['name']}: {c['gated']} samples gated for {c['spikes']} spikes injected "
                f"over {c['trials']} runs."
            )
    for c in cases:
        if c.get("after_onset_max_m") is not None:
            lines.append(
                f"\n{c['name']}: the robot stood at most {c['after_onset_max_m'] * 100:.1f} cm "
                f"(ground truth) after the LiDAR went blind (target {BLIND_LIMIT_M * 100:.0f} cm)."
            )
    early = sum(c["pre_onset_alarms"] for c in cases)
    lines.append(f"\nTransitions before the onset in the monitored runs: {early}.")
    looks: dict[tuple[str, str, str], list[str]] = {}
    for c in cases:
        for x in c["runs_to_look_at"]:
            where, _, run = x["run"].rpartition("/")
            looks.setdefault((c["name"], where, x["what"]), []).append(run)
    if looks:
        lines += ["", "Runs to look at:", ""]
        lines += [
            f"- {name}: {what}: `{where}/` {', '.join(runs)}"
            for (name, where, what), runs in looks.items()
        ]
    return lines


def _detection_row(c: Mapping[str, Any]) -> str:
    """A case's row of the detection table."""
    n = c["trials"]
    others = {k: v for k, v in c["first_sensors"].items() if k != c["sensor"]}
    other = ", ".join(f"{k} {v}" for k, v in others.items())
    wrong = ", ".join(f"{k} {v}" for k, v in c["others_excluded"].items())
    on, off = c["with_monitor"], c["without_monitor"]
    verdict = "met" if c["met_target"] else "MISSED: " + "; ".join(c["missed"])
    return (
        f"| {c['name']} | {c['mission']} | `{c['fault']}` | {c['sensor']} | "
        f"{c['detected']}/{n} | {c['isolated']}/{n}{f' ({other})' if other else ''} | "
        f"{_seconds(c['time_to_detect_median_s'])} / {_seconds(c['time_to_detect_max_s'])} | "
        f"{c['excluded']}/{n} | {_seconds(c['time_to_exclude_median_s'])} / "
        f"{_seconds(c['time_to_exclude_max_s'])} | "
        f"{c['isolated_by_exclusion']}/{n} | {wrong or '-'} | "
        f"{on['completed']} / {on['aborted']} / {on['not_ended']} | "
        f"{off['completed']} / {off['aborted']} / {off['not_ended']} | {verdict} |"
    )


def _closure_lines(loops: Sequence[Mapping[str, Any]]) -> list[str]:
    """The closure table of the square and figure-eight cases (none without such a case)."""
    if not loops:
        return []
    lines = [
        "",
        "## Closure of the completed runs [cm], mean ± SD (runs)",
        "",
        "| case | ground truth, monitor | ground truth, no monitor | EKF, monitor | "
        "EKF, no monitor |",
        "|---|---:|---:|---:|---:|",
    ]
    for c in loops:
        on, off = c["with_monitor"], c["without_monitor"]
        lines.append(
            f"| {c['name']} | {_pm(on['gt_closure_cm'])} | {_pm(off['gt_closure_cm'])} | "
            f"{_pm(on['ekf_closure_cm'])} | {_pm(off['ekf_closure_cm'])} |"
        )
    return lines


def _false_alarm_lines(fa: Mapping[str, Any]) -> list[str]:
    """The clean runs' table: transitions per hour driven, per sensor, and each alarm."""
    columns = [*SENSORS, *(s for s in fa["by_sensor"] if s not in SENSORS)]
    lines = [
        "",
        "## False alarms (clean runs, monitor on)",
        "",
        f"{fa['runs']} runs ({fa['completed']} completed, {fa['not_ended']} did not end): "
        f"{fa['hours_driven']:.3f} h driven, {fa['hours_monitored']:.3f} h monitored"
        + _clean_missions(fa.get("by_mission") or {})
        + ".",
        "",
        "| transitions to | count (per hour driven, one-sided upper bound) | "
        + " | ".join(columns)
        + " |",
        "|---|---|" + "---:|" * len(columns),
    ]
    for state in ("excluded", "suspect"):
        per = " | ".join(str(fa["by_sensor"].get(s, {}).get(state, 0)) for s in columns)
        lines.append(f"| {state} | {_per_h(fa[state])} | {per} |")
    if fa["alarms"]:
        lines += ["", "Alarms on clean runs:", ""]
        lines += [
            f"- `{a['run']}` {a['t_s']:.2f} s: {a['sensor']} {a['old']} -> {a['new']} "
            f"({a['reason']})"
            for a in fa["alarms"]
        ]
    return lines


def _clean_missions(by_mission: Mapping[str, Mapping[str, float]]) -> str:
    """The clean runs per mission, when the maze's are among them (the LiDAR judged there)."""
    if "maze" not in by_mission:
        return ""
    parts = [
        f"{m} {v['runs']:g} run{'' if v['runs'] == 1 else 's'}, {v['hours_driven']:.3f} h"
        for m, v in by_mission.items()
    ]
    return f" ({'; '.join(parts)}; the LiDAR is judged on the maze only)"


def _navigation_markdown(cases: Sequence[Mapping[str, Any]]) -> list[str]:
    """The maze cases' table: how the navigations ended, contacts, d_min, driving time, scans."""
    lines = [
        "",
        "## Navigation of the maze cases (goal reached / aborted / not ended)",
        "",
        "d_min (Eq. 21): the dropped cylinder to the robot's envelope, mean ± SD (runs), lowest.",
        "",
        "| case | monitor: reached / aborted / not ended | no monitor: reached / aborted / "
        "not ended | contacts (runs) monitor / no monitor | d_min [cm] monitor | "
        "d_min [cm] no monitor | driving [s] monitor / no monitor | "
        "scans per run, monitor / no monitor |",
        "|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    reasons = []
    for c in cases:
        on, off = c["navigation_with_monitor"], c["navigation_without_monitor"]
        cells = []
        for o in (on, off):
            low = o["d_min_lowest_cm"]
            cells.append(f"{_pm(o['d_min_cm'], 1)}{'' if low is None else f', {low:.1f}'}")
        lines.append(
            f"| {c['name']} | {on['reached']} / {on['aborted']} / {on['not_ended']} | "
            f"{off['reached']} / {off['aborted']} / {off['not_ended']} | "
            f"{on['collisions']} ({on['runs_with_contact']}) / "
            f"{off['collisions']} ({off['runs_with_contact']}) | {cells[0]} | {cells[1]} | "
            f"{_pm(on['driving_s'], 1)} / {_pm(off['driving_s'], 1)} | "
            f"{_pm(on['scans'], 0)} / {_pm(off['scans'], 0)} |"
        )
        for label, o in (("monitor", on), ("no monitor", off)):
            name = c["name"]
            reasons += [f"- {name}, {label}: {n} aborted: {why}" for why, n in o["reasons"].items()]
    if reasons:
        lines += ["", "Why the aborted runs ended:", "", *reasons]
    return lines


def plot_faults(path: Path, summary: Mapping[str, Any]) -> None:
    """``faults.png``: per case, detection rate and time to detect (top); closure with and
    without the monitor for the square and the figure-eight, d_min and goals reached with and
    without it for the maze (below, error bars one SD).

    Parameters
    ----------
    path : Path
        The PNG to write.
    summary : Mapping
        :func:`summarise`'s result.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    every = summary["cases"]

    def label(c: Mapping[str, Any]) -> str:
        return str(c["name"]).replace("_", " ").replace("square ", "square:\n")

    names = [label(c) for c in every]
    x = np.arange(len(every))
    cases = [c for c in every if c["mission"] != "maze"]
    maze = [c for c in every if c["mission"] == "maze"]
    rows = 1 + bool(cases) + bool(maze)
    fig, axes = plt.subplots(
        rows, 1, figsize=(max(7.0, 1.2 * len(every) + 2), 3.75 * rows), dpi=150, squeeze=False
    )
    ax1 = axes[0, 0]

    det = [100 * c["detection_rate"] for c in every]
    iso = [100 * c["isolation_rate"] for c in every]
    ax1.bar(x - 0.18, det, 0.36, color="C0", label="detected")
    ax1.bar(x + 0.18, iso, 0.36, color="C0", alpha=0.45, label="isolated (first sensor out)")
    ax1.axhline(100 * DETECTION_TARGET, color="k", ls="--", lw=0.8)
    for xi, v in zip(x, iso, strict=True):
        if v == 0:
            ax1.text(xi + 0.18, 1, "0", fontsize=7, ha="center", va="bottom")
    ax1.set_ylim(0, 105)
    ax1.set_ylabel("runs [%]")
    ax1.set_xticks(x, names, fontsize=7)
    ax1.set_title(
        "Detection with the health monitor (dashed: target); time to detect", fontsize=9, pad=24
    )
    ax_t = ax1.twinx()
    med = np.array([c["time_to_detect_median_s"] or np.nan for c in every], dtype=float)
    top = np.array([c["time_to_detect_max_s"] or np.nan for c in every], dtype=float)
    ax_t.errorbar(
        x,
        med,
        yerr=[np.zeros_like(med), top - med],
        fmt="D",
        color="C3",
        ms=5,
        capsize=4,
        label="time to detect: median, bar to max",
    )
    positive = [v for v in np.r_[med, top] if np.isfinite(v) and v > 0]
    if positive and max(positive) / min(positive) > 30:
        ax_t.set_yscale("log")
    else:
        ax_t.set_ylim(0, (max(positive) * 1.1) if positive else 1.0)
    ax_t.set_ylabel("time to detect [s]", color="C3")
    h1, l1 = ax1.get_legend_handles_labels()
    h2, l2 = ax_t.get_legend_handles_labels()
    ax1.legend(h1 + h2, l1 + l2, fontsize=7, loc="lower center", bbox_to_anchor=(0.5, 1.0), ncol=3)
    if cases:
        _plot_closure(axes[1, 0], cases, [label(c) for c in cases])
    if maze:
        _plot_navigation(axes[-1, 0], maze, [label(c) for c in maze])
    fig.tight_layout()
    from jackson.common.figures import save_figure

    save_figure(fig, path)


def _plot_closure(ax2: Any, cases: Sequence[Mapping[str, Any]], names: Sequence[str]) -> None:
    """Closure of the completed runs with and without the monitor (error bars one SD)."""
    import numpy as np

    x = np.arange(len(cases))
    width = 0.2
    series = (
        ("with_monitor", "gt_closure_cm", "ground truth, monitor", "C0", 1.0),
        ("without_monitor", "gt_closure_cm", "ground truth, no monitor", "C1", 1.0),
        ("with_monitor", "ekf_closure_cm", "EKF, monitor", "C0", 0.45),
        ("without_monitor", "ekf_closure_cm", "EKF, no monitor", "C1", 0.45),
    )
    for k, (side, key, label, color, alpha) in enumerate(series):
        xs = x + (k - 1.5) * width
        mean = np.array([c[side][key]["mean"] or np.nan for c in cases], dtype=float)
        sd = np.array([c[side][key]["sd"] or 0.0 for c in cases], dtype=float)
        ax2.bar(xs, mean, width, yerr=sd, color=color, alpha=alpha, capsize=2, label=label)
        for xi, c in zip(xs, cases, strict=True):
            if c[side][key]["n"] == 0:
                ax2.text(
                    xi,
                    0.02,
                    "none completed",
                    rotation=90,
                    fontsize=6,
                    ha="center",
                    va="bottom",
                    transform=ax2.get_xaxis_transform(),
                )
    means = [
        c[s][k]["mean"]
        for c in cases
        for s in ("with_monitor", "without_monitor")
        for k in ("gt_closure_cm", "ekf_closure_cm")
        if c[s][k]["mean"]
    ]
    if means and max(means) / max(min(means), 1e-3) > 30:
        ax2.set_yscale("log")
    ax2.set_ylabel("closure of completed runs [cm]")
    ax2.set_xticks(x, names, fontsize=7)
    ax2.set_title("Closure with and without the monitor (error bars: one SD)", fontsize=9, pad=24)
    ax2.legend(fontsize=7, ncol=4, loc="lower center", bbox_to_anchor=(0.5, 1.0))
    ax2.grid(axis="y", alpha=0.3)


def _plot_navigation(ax: Any, cases: Sequence[Mapping[str, Any]], names: Sequence[str]) -> None:
    """The maze cases: d_min to the dropped cylinder with and without the monitor (error bars
    one SD), each bar labelled with the goals reached (inside a tall bar, above a short one)
    and, for a LiDAR that went blind, how far the monitored robot drove after the onset."""
    import numpy as np

    x = np.arange(len(cases))
    sides = (
        ("navigation_with_monitor", "monitor", "C0"),
        ("navigation_without_monitor", "no monitor", "C1"),
    )
    tallest = max(
        (c[side]["d_min_cm"]["mean"] or 0.0 for c in cases for side, _, _ in sides), default=0.0
    )
    for k, (side, text, color) in enumerate(sides):
        xs = x + (k - 0.5) * 0.36
        d = [c[side]["d_min_cm"] for c in cases]
        mean = np.array([s["mean"] if s["mean"] is not None else np.nan for s in d], dtype=float)
        sd = np.array([s["sd"] or 0.0 for s in d], dtype=float)
        ax.bar(xs, mean, 0.36, yerr=sd, color=color, capsize=3, label=f"d_min, {text}")
        for xi, c, m, e in zip(xs, cases, mean, sd, strict=True):
            o = c[side]
            label = f"goal {o['reached']}/{o['runs']}\naborted {o['aborted']}"
            if k == 0 and c.get("after_onset_max_m") is not None:
                label += f"\nstood \u2264 {c['after_onset_max_m'] * 100:.1f} cm"
            inside = bool(np.isfinite(m)) and m >= 0.35 * tallest  # room for the text
            ax.text(
                xi,
                0.02 * tallest if inside else (m + e if np.isfinite(m) else 0.0) + 0.02 * tallest,
                label,
                fontsize=6,
                ha="center",
                va="bottom",
                color="white" if inside else "k",
            )
    ax.set_ylabel("d_min to the dropped cylinder [cm]")
    ax.set_xticks(x, names, fontsize=7)
    ax.set_title(
        "Maze: clearance (Eq. 21) and goals reached with and without the monitor "
        "(error bars: one SD)",
        fontsize=9,
        pad=24,
    )
    ax.legend(fontsize=7, ncol=2, loc="lower center", bbox_to_anchor=(0.5, 1.0))
    ax.grid(axis="y", alpha=0.3)
