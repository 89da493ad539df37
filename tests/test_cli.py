"""The jackson command as a user runs it: real subprocesses, real files."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from jackson.protocol import Ack, Telemetry, encode_frame

JACKSON = [str(Path(sys.executable).parent / "jackson")]


def test_decode_prints_messages_and_counters(tmp_path: Path) -> None:
    capture = tmp_path / "capture.bin"
    capture.write_bytes(
        b"\x00\x13" + encode_frame(Telemetry(t_us=5, enc_left=7), 0) + encode_frame(Ack(), 1)
    )
    out = subprocess.run([*JACKSON, "decode", str(capture)], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert "Telemetry(t_us=5, enc_left=7" in out.stdout
    assert "frames_ok=2" in out.stdout
    assert "bytes_skipped=2" in out.stdout


def test_decode_reads_standard_input() -> None:
    data = encode_frame(Ack(acked_type=3), 0) * 3
    out = subprocess.run([*JACKSON, "decode", "-q", "-"], input=data, capture_output=True)
    assert out.returncode == 0
    assert b"frames_ok=3" in out.stdout
    assert b"Ack(" not in out.stdout


def test_missing_file_is_one_line_and_exit_2(tmp_path: Path) -> None:
    out = subprocess.run(
        [*JACKSON, "decode", str(tmp_path / "nope.bin")], capture_output=True, text=True
    )
    assert out.returncode == 2
    assert out.stderr.strip().count("\n") == 0
    assert "cannot read" in out.stderr
    assert "Traceback" not in out.stderr


def test_bench_writes_json_records(tmp_path: Path) -> None:
    out_file = tmp_path / "bench.json"
    out = subprocess.run(
        [*JACKSON, "bench", "--quick", "--suite", "protocol", "--out", str(out_file)],
        capture_output=True,
        text=True,
    )
    assert out.returncode == 0, out.stderr
    records = json.loads(out_file.read_text())
    names = {r["name"] for r in records}
    assert "protocol.decode_vs_pymavlink" in names
    for r in records:
        assert set(r) == {
            "name",
            "value",
            "unit",
            "target",
            "better",
            "reference",
            "absolute",
            "absolute_unit",
            "reference_absolute",
            "machine_loop_us",
        }
        assert r["better"] in ("higher", "lower")
        assert r["value"] > 0 and r["absolute"] > 0 and r["machine_loop_us"] > 0
    assert "targets met:" in out.stdout and "sum(range(10000))" in out.stdout


def test_the_stage3_command_with_negative_coordinates_parses(tmp_path: Path) -> None:
    """docs/stage3.md's daemon command: the negative start reaches the LiDAR check, where the
    missing port is the one line (before, argparse took ``-0.69,...`` for an option)."""
    out = subprocess.run(
        [
            *JACKSON,
            "daemon",
            "--lidar",
            str(tmp_path / "lidar"),
            "--start",
            "-0.69,-0.04,0",
            "--goal",
            "1.21,-0.04",
            "--port",
            str(tmp_path / "tty"),
            "--no-record",
        ],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert out.returncode == 2, out.stderr
    assert "expected one argument" not in out.stderr
    assert str(tmp_path / "lidar") in out.stderr


def test_numbers_parse_as_written() -> None:
    """A negative number is a value for every option and positional; integers may be written
    as the numbers they are; YAML reads every float spelling as a number."""
    import argparse

    import yaml

    from jackson.common.args import OneLineParser, positive_int
    from jackson.common.fields import _StrictLoader

    p = OneLineParser(prog="t")
    p.add_argument("--x")
    p.add_argument("pose")
    for value in ("-0.5,1", "-7e-1", "-.5", "-inf", "-1,-2,-3"):
        assert p.parse_args(["--x", value, value]) == argparse.Namespace(x=value, pose=value)
    assert positive_int("1e3") == 1000 and positive_int("10.0") == 10
    for text, value in (("1e6", 1e6), ("1.0e6", 1e6), ("-2.5E-3", -2.5e-3), (".5e1", 5.0)):
        assert yaml.load(f"v: {text}", Loader=_StrictLoader) == {"v": value}
    assert yaml.load("v: 1.2.3e4", Loader=_StrictLoader) == {"v": "1.2.3e4"}
