"""No thread dies alone: an exception in a worker thread reaches the loop that owns the run.

A thread that Python starts and whose target raises prints a traceback and ends; the rest of
the process carries on, and a loop waiting on that thread's work waits for ever (the twin's
physics stops, the host waits for a telemetry frame that never comes). A thread started with
:func:`start` (or whose target is wrapped by :func:`guard`) instead records what it raised as a
:class:`ThreadFailure` in every open :class:`Watch`. The loop that owns the run opens a
:class:`Watch` around it and looks at :attr:`Watch.first` at each turn: the daemon's frame loop
aborts the mission on it (braked, SHUTDOWN said, exit status 1), a twin session raises
:class:`ThreadFailedError` when it ends, and the command line prints its one line with exit
status 1 (an internal failure, not a user's error: those are 2).

A watch opened while others are open sees what they saw: a failure recorded before the inner
loop started is still its concern.
"""

from __future__ import annotations

import sys
import threading
import traceback
from collections.abc import Callable
from dataclasses import dataclass
from types import TracebackType

from jackson.common.errors import JacksonError

EXIT_STATUS = 1
"""The exit status of a run ended by a failed thread (user errors exit 2)."""


class ThreadFailedError(JacksonError, RuntimeError):
    """A thread of the run raised: the message is the one line of :attr:`ThreadFailure.line`."""


@dataclass(frozen=True)
class ThreadFailure:
    """What a thread raised.

    Attributes
    ----------
    name : str
        What the thread does (e.g. ``twin``, ``jackson-serial``).
    error : BaseException
        The exception, with its traceback.
    """

    name: str
    error: BaseException

    @property
    def line(self) -> str:
        """One line: the thread, the exception, and the innermost place it was raised."""
        if isinstance(self.error, JacksonError):  # a user's error or one already told
            return str(self.error)
        text = " ".join(str(self.error).split()) or "(no message)"
        where = ""
        frames = traceback.extract_tb(self.error.__traceback__)
        if frames:
            last = frames[-1]
            where = f" in {last.name} ({last.filename.rsplit('/', 1)[-1]}:{last.lineno})"
        return (
            f"internal failure: the {self.name} thread raised {type(self.error).__name__}: "
            f"{text}{where}; the run was stopped"
        )


_lock = threading.Lock()
_open: list[Watch] = []


class Watch:
    """Collects the failures of guarded threads while it is open (a context manager)."""

    def __init__(self) -> None:
        self._failures: list[ThreadFailure] = []
        self._event = threading.Event()

    def __enter__(self) -> Watch:
        with _lock:
            for outer in _open:
                for failure in outer._failures:
                    self._add(failure)
            _open.append(self)
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        with _lock:
            if self in _open:
                _open.remove(self)

    def _add(self, failure: ThreadFailure) -> None:
        if failure not in self._failures:
            self._failures.append(failure)
            self._event.set()

    @property
    def first(self) -> ThreadFailure | None:
        """The first failure seen, or None."""
        with _lock:
            return self._failures[0] if self._failures else None

    def wait(self, timeout_s: float | None) -> bool:
        """Block until a failure is seen or ``timeout_s`` passes; True when one was seen."""
        return self._event.wait(timeout_s)

    def check(self) -> None:
        """Raise the first failure: a :class:`~jackson.common.errors.JacksonError` (a user's
        error, e.g. a world file the physics cannot play) as itself, anything else as a
        :class:`ThreadFailedError` with its line."""
        first = self.first
        if first is None:
            return
        if isinstance(first.error, JacksonError):  # its own line and exit status
            raise first.error
        raise ThreadFailedError(first.line) from first.error


def record(name: str, error: BaseException) -> ThreadFailure:
    """Record ``error`` as the failure of thread ``name`` in every open watch; with none open,
    print its one line on stderr (the failure is never silent)."""
    failure = ThreadFailure(name, error)
    with _lock:
        watches = list(_open)
        for watch in watches:
            watch._add(failure)
    if not watches:
        print(failure.line, file=sys.stderr, flush=True)
    return failure


def guard(target: Callable[..., object], name: str) -> Callable[..., None]:
    """``target`` wrapped so that what it raises is recorded (:func:`record`), not lost; the
    wrapper passes its arguments on (``threading.Thread(target=guard(f, name), args=...)``)."""

    def run(*args: object) -> None:
        try:
            target(*args)
        except BaseException as exc:  # every exception: SystemExit in a thread is lost too
            record(name, exc)

    return run


def start(target: Callable[[], object], name: str, *, daemon: bool = True) -> threading.Thread:
    """Start ``target`` in a thread called ``name``, guarded (:func:`guard`)."""
    thread = threading.Thread(target=guard(target, name), name=name, daemon=daemon)
    thread.start()
    return thread
