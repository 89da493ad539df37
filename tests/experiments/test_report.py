"""A campaign's report on synthetic run folders: summary.json's numbers, CIs, figures, progress."""

from __future__ import annotations

import csv
import io
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import pytest
from PIL import Image

from jackson.experiments import metrics as m
from jackson.experiments.campaign import TrialProgress, trial_line
from jackson.experiments.report import FIGURE_DPI, PAPER, summarise, write_report
from jackson.experiments.report_plots import anchored_trace, closure_zoom, plot_trajectories
from jackson.experiments.trial import trial_metrics

FloatArray = npt.NDArray[np.float64]
META = {"robot": "jackson_physical", "world": "square_room", "seed": 0, "workers": 1, "wall_s": 1.0}


def _square(t_s: FloatArray, end_m: tuple[float, float], yaw0: float = 0.0) -> FloatArray:
    """(x, y, yaw) round the 1 m square from (0, 0), drifting linearly to ``end_m``."""
    s = 4.0 * t_s / t_s[-1]  # arc length along the nominal square [m]
    side = np.minimum(np.floor(s), 3.0)
    u = s - side
    x = np.select([side == 0, side == 1, side == 2], [u, 1.0 + 0 * u, 1.0 - u], 0 * u)
    y = np.select([side == 0, side == 1, side == 2], [0 * u, u, 1.0 + 0 * u], 1.0 - u)
    frac = t_s / t_s[-1]
    x, y = x + frac * end_m[0], y + frac * end_m[1]
    c, sn = math.cos(yaw0), math.sin(yaw0)  # the same path seen in a frame turned by yaw0
    return np.column_stack((c * x - sn * y + 0.5, sn * x + c * y - 0.2, side * math.pi / 2 + yaw0))


def _write(path: Path, header: list[str], rows: npt.ArrayLike) -> None:
    with path.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        w.writerows(np.asarray(rows).tolist())


def _run(folder: Path, gt_end: tuple[float, float], ekf_end: tuple[float, float]) -> Path:
    """A run folder as a trial writes it: ground truth (200 Hz), EKF (30 Hz), odometry and
    commands (20 Hz), the start off the origin and turned (the plot anchors it)."""
    folder.mkdir(parents=True)
    t_gt, t_ekf, t_odo = np.arange(0, 40, 0.005), np.arange(0, 40, 1 / 30), np.arange(0, 40, 0.05)
    _write(folder / "ground_truth.csv", ["t_s", "x_m", "y_m", "yaw_rad"],
           np.column_stack((t_gt, _square(t_gt, gt_end, 0.3))))  # fmt: skip
    _write(folder / "ekf.csv", ["t_s", "x_m", "y_m", "yaw_rad"],
           np.column_stack((t_ekf, _square(t_ekf, ekf_end))))  # fmt: skip
    _write(folder / "odometry.csv", ["t_s", "x_m", "y_m", "yaw_rad"],
           np.column_stack((t_odo, _square(t_odo, (0.3 + 4 * gt_end[0], -0.2)))))  # fmt: skip
    v = np.where((t_odo > 1.0) & (t_odo < 39.0), 0.1, 0.0)
    _write(folder / "commands.csv", ["t_s", "v_cmd", "w_cmd"],
           np.column_stack((t_odo, v, 0 * v)))  # fmt: skip
    return folder


@pytest.fixture(scope="module")
def report(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list[dict[str, Any]]]:
    """A two-run square campaign's report folder and its per-run metrics."""
    out = tmp_path_factory.mktemp("report")
    results = []
    for i, (gt_end, ekf_end) in enumerate((((0.03, -0.02), (0.004, 0.001)),
                                           ((0.045, -0.01), (0.002, -0.003)))):  # fmt: skip
        r = trial_metrics(_run(out / "runs" / f"R{i + 1:02d}", gt_end, ekf_end), "square")
        r.update(trial=i, seed=i, completed=True, real_time_factor=4.0 + i)
        r.update(nees_in_band_fraction=[0.0, 0.25][i], nees_above_fraction=0.0)
        r.update(nees_mean=[0.2, 0.9][i], end_error_covered=[True, False][i])
        results.append(r)
    write_report(out, "square", results, META)
    return out, results


def test_summary_json_holds_numbers_per_metric(
    report: tuple[Path, list[dict[str, Any]]],
) -> None:
    out, results = report
    summary = json.loads((out / "summary.json").read_text())
    assert summary["confidence"] == 0.95
    gt = summary["metrics"]["gt_closure_cm"]
    assert gt["label"] == "Ground-truth closure" and gt["unit"] == "cm" and gt["n"] == 2
    values = [r["gt_closure_cm"] for r in results]
    assert values == pytest.approx([math.hypot(0.03, -0.02) * 100, math.hypot(0.045, -0.01) * 100])
    assert gt["mean"] == pytest.approx(np.mean(values))
    assert gt["sd"] == pytest.approx(np.std(values, ddof=1))
    assert gt["paper"] == {"physical": None, "isaac": {"mean": 3.39, "sd": 0.9, "note": None}}
    assert summary["metrics"]["duration_s"]["unit"] == "s"
    assert summary["metrics"]["nees_mean"]["unit"] == "1"
    for key, entry in summary["metrics"].items():
        for field in ("mean", "sd", "ci_low", "ci_high"):
            assert isinstance(entry[field], float), (key, field)
        assert entry["ci_method"] in summary["ci_methods"], key
    assert "±" not in (out / "summary.json").read_text()  # the text lives in summary.md only


def test_two_runs_give_intervals_inside_each_quantitys_domain(
    report: tuple[Path, list[dict[str, Any]]],
) -> None:
    metrics = json.loads((report[0] / "summary.json").read_text())["metrics"]
    for key in ("gt_closure_cm", "ekf_closure_cm", "odom_closure_cm", "duration_s", "nees_mean"):
        entry = metrics[key]
        assert entry["ci_method"] == "lognormal-cox", key
        assert 0.0 < entry["ci_low"] <= entry["mean"] <= entry["ci_high"], key
    # where the t-based interval of the same two runs reaches below zero
    assert m.mean_sd_ci([r["gt_closure_cm"] for r in report[1]]).ci_low < 0.0
    band = metrics["nees_in_band_fraction"]
    assert band["ci_method"] == "bootstrap-percentile"
    assert (band["ci_low"], band["ci_high"]) == (0.0, 0.25)  # inside [min, max] of the runs
    covered = metrics["end_error_covered"]
    assert covered["ci_method"] == "clopper-pearson" and covered["mean"] == 0.5
    assert (covered["ci_low"], covered["ci_high"]) == pytest.approx((0.01258, 0.98742), abs=1e-5)
    gap = metrics["optimism_gap_cm"]  # signed: the t-based interval
    assert gap["ci_method"] == "t" and gap["ci_low"] < gap["mean"] < gap["ci_high"]


def test_summary_md_keeps_the_text_and_names_the_interval(
    report: tuple[Path, list[dict[str, Any]]],
) -> None:
    text = (report[0] / "summary.md").read_text()
    assert "| EKF closure (cm) | 0.39 ± 0.04 | [0.16, 0.91] | log-normal |" in text
    assert "| log-normal | 1.18 ± 0.96 | 0.95 ± 0.17 |" in text  # the paper beside ours
    assert "- log-normal, for strictly positive quantities" in text
    assert "- exact binomial, for a share of runs" in text
    assert "Not computed" in text  # the synthetic EKF has no covariance


def test_every_figure_is_a_png_of_at_least_150_dpi_and_a_pdf(
    report: tuple[Path, list[dict[str, Any]]],
) -> None:
    assert FIGURE_DPI >= 150
    for name in ("trajectories", "closure"):
        png, pdf = report[0] / f"{name}.png", report[0] / f"{name}.pdf"
        with Image.open(png) as image:
            assert image.info["dpi"][0] == pytest.approx(FIGURE_DPI, abs=0.1), name
            assert image.width >= 1500, name
        assert pdf.read_bytes()[:5] == b"%PDF-", name
        assert b"/FontFile2" in pdf.read_bytes(), name  # TrueType text, selectable


def test_a_runs_plot_is_the_png_alone_unless_the_pdf_is_asked_for(tmp_path: Path) -> None:
    run = _run(tmp_path / "run", (0.03, -0.02), (0.004, 0.001))
    plot_trajectories(run / "trajectory.png", "square", [run], vector=False)
    assert (run / "trajectory.png").stat().st_size > 10_000
    assert not (run / "trajectory.pdf").exists()
    plot_trajectories(run / "trajectory.png", "square", [run])
    assert (run / "trajectory.pdf").read_bytes()[:5] == b"%PDF-"


def test_the_trace_is_anchored_thinned_and_keeps_its_true_end(tmp_path: Path) -> None:
    run = _run(tmp_path / "R01", (0.03, -0.02), (0.0, 0.0))
    trace = anchored_trace(run / "ground_truth.csv")
    assert (trace.x_m[0], trace.y_m[0]) == (0.0, 0.0)
    assert trace.end == pytest.approx((0.03, -0.02), abs=1e-9)  # the closure error's end point
    steps = np.hypot(np.diff(trace.x_m), np.diff(trace.y_m))
    assert 800 < trace.x_m.size < 900  # 4.04 m at one point per 5 mm, of 8000 rows
    assert steps.max() < 0.0075


def test_the_closure_zoom_holds_the_start_and_every_end_a_few_cm_across() -> None:
    cx, cy, half = closure_zoom([(0.03, -0.02), (0.045, -0.01), (0.004, 0.001)])
    for x, y in ((0.0, 0.0), (0.03, -0.02), (0.045, -0.01), (0.004, 0.001)):
        assert abs(x - cx) < half and abs(y - cy) < half
    assert half == pytest.approx(1.35 * 0.045 / 2)  # scaled to the largest closure
    assert closure_zoom([(0.001, 0.0)])[2] == 0.01  # never under 2 cm across


def test_the_paper_figures_are_numbers() -> None:
    phys, isaac = PAPER["figure8"]["optimism_gap_cm"]
    assert phys is not None and (phys.mean, phys.sd) == (4.69, 2.82)
    assert isaac is not None and isaac.text == "5.16 ± 0.41"
    floor = PAPER["figure8"]["gt_loop_diameter_ccw_m"][0]
    assert floor is not None and floor.text == "1.0795 ± 0.0167 (floor)"
    isaac_loop = PAPER["figure8"]["gt_loop_diameter_ccw_m"][1]
    assert isaac_loop is not None and (isaac_loop.text, isaac_loop.sd) == ("1.0429", None)
    odom = PAPER["figure8"]["odom_closure_cm"][0]
    assert odom is not None and odom.text == "207 ± 26"


def test_one_run_has_a_mean_and_no_interval() -> None:
    (row,) = [r for r in summarise("square", [{"gt_closure_cm": 3.0}])]
    assert row.stats.n == 1 and math.isnan(row.stats.ci_low)
    assert row.as_json()["sd"] is None and row.as_json()["ci_low"] is None
    assert row.markdown_row() == "| Ground-truth closure (cm) | 3.00 | — | — | — | 3.39 ± 0.90 |"


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_off_a_terminal_each_trial_prints_one_progress_line() -> None:
    stream = io.StringIO()
    result = {"mission": "figure8", "trial": 2, "seed": 2, "completed": True}
    with TrialProgress("figure8 x10", 10, stream=stream) as bar:
        bar.advance(trial_line({**result, "gt_closure_cm": 9.06, "ekf_closure_cm": 2.61}))
        bar.advance(trial_line({"mission": "square", "seed": 4, "completed": False}))
    assert stream.getvalue().splitlines() == [
        "[1/10] figure8 seed 2 (R03): completed, GT closure 9.1 cm, EKF closure 2.6 cm",
        "[2/10] square seed 4: not completed",
    ]


def test_on_a_terminal_the_bar_prints_no_lines_and_disabled_prints_nothing() -> None:
    tty = _Terminal()
    with TrialProgress("square x2", 2, stream=tty) as bar:
        bar.advance("square seed 0: completed")
    assert "[1/2]" not in tty.getvalue()
    quiet = io.StringIO()
    with TrialProgress("square x2", 2, enabled=False, stream=quiet) as bar:
        bar.advance("square seed 0: completed")
    assert quiet.getvalue() == ""


def test_ekf_path_length_and_largest_deviation(report: tuple[Path, list[dict[str, Any]]]) -> None:
    # the synthetic EKF runs the 1 m square drifting to a few millimetres off its start
    _, results = report
    for r in results:
        assert r["ekf_path_m"] == pytest.approx(4.0, abs=0.02)
        assert 0.0 < r["ekf_max_cross_track_cm"] < 0.6
    summary = json.loads((report[0] / "summary.json").read_text())
    assert summary["metrics"]["ekf_path_m"]["paper"]["physical"]["mean"] == 4.133
