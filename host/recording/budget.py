"""The recording folder's disk budget (``recording.budget_mb``): the oldest complete run folders
are deleted until the folder's total is under it.

A run folder is a folder of the recording folder holding ``meta.json`` and ``log.jrec``; it is
complete once no recorder holds it (:func:`~jackson.host.recording.run_in_progress`), so the
folder a daemon is writing, this one's or another process's, is never deleted; nor is anything
that is not a run folder (it counts towards the total all the same). The oldest is the one whose
log was written last the longest ago. Nothing is remembered between two calls: each one looks at
the folder as it is.
"""

from __future__ import annotations

import os
import shutil
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from jackson.host.recording import run_in_progress

REFRESH_S = 60.0  # [s] of wall time a cached size of the recording folder is trusted


@dataclass(frozen=True)
class Deleted:
    """A run folder deleted to stay under the budget.

    Attributes
    ----------
    folder : Path
        The run folder.
    size_bytes : int
        What it held [B].
    """

    folder: Path
    size_bytes: int


def _file_bytes(entry: os.DirEntry[str]) -> int:
    """A file's share of its bytes: a file with n hard links (the map and config.yaml that a
    service's run folders share, :func:`~jackson.host.recording.split.carry_files`) counts
    1/n at each, so a total over folders counts it once."""
    st = entry.stat(follow_symlinks=False)
    return st.st_size // max(st.st_nlink, 1)


def folder_bytes(folder: Path) -> int:
    """Bytes of the files under ``folder`` (0 when it is not there); symlinks not followed, a
    hard-linked file counted by its share (:func:`_file_bytes`)."""
    total = 0
    stack = [folder]
    while stack:
        try:
            entries = list(os.scandir(stack.pop()))
        except OSError:
            continue
        for e in entries:
            try:
                if e.is_dir(follow_symlinks=False):
                    stack.append(Path(e.path))
                elif e.is_file(follow_symlinks=False):
                    total += _file_bytes(e)
            except OSError:
                continue
    return total


def _entry_bytes(entry: os.DirEntry[str]) -> int:
    try:
        if entry.is_dir(follow_symlinks=False):
            return folder_bytes(Path(entry.path))
        if entry.is_file(follow_symlinks=False):
            return _file_bytes(entry)
    except OSError:
        pass
    return 0


def _last_written(folder: Path) -> float | None:
    """When the run folder's log was last written (None: not a run folder)."""
    try:
        if not (folder / "meta.json").is_file():
            return None
        return (folder / "log.jrec").stat().st_mtime
    except OSError:
        return None


def prune(
    root: Path,
    budget_bytes: int,
    keep: Path | None = None,
    on_delete: Callable[[Deleted], None] | None = None,
) -> int:
    """Delete the oldest complete run folders of ``root`` until its total is at most
    ``budget_bytes``; never ``keep``, never a folder in progress, never anything that is not a
    run folder (module docstring).

    Parameters
    ----------
    root : Path
        The recording folder.
    budget_bytes : int
        Its budget [B].
    keep : Path or None
        The run folder being written (never deleted, even once closed).
    on_delete : callable or None
        Told of each deletion as it happens.

    Returns
    -------
    int
        The recording folder's total after the deletions [B] (still above the budget when
        nothing more could go).
    """
    sizes: list[tuple[float, str, int]] = []  # (last written, name, bytes) of run folders
    total = 0
    try:
        entries = list(os.scandir(root))
    except OSError:
        return 0
    keep_name = keep.name if keep is not None and keep.parent.resolve() == root.resolve() else None
    for e in entries:
        n = _entry_bytes(e)
        total += n
        if e.name == keep_name or e.is_symlink() or not e.is_dir():
            continue
        written = _last_written(Path(e.path))
        if written is not None:
            sizes.append((written, e.name, n))
    if total <= budget_bytes:
        return total
    sizes.sort()
    for _, name, n in sizes:
        if total <= budget_bytes:
            break
        folder = root / name
        if run_in_progress(folder):
            continue  # another daemon is writing it
        shutil.rmtree(folder, ignore_errors=True)
        gone = n - folder_bytes(folder)  # what a failed deletion left stays counted
        total -= gone
        if on_delete is not None and gone > 0:
            on_delete(Deleted(folder, gone))
    return total


class DiskUse:
    """The recording folder's size without walking it at every call: the other folders'
    total is cached (refreshed after each :func:`prune` and once :data:`REFRESH_S` old), the
    run folder being written is measured at each call (a dozen files).

    Parameters
    ----------
    root : Path
        The recording folder.
    """

    def __init__(self, root: Path, refresh_s: float = REFRESH_S) -> None:
        self.root = root
        self.refresh_s = refresh_s
        self._others: tuple[float, int] | None = None  # (monotonic time [s], bytes)

    def others(self, total: int, current: Path | None) -> None:
        """The recording folder holds ``total`` bytes now, with ``current`` (the folder being
        written), as :func:`prune` returns."""
        own = folder_bytes(current) if current is not None else 0
        self._others = (time.monotonic(), max(0, total - own))

    def used_bytes(self, current: Path | None) -> int:
        """The recording folder's total [B], ``current`` being the folder written now."""
        cached = self._others
        own = folder_bytes(current) if current is not None else 0
        if cached is None or time.monotonic() - cached[0] > self.refresh_s:
            total = folder_bytes(self.root)
            if current is not None and current.parent.resolve() != self.root.resolve():
                total += own  # a run folder outside the recording folder
            self._others = (time.monotonic(), max(0, total - own))
            return total
        return cached[1] + own
