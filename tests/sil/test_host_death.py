"""A daemon killed or stopped at Stage 3 speed: the MCU's failsafe (``failsafe_ms``, 200 ms) drops
the interlock line and the robot is at rest within 0.10 m on the ground truth, while the host's
own command watchdog (``cmd_vel_timeout_s``) stays the paper's 0.6 s."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import pytest

import jackson.experiments.fault_matrix as fm
from jackson.host.config import DEFAULT_CONFIG, load_config

SPEED_M_S = 0.30  # [m/s] the square's sides at Stage 3's top speed (limits.max_v_m_s)
STOP_WITHIN_M = 0.10  # [m] from the fault to rest


def fast_square(folder: Path, actuator: str) -> Path:
    """The shipped configuration with the square's sides driven at :data:`SPEED_M_S`, long
    enough (2 m) for the robot to cruise at the fault."""
    text = DEFAULT_CONFIG.read_text(encoding="utf-8")
    for old, new in (
        ("  side_m: 1.0 ", "  side_m: 2.0 "),
        ("  v_max_m_s: 0.15 ", "  v_max_m_s: 0.30 "),
    ):
        assert old in text
        text = text.replace(old, new)
    path = folder / f"host-{actuator}.yaml"
    path.write_text(text, encoding="utf-8")
    cfg = load_config(path)
    assert (cfg.failsafe_ms, cfg.cmd_vel_timeout_s) == (200, 0.6)
    return path


@pytest.mark.parametrize("signal_name", ["SIGKILL", "SIGSTOP"])
def test_a_host_dead_at_speed_stops_within_ten_centimetres(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, signal_name: str
) -> None:
    monkeypatch.setattr(fm, "_config", fast_square)
    seen: dict[str, object] = {}
    measure = fm._measure

    def keep_samples(fault: fm.Fault, watch: fm._Watch, *rest: object) -> fm.FaultRow:
        seen["samples"], seen["fault_s"] = list(watch.samples), watch.fault_s
        return measure(fault, watch, *rest)  # type: ignore[arg-type]

    monkeypatch.setattr(fm, "_measure", keep_samples)
    row = fm.run_row(fm.Fault(f"host {signal_name}", "pca9685", must_brake=True), tmp_path)
    samples = seen["samples"]
    t_f = seen["fault_s"]
    assert isinstance(samples, list) and isinstance(t_f, float)
    before = [s for s in samples if t_f - 0.2 <= s[0] <= t_f]
    speed = math.dist(before[0][2:], before[-1][2:]) / (before[-1][0] - before[0][0])
    assert speed >= 0.25, speed  # Stage 3 speed at the fault
    # the failsafe counts from the last HEARTBEAT, at most one frame before the fault
    assert row.brake_delay_s is not None
    assert row.brake_delay_s <= fm.FAILSAFE_S + fm.PERIOD_S + 1e-6, row.brake_delay_s
    # 1 s of MCU time after the fault: a stopped host is still stopped (2.5 s of wall time)
    window = [s for s in samples if t_f <= s[0] <= t_f + 1.0]
    travelled = sum(math.dist(a[2:], b[2:]) for a, b in itertools.pairwise(window))
    assert travelled <= STOP_WITHIN_M, travelled
    rest = [s for s in window if s[0] >= t_f + 0.8]
    assert math.dist(rest[0][2:], rest[-1][2:]) < 1e-3  # at rest
