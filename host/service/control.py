"""The control socket: ``jackson goal``, ``cancel``, ``status`` and ``localise`` talk to a
running daemon over a local Unix socket.

The daemon listens on ``service.socket`` (:func:`~jackson.host.service.settings.socket_path`):
a stream socket whose file only the daemon's user and group may open (mode 0660, in a folder of
mode 0770 when the daemon makes it). Each request is one line of JSON; each answer one line of
JSON, ``{"ok": true, ...}`` or ``{"ok": false, "error": "one line"}``:

==============================================  ==============================================
request                                         answer
==============================================  ==============================================
``{"op": "status"}``                            ``{"ok": true, "status": {...}}``
``{"op": "goal", "x", "y", "yaw", "wait"}``     ``{"ok": true, "goal": {...}}``; with ``wait``
                                                also a ``{"feedback": {...}}`` line a second
                                                and the ``{"result": {...}}`` line at its end
``{"op": "cancel", "id"}``                      ``{"ok": true, "goal": {...}}`` (id 0 or
                                                absent: the active goal)
``{"op": "localise", "x", "y", "yaw"}``         ``{"ok": true}``
``{"op": "wait", "id"}``                        ``{"ok": true, "goal": {...}}``, then feedback
                                                and result lines as ``goal`` with ``wait``
``{"op": "drive", "v", "w"}``                   ``{"ok": true}``: one velocity command, as a
                                                ``/cmd_vel`` message (braked 0.6 s after the
                                                last)
==============================================  ==============================================

A goal's record (``goal``, ``result``) is :meth:`GoalRecord.as_dict`. The server never lets a
client's mistake reach the frame loop: bad JSON or fields get an error line, and a client that
goes away mid-wait is dropped.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import socket
import stat
import threading
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from jackson.common.errors import JacksonError
from jackson.common.threads import guard
from jackson.host.control.navigator import RouteError
from jackson.host.nav.types import Pose2D
from jackson.host.service.goals import GoalStatus
from jackson.host.service.navigation import NavigationService

MAX_LINE = 4096  # [bytes] the longest request line
MAX_CLIENTS = 16  # connections served at once
FEEDBACK_PERIOD_S = 1.0  # [s] of wall time between a waiting client's feedback lines
ACCEPT_TIMEOUT_S = 0.2  # [s] bounds how long stop() takes


class ControlError(JacksonError, RuntimeError):
    """The control socket cannot be used: another daemon holds it, or no daemon answers."""


def _number(req: dict[str, Any], key: str, default: float | None = None) -> float:
    v = req.get(key, default)
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise ValueError(f"{key}: expected a finite number, got {v!r}")
    return float(v)


class ControlServer:
    """Serves the control socket from background threads.

    Parameters
    ----------
    path : Path
        The socket's path.
    service : NavigationService
        Takes goals, cancels and poses.
    status : callable
        The daemon's status for ``status`` (a JSON-able dict).
    drive : callable
        Submits one velocity command (v [m/s], w [rad/s]), as ``/cmd_vel`` does.

    Raises
    ------
    ControlError
        Another daemon answers on ``path``, or the path cannot be made.
    """

    def __init__(
        self,
        path: Path,
        service: NavigationService,
        status: Callable[[], dict[str, Any]],
        drive: Callable[[float, float], None],
    ) -> None:
        self.path = path
        self.service = service
        self.status = status
        self.drive = drive
        self.requests = 0
        self.errors = 0
        self._stop = threading.Event()
        self._clients = threading.BoundedSemaphore(MAX_CLIENTS)
        self._sock = self._listen(path)
        self._thread = threading.Thread(
            target=guard(self._accept, "control-socket"), name="control-socket", daemon=True
        )

    @staticmethod
    def _listen(path: Path) -> socket.socket:
        if path.exists() or path.is_symlink():
            if not stat.S_ISSOCK(path.lstat().st_mode):
                raise ControlError(f"control socket {path}: is there and is not a socket")
            try:
                with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as probe:
                    probe.settimeout(1.0)
                    probe.connect(str(path))
            except OSError:
                path.unlink()  # a socket a killed daemon left behind
            else:
                raise ControlError(
                    f"control socket {path}: another jackson daemon is listening there; stop it "
                    "or give this one another (--socket or service.socket)"
                )
        try:
            if not path.parent.is_dir():
                path.parent.mkdir(parents=True, mode=0o770)
            sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
            old = os.umask(0o117)  # the socket file: rw for user and group only
            try:
                sock.bind(str(path))
            finally:
                os.umask(old)
            os.chmod(path, 0o660)
            sock.listen(MAX_CLIENTS)
            sock.settimeout(ACCEPT_TIMEOUT_S)
        except OSError as exc:
            raise ControlError(f"control socket {path}: {exc.strerror or exc}") from exc
        return sock

    def start(self) -> None:
        """Serve in the background."""
        self._thread.start()

    def stop(self) -> None:
        """Stop serving and remove the socket file; safe to call twice."""
        if self._stop.is_set():
            return
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout=2.0)
        self._sock.close()
        with contextlib.suppress(OSError):
            self.path.unlink()

    def _accept(self) -> None:
        while not self._stop.is_set():
            try:
                conn, _ = self._sock.accept()
            except TimeoutError:
                continue
            except OSError:
                return
            if not self._clients.acquire(blocking=False):
                with contextlib.suppress(OSError):
                    conn.sendall(b'{"ok": false, "error": "too many clients"}\n')
                conn.close()
                continue
            threading.Thread(
                target=guard(self._serve, "control-client"),
                args=(conn,),
                name="control-client",
                daemon=True,
            ).start()

    def _serve(self, conn: socket.socket) -> None:
        try:
            conn.settimeout(5.0)
            f = conn.makefile("rwb")
            line = f.readline(MAX_LINE + 1)
            if not line:
                return
            self.requests += 1
            for answer in self._answer(line):
                f.write(json.dumps(answer).encode() + b"\n")
                f.flush()
        except OSError:
            pass  # the client went away
        finally:
            conn.close()
            self._clients.release()

    def _answer(self, line: bytes) -> Iterator[dict[str, Any]]:
        try:
            if len(line) > MAX_LINE:
                raise ValueError(f"a request line longer than {MAX_LINE} bytes")
            req = json.loads(line.decode())
            if not isinstance(req, dict):
                raise ValueError("a request is a JSON object")
            op = req.get("op")
            if op == "status":
                yield {"ok": True, "status": self.status()}
            elif op == "goal":
                yield from self._goal(req)
            elif op == "wait":
                goal_id = req.get("id")
                if isinstance(goal_id, bool) or not isinstance(goal_id, int) or goal_id < 1:
                    raise ValueError(f"id: expected a goal id (an integer >= 1), got {goal_id!r}")
                rec = self.service.book.get(goal_id)
                if rec is None:
                    yield {"ok": False, "error": f"no goal {goal_id} (unknown or forgotten)"}
                else:
                    yield {"ok": True, "goal": rec.as_dict()}
                    yield from self._follow(goal_id)
            elif op == "cancel":
                goal_id = req.get("id", 0) or 0
                if isinstance(goal_id, bool) or not isinstance(goal_id, int) or goal_id < 0:
                    raise ValueError(f"id: expected a goal id (an integer >= 0), got {goal_id!r}")
                rec = self.service.cancel(goal_id)
                if rec is None:
                    what = "no goal is active or pending" if goal_id == 0 else f"no goal {goal_id}"
                    yield {"ok": False, "error": f"nothing to cancel: {what}"}
                else:
                    yield {"ok": True, "goal": rec.as_dict()}
            elif op == "localise":
                pose = Pose2D(_number(req, "x"), _number(req, "y"), _number(req, "yaw", 0.0))
                self.service.set_pose(pose)
                yield {"ok": True}
            elif op == "drive":
                self.drive(_number(req, "v"), _number(req, "w"))
                yield {"ok": True}
            else:
                raise ValueError(
                    f"op: expected status, goal, wait, cancel, localise or drive, got {op!r}"
                )
        except (ValueError, UnicodeDecodeError, RouteError) as exc:
            self.errors += 1
            yield {"ok": False, "error": str(exc)}

    def _goal(self, req: dict[str, Any]) -> Iterator[dict[str, Any]]:
        pose = Pose2D(_number(req, "x"), _number(req, "y"), _number(req, "yaw", 0.0))
        rec = self.service.submit_goal(pose, "socket")
        if rec.status == GoalStatus.REJECTED:
            yield {"ok": False, "error": f"goal refused: {rec.reason}", "goal": rec.as_dict()}
            return
        yield {"ok": True, "goal": rec.as_dict()}
        if req.get("wait"):
            yield from self._follow(rec.goal_id)

    def _follow(self, goal_id: int) -> Iterator[dict[str, Any]]:
        """Feedback lines until the goal ends, then its result line."""
        book = self.service.book
        while not self._stop.is_set():
            now = book.wait(goal_id, FEEDBACK_PERIOD_S)
            if now is None:
                yield {"result": {"id": goal_id, "status": "unknown", "reason": "forgotten"}}
                return
            if now.status.ended:
                yield {"result": now.as_dict()}
                return
            st = self.service.status
            yield {
                "feedback": {
                    **now.as_dict(),
                    "eta_s": None if math.isnan(st.eta_s) else st.eta_s,
                    "pose": [st.pose.x, st.pose.y, st.pose.yaw],
                }
            }
        yield {"result": {"id": goal_id, "status": "aborted", "reason": "the daemon stopped"}}


def ask(
    path: Path, request: dict[str, Any], timeout_s: float | None = 10.0
) -> Iterator[dict[str, Any]]:
    """Send one request to the daemon on ``path``; its answer lines as they come.

    Raises
    ------
    ControlError
        No daemon listens there, it may not be opened, or it went away mid-answer.
    """
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    sock.settimeout(timeout_s)
    try:
        try:
            sock.connect(str(path))
        except FileNotFoundError as exc:
            raise ControlError(
                f"no jackson daemon is running here: {path} does not exist (start one: jackson "
                "daemon with service.lidar and service.map, or give --socket)"
            ) from exc
        except ConnectionRefusedError as exc:
            raise ControlError(
                f"no jackson daemon answers on {path} (it stopped; start it again)"
            ) from exc
        except PermissionError as exc:
            raise ControlError(
                f"{path}: permission denied: the daemon's socket is for its user and group "
                "(add yourself to its group, or run as its user)"
            ) from exc
        except OSError as exc:
            raise ControlError(f"{path}: {exc.strerror or exc}") from exc
        f = sock.makefile("rwb")
        f.write(json.dumps(request).encode() + b"\n")
        f.flush()
        while True:
            try:
                line = f.readline()
            except TimeoutError as exc:
                raise ControlError(f"the daemon on {path} did not answer in {timeout_s} s") from exc
            if not line:
                return
            try:
                yield json.loads(line.decode())
            except (UnicodeDecodeError, json.JSONDecodeError) as exc:
                raise ControlError(f"the daemon on {path} answered garbage: {line[:60]!r}") from exc
    finally:
        sock.close()
