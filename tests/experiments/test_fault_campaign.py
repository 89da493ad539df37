"""The fault campaign: its figures on hand-made run folders, and real cases end to end (a
figure-eight's and the maze's)."""

from __future__ import annotations

import dataclasses
import json
import math
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from jackson.experiments.fault_campaign import (
    CASES,
    MAZE_ONSET_S,
    ONSET_S,
    FaultCase,
    Transition,
    clean_plan,
    detect,
    false_alarm_rate,
    load_run,
    plan_jobs,
    plot_faults,
    poisson_upper,
    summarise,
    summarise_case,
    summarise_clean,
    summary_markdown,
)
from jackson.sim.faults import LIDAR_KINDS

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
    found, excluded = s.detection, s.exclusion
    assert (found.detected, found.isolated, excluded.excluded, s.trials) == (2, 2, 1, 4)
    assert found.detection_rate == 0.5
    assert found.first_sensors == {"encoder_left": 1, "imu": 2, "none": 1}
    assert excluded.others_excluded == {"encoder_left": 1}
    assert found.isolated_by_exclusion == 1  # on2 was only suspected, on3 excluded the wrong one
    assert found.time_to_detect_median_s == pytest.approx(0.4)
    assert found.time_to_detect_max_s == pytest.approx(0.6)
    assert excluded.time_to_exclude_median_s == pytest.approx(0.2)
    assert excluded.time_to_exclude_max_s == pytest.approx(0.2)
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


def test_every_case_blames_a_sensor_at_its_missions_onset() -> None:
    for case in CASES:
        if case.mission == "maze":  # the navigation drives from 2 s to about 10 s
            assert case.spec.at_s == MAZE_ONSET_S and case.sensor == "lidar"
            assert case.spec.kind in LIDAR_KINDS
        else:
            assert case.spec.at_s == ONSET_S
            assert case.sensor in ("imu", "encoder_left", "encoder_right")
    maze = {c.name: c.spec for c in CASES if c.mission == "maze"}
    assert maze["lidar_noise"].params == {"sigma_m": 0.05}
    assert maze["lidar_dropout"].params == {"probability": 0.3}
    assert maze["lidar_dead"].params == {"probability": 1.0}
    assert maze["lidar_garbage"].params == {"ratio": 1.0} and maze["lidar_closed"].params == {}


def test_bad_arguments_are_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    from jackson.main import main

    for args in (
        ["faults", "--clean-hours", "-1"],
        ["faults", "--case", "imu_deaf"],
        ["square", "--short"],
        ["faults", "--world", "maze"],
        ["faults", "--case", "imu_dead", "--map", "m.yaml"],  # no maze case to take it
        ["faults", "--case", "lidar_dead", "--map", "no-such-map.yaml"],
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


LIDAR_DEAD = next(c for c in CASES if c.name == "lidar_dead")
STOPPED = "the LiDAR excluded (no scan for 1.00 s): no obstacle detection"


def _nav_folder(
    folder: Path,
    transitions: list[dict[str, Any]],
    *,
    completed: bool = True,
    failure: str | None = None,
    abort_reason: str | None = None,
    collisions: int = 0,
    d_min_m: float = 0.06,
    scans: int = 60,
    fault: bool = True,
) -> Path:
    """A maze run's folder as :func:`jackson.experiments.stage3.run_nav_trial` writes it."""
    folder.mkdir(parents=True)
    faults = [{"fault": LIDAR_DEAD.fault, "first_s": 4.04, "revolutions_lost": 40}]
    metrics = {
        "completed": completed,
        "failure": failure,
        "duration_s": 8.25,
        "d_min_m": d_min_m,
        "trial": 0,
        "seed": 0,
        "collisions": collisions,
        "scans": scans,
        "sim_s": 10.4,
        "faults": faults if fault else [],
    }
    health = {"abort_reason": abort_reason, "sensors": {"transitions": transitions}}
    (folder / "metrics.json").write_text(json.dumps(metrics))
    (folder / "health.json").write_text(json.dumps(health))
    (folder / "meta.json").write_text(json.dumps({"mission": "navigate"}))
    return folder


def test_maze_runs_report_goals_aborts_contacts_and_clearance(tmp_path: Path) -> None:
    excluded = [_transition(4.95, "lidar", "ok", "excluded")]
    on = [
        _nav_folder(
            tmp_path / "on1", excluded, completed=False, failure=STOPPED, abort_reason=STOPPED
        ),
        _nav_folder(tmp_path / "on2", excluded, completed=False, failure="no path to the goal"),
    ]
    off = [
        _nav_folder(tmp_path / "off1", [], collisions=2, d_min_m=0.05),
        _nav_folder(tmp_path / "off2", [], d_min_m=0.07),
    ]
    runs_on = [load_run(f, case="lidar_dead", monitor=True, root=tmp_path) for f in on]
    runs_off = [load_run(f, case="lidar_dead", monitor=False, root=tmp_path) for f in off]
    assert runs_on[0].mission == "maze" and runs_on[0].abort_reason == STOPPED
    assert runs_on[0].failure is None  # the abort's reason, told once
    assert runs_on[1].failure == "no path to the goal" and runs_on[1].ended  # the navigator's
    assert runs_on[0].onset_s == 4.04 and runs_off[0].collisions == 2
    s = summarise_case(LIDAR_DEAD, runs_on, runs_off)
    assert s.detection.detected == s.exclusion.excluded == 2
    assert s.detection.time_to_detect_median_s == pytest.approx(0.91)
    # every run ended (two aborted, two reached the goal), but these folders hold no ground
    # truth: how far the blind robot drove is unknown, and that misses the target
    assert s.after_onset_max_m is None and s.missed == ["drove None m blind (target 0.1 m)"]
    assert (s.with_monitor.completed, s.with_monitor.aborted, s.with_monitor.not_ended) == (0, 2, 0)
    nav_on, nav_off = s.navigation_with_monitor, s.navigation_without_monitor
    assert nav_on is not None and nav_off is not None
    assert nav_on.reasons == {STOPPED: 1, "no path to the goal": 1}
    assert (nav_off.reached, nav_off.collisions, nav_off.runs_with_contact) == (2, 2, 1)
    assert nav_off.d_min_cm.mean == pytest.approx(6.0) and nav_off.d_min_lowest_cm == 5.0
    assert nav_off.scans.mean == 60.0 and nav_off.driving_s.mean == 8.25
    assert summarise_case(DEAD, [], []).navigation_with_monitor is None  # a figure-eight's


def test_clean_maze_runs_add_the_lidar_to_the_false_alarms(tmp_path: Path) -> None:
    square = _run_folder(tmp_path / "sq", [], first_s=None, duration_s=45.0)
    maze = _nav_folder(
        tmp_path / "mz", [_transition(7.0, "lidar", "ok", "suspect")], d_min_m=0.06, fault=False
    )
    runs = [
        load_run(square, case="clean", monitor=True, root=tmp_path),
        load_run(maze, case="clean", monitor=True, root=tmp_path),
    ]
    fa = summarise_clean(runs)
    assert fa.by_sensor["lidar"] == {"excluded": 0, "suspect": 1}
    assert fa.by_mission["maze"] == {"runs": 1, "hours_driven": pytest.approx(8.25 / 3600)}
    assert "lidar" not in summarise_clean(runs[:1]).by_sensor  # not judged without the maze
    on = _nav_folder(
        tmp_path / "on",
        [_transition(4.95, "lidar", "ok", "excluded")],
        completed=False,
        failure=STOPPED,
        abort_reason=STOPPED,
    )
    dead = load_run(on, case="lidar_dead", monitor=True, root=tmp_path)
    off = load_run(_nav_folder(tmp_path / "off", []), case="lidar_dead", monitor=False)
    fig8 = load_run(
        _run_folder(tmp_path / "f8", [_transition(30.2, "imu", "ok", "excluded")]),
        case="imu_dead",
        monitor=True,
    )
    meta = {
        "trials": 1,
        "seed": 0,
        "robot": "jackson_physical",
        "onset_s": ONSET_S,
        "maze_onset_s": MAZE_ONSET_S,
        "map": "map/built_map.yaml",
        "runs": 5,
        "wall_s": 60.0,
        "workers": 2,
    }
    summary = summarise([DEAD, LIDAR_DEAD], [dead, off, fig8, *runs], meta)
    md = summary_markdown(summary)
    assert "LiDAR faults at 4 s into the maze's navigation trial" in md
    closure = md.split("## Closure")[1].split("##")[0]
    assert "| imu_dead |" in closure and "lidar_dead" not in closure  # no loop in the maze
    assert "| lidar_dead | 0 / 1 / 0 | 1 / 0 / 0 | 0 (0) / 0 (0) |" in md
    assert f"- lidar_dead, monitor: 1 aborted: {STOPPED}" in md
    assert "| imu | encoder_left | encoder_right | lidar |" in md
    assert "maze 1 run, 0.002 h" in md
    plot_faults(tmp_path / "faults.png", summary)  # three panels: detection, closure, maze
    assert (tmp_path / "faults.png").stat().st_size > 10_000
    assert "not the robot's)\n\nNone.\n" in md.split("## Lockstep stalls")[1]
    # stalls are the machine's: listed apart, and a run stalled twice is in no figure above
    first = "not ended: lockstep stalled: the twin waited 10.0 s for the host's HEARTBEAT"
    retried = dataclasses.replace(dead, stall_retried=first)
    twice = dataclasses.replace(
        fig8, folder="f8-again", stall_retried=first, stalled=True, failure=first + " (again)"
    )
    again = summarise([DEAD, LIDAR_DEAD], [retried, off, fig8, twice, *runs], meta)
    assert again["cases"] == summary["cases"]
    stalls = summary_markdown(again).split("## Lockstep stalls")[1].split("##")[0]
    assert f"- f8-again: {first} (again)" in stalls
    assert f"- {dead.folder}: {first}" in stalls


def test_maze_cases_plan_navigation_trials_on_the_map_and_clean_maze_runs(tmp_path: Path) -> None:
    from jackson.experiments.stage3 import NavTrialSpec
    from jackson.experiments.trial import TrialSpec

    configs = (tmp_path / "on.yaml", tmp_path / "off.yaml")
    map_yaml = tmp_path / "m.yaml"
    jobs = plan_jobs(
        tmp_path,
        [DEAD, LIDAR_DEAD],
        2,
        1e-4,
        robot="jackson_physical",
        seed=5,
        configs=configs,
        map_yaml=map_yaml,
    )
    maze = [j for j in jobs if j.mission == "maze"]
    assert [(j.case, j.monitor, j.spec.seed) for j in maze] == [
        ("lidar_dead", True, 5),
        ("lidar_dead", True, 6),
        ("lidar_dead", False, 5),
        ("lidar_dead", False, 6),
        ("clean", True, 5),  # the same twins but for the fault
        ("clean", True, 6),
    ]
    spec = maze[2].spec
    assert isinstance(spec, NavTrialSpec) and spec.map_yaml == map_yaml
    assert spec.world == "maze" and spec.config == configs[1]
    assert spec.faults == (LIDAR_DEAD.spec,) and maze[-1].spec.faults == ()
    assert spec.out == tmp_path / "runs" / "lidar_dead" / "no-monitor" / "R01"
    assert maze[-1].spec.out == tmp_path / "runs" / "clean" / "maze" / "R02"
    assert all(isinstance(j.spec, TrialSpec) for j in jobs if j.mission != "maze")
    assert sum(j.case == "clean" for j in jobs) == 3  # one square, two mazes
    none = plan_jobs(
        tmp_path, [LIDAR_DEAD], 2, 0.0, robot="r", seed=0, configs=configs, map_yaml=map_yaml
    )
    assert not [j for j in none if j.case == "clean"]
    with pytest.raises(ValueError, match="map"):
        plan_jobs(tmp_path, [LIDAR_DEAD], 1, 0.0, robot="r", seed=0, configs=configs)


def test_a_dead_lidar_aborts_the_maze_with_the_monitor_end_to_end(tmp_path: Path) -> None:
    import numpy as np

    from jackson.host.nav.grid import OccupancyGrid
    from jackson.sim.config import load_world
    from jackson.sim.raster import raster

    occ, ox, oy = raster(load_world("maze"), 0.05)  # the twin's truth: no mapping run
    OccupancyGrid(np.where(occ, 100, 0).astype(np.int8), 0.05, ox, oy).save(tmp_path / "m.yaml")
    out = tmp_path / "fc"
    run = subprocess.run(
        [
            JACKSON,
            "campaign",
            "faults",
            "--case",
            "lidar_dead",
            "--trials",
            "1",
            "--clean-hours",
            "0",
            "--map",
            str(tmp_path / "m.yaml"),
            "--out",
            str(out),
        ],
        capture_output=True,
        text=True,
        timeout=180,
    )
    assert run.returncode == 0, run.stdout + run.stderr
    assert "[2/2] " in run.stdout
    summary = json.loads((out / "summary.json").read_text())
    (case,) = summary["cases"]
    assert case["detected"] == case["excluded"] == case["isolated"] == 1
    assert 0.5 <= case["time_to_exclude_median_s"] <= 1.2  # no scan for 1 s
    nav = case["navigation_with_monitor"]
    assert nav["aborted"] == 1 and "LiDAR excluded" in next(iter(nav["reasons"]))
    assert case["navigation_without_monitor"]["reached"] == 1  # on the costmap it had
    assert summary["meta"]["map"] == str(tmp_path / "m.yaml") and not (out / "map").exists()
    (dead, _) = json.loads((out / "runs.json").read_text())
    assert dead["mission"] == "maze" and dead["scans"] < 40  # 4 s of 7.43 Hz, then none
    assert "## Navigation of the maze cases" in (out / "summary.md").read_text()
