"""No thread dies alone: a physics step or a LiDAR feed that raises in the twin's thread ends
``jackson run`` promptly with one line and exit status 1 (the daemon braked on its abort path),
instead of a host waiting for ever on a twin that stopped; and the helper that carries a
thread's exception to the loop that owns the run (jackson.common.threads)."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from jackson.common.errors import JacksonError
from jackson.common.threads import ThreadFailedError, Watch, guard, record, start
from jackson.main import main

PROMPT_S = 60.0  # a far backstop: a failed thread ends the run in seconds, a hang never


def _raise_on_call(n: int, exc: Exception) -> Callable[..., object]:
    """A replacement that raises ``exc`` at its ``n``-th call and calls the original before."""
    calls = [0]

    def wrap(original: Callable[..., object]) -> Callable[..., object]:
        def method(*args: object, **kwargs: object) -> object:
            calls[0] += 1
            if calls[0] == n:
                raise exc
            return original(*args, **kwargs)

        return method

    return wrap


# ------------------------------------------------------------------------- the helper


def test_a_guarded_thread_s_exception_reaches_the_open_watch() -> None:
    def boom() -> None:
        raise ZeroDivisionError("float division by zero")

    with Watch() as watch:
        start(boom, "physics").join(timeout=10)
        assert watch.wait(10.0)
        first = watch.first
    assert first is not None and first.name == "physics"
    assert "\n" not in first.line
    assert "physics thread raised ZeroDivisionError: float division by zero in boom" in first.line
    with pytest.raises(ThreadFailedError, match="ZeroDivisionError"):
        watch.check()


def test_a_watch_opened_later_sees_what_the_outer_one_saw() -> None:
    with Watch() as outer:
        thread = threading.Thread(target=guard(lambda x: 1 / x, "lidar"), args=(0,))
        thread.start()
        thread.join(timeout=10)
        with Watch() as inner:
            assert inner.first is outer.first is not None


def test_a_user_error_from_a_thread_keeps_its_line() -> None:
    class BadFileError(JacksonError):
        pass

    with Watch() as watch:
        record("twin", BadFileError("world w: triggers[0].add_cylinder: drops onto the robot"))
    assert watch.first is not None
    assert watch.first.line == "world w: triggers[0].add_cylinder: drops onto the robot"
    with pytest.raises(BadFileError):
        watch.check()


def test_a_failure_with_no_watch_open_is_one_line_on_stderr(
    capsys: pytest.CaptureFixture[str],
) -> None:
    start(lambda: 1 / 0, "i2c-server").join(timeout=10)
    err = capsys.readouterr().err.strip()
    assert err.startswith("internal failure: the i2c-server thread raised ZeroDivisionError")
    assert "\n" not in err


def test_a_clean_thread_leaves_the_watch_empty() -> None:
    with Watch() as watch:
        start(lambda: None, "ok").join(timeout=10)
    assert watch.first is None
    watch.check()


# ------------------------------------------------------------------------- jackson run


def _run_ends_in_one_line(argv: list[str], capsys: pytest.CaptureFixture[str], says: str) -> None:
    t0 = time.monotonic()
    rc = main(argv)
    wall = time.monotonic() - t0
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.strip()]
    assert rc == 1, err
    assert wall < PROMPT_S
    assert len(lines) == 1, lines
    assert lines[0].startswith(f"jackson run: internal failure: the twin thread raised {says}")


def test_a_physics_step_that_raises_ends_the_square_with_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    from jackson.host.actuation.output import Pca9685Output
    from jackson.sim.twin import Twin

    raising = _raise_on_call(200, ZeroDivisionError("float division by zero"))
    monkeypatch.setattr(Twin, "advance", raising(Twin.advance))
    brakes: list[int] = []
    brake = Pca9685Output.brake

    def counted(self: Pca9685Output) -> None:
        brake(self)
        brakes.append(1)

    monkeypatch.setattr(Pca9685Output, "brake", counted)
    _run_ends_in_one_line(
        ["run", "square", "--out", str(tmp_path / "run")], capsys, "ZeroDivisionError"
    )
    assert brakes  # the daemon's abort path braked through the twin's PCA9685


def _free_map(folder: Path) -> Path:
    """A 10 m x 10 m free floor with a wall round it, centred on the maze."""
    img = np.full((200, 200), 254, np.uint8)
    img[0, :] = img[-1, :] = img[:, 0] = img[:, -1] = 0
    Image.fromarray(img).save(folder / "free.pgm")
    (folder / "free.yaml").write_text(
        "image: free.pgm\nresolution: 0.05\norigin: [-5.0, -5.0, 0.0]\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.196\nnegate: 0\n"
    )
    return folder / "free.yaml"


def test_a_lidar_feed_that_raises_ends_the_maze_with_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    from jackson.sim.lidar_feed import LidarFeed

    raising = _raise_on_call(30, RuntimeError("revolution buffer broke"))
    monkeypatch.setattr(LidarFeed, "advance", raising(LidarFeed.advance))
    argv = ["run", "maze", "--map", str(_free_map(tmp_path)), "--out", str(tmp_path / "run")]
    _run_ends_in_one_line(argv, capsys, "RuntimeError: revolution buffer broke")


def test_a_physics_step_that_raises_ends_jackson_sim_with_one_line(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    from jackson.sim.runner import TwinRunner
    from jackson.sim.twin import Twin

    raising = _raise_on_call(20, ZeroDivisionError("float division by zero"))
    monkeypatch.setattr(Twin, "advance", raising(Twin.advance))
    monkeypatch.setattr(TwinRunner, "_await_hello", lambda self, stop: True)  # a host said it
    t0 = time.monotonic()
    rc = main(["sim", "--realtime", "--duration", "30"])
    assert time.monotonic() - t0 < PROMPT_S
    err = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert rc == 1
    assert len(err) == 1, err
    assert err[0].startswith(
        "jackson sim: internal failure: the twin thread raised ZeroDivisionError: float "
        "division by zero in method (test_thread_failures.py:"
    )
    assert err[0].endswith("; the run was stopped")
