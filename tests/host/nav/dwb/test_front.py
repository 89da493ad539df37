"""The DWB cycle's compiled front (window, roll-outs, batch in one call) against numpy's path,
bit for bit, and the planner's choice with and without it."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from jackson.host.actuation.limiter import LimiterConfig
from jackson.host.nav import native, native_grid
from jackson.host.nav.costmap import Costmap, CostmapConfig
from jackson.host.nav.dwb import Batch, DwbConfig, DwbPlanner
from jackson.host.nav.dwb import planner as planner_module
from jackson.host.nav.dwb.front import FrontLayout, front
from jackson.host.nav.types import Pose2D
from jackson.sim.lidar import Obstacles

from ...stage3_course import CYLINDER, GOAL, WALLS, scan_points

pytestmark = pytest.mark.skipif(native.LIB is None, reason=f"no compiled build: {native.REASON}")

BATCH_ARRAYS = (
    "v_m_s", "w_rad_s", "coarse_x_m", "coarse_y_m", "coarse_length_m", "x_end_m", "y_end_m",
    "yaw_end_rad", "cos_end", "sin_end", "end_cell", "end_on_grid",
)  # fmt: skip
ROLLOUT_ARRAYS = ("t_s", "ds_m", "yaw_rad", "cos_sin", "iv", "iw")

# windows of every shape: the defaults, one sample per axis, two, odd counts with a floor on
# v, a floor on v with slow turns (no row of in-place turns), a turn rate below the in-place
# minimum, and slow angular bounds with a short simulation
CONFIGS = (
    (DwbConfig(), LimiterConfig()),
    (DwbConfig(vx_samples=4, vtheta_samples=20, min_vel_x_m_s=0.05), LimiterConfig()),
    (DwbConfig(vx_samples=1, vtheta_samples=1), LimiterConfig()),
    (DwbConfig(vx_samples=2, vtheta_samples=2), LimiterConfig()),
    (DwbConfig(vx_samples=7, vtheta_samples=5, min_vel_x_m_s=0.05), LimiterConfig()),
    (DwbConfig(vx_samples=5, vtheta_samples=9), LimiterConfig(max_w_rad_s=0.2)),
    (
        DwbConfig(vx_samples=3, vtheta_samples=4, sim_time_s=0.4),
        LimiterConfig(max_alpha_rad_s2=0.5, max_alpha_decel_rad_s2=0.5),
    ),
)


def _costmap(rng: np.random.Generator) -> Costmap:
    """A rolling window with a wall and the cylinder seen from a random pose."""
    world = Obstacles(segments=WALLS)
    world.add_circle(*CYLINDER)
    pose = Pose2D(float(rng.uniform(-0.4, 1.2)), float(rng.uniform(-0.3, 0.3)), 0.0)
    cm = Costmap.rolling_window(CostmapConfig(), pose.x, pose.y)
    cm.update(scan_points(pose, world, rng, 0.01), (pose.x, pose.y))
    return cm


def _velocity(rng: np.random.Generator, case: int) -> tuple[float, float]:
    """At rest, turning on the spot, beyond the bounds either way, reversing, or anywhere."""
    return (
        (0.0, 0.0) if case == 0 else
        (0.0, float(rng.uniform(-1.5, 1.5))) if case == 1 else
        (0.6, -3.0) if case == 2 else
        (-0.2, 3.0) if case == 3 else
        (-0.0, -0.0) if case == 4 else
        (float(rng.uniform(-0.1, 0.35)), float(rng.uniform(-2.0, 2.0)))
    )  # fmt: skip


def _same(a: np.ndarray, b: np.ndarray, what: str) -> None:
    a, b = np.asarray(a), np.asarray(b)
    assert (a.shape, a.dtype) == (b.shape, b.dtype), what
    assert a.tobytes() == b.tobytes(), what


@pytest.mark.parametrize("which", range(len(CONFIGS)))
def test_the_compiled_front_is_numpys_window_rollouts_and_batch_bit_for_bit(which: int) -> None:
    """Targets, tables, cosines, coarse poses, end poses and cells, the cells ahead of the end
    poses: the bytes numpy's path makes (signed zeros included), on the grid and off it."""
    config, limits = CONFIGS[which]
    planner = DwbPlanner(config, limits)
    layout = FrontLayout.of(config, planner.kinematics)
    rng = np.random.default_rng(80 + which)
    for case in range(14):
        cm = _costmap(rng)
        far = case % 5 == 4  # a pose off the window: every cell clipped, none on the grid
        pose = Pose2D(
            float(rng.uniform(-0.5, 1.3)) + (9.0 if far else 0.0), float(rng.uniform(-0.4, 0.4)),
            float(rng.uniform(-math.pi, math.pi)),
        )  # fmt: skip
        velocity = _velocity(rng, case)
        made = front(layout, pose, velocity, cm)
        assert made is not None
        ro, batch = made
        v, w, v_brake = planner.samples(*velocity)
        want_ro = planner.rollouts(pose, velocity, v, w)
        want = Batch.of(v, w, v_brake, want_ro, cm)
        assert batch.v_brake_m_s == want.v_brake_m_s
        for name in BATCH_ARRAYS:
            _same(getattr(batch, name), getattr(want, name), name)
        for name in ROLLOUT_ARRAYS:
            _same(getattr(ro, name), getattr(want_ro, name), name)
        assert set(batch._forward) == set(layout.forward_m)
        for d in layout.forward_m:
            for got, expected in zip(batch._forward[d], want.forward_cells(d), strict=True):
                _same(got, expected, f"forward {d}")
        assert not far or not batch.end_on_grid.any()
        for m in {0, batch.size // 2, batch.size - 1}:  # the chosen one's poses, compiled
            compiled = ro.trajectory(m)
            with pytest.MonkeyPatch.context() as patch:
                patch.setattr(native, "LIB", None)
                _same(compiled, ro.trajectory(m), f"trajectory {m}")


def test_a_window_beyond_the_layouts_room_takes_numpys_path() -> None:
    """A layout with too little room for the steps makes nothing (no write past its buffers);
    the planner then chooses by numpy's path, the same command."""
    planner = DwbPlanner(DwbConfig(), LimiterConfig())
    cm = _costmap(np.random.default_rng(3))
    pose = Pose2D(0.0, 0.0, 0.3)
    layout = FrontLayout.of(planner.config, planner.kinematics)
    for room in ((1, 20, 42, 80), (420, 1, 42, 80), (420, 20, 1, 80), (420, 20, 42, 1)):
        small = replace(layout, capacity=np.array(room, np.int64))
        assert front(small, pose, (0.1, 0.5), cm) is None
    want = planner.compute(pose, (0.1, 0.5), _path(pose), GOAL, cm)
    planner._front = replace(layout, capacity=np.array((420, 20, 42, 1), np.int64))
    got = planner.compute(pose, (0.1, 0.5), _path(pose), GOAL, cm)
    assert (got.v_m_s, got.w_rad_s, got.total, got.scores) == (
        want.v_m_s, want.w_rad_s, want.total, want.scores,
    )  # fmt: skip


def _path(pose: Pose2D) -> np.ndarray:
    n = max(2, round((GOAL.x - pose.x) / 0.05) + 1)
    return np.column_stack((np.linspace(pose.x, GOAL.x, n), np.full(n, pose.y)))


@pytest.mark.parametrize("seed", range(3))
def test_the_planner_chooses_the_same_with_the_compiled_front(
    seed: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Every command (speeds, total, scores, trajectory, legal count, reason) of cycles near
    the walls and the cylinder, at rest and moving, with the front compiled and without it."""
    rng = np.random.default_rng(90 + seed)
    for case in range(10):
        cm = _costmap(rng)
        pose = Pose2D(
            float(rng.uniform(-0.4, 1.2)), float(rng.uniform(-0.3, 0.3)),
            float(rng.uniform(-math.pi, math.pi)),
        )  # fmt: skip
        velocity = _velocity(rng, case)
        commands = []
        for compiled in (True, False):
            if not compiled:
                monkeypatch.setattr(planner_module, "front", lambda *args: None)
            planner = DwbPlanner(DwbConfig(), LimiterConfig())
            commands.append(planner.compute(pose, velocity, _path(pose), GOAL, cm))
        a, b = commands
        assert (a.v_m_s, a.w_rad_s, a.total, a.valid, a.reason, a.samples, a.legal) == (
            b.v_m_s, b.w_rad_s, b.total, b.valid, b.reason, b.samples, b.legal,
        )  # fmt: skip
        assert a.scores == b.scores and a.trajectory.tobytes() == b.trajectory.tobytes()
        monkeypatch.undo()


@pytest.mark.parametrize("seed", range(6))
def test_the_compiled_plan_cells_are_numpys_slice_and_cells(seed: int) -> None:
    """The path's slice and its cells in the window, compiled and by numpy (plan_span,
    densify, plan_cells): the same span, cells and end, for paths through the window and out of
    it, back over themselves, with repeated points, of one point, and wholly off the grid."""
    from jackson.host.nav.dwb.core.path import plan_cells, plan_span

    rng = np.random.default_rng(70 + seed)
    config = DwbConfig()
    for case in range(12):
        cm = _costmap(rng)
        g = cm.geometry
        pose = Pose2D(float(rng.uniform(-0.5, 1.3)), float(rng.uniform(-0.4, 0.4)), 0.0)
        n = int(rng.integers(1, 40))
        steps = rng.normal(0.0, 0.12, (n, 2))
        steps[rng.random(n) < 0.2] = 0.0  # repeated points
        path = np.cumsum(steps, axis=0) + np.array([pose.x, pose.y])
        if case == 0:
            path = path + 50.0  # nowhere near the window
        elif case == 1:
            path = path[:1]
        elif case == 2:
            path = np.concatenate((path, path[::-1]))  # out and back
        found = native_grid.dwb_plan_cells(
            path, (pose.x, pose.y), (config.prune_distance_m, config.forward_prune_distance_m),
            g.as_tuple(), cm.costs_padded,
        )  # fmt: skip
        span = plan_span(pose, path, cm, config.prune_distance_m, config.forward_prune_distance_m)
        want = plan_cells(path, span, cm)
        if want is None:
            assert found is None
            continue
        assert found is not None
        assert found[0] == span and found[3] == want.reaches_end
        _same(found[1], want.rows, "rows")
        _same(found[2], want.cols, "cols")
    cm = _costmap(rng)
    with pytest.raises(ValueError, match="an empty path"):
        native_grid.dwb_plan_cells(np.empty((0, 2)), (0.0, 0.0), (1.0, 1.0), cm.geometry.as_tuple(),
                              cm.costs_padded)  # fmt: skip
