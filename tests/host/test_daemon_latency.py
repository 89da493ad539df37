"""The daemon's frame latency (telemetry read to the HEARTBEAT written) and its real-time
priority: the meter, where it is reported, and ``--realtime`` on a real daemon."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
from pathlib import Path

import pytest

from jackson.host.daemon_latency import LatencyMeter
from jackson.host.daemon_realtime import make_realtime
from jackson.host.daemon_reports import health_doc

JACKSON = str(Path(sys.executable).parent / "jackson")


def test_a_heartbeat_closes_the_pending_frame_and_one_without_a_frame_is_not_counted() -> None:
    meter = LatencyMeter()
    meter.written(5_000_000)  # a shutdown HEARTBEAT: no frame pending
    assert meter.frames == 0
    meter.arrived(1_000_000)
    meter.written(3_000_000)  # 2 ms after the bytes were read
    meter.written(9_000_000)  # a second HEARTBEAT for the same frame: not counted
    assert meter.frames == 1
    assert meter.max_us == pytest.approx(2000.0)


def test_the_report_gives_median_p99_max_as_shares_of_the_period() -> None:
    meter = LatencyMeter()
    for k in range(1000):
        meter.add(1000.0 if k < 990 else 20_000.0)  # 1 ms, and ten frames of 20 ms
    report = meter.report(0.05)
    assert report["frames"] == 1000
    assert report["us"]["median"] == pytest.approx(1000.0, rel=0.05)
    assert report["us"]["p99"] == pytest.approx(1000.0, rel=0.05)
    assert report["us"]["max"] == 20_000.0
    assert report["share_of_period"]["max"] == pytest.approx(0.4)
    assert report["share_of_period"]["median"] == pytest.approx(0.02, rel=0.05)
    json.dumps(report)  # health.json holds it
    meter.add(1e12)  # beyond the histogram: its last bin, the memory flat
    assert meter.report(0.05)["us"]["max"] == 1e12


def test_health_json_carries_the_latency_beside_the_cpu() -> None:
    from jackson.host.commands import CommandCounters
    from jackson.host.cpu import CpuMeter
    from jackson.host.daemon_link import LinkHealth

    class Core:
        abort_reason = None
        health = None
        mission = None  # no navigation: no planner entry

    meter = LatencyMeter()
    meter.add(2500.0)
    counters = CommandCounters()
    doc = health_doc(Core(), LinkHealth(), [], CpuMeter(), counters, 0.05, meter)  # type: ignore[arg-type]
    assert doc["latency"]["frames"] == 1
    assert doc["latency"]["share_of_period"]["max"] == pytest.approx(0.05)
    assert "planner" not in doc


def _in_thread(fn: object) -> object:
    out: list[object] = []
    thread = threading.Thread(target=lambda: out.append(fn()))  # type: ignore[operator]
    thread.start()
    thread.join()
    return out[0]


def test_realtime_is_the_calling_threads_alone_or_one_line_why_not() -> None:
    def set_then_spawn() -> tuple[str, int, int]:
        line = make_realtime(10)
        mine = os.sched_getscheduler(0) & ~getattr(os, "SCHED_RESET_ON_FORK", 0)
        child = _in_thread(lambda: os.sched_getscheduler(0))
        assert isinstance(child, int)
        return line, mine, child

    line, mine, child = _in_thread(set_then_spawn)  # type: ignore[misc]
    assert "\n" not in line
    if "SCHED_FIFO priority 10" in line:
        assert mine == os.SCHED_FIFO
        assert child == os.SCHED_OTHER  # recording, ROS: started later, normal policy
    else:
        assert "not permitted" in line or "refused" in line or "not available" in line
    assert os.sched_getscheduler(0) == os.SCHED_OTHER  # this thread was never touched
    with pytest.raises(ValueError):
        make_realtime(0)


def test_a_real_daemon_reports_its_latency_and_its_policy(tmp_path: Path) -> None:
    twin = subprocess.Popen(
        [JACKSON, "sim", "--no-lidar", "--realtime", "--world", "square_room"],
        stdout=subprocess.PIPE,
        text=True,
    )
    assert twin.stdout is not None
    ports = {}
    while len(ports) < 2:
        name, _, value = twin.stdout.readline().strip().partition(": ")
        if name in ("serial", "i2c"):
            ports[name] = value
    run = tmp_path / "run"
    try:
        out = subprocess.run(
            [JACKSON, "daemon", "--port", ports["serial"], "--i2c", ports["i2c"], "--realtime",
             "--max-seconds", "2", "--run-dir", str(run)],
            capture_output=True, text=True, timeout=120,
        )  # fmt: skip
    finally:
        twin.terminate()
        twin.wait(timeout=10)
    assert out.returncode == 0, out.stdout + out.stderr
    assert "daemon: realtime: " in out.stdout
    latency = json.loads((run / "health.json").read_text())["latency"]
    assert latency["frames"] > 10  # 20 Hz for about 2 s
    assert 0 < latency["us"]["median"] <= latency["us"]["p99"] <= latency["us"]["max"]


def test_jackson_status_shows_the_latency_when_the_daemon_reports_it() -> None:
    from jackson.host.cli import status_lines

    st = {"problems": [], "cpu": {}, "latency_ms": {"median": 3.0, "p99": 6.9, "max": 7.7}}
    assert "latency: median 3.0 ms, p99 6.9 ms, max 7.7 ms" in status_lines(st)
    assert not any(line.startswith("latency") for line in status_lines({"problems": []}))
