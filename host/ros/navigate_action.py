"""``navigate_to_pose``: the navigation service as Nav2's ``nav2_msgs/action/NavigateToPose``.

:class:`NavigateToPoseServer` serves the action of ROS 2 Jazzy's nav2_msgs (built by ``make
setup`` from its interface definitions, ``tools/build_ros_msgs.py``) on the daemon's node, so a
Nav2 client (RViz's Nav2 panel, ``ros2 action send_goal``, a ``BasicNavigator`` script) drives
the robot as it would drive Nav2's bt_navigator:

- **goal**: every goal is accepted, then handed to
  :meth:`~jackson.host.service.navigation.NavigationService.submit_goal` (source
  ``navigate_to_pose``). A goal the service refuses (off the map, in an obstacle, cut off,
  sensors lost) or one in another frame than ``map`` ends at once as *aborted* with the
  reason in ``error_msg``, as Jazzy's bt_navigator aborts a goal it cannot take.
- **feedback**, as soon as the goal is active and then about every :data:`FEEDBACK_PERIOD_S`
  of wall time while it is, from the service's status at its last frame: ``current_pose``
  (map frame, stamped with the frame's time), ``navigation_time`` and
  ``estimated_time_remaining`` (MCU time), ``number_of_recoveries``, ``distance_remaining``
  along the global plan (0 before a plan, as Nav2 reports it).
- **cancel**: :meth:`~jackson.host.service.navigation.NavigationService.cancel`; the goal
  ends *canceled* at the next frame, braked. A goal that has already ended refuses the cancel.
- **result**, when the goal's record ends: succeeded -> *succeeded*; canceled through this
  action -> *canceled*; anything else -> *aborted* with the reason in ``error_msg``: the
  navigator's failure, a timeout, localisation or sensors lost, teleop taking over, or a newer
  goal (from this action, ``/goal_pose`` or ``jackson goal``) preempting it, which is how
  Nav2's action server ends a preempted goal. ``error_code`` is ``NONE`` (0), the one code
  Jazzy's NavigateToPose defines (Nav2 fills it from its planner's and controller's own codes,
  which the service's navigator does not have). With Humble's nav2_msgs, whose result has no
  such fields, the goal's status alone tells the end.

Each goal waits for its end on a thread of the node's multi-threaded executor (the action's own
reentrant callback group), blocking on the service's goal book rather than polling: the other
callbacks (``/cmd_vel``, parameters) go on meanwhile.
"""

from __future__ import annotations

import importlib
import math
import threading
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from jackson.host.service.goals import GoalRecord, GoalStatus

if TYPE_CHECKING:
    from jackson.host.ros.messages import StampClock
    from jackson.host.service.navigation import NavigationService

ACTION_NAME = "navigate_to_pose"
MAP_FRAME = "map"
SOURCE = "navigate_to_pose"  # the goals' source in the service's book
FEEDBACK_PERIOD_S = 0.5  # [s] of wall time between feedback messages (about 2 Hz)
PENDING_POLL_S = 0.02  # [s] a goal is pending until the next frame: its first feedback then
NS_PER_S = 1_000_000_000


def duration_parts(t_s: float) -> tuple[int, int]:
    """A non-negative duration [s] as builtin_interfaces/Duration (sec, nanosec); nan is 0."""
    ns = round(t_s * 1e9) if math.isfinite(t_s) and t_s > 0.0 else 0
    return ns // NS_PER_S, ns % NS_PER_S


class NavigateToPoseServer:
    """The ``navigate_to_pose`` action server of the daemon's node (module docstring).

    Parameters
    ----------
    node : rclpy.node.Node
        The daemon's node; its executor must run callbacks on several threads (a goal waits
        for its end on one).
    service : NavigationService
        Takes the goals and cancels; its status gives the feedback.
    clock : StampClock
        MCU time to ROS time, for the feedback's pose stamp.
    say : callable
        One line for the operator (a goal refused).
    stopping : threading.Event
        Set when the node stops: waiting goals give up.
    """

    def __init__(
        self,
        node: Any,
        service: NavigationService,
        clock: StampClock,
        say: Callable[[str], None],
        stopping: threading.Event,
    ) -> None:
        from rclpy.action import server
        from rclpy.callback_groups import ReentrantCallbackGroup

        self.action: Any = importlib.import_module("nav2_msgs.action").NavigateToPose
        # Jazzy's result has error_code and error_msg; Humble's nav2_msgs (a system ROS 2 on
        # the Jetson) has neither: its clients read the end from the goal's status alone
        self.error_fields = "error_msg" in self.action.Result.get_fields_and_field_types()
        self.service = service
        self.clock = clock
        self.say = say
        self.stopping = stopping
        self._lock = threading.Lock()
        self._ids: dict[bytes, int] = {}  # action goal uuid -> the service's goal id
        action_server: Any = server.ActionServer  # untyped in rclpy
        self.server = action_server(
            node,
            self.action,
            ACTION_NAME,
            execute_callback=self._execute,
            cancel_callback=self._cancel,
            callback_group=ReentrantCallbackGroup(),
        )

    def destroy(self) -> None:
        """Take the action off the node."""
        self.server.destroy()

    # ------------------------------------------------------------------ callbacks

    def _cancel(self, goal_handle: Any) -> Any:
        """A client's cancel: the service cancels the goal at its next frame; refused when
        the goal has already ended."""
        from rclpy.action.server import CancelResponse

        with self._lock:
            goal_id = self._ids.get(bytes(goal_handle.goal_id.uuid))
        if goal_id is None:  # not handed to the service yet: _execute sees the request
            return CancelResponse.ACCEPT
        rec = self.service.cancel(goal_id, SOURCE)
        return CancelResponse.ACCEPT if rec is not None else CancelResponse.REJECT

    def _execute(self, goal_handle: Any) -> Any:
        """Hand the goal to the service, send feedback while it is active and end the action
        as its record ends (on an executor thread of its own)."""
        from jackson.host.ros.messages import planar_pose

        request = goal_handle.request.pose
        frame = request.header.frame_id
        if frame != MAP_FRAME:
            why = f"the goal is in frame {frame!r}: navigate_to_pose takes goals in {MAP_FRAME!r}"
            self.say(f"ROS: navigate_to_pose goal refused: {why}")
            return self._end(goal_handle, GoalStatus.ABORTED, why)
        if goal_handle.is_cancel_requested:
            return self._end(goal_handle, GoalStatus.CANCELED, "canceled before it started")
        pose = planar_pose(request.pose)
        asked = self.service.submit_goal(pose, SOURCE)
        if asked.status is GoalStatus.REJECTED:
            self.say(
                f"ROS: navigate_to_pose goal ({pose.x:.2f}, {pose.y:.2f}) rejected: {asked.reason}"
            )
            return self._end(goal_handle, asked.status, asked.reason)
        key = bytes(goal_handle.goal_id.uuid)
        goal_id = asked.goal_id
        with self._lock:
            self._ids[key] = goal_id
        if goal_handle.is_cancel_requested:  # asked while it was being handed over
            self.service.cancel(goal_id, SOURCE)
        try:
            active = False
            while not self.stopping.is_set():
                wait_s = FEEDBACK_PERIOD_S if active else PENDING_POLL_S
                rec: GoalRecord | None = self.service.book.wait(goal_id, wait_s)
                if rec is None:
                    return self._end(goal_handle, GoalStatus.ABORTED, "the goal was forgotten")
                if rec.status.ended:
                    return self._end(goal_handle, rec.status, rec.reason)
                active = self._feedback(goal_handle, goal_id) or active
            return self._end(goal_handle, GoalStatus.ABORTED, "the daemon stopped")
        finally:
            with self._lock:
                self._ids.pop(key, None)

    # ------------------------------------------------------------------ messages

    def _feedback(self, goal_handle: Any, goal_id: int) -> bool:
        """Feedback from the service's last frame, when this goal is the active one; whether
        it was sent."""
        st = self.service.status
        rec = st.goal
        if rec is None or rec.goal_id != goal_id:
            return False  # pending: the frame loop has not taken it yet
        fb = self.action.Feedback()
        pose = fb.current_pose
        pose.header.frame_id = MAP_FRAME
        ns = self.clock.ns(st.t_s)
        pose.header.stamp.sec, pose.header.stamp.nanosec = ns // NS_PER_S, ns % NS_PER_S
        pose.pose.position.x, pose.pose.position.y = float(st.pose.x), float(st.pose.y)
        pose.pose.orientation.z = math.sin(0.5 * st.pose.yaw)
        pose.pose.orientation.w = math.cos(0.5 * st.pose.yaw)
        fb.navigation_time.sec, fb.navigation_time.nanosec = duration_parts(rec.navigation_time_s)
        eta = fb.estimated_time_remaining
        eta.sec, eta.nanosec = duration_parts(st.eta_s)
        fb.number_of_recoveries = min(rec.recoveries, 32767)
        remaining = rec.distance_remaining_m
        fb.distance_remaining = float(remaining) if math.isfinite(remaining) else 0.0
        goal_handle.publish_feedback(fb)
        return True

    def _end(self, goal_handle: Any, status: GoalStatus, reason: str) -> Any:
        """Put the action in its end state and return its result."""
        result = self.action.Result()
        if status is GoalStatus.SUCCEEDED:
            goal_handle.succeed()
            reason = ""
        elif status is GoalStatus.CANCELED and goal_handle.is_cancel_requested:
            goal_handle.canceled()
        else:  # aborted, rejected, or canceled by someone else (preempted, jackson cancel)
            goal_handle.abort()
        if self.error_fields:
            result.error_code = self.action.Result.NONE
            result.error_msg = reason
        return result
