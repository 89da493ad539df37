"""A patrol's summary (``summary.json``) and its plot (``patrol.png``)."""

from __future__ import annotations

import itertools
import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from jackson.experiments.patrol.paths import RATIO_LIMIT, ratio_figures
from jackson.experiments.patrol.records import PatrolResult, PatrolSpec
from jackson.host.nav.grid import OccupancyGrid
from jackson.sim.config import WorldSpec

if TYPE_CHECKING:
    from matplotlib.axes import Axes

ERROR_P99_M = 0.10  # [m] the localisation error's 99th percentile the navigation must keep
ERROR_WORST_M = 0.20  # [m] and its worst


def _slope_per_hour(hours: list[float], values: list[float]) -> float:
    """Least-squares slope of ``values`` over robot-hours (nan with fewer than 3 points)."""
    pts = [(h, v) for h, v in zip(hours, values, strict=True) if math.isfinite(v)]
    if len(pts) < 3 or pts[-1][0] - pts[0][0] <= 0:
        return math.nan
    h, v = np.array(pts).T
    return float(np.polyfit(h, v, 1)[0])


def summarise(
    spec: PatrolSpec, r: PatrolResult, goal_points: tuple[int, int] | None = None
) -> dict[str, Any]:
    """The patrol's figures (``summary.json``); ``goal_points``: the goal points the map
    offers, of those the world does (:func:`~jackson.experiments.patrol.floor.goal_cells`)."""
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
        "map": str(spec.map_yaml) if spec.map_yaml is not None else "the world's raster",
        "goal_points_on_map": f"{goal_points[0]}/{goal_points[1]}" if goal_points else None,
        "localisation_error": r.localisation.figures() if r.localisation is not None else None,
        "unread_bags": r.unread_bags,
        "path_ratio": ratio_figures([o.path_ratio for o in reach]),
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


def plot_patrol(
    png: Path,
    world: WorldSpec,
    result: PatrolResult,
    summary: dict[str, Any],
    grid: OccupancyGrid | None = None,
) -> None:
    """The floor (on the daemon's map) with the truth's path coloured by the localisation
    error and every goal by outcome; the error over MCU time; each reached goal's path ratio;
    with samples, memory and CPU over robot-hours."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    soak = len(result.samples) >= 3
    fig = plt.figure(figsize=(19, 15 if soak else 10))
    gs = fig.add_gridspec(3 if soak else 2, 3, width_ratios=(1.0, 1.0, 0.9))
    _draw_floor(fig.add_subplot(gs[0:2, 0:2]), world, result, summary, grid)
    _draw_errors(fig.add_subplot(gs[0, 2]), result, summary)
    _draw_ratios(fig.add_subplot(gs[1, 2]), result, summary)
    if soak:
        _draw_soak(fig.add_subplot(gs[2, 0]), fig.add_subplot(gs[2, 1]), result)
    fig.tight_layout()
    fig.savefig(png, dpi=100, bbox_inches="tight")
    plt.close(fig)


def _draw_floor(
    ax: Axes,
    world: WorldSpec,
    r: PatrolResult,
    summary: dict[str, Any],
    grid: OccupancyGrid | None,
) -> None:
    """The map, the true walls, the truth's driving coloured by error, the goals."""
    from matplotlib.patches import Circle

    from jackson.experiments.metrics.map_quality import draw_map

    if grid is not None:
        draw_map(ax, grid)
    for k, (x0, y0, x1, y1) in enumerate(world.walls):
        ax.plot([x0, x1], [y0, y1], color="tab:red", lw=0.6, alpha=0.6,
                label="true walls" if k == 0 else None)  # fmt: skip
    for c in world.cylinders:
        ax.add_patch(Circle((c.x, c.y), c.radius, color="tab:red", alpha=0.6))
    loc = r.localisation
    if loc is not None and loc.error_m.size:
        order = np.argsort(loc.error_m)  # the largest errors drawn last, on top
        dots = ax.scatter(loc.x_m[order], loc.y_m[order], c=loc.error_m[order], s=3,
                          cmap="plasma", vmin=0.0, vmax=ERROR_WORST_M, zorder=3)  # fmt: skip
        ax.figure.colorbar(dots, ax=ax, fraction=0.03, pad=0.01,
                           label="localisation error [m] (truth while driving)")  # fmt: skip
        k = int(np.argmax(loc.error_m))
        ax.plot(loc.x_m[k], loc.y_m[k], "*", color="red", mec="k", ms=16, zorder=5,
                label=f"largest error {100 * loc.error_m[k]:.1f} cm")  # fmt: skip
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
                    "D" if kind == "unreachable" else "o", color=colour, ms=5, mec="k", mew=0.4,
                    label=f"{kind} ({len(good)})", zorder=4)  # fmt: skip
        if bad:
            ax.plot([o.x for o in bad], [o.y for o in bad], "x", color="red", ms=9, mew=2,
                    label=f"{kind} failed ({len(bad)})", zorder=4)  # fmt: skip
    for o in r.outcomes:
        if o.path_ratio > RATIO_LIMIT:
            ax.annotate(f"{o.path_ratio:.2f}x", (o.x, o.y), xytext=(4, 4),
                        textcoords="offset points", fontsize=8, color="darkred")  # fmt: skip
    sx, sy, _ = world.start_pose
    ax.plot(sx, sy, "k^", ms=9, label="start")
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    where = (
        "its own map"
        if grid is not None and summary.get("map", "").endswith(".yaml")
        else ("the world's raster")
    )
    ax.set_title(
        f"{world.name} on {where}: {summary['reachable_reached']} reached, "
        f"{summary['unreachable_answered']} unreachable answered, "
        f"{summary['contacts']} contact{'' if summary['contacts'] == 1 else 's'}"
    )
    # below the x label whatever the floor's shape: the gap in font sizes, not axes fractions
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, 0.0), borderaxespad=5.0,
              ncol=5)  # fmt: skip


def _draw_errors(ax: Axes, r: PatrolResult, summary: dict[str, Any]) -> None:
    """The localisation error over MCU time, with the 99th percentile and the limits."""
    loc = r.localisation
    fig = summary.get("localisation_error") or {}
    if loc is None or not loc.error_m.size:
        ax.text(0.5, 0.5, "no localisation samples", ha="center", transform=ax.transAxes)
        return
    ax.plot(loc.t_s / 60.0, 100 * loc.error_m, ".", ms=1.5, color="tab:purple")
    ax.axhline(100 * fig["p99_m"], color="k", ls="--", lw=1,
               label=f"p99 {100 * fig['p99_m']:.1f} cm")  # fmt: skip
    ax.axhline(100 * ERROR_P99_M, color="tab:orange", lw=1, label="10 cm (p99 limit)")
    ax.axhline(100 * ERROR_WORST_M, color="tab:red", lw=1, label="20 cm (worst limit)")
    ax.set_xlabel("MCU time [min]")
    ax.set_ylabel("localisation error [cm]")
    ax.set_title(
        f"localisation error while driving (AMCL's pose against the truth):\n"
        f"median {100 * fig['median_m']:.1f} cm, p99 {100 * fig['p99_m']:.1f} cm, "
        f"max {100 * fig['max_m']:.1f} cm",
        fontsize=10,
    )
    ax.legend(fontsize=8)


def _draw_ratios(ax: Axes, r: PatrolResult, summary: dict[str, Any]) -> None:
    """Each reached goal's executed path over the shortest collision-free one."""
    from matplotlib.ticker import MaxNLocator

    done = [o for o in r.outcomes if np.isfinite(o.path_ratio)]
    fig = summary.get("path_ratio") or {}
    if not done:
        ax.text(0.5, 0.5, "no reached goal with a path ratio", ha="center",
                transform=ax.transAxes)  # fmt: skip
        return
    colours = ["tab:red" if o.path_ratio > RATIO_LIMIT else "tab:green" for o in done]
    ax.bar([o.step for o in done], [o.path_ratio for o in done], color=colours)
    ax.axhline(1.0, color="k", lw=0.8)
    ax.axhline(RATIO_LIMIT, color="tab:red", ls="--", lw=1, label=f"{RATIO_LIMIT:g}x")
    ax.set_ylim(0.9, max(1.4, max(o.path_ratio for o in done) + 0.05))
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_xlabel("step")
    ax.set_ylabel("path ratio")
    ax.set_title(
        f"path on the truth / shortest path, {fig['goals']} reached goals:\n"
        f"median {fig['median']:.3f}, p95 {fig['p95']:.3f}, max {fig['max']:.3f}, "
        f"{fig['above_1_25']} above {RATIO_LIMIT:g}",
        fontsize=10,
    )
    ax.legend(fontsize=8)


def _draw_soak(ax1: Axes, ax2: Axes, r: PatrolResult) -> None:
    """Both processes' memory, and their CPU per robot-second and the recordings' size."""
    h = [x.robot_s / 3600.0 for x in r.samples]
    ax1.plot(h, [x.daemon_rss_mb for x in r.samples], label="daemon (with its planner worker)")
    ax1.plot(h, [x.twin_rss_mb for x in r.samples], label="twin")
    ax1.set_xlabel("robot time [h]")
    ax1.set_ylabel("resident memory [MB]")
    ax1.legend()
    ax1.set_title("memory")
    hh, dc, tc = [], [], []
    for a, b in itertools.pairwise(r.samples):
        d = b.robot_s - a.robot_s
        if d > 0:
            hh.append(b.robot_s / 3600.0)
            dc.append((b.daemon_cpu_s - a.daemon_cpu_s) / d)
            tc.append((b.twin_cpu_s - a.twin_cpu_s) / d)
    ax2.plot(hh, dc, label="daemon (with its planner worker)")
    ax2.plot(hh, tc, label="twin")
    ax2.set_xlabel("robot time [h]")
    ax2.set_ylabel("CPU-s per robot-second")
    ax2.legend()
    ax2b = ax2.twinx()
    ax2b.plot(h, [x.disk_mb for x in r.samples], "k:", label="recordings [MB]")
    ax2b.set_ylabel("recordings [MB] (dotted)")
    ax2.set_title("CPU and disk")
