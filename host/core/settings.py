"""Live settings: what may change while the daemon runs, and how a change reaches the core.

:class:`LiveSettings` is everything a client may change at run time (``ros2 param set`` on the
ROS node, docs/ros2.md): the command limits (the host YAML's ``limits:``) and the command
watchdog (``cmd_vel_timeout_s``). Everything else of the host configuration is read once, at start.

A change goes through the front door, as velocity commands and the navigation service's
requests do: a client hands the whole new value to :meth:`HostCore.request_settings
<jackson.host.core.HostCore.request_settings>` from any thread; the next telemetry frame takes
it (:meth:`SettingsInbox.take`), the run's log records it before that frame (record kind 8 of
``log.jrec``, :meth:`LiveSettings.encode`), and the core hands it, before the frame is
handled, to every stage that holds a copy:

* the actuation chain's velocity limiter (``limits``);
* the command arbiter's watchdog (``cmd_vel_timeout_s``);
* a navigating mission's navigator: DWB's dynamic window and roll-outs and the recoveries'
  speeds (``limits``, with the navigation's top speed ``navigation_max_v_m_s`` of the
  configuration applied as at start, :meth:`SettingsInbox.navigation_limits`).

``jackson replay`` hands the logged value to the same frame, so a run with a live change
replays bit for bit. Several requests before one frame: the newest wins. The MCU's own
failsafe is no live setting: it keeps the configured ``failsafe_ms`` (set when the device says
hello).
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass

from jackson.host.actuation.limiter import LimiterConfig
from jackson.host.config import CMD_VEL_TIMEOUT_RANGE_S, HostConfig


def cmd_vel_timeout_seconds(value: object) -> float:
    """``value`` as a command watchdog's lifetime [s].

    Raises
    ------
    ValueError
        Not a number within :data:`CMD_VEL_TIMEOUT_RANGE_S
        <jackson.host.config.CMD_VEL_TIMEOUT_RANGE_S>`, named in one line.
    """
    low, high = CMD_VEL_TIMEOUT_RANGE_S
    if not (isinstance(value, (int, float)) and low <= float(value) <= high):
        raise ValueError(f"cmd_vel_timeout_s must be within {low:g}-{high:g} s, got {value}")
    return float(value)


@dataclass(frozen=True)
class LiveSettings:
    """The settings a client may change at run time (module docstring).

    Attributes
    ----------
    limits : LimiterConfig
        Speed, acceleration and deceleration bounds of the body velocity.
    cmd_vel_timeout_s : float
        An external velocity command's lifetime [s], within :data:`CMD_VEL_TIMEOUT_RANGE_S
        <jackson.host.config.CMD_VEL_TIMEOUT_RANGE_S>`.

    Raises
    ------
    ValueError
        ``cmd_vel_timeout_s`` outside its range (the limits check themselves).
    """

    limits: LimiterConfig
    cmd_vel_timeout_s: float

    def __post_init__(self) -> None:
        cmd_vel_timeout_seconds(self.cmd_vel_timeout_s)

    @classmethod
    def of(cls, cfg: HostConfig) -> LiveSettings:
        """The settings of a host configuration (those in force at start)."""
        return cls(cfg.limits, cfg.cmd_vel_timeout_s)

    def encode(self) -> bytes:
        """The settings as the run's log keeps them (UTF-8 JSON)."""
        return json.dumps(
            {
                "limits": dataclasses.asdict(self.limits),
                "cmd_vel_timeout_s": self.cmd_vel_timeout_s,
            },
            separators=(",", ":"),
        ).encode()

    @classmethod
    def decode(cls, data: bytes) -> LiveSettings:
        """The settings a run's log kept (``watchdog_s``: the timeout's name in older logs).

        Raises
        ------
        ValueError
            Not a settings record, or values out of range.
        """
        try:
            d = json.loads(data.decode())
            limits = LimiterConfig(**{k: float(v) for k, v in d["limits"].items()})
            timeout = d["cmd_vel_timeout_s"] if "cmd_vel_timeout_s" in d else d["watchdog_s"]
            return cls(limits, float(timeout))
        except (UnicodeDecodeError, ValueError, KeyError, TypeError, AttributeError) as exc:
            raise ValueError(f"not live settings ({exc}): {data[:60]!r}") from exc


class SettingsInbox:
    """The live settings in force and the newest one requested, between the threads that
    request them and the frame that takes them (module docstring).

    Parameters
    ----------
    cfg : HostConfig
        The daemon's configuration: the settings at start, and the navigation's top speed.

    Attributes
    ----------
    current : LiveSettings
        In force since the last frame that took a request (the configuration's before).
    """

    def __init__(self, cfg: HostConfig) -> None:
        self.cfg = cfg
        self.current = LiveSettings.of(cfg)
        self._pending: LiveSettings | None = None  # requested, not yet taken

    def __getstate__(self) -> dict[str, object]:
        """The inbox for a core's snapshot (docs/recording.md): a request not yet taken stays
        out (the next frame takes it, logged in the next run folder)."""
        state = dict(self.__dict__)
        state["_pending"] = None
        return state

    @property
    def latest(self) -> LiveSettings:
        """The newest settings requested, or those in force: what a change starts from."""
        pending = self._pending
        return pending if pending is not None else self.current

    def request(self, settings: LiveSettings) -> None:
        """Ask for ``settings`` from the next telemetry frame on; safe from another thread (one
        reference is swapped)."""
        self._pending = settings

    def take(self) -> LiveSettings | None:
        """At a telemetry frame, on the core's thread: the settings requested since the last
        one (now in force), or None."""
        taken, self._pending = self._pending, None
        if taken is not None:
            self.current = taken
        return taken

    def navigation_limits(self) -> LimiterConfig:
        """The bounds a navigator plans within under the settings in force: their limits with
        the configuration's navigation top speed (:meth:`HostConfig.navigation_limits
        <jackson.host.config.HostConfig.navigation_limits>`)."""
        return dataclasses.replace(self.cfg, limits=self.current.limits).navigation_limits()
