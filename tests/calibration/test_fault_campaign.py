"""The fault campaign: its figures on hand-made run folders, and one real case end to end."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from jackson.calibration.fault_campaign import (
    CASES,
    FaultCase,
    Transition,
    clean_plan,
    detect,
    false_alarm_rate,
    load_run,
    poisson_upper,
    summarise_case,
    summarise_clean,
)

JACKSON = str(Path(sys.executable).parent / "jackson")
DEAD = FaultCase("imu_dead", "figure8", "imu_dead@30", "imu")


def _transition(t_s: float, sensor: str, old: str, new: str) -> dict[str, Any]:
    return {"t_s": t_s, "sensor": sensor, "from": old, "to": new, "reason": "test"}


def _run_folder(
    folder: Path,
    transitions: list[dict[str, Any]],
    *,
    first_s: float | None = 30.0,
    completed: bool = True,
    abort_reason: str | None = None,
    duration_s: float = 90.0,
    gt_closure_cm: float = 10.0,
    monitor: bool = True,
) -> Path:
    folder.mkdir(parents=True)
    faults = [] if first_s is None else [{"fault": "imu_spike@30", "first_s": first_s, "spikes": 2}]
    metrics = {
        "mission": "figure8",
        "trial": 0,
        "seed": 4,
        "completed": completed,
        "duration_s": duration_s,
        "sim_s": duration_s + 5.0,
        "gt_closure_cm": gt_closure_cm,
        "ekf_closure_cm": gt_closure_cm / 2,
        "faults": faults,
    }
    sensors: dict[str, Any] = {"monitor": "off"}
    if monitor:
        sensors = {"states": {}, "transitions": transitions, "counts": {"gated": len(transitions)}}
    health = {"abort_reason": abort_reason, "sensors": sensors}
    (folder / "metrics.json").write_text(json.dumps(metrics))
    (folder / "health.json").write_text(json.dumps(health))
    return folder


def test_a_transition_of_the_blamed_sensor_after_onset_is_a_detection(tmp_path: Path) -> None:
    folder = _run_folder(
        tmp_path / "R01",
        [
            _transition(12.0, "encoder_left", "ok", "suspect"),  # before the fault: not it
            _transition(30.25, "imu", "ok", "excluded"),
        ],
        first_s=30.05,
    )
    r = load_run(folder, case="imu_dead", monitor=True, root=tmp_path)
    assert r.folder == "R01" and r.onset_s == 30.05 and r.ended
    assert (r.spikes, r.gated) == (2, 2)
    d = detect(r.transitions, "imu", r.onset_s)
    assert d.detected and d.isolated and d.excluded and d.first_sensor == "imu"
    assert d.time_to_detect_s == pytest.approx(0.20)


def test_the_wrong_sensor_first_is_not_isolated_and_is_named() -> None:
    transitions = [
        Transition(30.3, "imu", "ok", "suspect", ""),
        Transition(30.5, "encoder_right", "ok", "suspect", ""),
        Transition(31.25, "encoder_right", "suspect", "excluded", ""),
        Transition(34.1, "encoder_right", "excluded", "recovered", ""),
    ]
    d = detect(transitions, "encoder_right", 30.0)
    assert d.detected and d.excluded and not d.isolated
    assert d.first_sensor == "imu" and d.time_to_detect_s == pytest.approx(0.5)
    assert d.first_excluded == "encoder_right" and d.others_excluded == ()
    assert d.time_to_exclude_s == pytest.approx(1.25)


def test_two_sensors_out_at_one_instant_are_not_isolated() -> None:
    transitions = [
        Transition(30.6, "imu", "ok", "suspect", ""),
        Transition(30.6, "encoder_left", "ok", "suspect", ""),
        Transition(33.2, "imu", "suspect", "excluded", ""),
    ]
    d = detect(transitions, "imu", 30.0)
    assert d.detected and not d.isolated and d.first_sensor == "imu+encoder_left"
    assert d.others_excluded == ()


def test_no_detection_before_onset_nor_without_onset_nor_by_recovery() -> None:
    early = [Transition(29.95, "imu", "ok", "excluded", "")]
    assert not detect(early, "imu", 30.0).detected
    assert not detect([Transition(31.0, "imu", "ok", "suspect", "")], "imu", None).detected
    back = [Transition(31.0, "imu", "excluded", "recovered", "")]
    assert detect(back, "imu", 30.0) == detect([], "imu", 30.0)


def test_case_summary_counts_detection_time_and_endings(tmp_path: Path) -> None:
    on = [
        _run_folder(tmp_path / "on1", [_transition(30.2, "imu", "ok", "excluded")]),
        _run_folder(tmp_path / "on2", [_transition(30.6, "imu", "ok", "suspect")]),
        _run_folder(tmp_path / "on3", [_transition(30.4, "encoder_left", "ok", "excluded")]),
        _run_folder(tmp_path / "on4", [], completed=False, abort_reason=None),  # never ended
    ]
    off = [
        _run_folder(tmp_path / "off1", [], monitor=False, gt_closure_cm=30.0),
        _run_folder(tmp_path / "off2", [], monitor=False, completed=False, abort_reason="IMU"),
    ]
    s = summarise_case(
        DEAD,
        [load_run(f, case="imu_dead", monitor=True) for f in on],
        [load_run(f, case="imu_dead", monitor=False) for f in off],
    )
    assert (s.detected, s.isolated, s.excluded, s.trials) == (2, 2, 1, 4)
    assert s.detection_rate == 0.5 and s.first_sensors == {"encoder_left": 1, "imu": 2, "none": 1}
    assert s.others_excluded == {"encoder_left": 1}
    assert s.isolated_by_exclusion == 1  # on2 was only suspected, on3 excluded the wrong one
    assert s.time_to_detect_median_s == pytest.approx(0.4)
    assert s.time_to_detect_max_s == pytest.approx(0.6)
    assert s.time_to_exclude_median_s == s.time_to_exclude_max_s == pytest.approx(0.2)
    assert (s.with_monitor.completed, s.with_monitor.not_ended) == (3, 1)
    assert (s.without_monitor.completed, s.without_monitor.aborted) == (1, 1)
    assert s.without_monitor.gt_closure_cm.mean == 30.0
    assert s.without_monitor.gt_closure_cm.sd is None  # one completed run
    assert not s.met_target and len(s.missed) == 2  # detection below 95 %, a run never ended


def test_poisson_upper_bound_of_no_event_is_minus_log_five_percent() -> None:
    assert poisson_upper(0) == pytest.approx(-math.log(0.05))  # 2.996
    assert poisson_upper(1) == pytest.approx(4.744, abs=1e-3)  # Garwood's table
    r = false_alarm_rate(0, 1.5)
    assert r.per_hour == 0.0 and r.upper_per_hour == pytest.approx(2.996 / 1.5, abs=1e-3)
    assert false_alarm_rate(0, 0.0).upper_per_hour is None


def test_false_alarms_per_hour_driven(tmp_path: Path) -> None:
    runs = [
        _run_folder(tmp_path / "c1", [], first_s=None, duration_s=1800.0),
        _run_folder(
            tmp_path / "c2",
            [
                _transition(40.0, "encoder_right", "ok", "suspect"),
                _transition(40.5, "encoder_right", "suspect", "excluded"),
                _transition(43.0, "encoder_right", "excluded", "recovered"),
            ],
            first_s=None,
            duration_s=5400.0,
        ),
    ]
    fa = summarise_clean([load_run(f, case="clean", monitor=True) for f in runs])
    assert fa.hours_driven == 2.0 and fa.runs == 2 and fa.not_ended == 0
    assert (fa.excluded.count, fa.suspect.count) == (1, 1)
    assert fa.excluded.per_hour == 0.5
    assert fa.excluded.upper_per_hour == pytest.approx(4.744 / 2.0, abs=1e-3)
    assert fa.by_sensor["encoder_right"] == {"excluded": 1, "suspect": 1}
    assert [a["t_s"] for a in fa.alarms] == [40.0, 40.5]


def test_clean_plan_reaches_the_hours_with_both_missions() -> None:
    assert clean_plan(0.0) == []
    assert clean_plan(1e-4) == ["square"]
    plan = clean_plan(1.0)
    assert plan.count("square") == plan.count("figure8") == 27


def test_every_case_blames_a_sensor_at_thirty_seconds() -> None:
    for case in CASES:
        assert case.spec.at_s == 30.0 and case.sensor in ("imu", "encoder_left", "encoder_right")


def test_bad_arguments_are_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    from jackson.main import main

    for args in (
        ["faults", "--clean-hours", "-1"],
        ["faults", "--case", "imu_deaf"],
        ["square", "--short"],
        ["faults", "--world", "maze"],
    ):
        try:
            status = main(["campaign", *args])
        except SystemExit as exc:  # argparse refuses the value itself
            status = int(exc.code or 0)
        err = capsys.readouterr().err
        assert status == 2 and len(err.strip().splitlines()) == 1, (args, err)


def test_imu_dead_is_detected_end_to_end(tmp_path: Path) -> None:
    out = tmp_path / "fc"
    run = subprocess.run(
        [
            JACKSON,
            "campaign",
            "faults",
            "--case",
            "imu_dead",
            "--trials",
            "1",
            "--clean-hours",
            "0.001",
            "--workers",
            "1",
            "--out",
            str(out),
        ],
        capture_output=True,
        text=True,
        timeout=180,
    )
    assert run.returncode == 0, run.stdout + run.stderr
    assert "[3/3] " in run.stdout  # a line per trial when stdout is not a terminal
    summary = json.loads((out / "summary.json").read_text())
    (case,) = summary["cases"]
    assert case["name"] == "imu_dead" and case["detected"] == 1 and case["isolated"] == 1
    assert 0.0 <= case["time_to_detect_median_s"] <= 0.5  # 0.25 s of silence, frame by frame
    assert case["with_monitor"]["completed"] == 1  # the figure-eight goes on, wheel-only yaw
    assert case["without_monitor"]["aborted"] == 1  # the paper's guard aborts on silence
    fa = summary["false_alarms"]
    assert fa["runs"] == 1 and fa["hours_driven"] > 0 and fa["excluded"]["count"] == 0
    assert (out / "faults.png").stat().st_size > 10_000
    no_monitor = (out / "host-no-monitor.yaml").read_text()
    assert "enabled: false" in no_monitor
    assert len(json.loads((out / "runs.json").read_text())) == 3
