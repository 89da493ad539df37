"""The figure worker (common/figure_worker.py): the figure drawn by a second process with the
same function and arguments, or by this one when the worker cannot."""

from __future__ import annotations

import os
import signal
from pathlib import Path

import pytest

from jackson.common.figure_worker import FigureWorker


def test_the_worker_draws_with_the_function_and_the_arguments_given(tmp_path: Path) -> None:
    source = tmp_path / "drawn.bin"
    source.write_bytes(bytes(range(256)) * 40)
    with FigureWorker("shutil", "copyfile") as worker:
        worker.draw(source, tmp_path / "figure.bin")
    assert worker.drawn_by_worker is True
    assert (tmp_path / "figure.bin").read_bytes() == source.read_bytes()


def test_a_dead_worker_leaves_the_figure_to_this_process(tmp_path: Path) -> None:
    source = tmp_path / "drawn.bin"
    source.write_bytes(b"a figure")
    with FigureWorker("shutil", "copyfile") as worker:
        assert worker._proc is not None
        worker._proc.kill()
        worker._proc.wait()
        worker.draw(source, tmp_path / "figure.bin")
    assert worker.drawn_by_worker is False
    assert (tmp_path / "figure.bin").read_bytes() == b"a figure"


def test_a_failing_figure_fails_here_as_it_would_have(tmp_path: Path) -> None:
    with FigureWorker("shutil", "copyfile") as worker, pytest.raises(FileNotFoundError):
        worker.draw(tmp_path / "missing.bin", tmp_path / "figure.bin")
    assert worker.drawn_by_worker is False
    assert not (tmp_path / "figure.bin").exists()


def test_a_worker_given_no_figure_ends_without_one(tmp_path: Path) -> None:
    worker = FigureWorker("shutil", "copyfile")
    proc = worker._proc
    assert proc is not None
    with worker:
        pass  # the command ended early: no figure
    assert proc.returncode == 0
    assert worker.drawn_by_worker is None
    assert list(tmp_path.iterdir()) == []


def test_a_stopped_worker_is_given_up_and_the_figure_drawn_here(tmp_path: Path) -> None:
    source = tmp_path / "drawn.bin"
    source.write_bytes(b"a figure")
    with FigureWorker("shutil", "copyfile", timeout_s=1.0) as worker:
        proc = worker._proc
        assert proc is not None
        os.kill(proc.pid, signal.SIGSTOP)
        worker.draw(source, tmp_path / "figure.bin")
    assert worker.drawn_by_worker is False
    assert (tmp_path / "figure.bin").read_bytes() == b"a figure"
    assert proc.returncode == -signal.SIGKILL  # killed, stopped as it was
