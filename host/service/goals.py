"""Goals of the navigation service: what was asked, where each one is, how each one ended.

A goal is asked for from any thread (the control socket, ROS's ``/goal_pose`` and
``navigate_to_pose``); :class:`GoalBook` gives it an id at once and keeps its record. The
service's frame loop moves it from ``pending`` to ``active`` and to one end, as Nav2's action
goals (action_msgs/GoalStatus) do:

=============  ====================================================================
``pending``    accepted, not yet taken by the frame loop
``active``     being navigated
``succeeded``  reached (the goal checker's tolerance, on the robot's estimate)
``aborted``    ended by the service: unreachable, timed out, localisation lost, sensors
               lost, teleop took over, the LiDAR lost
``canceled``   cancelled by a client, or preempted by a newer goal
``rejected``   refused before anything moved: off the map, in an obstacle, cut off
=============  ====================================================================

The book keeps the unfinished goals and the last ``history`` finished ones (a bounded deque):
it never grows with the service's run time. :meth:`GoalBook.wait` blocks a client until its goal
has ended.
"""

from __future__ import annotations

import threading
from collections import OrderedDict, deque
from dataclasses import dataclass, replace
from enum import Enum

from jackson.host.nav.types import Pose2D


class GoalStatus(str, Enum):
    """Where a goal is (module docstring)."""

    PENDING = "pending"
    ACTIVE = "active"
    SUCCEEDED = "succeeded"
    ABORTED = "aborted"
    CANCELED = "canceled"
    REJECTED = "rejected"

    @property
    def ended(self) -> bool:
        """The goal has reached one of its ends."""
        return self not in (GoalStatus.PENDING, GoalStatus.ACTIVE)


@dataclass(frozen=True)
class GoalRecord:
    """One goal as the book knows it.

    Attributes
    ----------
    goal_id : int
        Given by the book, counting from 1 in each daemon process.
    pose : Pose2D
        The goal in the map frame.
    source : str
        Who asked: ``socket``, ``goal_pose``, ``navigate_to_pose``.
    status : GoalStatus
        Where it is.
    reason : str
        How it ended (``goal reached``, the navigator's failure, ``canceled``...), else "".
    t_start_s, t_end_s : float or None
        MCU time it became active and ended [s].
    recoveries : int
        Recovery behaviours run for it.
    distance_remaining_m : float
        The global plan's length from the robot to the goal at the last frame [m] (nan before
        a plan).
    pose_end : Pose2D or None
        The robot's pose (map frame, its own estimate) when the goal ended.
    """

    goal_id: int
    pose: Pose2D
    source: str
    status: GoalStatus = GoalStatus.PENDING
    reason: str = ""
    t_start_s: float | None = None
    t_end_s: float | None = None
    recoveries: int = 0
    distance_remaining_m: float = float("nan")
    pose_end: Pose2D | None = None

    @property
    def navigation_time_s(self) -> float:
        """MCU time from active to end (or to now, for the active goal's last update) [s]."""
        if self.t_start_s is None or self.t_end_s is None:
            return 0.0
        return self.t_end_s - self.t_start_s

    def as_dict(self) -> dict[str, object]:
        """The record for JSON (``jackson status``, the control socket)."""
        return {
            "id": self.goal_id,
            "x": self.pose.x,
            "y": self.pose.y,
            "yaw": self.pose.yaw,
            "source": self.source,
            "status": self.status.value,
            "reason": self.reason,
            "t_start_s": self.t_start_s,
            "t_end_s": self.t_end_s,
            "navigation_time_s": self.navigation_time_s,
            "recoveries": self.recoveries,
            "distance_remaining_m": None
            if self.distance_remaining_m != self.distance_remaining_m
            else self.distance_remaining_m,
            "pose_end": None
            if self.pose_end is None
            else [self.pose_end.x, self.pose_end.y, self.pose_end.yaw],
        }


class GoalBook:
    """The goals' records, shared by the frame loop and the clients' threads.

    Parameters
    ----------
    history : int
        Finished goals kept (the oldest are forgotten first).
    """

    def __init__(self, history: int = 32) -> None:
        self._lock = threading.Condition()
        self._next_id = 1  # the next goal's id
        self._open: OrderedDict[int, GoalRecord] = OrderedDict()
        self._ended: deque[GoalRecord] = deque(maxlen=max(1, history))
        self.counts: dict[str, int] = {s.value: 0 for s in GoalStatus if s.ended}

    def __getstate__(self) -> dict[str, object]:
        """Copied under the lock, without it (a core's snapshot, docs/recording.md)."""
        with self._lock:
            state = dict(self.__dict__)
            del state["_lock"]
            state["_open"] = OrderedDict(self._open)
            state["_ended"] = deque(self._ended, maxlen=self._ended.maxlen)
            state["counts"] = dict(self.counts)
            return state

    def __setstate__(self, state: dict[str, object]) -> None:
        self.__dict__.update(state)
        self._lock = threading.Condition()

    def new(self, pose: Pose2D, source: str) -> GoalRecord:
        """A new pending goal with its id."""
        with self._lock:
            rec = GoalRecord(self._take_id(), pose, source)
            self._open[rec.goal_id] = rec
            self._lock.notify_all()
            return rec

    def reject(self, pose: Pose2D, source: str, reason: str) -> GoalRecord:
        """A goal refused at once (it never reaches the frame loop)."""
        with self._lock:
            rec = GoalRecord(self._take_id(), pose, source, GoalStatus.REJECTED, reason)
            self._finish(rec)
            return rec

    def _take_id(self) -> int:
        goal_id, self._next_id = self._next_id, self._next_id + 1
        return goal_id

    def update(self, rec: GoalRecord) -> None:
        """The frame loop's new record of a goal (an end is moved to the history)."""
        with self._lock:
            if rec.status.ended:
                self._open.pop(rec.goal_id, None)
                self._finish(rec)
            else:
                self._open[rec.goal_id] = rec
            self._lock.notify_all()

    def _finish(self, rec: GoalRecord) -> None:
        self._ended.append(rec)
        self.counts[rec.status.value] += 1
        self._lock.notify_all()

    def get(self, goal_id: int) -> GoalRecord | None:
        """The goal's newest record (None: unknown, or forgotten from the history)."""
        with self._lock:
            return self._get_unlocked(goal_id)

    def wait(self, goal_id: int, timeout_s: float | None = None) -> GoalRecord | None:
        """Block until the goal has ended (or ``timeout_s`` of wall time); its newest record."""
        with self._lock:
            self._lock.wait_for(
                lambda: (r := self._get_unlocked(goal_id)) is None or r.status.ended, timeout_s
            )
            return self._get_unlocked(goal_id)

    def _get_unlocked(self, goal_id: int) -> GoalRecord | None:
        rec = self._open.get(goal_id)
        if rec is not None:
            return rec
        for old in reversed(self._ended):
            if old.goal_id == goal_id:
                return old
        return None

    def open_goals(self) -> list[GoalRecord]:
        """Pending and active goals, oldest first."""
        with self._lock:
            return list(self._open.values())

    def history(self) -> list[GoalRecord]:
        """Finished goals, oldest first."""
        with self._lock:
            return list(self._ended)

    def end_all(self, reason: str, status: GoalStatus = GoalStatus.ABORTED) -> None:
        """End every open goal (the daemon stops)."""
        with self._lock:
            for rec in list(self._open.values()):
                self._open.pop(rec.goal_id)
                self._finish(replace(rec, status=status, reason=reason))
