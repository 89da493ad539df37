"""External velocity commands on the default twin: the real daemon in lockstep, commanded as
/cmd_vel commands it (``HostCore.submit_velocity``, once a frame), the speed read off the
twin's ground truth over the last 2 s of each 5 s command.

Open loop (the missions' way, as the paper's robot drove) the loaded wheels run 10-11 % slow
(0.134 m/s for 0.15 m/s); with the wheel-speed PI on the encoders they track within 3 %. Here
the PI runs as the default configuration runs it, on external commands (``wheel_pi.external``;
open loop: off) (tests/host/core/test_chain.py checks the missions keep the
feed-forward)."""

from __future__ import annotations

import dataclasses
import threading
from pathlib import Path

import numpy as np
import pytest

from jackson.host.core import HostCore
from jackson.host.core.results import CoreListener, FrameResult

from .harness import TwinThread, host_config, in_process_daemon, wait_for

COMMANDS = ((0.10, 0.0), (0.15, 0.0), (0.20, 0.0), (0.0, 0.5))  # [m/s, rad/s]
HOLD_S = 5.0  # [s] of MCU time each command is held
STEADY_S = 2.0  # [s] the steady state: the end of each hold


class Teleop(CoreListener):
    """Submits the command in force at each frame, as a 20 Hz /cmd_vel publisher would, once
    the gyro bias is known; notes when each command started (MCU time)."""

    def __init__(self, core: HostCore) -> None:
        self.core = core
        self.starts: list[float] = []
        self.done = threading.Event()

    def on_result(self, result: FrameResult) -> None:
        if not self.starts and self.core.gyro_bias.bias_rad_s is None:
            return
        t0 = self.starts[0] if self.starts else result.t_s
        k = int((result.t_s - t0) // HOLD_S)
        if k >= len(COMMANDS):
            self.done.set()
            return
        if k == len(self.starts):
            self.starts.append(result.t_s)
        self.core.submit_velocity(*COMMANDS[k])


def steady_speeds(tmp_path: Path, closed_loop: bool) -> list[tuple[float, float]]:
    """(v [m/s], w [rad/s]) of the twin's truth at the end of each command."""
    twin = TwinThread(tmp_path, world="open_floor")
    cfg = host_config(twin.i2c)
    # the default: the PI on external commands only (wheel_pi.external), which these are
    cfg = dataclasses.replace(
        cfg, wheel_pi=dataclasses.replace(cfg.wheel_pi, enabled=False, external=closed_loop)
    )
    daemon = in_process_daemon(twin, cfg)
    teleop = Teleop(daemon.core)
    daemon.core.listeners.append(teleop)
    runner = threading.Thread(target=daemon.run, kwargs={"max_s": 300.0}, daemon=True)
    runner.start()
    try:
        wait_for(teleop.done.is_set, timeout_s=300, what="the commands' end")
    finally:
        daemon.stop.set()
        runner.join(timeout=30)
        daemon.transport.close()
        twin.stop()
    log = twin.twin.truth_log
    t = np.array([row.t_s for row in log])
    out = []
    for start in teleop.starts:
        end = start + HOLD_S
        steady = (t >= end - STEADY_S) & (t < end)
        out.append(
            (
                float(np.mean([log[i].vx for i in np.flatnonzero(steady)])),
                float(np.mean([log[i].wz for i in np.flatnonzero(steady)])),
            )
        )
    return out


def _relative_errors(speeds: list[tuple[float, float]]) -> list[float]:
    return [
        (v / v_cmd - 1.0) if v_cmd else (w / w_cmd - 1.0)
        for (v_cmd, w_cmd), (v, w) in zip(COMMANDS, speeds, strict=True)
    ]


def test_external_commands_track_within_3_percent_with_the_wheel_speed_pi(
    tmp_path: Path,
) -> None:
    errors = _relative_errors(steady_speeds(tmp_path, closed_loop=True))
    assert all(abs(e) < 0.03 for e in errors), errors


def test_open_loop_the_default_twins_wheels_run_ten_percent_slow(tmp_path: Path) -> None:
    # why the loop is there: the feed-forward assumes the motors' no-load speed
    speeds = steady_speeds(tmp_path, closed_loop=False)
    errors = _relative_errors(speeds)
    assert all(-0.13 < e < -0.08 for e in errors), errors
    assert speeds[1][0] == pytest.approx(0.134, abs=0.003)  # /cmd_vel 0.15 m/s
