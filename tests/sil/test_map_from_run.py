"""Mapping from a recording, end to end: a survey of the twin by ``jackson map`` (the real host
daemon; its bag with /scan, its report beside the map), mapped again offline by
``jackson map --from``, each in a subprocess."""

from __future__ import annotations

import json
import re
import subprocess
from pathlib import Path

import pytest

from jackson.experiments.stage3 import map_quality
from jackson.host.nav.grid import OccupancyGrid
from jackson.host.ros.bag import bag_info
from jackson.sim.config import load_world

from .harness import JACKSON

WORLD = "stage3_corridor"
FINAL_LINE = re.compile(
    r"map: (?P<yaml>\S+/built_map\.yaml) \(\+ \.pgm\) from (?P<scans>\d+) scans over "
    r"(?P<robot_s>[\d.]+) s of robot time \(odometry: /odometry/filtered\); "
    r"(?P<rate>[\d.]+) robot-seconds mapped per CPU-second"
)


def is_png(path: Path) -> bool:
    return path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and path.stat().st_size > 20_000


def test_a_recorded_survey_maps_offline_as_well_as_it_did_live(tmp_path: Path) -> None:
    run = tmp_path / "run"
    done = subprocess.run(
        [JACKSON, "map", "--world", WORLD, "--out", str(run)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr
    live = json.loads((run / "metrics.json").read_text())
    assert live["completed"], live["failure"]
    assert bag_info(run / "bag").counts["/scan"] > 50
    # the report beside the map: the picture, the figures, and a table of them
    assert is_png(run / "built_map.png")
    figures = json.loads((run / "map_quality.json").read_text())
    assert figures["world"] == WORLD and figures["nodes"] == live["map_nodes"]
    assert figures["loop_closures"] == live["map_loops_closed"]
    assert figures["ssim"] == pytest.approx(live["map_ssim"], abs=0.005)
    assert 0.0 < figures["precision"] <= 1.0 and figures["segments_judged"] >= 4
    assert ("loop_closure_after_m" in figures) == (figures["loop_closures"] > 0)
    assert f"report: {run / 'built_map.png'}, {run / 'map_quality.json'}" in done.stdout
    assert re.search(r"^  SSIM +0\.\d{3}$", done.stdout, re.M), done.stdout

    out = tmp_path / "offline"
    done = subprocess.run(
        [JACKSON, "map", "--from", str(run), "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    last = done.stdout.strip().splitlines()[-1]
    m = FINAL_LINE.fullmatch(last)
    assert m is not None, last
    assert Path(m["yaml"]) == out / "built_map.yaml"
    assert int(m["scans"]) > 50 and float(m["robot_s"]) > 5.0 and float(m["rate"]) > 0.0
    assert (out / "built_map.pgm").exists() and (out / "trajectory.csv").exists()

    offline = map_quality(OccupancyGrid.load(out / "built_map.yaml"), load_world(WORLD))
    assert offline >= live["map_ssim"] - 0.05, (offline, live["map_ssim"])
    # a twin run's recording: judged against the world it names, as the live map was
    assert is_png(out / "built_map.png")
    again = json.loads((out / "map_quality.json").read_text())
    assert again["ssim"] == pytest.approx(offline, abs=0.005)
    assert again["world"] == WORLD and 0.0 < again["precision"] <= 1.0

    # the revolutions as recorded, not moved to the base's pose at their ends: another map
    raw = tmp_path / "raw"
    done = subprocess.run(
        [JACKSON, "map", "--from", str(run), "--no-deskew", "--out", str(raw)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    assert (raw / "built_map.pgm").read_bytes() != (out / "built_map.pgm").read_bytes()


def test_mapping_a_folder_without_a_bag_is_one_line_and_exit_2(tmp_path: Path) -> None:
    done = subprocess.run(
        [JACKSON, "map", "--from", str(tmp_path)], capture_output=True, text=True, timeout=60
    )
    assert done.returncode == 2
    assert done.stderr.strip() == (
        f"jackson map: {tmp_path}: no bag (a run folder holds one in bag/ when it was recorded)"
    )


def test_from_refuses_the_survey_options_with_exit_2(tmp_path: Path) -> None:
    done = subprocess.run(
        [JACKSON, "map", "--from", str(tmp_path), "--world", "maze", "--seed", "3"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 2
    assert done.stderr.strip().startswith("jackson map: --world, --seed: not with --from")


def test_no_deskew_is_refused_without_from_with_exit_2() -> None:
    done = subprocess.run(
        [JACKSON, "map", "--world", "maze", "--no-deskew"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 2
    assert done.stderr.strip().startswith("jackson map: --no-deskew: only with --from")
