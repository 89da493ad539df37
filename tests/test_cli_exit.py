"""The installed command's fast exit (``jackson.main.exit_now``): what a command has said and
what its exit handlers do still happen; with another thread alive it does not end the process."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

SCRIPT = """\
import atexit, sys, threading
from pathlib import Path
from jackson.main import exit_now
atexit.register(lambda: Path(sys.argv[1]).write_text("handler ran"))
sys.stdout.write("said before the exit")  # buffered: no newline, stdout a pipe
if sys.argv[2] == "thread":
    stop = threading.Event()
    t = threading.Thread(target=stop.wait)
    t.start()
    exit_now(3)
    sys.stdout.write(", then returned")
    stop.set()
    t.join()
    sys.exit(5)
exit_now(3)
sys.stdout.write(", never")
"""


def _run(tmp_path: Path, mode: str) -> subprocess.CompletedProcess[str]:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONUNBUFFERED"}  # stdout buffered
    return subprocess.run(
        [sys.executable, "-c", SCRIPT, str(tmp_path / "handler.txt"), mode],
        capture_output=True,
        text=True,
        timeout=60,
        env=env,
    )


def test_the_fast_exit_flushes_what_was_said_and_runs_the_exit_handlers(tmp_path: Path) -> None:
    done = _run(tmp_path, "alone")
    assert done.returncode == 3, done.stderr
    assert done.stdout == "said before the exit"
    assert (tmp_path / "handler.txt").read_text() == "handler ran"


def test_with_another_thread_alive_the_process_ends_the_usual_way(tmp_path: Path) -> None:
    done = _run(tmp_path, "thread")
    assert done.returncode == 5, done.stderr
    assert done.stdout == "said before the exit, then returned"
    assert (tmp_path / "handler.txt").read_text() == "handler ran"
