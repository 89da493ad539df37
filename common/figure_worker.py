"""A figure drawn by a second process that imports the plotting code while the run runs.

``jackson run`` draws one figure after its run, and importing matplotlib and the report's
plotting module took about half a second of its command beyond the run (issue figure
``sil.square_command_overhead_s``). The run is the twin's thread and the host's under one
interpreter lock, one core; a :class:`FigureWorker` started with the command imports the
plotting code in a second interpreter meanwhile, on the other core, then waits. Handed the
figure's arguments (:meth:`FigureWorker.draw`, pickled over its stdin), it draws and writes
the figure and exits; only the drawing is left after the run.

The worker draws with the same function and the same arguments as this process would, so the
files are the same. A worker that cannot start, dies or fails leaves the figure to this
process, drawn here as before; a command that ends without a figure closes the worker's stdin,
and the worker exits at the end of its input without drawing (so it also ends when the command
is killed).
"""

from __future__ import annotations

import importlib
import pickle
import subprocess
import sys
from collections.abc import Callable
from types import TracebackType
from typing import Any

TIMEOUT_S = 30.0
"""Longest wait for the worker's figure [s] (it takes about half a second; a stopped or stuck
worker must not hold the command): then it is killed and the figure drawn here."""

BOOT = """\
import importlib, os, pickle, sys
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot
function = getattr(importlib.import_module(sys.argv[1]), sys.argv[2])
data = sys.stdin.buffer.read()
if data:
    args, kwargs = pickle.loads(data)
    function(*args, **kwargs)
    os._exit(0)
"""
"""The worker: import matplotlib (files only: Agg) and the function's module, then draw once
with what arrives on stdin (the parent's pickle, trusted), nothing when stdin ends empty. Once
the figure is written (matplotlib closes its files) it ends at once, without the interpreter's
teardown of its modules, which the command would wait for."""


class FigureWorker:
    """A process ready to draw one figure with ``module.function`` (module docstring).

    Parameters
    ----------
    module : str
        The plotting function's module, e.g. ``jackson.experiments.report_plots``.
    function : str
        Its name in the module.
    timeout_s : float
        Longest wait for the worker's figure [s].

    Attributes
    ----------
    drawn_by_worker : bool or None
        After :meth:`draw`: whether the worker drew the figure (None before).
    """

    def __init__(self, module: str, function: str, timeout_s: float = TIMEOUT_S) -> None:
        self.module = module
        self.function = function
        self.timeout_s = timeout_s
        self.drawn_by_worker: bool | None = None
        self._proc: subprocess.Popen[bytes] | None
        try:
            self._proc = subprocess.Popen(
                [sys.executable, "-c", BOOT, module, function],
                stdin=subprocess.PIPE,
                stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL,
            )
        except OSError:
            self._proc = None

    def __enter__(self) -> FigureWorker:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    def draw(self, *args: Any, **kwargs: Any) -> None:
        """Draw the figure: ``module.function(*args, **kwargs)``, by the worker, or here if it
        cannot (the arguments must pickle).

        Raises
        ------
        Exception
            Whatever the function raises, drawn here.
        """
        proc, self._proc = self._proc, None
        if proc is not None:
            try:
                proc.communicate(pickle.dumps((args, kwargs)), timeout=self.timeout_s)
            except (OSError, subprocess.TimeoutExpired):
                proc.kill()
                proc.wait()
            if proc.returncode == 0:
                self.drawn_by_worker = True
                return
        self.drawn_by_worker = False
        function: Callable[..., Any] = getattr(importlib.import_module(self.module), self.function)
        function(*args, **kwargs)

    def close(self) -> None:
        """End a worker that drew nothing (its stdin closed: it exits without a figure)."""
        proc, self._proc = self._proc, None
        if proc is None:
            return
        try:
            proc.communicate(b"", timeout=self.timeout_s)
        except (OSError, subprocess.TimeoutExpired):
            proc.kill()
            proc.wait()
