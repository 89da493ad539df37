"""A patrol's summary (``summary.json``) and its plot (``patrol.png``)."""

from __future__ import annotations

import itertools
import math
from pathlib import Path
from typing import Any

import numpy as np

from jackson.experiments.patrol.records import PatrolResult, PatrolSpec
from jackson.sim.config import WorldSpec


def _slope_per_hour(hours: list[float], values: list[float]) -> float:
    """Least-squares slope of ``values`` over robot-hours (nan with fewer than 3 points)."""
    pts = [(h, v) for h, v in zip(hours, values, strict=True) if math.isfinite(v)]
    if len(pts) < 3 or pts[-1][0] - pts[0][0] <= 0:
        return math.nan
    h, v = np.array(pts).T
    return float(np.polyfit(h, v, 1)[0])


def summarise(spec: PatrolSpec, r: PatrolResult) -> dict[str, Any]:
    """The patrol's figures (``summary.json``)."""
    by_kind: dict[str, dict[str, int]] = {}
    for o in r.outcomes:
        k = by_kind.setdefault(o.kind, {"sent": 0, "ok": 0})
        k["sent"] += 1
        k["ok"] += int(o.ok)
    reach = [o for o in r.outcomes if o.kind in ("goal", "preempt")]
    unreach = [o for o in r.outcomes if o.kind == "unreachable"]
    s = r.samples
    robot_h = [x.robot_s / 3600.0 for x in s]
    later = [k for k, h in enumerate(robot_h) if h >= 1.0]
    out: dict[str, Any] = {
        "world": spec.world,
        "seed": spec.seed,
        "steps": len(r.outcomes),
        "by_kind": by_kind,
        "reachable_reached": f"{sum(o.ok for o in reach)}/{len(reach)}",
        "unreachable_answered": f"{sum(o.ok for o in unreach)}/{len(unreach)}",
        "unreachable_answer_max_s": max((o.answered_s for o in unreach), default=None),
        "truth_error_max_m": max(
            (o.truth_error_m for o in reach if math.isfinite(o.truth_error_m)), default=None
        ),
        "contacts": r.contacts,
        "sensor_exclusions": len(r.exclusions),
        "sensor_suspicions": r.suspicions,
        "daemon_exit": r.daemon_exit,
        "failure": r.failure,
        "robot_hours": robot_h[-1] if robot_h else 0.0,
        "wall_hours": s[-1].wall_s / 3600.0 if s else 0.0,
    }
    if s:
        out["daemon_rss_mb"] = {"first": s[0].daemon_rss_mb, "last": s[-1].daemon_rss_mb}
        out["twin_rss_mb"] = {"first": s[0].twin_rss_mb, "last": s[-1].twin_rss_mb}
        out["disk_mb"] = {"last": s[-1].disk_mb, "max": max(x.disk_mb for x in s),
                          "budget": spec.budget_mb}  # fmt: skip
        if len(s) >= 2 and s[-1].robot_s > s[0].robot_s:
            span = s[-1].robot_s - s[0].robot_s
            out["daemon_cpu_per_robot_s"] = (s[-1].daemon_cpu_s - s[0].daemon_cpu_s) / span
            out["twin_cpu_per_robot_s"] = (s[-1].twin_cpu_s - s[0].twin_cpu_s) / span
    if len(later) >= 3:
        idx = later
        out["after_first_hour"] = {
            "daemon_rss_mb_per_robot_hour": _slope_per_hour(
                [robot_h[k] for k in idx], [s[k].daemon_rss_mb for k in idx]
            ),
            "twin_rss_mb_per_robot_hour": _slope_per_hour(
                [robot_h[k] for k in idx], [s[k].twin_rss_mb for k in idx]
            ),
        }
        cpu = []
        for a, b in itertools.pairwise(idx):
            d = s[b].robot_s - s[a].robot_s
            if d > 0:
                cpu.append((robot_h[b], (s[b].daemon_cpu_s - s[a].daemon_cpu_s) / d))
        if len(cpu) >= 3:
            out["after_first_hour"]["daemon_cpu_per_robot_s_slope_per_hour"] = _slope_per_hour(
                [c[0] for c in cpu], [c[1] for c in cpu]
            )
    return out


def plot_patrol(png: Path, world: WorldSpec, result: PatrolResult, summary: dict[str, Any]) -> None:
    """The floor with every goal by outcome; with samples, memory and CPU over robot-hours."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Circle

    r = result
    soak = len(r.samples) >= 3
    fig, axes = plt.subplots(1, 3 if soak else 1, figsize=(18 if soak else 8, 6))
    ax = axes[0] if soak else axes
    for x0, y0, x1, y1 in world.walls:
        ax.plot([x0, x1], [y0, y1], color="0.2", lw=1.2)
    for c in world.cylinders:
        ax.add_patch(Circle((c.x, c.y), c.radius, color="0.2"))
    if world.patrol is not None:
        for k, (x, y) in enumerate(world.patrol.drop_spots):
            ax.plot(x, y, "s", color="tab:purple", ms=7, mfc="none",
                    label="drop spot" if k == 0 else None)  # fmt: skip
    colours = {"goal": "tab:green", "preempt": "tab:blue", "cancel": "tab:orange",
               "teleop": "tab:cyan", "unreachable": "tab:brown"}  # fmt: skip
    for kind, colour in colours.items():
        os_ = [o for o in r.outcomes if o.kind == kind]
        good = [o for o in os_ if o.ok]
        bad = [o for o in os_ if not o.ok]
        if good:
            ax.plot([o.x for o in good], [o.y for o in good],
                    "D" if kind == "unreachable" else "o", color=colour, ms=4,
                    label=f"{kind} ({len(good)})")  # fmt: skip
        if bad:
            ax.plot([o.x for o in bad], [o.y for o in bad], "x", color="red", ms=8,
                    label=f"{kind} failed ({len(bad)})")  # fmt: skip
    sx, sy, _ = world.start_pose
    ax.plot(sx, sy, "k^", ms=9, label="start")
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(
        f"{world.name}: {summary['reachable_reached']} reached,\n"
        f"{summary['unreachable_answered']} unreachable answered, "
        f"{summary['contacts']} contacts"
    )
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    if soak:
        h = [x.robot_s / 3600.0 for x in r.samples]
        axes[1].plot(h, [x.daemon_rss_mb for x in r.samples], label="daemon")
        axes[1].plot(h, [x.twin_rss_mb for x in r.samples], label="twin")
        axes[1].set_xlabel("robot time [h]")
        axes[1].set_ylabel("resident memory [MB]")
        axes[1].legend()
        axes[1].set_title("memory")
        ax2 = axes[2]
        hh, dc, tc = [], [], []
        for a, b in zip(r.samples, r.samples[1:], strict=False):
            d = b.robot_s - a.robot_s
            if d > 0:
                hh.append(b.robot_s / 3600.0)
                dc.append((b.daemon_cpu_s - a.daemon_cpu_s) / d)
                tc.append((b.twin_cpu_s - a.twin_cpu_s) / d)
        ax2.plot(hh, dc, label="daemon")
        ax2.plot(hh, tc, label="twin")
        ax2.set_xlabel("robot time [h]")
        ax2.set_ylabel("CPU-s per robot-second")
        ax2.legend()
        ax2b = ax2.twinx()
        ax2b.plot(h, [x.disk_mb for x in r.samples], "k:", label="recordings [MB]")
        ax2b.set_ylabel("recordings [MB] (dotted)")
        ax2.set_title("CPU and disk")
    fig.tight_layout()
    fig.savefig(png, dpi=110)
    plt.close(fig)
