"""The one base of every error the project raises on purpose.

A :class:`JacksonError` is something a user can cause or meet (a bad file, a missing port, a
firmware of another version, a build that is missing): its message is one line that says what
was wrong and what to do. The command line catches it once (``jackson``'s ``main``) and prints
that line with exit status 2; anything else is a bug and shows its traceback. Each error keeps
the standard base it had (ValueError, OSError, RuntimeError), so callers that catch those still
do.
"""

from __future__ import annotations

import errno
from dataclasses import dataclass


class JacksonError(Exception):
    """An error with a one-line message for the user (module docstring)."""


@dataclass(frozen=True)
class PortKind:
    """How :func:`port_open_message` names a kind of serial port and what belongs on it.

    Attributes
    ----------
    name : str
        The port's kind, e.g. "serial port", "LiDAR port".
    device : str
        What should be plugged in, e.g. "the robot".
    look_for : str
        Where to look for it, e.g. "/dev/ttyACM* or /dev/jackson-mcu".
    holders : str
        Who may hold it, with its leading space, e.g. " (a running jackson daemon?)"; or "".
    """

    name: str
    device: str
    look_for: str
    holders: str = ""


def port_open_message(kind: PortKind, port: str, exc: BaseException) -> str:
    """A one-line explanation of why ``port`` cannot be opened, and what to do.

    Parameters
    ----------
    kind : PortKind
        The port's kind.
    port : str
        The device path.
    exc : BaseException
        What opening it raised (an OSError or pyserial's SerialException).

    Returns
    -------
    str
    """
    text = str(exc)
    code = getattr(exc, "errno", None)  # pyserial's SerialException carries it or only text
    if code == errno.EACCES or "Permission denied" in text:
        return (
            f"permission denied on the {kind.name} {port}: add yourself to the dialout group "
            "(sudo usermod -aG dialout $USER) and log in again"
        )
    if code in (errno.EAGAIN, errno.EWOULDBLOCK) or "exclusively lock" in text:
        return (
            f"{kind.name} {port} is in use by another program{kind.holders}: stop it first, "
            f"or look with: fuser -v {port}"
        )
    if code == errno.ENOENT or "No such file" in text:
        return (
            f"{kind.name} {port} does not exist: is {kind.device} plugged in? "
            f"(look for {kind.look_for})"
        )
    return f"cannot open {kind.name} {port}: {text}"
