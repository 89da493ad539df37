"""The report ``jackson map`` writes beside a map: a picture and its figures.

``built_map.png`` (and a PDF beside it) shows the map, the optimised trajectory (the pose
graph's nodes joined in order), the loop closures (each a line between its two nodes), the
start and the end. On the twin, where the world is known, the true walls are drawn over it
coloured by coverage and the occupied cells far from any wall in magenta
(:func:`jackson.experiments.metrics.map_quality.draw_quality`), and the figures are written:
wall coverage, precision, SSIM, misplacement
(:mod:`jackson.experiments.metrics.map_quality`) and the largest loop's closure error before
and after optimisation (:mod:`jackson.experiments.metrics.loop_closure`).
``map_quality.json`` holds the same figures; without a ground truth (a recording of the real
robot) only the graph's own: nodes, trajectory length, loop closures.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from jackson.common.errors import JacksonError
from jackson.experiments.metrics.loop_closure import (
    GraphFile,
    LargestLoop,
    largest_loop,
    loop_closure_error,
    read_graph,
)
from jackson.experiments.metrics.map_quality import (
    COVERED,
    MapQuality,
    draw_map,
    draw_quality,
    judge_run,
)

if TYPE_CHECKING:
    from matplotlib.axes import Axes

    from jackson.host.nav.grid import OccupancyGrid
    from jackson.sim.config import WorldSpec

MAP_NAME = "built_map"
REPORT_PNG = f"{MAP_NAME}.png"
REPORT_JSON = "map_quality.json"
TRAJECTORY_COLOUR = "tab:blue"
CLOSURE_COLOUR = "darkorange"


@dataclass(frozen=True, eq=False)
class MapReport:
    """What :func:`write_map_report` wrote.

    Attributes
    ----------
    png, json : Path
        The picture and the figures.
    figures : dict
        The figures (as in the JSON; nan as None there).
    quality : MapQuality or None
        The map judged against the world (None: no world or no ground truth).
    loop : LargestLoop or None
        The largest loop's closure error (None: no loop closed, or no ground truth).
    """

    png: Path
    json: Path
    figures: dict[str, Any]
    quality: MapQuality | None
    loop: LargestLoop | None

    def lines(self) -> list[str]:
        """The figures as a short table, one line each."""
        return [f"  {name:<18} {value}" for name, value in figure_rows(self.figures)]


def twin_world(run: Path) -> WorldSpec | None:
    """The world a twin run was made in: the one its ``meta.json`` names, if that loads and
    the run has a ground truth; None for any other run (the real robot's)."""
    from jackson.sim.config import load_world

    meta_path = run / "meta.json"
    if not (run / "ground_truth.csv").is_file() or not meta_path.is_file():
        return None
    try:
        name = json.loads(meta_path.read_text()).get("world")
        return load_world(name) if isinstance(name, str) and name else None
    except (JacksonError, OSError, ValueError):
        return None


def write_map_report(
    out: Path, run: Path | None = None, world: WorldSpec | None = None
) -> MapReport:
    """Write ``built_map.png`` and ``map_quality.json`` beside the map in ``out``.

    Parameters
    ----------
    out : Path
        The folder holding ``built_map.yaml`` (+ PGM) and ``built_map.graph.npz``.
    run : Path, optional
        The run the map was made from (its ``ground_truth.csv`` and ``meta.json``); default
        ``out`` (a survey writes its run's files beside the map).
    world : WorldSpec, optional
        The world to judge against; default the one the run's ``meta.json`` names, when the
        run is a twin run (:func:`twin_world`). Without one nothing is judged.

    Returns
    -------
    MapReport

    Raises
    ------
    MetricInputError
        A missing or unreadable map, graph or ground truth.
    """
    from jackson.host.nav.grid import OccupancyGrid

    run = out if run is None else run
    map_yaml = out / f"{MAP_NAME}.yaml"
    grid = OccupancyGrid.load(map_yaml)
    graph = read_graph(out / f"{MAP_NAME}.graph.npz")
    if world is None:
        world = twin_world(run)
    truth = run / "ground_truth.csv"
    quality = loop = None
    if world is not None and truth.is_file():
        quality = judge_run(run, world, map_yaml=map_yaml)
        loop = loop_closure_error(graph, truth)
    figures = report_figures(graph, quality, loop, world.name if world is not None else None)
    png = plot_map_report(out / REPORT_PNG, grid, graph, quality, figures)
    json_path = out / REPORT_JSON
    clean = {
        k: None if isinstance(v, float) and not math.isfinite(v) else v for k, v in figures.items()
    }
    json_path.write_text(json.dumps(clean, indent=2) + "\n")
    return MapReport(png, json_path, figures, quality, loop)


def report_figures(
    graph: GraphFile,
    quality: MapQuality | None,
    loop: LargestLoop | None,
    world: str | None,
) -> dict[str, Any]:
    """The report's figures: the graph's own, then the judgement's when there is one."""
    pair = largest_loop(graph)
    travel = math.nan
    if pair is not None and graph.travel is not None:
        travel = float(graph.travel[pair[1]] - graph.travel[pair[0]])
    figures: dict[str, Any] = {
        "world": world,
        "nodes": len(graph.poses),
        "trajectory_m": graph.trajectory_m(),
        "loop_closures": graph.closures,
        "largest_loop_nodes": list(pair) if pair is not None else None,
        "largest_loop_travel_m": travel,
    }
    if loop is not None:
        figures.update(
            loop_closure_before_m=loop.before_m,
            loop_closure_before_rad=loop.before_rad,
            loop_closure_after_m=loop.after_m,
            loop_closure_after_rad=loop.after_rad,
        )
    if quality is not None:
        figures.update(quality.summary())
    return figures


def figure_rows(f: dict[str, Any]) -> list[tuple[str, str]]:
    """The figures as (name, value) rows for a table or a text box."""
    rows = [
        ("nodes", f"{f['nodes']}, {f['trajectory_m']:.1f} m of trajectory"),
        ("loop closures", str(f["loop_closures"])),
    ]
    if f["largest_loop_nodes"] is not None:
        i, j = f["largest_loop_nodes"]
        rows.append(
            ("largest loop", f"nodes {i}-{j}, {f['largest_loop_travel_m']:.1f} m of travel apart")
        )
    if "loop_closure_before_m" in f:
        for when in ("before", "after"):
            rows.append(
                (
                    f"  error {when}",
                    f"{f[f'loop_closure_{when}_m'] * 100:.1f} cm, "
                    f"{math.degrees(f[f'loop_closure_{when}_rad']):.2f}°",
                )
            )
    if "precision" in f:
        rows += [
            (
                "walls covered",
                f"{f['segments_covered_fraction']:.0%} of {f['segments_judged']} segments "
                f"≥ {COVERED:.0%} covered",
            ),
            ("  worst segment", f"{f['worst_segment_coverage']:.0%} ({f['worst_segment']})"),
            ("  samples covered", f"{f['sample_coverage']:.1%}"),
            ("precision", f"{f['precision']:.1%} of {f['occupied_cells']} occupied cells"),
            ("SSIM", f"{f['ssim']:.3f}"),
            (
                "misplacement",
                f"p99 {f['misplacement_p99_m'] * 100:.1f} cm, "
                f"max {f['misplacement_max_m'] * 100:.1f} cm",
            ),
        ]
    return rows


def plot_map_report(
    path: Path,
    grid: OccupancyGrid,
    graph: GraphFile,
    quality: MapQuality | None,
    figures: dict[str, Any],
) -> Path:
    """The report's picture (module docstring): the map, the judgement if any, the optimised
    trajectory, the loop closures, start and end; a panel beside it with the legend and the
    figures. Returns the PNG (a PDF is written beside it)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import PathCollection

    from jackson.common.figures import save_figure

    view = _view(grid, graph, quality)
    span = max(view[1] - view[0], view[3] - view[2])
    aspect = (view[3] - view[2]) / max(view[1] - view[0], 1e-9)
    map_w = min(11.0, 11.0 / aspect)  # [in] no taller than 11 in
    panel_h = 2.4  # [in] the legend and the figures below the map
    fig = plt.figure(figsize=(11.0, map_w * aspect + 0.8 + panel_h))
    rows = fig.add_gridspec(2, 1, height_ratios=(map_w * aspect + 0.8, panel_h), hspace=0.12)
    ax = fig.add_subplot(rows[0])
    panel = rows[1].subgridspec(1, 2, wspace=0.0)
    legend_ax, text_ax = fig.add_subplot(panel[0, 0]), fig.add_subplot(panel[0, 1])
    draw_map(ax, grid)
    if quality is not None:
        pt_per_m = 72.0 * map_w / span  # the wall samples' markers grow with the zoom
        draw_quality(ax, quality, scale=float(np.clip((pt_per_m / 50.0) ** 2, 0.25, 3.0)))
    _draw_graph(ax, graph)
    ax.set_xlim(view[0], view[1])
    ax.set_ylim(view[2], view[3])
    name = figures["world"] or f"{path.parent.name} (no ground truth)"
    ax.set_title(f"{name}: map, optimised trajectory and loop closures", fontsize=11)
    handles, labels = ax.get_legend_handles_labels()
    legend = legend_ax.legend(handles, labels, loc="upper left", fontsize=9, frameon=False)
    for handle in legend.legend_handles:
        if isinstance(handle, PathCollection):  # the wall samples: tiny on the map
            handle.set_sizes([25.0])
    text = "\n".join(f"{name:<18} {value}" for name, value in figure_rows(figures))
    text_ax.text(0.0, 1.0, text, va="top", ha="left", family="monospace", fontsize=8.5)
    for a in (legend_ax, text_ax):
        a.axis("off")
    save_figure(fig, path, bbox_inches="tight")
    return path


def _draw_graph(ax: Axes, graph: GraphFile) -> None:
    """The optimised trajectory, the loop closures (the largest one thicker), start and end."""
    xy = graph.poses[:, :2]
    if len(xy) == 0:
        return
    ax.plot(xy[:, 0], xy[:, 1], c=TRAJECTORY_COLOUR, lw=1.2, zorder=3, label="optimised trajectory")
    pairs = graph.edge_nodes[graph.edge_loop]
    largest = largest_loop(graph)
    for k, (i, j) in enumerate(pairs):
        big = largest is not None and sorted((int(i), int(j))) == list(largest)
        ax.plot(
            xy[[i, j], 0],
            xy[[i, j], 1],
            c=CLOSURE_COLOUR,
            lw=2.2 if big else 1.2,
            marker="o",
            ms=3.5 if big else 2.5,
            zorder=6,  # above the start and end: a loop often closes at the start
            label=f"loop closure ({len(pairs)})" if k == 0 else None,
        )
    ax.plot(*xy[0], "o", ms=9, mfc="white", mec=TRAJECTORY_COLOUR, mew=2, zorder=5, label="start")
    ax.plot(*xy[-1], "s", ms=8, mfc=TRAJECTORY_COLOUR, mec="white", mew=1.5, zorder=5, label="end")


def _view(
    grid: OccupancyGrid, graph: GraphFile, quality: MapQuality | None
) -> tuple[float, float, float, float]:
    """x0, x1, y0, y1 [m]: the known cells, the trajectory and the walls in view, with a
    margin."""
    rows, cols = np.nonzero(grid.data >= 0)
    xs, ys = grid.cell_to_world(rows, cols)
    pts = [np.column_stack((xs, ys)), graph.poses[:, :2]]
    if quality is not None:
        pts.append(quality.samples.xy[quality.samples.seen])
    allp = np.concatenate([p.reshape(-1, 2) for p in pts])
    if len(allp) == 0:
        x0, y0 = grid.origin_x_m, grid.origin_y_m
        return x0, x0 + grid.width * grid.resolution_m, y0, y0 + grid.height * grid.resolution_m
    lo, hi = allp.min(axis=0) - 0.3, allp.max(axis=0) + 0.3
    return float(lo[0]), float(hi[0]), float(lo[1]), float(hi[1])
