"""NEES of the EKF's pose covariance against ground truth, on synthetic run folders."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pytest

from jackson.experiments import metrics as m
from jackson.experiments.consistency import (
    ConsistencyError,
    campaign_consistency,
    plot_consistency,
    run_consistency,
    significant,
)
from jackson.host.recording import EKF_COLUMNS

FloatArray = npt.NDArray[np.float64]
ROWS = 3000  # 100 s at 30 Hz


def _covariances(t_s: FloatArray) -> FloatArray:
    """Pose covariances that grow and rotate over the run, correlated between components."""
    sd = np.column_stack((0.01 + 0.001 * t_s, 0.02 + 0.0005 * t_s, 0.005 + 0.0003 * t_s))
    rho_xy, rho_xyaw, rho_yyaw = 0.5 * np.sin(0.1 * t_s), 0.3, -0.2
    corr = np.empty((t_s.size, 3, 3))
    corr[:] = np.eye(3)
    corr[:, 0, 1] = corr[:, 1, 0] = rho_xy
    corr[:, 0, 2] = corr[:, 2, 0] = rho_xyaw
    corr[:, 1, 2] = corr[:, 2, 1] = rho_yyaw
    return np.asarray(corr * sd[:, :, None] * sd[:, None, :], dtype=np.float64)


def _truth(t_s: FloatArray) -> FloatArray:
    """A 1 m circle driven at 0.1 rad/s from (0, 0, 0): the heading passes +-pi."""
    yaw = 0.1 * t_s
    return np.column_stack((np.sin(yaw), 1.0 - np.cos(yaw), yaw))


def _write_run(
    folder: Path,
    t_s: FloatArray,
    pose: FloatArray,
    covariance: FloatArray,
    truth: FloatArray,
    blank_rows: int = 0,
) -> Path:
    """ekf.csv (headings wrapped, the first ``blank_rows`` without values) and
    ground_truth.csv as the recorder and the twin write them."""
    folder.mkdir(parents=True, exist_ok=True)
    with (folder / "ekf.csv").open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(EKF_COLUMNS)
        for k in range(t_s.size):
            p = covariance[k]
            values = [
                pose[k, 0],
                pose[k, 1],
                float(m.wrap_angle(pose[k, 2])),
                *([0.0] * 4),
                *(p[0, 0], p[1, 1], p[2, 2], p[0, 1], p[0, 2], p[1, 2]),
            ]
            w.writerow([repr(float(t_s[k]))] + ([""] * 13 if k < blank_rows else values))
    with (folder / "ground_truth.csv").open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(("t_s", "x_m", "y_m", "yaw_rad", "vx_m_s", "vy_m_s", "wz_rad_s"))
        for k in range(t_s.size):
            yaw = float(m.wrap_angle(truth[k, 2]))
            w.writerow((repr(float(t_s[k])), truth[k, 0], truth[k, 1], yaw, 0.0, 0.0, 0.0))
    return folder


def _synthetic(tmp_path: Path, scale: float = 1.0, seed: int = 1) -> Path:
    """A run whose errors are drawn from the covariance; ekf.csv states scale x that."""
    rng = np.random.default_rng(seed)
    t = np.arange(ROWS) / 30.0
    cov = _covariances(t)
    err = np.einsum("kij,kj->ki", np.linalg.cholesky(cov), rng.standard_normal((ROWS, 3)))
    err[0] = 0.0  # the filter starts where the robot stands
    truth = _truth(t)
    return _write_run(tmp_path / f"run-{scale}", t, truth + err, cov * scale, truth)


def test_nees_band_is_the_two_sided_chi_square_interval() -> None:
    assert m.nees_band(3) == pytest.approx((0.2158, 9.3484), abs=1e-4)
    assert m.nees_band(3, runs=10) == pytest.approx((1.6791, 4.6979), abs=1e-4)
    assert m.nees_band(1, confidence=0.5) == pytest.approx((0.1015, 1.3233), abs=1e-4)


def test_errors_drawn_from_the_covariance_stay_in_band_95_percent_of_the_time(
    tmp_path: Path,
) -> None:
    r = run_consistency(_synthetic(tmp_path))
    assert r.rows == ROWS - 1  # the first row, where the robot stands, is before any motion
    assert r.rows_before_motion == 1
    assert 0.93 < r.in_band_fraction < 0.97
    assert r.above_fraction == pytest.approx(0.025, abs=0.012)
    assert r.below_fraction == pytest.approx(0.025, abs=0.012)
    assert r.nees_mean == pytest.approx(3.0, abs=0.2)
    assert float(np.nanmean(r.nees_xy)) == pytest.approx(2.0, abs=0.15)
    assert float(np.nanmean(r.nees_yaw)) == pytest.approx(1.0, abs=0.1)


def test_an_optimistic_covariance_is_flagged_above_the_band(tmp_path: Path) -> None:
    r = run_consistency(_synthetic(tmp_path, scale=0.01))  # P / 100
    assert r.above_fraction > 0.95
    assert r.in_band_fraction < 0.05
    assert r.nees_mean == pytest.approx(300.0, rel=0.1)
    metrics = r.metrics()
    assert metrics["nees_above_fraction"] == r.above_fraction
    assert metrics["nees_in_band_fraction"] < 0.05


def test_a_pessimistic_covariance_is_flagged_below_the_band(tmp_path: Path) -> None:
    r = run_consistency(_synthetic(tmp_path, scale=100.0))  # P x 100
    assert r.below_fraction > 0.95
    assert r.above_fraction == 0.0
    assert r.nees_mean == pytest.approx(0.03, rel=0.1)


def test_the_heading_error_is_wrapped_across_pi(tmp_path: Path) -> None:
    # truth turns from 3.0 to 3.3 rad (wrapped in the file to -2.98); the EKF reads 0.01 rad more
    t = np.arange(300) / 30.0
    truth = np.column_stack((np.zeros(300), np.zeros(300), 3.0 + 0.0303 * t))
    est = truth.copy()
    est[1:, 2] += 0.01
    cov = np.broadcast_to(np.diag([1e-4, 1e-4, 1e-4]), (300, 3, 3)).copy()
    r = run_consistency(_write_run(tmp_path / "wrap", t, est, cov, truth))
    assert r.rows_before_motion == 1  # turned 1.01 mrad by the second row
    assert np.allclose(r.errors[:, 2], 0.01, atol=1e-9)
    assert np.allclose(r.nees, 1.0, atol=1e-6)  # 0.01^2 / 1e-4
    assert r.in_band_fraction == 1.0


def test_singular_and_uninitialised_rows_are_left_out_and_counted(tmp_path: Path) -> None:
    t = np.arange(200) / 30.0
    truth = _truth(t)
    cov = _covariances(t)
    cov[50:60] = 0.0  # no covariance at all
    cov[80, 2, :] = cov[80, :, 2] = 0.0  # heading variance zero: rank 2
    est = truth + 0.5 * np.sqrt(np.diagonal(cov, axis1=1, axis2=2))
    r = run_consistency(_write_run(tmp_path / "sing", t, est, cov, truth, blank_rows=5))
    assert r.rows_uninitialised == 5
    assert r.rows_singular == 11
    assert r.rows_without_truth == 0
    assert r.rows_before_motion == 1  # the first initialised row: the truth put onto it
    assert r.rows == 200 - 5 - 1 - 11
    assert np.isnan(r.nees[44:54]).all() and np.isnan(r.nees[74])
    assert r.in_band_fraction + r.above_fraction + r.below_fraction == pytest.approx(1.0)
    metrics = r.metrics()
    assert (metrics["nees_rows_singular"], metrics["nees_rows_uninitialised"]) == (11, 5)


def test_rows_before_the_first_motion_are_left_out_and_counted(tmp_path: Path) -> None:
    # 2 s standing (the gyro's bias window: zero error by construction), then a drive whose
    # errors are the covariance's own size; the truth jitters by less than a millimetre first
    t = np.arange(300) / 30.0
    moving = np.clip(t - 2.0, 0.0, None)
    truth = np.column_stack((0.2 * moving, np.zeros(300), np.zeros(300)))
    truth[:60, 1] = 0.0009 * np.sin(t[:60])
    cov = np.broadcast_to(np.diag([1e-4, 1e-4, 1e-4]), (300, 3, 3)).copy()
    est = truth.copy()
    est[:, 2] += np.where(truth[:, 0] > 0.0, 0.01, 0.0)  # NEES 1 once moving
    r = run_consistency(_write_run(tmp_path / "still", t, est, cov, truth))
    assert r.rows_before_motion == 61  # row 60 is at 2.0 s, 0 m; row 61 at 6.7 mm
    assert r.rows == 300 - 61 and r.t_s[0] == pytest.approx(61 / 30.0)
    assert r.in_band_fraction == 1.0
    assert r.metrics()["nees_rows_before_motion"] == 61
    never = run_consistency(_write_run(tmp_path / "never", t, 0.0 * est, cov, 0.0 * truth))
    assert (never.rows, never.rows_before_motion) == (0, 300)
    assert never.end_error_m == 0.0
    pooled = campaign_consistency([r, never])
    assert pooled.summary()["rows_skipped"]["before_motion"] == 361
    assert pooled.in_band_fraction == 1.0


def test_the_end_point_2_sigma_is_the_position_ellipse_semi_major_axis(tmp_path: Path) -> None:
    t = np.arange(60) / 30.0
    truth = _truth(t)
    cov = np.broadcast_to(np.diag([0.03**2, 0.01**2, 1e-4]), (60, 3, 3)).copy()
    est = truth.copy()
    est[-1, 0] += 0.05  # 5 cm off, inside 2 x 3 cm
    r = run_consistency(_write_run(tmp_path / "end", t, est, cov, truth))
    assert r.end_position_2sigma_m == pytest.approx(0.06)
    assert r.end_error_m == pytest.approx(0.05)
    assert r.end_error_covered
    est[-1, 0] += 0.02  # 7 cm: beyond
    r = run_consistency(_write_run(tmp_path / "end2", t, est, cov, truth))
    assert not r.end_error_covered
    assert r.metrics()["end_position_2sigma_cm"] == pytest.approx(6.0)
    assert r.gt_closure_m == pytest.approx(m.closure_error(truth[:, :2]))
    assert r.optimism_gap_m == pytest.approx(r.gt_closure_m - r.ekf_closure_m)


def test_truth_in_another_frame_is_carried_into_the_odom_frame(tmp_path: Path) -> None:
    t = np.arange(300) / 30.0
    odom = _truth(t)
    c, s = math.cos(1.0), math.sin(1.0)  # the world: odom rotated by 1 rad, moved by (2, -3)
    world = np.column_stack(
        (2.0 + c * odom[:, 0] - s * odom[:, 1], -3.0 + s * odom[:, 0] + c * odom[:, 1]),
    )
    world = np.column_stack((world, odom[:, 2] + 1.0))
    cov = _covariances(t)
    r = run_consistency(_write_run(tmp_path / "frame", t, odom, cov, world))
    assert np.abs(r.errors).max() < 1e-9


def test_a_run_without_the_pose_covariance_is_refused(tmp_path: Path) -> None:
    folder = _synthetic(tmp_path)
    lines = (folder / "ekf.csv").read_text().splitlines()
    (folder / "ekf.csv").write_text(
        "\n".join(",".join(line.split(",")[:11]) for line in lines) + "\n"
    )
    with pytest.raises(ConsistencyError, match="p_xy, p_xyaw, p_yyaw"):
        run_consistency(folder)
    with pytest.raises(ConsistencyError, match="cannot read"):
        run_consistency(tmp_path / "nowhere")


def test_the_campaign_pools_its_runs_and_draws_the_figure(tmp_path: Path) -> None:
    good = run_consistency(_synthetic(tmp_path, seed=2))
    bad = run_consistency(_synthetic(tmp_path, scale=0.01, seed=3))
    c = campaign_consistency([good, bad])
    assert c.in_band_fraction == pytest.approx(
        0.5 * (good.in_band_fraction + bad.in_band_fraction), abs=1e-9
    )
    assert c.above_fraction > 0.45
    assert c.average_band == pytest.approx(m.nees_band(3, runs=2))
    assert c.t_s.size == ROWS - 1  # from the first motion on
    assert c.average_nees == pytest.approx(0.5 * (good.nees + bad.nees))
    assert c.summary()["rows"] == 2 * (ROWS - 1)
    png = tmp_path / "nees.png"
    plot_consistency(png, c, title="synthetic")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    width, height = int.from_bytes(png.read_bytes()[16:20]), int.from_bytes(png.read_bytes()[20:24])
    assert (width, height) == (1600, 1700)  # 8 x 8.5 in at 200 dpi (report.FIGURE_DPI)
    assert png.with_suffix(".pdf").read_bytes()[:5] == b"%PDF-"  # and its vector twin


def test_figures_that_span_decades_keep_three_significant_digits() -> None:
    assert [significant(v) for v in (3.0, 0.000944, 545.2, 11.83, 2.615)] == [
        "3.00",
        "0.000944",
        "545",
        "11.8",
        "2.62",
    ]
    assert [significant(v) for v in (0.0, math.nan)] == ["0", "nan"]


# ------------------------------------------------------------------------ end to end


def test_the_default_ekf_tells_the_truth_and_the_papers_does_not(tmp_path: Path) -> None:
    """A square of the twin's jackson_physical with the real host: the default EKF's
    covariance keeps the NEES in band and its 2-sigma covers the true end error by centimetres;
    the paper's (jackson_bringup.yaml's Table 2 values) claims metres, under the band."""
    from jackson.experiments.fidelity.mechanisms import BRINGUP_CONFIG
    from jackson.experiments.trial import TrialSpec, run_trial

    runs = {}
    for name, config in (("default", None), ("paper", BRINGUP_CONFIG)):
        out = tmp_path / name
        run_trial(TrialSpec("square", 0, 7, "jackson_physical", "square_room", out, config))
        runs[name] = run_consistency(out)
    default, paper = runs["default"], runs["paper"]
    assert default.in_band_fraction >= 0.8
    assert default.end_error_m <= default.end_position_2sigma_m <= 0.2
    assert paper.below_fraction > 0.95 and paper.end_position_2sigma_m > 1.0
