"""A long-running daemon's run folders: when the next one starts (``recording.split``), what it
is called, and the work of a split done off the frame loop (docs/recording.md).

- ``goal``: a new folder starts at the telemetry frame that takes a navigation goal's request
  (the request is the goal's folder's first record); the idle stretch after a goal stays in its
  folder. A folder that has run ``split_s`` of MCU time without a goal is split as with
  ``duration``, so an idle robot's folder does not grow for ever either.
- ``duration``: a new folder every ``split_s`` of MCU time.
- ``none``: one folder, as long as the daemon runs.

A split happens between two telemetry frames, before the LiDAR bytes of the second: the new
folder holds the core's snapshot (:mod:`jackson.host.recording.snapshot`), from which ``jackson
replay`` starts.
"""

from __future__ import annotations

import os
import queue
import shutil
import threading
from collections.abc import Callable
from pathlib import Path

from jackson.common.threads import guard
from jackson.host.config import RECORDING_SPLITS
from jackson.host.recording import RECORDED
from jackson.host.recording.snapshot import SNAPSHOT_NAME


class SplitPolicy:
    """When the daemon starts its next run folder (module docstring).

    Parameters
    ----------
    mode : str
        ``goal``, ``duration`` or ``none``.
    split_s : float
        MCU time [s] per folder (``duration``; the longest a folder runs with ``goal``).
    """

    def __init__(self, mode: str, split_s: float) -> None:
        if mode not in RECORDING_SPLITS:
            raise ValueError(f"split {mode!r}: one of {', '.join(RECORDING_SPLITS)}")
        if not split_s > 0.0:
            raise ValueError(f"split_s must be > 0, got {split_s}")
        self.mode = mode
        self.split_s = split_s
        self.t0_s: float | None = None  # MCU time of the folder's first telemetry frame

    @property
    def by_goal(self) -> bool:
        """A goal starts a folder (the service's requests are staged before each frame)."""
        return self.mode == "goal"

    def reason(self, t_s: float | None, goal_id: int | None) -> str | None:
        """Before a telemetry frame: why the next folder starts now, else None.

        Parameters
        ----------
        t_s : float or None
            MCU time of the last frame handled [s].
        goal_id : int or None
            A goal request this frame takes.
        """
        if self.mode == "none" or self.t0_s is None or t_s is None:
            return None  # a folder holds at least one telemetry frame
        if goal_id is not None and self.mode == "goal":
            return f"goal {goal_id}"
        if t_s - self.t0_s >= self.split_s:
            return "duration"
        return None

    def frame(self, t_s: float | None) -> None:
        """A telemetry frame at MCU time ``t_s`` [s] went into the folder."""
        if t_s is not None and (self.t0_s is None or t_s < self.t0_s):
            self.t0_s = t_s  # the first (or an MCU reset's clock that started again)

    def started(self) -> None:
        """A new folder started: its time counts from its first frame."""
        self.t0_s = None


def part_folder(first: Path, part: int) -> Path:
    """The run folder of part ``part`` (2, 3, ...) of a daemon whose first one is ``first``:
    ``<first>-002``..., the next free name."""
    while True:
        folder = first.with_name(f"{first.name}-{part:03d}")
        if not folder.exists():
            return folder
        part += 1


def carry_files(old: Path, new: Path) -> None:
    """Give run folder ``new`` the caller's files of run folder ``old`` (config.yaml, the map:
    all but :data:`~jackson.host.recording.RECORDED` and the snapshot).

    Each is a hard link where the file system allows one (the files are written once and never
    changed, so each folder stays whole on its own and a service's map is stored once however
    many goals it serves: about 14 MB per robot-hour of a 180 kB map split per goal), else a
    copy.
    """
    for e in os.scandir(old):
        name = e.name
        if name in RECORDED or name == SNAPSHOT_NAME or name.startswith("."):
            continue
        if e.is_file(follow_symlinks=False) and not (new / name).exists():
            try:
                os.link(e.path, new / name)
            except OSError:  # another file system, or one without hard links
                shutil.copyfile(e.path, new / name)


class FolderWorker:
    """Runs the slow part of each split (the snapshot's compression and write, closing the
    previous folder's bag and files, the budget) on one thread, in order, off the frame loop.

    Parameters
    ----------
    say : callable
        Tells the operator of a job that failed (one line; called on the worker's thread).
    """

    def __init__(self, say: Callable[[str], None]) -> None:
        self.say = say
        self._jobs: queue.SimpleQueue[tuple[str, Callable[[], None]] | None] = queue.SimpleQueue()
        self._thread: threading.Thread | None = None

    def submit(self, what: str, job: Callable[[], None]) -> None:
        """Run ``job`` after the jobs before it; ``what`` names it if it fails."""
        if self._thread is None:
            self._thread = threading.Thread(
                target=guard(self._run, "run-folders"), name="run-folders", daemon=True
            )
            self._thread.start()
        self._jobs.put((what, job))

    def join(self) -> None:
        """Wait for every job submitted (the daemon's end)."""
        if self._thread is not None:
            self._jobs.put(None)
            self._thread.join()
            self._thread = None

    def _run(self) -> None:
        while (item := self._jobs.get()) is not None:
            what, job = item
            try:
                job()
            except Exception as exc:  # a full disk must not stop the robot
                self.say(f"recording: {what} failed: {exc}")
