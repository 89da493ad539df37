"""A new robot's owner calibrates it from the command line alone, on the twin, in one session.

The robot file is one the project has never seen (40 mm wheels, a 0.25 m track, 1000 / 980
ticks per revolution, a gyro bias, unequal deadbands, a weaker right drive). ``jackson sim
--robot FILE --truth PATH`` runs in its own process, as a user starts it; the documented order
imu -> encoders -> track -> deadband -> characterise -> step -> twin-fit runs through
``jackson``'s own entry point with ``--write`` into a copy of the host YAML, the tape measure
and the turn count taken from the twin's ground-truth file (``--twin-truth``). Every calibrated
value must land within 1 % of the hidden truth (the deadbands within the staircase's finest
step); then that YAML drives the robot's square and figure-eight within twice
jackson_physical's closures.

The owner types the commands at a person's pace: between two commands the twin streams into
a port nobody reads for ``JACKSON_IDLE_S`` seconds of its clock (2 by default; 10-20 s is a
person reading the output, e.g. ``JACKSON_IDLE_S=15``), and a CPU-bound process runs beside
the whole recipe. Each command must start clean: the frames the twin queued while idle are
not taken as the new session's, and no health line reports frames lost.
"""

from __future__ import annotations

import json
import math
import os
import re
import selectors
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
import yaml

from jackson.calibration.procedures import CalibrationError, RunData
from jackson.calibration.runs import load_run, truth_distance_m, truth_reference
from jackson.calibration.yaml_update import update_config
from jackson.host.config import DEFAULT_CONFIG, HostConfig, load_config
from jackson.main import main
from jackson.sim.runner import TruthTrack, read_truth

from ..sil.harness import TwinThread, wait_for

JACKSON = str(Path(sys.executable).parent / "jackson")
IDLE_S = float(os.environ.get("JACKSON_IDLE_S", "2"))  # [s] of twin time between commands
# [s] of wall time without a HEARTBEAT before the twin moves on without the host (the doc's
# --heartbeat-timeout): far beyond a busy host's time for one frame, so a step never starts late
# on the twin's clock; paid once at the end of each run
HOST_SILENT_S = 3.0
STARTUP_BACKSTOP_S = 300.0  # [s] of wall time for `jackson sim` to print its links

TRUE_RADIUS_M = 0.040
TRUE_SEPARATION_M = 0.25
TRUE_TPR = (1000.0, 980.0)
TRUE_GYRO_BIAS_Z = 0.012  # [rad/s]
TRUE_GRAVITY_SCALE = 0.962
TRUE_DEADBAND = (0.13, 0.085)  # breakaway duty left, right (both directions)
TRUE_RIGHT_GAIN = 0.93  # the right drive 7 % weaker than the left
# jackson_physical's mean ground-truth closures [cm], as docs/fidelity.md quotes them (its
# registry, docs/figures.yaml, which make docs-check holds to the campaigns that make them)
_FIGURES = {
    e["name"]: float(e["value"])
    for e in yaml.safe_load(
        (Path(__file__).resolve().parents[2] / "docs" / "figures.yaml").read_text()
    )
}
PHYSICAL_CLOSURE_CM = {
    "square": _FIGURES["square ground-truth closure, jackson_physical seeds 0-9"],
    "figure8": _FIGURES["figure-eight floor closure, jackson_physical seeds 0-9"],
}
FINEST_STEP = 0.001  # the deadband staircase's finest step
ROBOT_FILE = f"""\
name: owners_robot
wheel_radius_m: {TRUE_RADIUS_M}
wheel_separation_m: {TRUE_SEPARATION_M}
ticks_per_rev: {{left: {TRUE_TPR[0]:g}, right: {TRUE_TPR[1]:g}}}
motor:
  deadband_duty: {{left: {TRUE_DEADBAND[0]}, right: {TRUE_DEADBAND[1]}}}
  gain: {{left: 1.0, right: {TRUE_RIGHT_GAIN}}}
imu:
  gyro_bias_rad_s: [0.004, -0.003, {TRUE_GYRO_BIAS_Z}]
  gravity_scale: {TRUE_GRAVITY_SCALE}
"""


class Sim:
    """``jackson sim --robot FILE --truth PATH`` in its own process, as a user runs it."""

    def __init__(self, robot: Path, truth: Path) -> None:
        self.err = truth.with_name("sim.err")  # its lines on stderr (the host judged gone, back)
        with self.err.open("w") as err:
            self.proc = subprocess.Popen(
                [
                    JACKSON,
                    "sim",
                    "--robot",
                    str(robot),
                    "--truth",
                    str(truth),
                    "--no-lidar",
                    "--heartbeat-timeout",
                    f"{HOST_SILENT_S:g}",
                ],
                stdout=subprocess.PIPE,
                stderr=err,
            )
        lines = self._lines_until("truth: ", timeout_s=STARTUP_BACKSTOP_S)
        self.serial = lines["serial"]
        self.i2c = lines["i2c"]
        self.truth = Path(lines["truth"])

    def _lines_until(self, last: str, timeout_s: float) -> dict[str, str]:
        """Its first lines up to the one starting with ``last`` (waits for each line)."""
        assert self.proc.stdout is not None
        fd = self.proc.stdout.fileno()
        sel = selectors.DefaultSelector()
        sel.register(fd, selectors.EVENT_READ)
        deadline = time.monotonic() + timeout_s
        text = ""
        while f"\n{last}" not in f"\n{text}" or not text.endswith("\n"):
            left = deadline - time.monotonic()
            if left <= 0 or not sel.select(left):
                self.proc.kill()
                raise AssertionError(f"jackson sim printed no {last!r} line: {text!r}")
            chunk = os.read(fd, 4096).decode()
            if not chunk:
                raise AssertionError(f"jackson sim ended: {text!r}")
            text += chunk
        sel.close()
        return dict(line.partition(": ")[::2] for line in text.splitlines())

    def stop(self) -> None:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
        self.proc.communicate(timeout=STARTUP_BACKSTOP_S)


@pytest.fixture
def sim(tmp_path: Path) -> Iterator[Sim]:
    robot = tmp_path / "owners_robot.yaml"
    robot.write_text(ROBOT_FILE)
    s = Sim(robot, tmp_path / "truth.csv")
    yield s
    s.stop()


DOC = Path(__file__).resolve().parents[2] / "docs" / "calibration.md"
ORDER = ["imu", "encoders", "track", "deadband", "characterise", "step", "twin-fit"]


def doc_recipe() -> list[tuple[str, list[str]]]:
    """The ``jackson calibrate`` lines of docs/calibration.md's block for the twin, in order:
    (procedure, its arguments after ``$P``)."""
    text = DOC.read_text()
    block = text.split("# terminal 2: the documented order", 1)[1].split("```", 1)[0]
    out = []
    for line in block.splitlines():
        words = line.split("#", 1)[0].split()
        if words[:2] == ["jackson", "calibrate"]:
            assert words[3] == "$P", line
            out.append((words[2], words[4:]))
    return out


def last_truth_us(path: Path) -> int:
    """The twin's clock [us] in the last complete row of its truth file."""
    with path.open("rb") as f:
        f.seek(max(0, f.seek(0, os.SEEK_END) - 4096))
        rows = f.read().split(b"\n")[:-1]  # the row being written is not a row yet
    return int(rows[-1].split(b",")[0])


def rel(got: float, true: float) -> float:
    return abs(got - true) / abs(true)


@pytest.fixture
def busy_machine() -> Iterator[None]:
    """A CPU-bound process beside the test, for its whole length."""
    hog = subprocess.Popen([sys.executable, "-c", "while True: pass"])
    yield
    hog.kill()
    hog.wait()


@pytest.mark.timeout(900)  # a far backstop: on a busy machine the twin's clock slows with the host
def test_the_documented_order_recovers_a_robot_never_seen_within_1_percent(
    sim: Sim, tmp_path: Path, capsys: pytest.CaptureFixture[str], busy_machine: None
) -> None:
    config = tmp_path / "owner.yaml"
    shutil.copy(DEFAULT_CONFIG, config)
    # the owner measures the wheels first (calipers): the encoder resolution is relative to r
    update_config(config, {"robot.wheel_radius_m": TRUE_RADIUS_M})
    link = ["--port", sim.serial, "--i2c", sim.i2c]
    write = ["--write", str(config)]
    out = tmp_path / "runs"
    got: dict[str, tuple[float, float]] = {}  # calibrated value, hidden truth

    def pause() -> None:
        """The owner reads the output: the twin streams into the unread port for IDLE_S of
        its clock (it runs in real time while no host answers)."""
        until_us = last_truth_us(sim.truth) + round(IDLE_S * 1e6)
        wait_for(
            lambda: last_truth_us(sim.truth) >= until_us,
            timeout_s=10.0 * (IDLE_S + HOST_SILENT_S) + STARTUP_BACKSTOP_S,
            what=f"the twin's clock to run {IDLE_S:g} s on while nobody reads its port",
        )

    started = False

    recipe = dict(doc_recipe())
    assert [name for name, _ in doc_recipe()] == ORDER  # the documented order is this test's

    def calibrate(procedure: str) -> HostConfig:
        nonlocal started
        if started:
            pause()
        started = True
        # the doc's arguments, its truth.csv this twin's truth file
        argv = [str(sim.truth) if a == "truth.csv" else a for a in recipe[procedure]]
        rc = main(["calibrate", procedure, *link, "--out", str(out / procedure), *argv, *write])
        captured = capsys.readouterr()
        assert rc == 0, f"calibrate {procedure}: {captured.err}\n{sim.err.read_text()}"
        assert "nan" not in captured.out.lower(), captured.out
        assert "frames lost" not in captured.out, captured.out  # a clean start after idleness
        return load_config(config)

    cfg = calibrate("imu")
    cal = cfg.imu.calibration
    assert cal is not None
    got["gyro bias z [rad/s]"] = (cal.gyro_bias_rad_s[2], TRUE_GYRO_BIAS_Z)
    got["accel scale"] = (cal.accel_scale, 1.0 / TRUE_GRAVITY_SCALE)

    cfg = calibrate("encoders")
    got["TPR left"] = (cfg.robot.ticks_per_rev_left, TRUE_TPR[0])
    got["TPR right"] = (cfg.robot.ticks_per_rev_right, TRUE_TPR[1])

    cfg = calibrate("track")
    got["separation (track) [m]"] = (cfg.robot.wheel_separation_m, TRUE_SEPARATION_M)

    cfg = calibrate("deadband")
    db = cfg.deadband
    deadband = {
        "left forward": (db.forward_left, TRUE_DEADBAND[0]),
        "left reverse": (db.reverse_left, TRUE_DEADBAND[0]),
        "right forward": (db.forward_right, TRUE_DEADBAND[1]),
        "right reverse": (db.reverse_right, TRUE_DEADBAND[1]),
    }

    cfg = calibrate("characterise")
    # the truth: the chassis' mean speed over the settled second half of the full-duty step,
    # from the ground-truth file (the run's MCU time is the twin's time), over the true radius
    step = load_run(out / "characterise" / "characterise")
    a = int(np.flatnonzero(step.duty_left)[0])
    b = a + int(np.flatnonzero(step.duty_left[a:] == 0)[0])
    t_a, t_b = step.t_s[a], step.t_s[b]
    track = read_truth(sim.truth)
    t_s = track.t_us / 1e6
    sel = (t_s >= t_a + 0.5 * (t_b - t_a) - 1e-9) & (t_s <= t_b + 1e-9)
    path_m = np.hypot(np.diff(track.x_m[sel]), np.diff(track.y_m[sel])).sum()
    top_wheel = path_m / (t_s[sel][-1] - t_s[sel][0]) / TRUE_RADIUS_M
    got["max wheel speed [rad/s]"] = (cfg.deadband.max_wheel_rad_s, top_wheel)

    cfg = calibrate("step")
    gains = cfg.deadband
    # the weaker right drive gets the full feed-forward, the left is scaled down to match
    got["gain left/right forward"] = (
        gains.gain_left / gains.gain_right,
        (1.0 - TRUE_DEADBAND[1]) * TRUE_RIGHT_GAIN / (1.0 - TRUE_DEADBAND[0]),
    )

    cfg = calibrate("twin-fit")
    # twin-fit holds the radius: the distance per count stays the one encoders measured
    for side, tpr, true_tpr in (
        ("left", cfg.robot.ticks_per_rev_left, TRUE_TPR[0]),
        ("right", cfg.robot.ticks_per_rev_right, TRUE_TPR[1]),
    ):
        per_count = 2 * math.pi * cfg.robot.wheel_radius_left_m / tpr
        got[f"distance per count {side} [m]"] = (per_count, 2 * math.pi * TRUE_RADIUS_M / true_tpr)
    got["separation (twin-fit) [m]"] = (cfg.robot.wheel_separation_m, TRUE_SEPARATION_M)

    errors = {k: rel(v, t) for k, (v, t) in got.items()}
    with capsys.disabled():
        print()
        for k, (v, t) in got.items():
            print(f"{k}: {v:.6g} (truth {t:.6g}), error {errors[k] * 100:.3f} %")
        for k, (v, t) in deadband.items():
            print(f"deadband {k}: {v:.4f} (truth {t:.4f}), error {v - t:+.4f}")
    assert max(errors.values()) < 0.01, errors
    assert max(abs(v - t) for v, t in deadband.values()) <= FINEST_STEP, deadband

    # the calibrated YAML drives that robot (jackson run --config, a twin of its own): closures
    # within twice jackson_physical's, the loops equal (the weaker right drive compensated)
    assert load_config(config).robot == cfg.robot
    for mission in ("square", "figure8"):
        run = tmp_path / mission
        argv = ["run", mission, "--robot", str(tmp_path / "owners_robot.yaml"), "--out", str(run)]
        assert main([*argv, "--config", str(config)]) == 0
        assert "holds no calibration" not in capsys.readouterr().out
        m = json.loads((run / "metrics.json").read_text())
        with capsys.disabled():
            print(
                f"{mission} with the calibrated YAML: closure ground truth "
                f"{m['gt_closure_cm']:.2f} cm (jackson_physical {PHYSICAL_CLOSURE_CM[mission]} cm),"
                f" EKF {m['ekf_closure_cm']:.2f} cm, raw odometry {m['odom_closure_cm']:.2f} cm"
                f" in {m['duration_s']:.1f} s"
            )
        assert m["completed"] and m["gt_closure_cm"] < 2.0 * PHYSICAL_CLOSURE_CM[mission]
        assert m["odom_closure_cm"] < 10.0  # the packaged beliefs' odometry misses by 1.4 m
    ccw, cw = m["gt_loop_diameter_ccw_m"], m["gt_loop_diameter_cw_m"]
    with capsys.disabled():
        print(f"figure-eight loops: CCW {ccw:.3f} m, CW {cw:.3f} m")
    assert abs(ccw - cw) < 0.02 * (ccw + cw) / 2


def test_each_run_is_measured_by_the_truth_of_its_own_twin_session(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The tape measure is the displacement in the truth file at the run's first and last
    frame; a truth file of another session, or one that ends before the run, is refused."""
    truth = tmp_path / "truth.csv"
    twin = TwinThread(tmp_path, world="open_floor", heartbeat_timeout_s=HOST_SILENT_S, truth=truth)
    out = tmp_path / "runs"
    try:
        link = ["--port", twin.serial, "--i2c", twin.i2c, "--out", str(out)]
        argv = ["--count", "1", "--length", "0.3", "--twin-truth", str(truth)]
        assert main(["calibrate", "encoders", *link, *argv]) == 0
    finally:
        twin.stop()
    run = load_run(out / "straight-1")
    log = twin.twin.truth_log
    a = next(s for s in log if s.t_s >= run.t_s[0] - 1e-9)
    b = next(s for s in log if s.t_s >= run.t_s[-1] - 1e-9)
    assert run.notes["measured_distance_m"] == pytest.approx(
        math.hypot(b.x - a.x, b.y - a.y), abs=1e-8
    )
    capsys.readouterr()
    lines = truth.read_text().splitlines(keepends=True)
    other = tmp_path / "other.csv"
    other.write_text(
        re.sub(r"boot_id 0x[0-9a-f]+", "boot_id 0x00000001", lines[0]) + "".join(lines[1:])
    )
    short = tmp_path / "short.csv"
    short.write_text("".join(lines[:12]))
    for path, words in ((other, "boot_id 0x00000001"), (short, "are not in the twin's truth")):
        runs = ["--runs", str(out / "straight-1"), "--twin-truth", str(path)]
        assert main(["calibrate", "encoders", *runs]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and words in err[0], err


def test_a_run_is_found_in_the_truth_after_the_mcu_clock_wrapped() -> None:
    """The twin's time is 64-bit; a run's frames carry it modulo 2^32 (71.6 min)."""
    wrap = 1 << 32
    t_us = np.arange(wrap - 2_000_000, 2 * wrap + 3_000_000, 50_000, dtype=np.int64)
    mm = t_us.astype(np.float64) * 1e-9  # moves 1 mm per second along x and -y
    track = TruthTrack(Path("t.csv"), 7, t_us, mm, -mm, 0.1 * mm)
    start = 2 * wrap - 1_000_000  # the second wrap: 1 s before it, 2 s after it
    frames = (start + np.arange(0, 3_000_001, 50_000)) % wrap
    t_s = np.cumsum(np.concatenate(([frames[0]], np.diff(frames) % wrap))) / 1e6
    n = len(t_s)
    zero, nan3 = np.zeros(n, dtype=np.int64), np.full((n, 3), np.nan)
    run = RunData("r", t_s, zero, zero, nan3, nan3, np.zeros(n), np.zeros(n))
    ref = truth_reference(run, track, {7})
    true_us = start + np.arange(0, 3_000_001, 50_000)
    assert np.allclose(ref.x_m, true_us * 1e-9, rtol=0, atol=1e-12)
    assert truth_distance_m(ref) == pytest.approx(3.0 * 1e-3 * math.sqrt(2))
    with pytest.raises(CalibrationError, match="boot_id"):
        truth_reference(run, track, {8})


def test_jackson_sim_never_replaces_a_file_that_is_not_its_truth(tmp_path: Path) -> None:
    config = tmp_path / "owner.yaml"
    shutil.copy(DEFAULT_CONFIG, config)
    out = subprocess.run(
        [JACKSON, "sim", "--no-lidar", "--truth", str(config), "--duration", "0.1"],
        capture_output=True,
        text=True,
        timeout=STARTUP_BACKSTOP_S,
    )
    err = out.stderr.strip().splitlines()
    assert out.returncode == 2 and len(err) == 1 and "--truth" in err[0], out.stderr
    assert config.read_text() == DEFAULT_CONFIG.read_text()


def test_the_shipped_config_on_a_new_robot_points_the_owner_to_calibrate(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Driven with the paper robot's config, the owner's robot disagrees with it: the first
    sensor excluded comes with one line that says the config is uncalibrated and what to run."""
    robot = tmp_path / "owners_robot.yaml"
    robot.write_text(ROBOT_FILE)
    main(["run", "square", "--robot", str(robot), "--out", str(tmp_path / "square")])
    out = capsys.readouterr().out
    excluded = [line for line in out.splitlines() if "-> excluded" in line]
    assert excluded, out  # the disagreement is seen
    hints = [line for line in out.splitlines() if "holds no calibration" in line]
    assert len(hints) == 1 and "jackson calibrate" in hints[0], out
    assert out.index(excluded[0]) < out.index(hints[0])
