"""The DWB cycle's front compiled: the window's targets, the roll-outs and the batch, in one call.

Before the critics, a cycle samples the window (:func:`~.core.window.sample_targets`), rolls the
targets out (:func:`~.core.rollouts.build_rollouts`) and evaluates the arrays every critic reads
(:meth:`~.critics.base.Batch.of`, with the cells ahead of the end poses the align critics
score). In numpy that is two dozen calls on arrays of a few hundred numbers, whose cost is the
calls themselves. With the compiled library (:mod:`jackson.host.nav.native`) it is one call,
``jackson_dwb_front``, with numpy's operations in numpy's order: the same targets, tables,
poses and cells bit for bit (``tests/host/nav/dwb/test_front.py``).

The call writes into three buffers (floats, indices, flags) laid out once per planner
configuration and bounds (:class:`FrontLayout`); the arrays handed on are views of them, made
new each cycle, which the critics only read. A window larger than the layout's room (it is
sized from the speed limits, so only a change of the rules could do it) returns None, and the
planner takes numpy's path.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from jackson.host.nav import native
from jackson.host.nav.costmap import Costmap
from jackson.host.nav.dwb.core.config import DwbConfig
from jackson.host.nav.dwb.core.kinematics import Kinematics
from jackson.host.nav.dwb.core.rollouts import Rollouts
from jackson.host.nav.dwb.critics.base import _CULL_STEPS, Batch
from jackson.host.nav.types import Pose2D

FloatArray = npt.NDArray[np.float64]

# the float buffer's arrays, in order, then the index buffer's and the flag buffer's
_FLOATS = ("v", "w", "t", "ds", "yaw", "cs", "cx", "cy", "length", "yaw_end", "cos", "sin", "brake")
_INDICES = ("iv", "iw", "end_cell", "forward_cell")
_FLAGS = ("end_ok", "forward_ok")


@dataclass(frozen=True)
class FrontLayout:
    """The buffers' layout for one configuration and set of bounds.

    Attributes
    ----------
    kinematics : Kinematics
        The bounds it was made for.
    forward_m : tuple of float
        The distinct forward point distances the align critics read [m].
    forward : ndarray, shape (F,)
        The same, as the compiled call reads them.
    params : ndarray, shape (11,)
        The window's and the roll-outs' parameters, in the compiled call's order.
    counts : tuple of int
        (vx_samples, vtheta_samples, the coarse stride).
    capacity : ndarray of int64, shape (4,)
        Room for M targets, V and W distinct targets, K steps.
    floats, indices, flags : tuple of int
        Each array's offset in its buffer, the buffer's size last.
    offsets : ndarray of int64
        The three buffers' offsets (without the sizes) one after the other, as the compiled
        call reads them.
    """

    kinematics: Kinematics
    forward_m: tuple[float, ...]
    forward: FloatArray
    params: FloatArray
    counts: tuple[int, int, int]
    capacity: npt.NDArray[np.int64]
    floats: tuple[int, ...]
    indices: tuple[int, ...]
    flags: tuple[int, ...]
    offsets: npt.NDArray[np.int64]

    @classmethod
    def of(cls, config: DwbConfig, kinematics: Kinematics) -> FrontLayout:
        """The layout for ``config`` within ``kinematics``.

        Parameters
        ----------
        config : DwbConfig
            Samples, simulation time, granularities, forward point distances.
        kinematics : Kinematics
            The speed and acceleration bounds.

        Returns
        -------
        FrontLayout
            Room for the largest window the bounds allow.
        """
        c, k = config, kinematics
        forward = tuple(
            dict.fromkeys(
                (c.path_align_forward_point_distance_m, c.goal_align_forward_point_distance_m)
            )
        )
        m = c.vx_samples * (c.vtheta_samples + 1)
        n_v, n_w = c.vx_samples, 2 * (c.vtheta_samples + 1)
        w_max = max(k.max_vel_theta_rad_s, c.min_speed_theta_rad_s)
        steps = max(
            k.max_vel_x_m_s * c.sim_time_s / c.linear_granularity_m,
            w_max * c.sim_time_s / c.angular_granularity_rad,
        )
        n_k = max(1, math.ceil(steps)) + 1
        blocks = -(-n_k // _CULL_STEPS)
        nf = len(forward)
        sizes = {
            "v": m, "w": m, "t": n_k + 1, "ds": n_v * n_k, "yaw": n_w * (n_k + 1),
            "cs": 2 * n_w * n_k, "cx": (blocks + 1) * m, "cy": (blocks + 1) * m,
            "length": blocks * m, "yaw_end": m, "cos": m, "sin": m, "brake": 1,
            "iv": m, "iw": m, "end_cell": m, "forward_cell": nf * m,
            "end_ok": m, "forward_ok": nf * m,
        }  # fmt: skip
        params = np.array(
            (
                c.sim_time_s, c.linear_granularity_m, c.angular_granularity_rad,
                c.min_vel_x_m_s, c.min_speed_theta_rad_s, k.max_vel_x_m_s,
                k.max_vel_theta_rad_s, k.acc_lim_x_m_s2, k.decel_lim_x_m_s2,
                k.acc_lim_theta_rad_s2, k.decel_lim_theta_rad_s2,
            ),
            np.float64,
        )  # fmt: skip
        floats, indices, flags = (_offsets(names, sizes) for names in (_FLOATS, _INDICES, _FLAGS))
        return cls(
            kinematics, forward, np.array(forward, np.float64), params,
            (c.vx_samples, c.vtheta_samples, _CULL_STEPS),
            np.array((m, n_v, n_w, n_k), np.int64), floats, indices, flags,
            np.array((*floats[:-1], *indices[:-1], *flags[:-1]), np.int64),
        )  # fmt: skip


def _offsets(names: tuple[str, ...], sizes: dict[str, int]) -> tuple[int, ...]:
    """Where each array starts in a buffer holding them in order, the buffer's size last."""
    out = [0]
    for name in names:
        out.append(out[-1] + sizes[name])
    return tuple(out)


def front(
    layout: FrontLayout, pose: Pose2D, velocity: tuple[float, float], costmap: Costmap
) -> tuple[Rollouts, Batch] | None:
    """The cycle's roll-outs and batch, compiled.

    Parameters
    ----------
    layout : FrontLayout
        The planner's layout.
    pose : Pose2D
        Start pose (map frame).
    velocity : tuple of float
        Current (v [m/s], w [rad/s]).
    costmap : Costmap
        The local costmap.

    Returns
    -------
    tuple or None
        (the roll-outs, the batch: its targets, end poses and cells, and the forward cells at
        the layout's distances), as :func:`~.core.window.sample_targets`,
        :func:`~.core.rollouts.build_rollouts` and :meth:`~.critics.base.Batch.of` make them;
        None without the compiled library or when the window outgrows the layout.
    """
    lib = native.LIB
    if lib is None:
        return None
    g = costmap.geometry
    fo, io, bo = layout.floats, layout.indices, layout.flags
    f = np.empty(fo[-1])
    n = np.empty(io[-1], np.int64)
    b = np.empty(bo[-1], np.uint8)
    state = np.array((velocity[0], velocity[1], pose.x, pose.y, pose.yaw), np.float64)
    grid = np.array((g.origin_x_m, g.origin_y_m, g.resolution_m), np.float64)
    sizes = np.zeros(5, np.int64)
    address = native.address
    at = address(layout.offsets)
    at_i = at + 8 * (len(fo) - 1)
    at_b = at_i + 8 * (len(io) - 1)
    vx, vth, stride = layout.counts
    failed = lib.jackson_dwb_front(
        address(layout.params), vx, vth, stride, address(state), address(grid), g.rows, g.cols,
        layout.forward.size, address(layout.forward), address(layout.capacity), address(sizes),
        address(f), at, address(n), at_i, address(b), at_b,
    )  # fmt: skip
    if failed:
        return None
    m, n_v, n_w, k, blocks = sizes.tolist()
    v = f[fo[0] : fo[0] + m]
    w = f[fo[1] : fo[1] + m]
    iv = n[io[0] : io[0] + m]
    iw = n[io[1] : io[1] + m]
    ro = Rollouts.of_tables(
        pose,
        f[fo[2] : fo[2] + k + 1],
        f[fo[3] : fo[3] + n_v * k].reshape(n_v, k),
        f[fo[4] : fo[4] + n_w * (k + 1)].reshape(n_w, k + 1),
        f[fo[5] : fo[5] + 2 * n_w * k].reshape(2 * n_w, k),
        iv,
        iw,
    )
    x_c = f[fo[6] : fo[6] + (blocks + 1) * m].reshape(blocks + 1, m)
    y_c = f[fo[7] : fo[7] + (blocks + 1) * m].reshape(blocks + 1, m)
    flags = b.view(np.bool_)
    batch = Batch(
        v, w, float(f[fo[12]]), ro, x_c, y_c, f[fo[8] : fo[8] + blocks * m].reshape(blocks, m),
        x_c[-1], y_c[-1], f[fo[9] : fo[9] + m], f[fo[10] : fo[10] + m], f[fo[11] : fo[11] + m],
        n[io[2] : io[2] + m], flags[bo[0] : bo[0] + m], costmap,
    )  # fmt: skip
    for j, d in enumerate(layout.forward_m):  # distance j's m cells
        batch._forward[d] = (
            n[io[3] + j * m : io[3] + (j + 1) * m],
            flags[bo[1] + j * m : bo[1] + (j + 1) * m],
        )
    return ro, batch
