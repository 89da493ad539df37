"""Stage 3 on the twin: mapping runs, navigation trials around the dropped cylinder, metrics.

A trial runs the real host daemon against the twin in lockstep, as :mod:`jackson.calibration.
trial` does for the square and the figure-eight, with the twin's emulated RPLIDAR on its own
pty read by the host's real driver. The daemon's command source is
:class:`jackson.host.control.navigate.NavigateMission`: particle-filter localisation on a map
made beforehand (``amcl``) or mapping while driving (``slam``), A* + DWB navigation.

* :func:`run_mapping` drives a survey route with ``slam`` in the world *without* its triggered
  obstacles (the paper maps the static maze first) and saves the map (PGM + YAML) with its
  SSIM against the twin's ground-truth raster (Eq. 15).
* :func:`run_nav_trial` drives start -> goal with ``amcl`` on such a map while the twin drops
  the cylinder, and returns the paper's Stage 3 metrics: success, contacts, d_min (Eq. 21,
  the oriented envelope from the insertion on), path length, t_nav, recoveries, plus the
  localisation error against ground truth.

Success is judged on the truth: a run is ``completed`` (the campaigns' success) when the
navigator reached its last goal by its own estimate (``reached``) *and* the twin's ground truth
ends within the goal tolerance of it (``reached_truth``, the true end distance in
``goal_error_m``). A run is limited by the mission's MCU time (the daemon's guard, 180 s); the
wall clock is a backstop (:func:`jackson.experiments.trial.wall_backstop_s`), and a lockstep
that stands still ends the run within seconds; a run cut either way has ``failure`` ``not
ended: ...`` (:func:`jackson.experiments.trial.cut_reason`).

Either run takes faults (:attr:`NavTrialSpec.faults`, :mod:`jackson.sim.faults`) as a square's
or a figure-eight's trial does: the twin injects them besides the robot file's, meta.json lists
their schedule and metrics.json what each injected.

A :class:`Variant` perturbs the twin, never the host (the host keeps its nominal beliefs, as
the paper's OFAT and robustness campaigns perturb the simulated robot): wheel radius, wheel
separation, drive torque (our analogue of the paper's PhysX drive damping D: the motor's
torque per unit of speed error scales with its stall torque), obstacle offset, floor friction,
LiDAR noise and dropout.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import math
import re
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import yaml

from jackson.common.errors import JacksonError
from jackson.experiments import metrics as m
from jackson.experiments.run_csv import write_ground_truth
from jackson.experiments.stall_retry import retry_stalled, stall_lines
from jackson.experiments.trial import cut_reason, twin_session, wall_backstop_s
from jackson.host.config import HostConfig, dump_config, load_config
from jackson.host.control.navigate import (
    MAP_NAME,
    Localisation,
    NavigateConfig,
    NavigateMission,
    navigate_meta,
)
from jackson.host.control.navigator import NavigatorConfig, check_route
from jackson.host.control.navigator_config import PLAN_DELAY_TICKS
from jackson.host.daemon import Daemon
from jackson.host.nav.grid import OccupancyGrid
from jackson.host.nav.types import Pose2D
from jackson.host.transport import STALL_S
from jackson.sim.config import RobotSpec, Sides, WorldSpec, load_robot, load_world
from jackson.sim.faults import FaultSpec, schedule

STAGE3_START = Pose2D(-0.6909, -0.0364, 0.0)  # REFERENCE: Stage 3
STAGE3_GOAL = Pose2D(1.2091, -0.0364, 0.0)
STAGE3_WORLD = "maze"


class MappingError(JacksonError, RuntimeError):
    """A Stage 3 campaign's mapping run did not complete: there is no map to navigate on."""


@dataclass(frozen=True)
class Variant:
    """One condition of a campaign: how the twin differs from the nominal robot and world.

    Attributes
    ----------
    name : str
        The paper's label (C00, C01, ..., G04).
    wheel_radius_scale, wheel_separation_scale : float
        Factors on the twin's true r and B (Table 4: 0.95, 1.05).
    drive_torque_scale : float
        Factor on the motors' stall torque: the drive's torque per unit of speed error, our
        analogue of the paper's drive damping D (Table 4: 0.90, 1.10).
    obstacle_dy_m : float
        Offset of the dropped cylinder across the route [m] (Table 10: +-0.15).
    mu_static, mu_dynamic : float or None
        Floor friction instead of the world's (Table 10 G03: 0.30, 0.25).
    lidar_extra_sigma_m : float
        Further LiDAR range noise [m] (G04: 0.03).
    lidar_dropout : float
        Probability a beam returns nothing (G04: 0.05).
    """

    name: str = "C00"
    wheel_radius_scale: float = 1.0
    wheel_separation_scale: float = 1.0
    drive_torque_scale: float = 1.0
    obstacle_dy_m: float = 0.0
    mu_static: float | None = None
    mu_dynamic: float | None = None
    lidar_extra_sigma_m: float = 0.0
    lidar_dropout: float = 0.0

    def robot(self, spec: RobotSpec) -> RobotSpec:
        """``spec`` with this variant's changes."""
        r = spec.wheel_radius_m
        k = self.wheel_radius_scale
        return dataclasses.replace(
            spec,
            wheel_radius_m=Sides(r.left * k, r.right * k),
            wheel_separation_m=spec.wheel_separation_m * self.wheel_separation_scale,
            motor=dataclasses.replace(
                spec.motor, stall_torque_nm=spec.motor.stall_torque_nm * self.drive_torque_scale
            ),
            lidar=dataclasses.replace(
                spec.lidar,
                extra_noise_sigma_m=spec.lidar.extra_noise_sigma_m + self.lidar_extra_sigma_m,
                dropout_probability=max(spec.lidar.dropout_probability, self.lidar_dropout),
            ),
        )

    def world(self, spec: WorldSpec) -> WorldSpec:
        """``spec`` with this variant's changes."""
        triggers = tuple(
            dataclasses.replace(
                t, cylinder=dataclasses.replace(t.cylinder, y=t.cylinder.y + self.obstacle_dy_m)
            )
            for t in spec.triggers
        )
        return dataclasses.replace(
            spec,
            triggers=triggers,
            mu_static=spec.mu_static if self.mu_static is None else self.mu_static,
            mu_dynamic=spec.mu_dynamic if self.mu_dynamic is None else self.mu_dynamic,
        )


OFAT = (  # Table 4: one factor at a time
    Variant("C00"),
    Variant("C01", wheel_radius_scale=0.95),
    Variant("C02", wheel_radius_scale=1.05),
    Variant("C03", wheel_separation_scale=0.95),
    Variant("C04", wheel_separation_scale=1.05),
    Variant("C05", drive_torque_scale=0.90),
    Variant("C06", drive_torque_scale=1.10),
)
ROBUSTNESS = (  # Table 10
    Variant("C00"),
    Variant("G01", obstacle_dy_m=0.15),
    Variant("G02", obstacle_dy_m=-0.15),
    Variant("G03", mu_static=0.30, mu_dynamic=0.25),
    Variant("G04", lidar_extra_sigma_m=0.03, lidar_dropout=0.05),
)


@dataclass(frozen=True)
class NavTrialSpec:
    """One navigation (or mapping) run on the twin.

    Attributes
    ----------
    index, seed : int
        Trial number and the twin's and the particle filter's seed.
    robot, world : str
        Twin robot and world files (names or paths).
    out : Path
        The run folder to write.
    map_yaml : Path or None
        The map to localise on (``amcl``); None maps while driving (``slam``).
    goals : tuple of Pose2D
        Visited in order (map = world frame).
    variant : Variant
        How the twin differs from nominal.
    config : Path or None
        Host configuration (default: the paper's robot).
    static_only : bool
        Leave out the world's triggered obstacles (a mapping run).
    faults : tuple of FaultSpec
        Faults injected besides the robot file's (:mod:`jackson.sim.faults`), as
        :class:`jackson.experiments.trial.TrialSpec`'s: meta.json lists their schedule and
        metrics.json what each injected (``faults``).
    stall_s : float
        Wall seconds both ends of the lockstep may wait for each other before the run is cut
        as stalled (:func:`jackson.experiments.trial.twin_session`).
    lidar_mode : str or None
        The RPLIDAR scan mode the host starts (None: the densest, as the daemon does;
        ``"standard"``, ``"Express"``...).
    """

    index: int
    seed: int
    robot: str
    world: str
    out: Path
    map_yaml: Path | None = None
    goals: tuple[Pose2D, ...] = (STAGE3_GOAL,)
    variant: Variant = field(default_factory=Variant)
    config: Path | None = None
    static_only: bool = False
    faults: tuple[FaultSpec, ...] = ()
    stall_s: float = STALL_S
    lidar_mode: str | None = None


def world_extent(world: WorldSpec, margin_m: float = 0.5) -> tuple[float, float, float, float]:
    """(x_min, y_min, x_max, y_max) of the walls and cylinders plus ``margin_m`` [m]."""
    xs = [p for w in world.walls for p in (w[0], w[2])] + [c.x for c in world.cylinders]
    ys = [p for w in world.walls for p in (w[1], w[3])] + [c.y for c in world.cylinders]
    x0, y0, _ = world.start_pose
    xs, ys = [*xs, x0], [*ys, y0]
    return (min(xs) - margin_m, min(ys) - margin_m, max(xs) + margin_m, max(ys) + margin_m)


def run_nav_trial(spec: NavTrialSpec) -> dict[str, Any]:
    """Drive one navigation (or mapping) run and return its metrics (also ``metrics.json``);
    a run cut by a lockstep stall is run once more (:mod:`jackson.experiments.stall_retry`)."""
    return retry_stalled(_run_nav_trial_once, spec, spec.out)


def _run_nav_trial_once(spec: NavTrialSpec) -> dict[str, Any]:
    """One run of :func:`run_nav_trial`."""
    from jackson.sim.twin import Twin

    cpu0 = time.process_time()  # the trial's CPU, the twin's thread included
    run_dir = spec.out
    run_dir.mkdir(parents=True, exist_ok=True)
    cfg = load_config(spec.config) if spec.config else HostConfig()
    world = spec.variant.world(load_world(spec.world))
    if spec.static_only:
        world = dataclasses.replace(world, triggers=())
    robot = spec.variant.robot(load_robot(spec.robot))
    twin = Twin(world, robot, lidar=True, seed=spec.seed, faults=spec.faults)
    faults = twin.faults.faults if twin.faults is not None else ()
    localisation: Localisation = "slam" if spec.map_yaml is None else "amcl"
    grid = OccupancyGrid.load(spec.map_yaml) if spec.map_yaml is not None else None
    nav = NavigateConfig(
        start=Pose2D(*world.start_pose),
        goals=spec.goals,
        localisation=localisation,
        extent=world_extent(world),
        seed=spec.seed,
        # as the daemon takes its plans (searched here, in lockstep: the same plans)
        navigator=NavigatorConfig(plan_delay_ticks=PLAN_DELAY_TICKS),
    )
    mission = NavigateMission(nav, cfg.navigation_limits(), grid)
    if grid is not None:
        grid.save(run_dir / f"{MAP_NAME}.yaml")  # the replay localises on the same map
    wall0 = time.perf_counter()
    with twin_session(
        twin, cfg, lidar=True, stall_s=spec.stall_s, lidar_mode=spec.lidar_mode
    ) as session:
        cfg = session.cfg
        (run_dir / "config.yaml").write_text(yaml.safe_dump(dump_config(cfg), sort_keys=False))
        meta = {
            "mission": "navigate",
            "navigate": navigate_meta(nav),
            "trial": spec.index,
            "seed": spec.seed,
            "robot": spec.robot,
            "world": spec.world,
            "variant": dataclasses.asdict(spec.variant),
            "faults": schedule(faults),
        }
        daemon = Daemon(
            cfg,
            session.output,
            session.transport,
            mission=mission,
            run_folder=run_dir,
            meta=meta,
            lidar=session.lidar,
        )
        # the mission's limit is MCU time (its route's); the wall clock only a backstop
        daemon.run(max_s=wall_backstop_s("navigate", mission.timeout_s))
        wall = time.perf_counter() - wall0
        cut = cut_reason(daemon, "navigate", session.runner.stalled)
    t_host = daemon.core.t_s if daemon.core.t_s is not None else math.inf
    truth = [s for s in twin.truth_log if s.t_s <= t_host + 1e-9]
    write_ground_truth(run_dir / "ground_truth.csv", truth)
    write_nav_samples(run_dir / "nav.csv", mission)
    inserted = list(twin.world.inserted)
    result = nav_metrics(mission, truth, inserted, cut or daemon.core.abort_reason)
    result.update(
        trial=spec.index,
        seed=spec.seed,
        variant=spec.variant.name,
        collisions=twin.collisions,
        scans=daemon.core.scans,
        wall_s=wall,
        sim_s=twin.t_s,
        real_time_factor=twin.t_s / wall if wall > 0 else math.inf,
        faults=twin.faults.record() if twin.faults is not None else [],
    )
    built = mission.finish_map(run_dir / "built_map.yaml")
    if built is not None and mission.mapper is not None:
        result["map_ssim"] = map_quality(built, world)
        result["map_nodes"] = len(mission.mapper.graph)
        result["map_loops_closed"] = mission.mapper.loops_closed
        result["map_optimisations"] = mission.mapper.optimisations
    result["cpu_s"] = time.process_time() - cpu0
    (run_dir / "metrics.json").write_text(json.dumps(result, indent=2) + "\n")
    return result


def write_nav_samples(path: Path, mission: NavigateMission) -> None:
    """``nav.csv``: the mission's belief (map-frame pose, command, state) per control tick."""
    with path.open("w", newline="") as f:
        w = csv.writer(f)
        fields = [f.name for f in dataclasses.fields(mission.samples[0])] if mission.samples else []
        w.writerow(fields)
        for s in mission.samples:
            w.writerow([repr(v) if isinstance(v, float) else v for v in dataclasses.astuple(s)])


def nav_metrics(
    mission: NavigateMission,
    truth: Sequence[Any],
    inserted: Sequence[tuple[float, Any]],
    abort_reason: str | None,
) -> dict[str, Any]:
    """The Stage 3 figures of one run from the twin's ground truth and the mission's log.

    Parameters
    ----------
    mission : NavigateMission
        The run's mission, after the run.
    truth : sequence of Truth
        The twin's ground truth up to the host's last frame.
    inserted : sequence of (float, Cylinder)
        The obstacles the twin dropped, with their time [s].
    abort_reason : str or None
        Why the host stopped the run (an abort, or a cut: ``not ended: ...``), None otherwise.

    Returns
    -------
    dict
        The figures. ``reached``: the navigator reached the last goal by its own estimate;
        ``reached_truth``: the ground truth ends within the goal tolerance of it
        (``goal_tolerance_m``; the true end distance is ``goal_error_m``); ``completed``, the
        run's success: both. ``failure`` names why a run did not succeed.
    """
    t = np.array([s.t_s for s in truth])
    poses = np.array([(s.x, s.y, s.yaw) for s in truth]).reshape(-1, 3)
    reached = mission.done and mission.failure is None and abort_reason is None
    end = poses[-1] if t.size else np.zeros(3)
    goal = mission.config.goals[-1]
    goal_error_m = float(math.hypot(end[0] - goal.x, end[1] - goal.y))
    tolerance_m = mission.config.navigator.xy_goal_tolerance_m
    reached_truth = bool(t.size) and goal_error_m <= tolerance_m
    success = reached and reached_truth
    failure = mission.failure or abort_reason
    if reached and not reached_truth:
        failure = (
            f"reached by the navigator's own estimate, but the true end is "
            f"{100 * goal_error_m:.1f} cm from the goal (tolerance {100 * tolerance_m:g} cm)"
        )
    t0 = mission.t_start_s if mission.t_start_s is not None else 0.0
    t1 = mission.t_goal_s if mission.t_goal_s is not None else (t[-1] if t.size else t0)
    moving = (t >= t0) & (t <= t1)
    path_m = (
        float(np.sum(np.hypot(*np.diff(poses[moving, :2], axis=0).T))) if moving.sum() > 1 else 0.0
    )
    d_min = math.nan
    t_ins = math.nan
    cylinder = None
    if inserted and t.size:
        t_ins, cyl = inserted[0]
        cylinder = [cyl.x, cyl.y, cyl.radius]
        after = t >= t_ins
        if after.any():
            d_min = m.d_min(poses[after], (cyl.x, cyl.y, cyl.radius))
    d_min_est = math.nan
    # the mission's belief against the truth at its ticks
    err = []
    yaw_err = []
    if mission.samples and t.size:
        ts = np.array([s.t_s for s in mission.samples])
        est = np.array([(s.x_m, s.y_m, s.yaw_rad) for s in mission.samples])
        gx, gy = np.interp(ts, t, poses[:, 0]), np.interp(ts, t, poses[:, 1])
        gyaw = np.interp(ts, t, np.unwrap(poses[:, 2]))
        err = np.hypot(est[:, 0] - gx, est[:, 1] - gy).tolist()
        yaw_err = np.abs(m.wrap_angle(est[:, 2] - gyaw)).tolist()
        if cylinder is not None and (ts >= t_ins).any():
            # the physical robot's d_min (T14) is of its own (AMCL) estimate: this one
            d_min_est = m.d_min(est[ts >= t_ins], tuple(cylinder))
    return {
        "completed": bool(success),
        "reached": bool(reached),
        "reached_truth": bool(reached_truth),
        "failure": failure,
        "t_nav_s": (t1 - t0) if success else math.nan,
        "duration_s": float(t1 - t0),
        "path_length_m": path_m,
        "d_min_m": d_min,
        "d_min_estimate_m": d_min_est,
        "t_insert_s": t_ins,
        "t_start_s": t0,
        "cylinder": cylinder,
        "recoveries": int(sum(mission.navigator.recoveries.values())),
        "recoveries_by_kind": dict(mission.navigator.recoveries),
        "replans": mission.navigator.replans,
        "goal_error_m": goal_error_m,
        "goal_tolerance_m": tolerance_m,
        "start": [mission.config.start.x, mission.config.start.y],
        "goal": [goal.x, goal.y],
        "localisation_error_mean_cm": 100 * float(np.mean(err)) if err else math.nan,
        "localisation_error_max_cm": 100 * float(np.max(err)) if err else math.nan,
        "localisation_yaw_error_max_deg": math.degrees(float(np.max(yaw_err)))
        if yaw_err
        else math.nan,
    }


def map_quality(grid: OccupancyGrid, world: WorldSpec) -> float:
    """SSIM (Eq. 15) of a built map against the twin's raster of ``world`` on the same cells;
    only what the robot could have seen counts as free in the truth (the rest unknown)."""
    from jackson.sim.raster import raster, reachable_free

    bounds = (
        grid.origin_x_m,
        grid.origin_y_m,
        grid.origin_x_m + grid.width * grid.resolution_m,
        grid.origin_y_m + grid.height * grid.resolution_m,
    )
    occ, ox, oy = raster(world, grid.resolution_m, bounds=bounds)
    x0, y0, _ = world.start_pose
    free = reachable_free(occ, ox, oy, grid.resolution_m, (x0, y0))
    truth = np.full(occ.shape, -1, np.int8)
    truth[free] = 0
    truth[occ] = 100
    rows, cols = min(truth.shape[0], grid.height), min(truth.shape[1], grid.width)
    return float(m.map_ssim(grid.data[:rows, :cols], truth[:rows, :cols]))


# ---------------------------------------------------------------------------------- campaigns

PAPER_MEDIANS = {  # REFERENCE: OFAT medians (D_traj cm / d_min cm / t_nav s) and robustness
    "C00": (1.05, 8.17, 13.23),
    "C02": (35.80, 4.95, 25.20),
    "C03": (4.25, 5.65, 54.31),
    "G04": (math.nan, math.nan, 18.12),
}
CAMPAIGNS: dict[str, tuple[Variant, ...]] = {
    "maze": (Variant("C00"),),
    "ofat": OFAT,
    "robustness": ROBUSTNESS,
}


def trajectory_xy(run_dir: Path, result: dict[str, Any]) -> npt.NDArray[np.float64]:
    """The ground-truth path from time zero to the goal, anchored at the start (Eq. 19-20
    compare aligned trajectories)."""
    from jackson.experiments.run_csv import read_csv

    gt = read_csv(run_dir / "ground_truth.csv")
    t0 = float(result.get("t_start_s", 0.0) or 0.0)
    keep = gt["t_s"] >= t0
    xy = np.column_stack((gt["x_m"][keep], gt["y_m"][keep]))
    return xy - xy[0] if len(xy) else xy


def run_stage3_campaign(
    name: str,
    trials: int,
    out: Path,
    *,
    robot: str = "jackson_physical",
    world: str = STAGE3_WORLD,
    seed: int = 0,
    workers: int = 2,
    config: Path | None = None,
    map_yaml: Path | None = None,
    progress: bool = True,
    cluster: str | None = None,
    lidar_mode: str | None = None,
) -> list[dict[str, Any]]:
    """Every variant of campaign ``name`` ``trials`` times, in worker processes (or on a Ray
    ``cluster``: ``local``, ``auto``, ``ray://HOST:PORT``, see
    :func:`jackson.experiments.cluster.map_trials`; the paths are then made absolute); the map
    is built once first (unless given); writes ``runs.csv``, ``runs.json``, ``summary.md`` and
    plots into ``out``. ``lidar_mode``: the RPLIDAR scan mode the host starts (None: the
    densest)."""
    from rich.progress import Progress

    from jackson.experiments.cluster import map_trials

    variants = CAMPAIGNS[name]
    if cluster is not None:
        out = out.absolute()
        config = config.absolute() if config is not None else None
        map_yaml = map_yaml.absolute() if map_yaml is not None else None
    out.mkdir(parents=True, exist_ok=True)
    wall0 = time.perf_counter()
    cpu0 = time.process_time()
    if map_yaml is None:
        survey = mapping_spec(robot, world, seed, out / "map", config)
        mapping = run_nav_trial(dataclasses.replace(survey, lidar_mode=lidar_mode))
        if not mapping["completed"]:
            raise MappingError(f"the mapping run failed: {mapping['failure']}")
        map_yaml = out / "map" / "built_map.yaml"
    goals = world_goals(load_world(world))
    specs = [
        NavTrialSpec(
            i,
            seed + 1000 * k + i,
            robot,
            world,
            out / "runs" / f"{v.name}-R{i + 1:02d}",
            map_yaml=map_yaml,
            goals=goals,
            variant=v,
            config=config,
            lidar_mode=lidar_mode,
        )
        for k, v in enumerate(variants)
        for i in range(trials)
    ]
    results: list[dict[str, Any]] = []
    with Progress(disable=not progress, transient=True) as bar:
        task = bar.add_task(f"{name}: {len(specs)} runs", total=len(specs))
        for k, r in map_trials(run_nav_trial, specs, workers=workers, cluster=cluster, folder=out):
            r["run"] = str(specs[k].out.relative_to(out))
            results.append(r)
            bar.advance(task)
    results.sort(key=lambda r: (str(r["variant"]), int(r["trial"])))
    add_d_traj(out, results)
    wall = time.perf_counter() - wall0
    meta = {
        "robot": robot,
        "world": world,
        "seed": seed,
        "trials": trials,
        "workers": workers,
        "wall_s": wall,
        # this process's (the mapping run) and every trial's, in whichever worker it ran
        "cpu_s": time.process_time() - cpu0 + sum(float(r["cpu_s"]) for r in results),
        "map": str(map_yaml),
        "lidar_mode": lidar_mode or "densest",
    }
    write_stage3_report(out, name, results, meta)
    return results


def mapping_spec(
    robot: str, world: str, seed: int, out: Path, config: Path | None = None
) -> NavTrialSpec:
    """The survey of the static world: through the world's ``survey`` waypoints (by default
    to its goal, or the Stage 3 goal) and back to the start."""
    spec = load_world(world)
    start = Pose2D(*spec.start_pose)
    via = tuple(Pose2D(x, y) for x, y in spec.survey) or world_goals(spec)
    return NavTrialSpec(
        0, seed, robot, world, out, goals=(*via, start), config=config, static_only=True
    )


def world_grid(world: WorldSpec, resolution_m: float = 0.05) -> OccupancyGrid:
    """The world's walls and cylinders as an occupancy grid (100 occupied, 0 free): the map
    a survey would ideally build."""
    from jackson.sim.raster import raster

    occupied, ox, oy = raster(world, resolution_m)
    return OccupancyGrid(np.where(occupied, 100, 0).astype(np.int8), resolution_m, ox, oy)


def check_world_route(world: WorldSpec, goals: tuple[Pose2D, ...]) -> None:
    """Refuse goals the twin's world rules out (in or beside a wall or cylinder, outside the
    world, shut off from the start), before a mapping run drives anywhere.

    Raises
    ------
    RouteError
        As :func:`jackson.host.control.navigator.check_route` on the world's own raster.
    """
    grid = world_grid(world)
    check_route(grid, Pose2D(*world.start_pose), goals, NavigatorConfig())


def world_goals(world: WorldSpec) -> tuple[Pose2D, ...]:
    """The goal a world file gives (``goal``), else the paper's Stage 3 goal."""
    return (Pose2D(*world.goal),) if world.goal is not None else (STAGE3_GOAL,)


def add_d_traj(out: Path, results: list[dict[str, Any]]) -> None:
    """D_traj (Eq. 19-20) of every completed run against the median of the C00 runs (their
    own by leave-one-out), in cm."""
    paths = {id(r): trajectory_xy(out / r["run"], r) for r in results if r["completed"]}
    base = [r for r in results if r["completed"] and r["variant"] == "C00"]
    if len(base) < 2:
        return
    base_paths = [paths[id(r)] for r in base]
    loo = m.d_traj_leave_one_out(base_paths)
    for r, d in zip(base, loo, strict=True):
        r["d_traj_cm"] = 100.0 * float(d)
    baseline = m.median_baseline(base_paths)
    for r in results:
        if r["completed"] and r["variant"] != "C00":
            r["d_traj_cm"] = 100.0 * m.d_traj(paths[id(r)], baseline)


def _median_iqr(values: Sequence[float], scale: float = 1.0, digits: int = 2) -> str:
    v = [x * scale for x in values if x is not None and math.isfinite(x)]
    if not v:
        return "-"
    q = m.median_iqr(v)
    return f"{q.median:.{digits}f} [{q.q1:.{digits}f}, {q.q3:.{digits}f}]"


def write_stage3_report(
    out: Path, name: str, results: list[dict[str, Any]], meta: dict[str, Any]
) -> None:
    """``runs.json``, ``runs.csv``, ``summary.md`` (median [IQR] per variant beside the
    paper's medians) and ``stage3.png``."""
    from jackson.experiments.campaign import write_runs

    flat = [{k: v for k, v in r.items() if not isinstance(v, (dict, list))} for r in results]
    write_runs(out, flat)
    lines = [
        f"# Stage 3 campaign `{name}`",
        "",
        f"Robot `{meta['robot']}`, world `{meta['world']}`, {meta['trials']} trials per "
        f"variant, seed {meta['seed']}, {meta['workers']} workers, wall time "
        f"{meta['wall_s']:.0f} s, CPU time {meta['cpu_s']:.0f} s. Map: `{meta['map']}`.",
        "",
        "Success is judged on the truth: the navigator reached the goal by its own estimate "
        "*and* the twin's ground truth ends within the goal tolerance of it; `reached (own "
        "estimate)` counts the navigator's judgement alone. Continuous outcomes: median [IQR] "
        "over successful runs (REFERENCE: Stage 3).",
        "",
        "| variant | success | reached (own estimate) | contacts | recoveries | D_traj (cm) |"
        " d_min (cm) | path (m) | t_nav (s) | loc. error mean (cm) |"
        " paper D_traj / d_min / t_nav |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    variants = sorted({str(r["variant"]) for r in results})
    for v in variants:
        rs = [r for r in results if r["variant"] == v]
        ok = [r for r in rs if r["completed"]]
        paper = PAPER_MEDIANS.get(v)
        paper_text = " / ".join("-" if math.isnan(x) else f"{x:g}" for x in paper) if paper else "-"
        lines.append(
            f"| {v} | {len(ok)}/{len(rs)} | "
            f"{sum(1 for r in rs if r.get('reached', r['completed']))}/{len(rs)} | "
            f"{sum(int(r['collisions']) for r in rs)} | "
            f"{sum(int(r['recoveries']) for r in rs)} | "
            f"{_median_iqr([r.get('d_traj_cm', math.nan) for r in ok])} | "
            f"{_median_iqr([r['d_min_m'] for r in ok], 100.0)} | "
            f"{_median_iqr([r['path_length_m'] for r in ok], 1.0, 3)} | "
            f"{_median_iqr([r['t_nav_s'] for r in ok])} | "
            f"{_median_iqr([r['localisation_error_mean_cm'] for r in ok])} | {paper_text} |"
        )
    failures = [
        f"- {r['run']}: {r['failure']}"
        for r in results
        if not r["completed"] and not r.get("stalled")
    ]
    if failures:
        lines += ["", "Runs that did not reach the goal:", "", *failures]
    lines += stall_lines(results, lambda r: str(r["run"]))
    from jackson.experiments.report import judge_consistency

    runs = [out / str(r["run"]) for r in results]  # the odometry frame's pose, the truth in it
    _, consistency = judge_consistency(out, runs, "navigation", closed_path=False)
    lines += ["", "## Consistency of the EKF's covariance", "", *consistency]
    lines += [
        "",
        "Paper (REFERENCE): success 10/10 and 0 collisions on both domains; d_min 0.122 ± "
        "0.007 m (physical), 0.074 ± 0.016 m (Isaac); path 1.958 ± 0.014 / 1.888 ± 0.039 m; "
        "t_nav 22.405 ± 0.816 s / median 13.317 s.",
        "",
    ]
    (out / "summary.md").write_text("\n".join(lines))
    (out / "meta.json").write_text(json.dumps(meta, indent=2) + "\n")
    plot_stage3(out / "stage3.png", out, results)


def plot_stage3(png: Path, out: Path, results: list[dict[str, Any]], vector: bool = True) -> None:
    """The map, every run's true path (coloured by variant), the cylinder(s) and the robot's
    envelope where it came closest to the cylinder in the run with the smallest d_min (the
    PDF beside the PNG unless ``vector`` is False)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Circle, Polygon

    from jackson.experiments.run_csv import read_csv

    fig, ax = plt.subplots(figsize=(9, 6))
    first = out / results[0]["run"] if results else None
    if first is not None and (first / f"{MAP_NAME}.yaml").exists():
        grid = OccupancyGrid.load(first / f"{MAP_NAME}.yaml")
        img = np.where(grid.data < 0, 0.75, np.where(grid.data >= 50, 0.0, 1.0))
        x0, y0 = grid.origin_x_m, grid.origin_y_m
        res = grid.resolution_m
        extent = (x0, x0 + grid.width * res, y0, y0 + grid.height * res)
        ax.imshow(img, cmap="gray", vmin=0, vmax=1, origin="lower", extent=extent)
        rows, cols = np.nonzero(grid.data >= 0)
        if rows.size:  # zoom on what the map knows
            ax.set_xlim(x0 + (cols.min() - 4) * res, x0 + (cols.max() + 5) * res)
            ax.set_ylim(y0 + (rows.min() - 4) * res, y0 + (rows.max() + 5) * res)
    colours = plt.get_cmap("tab10")
    variants = sorted({str(r["variant"]) for r in results})
    closest: tuple[float, npt.NDArray[np.float64], Any] | None = None
    for r in results:
        gt = read_csv(out / r["run"] / "ground_truth.csv")
        k = variants.index(str(r["variant"]))
        ax.plot(gt["x_m"], gt["y_m"], lw=0.8, alpha=0.7, color=colours(k % 10))
        cyl = r.get("cylinder")
        if cyl is not None and math.isfinite(r["d_min_m"]):
            poses = np.column_stack((gt["x_m"], gt["y_m"], gt["yaw_rad"]))
            t_ok = gt["t_s"] >= r["t_insert_s"]
            dist = m.envelope_to_circle_distance(poses[t_ok], tuple(cyl))
            i = int(np.argmin(dist))
            if closest is None or dist[i] < closest[0]:
                closest = (float(dist[i]), poses[t_ok][i], cyl)
    for k, v in enumerate(variants):  # a paper's condition (C00: the baseline) or a world
        runs = sum(str(r["variant"]) == v for r in results)
        what = f"condition {v}" if re.fullmatch(r"[A-Z]\d\d", v) else v
        label = f"true path{'s' if runs > 1 else ''}, {what}"
        ax.plot([], [], color=colours(k % 10), label=label)
    drawn = set()
    for r in results:
        cyl = r.get("cylinder")
        if cyl is not None and tuple(cyl) not in drawn:
            drawn.add(tuple(cyl))
            ax.add_patch(Circle((cyl[0], cyl[1]), cyl[2], color="tab:red", alpha=0.35))
    if closest is not None:
        d, (x, y, yaw), _ = closest
        (ex0, ex1), (ey0, ey1) = m.ENVELOPE_X_M, m.ENVELOPE_Y_M
        corners = np.array([(ex0, ey0), (ex1, ey0), (ex1, ey1), (ex0, ey1)])
        c, s = math.cos(yaw), math.sin(yaw)
        world = corners @ np.array([[c, s], [-s, c]]) + (x, y)
        label = f"envelope at d_min {100 * d:.1f} cm"
        ax.add_patch(Polygon(world, fill=False, ec="k", lw=1.2, label=label))
    start = results[0].get("start", [STAGE3_START.x, STAGE3_START.y]) if results else [0, 0]
    goal = results[0].get("goal", [STAGE3_GOAL.x, STAGE3_GOAL.y]) if results else [0, 0]
    ax.plot(start[0], start[1], "go", label="start")
    ax.plot(goal[0], goal[1], "r*", ms=12, label="goal")
    tolerance = Circle((goal[0], goal[1]), 0.25, fill=False, ls="--", ec="tab:red")
    tolerance.set_label("xy goal tolerance 0.25 m")
    ax.add_patch(tolerance)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title("Stage 3 on the twin: map, true paths" + (", dropped cylinder" if drawn else ""))
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
    fig.tight_layout()
    from jackson.common.figures import save_figure

    save_figure(fig, png, vector=vector, bbox_inches="tight")
