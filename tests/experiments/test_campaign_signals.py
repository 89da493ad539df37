"""A campaign stopped by SIGTERM (systemd, a CI timeout, ``kill``) stops its trials too: no
worker process is left running a trial into the report folder."""

from __future__ import annotations

import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

JACKSON = str(Path(sys.executable).parent / "jackson")


def _descendants(pid: int) -> set[int]:
    """Every process below ``pid`` (by /proc's parent links)."""
    children: dict[int, list[int]] = {}
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
        except OSError:
            continue
        ppid = int(stat.rsplit(")", 1)[1].split()[1])
        children.setdefault(ppid, []).append(int(entry.name))
    out: set[int] = set()
    todo = [pid]
    while todo:
        for child in children.get(todo.pop(), []):
            out.add(child)
            todo.append(child)
    return out


def _alive(pid: int) -> bool:
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] != "Z"  # a zombie has ended


def _wait_for(condition: object, timeout_s: float, what: str) -> None:
    """Poll ``condition`` every 10 ms (a busy loop would take a core from the campaign)."""
    deadline = time.monotonic() + timeout_s
    tick = threading.Event()
    while not condition():  # type: ignore[operator]
        assert time.monotonic() < deadline, f"timed out waiting for {what}"
        tick.wait(0.01)


def test_sigterm_stops_the_workers_and_their_trials(tmp_path: Path) -> None:
    out = tmp_path / "report"
    proc = subprocess.Popen(
        [JACKSON, "campaign", "square", "--trials", "6", "--workers", "2", "--out", str(out)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        # both workers have a trial running: each writes its run folder as the trial starts
        _wait_for(lambda: len(list(out.glob("runs/*"))) >= 2, 120, "two trials to start")
        workers = _descendants(proc.pid)
        assert len(workers) >= 3  # the forkserver and two workers, at least
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 128 + signal.SIGTERM, err
    assert "Traceback" not in err
    _wait_for(lambda: not any(_alive(p) for p in workers), 30, "the workers to end")
    # the trials did not run on: no new run folder appears once the campaign has ended
    assert len(list(out.glob("runs/*"))) < 6
