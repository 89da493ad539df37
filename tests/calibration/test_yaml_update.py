"""The YAML writer behind ``jackson calibrate --write``: comments, key order and untouched lines
kept, the diff and the backup, values that read back equal through the host's loader."""

from __future__ import annotations

import datetime as dt
import difflib
import re
import shutil
from pathlib import Path
from typing import Any

import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from jackson.calibration.yaml_update import (
    YamlUpdateError,
    edit_text,
    format_value,
    update_config,
)
from jackson.common.fields import read_yaml
from jackson.host.config import DEFAULT_CONFIG, load_config

CALIBRATED = {  # what imu, encoders, track, deadband and step write, all at once
    "imu.calibration.rotation": [1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, -1.0],
    "imu.calibration.gyro_bias_rad_s": [0.0012, -0.0003, 0.00995],
    "imu.calibration.accel_scale": 1.0552,
    "robot.ticks_per_rev.left": 617.2,
    "robot.ticks_per_rev.right": 625.9,
    "robot.wheel_separation_m": 0.20498,
    "deadband.left.forward": 0.1205,
    "deadband.right.reverse": 0.1505,
    "deadband.max_wheel_rad_s": 8.635,
    "deadband.gain.right.reverse": 0.9987,
}
NOW = dt.datetime(2024, 5, 17, 14, 3, 9)


def config_copy(tmp: Path) -> Path:
    path = tmp / "jackson.yaml"
    shutil.copy(DEFAULT_CONFIG, path)
    return path


def comments(text: str) -> list[str]:
    """Every comment of a YAML text, in order (this file has no '#' inside values)."""
    return [line[line.index("#") :] for line in text.splitlines() if "#" in line]


def key_paths(data: Any, prefix: str = "") -> list[str]:
    """Every dotted key of a parsed YAML document, in the file's order."""
    if not isinstance(data, dict):
        return []
    out = []
    for key, value in data.items():
        out.append(prefix + str(key))
        out.extend(key_paths(value, f"{prefix}{key}."))
    return out


# ------------------------------------------------------------------------- numbers


def test_format_value_writes_yaml_floats() -> None:
    assert format_value(617.2) == "617.2"
    assert format_value(1e-05) == "1.0e-05"  # YAML 1.1 needs the dot to read a float
    assert format_value(1e16) == "1.0e+16"
    assert format_value(621) == "621"
    assert format_value([1.0, 0.0, 2.5e-05]) == "[1.0, 0.0, 2.5e-05]"


@pytest.mark.parametrize("value", [1e-05, 2.5e-07, 0.1 + 0.2, 617.2, 1.0, 123456789.12345679])
def test_a_written_float_reads_back_equal_through_the_host_config(
    tmp_path: Path, value: float
) -> None:
    path = config_copy(tmp_path)
    update_config(path, {"ekf.process_noise.x": value, "ekf.mahalanobis_threshold.imu": value})
    text = path.read_text()
    assert f"    x: {format_value(value)} " in text and f"    imu: {format_value(value)}\n" in text
    cfg = load_config(path)
    assert cfg.ekf.process_noise.x == value and cfg.ekf.mahalanobis_imu == value


@settings(max_examples=60, deadline=None)
@given(st.floats(allow_nan=False, allow_infinity=False, width=64))
def test_any_finite_float_round_trips_through_the_host_reader(value: float) -> None:
    text = edit_text("a:\n  b: 0.5   # c\n", {"a.b": value, "a.c": [value, 1]})
    data = yaml.load(text, Loader=yaml.SafeLoader)
    assert data["a"]["b"] == value and data["a"]["c"] == [value, 1]  # plain YAML 1.1 too
    assert "# c" in text


# ------------------------------------------------------------------------- comments, order, lines


def test_every_comment_and_the_key_order_are_kept(tmp_path: Path) -> None:
    path = config_copy(tmp_path)
    before = path.read_text()
    update_config(path, CALIBRATED)
    after = path.read_text()
    assert comments(after) == comments(before)
    old_keys = key_paths(yaml.safe_load(before))
    new_keys = key_paths(yaml.safe_load(after))
    assert [k for k in new_keys if k in old_keys] == old_keys  # the new ones slot in between
    assert sorted(set(new_keys) - set(old_keys)) == [
        "deadband.gain.right.forward",
        "deadband.gain.right.reverse",
        "imu.calibration",
        "imu.calibration.accel_scale",
        "imu.calibration.gyro_bias_rad_s",
        "imu.calibration.rotation",
        "robot.ticks_per_rev.left",
        "robot.ticks_per_rev.right",
    ]


def test_only_the_changed_lines_differ_and_comments_keep_their_column(tmp_path: Path) -> None:
    path = config_copy(tmp_path)
    before = path.read_text().splitlines()
    update_config(path, CALIBRATED)
    after = path.read_text().splitlines()
    diff = [ln for ln in difflib.ndiff(before, after) if ln[:2] in ("- ", "+ ")]
    removed = [ln[2:] for ln in diff if ln.startswith("- ")]
    added = [ln[2:] for ln in diff if ln.startswith("+ ")]
    assert len(removed) == 6  # ticks, separation, 2 deadbands, max_wheel_rad_s, gain right
    assert len(added) == 6 + 4  # ... and imu.calibration with its three fields
    assert "  wheel_separation_m: 0.20498  # [m] B_run, Table 3" in path.read_text()
    assert "    forward: 0.1205            # [duty 0-1] breakaway duty" in path.read_text()
    assert "  ticks_per_rev: {left: 617.2, right: 625.9} # [ticks/rev] C_e,run" in path.read_text()
    column = {line.split(":")[0]: line.index("#") for line in removed}
    for line in added:  # a comment keeps its column unless the new value reaches past it
        if line.split(":")[0] in column:
            value_end = len(line[: line.index("#")].rstrip())
            assert line.index("#") == max(column[line.split(":")[0]], value_end + 1)


def test_a_new_section_goes_after_its_siblings_before_the_blank_line(tmp_path: Path) -> None:
    path = config_copy(tmp_path)
    update_config(path, {k: v for k, v in CALIBRATED.items() if k.startswith("imu.")})
    lines = path.read_text().splitlines()
    at = lines.index("  calibration:")
    assert lines[at - 1].startswith("  #   accel_scale: 1.054")  # the commented example stays
    assert lines[at + 1 : at + 6] == [
        "    rotation: [1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, -1.0]",
        "    gyro_bias_rad_s: [0.0012, -0.0003, 0.00995]",
        "    accel_scale: 1.0552",
        "",
        "serial:",
    ]


def test_a_new_top_level_field_goes_at_the_end_after_a_blank_line() -> None:
    text = "# head\nrobot:\n  wheel_radius_m: 0.033   # [m]\n"
    assert edit_text(text, {"watchdog_s": 0.5, "ekf.r_vx": 1e-4}) == (
        f"{text}\nwatchdog_s: 0.5\n\nekf:\n  r_vx: 0.0001\n"
    )


def test_null_becomes_a_block_keeping_its_comment() -> None:
    text = "imu:\n  calibration: null   # optional\n\nserial:\n  port: x\n"
    assert edit_text(text, {"imu.calibration.accel_scale": 1.05}) == (
        "imu:\n  calibration:        # optional\n    accel_scale: 1.05\n\nserial:\n  port: x\n"
    )


def test_one_number_for_both_sides_becomes_a_pair_only_when_they_differ() -> None:
    text = "robot:\n  ticks_per_rev: 621     # [ticks/rev]\n"
    same = {"robot.ticks_per_rev.left": 621.0, "robot.ticks_per_rev.right": 621}
    assert edit_text(text, same) == text
    assert edit_text(text, {"robot.ticks_per_rev.left": 617.2}) == (
        "robot:\n  ticks_per_rev: {left: 617.2, right: 621} # [ticks/rev]\n"
    )


def test_a_flow_mapping_and_a_list_are_edited_in_their_own_style() -> None:
    text = (
        "robot:\n  ticks_per_rev: {left: 617, right: 621}   # history\n"
        "imu:\n  calibration:\n    rotation:\n    - 1\n    - 0\n    - 0\n    - 0\n    - 1\n"
        "    - 0\n    - 0\n    - 0\n    - 1      # row-major\n"
        "    gyro_bias_rad_s: [0, 0, 0]   # [rad/s]\n    accel_scale: 1.0\n"
    )
    new = edit_text(
        text,
        {
            "robot.ticks_per_rev.right": 626.0,
            "imu.calibration.rotation": [1, 0, 0, 0, -1, 0, 0, 0, -1],
            "imu.calibration.gyro_bias_rad_s": [0.0, 0.0, 0.01],
        },
    )
    assert new == (
        "robot:\n  ticks_per_rev: {left: 617, right: 626.0} # history\n"
        "imu:\n  calibration:\n    rotation:\n    - 1\n    - 0\n    - 0\n    - 0\n    - -1\n"
        "    - 0\n    - 0\n    - 0\n    - -1     # row-major\n"
        "    gyro_bias_rad_s: [0, 0, 0.01] # [rad/s]\n    accel_scale: 1.0\n"
    )


@pytest.mark.parametrize("newline", ["\n", "\r\n"])
def test_document_markers_line_ends_and_four_space_indents_are_kept(newline: str) -> None:
    lines = ["---", "robot:", "    wheel_radius_m: 0.033  # [m]", "    wheel_separation_m: 0.198"]
    text = newline.join([*lines, "...", ""])
    assert edit_text(text, {"robot.wheel_radius_m": 0.0331}) == text.replace("0.033 ", "0.0331")


# ------------------------------------------------------------------------- diff, backup, no-op


def test_the_diff_is_shown_and_the_old_file_kept(tmp_path: Path) -> None:
    path = config_copy(tmp_path)
    before = path.read_text()
    result = update_config(path, {"robot.wheel_separation_m": 0.20498}, now=NOW)
    assert result.backup == tmp_path / "jackson.yaml.bak-20240517-140309"
    assert result.backup.read_text() == before
    assert result.changes == ["robot.wheel_separation_m: 0.198 -> 0.20498"]
    diff = result.diff.splitlines()
    assert diff[:2] == [f"--- {path} (before)", f"+++ {path}"]
    comment = "# [m] B_run, Table 3 (360 deg rotation check, Eq. A12-A15)"
    assert [ln for ln in diff if ln[:1] in "+-" and ln[:3] not in ("---", "+++")] == [
        f"-  wheel_separation_m: 0.198    {comment}",
        f"+  wheel_separation_m: 0.20498  {comment}",
    ]
    first = path.read_text()
    second = update_config(path, {"robot.wheel_separation_m": 0.205}, now=NOW)
    assert second.backup == tmp_path / "jackson.yaml.bak-20240517-140309-1"
    assert second.backup.read_text() == first


def test_a_second_write_of_the_same_values_is_a_no_op(tmp_path: Path) -> None:
    path = config_copy(tmp_path)
    update_config(path, CALIBRATED)
    text = path.read_text()
    mtime = path.stat().st_mtime_ns
    again = update_config(path, CALIBRATED)
    assert (again.backup, again.changes, again.diff) == (None, [], "")
    assert path.read_text() == text and path.stat().st_mtime_ns == mtime
    assert len(list(tmp_path.glob("jackson.yaml.bak-*"))) == 1


def test_a_value_already_there_keeps_its_spelling(tmp_path: Path) -> None:
    path = config_copy(tmp_path)
    result = update_config(path, {"deadband.left.forward": 0.1, "limits.max_v_m_s": 0.3})
    assert result.backup is None and path.read_text() == DEFAULT_CONFIG.read_text()


def test_the_written_file_reads_back_through_the_host_config(tmp_path: Path) -> None:
    path = config_copy(tmp_path)
    result = update_config(path, CALIBRATED)
    cfg = load_config(path)
    assert cfg.imu.calibration is not None
    assert cfg.imu.calibration.rotation == tuple(CALIBRATED["imu.calibration.rotation"])
    assert cfg.imu.calibration.gyro_bias_rad_s == (0.0012, -0.0003, 0.00995)
    assert cfg.imu.calibration.accel_scale == 1.0552
    assert (cfg.robot.ticks_per_rev_left, cfg.robot.ticks_per_rev_right) == (617.2, 625.9)
    assert cfg.robot.wheel_separation_m == 0.20498
    assert (cfg.deadband.forward_left, cfg.deadband.reverse_right) == (0.1205, 0.1505)
    assert cfg.deadband.gain("right", "forward") == 1.0
    assert cfg.deadband.gain("right", "reverse") == 0.9987
    _, data = read_yaml(path, "config")
    assert data["deadband"]["gain"]["right"] == {"forward": 1.0, "reverse": 0.9987}
    # each change is named by the YAML path the file spells (the path the caller gave)
    assert "deadband.gain.right.reverse: 1.0 -> 0.9987" in result.changes
    assert "robot.ticks_per_rev.left: 621 -> 617.2" in result.changes
    assert {line.split(": ")[0] for line in result.changes} <= set(CALIBRATED)


# ------------------------------------------------------------------------- bad input


def test_an_invalid_value_leaves_the_file_untouched(tmp_path: Path) -> None:
    path = config_copy(tmp_path)
    with pytest.raises(YamlUpdateError, match=r"deadband\.left\.forward"):
        update_config(path, {"deadband.left.forward": 0.95})
    assert path.read_text() == DEFAULT_CONFIG.read_text()
    assert [p.name for p in tmp_path.iterdir()] == ["jackson.yaml"]


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("robot: {wheel_radius_m: 0.033\n", r"^config c\.yaml: line 2: not valid YAML"),
        ("- 1\n- 2\n", r"^config c\.yaml: .*mapping"),
        ("robot: [1, 2]\n", r"^config c\.yaml: robot: .*mapping"),
        ("robot:\n  wheel_radius_m: 0.033\n  wheel_radius_m: 0.034\n", r"wheel_radius_m"),
    ],
)
def test_a_file_that_is_not_a_host_yaml_is_one_line(
    tmp_path: Path, text: str, message: str
) -> None:
    path = tmp_path / "c.yaml"
    path.write_text(text)
    with pytest.raises(YamlUpdateError, match=message) as info:
        update_config(path, {"robot.wheel_radius_m": 0.034})
    assert "\n" not in str(info.value)
    assert path.read_text() == text and len(list(tmp_path.iterdir())) == 1


@pytest.mark.parametrize(
    ("text", "updates", "message"),
    [
        ("robot: {a: 1\n", {"robot.a": 2}, "config: line 2: cannot be edited as YAML (expected"),
        ("- 1\n", {"robot.a": 2}, "config: the top level is not a mapping of fields"),
        ("robot: [1, 2]\n", {"robot.a": 2}, "config: robot.a: robot is a list, not a section"),
        ("robot: x\n", {"robot.a": 2}, "config: robot.a: robot is text, not a section"),
        ("robot:\n  a: 1\n", {"robot.a.b": 2}, "config: robot.a.b: robot.a is a number, not"),
        ("robot:\n  a: 1\n", {"robot.a": float("nan")}, "robot.a: the value is not a finite"),
        ("robot:\n  a: 1\n", {"robot..a": 1}, "config: 'robot..a': not a dotted field name"),
    ],
)
def test_what_cannot_be_edited_is_one_line(text: str, updates: Any, message: str) -> None:
    with pytest.raises(YamlUpdateError) as info:
        edit_text(text, updates)
    assert message in str(info.value) and "\n" not in str(info.value)


def test_an_unreadable_path_is_one_line(tmp_path: Path) -> None:
    with pytest.raises(YamlUpdateError, match=re.escape(f"{tmp_path / 'missing.yaml'}")):
        update_config(tmp_path / "missing.yaml", {"robot.wheel_radius_m": 0.034})
