"""A navigation service that runs for hours writes one run folder per goal, each replayable on
its own, and keeps its recording folder under the budget: ``jackson sim`` and ``jackson daemon
--lidar --map`` as processes, three goals sent with ``jackson goal --wait``."""

from __future__ import annotations

import dataclasses
import json
import os
import re
import signal
import subprocess
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest
import yaml

from jackson.host.config import HostConfig, dump_config
from jackson.host.recording import KIND_END, KIND_REQUEST, read_log
from jackson.host.recording.snapshot import SNAPSHOT_NAME

from .harness import JACKSON, start_service

WORLD = "hall_15m"
START = "1.5,1.5,0.55"
GOALS = ("7.5,5", "3,8", "1.5,1.5")
OLD_MB = 100.0  # three earlier runs of this size (sparse files), the oldest first
BUDGET_MB = 101.0  # two go at start-up, the third once this run holds a megabyte


@dataclass
class Service:
    tmp: Path
    runs: Path  # the recording folder
    log: str  # the daemon's output
    status: str  # jackson status before the daemon stopped
    goals: list[str]  # jackson goal --wait's output, per goal


def _old_run(root: Path, name: str, age_s: float) -> None:
    run = root / name
    run.mkdir(parents=True)
    (run / "meta.json").write_text("{}")
    (run / "log.jrec").write_bytes(b"JREC0001")
    with open(run / "data.bin", "wb") as f:
        f.truncate(round(OLD_MB * 1e6))
    t = time.time() - age_s
    os.utime(run / "log.jrec", (t, t))


@pytest.fixture(scope="module")
def service(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Service]:
    tmp = tmp_path_factory.mktemp("split")
    runs = tmp / "runs"
    for k in range(3):
        _old_run(runs, f"old-{k + 1}", 3000.0 - 1000.0 * k)
    cfg = dataclasses.replace(HostConfig(), recording_split="goal", recording_budget_mb=BUDGET_MB)
    (tmp / "host.yaml").write_text(yaml.safe_dump(dump_config(cfg), sort_keys=False))
    sim, daemon, sock = start_service(tmp, WORLD, START, 3, runs / "run", tmp / "host.yaml")

    def cli(*args: str) -> str:
        r = subprocess.run(
            [JACKSON, *args, "--socket", str(sock)], capture_output=True, text=True, timeout=300
        )
        assert r.returncode == 0, r.stdout + r.stderr
        return r.stdout

    try:
        goals = [cli("goal", g, "--wait") for g in GOALS]
        status = cli("status")
    finally:
        for p in (daemon, sim):
            if p.poll() is None:
                p.send_signal(signal.SIGINT)
        daemon.wait(60)
        sim.communicate(timeout=60)
    yield Service(tmp, runs, (tmp / "daemon.log").read_text(), status, goals)


def _own(service: Service) -> list[Path]:
    """The daemon's run folders, in order."""
    first = service.runs / "run"
    return [first, *sorted(service.runs.glob("run-*"))]


@pytest.mark.timeout(900)
def test_three_goals_three_folders_each_its_own_complete_run(service: Service) -> None:
    assert all("succeeded: goal reached" in out for out in service.goals), service.goals
    folders = _own(service)
    assert [f.name for f in folders] == ["run", "run-002", "run-003", "run-004"], service.log
    for k, folder in enumerate(folders):
        names = {p.name for p in folder.iterdir()}
        assert {"log.jrec", "meta.json", "config.yaml", "map.yaml", "health.json"} <= names
        assert {"odometry.csv", "ekf.csv", "commands.csv", "health.csv", "bag"} <= names
        assert (folder / "bag" / "metadata.yaml").is_file()  # its own bag, finished
        assert list(read_log(folder))[-1].kind == KIND_END
        meta = json.loads((folder / "meta.json").read_text())
        assert meta.get("previous") == (folders[k - 1].name if k else None)
        assert meta.get("next") == (folders[k + 1].name if k + 1 < len(folders) else None)
        if k:
            assert meta["split"]["reason"] == f"goal {k}" and meta["snapshot"] == SNAPSHOT_NAME
            assert (folder / SNAPSHOT_NAME).is_file()
            # the goal's request is in its own folder, and only there
            ids = [json.loads(r.payload)["id"] for r in read_log(folder) if r.kind == KIND_REQUEST]
            assert ids == [k]
        else:
            assert SNAPSHOT_NAME not in names
            assert not [r for r in read_log(folder) if r.kind == KIND_REQUEST]
    said = re.findall(r"recording: (\S+) \((goal \d)\), after (\S+); split in", service.log)
    assert [(Path(a).name, b, c) for a, b, c in said] == [
        ("run-002", "goal 1", "run"),
        ("run-003", "goal 2", "run-002"),
        ("run-004", "goal 3", "run-003"),
    ]


@pytest.mark.timeout(900)
def test_each_folder_replays_bit_for_bit_on_its_own(service: Service) -> None:
    for folder in _own(service):
        r = subprocess.run(
            [JACKSON, "replay", str(folder)], capture_output=True, text=True, timeout=600
        )
        assert r.returncode == 0 and "bit for bit" in r.stdout, r.stdout + r.stderr
        assert ("started from the core's snapshot" in r.stdout) == (folder.name != "run")


@pytest.mark.timeout(900)
def test_the_oldest_runs_are_deleted_to_stay_under_the_budget(service: Service) -> None:
    deleted = re.findall(
        r"recording: deleted (\S+) \((\d+) MB\) to stay under the (\d+) MB budget", service.log
    )
    assert deleted == [(f"old-{k}", f"{OLD_MB:.0f}", f"{BUDGET_MB:.0f}") for k in (1, 2, 3)]
    assert sorted(p.name for p in service.runs.iterdir()) == [f.name for f in _own(service)]
    assert f"of a {BUDGET_MB:.0f} MB budget (" in service.status, service.status
    assert "MB left)" in service.status
