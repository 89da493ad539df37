"""Stage 3 on floors unlike the maze: one campaign over several worlds, each with a cylinder
dropped on the route, judged on the twin's ground truth.

``jackson campaign worlds`` maps every world once (its own survey route, :func:`mapping_spec`),
then runs ``trials`` navigations per world to the world file's goal, the robot alternating
between the shipped robot files (trial k uses ``robots[k % len(robots)]``), each seeded
``seed + 1000 w + k``. A world either expects the goal to be reached or, like
``blocked_route`` (the cylinder drops into the only doorway), expects the robot to say it
cannot be reached.

A run **passes** when
- it expects the goal: the navigation completed and the ground-truth end lies within the xy
  goal tolerance (0.25 m) of the goal;
- it expects "unreachable": the navigation failed with ``goal (x, y) unreachable: blocked at
  (x, y)`` within ``UNREACHABLE_LIMIT_S`` of MCU time after the cylinder dropped;
and in both cases with no contact and no sensor excluded by the health monitor (the twin's
sensors are healthy, so any exclusion is a false alarm; suspicions longer than
``LONG_SUSPICION_S`` are counted apart).

The report folder holds ``runs.csv``/``runs.json`` (every run), ``summary.md`` (a table per
world), one ``<world>.png`` per world (the map, every true path, the cylinder) and the maps in
``maps/<world>/``.
"""

from __future__ import annotations

import csv
import json
import math
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from jackson.experiments.stage3 import (
    NavTrialSpec,
    mapping_spec,
    plot_stage3,
    run_nav_trial,
    world_goals,
)
from jackson.experiments.stall_retry import stall_lines
from jackson.sim.config import load_world

WORLDS: dict[str, str] = {
    "two_rooms": "reach",
    "corridor_8m": "reach",
    "hall_15m": "reach",
    "clutter": "reach",
    "maze": "reach",
    "blocked_route": "unreachable",
}
"""The campaign's worlds and what each expects (``reach`` or ``unreachable``)."""

ROBOTS = ("jackson_physical", "jackson")
"""The shipped twin robots the trials alternate between."""

GOAL_TOLERANCE_M = 0.25  # [m] REFERENCE Stage 3 xy goal tolerance, judged on the truth
UNREACHABLE_LIMIT_S = 15.0  # [s] of MCU time from the drop to "unreachable"
LONG_SUSPICION_S = 2.0  # [s] a suspicion longer than this is reported


def health_events(run_dir: Path, t_end_s: float) -> tuple[int, int, list[str]]:
    """Exclusions and long suspicions of any sensor in a run's ``health.json``.

    Parameters
    ----------
    run_dir : Path
        The run folder.
    t_end_s : float
        MCU time the run ended (a suspicion still open then lasts until it).

    Returns
    -------
    tuple
        (exclusions, suspicions longer than ``LONG_SUSPICION_S``, one text per event).
    """
    path = run_dir / "health.json"
    if not path.exists():
        return 0, 0, []
    transitions = json.loads(path.read_text())["sensors"]["transitions"]
    exclusions, long_suspicions, texts = 0, 0, []
    since: dict[str, float] = {}
    for tr in transitions:
        sensor, t = str(tr["sensor"]), float(tr["t_s"])
        if tr["to"] == "excluded":
            exclusions += 1
            texts.append(f"{sensor} excluded at {t:.2f} s: {tr['reason']}")
        if tr["to"] == "suspect":
            since[sensor] = t
        elif sensor in since:
            start = since.pop(sensor)
            if t - start > LONG_SUSPICION_S:
                long_suspicions += 1
                texts.append(f"{sensor} suspect {start:.2f}-{t:.2f} s")
    for sensor, start in since.items():
        if t_end_s - start > LONG_SUSPICION_S:
            long_suspicions += 1
            texts.append(f"{sensor} suspect from {start:.2f} s to the end")
    return exclusions, long_suspicions, texts


def judge(result: dict[str, Any], expect: str, run_dir: Path) -> dict[str, Any]:
    """A run's verdict and the figures behind it (added to the trial's own metrics)."""
    t_end = float(result.get("sim_s", math.nan))  # the MCU time the run ended
    exclusions, suspicions, events = health_events(run_dir, t_end)
    reached_truth = bool(result.get("completed")) and (
        float(result.get("goal_error_m", math.inf)) <= GOAL_TOLERANCE_M
    )
    failure = str(result.get("failure") or "")
    unreachable = "unreachable: blocked at (" in failure
    t_ins = float(result.get("t_insert_s", math.nan))
    after = t_end - t_ins if unreachable and math.isfinite(t_ins) else math.nan
    if expect == "reach":
        ok_outcome = reached_truth
    else:
        ok_outcome = unreachable and after <= UNREACHABLE_LIMIT_S
    passed = ok_outcome and int(result.get("collisions", 0)) == 0 and exclusions == 0
    return {
        "expect": expect,
        "reached_truth": reached_truth,
        "reported_unreachable": unreachable,
        "unreachable_after_drop_s": after,
        "exclusions": exclusions,
        "long_suspicions": suspicions,
        "health_events": events,
        "passed": bool(passed),
    }


def run_worlds_campaign(
    out: Path,
    trials: int,
    *,
    worlds: Sequence[str] = tuple(WORLDS),
    robots: Sequence[str] = ROBOTS,
    seed: int = 0,
    workers: int = 2,
    config: Path | None = None,
    progress: bool = True,
    cluster: str | None = None,
) -> list[dict[str, Any]]:
    """Map each world, navigate it ``trials`` times, judge every run, write the report.

    Parameters
    ----------
    out : Path
        The report folder.
    trials : int
        Navigations per world.
    worlds : sequence of str
        World names from :data:`WORLDS` (what each expects comes from there; another world
        file expects its goal to be reached).
    robots : sequence of str
        Twin robot files the trials alternate between; the mapping run uses the first.
    seed : int
        Base seed.
    workers : int
        Worker processes (or a Ray cluster's CPUs).
    config : Path or None
        Host configuration (default: the paper's robot).
    progress : bool
        Show a progress bar.
    cluster : str or None
        Run the trials on Ray (:func:`jackson.experiments.cluster.map_trials`).

    Returns
    -------
    list of dict
        Every navigation run's metrics and verdict.
    """
    from rich.progress import Progress

    from jackson.experiments.cluster import map_trials

    if cluster is not None:
        out = out.absolute()
        config = config.absolute() if config is not None else None
    out.mkdir(parents=True, exist_ok=True)
    wall0, cpu0 = time.perf_counter(), time.process_time()
    maps = [mapping_spec(robots[0], w, seed, out / "maps" / Path(w).stem, config) for w in worlds]
    specs: list[NavTrialSpec] = []
    expects: list[str] = []
    results: list[dict[str, Any]] = []
    failed_maps: dict[str, str] = {}
    with Progress(disable=not progress, transient=True) as bar:
        task = bar.add_task(f"worlds: mapping {len(maps)} worlds", total=len(maps))
        for k, r in map_trials(run_nav_trial, maps, workers=workers, cluster=cluster, folder=out):
            if not r["completed"]:
                failed_maps[worlds[k]] = str(r["failure"])
            bar.advance(task)
        for w_index, world in enumerate(worlds):
            if world in failed_maps:
                continue
            goals = world_goals(load_world(world))
            for i in range(trials):
                robot = robots[i % len(robots)]
                specs.append(
                    NavTrialSpec(
                        i,
                        seed + 1000 * w_index + i,
                        robot,
                        world,
                        out / "runs" / f"{Path(world).stem}-R{i + 1:02d}",
                        map_yaml=maps[w_index].out / "built_map.yaml",
                        goals=goals,
                        config=config,
                    )
                )
                expects.append(WORLDS.get(Path(world).stem, "reach"))
        task = bar.add_task(f"worlds: {len(specs)} navigations", total=len(specs))
        for k, r in map_trials(run_nav_trial, specs, workers=workers, cluster=cluster, folder=out):
            spec = specs[k]
            r["run"] = str(spec.out.relative_to(out))
            r["world"] = Path(spec.world).stem
            r["robot"] = spec.robot
            r["variant"] = r["world"]
            r.update(judge(r, expects[k], spec.out))
            results.append(r)
            bar.advance(task)
    results.sort(key=lambda r: (list(worlds).index(str(r["world"])), int(r["trial"])))
    meta = {
        "worlds": list(worlds),
        "robots": list(robots),
        "trials": trials,
        "seed": seed,
        "workers": workers,
        "failed_maps": failed_maps,
        "wall_s": time.perf_counter() - wall0,
        "cpu_s": time.process_time() - cpu0 + sum(float(r.get("cpu_s", 0.0)) for r in results),
    }
    write_worlds_report(out, results, meta)
    return results


def _median_iqr(values: Sequence[float], digits: int = 2) -> str:
    v = [x for x in values if x is not None and math.isfinite(x)]
    if not v:
        return "-"
    q1, q2, q3 = np.percentile(v, [25, 50, 75])
    return f"{q2:.{digits}f} [{q1:.{digits}f}, {q3:.{digits}f}]"


def write_worlds_report(out: Path, results: list[dict[str, Any]], meta: dict[str, Any]) -> None:
    """``runs.csv``, ``runs.json``, ``summary.md`` and one PNG per world."""
    columns: list[str] = []
    for r in results:
        columns += [k for k in r if k not in columns and not isinstance(r[k], (list, dict))]
    with (out / "runs.csv").open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=columns, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(results)
    (out / "runs.json").write_text(json.dumps({"meta": meta, "runs": results}, indent=1))
    lines = [
        "# Stage 3 over several worlds",
        "",
        f"{meta['trials']} navigations per world, robots {', '.join(meta['robots'])} in turn, "
        f"seed {meta['seed']}; every world maps itself first. Judged on the twin's ground "
        f"truth: *reached* = completed and the true end within {GOAL_TOLERANCE_M} m of the "
        f"goal; *unreachable* = reported as such within {UNREACHABLE_LIMIT_S:g} s of the drop. "
        f"{meta['wall_s']:.0f} s wall, {meta['cpu_s']:.0f} s CPU.",
        "",
        "| world | expects | passed | reached (truth) | reached (own) | unreachable "
        "reported [s after drop] | contacts | exclusions | suspicions > 2 s | t_nav [s] | "
        "d_min [cm] | recoveries | loc. error mean [cm] |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for world in meta["worlds"]:
        name = Path(world).stem
        runs = [r for r in results if r["world"] == name]
        if name in meta["failed_maps"]:
            lines.append(f"| {name} | mapping failed: {meta['failed_maps'][name]} |" + " |" * 11)
            continue
        n = len(runs)
        lines.append(
            f"| {name} | {runs[0]['expect'] if runs else '-'} "
            f"| {sum(r['passed'] for r in runs)}/{n} "
            f"| {sum(r['reached_truth'] for r in runs)}/{n} "
            f"| {sum(bool(r['completed']) for r in runs)}/{n} "
            f"| {sum(r['reported_unreachable'] for r in runs)}/{n} "
            f"{_median_iqr([r['unreachable_after_drop_s'] for r in runs])} "
            f"| {sum(int(r['collisions']) for r in runs)} "
            f"| {sum(r['exclusions'] for r in runs)} "
            f"| {sum(r['long_suspicions'] for r in runs)} "
            f"| {_median_iqr([r['t_nav_s'] for r in runs])} "
            f"| {_median_iqr([100 * r['d_min_m'] for r in runs], 1)} "
            f"| {sum(int(r['recoveries']) for r in runs)} "
            f"| {_median_iqr([r['localisation_error_mean_cm'] for r in runs], 1)} |"
        )
    bad = [r for r in results if not r["passed"] and not r.get("stalled")]
    if bad:
        lines += ["", "Runs that did not pass:", ""]
        for r in bad:
            why = r.get("failure") or f"true end {100 * r['goal_error_m']:.1f} cm from the goal"
            extra = "; ".join(r["health_events"])
            lines.append(f"- {r['run']} ({r['robot']}): {why}" + (f"; {extra}" if extra else ""))
    lines += stall_lines(results, lambda r: f"{r['run']} ({r['robot']})")
    events = [r for r in results if r["passed"] and r["health_events"]]
    if events:
        lines += ["", "Health events in runs that passed:", ""]
        lines += [f"- {r['run']}: {'; '.join(r['health_events'])}" for r in events]
    (out / "summary.md").write_text("\n".join(lines) + "\n")
    for world in meta["worlds"]:
        name = Path(world).stem
        runs = [r for r in results if r["world"] == name]
        if runs:
            plot_stage3(out / f"{name}.png", out, runs)
