"""The twin's serial link: a pseudo-terminal that looks like the ESP32-S3's USB port."""

from __future__ import annotations

import contextlib
import errno
import os
import termios
import tty
from pathlib import Path

QUEUE_BYTES = 8192  # like a USB CDC TX buffer: frames that do not fit are dropped whole


class PtyLink:
    """A raw-mode pty. The twin keeps its own slave descriptor open, so a client may close and
    reopen the port (a host reconnecting) without the link going down; frames are written
    whole or not at all, and never block the twin.
    """

    def __init__(self, link: str | None = None) -> None:
        self.master, self._slave = os.openpty()
        tty.setraw(self._slave)
        os.set_blocking(self.master, False)
        self.path = os.ttyname(self._slave)
        self._queue = bytearray()
        self.link = Path(link) if link else None
        if self.link is not None:
            try:
                self._make_link(self.link)
            except OSError:
                self.link = None
                self.close()
                raise

    def _make_link(self, link: Path) -> None:
        """Point ``link`` at the pty. Only a symlink is replaced (a twin's link from before);
        a file or folder the user has there is never deleted."""
        if link.is_symlink():
            link.unlink()
        elif link.exists():
            raise FileExistsError(
                errno.EEXIST,
                "is there and is not a symlink; give a new path for the link",
                str(link),
            )
        try:
            link.symlink_to(self.path)
        except OSError as exc:
            raise OSError(exc.errno, f"cannot make the link ({exc.strerror})", str(link)) from exc

    def fileno(self) -> int:
        return self.master

    def flush(self) -> None:
        while self._queue:
            try:
                n = os.write(self.master, self._queue)
            except BlockingIOError:
                return
            except OSError as exc:  # pragma: no cover - only if the pty itself fails
                if exc.errno in (errno.EIO, errno.EAGAIN):
                    return
                raise
            del self._queue[:n]

    def write(self, frame: bytes) -> bool:
        """Queue a whole frame; False (dropped) when the buffer cannot take it."""
        self.flush()
        if len(self._queue) + len(frame) > QUEUE_BYTES:
            return False
        self._queue += frame
        self.flush()
        return True

    def discard(self) -> None:
        """Drop what was written and not yet read by the host (queued here or in the pty)."""
        self._queue.clear()
        with contextlib.suppress(OSError):
            termios.tcflush(self._slave, termios.TCIFLUSH)

    def read(self) -> bytes:
        """Whatever the host has written (b"" when nothing)."""
        self.flush()
        try:
            return os.read(self.master, 65536)
        except (BlockingIOError, OSError):
            return b""

    def close(self) -> None:
        for fd in (self.master, self._slave):
            with contextlib.suppress(OSError):
                os.close(fd)
        if self.link is not None and self.link.is_symlink():  # ours; never a user's file
            with contextlib.suppress(FileNotFoundError):
                self.link.unlink()
