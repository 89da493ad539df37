"""Campaigns on Ray (``--cluster``): the same trials, the same results as the local pool."""

from __future__ import annotations

import json
import math
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from jackson.experiments.campaign import run_campaign
from jackson.experiments.cluster import ClusterError, map_trials, parse_cluster
from jackson.host.daemon_link import HOST_STALL_RECORD
from jackson.main import main

ray = pytest.importorskip("ray")

# the trial's timing: wall time, and the twin's few steps past the host's exit (machine load)
TIMING = ("wall_s", "sim_s", "real_time_factor")
# run-folder files that are a pure function of the trial's seed
PURE_FILES = (
    "commands.csv",
    "ekf.csv",
    "ground_truth.csv",
    "health.csv",
    "health.json",
    "meta.json",
    "odometry.csv",
)
# health.json's link counters kept on the wall clock: times the reader heard nothing for
# silence_s, which a loaded machine's scheduler decides, not the seed
WALL_CLOCK_LINK = ("silences",)


@pytest.fixture(scope="module")
def local_ray() -> Iterator[Any]:
    """One local Ray instance for the module's tests that need one (the last ones in it: the
    tests above them need this process without Ray)."""
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    try:
        yield ray
    finally:
        ray.shutdown()


def without_timing(results: list[dict[str, Any]]) -> list[dict[str, Any]]:
    return [{k: v for k, v in r.items() if k not in TIMING} for r in results]


def pure_content(path: Path) -> Any:
    """A run-folder file as far as it is a pure function of the trial's seed."""
    if path.name != "health.json":
        return path.read_bytes()
    health = json.loads(path.read_text())
    for key in WALL_CLOCK_LINK:
        del health["link"][key]
    # the daemon's CPU measures the machine, not the trial; its frame count is the seed's
    frames = health.pop("cpu")["frames"]
    health.pop("latency", None)  # the frame latency, like the CPU, measures the machine
    # a stall of the daemon's own loop on a loaded machine is not told in lockstep (the twin
    # waited for it): the events are the trial's
    assert not [e for e in health["events"] if e.startswith(HOST_STALL_RECORD)], health["events"]
    return health, frames


def test_cluster_forms() -> None:
    for good in ("local", "auto", "ray://head.example:10001"):
        assert parse_cluster(good) == good
    for bad in ("ray://head", "ray:/head:1", "head:6379", ""):
        with pytest.raises(ValueError):
            parse_cluster(bad)


def test_no_ray_installed_is_one_line_and_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setitem(sys.modules, "ray", None)  # import ray: ImportError
    rc = main(["campaign", "square", "--trials", "1", "--cluster", "auto", "--out", str(tmp_path)])
    err = capsys.readouterr().err
    assert rc == 2
    assert err == (
        "jackson campaign: --cluster needs the cluster extra: pip install 'jackson[cluster]'\n"
    )
    assert not (tmp_path / "runs").exists()


def test_no_cluster_at_the_address_is_one_line_and_exit_1(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("RAY_ADDRESS", "127.0.0.1:1")  # nothing listens on port 1
    assert not ray.is_initialized()
    rc = main(["campaign", "square", "--trials", "1", "--cluster", "auto", "--out", str(tmp_path)])
    err = capsys.readouterr().err
    assert rc == 1
    assert err.startswith("jackson campaign: --cluster auto: no Ray cluster there")
    assert err.count("\n") == 1
    assert not (tmp_path / "runs").exists()


# Ray runs its workers niced: on a machine busy with other work they get the CPU last, and 4
# square trials (about 25 CPU-seconds) took over the suite's 120 s once at load 7
@pytest.mark.timeout(1200)
def test_square_on_ray_gives_the_local_pools_metrics_and_files(
    local_ray: Any, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    pool = run_campaign("square", 2, tmp_path / "pool", seed=3, workers=2, progress=False)
    out = str(tmp_path / "ray")
    rc = main(
        ["campaign", "square", "--trials", "2", "--seed", "3", "--cluster", "local", "--out", out]
    )
    assert rc == 0, capsys.readouterr().err
    on_ray = json.loads((tmp_path / "ray" / "runs.json").read_text())
    assert [r["seed"] for r in on_ray] == [3, 4]
    assert all(r["completed"] for r in on_ray)
    assert without_timing(on_ray) == without_timing(json.loads(json.dumps(pool)))
    report = sorted(p.name for p in (tmp_path / "pool").iterdir())
    assert sorted(p.name for p in (tmp_path / "ray").iterdir()) == report
    for run in ("R01", "R02"):
        for name in PURE_FILES:
            a = pure_content(tmp_path / "pool" / "runs" / run / name)
            assert pure_content(tmp_path / "ray" / "runs" / run / name) == a, f"{run}/{name}"


def test_results_come_back_with_their_specs_index(local_ray: Any, tmp_path: Path) -> None:
    got = dict(map_trials(math.sqrt, [4.0, 9.0, 16.0], cluster="local", folder=tmp_path))
    assert got == {0: 2.0, 1: 3.0, 2: 4.0}


def test_a_node_without_the_report_folder_runs_no_trial(local_ray: Any, tmp_path: Path) -> None:
    with pytest.raises(ClusterError, match="does not see the report folder"):
        list(map_trials(math.sqrt, [4.0], cluster="local", folder=tmp_path / "elsewhere"))
