"""Campaigns and single runs on the twin at a small trial count (full ones run from the CLI)."""

from __future__ import annotations

import csv
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from jackson.experiments.campaign import run_campaign

JACKSON = str(Path(sys.executable).parent / "jackson")


def test_square_campaign_writes_the_report(
    tmp_path: Path, capfd: pytest.CaptureFixture[str]
) -> None:
    results = run_campaign("square", 2, tmp_path / "sq", workers=2, seed=5, progress=True)
    assert [r["completed"] for r in results] == [True, True]
    for r in results:
        assert r["gt_closure_cm"] < 10.0
        assert r["odom_closure_cm"] > 0.0
        assert 30.0 < r["duration_s"] < 90.0
    for name in (
        "runs.csv",
        "runs.json",
        "summary.md",
        "summary.json",
        "trajectories.png",
        "trajectories.pdf",
        "closure.png",
        "closure.pdf",
        "nees.png",
        "nees.pdf",
        "runs/R01/ground_truth.csv",
        "runs/R02/ekf.csv",
    ):
        assert (tmp_path / "sq" / name).exists(), name
    summary = (tmp_path / "sq" / "summary.md").read_text()
    assert "EKF closure (cm)" in summary and "1.18 ± 0.96" in summary  # the paper beside ours
    assert "## Lockstep stalls (the machine's failures, not the robot's)\n\nNone." in summary
    ekf = json.loads((tmp_path / "sq" / "summary.json").read_text())["metrics"]["ekf_closure_cm"]
    assert ekf["n"] == 2 and ekf["unit"] == "cm" and ekf["ci_method"] == "lognormal-cox"
    assert 0.0 < ekf["ci_low"] <= ekf["mean"] <= ekf["ci_high"]
    assert ekf["paper"]["physical"] == {"mean": 1.18, "sd": 0.96, "note": None}
    # stderr is no terminal here: one line per finished trial, in the order they finished
    lines = [line for line in capfd.readouterr().err.splitlines() if line.startswith("[")]
    assert [line[:6] for line in lines] == ["[1/2] ", "[2/2] "]
    for r in results:
        line = (
            f"square seed {r['seed']} (R{r['trial'] + 1:02d}): completed, "
            f"GT closure {r['gt_closure_cm']:.1f} cm"
        )
        assert any(line in text for text in lines), line


def test_campaign_is_deterministic_for_a_seed(tmp_path: Path) -> None:
    a = run_campaign("figure8", 2, tmp_path / "a", workers=2, seed=9, progress=False)
    # trial 0 again, alone in one worker: the same figures to the last bit
    b = run_campaign("figure8", 1, tmp_path / "b", workers=1, seed=9, progress=False)
    keys = ("gt_closure_cm", "ekf_closure_cm", "gt_loop_diameter_ccw_m", "gt_loop_diameter_cw_m")
    assert [a[0][k] for k in keys] == [b[0][k] for k in keys]
    assert [a[1][k] for k in keys] != [b[0][k] for k in keys]  # trial 1 is another seed
    for r in a:
        assert 0.9 < r["gt_loop_diameter_ccw_m"] < 1.2 and 0.9 < r["gt_loop_diameter_cw_m"] < 1.2
    metrics = json.loads((tmp_path / "a" / "summary.json").read_text())["metrics"]
    ccw = metrics["gt_loop_diameter_ccw_m"]
    assert ccw["label"] == "CCW loop diameter, ground truth" and ccw["unit"] == "m"
    assert ccw["mean"] == sum(r["gt_loop_diameter_ccw_m"] for r in a) / 2
    assert ccw["paper"]["physical"] == {"mean": 1.0795, "sd": 0.0167, "note": "floor"}


def test_jackson_run_prints_the_table_and_writes_the_plot(tmp_path: Path) -> None:
    out = subprocess.run(
        [JACKSON, "run", "square", "--pdf", "--out", str(tmp_path / "run")],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert out.returncode == 0, out.stderr
    assert "ground-truth closure" in out.stdout and "real-time factor" in out.stdout
    assert (tmp_path / "run" / "trajectory.png").stat().st_size > 10_000
    assert (tmp_path / "run" / "trajectory.pdf").read_bytes()[:5] == b"%PDF-"


def test_runs_csv_has_every_runs_columns_when_the_first_run_failed(tmp_path: Path) -> None:
    """A failed run has fewer metrics than a completed one; sorted first, it used to make
    the report fail (DictWriter: fields not in fieldnames) and leave no summary."""
    from jackson.experiments.campaign import write_runs

    failed = {"variant": "C00", "trial": 0, "completed": False, "failure": "LiDAR excluded"}
    done = {"variant": "C00", "trial": 1, "completed": True, "failure": None, "d_traj_cm": 0.5}
    write_runs(tmp_path, [failed, done])
    rows = list(csv.DictReader((tmp_path / "runs.csv").open()))
    assert list(rows[0]) == ["variant", "trial", "completed", "failure", "d_traj_cm"]
    assert rows[0]["d_traj_cm"] == "" and rows[1]["d_traj_cm"] == "0.5"


def _nav_run(out: Path, short_of_goal_m: float) -> dict[str, object]:
    """The metrics of a run whose navigator reached its goal by its own estimate, the twin's
    truth ending ``short_of_goal_m`` before it on the straight line from the start."""
    from jackson.experiments.run_csv import write_ground_truth
    from jackson.experiments.stage3 import STAGE3_GOAL, STAGE3_START, nav_metrics
    from jackson.host.config import HostConfig
    from jackson.host.control.navigate import NavigateConfig, NavigateMission
    from jackson.sim.twin import Truth

    nav = NavigateConfig(start=STAGE3_START, goals=(STAGE3_GOAL,), localisation="slam")
    mission = NavigateMission(nav, HostConfig().limits)
    # the run as the navigator saw it: it declared the goal reached at 10 s
    mission.done, mission.t_start_s, mission.t_goal_s = True, 2.0, 10.0
    end_x = STAGE3_GOAL.x - short_of_goal_m
    t = np.linspace(0.0, 12.0, 241)
    x = np.clip(np.linspace(-1.5, 3.5, 241), STAGE3_START.x, end_x)  # drives, then stands
    truth = [
        Truth(float(ti), float(xi), STAGE3_GOAL.y, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        for ti, xi in zip(t, x, strict=True)
    ]
    out.mkdir(parents=True)
    write_ground_truth(out / "ground_truth.csv", truth)
    r = nav_metrics(mission, truth, [], None)
    r.update(variant="C00", collisions=0, trial=0, run=f"runs/{out.name}")
    return r


def test_a_run_reached_by_its_estimate_but_not_in_truth_is_no_success(tmp_path: Path) -> None:
    """The maze run that ended 25.1 cm from the goal on the ground truth while the robot's own
    estimate was within 0.25 m: reached by the navigator, not in truth, no success."""
    from jackson.experiments.stage3 import write_stage3_report

    short = _nav_run(tmp_path / "runs" / "short", 0.251)
    assert short["reached"] is True and short["reached_truth"] is False
    assert short["completed"] is False and math.isnan(short["t_nav_s"])  # type: ignore[arg-type]
    assert short["goal_error_m"] == pytest.approx(0.251) and short["goal_tolerance_m"] == 0.25
    assert short["failure"] == (
        "reached by the navigator's own estimate, but the true end is 25.1 cm from the goal "
        "(tolerance 25 cm)"
    )
    inside = _nav_run(tmp_path / "runs" / "inside", 0.249)
    assert inside["reached"] and inside["reached_truth"] and inside["completed"]
    assert inside["failure"] is None and inside["t_nav_s"] == 8.0
    meta = {"robot": "r", "world": "maze", "trials": 2, "seed": 0, "workers": 1}
    meta.update(wall_s=1.0, cpu_s=1.0, map="map.yaml")
    write_stage3_report(tmp_path, "maze", [short, inside], meta)
    summary = (tmp_path / "summary.md").read_text()
    assert "| variant | success | reached (own estimate) |" in summary
    assert "| C00 | 1/2 | 2/2 |" in summary  # P_success on the truth
    assert "- runs/short: reached by the navigator's own estimate, but the true end is 25.1 cm" in (
        summary
    )
    rows = list(csv.DictReader((tmp_path / "runs.csv").open()))
    assert [(r["reached"], r["reached_truth"], r["completed"]) for r in rows] == [
        ("True", "False", "False"),
        ("True", "True", "True"),
    ]
    # runs without the EKF's CSV: the consistency section says why it is missing
    assert "## Consistency of the EKF's covariance\n\nNot computed: " in summary


def test_the_stage3_report_judges_the_ekfs_covariance_against_the_truth(tmp_path: Path) -> None:
    """Navigation runs whose EKF estimate drifts off the truth in y, 3 cm at the end, with a
    sigma that grows with it to 2 cm: the report pools their NEES (2.25 once the drift has
    begun, inside the band; zero at the first row, where both are anchored) and draws
    nees.png."""
    from jackson.experiments.stage3 import write_stage3_report
    from jackson.host.recording import EKF_COLUMNS

    results = [_nav_run(tmp_path / "runs" / name, 0.1) for name in ("a", "b")]
    for name in ("a", "b"):
        run = tmp_path / "runs" / name
        gt = np.genfromtxt(run / "ground_truth.csv", delimiter=",", names=True)
        with (run / "ekf.csv").open("w", newline="") as f:
            w = csv.writer(f)
            w.writerow(EKF_COLUMNS)
            end = float(gt["t_s"][-1])
            for t, x, y in zip(gt["t_s"], gt["x_m"], gt["y_m"], strict=True):
                drift, sd = 0.03 * t / end, 0.02 * t / end + 1e-6
                w.writerow((t, x, y + drift, 0.0, *([0.0] * 4), 1e-4, sd**2, 1e-4, 0.0, 0.0, 0.0))
    meta = {"robot": "r", "world": "maze", "trials": 2, "seed": 0, "workers": 1}
    meta.update(wall_s=1.0, cpu_s=1.0, map="map.yaml")
    write_stage3_report(tmp_path, "maze", results, meta)
    summary = (tmp_path / "summary.md").read_text()
    # every row from the first motion on (the rows standing at the start are counted apart)
    assert "| inside the band | 100.0% |" in summary
    assert "before the first motion, singular P | 0, 0, " in summary
    assert "| end-point error within the end position's 2-sigma | 2/2 runs |" in summary
    assert (tmp_path / "nees.png").stat().st_size > 0
