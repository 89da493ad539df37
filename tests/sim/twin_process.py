"""Starts ``jackson sim`` as a user does and connects the wire-level test peer to it."""

from __future__ import annotations

import signal
import subprocess
import sys
from pathlib import Path

from .wire_peer import WirePeer

JACKSON = str(Path(sys.executable).parent / "jackson")


class TwinProcess:
    """``jackson sim ARGS`` in a subprocess; ``serial`` and ``i2c`` are where to connect."""

    def __init__(self, *args: str) -> None:
        self.proc = subprocess.Popen(
            [JACKSON, "sim", *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
        )
        assert self.proc.stdout is not None
        lines = [self.proc.stdout.readline().strip() for _ in range(3)]
        if not lines[0].startswith("serial: "):
            err = self.proc.stderr.read() if self.proc.stderr else ""
            raise RuntimeError(f"jackson sim did not start: {lines} {err}")
        self.serial = lines[0].split(": ", 1)[1]
        self.i2c = lines[1].split(": ", 1)[1]

    def host(self) -> WirePeer:
        return WirePeer(self.serial, self.i2c)

    def stop(self) -> tuple[int, str, str]:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
        out, err = self.proc.communicate(timeout=20)
        return self.proc.returncode, out, err
