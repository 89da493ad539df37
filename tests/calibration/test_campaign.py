"""Campaigns and single runs on the twin at a small trial count (full ones run from the CLI)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from jackson.calibration.campaign import run_campaign

JACKSON = str(Path(sys.executable).parent / "jackson")


def test_square_campaign_writes_the_report(tmp_path: Path) -> None:
    results = run_campaign("square", 2, tmp_path / "sq", workers=2, seed=5, progress=False)
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
        "closure.png",
        "runs/R01/ground_truth.csv",
        "runs/R02/ekf.csv",
    ):
        assert (tmp_path / "sq" / name).exists(), name
    summary = (tmp_path / "sq" / "summary.md").read_text()
    assert "EKF closure (cm)" in summary and "1.18 ± 0.96" in summary  # the paper beside ours


def test_campaign_is_deterministic_for_a_seed(tmp_path: Path) -> None:
    a = run_campaign("figure8", 2, tmp_path / "a", workers=2, seed=9, progress=False)
    b = run_campaign("figure8", 2, tmp_path / "b", workers=1, seed=9, progress=False)
    keys = ("gt_closure_cm", "ekf_closure_cm", "gt_loop_diameter_ccw_m", "gt_loop_diameter_cw_m")
    assert [[r[k] for k in keys] for r in a] == [[r[k] for k in keys] for r in b]
    for r in a:
        assert 0.9 < r["gt_loop_diameter_ccw_m"] < 1.2 and 0.9 < r["gt_loop_diameter_cw_m"] < 1.2
    rows = json.loads((tmp_path / "a" / "summary.json").read_text())["rows"]
    assert any(row["metric"].startswith("CCW loop diameter") for row in rows)


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
