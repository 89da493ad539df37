"""The largest loop's closure error from a saved pose graph: a chain that drifts by a known
amount is that far off before, optimised poses that are exact are not off after, and the
loop chosen is the one spanning the most travel."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from jackson.experiments.metrics.inputs import MetricInputError
from jackson.experiments.metrics.loop_closure import (
    largest_loop,
    loop_closure_error,
    read_graph,
    relative,
)

N = 21  # nodes, one a second, 0.5 m apart round a circle of 20 steps
STEP_RAD = 2 * math.pi / 20
RADIUS = 0.5 / (2 * math.sin(STEP_RAD / 2))


def true_pose(t: float | np.ndarray) -> np.ndarray:
    """The base on a circle, counter-clockwise, heading along it, node k at t = k s."""
    a = np.asarray(t, np.float64) * STEP_RAD
    return np.stack((RADIUS * np.sin(a), RADIUS * (1 - np.cos(a)), a), axis=-1)


def write_graph(
    path: Path,
    chain_bias: tuple[float, float, float] = (0.0, 0.0, 0.0),
    loops: tuple[tuple[int, int], ...] = ((0, 20),),
    poses: np.ndarray | None = None,
    drop_chain: int | None = None,
) -> Path:
    """A graph file of the circle: chain edges the true steps plus ``chain_bias`` each, the
    nodes' poses ``poses`` (default the truth), loop edges at the true relative pose."""
    truth = true_pose(np.arange(N, dtype=np.float64))
    step = relative(truth[0], truth[1])
    edges = [(k - 1, k) for k in range(1, N) if k != drop_chain]
    z = [step + np.array(chain_bias) for _ in edges]
    edges += list(loops)
    z += [relative(truth[i], truth[j]) for i, j in loops]
    np.savez_compressed(
        path,
        poses=truth if poses is None else poses,
        scan_t=np.arange(N, dtype=np.float64),
        travel=0.5 * np.arange(N, dtype=np.float64),
        edge_nodes=np.array(edges, np.int64).reshape(-1, 2),
        edge_z=np.array(z).reshape(-1, 3),
        edge_loop=np.array([False] * (len(edges) - len(loops)) + [True] * len(loops)),
    )
    return path


def truth_csv(path: Path) -> Path:
    """``ground_truth.csv`` every 0.03 s from -0.02 s (never at the scans' times: interpolated
    there, to within 0.2 mm on the circle)."""
    t = np.arange(-0.02, N, 0.03)
    p = true_pose(t)
    rows = "".join(
        f"{a:.17g},{x:.17g},{y:.17g},{th:.17g},0,0,0\n" for a, (x, y, th) in zip(t, p, strict=True)
    )
    path.write_text("t_s,x_m,y_m,yaw_rad,vx_m_s,vy_m_s,wz_rad_s\n" + rows)
    return path


def test_a_chain_stretched_1_percent_is_off_by_1_percent_before_and_exact_after(
    tmp_path: Path,
) -> None:
    # half way round: each step 1 % long in its own direction stretches the half circle,
    # whose ends are a diameter apart, by 1 % of it; the heading stays right
    graph = write_graph(tmp_path / "g.npz", chain_bias=(0.005, 0.0, 0.0), loops=((0, 10),))
    e = loop_closure_error(graph, truth_csv(tmp_path / "gt.csv"))
    assert e is not None
    assert (e.closures, e.i, e.j, e.travel_m) == (1, 0, 10, 5.0)
    assert e.before_m == pytest.approx(0.01 * 2 * RADIUS, rel=0.01)
    assert e.before_rad == pytest.approx(0.0, abs=1e-9)
    assert e.after_m == pytest.approx(0.0, abs=1e-3) and e.after_rad == pytest.approx(0.0, abs=1e-3)


def test_a_chain_turning_too_far_is_off_by_its_whole_drift_before_and_not_after(
    tmp_path: Path,
) -> None:
    drift = 0.002  # [rad] per step: 0.04 rad round the 20 steps
    graph = write_graph(tmp_path / "g.npz", chain_bias=(0.0, 0.0, drift))
    e = loop_closure_error(graph, truth_csv(tmp_path / "gt.csv"))
    assert e is not None
    assert e.before_rad == pytest.approx(20 * drift, abs=1e-3)
    # step k is 0.5 m turned by k * drift more than the truth: the chain's end is off by
    # |sum_k 0.5 (e^{i(k a + k d)} - e^{i k a})|, a = STEP_RAD, d = drift (k = 1..19 after 0)
    k = np.arange(20)
    heading = k * STEP_RAD + STEP_RAD / 2  # each chord's direction
    off = 0.5 * (np.exp(1j * (heading + k * drift)) - np.exp(1j * heading))
    assert e.before_m == pytest.approx(abs(off.sum()), rel=0.02)
    assert e.before_m > 0.05
    assert e.after_m == pytest.approx(0.0, abs=1e-3) and e.after_rad == pytest.approx(0.0, abs=1e-3)


def test_optimised_poses_left_off_by_3_cm_are_3_cm_off_after(tmp_path: Path) -> None:
    poses = true_pose(np.arange(N, dtype=np.float64))
    poses[20, :2] += (0.03 * math.cos(0.7), 0.03 * math.sin(0.7))
    poses[20, 2] += 0.01
    graph = write_graph(tmp_path / "g.npz", poses=poses)
    e = loop_closure_error(graph, truth_csv(tmp_path / "gt.csv"))
    assert e is not None
    assert e.before_m == pytest.approx(0.0, abs=1e-3)
    assert e.after_m == pytest.approx(0.03, abs=1e-3) and e.after_rad == pytest.approx(
        0.01, abs=1e-4
    )


def test_the_loop_spanning_the_most_travel_is_judged(tmp_path: Path) -> None:
    graph = read_graph(write_graph(tmp_path / "g.npz", loops=((9, 2), (4, 19), (0, 12))))
    assert graph.closures == 3
    assert largest_loop(graph) == (4, 19)  # 7.5 m of travel against 3.5 m and 6 m


def test_a_graph_without_a_loop_closure_has_none(tmp_path: Path) -> None:
    graph = write_graph(tmp_path / "g.npz", loops=())
    assert loop_closure_error(graph, truth_csv(tmp_path / "gt.csv")) is None


def test_a_broken_chain_or_a_ground_truth_of_another_run_is_refused(tmp_path: Path) -> None:
    broken = write_graph(tmp_path / "g.npz", drop_chain=7)
    with pytest.raises(MetricInputError, match="no chain edge 6 -> 7"):
        loop_closure_error(broken, truth_csv(tmp_path / "gt.csv"))
    graph = write_graph(tmp_path / "h.npz")
    late = (np.array([100.0, 101.0]), true_pose(np.array([0.0, 1.0])))
    with pytest.raises(MetricInputError, match="outside the ground truth"):
        loop_closure_error(graph, late)
    with pytest.raises(MetricInputError, match="not a pose"):
        read_graph(truth_csv(tmp_path / "gt.csv"))
