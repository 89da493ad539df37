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
