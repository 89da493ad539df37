"""The ROS node's parameters: those read once when it starts, and the daemon's live settings,
which ``ros2 param set`` changes while it runs.

The node's own parameters (:class:`~jackson.host.ros.settings.RosSettings`: names, frames,
offsets, covariances) are declared with the configuration's values as defaults
(:func:`declare_node_parameters`) and read once; setting one later is refused with the reason.
The live ones (:func:`declare_live_parameters`) are the fields of
:class:`~jackson.host.core.settings.LiveSettings`: the command limits as ``limits.max_v_m_s``,
``limits.max_w_rad_s``, ... (the host YAML's ``limits:``) and the command watchdog
``cmd_vel_timeout_s``. A change to them becomes a whole new :class:`LiveSettings`
(:func:`changed_settings`), which the node hands to the core's front door
(:meth:`~jackson.host.core.HostCore.request_settings`): it takes effect at the next telemetry
frame, in every stage that holds a copy, and the run's log records it.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Collection, Iterable
from typing import Any

from jackson.common.errors import JacksonError
from jackson.host.config import HostConfig
from jackson.host.core.settings import LiveSettings, cmd_vel_timeout_seconds
from jackson.host.ros.settings import RosSettings

LIMITS_PREFIX = "limits."  # the limits' parameters: limits.<LimiterConfig field>
WATCHDOG = "cmd_vel_timeout_s"  # the command watchdog's parameter [s]


class ParameterError(JacksonError, ValueError):
    """A parameter change the node refuses (one line: which parameter and why)."""


def declare_node_parameters(node: Any, cfg: HostConfig) -> RosSettings:
    """Declare the node's own parameters, the configuration's values as defaults, and read
    them (overrides given on the command line or by the daemon win).

    Parameters
    ----------
    node : rclpy.node.Node
        The node.
    cfg : HostConfig
        The daemon's configuration.

    Returns
    -------
    RosSettings
        The values the node runs with.
    """
    defaults = RosSettings.for_config(cfg)
    values: dict[str, Any] = {}
    for name, default in vars(defaults).items():
        initial = [float(c) for c in default] if isinstance(default, tuple) else default
        value = node.declare_parameter(name, initial).value
        values[name] = tuple(float(c) for c in value) if isinstance(default, tuple) else value
    return RosSettings(**values)


def declare_live_parameters(node: Any, settings: LiveSettings) -> LiveSettings:
    """Declare the live settings as parameters (module docstring), ``settings`` as their
    defaults, and read them back: values given when the node was made (``-p
    limits.max_v_m_s:=0.2``, the daemon's overrides) win.

    Parameters
    ----------
    node : rclpy.node.Node
        The node.
    settings : LiveSettings
        The settings in force.

    Returns
    -------
    LiveSettings
        The settings the parameters hold: ``settings`` itself when no value was given.

    Raises
    ------
    ParameterError
        A value given at start that its setting refuses.
    """
    names = [LIMITS_PREFIX + f.name for f in dataclasses.fields(settings.limits)]
    for name in names:
        default = getattr(settings.limits, name.removeprefix(LIMITS_PREFIX))
        node.declare_parameter(name, float(default))
    node.declare_parameter(WATCHDOG, float(settings.cmd_vel_timeout_s))
    given = [(name, node.get_parameter(name).value) for name in [*names, WATCHDOG]]
    return changed_settings(settings, given, ())


def changed_settings(
    current: LiveSettings, changes: Iterable[tuple[str, Any]], fixed: Collection[str]
) -> LiveSettings:
    """The live settings after a set of parameter changes (all of them, or none).

    Parameters
    ----------
    current : LiveSettings
        What the changes start from (the newest requested).
    changes : iterable of (str, object)
        Parameter names and their new values, as ``ros2 param set`` gives them.
    fixed : collection of str
        The parameters read only when the node starts.

    Returns
    -------
    LiveSettings
        ``current`` with the changes (``current`` itself without a live one among them).

    Raises
    ------
    ParameterError
        The first change refused: a value its setting refuses (not > 0, out of range), or
        a parameter read only at start.
    """
    limits, timeout_s = current.limits, current.cmd_vel_timeout_s
    for name, value in changes:
        if name.startswith(LIMITS_PREFIX):
            field = name.removeprefix(LIMITS_PREFIX)
            try:
                limits = dataclasses.replace(limits, **{field: float(value)})
            except (TypeError, ValueError) as exc:
                raise ParameterError(f"{name}: {exc}") from exc
        elif name == WATCHDOG:
            try:
                timeout_s = cmd_vel_timeout_seconds(value)
            except ValueError as exc:
                raise ParameterError(str(exc)) from exc
        elif name in fixed:
            raise ParameterError(
                f"{name} is read when the node starts: restart the daemon to change it"
            )
    if (limits, timeout_s) == (current.limits, current.cmd_vel_timeout_s):
        return current
    return LiveSettings(limits, timeout_s)
