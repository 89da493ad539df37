"""Campaigns and single runs on the twin at a small trial count (full ones run from the CLI)."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path

import pytest

from jackson.calibration.campaign import run_campaign

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
        [JACKSON, "run", "square", "--out", str(tmp_path / "run")],
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
    from jackson.calibration.campaign import write_runs

    failed = {"variant": "C00", "trial": 0, "completed": False, "failure": "LiDAR excluded"}
    done = {"variant": "C00", "trial": 1, "completed": True, "failure": None, "d_traj_cm": 0.5}
    write_runs(tmp_path, [failed, done])
    rows = list(csv.DictReader((tmp_path / "runs.csv").open()))
    assert list(rows[0]) == ["variant", "trial", "completed", "failure", "d_traj_cm"]
    assert rows[0]["d_traj_cm"] == "" and rows[1]["d_traj_cm"] == "0.5"
