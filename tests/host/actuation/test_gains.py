"""Per-wheel, per-direction gains of the deadband compensation: config, duty map, YAML update."""

from __future__ import annotations

import math
import shutil
from pathlib import Path
from typing import Any

import pytest
import yaml
from hypothesis import given
from hypothesis import strategies as st

from jackson.calibration.yaml_update import update_config
from jackson.host.actuation.deadband import DeadbandConfig, wheel_duty
from jackson.host.config import (
    DEFAULT_CONFIG,
    ConfigError,
    HostConfig,
    config_diff,
    dump_config,
    load_config,
    parse_config,
)

PER_DIRECTION = DeadbandConfig(
    forward_left=0.10,
    reverse_left=0.12,
    forward_right=0.14,
    reverse_right=0.16,
    max_wheel_rad_s=10.0,
    gain_left=0.8,
    gain_right=0.9,
    gain_reverse_left=0.6,
    gain_reverse_right=1.2,
)


def deadband_of(section: dict[str, Any]) -> DeadbandConfig:
    return parse_config({"deadband": section}, "config test.yaml").deadband


def old_formula(omega: float, side: str, cfg: DeadbandConfig) -> float:
    """wheel_duty as it was with one gain per wheel, for the bit-identity check."""
    if side == "left":
        forward, reverse, gain = cfg.forward_left, cfg.reverse_left, cfg.gain_left
    else:
        forward, reverse, gain = cfg.forward_right, cfg.reverse_right, cfg.gain_right
    magnitude = abs(omega)
    if magnitude <= cfg.zero_threshold_rad_s:
        return 0.0
    breakaway = forward if omega > 0.0 else reverse
    duty = min(1.0, breakaway + (1.0 - breakaway) * gain * magnitude / cfg.max_wheel_rad_s)
    return math.copysign(duty, omega)


# ------------------------------------------------------------------------- the duty map


@given(
    omega=st.floats(-30.0, 30.0, allow_nan=False),
    gain_left=st.floats(0.05, 2.0),
    gain_right=st.floats(0.05, 2.0),
)
def test_one_gain_per_wheel_gives_bit_identical_duties(
    omega: float, gain_left: float, gain_right: float
) -> None:
    cfg = DeadbandConfig(0.11, 0.13, 0.09, 0.15, 10.47, gain_left=gain_left, gain_right=gain_right)
    for side in ("left", "right"):
        assert wheel_duty(omega, side, cfg) == old_formula(omega, side, cfg)


def test_defaults_keep_one_gain_of_1_for_both_directions() -> None:
    d = DeadbandConfig()
    assert (d.gain_left, d.gain_right) == (1.0, 1.0)
    assert d.gain_reverse_left is None and d.gain_reverse_right is None
    assert [d.gain(s, r) for s in ("left", "right") for r in ("forward", "reverse")] == [1.0] * 4
    assert HostConfig().deadband == d


def test_wheel_duty_takes_the_gain_of_the_commands_direction() -> None:
    c = PER_DIRECTION
    assert wheel_duty(5.0, "left", c) == pytest.approx(0.10 + 0.90 * 0.8 * 0.5)
    assert wheel_duty(-5.0, "left", c) == pytest.approx(-(0.12 + 0.88 * 0.6 * 0.5))
    assert wheel_duty(5.0, "right", c) == pytest.approx(0.14 + 0.86 * 0.9 * 0.5)
    assert wheel_duty(-5.0, "right", c) == pytest.approx(-(0.16 + 0.84 * 1.2 * 0.5))
    # a reverse gain leaves the breakaway point alone
    assert wheel_duty(-0.051, "left", c) == pytest.approx(-0.12, abs=0.005)


def test_gain_and_breakaway_by_wheel_and_direction() -> None:
    c = PER_DIRECTION
    assert c.gain("left", "forward") == 0.8 and c.gain("left", "reverse") == 0.6
    assert c.gain("right", "forward") == 0.9 and c.gain("right", "reverse") == 1.2
    assert c.breakaway("left", "reverse") == 0.12 and c.breakaway("right", "forward") == 0.14
    with pytest.raises(ValueError, match="direction"):
        c.gain("left", "sideways")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="side"):
        c.breakaway("middle", "forward")  # type: ignore[arg-type]


@pytest.mark.parametrize("bad", [0.0, -1.0, math.nan, math.inf])
def test_impossible_reverse_gain_is_rejected_naming_it(bad: float) -> None:
    with pytest.raises(ValueError, match="gain_reverse_right"):
        DeadbandConfig(gain_reverse_right=bad)


# ------------------------------------------------------------------------- the YAML


def test_packaged_config_has_one_gain_per_wheel() -> None:
    db = load_config(DEFAULT_CONFIG).deadband
    assert db == DeadbandConfig()
    assert dump_config(HostConfig())["deadband"]["gain"] == {"left": 1.0, "right": 1.0}


def test_todays_form_is_a_gain_for_both_directions() -> None:
    db = deadband_of({"gain": {"left": 0.9, "right": 1.1}})
    assert (db.gain_left, db.gain_right) == (0.9, 1.1)
    assert db.gain("left", "reverse") == 0.9 and db.gain("right", "reverse") == 1.1
    assert wheel_duty(-5.0, "left", db) == -wheel_duty(5.0, "left", db)


def test_per_direction_form_and_mixed_forms_parse() -> None:
    db = deadband_of({"gain": {"left": {"forward": 0.92, "reverse": 0.95}, "right": 1.05}})
    assert (db.gain_left, db.gain_reverse_left) == (0.92, 0.95)
    assert (db.gain_right, db.gain_reverse_right) == (1.05, None)
    only_forward = deadband_of({"gain": {"left": {"forward": 0.9}}})
    assert only_forward.gain("left", "reverse") == 0.9 and only_forward.gain_reverse_left is None
    only_reverse = deadband_of({"gain": {"right": {"reverse": 0.8}}})
    assert only_reverse.gain("right", "forward") == 1.0
    assert only_reverse.gain("right", "reverse") == 0.8


@pytest.mark.parametrize(
    ("gain", "message"),
    [
        ({"right": 0}, "deadband.gain.right: expected a number in (0, 2]"),
        ({"left": {"reverse": 0}}, "deadband.gain.left.reverse: expected a number in (0, 2]"),
        ({"left": {"forward": 2.5}}, "deadband.gain.left.forward: expected a number in (0, 2]"),
        ({"left": {"backward": 1.0}}, "deadband.gain.left.backward: unknown field"),
        ({"left": "fast"}, "deadband.gain.left: expected a number in (0, 2]"),
    ],
)
def test_bad_gain_is_one_line_naming_the_field(gain: dict[str, Any], message: str) -> None:
    with pytest.raises(ConfigError) as err:
        deadband_of({"gain": gain})
    assert str(err.value).startswith(f"config test.yaml: {message}")
    assert "\n" not in str(err.value)


@pytest.mark.parametrize(
    "db",
    [
        DeadbandConfig(),
        PER_DIRECTION,
        DeadbandConfig(gain_left=0.93, gain_reverse_right=0.97),
        DeadbandConfig(gain_left=0.9, gain_reverse_left=0.9),  # equal, yet given
    ],
)
def test_dump_and_parse_round_trip_the_gains(db: DeadbandConfig) -> None:
    cfg = HostConfig(deadband=db)
    text = yaml.safe_dump(dump_config(cfg), sort_keys=False)
    assert parse_config(yaml.safe_load(text)) == cfg


def test_config_diff_names_each_changed_gain() -> None:
    old = HostConfig()
    new = HostConfig(deadband=DeadbandConfig(gain_right=0.92, gain_reverse_left=0.97))
    assert config_diff(old, new) == [
        "deadband.gain_right: 1 -> 0.92",
        "deadband.gain_reverse_left: null -> 0.97",
    ]


# ------------------------------------------------------------------------- writing them


def config_copy(tmp: Path) -> Path:
    path = tmp / "jackson.yaml"
    shutil.copy(DEFAULT_CONFIG, path)
    return path


def test_update_config_writes_four_gains_keeping_the_comments(tmp_path: Path) -> None:
    path = config_copy(tmp_path)
    updates = {
        "deadband.max_wheel_rad_s": 8.635,
        "deadband.gain.left.forward": 0.9196,
        "deadband.gain.left.reverse": 0.9201,
        "deadband.gain.right.forward": 1.0,
        "deadband.gain.right.reverse": 0.9987,
    }
    result = update_config(path, updates)
    assert result.backup is not None and result.backup.read_text() == DEFAULT_CONFIG.read_text()
    db = load_config(path).deadband
    assert (db.gain_left, db.gain_reverse_left) == (0.9196, 0.9201)
    assert (db.gain_right, db.gain_reverse_right) == (1.0, 0.9987)
    assert db.max_wheel_rad_s == 8.635
    text = path.read_text()
    assert "left: {forward: 0.9196, reverse: 0.9201}" in text
    assert "# one number for both directions, or {forward: g, reverse: g}" in text
    assert "deadband.gain.left.reverse: 1.0 -> 0.9201" in result.changes
    # every other line is untouched
    old = DEFAULT_CONFIG.read_text().splitlines()
    new = text.splitlines()
    assert len(old) == len(new)
    assert sum(a != b for a, b in zip(old, new, strict=True)) == 3


def test_setting_one_direction_keeps_the_other(tmp_path: Path) -> None:
    path = config_copy(tmp_path)
    update_config(path, {"deadband.gain.right.reverse": 0.95})
    db = load_config(path).deadband
    assert db.gain("right", "forward") == 1.0 and db.gain("right", "reverse") == 0.95
    assert "right: {forward: 1.0, reverse: 0.95}" in path.read_text()


def test_gains_in_a_flow_mapping_are_written_in_flow_style(tmp_path: Path) -> None:
    path = tmp_path / "flow.yaml"
    path.write_text("deadband: {gain: {left: 0.9, right: 1.1}, max_wheel_rad_s: 9.0}\n")
    update_config(path, {"deadband.gain.left.reverse": 0.8, "deadband.gain.right.forward": 1.05})
    assert path.read_text() == (
        "deadband: {gain: {left: {forward: 0.9, reverse: 0.8}, right: {forward: 1.05, "
        "reverse: 1.1}}, max_wheel_rad_s: 9.0}\n"
    )
    db = load_config(path).deadband
    assert (db.gain_left, db.gain_reverse_left) == (0.9, 0.8)
    assert (db.gain_right, db.gain_reverse_right) == (1.05, 1.1)
    assert db.max_wheel_rad_s == 9.0
