"""The live view's server: the robot over the Foxglove WebSocket protocol (foxglove-sdk), for
the daemon's view (:mod:`jackson.host.liveview`) and the twin's ground truth
(:mod:`jackson.sim.liveview`).

A :class:`LiveServer` is one WebSocket server (subprotocol ``foxglove.websocket.v1``) with a
foxglove ``Context`` of its own, so two servers in one process (a test's twin and daemon)
never share a channel. Its channels carry the SDK's schemas, protobuf-encoded (``LaserScan``,
``Grid``, ``PoseInFrame``, ``PosesInFrame``, ``FrameTransforms``, ``SceneUpdate``) or JSON.

It binds 127.0.0.1 unless told otherwise (``--live-view [HOST:]PORT``,
:func:`~jackson.common.args.host_port`): the view shows the robot's map and where it is, so
it is opened to a network only on purpose. A port in use is a :class:`LiveViewError` with one
line; whoever starts the server goes on without it.

Stamps are MCU time (the twin's sim time): the daemon's view and the twin's share one clock,
as the daemon's ROS topics and the twin's /clock do.

This module loads foxglove-sdk: it is imported only where a live view is asked for.
"""

from __future__ import annotations

import math
import threading
from collections import deque
from collections.abc import Callable

import foxglove
import numpy as np
import numpy.typing as npt
from foxglove.messages import FrameTransform, LaserScan, Pose, Quaternion, Timestamp, Vector3
from foxglove.websocket import ChannelView, Client, ServerListener, WebSocketServer

from jackson.common.errors import JacksonError

DEFAULT_HOST = "127.0.0.1"  # this machine only (ssh -L 8765:localhost:8765 from a laptop)
DEFAULT_PORT = 8765  # Foxglove's default
MAP_PERIOD_S = 10.0  # [s] of MCU time between two sends of a map (or a world) and footprint
POSE_PERIOD_S = 0.1  # [s] of MCU time: poses, transforms and plans at 10 Hz
HEALTH_PERIOD_S = 1.0  # [s] of MCU time: the health summary at 1 Hz
NS_PER_S = 1_000_000_000


class LiveViewError(JacksonError, RuntimeError):
    """The live view cannot be served (its port in use, an address not on this machine): one
    line. The daemon and the twin go on without it."""


class Every:
    """Due once per ``period_s`` of MCU time: the rate limit of a topic.

    Parameters
    ----------
    period_s : float
        The period [s].
    """

    def __init__(self, period_s: float) -> None:
        self.period_s = period_s
        self._next_s = -math.inf

    def due(self, t_s: float) -> bool:
        """True (and the next one a period later) when ``t_s`` has reached the due time; a
        clock that went back (an MCU reset) is due at once."""
        nxt = self._next_s
        if t_s >= nxt - 1e-6 or t_s < nxt - 2.0 * self.period_s:
            self._next_s = t_s + self.period_s
            return True
        return False


class _Subscriptions(ServerListener):
    """The server's listener: the topics a client subscribed to, taken by the publishing
    thread (latched topics such as the map are sent again to a new subscriber). Called on the
    server's own thread."""

    def __init__(self) -> None:
        self.new: deque[str] = deque(maxlen=256)

    def on_subscribe(self, client: Client, channel: ChannelView) -> None:
        self.new.append(channel.topic)

    def on_unsubscribe(self, client: Client, channel: ChannelView) -> None:
        return None


class LiveServer:
    """One Foxglove WebSocket server and the context its channels belong to.

    Parameters
    ----------
    name : str
        The server's name, shown by Foxglove.
    host : str
        The address to bind.
    port : int
        The TCP port (0: any free one; :attr:`port` tells which).
    """

    def __init__(self, name: str, host: str = DEFAULT_HOST, port: int = DEFAULT_PORT) -> None:
        self.name, self.host, self.requested_port = name, host, port
        self.context = foxglove.Context()
        self._listener = _Subscriptions()
        self._server: WebSocketServer | None = None
        self._lock = threading.Lock()

    def start(self) -> str:
        """Bind and serve; the address a Foxglove client opens (``ws://HOST:PORT``).

        Raises
        ------
        LiveViewError
            The address cannot be bound (the port in use, an address not on this machine).
        """
        try:
            self._server = foxglove.start_server(
                name=self.name,
                host=self.host,
                port=self.requested_port,
                context=self.context,
                server_listener=self._listener,
            )
        except RuntimeError as exc:
            text = str(exc).removeprefix("FoxgloveError: ")
            raise LiveViewError(
                f"live view: cannot serve on {self.host}:{self.requested_port}: {text}"
            ) from exc
        return self.url

    @property
    def port(self) -> int:
        """The port it listens on (0 before :meth:`start`)."""
        return self._server.port if self._server is not None else 0

    @property
    def url(self) -> str:
        """``ws://HOST:PORT``."""
        return f"ws://{self.host}:{self.port}"

    def subscribed(self) -> set[str]:
        """The topics clients subscribed to since the last call."""
        new = self._listener.new
        out: set[str] = set()
        while new:
            out.add(new.popleft())
        return out

    def stop(self) -> None:
        """Stop serving (clients are disconnected); safe to call twice."""
        with self._lock:
            server, self._server = self._server, None
        if server is not None:
            server.stop()


class ServedView:
    """What the daemon's and the twin's live views share: the server they publish on, whether
    they still publish, and how they stop when publishing fails (the robot or the twin goes on
    without its view; ``tell`` says why, once).

    Attributes
    ----------
    server : LiveServer
        The server.
    off : str or None
        Why the view stopped publishing (None while it serves).
    published : dict of str to int
        Messages sent per topic.
    """

    def __init__(
        self, server: LiveServer, topics: tuple[str, ...], tell: Callable[[str], None]
    ) -> None:
        self.server = server
        self.tell = tell
        self.off: str | None = None
        self.published: dict[str, int] = dict.fromkeys(topics, 0)

    def start(self) -> str:
        """Serve; the address to open in Foxglove.

        Raises
        ------
        LiveViewError
            The address cannot be bound.
        """
        return self.server.start()

    def stop(self) -> None:
        """Stop serving."""
        self.server.stop()

    def _fail(self, exc: Exception) -> None:
        self.off = f"live view off: publishing failed: {type(exc).__name__}: {exc}"
        self.server.stop()
        self.tell(self.off)


def stamp_ns(t_s: float) -> int:
    """MCU time [s] as the stamp of a message and its log time [ns] (never negative)."""
    return max(0, round(t_s * NS_PER_S))


def timestamp(t_s: float) -> Timestamp:
    """MCU time [s] as a Foxglove ``Timestamp``."""
    ns = stamp_ns(t_s)
    return Timestamp(ns // NS_PER_S, ns % NS_PER_S)


def pose(x_m: float, y_m: float, yaw_rad: float, z_m: float = 0.0) -> Pose:
    """A planar pose as a Foxglove ``Pose`` (a rotation about +z)."""
    half = 0.5 * yaw_rad
    return Pose(
        position=Vector3(x=x_m, y=y_m, z=z_m),
        orientation=Quaternion(x=0.0, y=0.0, z=math.sin(half), w=math.cos(half)),
    )


def transform(
    t_s: float, parent: str, child: str, x_m: float, y_m: float, yaw_rad: float
) -> FrameTransform:
    """``child`` in ``parent`` at MCU time ``t_s``: a planar transform."""
    half = 0.5 * yaw_rad
    return FrameTransform(
        timestamp=timestamp(t_s),
        parent_frame_id=parent,
        child_frame_id=child,
        translation=Vector3(x=x_m, y=y_m, z=0.0),
        rotation=Quaternion(x=0.0, y=0.0, z=math.sin(half), w=math.cos(half)),
    )


def laser_scan(
    t_s: float,
    frame: str,
    start_angle_rad: float,
    end_angle_rad: float,
    ranges_m: npt.ArrayLike,
) -> LaserScan:
    """One revolution in the sensor's frame, its ranges evenly spread from the start angle to
    the end angle (``inf``: no return, which Foxglove leaves out)."""
    return LaserScan(
        timestamp=timestamp(t_s),
        frame_id=frame,
        pose=pose(0.0, 0.0, 0.0),
        start_angle=start_angle_rad,
        end_angle=end_angle_rad,
        ranges=np.asarray(ranges_m, dtype=np.float64).tolist(),
    )
