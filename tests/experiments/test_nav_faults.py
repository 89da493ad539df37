"""Navigation trials take the twin's faults as the square's and the figure-eight's do: a LiDAR
silent for two seconds costs the host its revolutions, and the run's meta and metrics say so."""

from __future__ import annotations

import dataclasses
import json
import re
from pathlib import Path

import numpy as np
import pytest
import yaml

from jackson.experiments.stage3 import NavTrialSpec, run_nav_trial
from jackson.host.config import HostConfig, dump_config
from jackson.host.nav.grid import OccupancyGrid
from jackson.main import main
from jackson.sim.config import load_world
from jackson.sim.raster import raster

DARK = "lidar_dropout@4+2:probability=1"  # every revolution from 4 s to 6 s lost
REVOLUTION_HZ = 7.43  # the twin's RPLIDAR


def truth_map(folder: Path) -> Path:
    """The twin's raster of the static maze as the known map: no mapping run needed."""
    occ, ox, oy = raster(load_world("maze"), 0.05)
    OccupancyGrid(np.where(occ, 100, 0).astype(np.int8), 0.05, ox, oy).save(folder / "m.yaml")
    return folder / "m.yaml"


def no_monitor(folder: Path) -> Path:
    """The default host with ``health.enabled: false``: a LiDAR gone for 1 s aborts nothing."""
    cfg = HostConfig()
    off = dataclasses.replace(cfg, health=dataclasses.replace(cfg.health, enabled=False))
    path = folder / "host.yaml"
    path.write_text(yaml.safe_dump(dump_config(off), sort_keys=False))
    return path


def test_a_lidar_silent_for_two_seconds_costs_the_maze_run_its_revolutions(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    map_yaml, config = truth_map(tmp_path), no_monitor(tmp_path)
    clean = run_nav_trial(
        NavTrialSpec(0, 0, "jackson_physical", "maze", tmp_path / "clean", map_yaml, config=config)
    )
    out = tmp_path / "dark"
    args = ["run", "maze", "--map", str(map_yaml), "--config", str(config), "--fault", DARK]
    assert main([*args, "--seed", "0", "--out", str(out)]) == 0  # the goal reached on odometry
    printed = re.sub(r"[\s│]", "", capsys.readouterr().out)  # the table's cells, unwrapped
    assert f"fault{DARK}:actedfrom4.040s,15revolutionslost" in printed
    dark = json.loads((out / "nav" / "metrics.json").read_text())
    (record,) = dark["faults"]
    assert record["first_s"] == pytest.approx(4.0, abs=1 / REVOLUTION_HZ)
    assert record["revolutions_lost"] == 15  # 2 s at 7.43 Hz
    assert clean["faults"] == [] and clean["completed"] and dark["completed"]
    # per second of the run, as the runs need not last as long: 15 revolutions fewer
    rate_clean, rate_dark = clean["scans"] / clean["sim_s"], dark["scans"] / dark["sim_s"]
    assert rate_clean > 7.0 and rate_dark < rate_clean - 10 / dark["sim_s"]
    meta = json.loads((out / "nav" / "meta.json").read_text())
    assert meta["faults"] == [
        {
            "fault": DARK,
            "kind": "lidar_dropout",
            "at_s": 4.0,
            "end_s": 6.0,
            "side": None,
            "params": {"probability": 1.0},
        }
    ]
    assert json.loads((tmp_path / "clean" / "meta.json").read_text())["faults"] == []


def test_a_bad_fault_for_the_maze_is_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["run", "maze", "--fault", "lidar_dropout@4:prob=1"])
    err = capsys.readouterr().err
    assert exc.value.code == 2 and len(err.strip().splitlines()) == 1
    assert "unknown key 'prob'" in err
