"""The compiled model: the same twin bit for bit, loaded only when built from today's source."""

from __future__ import annotations

import dataclasses
import os
import shutil
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pytest

from jackson.sim import compiled, physics
from jackson.sim.config import Cylinder, Trigger, load_robot, load_world
from jackson.sim.faults import parse_fault
from jackson.sim.mcu import SensorSample
from jackson.sim.robot import WheelDrive
from jackson.sim.twin import Twin

ROOT = Path(__file__).resolve().parents[2]
SECONDS = 20.0
SENSOR_HZ = 20


def duties(t_s: float) -> tuple[float, float]:
    """Into the wall ahead, back out, then a figure-eight (a left loop, a right loop)."""
    if t_s < 3.0:
        return 0.8, 0.8
    if t_s < 7.0:
        return -0.6, -0.6
    return (0.3, 0.6) if t_s < 13.5 else (0.6, 0.3)


def drive(
    dynamics: type[physics.DiffDriveDynamics], monkeypatch: pytest.MonkeyPatch
) -> tuple[Twin, list[SensorSample]]:
    """20 s of the imperfect robot with ``dynamics`` as its model: a wall contact, a trigger's
    cylinder, a wheel-slip window, friction patches, tyre creep and scrub, actuation latency,
    LiDAR; the twin and its sensor readings at 20 Hz."""
    world = dataclasses.replace(
        load_world("square_room"),
        start_pose=(1.8, 0.0, 0.0),  # 0.7 m from the wall ahead
        triggers=(Trigger(0.3, Cylinder(0.0, 1.5, 0.2)),),
    )
    slip = parse_fault("wheel_slip@9+2:side=left,mu_scale=0.2")
    with monkeypatch.context() as m:
        m.setattr(compiled, "Dynamics", dynamics)
        twin = Twin(world, load_robot("jackson_physical"), seed=3, lidar=True, faults=(slip,))
    assert type(twin.robot.model) is dynamics
    readings: list[SensorSample] = []
    for k in range(round(SECONDS * SENSOR_HZ)):
        left, right = duties(k / SENSOR_HZ)
        twin.command(WheelDrive(left, 1.0), WheelDrive(right, 1.0))
        twin.advance(1.0 / SENSOR_HZ)
        readings.append(twin.sensors())
    return twin, readings


def first_difference(a: Sequence[object], b: Sequence[object]) -> str:
    """Where two logs first differ, bit for bit (repr tells -0.0 from 0.0, a float from an int)."""
    for i, (x, y) in enumerate(zip(a, b, strict=False)):
        if repr(x) != repr(y):
            return f"entry {i}: {x!r} != {y!r}"
    return f"lengths {len(a)} != {len(b)}" if len(a) != len(b) else ""


def test_compiled_twin_is_bit_identical_to_the_interpreted_one(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    if not compiled.SELECTION.compiled:
        pytest.skip(f"no compiled model to compare: {compiled.SELECTION.reason}")
    interpreted, interpreted_readings = drive(physics.DiffDriveDynamics, monkeypatch)
    native, native_readings = drive(compiled.Dynamics, monkeypatch)
    assert type(native.robot.model).__module__ == compiled.MODULE
    # the drive reaches what it is meant to: a contact, the trigger, the slip window
    assert interpreted.collisions >= 1
    assert interpreted.world.inserted
    assert interpreted.faults is not None
    assert interpreted.faults.record()[0]["first_s"] == 9.0
    assert len(interpreted.truth_log) == round(SECONDS * 200) + 1
    assert first_difference(interpreted.truth_log, native.truth_log) == ""
    assert first_difference(interpreted_readings, native_readings) == ""
    assert len(interpreted.scans) == len(native.scans) > 100
    for a, b in zip(interpreted.scans, native.scans, strict=True):
        assert a.t_s == b.t_s
        assert np.array_equal(a.ranges, b.ranges)
    assert native.collisions == interpreted.collisions


def edited_source(tmp_path: Path) -> Path:
    """A copy of physics.py in a checkout of its own, edited after its build."""
    source = tmp_path / "sim" / "physics.py"
    source.parent.mkdir()
    source.write_bytes(compiled.source_path().read_bytes() + b"# edited\n")
    return source


def test_a_build_of_an_older_source_is_not_loaded(tmp_path: Path) -> None:
    source = edited_source(tmp_path)
    builds = compiled.builds_dir(source)
    stale = compiled.build_path(builds, compiled.source_digest(compiled.source_path().read_bytes()))
    stale.parent.mkdir(parents=True)
    stale.write_bytes(b"not a module: loading it would fail")
    choice = compiled.select(source, builds, {})
    assert not choice.compiled
    assert choice.dynamics is physics.DiffDriveDynamics
    digest = compiled.source_digest(source.read_bytes())
    assert choice.reason == f"interpreted (no build of physics.py {digest}; make setup)"


SELECT_PY = """\
import sys, warnings
from pathlib import Path
from jackson.sim import compiled
warnings.simplefilter("error")
try:
    choice = compiled.select(Path(sys.argv[1]), Path(sys.argv[2]), {})
except RuntimeWarning as e:
    print(f"warning: {e}")
else:
    print(choice.reason, choice.dynamics.__module__)
"""


def select_in_a_fresh_interpreter(source: Path) -> str:
    """:func:`compiled.select` of a source in a process that has loaded no build yet."""
    out = subprocess.run(
        [sys.executable, "-c", SELECT_PY, str(source), str(compiled.builds_dir(source))],
        capture_output=True,
        text=True,
        check=True,
        env={**os.environ, compiled.ENV_INTERPRETED: "1"},  # its own import loads nothing
    )
    return out.stdout.strip()


def test_a_build_of_the_present_source_is_loaded(tmp_path: Path) -> None:
    source = edited_source(tmp_path)
    current = compiled.build_path(
        compiled.builds_dir(source), compiled.source_digest(source.read_bytes())
    )
    current.parent.mkdir(parents=True)
    current.write_bytes(b"not a module")  # tried, and refused with a warning
    assert select_in_a_fresh_interpreter(source).startswith(
        f"warning: jackson.sim: compiled physics not loaded: {current}"
    )
    if compiled.SELECTION.build is None:
        pytest.skip(f"no compiled model to load: {compiled.SELECTION.reason}")
    shutil.copyfile(compiled.SELECTION.build, current)  # the real build, at the edited digest
    assert select_in_a_fresh_interpreter(source) == f"compiled ({current}) {compiled.MODULE}"


def test_the_environment_can_refuse_the_build() -> None:
    choice = compiled.select(
        compiled.source_path(),
        compiled.builds_dir(compiled.source_path()),
        {"JACKSON_SIM_INTERPRETED": "1"},
    )
    assert not choice.compiled
    assert choice.reason == "interpreted (JACKSON_SIM_INTERPRETED is set)"


def test_module_says_which_model_runs() -> None:
    out = subprocess.run(
        [sys.executable, "-m", "jackson.sim.compiled"],
        capture_output=True,
        text=True,
        check=True,
        env={**os.environ, "JACKSON_SIM_INTERPRETED": "1"},
    )
    assert out.stdout == "jackson.sim.physics: interpreted (JACKSON_SIM_INTERPRETED is set)\n"


def test_a_build_that_cannot_be_made_is_one_line_and_only_the_firmware_core_stops_setup(
    tmp_path: Path,
) -> None:
    # the physics, collision tests and capsule decoding have interpreted stand-ins; the twin's
    # MCU has none
    out = subprocess.run(
        [sys.executable, str(ROOT / "tools" / "build_compiled.py"), "--force"],
        capture_output=True,
        text=True,
        env={**os.environ, "CC": str(tmp_path / "no-such-cc"), "CXX": str(tmp_path / "no-c++")},
    )
    assert out.returncode == 1
    assert out.stdout == ""
    assert out.stderr == (
        "setup: compiled physics not built, the twin runs interpreted: "
        f"no C compiler ({tmp_path / 'no-such-cc'} not found)\n"
        "setup: compiled collision tests not built, the costmap uses numpy: "
        f"no C++ compiler ({tmp_path / 'no-c++'} not found)\n"
        "setup: compiled capsule decoding not built, the LiDAR's decoder uses numpy: "
        f"no C++ compiler ({tmp_path / 'no-c++'} not found)\n"
        "setup: the firmware core (the twin's MCU) cannot be built: "
        f"no C++ compiler ({tmp_path / 'no-c++'} not found)\n"
    )
