"""The daemon under systemd's notify protocol, against the twin: READY when its loop starts, a
WATCHDOG ping from the main loop at a quarter of WATCHDOG_USEC, STOPPING at the end; a hung
daemon (SIGSTOP) stops pinging, which is what makes systemd kill it and run ``jackson brake``."""

from __future__ import annotations

import itertools
import os
import signal
import socket
import subprocess
import time
from pathlib import Path

from .harness import JACKSON, TwinThread


def _receive(sock: socket.socket, until: float, last: str = "") -> list[tuple[float, str]]:
    """Datagrams until ``until`` or until ``last`` arrives."""
    got: list[tuple[float, str]] = []
    while time.monotonic() < until and not (got and got[-1][1] == last):
        sock.settimeout(max(0.01, until - time.monotonic()))
        try:
            text = sock.recv(256).decode()  # stamped when it arrived, not when waited for
            got.append((time.monotonic(), text))
        except TimeoutError:
            break
    return got


def test_the_daemon_notifies_systemd_and_a_hung_daemon_stops_pinging(tmp_path: Path) -> None:
    twin = TwinThread(tmp_path)
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
    sock.bind(str(tmp_path / "notify"))
    env = {**os.environ, "NOTIFY_SOCKET": str(tmp_path / "notify"), "WATCHDOG_USEC": "400000"}
    cmd = [JACKSON, "daemon", "--port", twin.serial, "--i2c", twin.i2c, "--no-record"]
    daemon = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL)
    try:
        sock.settimeout(60)
        assert sock.recv(256) == b"READY=1"
        pings = []
        while len(pings) < 10:  # the main loop pings while it runs
            pings.append(time.monotonic())
            assert sock.recv(256) == b"WATCHDOG=1"
        gaps = [b - a for a, b in itertools.pairwise(pings[1:])]
        assert max(gaps) < 0.4  # systemd's period: never missed
        daemon.send_signal(signal.SIGSTOP)
        stopped = time.monotonic()
        hung = _receive(sock, stopped + 1.0)  # more than two watchdog periods
        assert [text for t, text in hung if t > stopped + 0.15] == []
        daemon.send_signal(signal.SIGCONT)
        daemon.send_signal(signal.SIGTERM)
        rest = _receive(sock, time.monotonic() + 30, "STOPPING=1")
        assert "STOPPING=1" in [text for _, text in rest]
        assert daemon.wait(timeout=30) == 0
    finally:
        if daemon.poll() is None:
            daemon.kill()
            daemon.wait()
        sock.close()
        twin.stop()
