"""The navigation service's settings: the ``service:`` section of the host configuration.

With ``lidar`` and ``map`` both given, ``jackson daemon`` (and so the systemd unit) runs the
navigation service: it localises on the map from ``start``, holds the robot braked while idle
and takes goal after goal (docs/host.md, "The navigation service"). Without them the daemon
takes velocity commands only, as before.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

SOCKET_NAME = "daemon.sock"
SYSTEM_SOCKET_DIR = Path("/run/jackson")  # systemd's RuntimeDirectory=jackson


@dataclass(frozen=True)
class LiveViewSettings:
    """The live view over the Foxglove WebSocket protocol (opt-in).

    Attributes
    ----------
    enabled : bool
        Serve it.
    host : str
        The address to bind (127.0.0.1: this machine only; 0.0.0.0 opens it to the network).
    port : int
        The TCP port (Foxglove's default 8765).
    """

    enabled: bool = False
    host: str = "127.0.0.1"
    port: int = 8765


@dataclass(frozen=True)
class ServiceSettings:
    """What the navigation service needs besides the robot.

    Attributes
    ----------
    lidar : str or None
        The RPLIDAR's port; with ``map``, the daemon runs the service.
    lidar_mode : str
        The RPLIDAR's scan mode (``densest``, ``standard`` or a mode's name).
    map : Path or None
        The map (map_server YAML) the robot localises and plans on.
    start : tuple of 3 float
        The robot's pose in the map frame when the daemon starts [m, m, rad].
    socket : str
        The control socket's path (``jackson goal``/``cancel``/``status``); ``auto``:
        :func:`default_socket`.
    goal_timeout_s : float
        A goal not reached within this much MCU time ends as timed out [s].
    lost_std_m : float
        The localiser's position standard deviation above which the robot counts as lost [m].
    lost_confirm_s : float
        How long it must stay above it before the goal ends [s].
    history : int
        Finished goals the service keeps for ``status`` and late waiters.
    live_view : LiveViewSettings
        The Foxglove WebSocket live view.
    """

    lidar: str | None = None
    lidar_mode: str = "densest"
    map: Path | None = None
    start: tuple[float, float, float] = (0.0, 0.0, 0.0)
    socket: str = "auto"
    goal_timeout_s: float = 600.0
    lost_std_m: float = 0.5
    lost_confirm_s: float = 2.0
    history: int = 32
    live_view: LiveViewSettings = field(default_factory=LiveViewSettings)

    @property
    def serves(self) -> bool:
        """The daemon runs the navigation service (a LiDAR and a map are named)."""
        return self.lidar is not None and self.map is not None


def default_socket() -> Path:
    """Where the daemon listens and the commands look when ``socket`` is ``auto``.

    ``$JACKSON_SOCKET`` when set; else ``/run/jackson/daemon.sock`` when ``/run/jackson`` is
    there (the systemd unit makes it) or the process may make it (root); else the user's
    ``$XDG_RUNTIME_DIR/jackson/daemon.sock``; else ``/tmp/jackson-<uid>/daemon.sock``.
    """
    env = os.environ.get("JACKSON_SOCKET")
    if env:
        return Path(env)
    if SYSTEM_SOCKET_DIR.is_dir() or os.geteuid() == 0:
        return SYSTEM_SOCKET_DIR / SOCKET_NAME
    runtime = os.environ.get("XDG_RUNTIME_DIR")
    if runtime and Path(runtime).is_dir():
        return Path(runtime) / "jackson" / SOCKET_NAME
    return Path(f"/tmp/jackson-{os.geteuid()}") / SOCKET_NAME


def socket_path(settings: ServiceSettings) -> Path:
    """The control socket's path the settings name."""
    return default_socket() if settings.socket == "auto" else Path(settings.socket)
