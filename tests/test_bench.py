"""The benchmarks' ratio plumbing: side-by-side timing, the record, the table and the peers.

No timing is asserted here; each test checks that a ratio is built from two things measured
in the same run, and that the peers do the same work as ours.
"""

from __future__ import annotations

import inspect
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from jackson.bench.report import print_table, write_json
from jackson.bench.runner import run_suite
from jackson.bench.suites import SUITES
from jackson.common.bench import (
    BenchResult,
    interleaved_best,
    interleaved_slices,
    reference_loop_us,
)
from jackson.protocol import FrameDecoder, decode_message
from jackson.protocol.bench import _mavlink, mavlink_stream, telemetry_stream
from jackson.sim.bench import bare_pymunk, drive_figure_eight, twin_vs_pymunk
from jackson.sim.bench_lidar import pymunk_room, square_room
from jackson.sim.config import load_robot, load_world
from jackson.sim.lidar import A1M8_BEAMS, cast
from jackson.sim.twin import Twin


def test_met_is_judged_on_the_ratio_side_of_the_target() -> None:
    higher = BenchResult("a", 1.2, "x", 1.0, "higher", "peer", 5.0, "MB/s", 4.0)
    lower = BenchResult("b", 2.5, "x", 2.0, "lower")
    assert higher.met and not lower.met
    assert lower.absolute is None and lower.machine_loop_us is None


def test_interleaved_best_alternates_and_keeps_each_best() -> None:
    calls: list[str] = []
    times = {"a": iter([0.3, 0.1, 0.2]), "b": iter([0.05, 0.07, 0.06])}

    def timed(name: str) -> float:
        calls.append(name)
        return next(times[name])

    best, loop_us = interleaved_best(
        {"a": lambda: timed("a"), "b": lambda: timed("b")}, 3, self_timed=True
    )
    assert calls == ["a", "b", "a", "b", "a", "b"]
    assert best == {"a": 0.1, "b": 0.05}
    assert 0.0 < loop_us < 1e6


def test_a_self_timed_candidate_must_return_its_time() -> None:
    with pytest.raises(TypeError, match="returns its time"):
        interleaved_best({"a": lambda: None}, 1, self_timed=True)


def test_interleaved_slices_alternate_and_sum_each_slices_best(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    calls: list[str] = []
    # slice durations by round: candidate a's slice 1 is slow in round 0, fast in round 1
    durations = {("a", 0): [1.0, 5.0], ("a", 1): [3.0, 2.0], ("b", 0): [4.0, 4.0]}
    durations[("b", 1)] = [6.0, 1.0]
    clock = {"now": 0.0, "round": -1}
    monkeypatch.setattr("jackson.common.bench.time.perf_counter", lambda: clock["now"])

    def make_round() -> dict[str, list[object]]:
        clock["round"] += 1

        def piece(name: str, i: int) -> object:
            def run() -> None:
                calls.append(f"{name}{i}")
                clock["now"] += durations[(name, clock["round"])][i]

            return run

        return {name: [piece(name, i) for i in range(2)] for name in ("a", "b")}

    best, _ = interleaved_slices(make_round, 2)  # type: ignore[arg-type]
    assert calls[:4] == ["a0", "b0", "a1", "b1"]
    assert best == {"a": 1.0 + 2.0, "b": 4.0 + 1.0}


def test_slices_of_different_counts_are_refused() -> None:
    with pytest.raises(ValueError, match="slice counts"):
        interleaved_slices(lambda: {"a": [lambda: None], "b": []}, 1)


def test_run_suite_records_the_machine_loop_beside_each_figure(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    def run(quick: bool) -> list[BenchResult]:
        return [
            BenchResult("fake.own_loop", 2.0, "x", 1.0, "higher", machine_loop_us=123.0),
            BenchResult("fake.no_loop", 0.5, "x", 1.0, "lower"),
        ]

    monkeypatch.setitem(SUITES, "fake", run)
    own, filled = run_suite("fake", quick=True)
    assert own.machine_loop_us == 123.0
    assert filled.machine_loop_us is not None and filled.machine_loop_us > 0.0
    assert reference_loop_us(1) > 0.0


def test_json_and_table_carry_ratio_target_and_absolute(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    results = [
        BenchResult("x.vs_peer", 3.0, "x peer's speed", 1.0, "higher", "peer", 9.0, "MB/s", 3.0),
        BenchResult("x.share", 0.5, "of 5 ms", 0.2, "lower", "period", 2500.0, "us", None, 99.0),
        BenchResult("x.info", 9.0, "x twin's time", None, "lower", "the twin alone"),
    ]
    path = tmp_path / "sub" / "bench.json"
    write_json(results, path)
    records = json.loads(path.read_text())
    assert records[0]["value"] == 3.0 and records[0]["reference_absolute"] == 3.0
    assert records[1]["absolute"] == 2500.0 and records[1]["machine_loop_us"] == 99.0
    print_table(results)
    out = capsys.readouterr().out
    assert "x.vs_peer" in out and ">= 1" in out and "<= 0.2" in out
    assert "NO" in out and "yes" in out
    assert "(info)" in out  # reported, not judged
    assert records[2]["target"] is None
    assert "targets met: 1/2" in out


def test_pymavlink_decodes_a_peer_stream_of_the_same_frames_and_sizes() -> None:
    n = 50
    ours, theirs = telemetry_stream(n, 0.0), mavlink_stream(n, 0.0)
    assert len(ours) == len(theirs) == 38 * n
    frames = FrameDecoder().feed(ours)
    assert len([decode_message(f) for f in frames]) == n
    mav = _mavlink().MAVLink(None)
    msgs = mav.parse_buffer(theirs)
    assert len(msgs) == n
    assert all(m.get_type() == "RAW_IMU" for m in msgs)
    assert msgs[1].time_usec == 50_000  # the telemetry's MCU time carried across


def test_both_corrupted_streams_lose_bytes_at_the_same_places() -> None:
    ours, theirs = telemetry_stream(200, 0.01), mavlink_stream(200, 0.01)
    clean_ours, clean_theirs = telemetry_stream(200, 0.0), mavlink_stream(200, 0.0)
    diff_ours = [i for i in range(len(ours)) if ours[i] != clean_ours[i]]
    diff_theirs = [i for i in range(len(theirs)) if theirs[i] != clean_theirs[i]]
    assert 0 < len(diff_ours) <= 0.01 * len(ours)
    # the same places drawn; a random value equal to the original byte hides one (1 in 256)
    assert len(set(diff_ours) ^ set(diff_theirs)) <= 0.05 * len(diff_ours) + 2


def test_bare_pymunk_replays_the_twins_motion() -> None:
    twin = Twin(load_world("square_room"), load_robot("jackson"), lidar=False, seed=1)
    wall, velocities = drive_figure_eight(twin, 1.0)
    assert wall > 0.0 and len(velocities) == 20
    assert any(v != (0.0, 0.0, 0.0) for v in velocities)
    assert bare_pymunk(velocities, lidar=True) > 0.0


def test_twin_ratio_is_the_twins_time_over_pymunks() -> None:
    r = twin_vs_pymunk(False, 0.5, 1)
    assert r.better == "lower" and r.target == 2.0
    assert r.absolute is not None and r.reference_absolute is not None
    # both absolutes are real-time factors: the time ratio is their inverse ratio
    assert r.value == pytest.approx(r.reference_absolute / r.absolute)


def test_pymunk_rays_see_the_room_as_the_lidar_model_does() -> None:
    obstacles = square_room(40, 4)
    space = pymunk_room(obstacles)
    angles = np.linspace(-math.pi, math.pi, A1M8_BEAMS, endpoint=False)[::20]
    exact = cast((0.1, -0.2), angles, obstacles, 12.0)
    every = __import__("pymunk").ShapeFilter()
    for a, r in zip(angles.tolist(), exact.tolist(), strict=True):
        end = (0.1 + 12.0 * math.cos(a), -0.2 + 12.0 * math.sin(a))
        hit = space.segment_query_first((0.1, -0.2), end, 0.0, every)
        assert hit is not None
        assert hit.alpha * 12.0 == pytest.approx(r, abs=1e-6)


def test_sil_figures_judge_the_run_against_the_robots_clock_and_the_command_against_its_runs() -> (
    None
):
    from jackson.bench.sil import figures

    runs = [{"sim_s": 30.0, "wall_s": 2.0}, {"sim_s": 10.0, "wall_s": 0.5}]
    rtf, over = figures("maze", 5.0, runs, 30.0, 200.0, judged="nav")
    assert rtf.name == "sil.maze_nav_real_time_factor"
    assert rtf.value == 20.0 and not rtf.met  # the navigation run's own: 10 s in 0.5 s
    assert over.name == "sil.maze_command_over_run"
    assert over.value == 2.0 and not over.met  # 5 s for 2.5 s of runs
    fast = figures("square", 0.5, [{"sim_s": 50.0, "wall_s": 0.4}], 100.0, 200.0)
    assert [f.met for f in fast] == [True, True]
    # a run of under a second: what the command adds is judged in seconds, not as a ratio
    short = figures(
        "square", 2.0, [{"sim_s": 50.0, "wall_s": 0.4}], 100.0, 200.0, overhead_in_seconds=True
    )
    assert short[1].name == "sil.square_command_overhead_s"
    assert short[1].value == pytest.approx(1.6) and not short[1].met  # 1.6 s beyond the run
    assert figures(
        "square", 1.8, [{"sim_s": 50.0, "wall_s": 0.4}], 100.0, 200.0, overhead_in_seconds=True
    )[1].met  # 1.4 s, though 4.5x the run


def test_the_vectorised_peer_sees_the_room_as_the_lidar_model_does() -> None:
    from jackson.sim.bench_lidar import numpy_rays

    obstacles = square_room(40, 4)
    angles = np.linspace(-math.pi, math.pi, A1M8_BEAMS, endpoint=False)
    for origin in ((0.1, -0.2), (-2.0, 1.5), (2.6, 2.6)):
        exact = cast(origin, angles, obstacles, 12.0)
        peer = numpy_rays(obstacles, *origin, angles, 12.0)
        assert np.all(np.isfinite(peer))  # a closed room: every beam hits
        np.testing.assert_allclose(peer, exact, atol=1e-9)
    # from inside a cylinder, as the model has it
    cx, cy, _ = obstacles.circles[0]
    inside = numpy_rays(obstacles, float(cx), float(cy), angles[::90], 12.0)
    np.testing.assert_allclose(inside, cast((cx, cy), angles[::90], obstacles, 12.0), atol=1e-9)


def test_naming_the_suites_loads_none_of_them() -> None:
    """The registry names every suite without importing the code it measures, so the command
    line lists the suites (``jackson bench --help``) as fast as before."""
    code = (
        "import sys, jackson.bench.suites as s; "
        "print(sorted(k for k in sys.modules if k.startswith(('jackson.host', 'jackson.sim', "
        "'jackson.experiments', 'jackson.protocol.bench', 'jackson.bench.'))"
        " and k != 'jackson.bench.suites'))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_every_suite_runs_through_the_registry() -> None:
    """Each entry is a function of ``quick`` (no module named by a string)."""
    assert list(SUITES) == [
        "protocol", "firmware", "twin", "lidar", "lockstep", "host", "daemon", "sil", "soak",
        "campaign", "stage3", "mapping", "ros",
    ]  # fmt: skip
    for name, suite in SUITES.items():
        assert callable(suite), name
        assert list(inspect.signature(suite).parameters) == ["quick"], name


def test_daemon_latency_is_judged_idle_and_realtime_loaded_and_told_for_the_rest() -> None:
    from jackson.bench.daemon_latency import TARGETS, _figures

    latency = {
        "frames": 200,
        "status": 0,
        "load": 4.0,
        "us": {"median": 2500.0, "p99": 8000.0, "max": 9000.0},
        "share_of_period": {"median": 0.05, "p99": 0.16, "max": 0.18},
    }
    idle = _figures(latency, "idle", realtime=False, loaded=False, loop_us=1.0)
    loaded = _figures(latency, "loaded", realtime=False, loaded=True, loop_us=1.0)
    fifo = _figures(latency, "loaded_realtime", realtime=True, loaded=True, loop_us=1.0)
    assert [r.name for r in idle] == [
        "daemon.latency_median_idle",
        "daemon.latency_p99_idle",
        "daemon.latency_max_idle",
    ]
    assert [r.target for r in idle] == [r.target for r in fifo] == list(TARGETS.values())
    assert all(r.target is None for r in loaded)  # the machine's load, reported
    assert [r.value for r in fifo] == [0.05, 0.16, 0.18]  # ratios to the 50 ms period
    assert fifo[1].absolute == 8.0 and fifo[1].reference_absolute == 50.0  # ms
    assert "SCHED_FIFO" in fifo[0].reference and "busy" in fifo[0].reference


def test_the_busy_processes_end_with_the_block() -> None:
    from jackson.bench.daemon_latency import busy

    with busy(2) as procs:
        assert len(procs) == 2 and all(proc.poll() is None for proc in procs)
    assert all(proc.returncode is not None for proc in procs)  # killed and reaped
