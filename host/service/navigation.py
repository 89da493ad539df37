"""The navigation service: a daemon's mission that lasts as long as the daemon and takes goal
after goal.

:class:`NavigationService` is the :class:`~jackson.host.control.base.ServiceMission` the daemon
runs when its configuration names a LiDAR and a map. It keeps one localiser and one navigator
(:class:`~jackson.host.control.navigate.NavigateMission`) for the whole process and moves
between three states, as a Nav2 bringup's BT navigator and twist_mux do together:

``idle``
    No goal: the robot is held braked; the localiser follows the odometry and the scans.
``navigating``
    A goal is active: the navigator's command drives the robot.
``teleop``
    Velocity commands (``/cmd_vel``, a joystick) are arriving: they drive the robot, and the
    goal that was active ended (``aborted``: teleop took over). Navigation does not resume
    by itself: once the commands stop, the service is idle.

Requests come from other threads (the control socket, the ROS node) through
:meth:`~NavigationService.submit_goal`, :meth:`~NavigationService.cancel` and
:meth:`~NavigationService.set_pose`. A goal is checked against the map at once on the caller's
thread (off the map, in an obstacle, cut off from the robot: ``rejected`` with the reason, and
nothing reaches the frame loop). The others wait in an inbox that the frame loop empties at the
next telemetry frame (:meth:`~NavigationService.take_requests`); the core logs what it took
before the frame in the run's log, so ``jackson replay`` applies the same requests at the same
frames. A new goal preempts the active one (``canceled``: preempted by goal N); a cancel
brakes and returns to idle; an unreachable goal, a timeout (``goal_timeout_s`` of MCU time), a
lost localisation (the particle filter's position spread above ``lost_std_m`` for
``lost_confirm_s``), lost sensors or a lost LiDAR end the goal with the reason and return to
idle: never the process. While the sensors are lost the service refuses new goals with the
reason.
"""

from __future__ import annotations

import json
import math
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from enum import Enum

import numpy as np
import numpy.typing as npt

from jackson.host.actuation.limiter import LimiterConfig
from jackson.host.control.base import NavState
from jackson.host.control.navigate import NavigateConfig, NavigateMission
from jackson.host.control.route import RouteChecker, RouteError
from jackson.host.nav.grid import OccupancyGrid
from jackson.host.nav.planner_server import Planner
from jackson.host.nav.types import Pose2D, Scan
from jackson.host.service.goals import GoalBook, GoalRecord, GoalStatus
from jackson.host.service.settings import ServiceSettings

MIN_ETA_SPEED_M_S = 0.05  # [m/s] the slowest average speed an estimate of time remaining uses


class ServiceState(str, Enum):
    """Where the service is (module docstring)."""

    IDLE = "idle"
    NAVIGATING = "navigating"
    TELEOP = "teleop"


@dataclass(frozen=True)
class Request:
    """A client's request, as the frame loop takes it (and the run's log keeps it).

    Attributes
    ----------
    kind : str
        ``goal``, ``cancel`` (``goal_id`` 0: whatever is active) or ``pose`` (the robot is
        at ``x, y, yaw`` now).
    goal_id : int
        The goal's id (``goal``, ``cancel``).
    x, y, yaw : float
        The pose [m, m, rad], map frame (``goal``, ``pose``).
    source : str
        Who asked.
    """

    kind: str
    goal_id: int = 0
    x: float = 0.0
    y: float = 0.0
    yaw: float = 0.0
    source: str = ""

    def encode(self) -> bytes:
        """The request as the run's log keeps it (UTF-8 JSON)."""
        return json.dumps(
            {
                "kind": self.kind,
                "id": self.goal_id,
                "x": self.x,
                "y": self.y,
                "yaw": self.yaw,
                "source": self.source,
            },
            separators=(",", ":"),
        ).encode()

    @classmethod
    def decode(cls, data: bytes) -> Request:
        """A request from the run's log.

        Raises
        ------
        ValueError
            Not a request record.
        """
        try:
            d = json.loads(data.decode())
            return cls(
                str(d["kind"]),
                int(d["id"]),
                float(d["x"]),
                float(d["y"]),
                float(d["yaw"]),
                str(d["source"]),
            )
        except (UnicodeDecodeError, json.JSONDecodeError, KeyError, TypeError) as exc:
            raise ValueError(f"not a service request: {data[:60]!r}") from exc

    @property
    def pose(self) -> Pose2D:
        return Pose2D(self.x, self.y, self.yaw)


@dataclass(frozen=True)
class ServiceStatus:
    """The service at one frame, for other threads (the socket, ROS, the live view).

    Attributes
    ----------
    t_s : float
        MCU time of the frame [s].
    state : ServiceState
        Idle, navigating or teleop.
    unavailable : str or None
        Why goals are refused now (sensors or LiDAR lost), else None.
    pose : Pose2D
        The robot in the map frame (its own estimate).
    covariance : tuple of 9 float
        The localiser's x, y, yaw covariance, row-major [m², m·rad, rad²].
    goal : GoalRecord or None
        The active goal.
    eta_s : float
        Estimated time remaining of the active goal [s] (nan without one).
    """

    t_s: float = 0.0
    state: ServiceState = ServiceState.IDLE
    unavailable: str | None = None
    pose: Pose2D = field(default_factory=Pose2D)
    covariance: tuple[float, ...] = (0.0,) * 9
    goal: GoalRecord | None = None
    eta_s: float = math.nan


def path_remaining_m(path: npt.NDArray[np.float64], pose: Pose2D) -> float:
    """Length of the global plan from the point nearest the robot to its end, plus the robot's
    distance to that point [m] (nan without a plan): Nav2's ``distance_remaining``."""
    if len(path) == 0:
        return math.nan
    d = np.hypot(path[:, 0] - pose.x, path[:, 1] - pose.y)
    k = int(np.argmin(d))
    rest = path[k:]
    return float(d[k] + np.hypot(*np.diff(rest, axis=0).T).sum()) if len(rest) > 1 else float(d[k])


class NavigationService:
    """The daemon's mission in service mode (module docstring).

    Parameters
    ----------
    config : NavigateConfig
        Start pose (its ``goals`` empty), localiser and navigator settings.
    limits : LimiterConfig
        The navigation limits.
    static_map : OccupancyGrid
        The map it localises and plans on.
    settings : ServiceSettings
        Timeouts, the lost-localisation test, the history kept.
    planner : Planner or None
        Where its global plans are searched (:class:`NavigateMission`).
    """

    name = "service"

    def __init__(
        self,
        config: NavigateConfig,
        limits: LimiterConfig,
        static_map: OccupancyGrid,
        settings: ServiceSettings,
        planner: Planner | None = None,
    ) -> None:
        self.settings = settings
        self.nav = NavigateMission(
            replace(config, goals=()), limits, static_map, keep_samples=False, planner=planner
        )
        self.routes = RouteChecker(
            static_map, self.nav.navigator.config, self.nav.navigator.static_costmap
        )
        self.book = GoalBook(settings.history)
        self.done = False  # a service is never done: the daemon runs until it is stopped
        self.state = ServiceState.IDLE
        self.active: GoalRecord | None = None
        self.unavailable: str | None = None
        self.tell: Callable[[str], None] | None = None  # the operator's console and the log
        self.status = ServiceStatus(pose=config.start)
        self.requests_taken = 0
        self._inbox: deque[Request] = deque()
        self._staged: list[Request] | None = None  # what the next frame takes (stage())
        self._taken: list[Request] = []
        self._lost_since_s: float | None = None
        self._travelled_m = 0.0
        self._last_pose: Pose2D | None = None
        self._lidar_lost: str | None = None

    # ------------------------------------------------------------------ any thread

    def submit_goal(self, pose: Pose2D, source: str = "socket") -> GoalRecord:
        """Ask for a goal (map frame). Checked against the map now: the record is ``rejected``
        with the reason, or ``pending`` until the next frame takes it."""
        if not all(math.isfinite(v) for v in (pose.x, pose.y, pose.yaw)):
            return self.book.reject(pose, source, "the goal is not a finite pose")
        blocked = self.unavailable
        if blocked is not None:
            return self.book.reject(pose, source, f"the robot cannot navigate now: {blocked}")
        try:
            region = self.routes.region_near(self.status.pose)
            self.routes.check_goal(pose, region)
        except RouteError as exc:
            return self.book.reject(pose, source, str(exc))
        rec = self.book.new(pose, source)
        self._inbox.append(Request("goal", rec.goal_id, pose.x, pose.y, pose.yaw, source))
        return rec

    def cancel(self, goal_id: int = 0, source: str = "socket") -> GoalRecord | None:
        """Cancel goal ``goal_id`` (0: the active or newest pending one); its record, or None
        when there is nothing to cancel."""
        open_goals = self.book.open_goals()
        if goal_id == 0:
            rec = open_goals[-1] if open_goals else None
        else:
            rec = next((g for g in open_goals if g.goal_id == goal_id), None)
        if rec is None:
            return None
        self._inbox.append(Request("cancel", rec.goal_id, source=source))
        return rec

    def set_pose(self, pose: Pose2D, source: str = "socket") -> None:
        """The robot stands at ``pose`` (map frame): the localiser starts again there.

        Raises
        ------
        RouteError
            The pose is off the map, in an obstacle or within the robot's radius of one.
        """
        self.routes.region(pose, "pose")
        self._inbox.append(Request("pose", 0, pose.x, pose.y, pose.yaw, source))

    def put(self, request: Request) -> None:
        """A request as the run's log kept it (``jackson replay``)."""
        if request.kind == "goal" and self.book.get(request.goal_id) is None:
            self.book.update(GoalRecord(request.goal_id, request.pose, request.source))
        self._inbox.append(request)

    def __getstate__(self) -> dict[str, object]:
        """The service's state for a core's snapshot (docs/recording.md): the requests not yet
        taken (the inbox, the staged ones) and the operator's console (``tell``) stay out; the
        next frame takes the requests, and logs them in the next run folder."""
        state = dict(self.__dict__)
        state.update(_inbox=deque(), _staged=None, tell=None)
        return state

    # ------------------------------------------------------------------ the frame loop

    def stage(self) -> int | None:
        """Before a telemetry frame (the daemon): fix the requests that frame takes (those
        arriving from now on wait for the next one); the first goal's id among them, if any
        (the daemon starts the goal's run folder first, docs/recording.md)."""
        staged = self._staged if self._staged is not None else []
        while self._inbox:
            staged.append(self._inbox.popleft())
        self._staged = staged
        return next((r.goal_id for r in staged if r.kind == "goal"), None)

    def take_requests(self) -> list[Request]:
        """At a telemetry frame, before it is handled: the requests it applies (the core logs
        them first): the staged ones (:meth:`stage`), else every one waiting."""
        taken = self._taken
        if self._staged is not None:
            taken.extend(self._staged)
            self._staged = None
        else:
            while self._inbox:
                taken.append(self._inbox.popleft())
        self.requests_taken += len(taken)
        return list(taken)

    @property
    def navigating(self) -> bool:
        """A goal is active (the LiDAR is needed)."""
        return self.state == ServiceState.NAVIGATING

    @property
    def idle(self) -> bool:
        """No goal and no velocity commands: hold the robot braked."""
        return self.state != ServiceState.NAVIGATING

    def set_limits(self, limits: LimiterConfig) -> None:
        """New speed and acceleration bounds for the navigator, from the next frame on (the
        daemon's live settings)."""
        self.nav.set_limits(limits)

    def on_scan(self, scan: Scan, s: NavState) -> None:
        """A LiDAR revolution: the localiser (and the navigator's costmaps at the next tick)."""
        self.nav.on_scan(scan, s)

    def external(self, t_s: float, live: bool) -> None:
        """Whether velocity commands are in force at this frame: while they are, they drive
        and an active goal ends; once they stop, the service is idle (no goal resumes)."""
        if not live:
            if self.state == ServiceState.TELEOP:
                self.state = ServiceState.IDLE
                self._say("teleop ended: idle, braked")
            return
        if self.active is not None:
            self._end(GoalStatus.ABORTED, "teleop took over: velocity commands arrived", t_s)
        if self.state != ServiceState.TELEOP:
            self.state = ServiceState.TELEOP
            self._say("teleop: velocity commands drive the robot; navigation waits for a goal")

    def sensors(self, t_s: float, lost: str | None) -> None:
        """The health policy's verdict at this frame: lost sensors end the goal and refuse
        new ones until they are back."""
        reason = lost if lost is not None else self._lidar_lost
        if reason is not None and self.active is not None:
            self._end(GoalStatus.ABORTED, reason, t_s)
        if reason != self.unavailable:
            self.unavailable = reason
            self._say(
                f"goals refused: {reason}" if reason is not None else "sensors back: taking goals"
            )

    def lidar_lost(self, reason: str) -> None:
        """The LiDAR's port failed: no navigation for the rest of the process."""
        self._lidar_lost = f"LiDAR lost: {reason}"

    def command(self, s: NavState) -> tuple[float, float]:
        """(v [m/s], w [rad/s]) for this frame: the requests taken, then the navigator."""
        t_s = s.t_s
        pose = self.nav.track(s)  # the odometry to this frame, before a pose is given
        taken, self._taken = self._taken, []
        for req in taken:
            self._apply(req, t_s)
        if self.active is None:
            self._publish(t_s, self.nav.pose_map())
            return 0.0, 0.0
        v, w = self.nav.command(s)
        pose = self.nav.pose_map()
        if self._last_pose is not None:
            self._travelled_m += pose.distance(self._last_pose)
        self._last_pose = pose
        if self.nav.done:
            if self.nav.failure is not None:
                self._end(GoalStatus.ABORTED, self.nav.failure, t_s)
            else:
                self._end(GoalStatus.SUCCEEDED, "goal reached", t_s)
            v, w = 0.0, 0.0
        else:
            rec = self.active
            assert rec is not None and rec.t_start_s is not None
            lost = self._lost(t_s)
            if t_s - rec.t_start_s > self.settings.goal_timeout_s:
                self._end(
                    GoalStatus.ABORTED,
                    f"timeout: not reached in {self.settings.goal_timeout_s:g} s of MCU time",
                    t_s,
                )
                v, w = 0.0, 0.0
            elif lost is not None:
                self._end(GoalStatus.ABORTED, lost, t_s)
                v, w = 0.0, 0.0
            else:
                self.active = replace(
                    rec,
                    t_end_s=t_s,
                    recoveries=sum(self.nav.recoveries.values()),
                    distance_remaining_m=path_remaining_m(self.nav.navigator.plan, pose),
                )
                self.book.update(self.active)
        self._publish(t_s, pose)
        return v, w

    # ------------------------------------------------------------------ internals

    def _apply(self, req: Request, t_s: float) -> None:
        if req.kind == "goal":
            rec = self.book.get(req.goal_id) or GoalRecord(req.goal_id, req.pose, req.source)
            if rec.status.ended:
                return  # cancelled while it waited
            if self.active is not None:
                self._end(GoalStatus.CANCELED, f"preempted by goal {req.goal_id}", t_s)
            self.active = replace(rec, status=GoalStatus.ACTIVE, t_start_s=t_s, t_end_s=t_s)
            self.book.update(self.active)
            self.nav.request_goal(req.pose)
            self.state = ServiceState.NAVIGATING
            self._travelled_m = 0.0
            self._last_pose = None
            self._lost_since_s = None
            self._say(
                f"goal {req.goal_id} ({req.x:.2f}, {req.y:.2f}, {req.yaw:.2f}) from {req.source}"
            )
        elif req.kind == "cancel":
            if self.active is not None and self.active.goal_id == req.goal_id:
                self._end(GoalStatus.CANCELED, f"canceled by {req.source or 'a client'}", t_s)
            else:
                waiting = self.book.get(req.goal_id)
                if waiting is not None and not waiting.status.ended:
                    self.book.update(
                        replace(
                            waiting, status=GoalStatus.CANCELED, reason="canceled while pending"
                        )
                    )
        elif req.kind == "pose":
            self.nav.relocalise(req.pose)
            self._lost_since_s = None
            self._say(f"localising from ({req.x:.2f}, {req.y:.2f}, {req.yaw:.2f}) ({req.source})")

    def _end(self, status: GoalStatus, reason: str, t_s: float) -> None:
        rec = self.active
        if rec is None:
            return
        self.nav.navigator.cancel()
        self.nav.done = True
        pose = self.nav.pose_map()
        end = replace(
            rec,
            status=status,
            reason=reason,
            t_end_s=t_s,
            pose_end=pose,
            recoveries=sum(self.nav.recoveries.values()),
        )
        self.active = None
        if self.state == ServiceState.NAVIGATING:
            self.state = ServiceState.IDLE
        self.book.update(end)
        self._say(
            f"goal {end.goal_id} {status.value} after {end.navigation_time_s:.1f} s: {reason}; "
            f"at ({pose.x:.2f}, {pose.y:.2f})"
        )

    def _lost(self, t_s: float) -> str | None:
        """The localiser's position spread has stayed above ``lost_std_m`` for
        ``lost_confirm_s``: the reason, else None."""
        pf = self.nav.filter
        if pf is None:
            return None
        cov = pf.covariance()
        std = math.sqrt(max(float(np.linalg.eigvalsh(cov[:2, :2]).max()), 0.0))
        if std <= self.settings.lost_std_m:
            self._lost_since_s = None
            return None
        if self._lost_since_s is None:
            self._lost_since_s = t_s
        if t_s - self._lost_since_s < self.settings.lost_confirm_s:
            return None
        return (
            f"localisation lost: position spread {std:.2f} m for "
            f"{t_s - self._lost_since_s:.1f} s (limit {self.settings.lost_std_m:g} m); "
            "give the pose again (jackson localise X,Y,YAW or /initialpose)"
        )

    def _publish(self, t_s: float, pose: Pose2D) -> None:
        pf = self.nav.filter
        cov = tuple(float(v) for v in pf.covariance().ravel()) if pf is not None else (0.0,) * 9
        rec = self.active
        eta = math.nan
        if rec is not None and rec.t_start_s is not None:
            elapsed = t_s - rec.t_start_s
            speed = self._travelled_m / elapsed if elapsed > 1.0 else math.nan
            if not speed >= MIN_ETA_SPEED_M_S:
                speed = max(self.nav.navigator.limits.max_v_m_s, MIN_ETA_SPEED_M_S)
            eta = rec.distance_remaining_m / speed
        self.status = ServiceStatus(t_s, self.state, self.unavailable, pose, cov, rec, eta)

    def _say(self, text: str) -> None:
        if self.tell is not None:
            self.tell(text)


def service_meta(service: NavigationService) -> dict[str, object]:
    """What ``meta.json`` records of the service (besides ``navigate``), so a replay rebuilds
    it."""
    sv = service.settings
    return {
        "goal_timeout_s": sv.goal_timeout_s,
        "lost_std_m": sv.lost_std_m,
        "lost_confirm_s": sv.lost_confirm_s,
        "history": sv.history,
    }
