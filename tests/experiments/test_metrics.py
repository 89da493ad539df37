"""The paper's validation metrics (Eq. 13-16, 19-21, A19) against hand-computed cases."""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
import pytest
from numpy.lib.stride_tricks import sliding_window_view
from skimage.metrics import structural_similarity

from jackson.experiments.metrics import (
    ENVELOPE_X_M,
    ENVELOPE_Y_M,
    Cylinder,
    MeanSdCi,
    MedianIqr,
    MetricInputError,
    NoMotionError,
    SafetyVector,
    align_start,
    arc_length_weights,
    closure_error,
    cross_track_rmse,
    d_min,
    d_rot,
    d_traj,
    d_traj_leave_one_out,
    d_trans,
    envelope_to_circle_distance,
    figure_eight_path,
    figure_eight_split,
    final_heading_error,
    fit_circle_kasa,
    format_mean_sd,
    heading_rmse,
    loop_diameters,
    max_cross_track,
    mean_sd_ci,
    median_baseline,
    median_iqr,
    occupancy_ssim,
    optimism_gap,
    point_to_polyline_distance,
    resample_by_arc_length,
    safety_vector,
    square_path,
    synchronise,
    time_zero_index,
    wrap_angle,
)

DEG = math.pi / 180.0
R_CYL_M = 0.125  # [m] Stage 3 cylinder radius


# ---- closure, cross-track, heading -------------------------------------------------------------


def test_closure_of_a_3_4_5_triangle_path_is_5() -> None:
    assert closure_error([[0.0, 0.0], [3.0, 0.0], [3.0, 4.0]]) == 5.0
    assert closure_error([[1.0, 1.0], [2.0, 5.0], [1.0, 1.0]]) == 0.0


def test_square_path_is_the_closed_unit_square() -> None:
    expected = [[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]]
    np.testing.assert_array_equal(square_path(), expected)
    np.testing.assert_array_equal(square_path(2.0), 2.0 * np.array(expected))


def test_points_0_1_m_off_a_side_have_cross_track_rmse_0_1() -> None:
    outside = np.column_stack((np.linspace(0.2, 0.8, 7), np.full(7, -0.1)))
    inside = np.column_stack((np.full(5, 0.9), np.linspace(0.2, 0.8, 5)))
    assert cross_track_rmse(outside, square_path()) == pytest.approx(0.1, abs=1e-15)
    assert cross_track_rmse(inside, square_path()) == pytest.approx(0.1, abs=1e-15)
    assert max_cross_track(outside, square_path()) == pytest.approx(0.1, abs=1e-15)


def test_cross_track_near_a_corner_uses_the_nearest_segment_not_the_vertex() -> None:
    # (0.95, 0.02): bottom side 0.02 away (vertex (1, 0) is 0.0539 away, right side 0.05)
    # (0.9, -0.03): projects inside the bottom side, 0.03 (vertex 0.1044)
    # (1.03, -0.04): beyond both sides' ends, so the corner itself is nearest: 0.05
    points = [[0.95, 0.02], [0.9, -0.03], [1.03, -0.04]]
    d = point_to_polyline_distance(points, square_path())
    np.testing.assert_allclose(d, [0.02, 0.03, 0.05], atol=1e-15)
    assert cross_track_rmse(points, square_path()) == pytest.approx(
        math.sqrt((0.02**2 + 0.03**2 + 0.05**2) / 3), abs=1e-15
    )
    assert max_cross_track(points, square_path()) == pytest.approx(0.05, abs=1e-15)


def test_distance_to_a_single_vertex_and_to_repeated_vertices() -> None:
    np.testing.assert_allclose(point_to_polyline_distance([[3.0, 4.0]], [[0.0, 0.0]]), [5.0])
    poly = [[0.0, 0.0], [0.0, 0.0], [2.0, 0.0], [2.0, 0.0]]
    np.testing.assert_allclose(point_to_polyline_distance([[1.0, 0.5]], poly), [0.5])


def test_figure_eight_path_ccw_loop_then_cw_loop_from_the_origin_heading_x() -> None:
    path = figure_eight_path(0.5, n=720)
    assert path.shape == (1441, 2)
    np.testing.assert_array_equal(path[0], [0.0, 0.0])
    np.testing.assert_array_equal(path[720], [0.0, 0.0])
    np.testing.assert_array_equal(path[-1], [0.0, 0.0])
    assert path[1, 0] > 0.0 and 0.0 < path[1, 1] / path[1, 0] < 0.005  # leaves heading +x, CCW
    np.testing.assert_allclose(np.hypot(path[:721, 0], path[:721, 1] - 0.5), 0.5, atol=1e-15)
    np.testing.assert_allclose(np.hypot(path[720:, 0], path[720:, 1] + 0.5), 0.5, atol=1e-15)
    assert path[180, 0] == pytest.approx(0.5) and path[180, 1] == pytest.approx(0.5)  # CCW
    assert path[900, 0] == pytest.approx(0.5) and path[900, 1] == pytest.approx(-0.5)  # CW
    assert cross_track_rmse(path, path) == 0.0


def test_heading_rmse_wraps_179_deg_against_minus_179_deg_to_2_deg() -> None:
    assert heading_rmse([179 * DEG], [-179 * DEG]) == pytest.approx(2 * DEG, abs=1e-12)
    assert heading_rmse([170 * DEG, 0.0], [-170 * DEG, 0.0]) == pytest.approx(
        math.sqrt(20.0**2 / 2) * DEG, abs=1e-12
    )
    # an unwrapped estimate equals its wrapped copy
    assert heading_rmse([2 * math.pi + 0.1], [0.0]) == pytest.approx(0.1, abs=1e-12)


def test_final_heading_error_is_the_wrapped_signed_heading_change() -> None:
    assert final_heading_error(0.0, 2 * math.pi + 1.41 * DEG) == pytest.approx(1.41 * DEG)
    assert final_heading_error(179 * DEG, -179 * DEG) == pytest.approx(2 * DEG)
    assert final_heading_error(-179 * DEG, 179 * DEG) == pytest.approx(-2 * DEG)


def test_wrap_angle_range_is_minus_pi_to_pi() -> None:
    np.testing.assert_allclose(
        wrap_angle([math.pi, -math.pi, 3 * math.pi / 2]), [-math.pi] * 2 + [-math.pi / 2]
    )


# ---- alignment ---------------------------------------------------------------------------------


def test_time_zero_is_the_first_command_above_0_01_m_s() -> None:
    t_s = [0.0, 0.05, 0.10, 0.15, 0.20]
    assert time_zero_index(t_s, [0.0, 0.005, 0.01, 0.02, 0.08]) == 3  # 0.01 is not above
    assert time_zero_index(t_s, [0.0, -0.05, 0.0, 0.0, 0.011]) == 4  # reversing is not time zero
    assert time_zero_index(t_s, [0.2] * 5) == 0
    with pytest.raises(NoMotionError):
        time_zero_index(t_s, [0.0, 0.01, 0.0, 0.0, 0.0])
    with pytest.raises(MetricInputError):
        time_zero_index(t_s, [0.1, 0.2])


def test_align_start_anchors_the_pose_at_0_0_0() -> None:
    poses = [[5.0, 5.0, 0.0], [1.0, 2.0, math.pi / 2], [1.0, 3.0, math.pi / 2], [0.0, 3.0, math.pi]]
    out = align_start(poses, start_index=1)
    np.testing.assert_allclose(out[1:], [[0, 0, 0], [1, 0, 0], [1, 1, math.pi / 2]], atol=1e-15)
    np.testing.assert_allclose(align_start(poses)[0], [0.0, 0.0, 0.0])
    # positions only: translation, and rotation by a given heading
    xy = [[1.0, 2.0], [1.0, 3.0]]
    np.testing.assert_allclose(align_start(xy), [[0, 0], [0, 1]])
    np.testing.assert_allclose(align_start(xy, yaw0_rad=math.pi / 2), [[0, 0], [1, 0]], atol=1e-15)


def test_synchronise_interpolates_onto_common_times() -> None:
    t_common = [0.5, 1.0, 1.5, 2.0]
    a, b = synchronise([0, 1, 2], [0, 10, 20], [0.5, 1.5, 2.5], [[1, 2], [3, 4], [5, 6]], t_common)
    np.testing.assert_allclose(a, [5, 10, 15, 20])
    np.testing.assert_allclose(b, [[1, 2], [2, 3], [3, 4], [4, 5]])
    with pytest.raises(MetricInputError):
        synchronise([0, 1, 2], [0, 1, 2], [1, 2, 3], [0, 1, 2], [0.5, 1.0])  # before b starts


def test_synchronise_angles_interpolates_across_the_wrap() -> None:
    a, b = synchronise(
        [0.0, 1.0],
        [170 * DEG, -170 * DEG],
        [0.0, 1.0],
        [-10 * DEG, 10 * DEG],
        [0.25, 0.5],
        angular=True,
    )
    np.testing.assert_allclose(a, [175 * DEG, -180 * DEG], atol=1e-12)
    np.testing.assert_allclose(b, [-5 * DEG, 0.0], atol=1e-12)


# ---- Eq. 13-14 ---------------------------------------------------------------------------------


def test_d_trans_of_a_constant_3_4_cm_offset_is_5_cm() -> None:
    p_real = np.column_stack((np.linspace(0, 1, 20), np.linspace(0, 0.5, 20) ** 2))
    assert d_trans(p_real + np.array([0.03, 0.04]), p_real) == pytest.approx(0.05, abs=1e-15)
    assert d_trans([[0, 0], [0, 0]], [[0.1, 0.0], [0.0, 0.0]]) == pytest.approx(math.sqrt(0.01 / 2))
    with pytest.raises(MetricInputError):
        d_trans([[0, 0]], [[0, 0], [1, 1]])


def test_d_rot_is_the_rms_of_wrapped_heading_differences() -> None:
    sim = [0.1, -0.1, 3.1]
    real = [0.0, 0.1, -3.1]
    wrapped = 6.2 - 2 * math.pi
    expected = math.sqrt((0.1**2 + 0.2**2 + wrapped**2) / 3)
    assert d_rot(sim, real) == pytest.approx(expected, abs=1e-15)
    assert d_rot([0.05] * 4, [0.0] * 4) == pytest.approx(0.05)


# ---- figure-eight ------------------------------------------------------------------------------


def synthetic_figure_eight(r_ccw_m: float, r_cw_m: float, n: int = 400) -> npt.NDArray[np.float64]:
    """Poses of a CCW loop of r_ccw then a CW loop of r_cw, both through the origin."""
    phi = np.linspace(0.0, 2 * math.pi, n + 1)
    ccw = np.column_stack((r_ccw_m * np.sin(phi), r_ccw_m * (1 - np.cos(phi)), phi))
    cw = np.column_stack((r_cw_m * np.sin(phi), -r_cw_m * (1 - np.cos(phi)), 2 * math.pi - phi))
    return np.vstack((ccw, cw[1:]))


def test_loop_diameters_of_a_0_5_and_0_55_m_figure_eight() -> None:
    poses = synthetic_figure_eight(0.5, 0.55)
    split = figure_eight_split(poses[:, 2])
    assert split == 400
    ccw, cw = loop_diameters(poses[:, :2], split)
    assert ccw == pytest.approx(1.0, abs=1e-9)
    assert cw == pytest.approx(1.1, abs=1e-9)


def test_figure_eight_split_unwraps_a_wrapped_heading() -> None:
    poses = synthetic_figure_eight(0.5, 0.5)
    assert figure_eight_split(wrap_angle(poses[:, 2])) == 400


def test_nominal_figure_eight_has_1_m_loops() -> None:
    path = figure_eight_path()
    ccw, cw = loop_diameters(path, 720)
    assert (ccw, cw) == (pytest.approx(1.0, abs=1e-12), pytest.approx(1.0, abs=1e-12))


def test_kasa_fit_recovers_a_partial_arc() -> None:
    phi = np.linspace(0.3, 1.2, 30)
    cx, cy, r = fit_circle_kasa(np.column_stack((2 + 0.7 * np.cos(phi), -1 + 0.7 * np.sin(phi))))
    assert (cx, cy, r) == (pytest.approx(2.0), pytest.approx(-1.0), pytest.approx(0.7))
    with pytest.raises(MetricInputError):
        fit_circle_kasa([[0, 0], [1, 1], [2, 2]])


def test_optimism_gap_is_ground_truth_minus_ekf() -> None:
    assert optimism_gap(0.0690, 0.1159) == pytest.approx(0.0469)  # paper, physical Stage 2
    assert optimism_gap(0.0192, 0.0708) == pytest.approx(0.0516)  # paper, Isaac twin
    assert optimism_gap(0.0339, 0.0095) < 0.0  # an EKF that over-reports


# ---- Eq. 19-20 ---------------------------------------------------------------------------------


def test_arc_length_weights_give_half_of_each_adjacent_segment() -> None:
    np.testing.assert_allclose(arc_length_weights([[0, 0], [1, 0], [1, 2]]), [0.5, 1.5, 1.0])
    np.testing.assert_array_equal(arc_length_weights([[1, 1], [1, 1]]), [0.0, 0.0])


def test_d_traj_of_a_trajectory_2_cm_off_a_straight_baseline_is_2_cm() -> None:
    baseline = [[0.0, 0.0], [1.0, 0.0]]
    xy = np.column_stack((np.linspace(0, 1, 50), np.full(50, 0.02)))
    assert d_traj(xy, baseline) == pytest.approx(0.02, abs=1e-15)


def test_d_traj_ignores_dense_sampling_in_one_place() -> None:
    baseline = [[0.0, 0.0], [1.0, 0.0]]
    uniform_x = np.linspace(0.0, 1.0, 2001)
    dense_x = np.concatenate((np.linspace(0.0, 0.1, 5000), np.linspace(0.1, 1.0, 901)[1:]))

    def run(x: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        return np.column_stack((x, 0.01 + 0.02 * x))  # 1 cm off at the start, 3 cm at the end

    exact = math.sqrt(0.01**2 + 0.01 * 0.02 + 0.02**2 / 3)  # sqrt(int_0^1 (a + b x)^2 dx)
    uniform = d_traj(run(uniform_x), baseline)
    dense = d_traj(run(dense_x), baseline)
    assert uniform == pytest.approx(exact, rel=1e-7)
    assert dense == pytest.approx(exact, rel=1e-7)
    unweighted = cross_track_rmse(run(dense_x), baseline)
    assert abs(unweighted - exact) > 0.003  # what the weighting is for


def test_resample_by_arc_length_spaces_points_evenly() -> None:
    xy = [[0.0, 0.0], [0.0, 0.0], [1.0, 0.0], [1.0, 1.0]]
    out = resample_by_arc_length(xy, 5)
    np.testing.assert_allclose(out, [[0, 0], [0.5, 0], [1, 0], [1, 0.5], [1, 1]])
    np.testing.assert_array_equal(resample_by_arc_length([[2, 3]], 3), [[2, 3]] * 3)


def test_median_baseline_is_the_pointwise_median_of_resampled_runs() -> None:
    runs = [np.column_stack((np.linspace(0, 1, 11), np.full(11, y))) for y in (0.0, 0.01, 0.05)]
    runs[1] = np.column_stack((np.linspace(0, 1, 7) ** 2, np.full(7, 0.01)))  # other sampling
    base = median_baseline(runs, n=5)
    np.testing.assert_allclose(
        base, [[0, 0.01], [0.25, 0.01], [0.5, 0.01], [0.75, 0.01], [1, 0.01]]
    )


def test_leave_one_out_of_three_identical_runs_is_zero() -> None:
    run = np.column_stack((np.linspace(0, 1.9, 40), np.zeros(40)))
    np.testing.assert_allclose(d_traj_leave_one_out([run, run.copy(), run.copy()]), 0.0, atol=1e-15)


def test_leave_one_out_compares_each_run_with_the_others_median() -> None:
    runs = [np.column_stack((np.linspace(0, 1, 21), np.full(21, y))) for y in (0.0, 0.01, 0.03)]
    # run 0 vs median(0.01, 0.03) = 0.02; run 1 vs 0.015; run 2 vs 0.005
    np.testing.assert_allclose(d_traj_leave_one_out(runs), [0.02, 0.005, 0.025], atol=1e-15)
    with pytest.raises(MetricInputError):
        d_traj_leave_one_out(runs[:1])


# ---- Eq. 15 / A19 ------------------------------------------------------------------------------


def occupancy_map() -> npt.NDArray[np.uint8]:
    """A 64 x 64 map_saver-style grid: free 254, walls 0, unknown 205 outside."""
    grid = np.full((64, 64), 205, dtype=np.uint8)
    grid[8:56, 8:56] = 254
    grid[8:56, 8] = grid[8:56, 55] = grid[8, 8:56] = grid[55, 8:56] = 0
    grid[20:40, 30:33] = 0  # an inner wall
    return grid


def ssim_by_hand(a: npt.NDArray[np.uint8], b: npt.NDArray[np.uint8], win: int = 7) -> float:
    """Eq. 15 on every win x win window inside the map (sample statistics), averaged."""
    wa = sliding_window_view(a.astype(np.float64), (win, win)).reshape(-1, win * win)
    wb = sliding_window_view(b.astype(np.float64), (win, win)).reshape(-1, win * win)
    mu_a, mu_b = wa.mean(axis=1), wb.mean(axis=1)
    var_a, var_b = wa.var(axis=1, ddof=1), wb.var(axis=1, ddof=1)
    cov = ((wa - mu_a[:, None]) * (wb - mu_b[:, None])).sum(axis=1) / (win * win - 1)
    c1, c2 = (0.01 * 255) ** 2, (0.03 * 255) ** 2
    s = ((2 * mu_a * mu_b + c1) * (2 * cov + c2)) / (
        (mu_a**2 + mu_b**2 + c1) * (var_a + var_b + c2)
    )
    return float(s.mean())


def test_ssim_of_identical_maps_is_1() -> None:
    grid = occupancy_map()
    assert occupancy_ssim(grid, grid.copy()) == pytest.approx(1.0, abs=1e-12)
    assert occupancy_ssim(grid, grid.copy(), gaussian_weights=True) == pytest.approx(1.0)


def test_ssim_of_a_shifted_map_is_below_1_and_matches_eq_15() -> None:
    grid = occupancy_map()
    shifted = np.roll(grid, 2, axis=1)
    value = occupancy_ssim(grid, shifted)
    assert 0.0 < value < 1.0
    reference = structural_similarity(grid, shifted, data_range=255, K1=0.01, K2=0.03)
    assert value == pytest.approx(reference, abs=1e-12)
    assert value == pytest.approx(ssim_by_hand(grid, shifted), abs=1e-9)
    gaussian = structural_similarity(
        grid,
        shifted,
        data_range=255,
        K1=0.01,
        K2=0.03,
        gaussian_weights=True,
        sigma=1.5,
        use_sample_covariance=False,
    )
    assert occupancy_ssim(grid, shifted, gaussian_weights=True) == pytest.approx(gaussian)


def test_ssim_rejects_maps_that_are_not_matching_8_bit_grids() -> None:
    grid = occupancy_map()
    with pytest.raises(MetricInputError):
        occupancy_ssim(grid, grid.astype(np.float64))
    with pytest.raises(MetricInputError):
        occupancy_ssim(grid, grid[:-1])


# ---- Eq. 21, Eq. 16 ----------------------------------------------------------------------------


def test_d_min_cylinder_ahead_faces_the_front_edge() -> None:
    pose = [[0.0, 0.0, 0.0]]
    assert d_min(pose, (0.6, 0.0, R_CYL_M)) == pytest.approx(0.6 - 0.135177 - R_CYL_M, abs=1e-15)


def test_d_min_robot_turned_sideways_faces_its_left_or_right_edge() -> None:
    # yaw -90 deg puts world +x on the robot's left (y_max = 0.135); +90 deg on its right
    # (y_min = -0.135439)
    left = d_min([[0.0, 0.0, -math.pi / 2]], (0.6, 0.0, R_CYL_M))
    right = d_min([[0.0, 0.0, math.pi / 2]], (0.6, 0.0, R_CYL_M))
    assert left == pytest.approx(0.6 - 0.135 - R_CYL_M, abs=1e-15)
    assert right == pytest.approx(0.6 - 0.135439 - R_CYL_M, abs=1e-15)


def test_d_min_corner_nearest_case() -> None:
    # cylinder at (0.5, 0.4), robot at the origin facing +x: nearest point of the envelope is
    # its front-left corner (0.135177, 0.135); sqrt(0.364823^2 + 0.265^2) - 0.125
    value = d_min([[0.0, 0.0, 0.0]], Cylinder(0.5, 0.4, R_CYL_M))
    assert value == pytest.approx(math.hypot(0.364823, 0.265) - R_CYL_M, abs=1e-15)
    assert value == pytest.approx(0.3259111, abs=1e-7)
    # robot at (1, 2) facing +y, cylinder at robot-frame (0.3, -0.4) = world (1.4, 2.3):
    # nearest is the front-right corner (0.135177, -0.135439)
    turned = d_min([[1.0, 2.0, math.pi / 2]], (1.4, 2.3, R_CYL_M))
    assert turned == pytest.approx(math.hypot(0.3 - 0.135177, 0.4 - 0.135439) - R_CYL_M)


def test_d_min_is_zero_touching_and_negative_overlapping() -> None:
    pose = [[0.0, 0.0, 0.0]]
    assert d_min(pose, (0.135177 + R_CYL_M, 0.0, R_CYL_M)) == pytest.approx(0.0, abs=1e-15)
    assert d_min(pose, (0.2, 0.0, R_CYL_M)) == pytest.approx(0.2 - 0.135177 - R_CYL_M)
    # centre inside the envelope: minus (depth to the nearest edge + r)
    assert d_min(pose, (0.0, 0.0, R_CYL_M)) == pytest.approx(-0.135 - R_CYL_M)


def test_d_min_counts_only_poses_from_the_insertion_time() -> None:
    poses = np.array([[0.3, 0.0, 0.0], [0.0, 0.0, 0.0], [-0.2, 0.0, 0.0]])
    t_s = [0.0, 1.0, 2.0]
    cyl = (0.6, 0.0, R_CYL_M)
    assert d_min(poses, cyl) == pytest.approx(0.3 - 0.135177 - R_CYL_M)
    assert d_min(poses, cyl, t_s=t_s, t_ins_s=1.0) == pytest.approx(0.6 - 0.135177 - R_CYL_M)
    with pytest.raises(MetricInputError):
        d_min(poses, cyl, t_ins_s=1.0)
    with pytest.raises(MetricInputError):
        d_min(poses, cyl, t_s=t_s, t_ins_s=3.0)


def test_clearance_per_pose_uses_the_paper_envelope() -> None:
    assert (ENVELOPE_X_M, ENVELOPE_Y_M) == ((-0.135, 0.135177), (-0.135439, 0.135))
    d = envelope_to_circle_distance([[0, 0, 0], [0, 0, math.pi]], (0.6, 0.0, 0.0))
    np.testing.assert_allclose(d, [0.6 - 0.135177, 0.6 - 0.135])


def test_safety_vector_counts_all_attempted_runs() -> None:
    s = safety_vector(
        successes=14, attempts=15, collisions=0, d_min_m=0.0565, recoveries=3, t_nav_s=54.31
    )
    assert s == SafetyVector(p_success=14 / 15, c_count=0, d_min=0.0565, e_recovery=3, t_nav=54.31)
    assert s.as_tuple() == (14 / 15, 0, 0.0565, 3, 54.31)
    with pytest.raises(MetricInputError):
        safety_vector(11, 10, 0, 0.1, 0, 20.0)
    with pytest.raises(MetricInputError):
        safety_vector(0, 0, 0, 0.1, 0, 20.0)


# ---- summaries ---------------------------------------------------------------------------------


def test_mean_sd_and_95_ci_of_1_2_3_4() -> None:
    s = mean_sd_ci([1.0, 2.0, 3.0, 4.0])
    assert s.mean == 2.5
    assert s.sd == pytest.approx(1.2910, abs=1e-4)
    # t_0.975,3 = 3.182446, half-width 3.182446 * 1.290994 / 2
    assert s.half_width == pytest.approx(2.054260, abs=1e-6)
    assert (s.ci_low, s.ci_high) == (pytest.approx(0.445740, abs=1e-6), pytest.approx(4.554260))


def test_mean_sd_ci_of_one_value_has_no_spread() -> None:
    s = mean_sd_ci([0.0118])
    assert s.mean == 0.0118
    assert math.isnan(s.sd) and math.isnan(s.ci_low) and math.isnan(s.ci_high)


def test_median_iqr() -> None:
    assert median_iqr([1.0, 2.0, 3.0, 4.0]) == MedianIqr(2.5, 1.75, 3.25)
    assert median_iqr([4.0, 1.0, 100.0, 2.0, 3.0]) == MedianIqr(3.0, 2.0, 4.0)


def test_format_mean_sd_in_centimetres() -> None:
    summary = MeanSdCi(mean=0.0118, sd=0.0096, ci_low=0.0, ci_high=0.0)
    assert format_mean_sd(summary) == "1.18 ± 0.96 cm"
    assert format_mean_sd(summary, unit="") == "1.18 ± 0.96"
    assert format_mean_sd([1.0, 2.0, 3.0, 4.0], scale=1.0, unit="s") == "2.50 ± 1.29 s"
