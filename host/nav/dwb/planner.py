"""The DWB cycle: sample the window, roll out, let every critic score all roll-outs, choose."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import numpy.typing as npt

from jackson.host.nav import native, native_grid
from jackson.host.nav.costmap import Costmap
from jackson.host.nav.dwb.core.config import Command, DwbConfig
from jackson.host.nav.dwb.core.distance import DistanceMaps
from jackson.host.nav.dwb.core.kinematics import Kinematics, SpeedLimits
from jackson.host.nav.dwb.core.path import PlanCells, plan_cells, plan_span
from jackson.host.nav.dwb.core.rollouts import Rollouts, build_rollouts
from jackson.host.nav.dwb.core.window import dynamic_window, sample_targets
from jackson.host.nav.dwb.critics import Batch, Context, Critic, bringup_critics
from jackson.host.nav.dwb.critics.base import DeferredLegality
from jackson.host.nav.dwb.front import FrontLayout, front
from jackson.host.nav.types import Pose2D

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

NO_PATH = "no point of the global path lies on the local costmap"


class DwbPlanner:
    """The DWB-style local planner.

    Parameters
    ----------
    config : DwbConfig
        Sampling, simulation and critics.
    limits : SpeedLimits or Kinematics
        Speed and acceleration bounds (the navigation's, e.g. the velocity limiter's
        configuration); the window never leaves them.
    critics : sequence of Critic, optional
        The critics, in scoring order, names distinct; Nav2 bringup's
        (:func:`~jackson.host.nav.dwb.critics.bringup_critics`) by default.

    Attributes
    ----------
    config : DwbConfig
        As given.
    kinematics : Kinematics
        The planner's own copy of the bounds (:meth:`set_limits` replaces it).
    critics : tuple of Critic
        The critics, in scoring order.

    Raises
    ------
    ValueError
        When two critics share a name.
    """

    def __init__(
        self,
        config: DwbConfig,
        limits: SpeedLimits | Kinematics,
        critics: Sequence[Critic] | None = None,
    ) -> None:
        self.config = config
        self.kinematics = Kinematics.of(limits)
        self.critics = tuple(bringup_critics(config) if critics is None else critics)
        names = [critic.name for critic in self.critics]
        if len(set(names)) != len(names):
            raise ValueError(f"DwbPlanner: critic names must be distinct, got {names}")
        self._deferred = _deferred(self.critics)
        self._maps = DistanceMaps()
        self._plan_key: tuple[object, ...] | None = None
        self._plan: PlanCells | None = None
        self._front: FrontLayout | None = None

    def __setstate__(self, state: dict[str, object]) -> None:
        """A planner pickled before it kept its own kinematics and its deferred critics (a
        run folder's snapshot) takes them from what it held."""
        limits = state.pop("limits", None)
        self.__dict__.update(state)
        if limits is not None:
            self.kinematics = Kinematics.of(limits)  # type: ignore[arg-type]  # a LimiterConfig
        self._deferred = _deferred(self.critics)
        self._front = None

    def set_limits(self, limits: SpeedLimits | Kinematics) -> None:
        """New speed and acceleration bounds from the next cycle on (a live setting).

        Parameters
        ----------
        limits : SpeedLimits or Kinematics
            The bounds.
        """
        self.kinematics = Kinematics.of(limits)

    def critic(self, name: str) -> Critic:
        """The critic called ``name``.

        Parameters
        ----------
        name : str
            As in :data:`~jackson.host.nav.dwb.critics.CRITICS`.

        Returns
        -------
        Critic
            It.

        Raises
        ------
        KeyError
            When the planner has no such critic.
        """
        for critic in self.critics:
            if critic.name == name:
                return critic
        raise KeyError(f"DwbPlanner has no critic {name!r}")

    def reset(self) -> None:
        """Forget the critics' state (a new goal)."""
        for critic in self.critics:
            critic.reset()

    # ------------------------------------------------------------------ sampling

    def window(self, v_m_s: float, w_rad_s: float) -> tuple[float, float, float, float]:
        """The dynamic window (:func:`~jackson.host.nav.dwb.core.window.dynamic_window`).

        Parameters
        ----------
        v_m_s, w_rad_s : float
            Current velocity [m/s], [rad/s].

        Returns
        -------
        tuple of float
            (v_lo, v_hi, w_lo, w_hi) [m/s], [m/s], [rad/s], [rad/s].
        """
        return dynamic_window(self.config, self.kinematics, v_m_s, w_rad_s)

    def samples(self, v_m_s: float, w_rad_s: float) -> tuple[FloatArray, FloatArray, float]:
        """The window's targets (:func:`~jackson.host.nav.dwb.core.window.sample_targets`).

        Parameters
        ----------
        v_m_s, w_rad_s : float
            Current velocity [m/s], [rad/s].

        Returns
        -------
        tuple
            (v (M,), w (M,), slowest v of the window).
        """
        return sample_targets(self.config, self.kinematics, v_m_s, w_rad_s)

    def rollout(
        self, pose: Pose2D, velocity: tuple[float, float], v: FloatArray, w: FloatArray
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """Every pose of every roll-out (:meth:`compute` evaluates only the poses it reads).

        Parameters
        ----------
        pose : Pose2D
            Start pose (map frame).
        velocity : tuple of float
            Current (v [m/s], w [rad/s]).
        v, w : ndarray, shape (M,)
            Targets [m/s], [rad/s].

        Returns
        -------
        tuple of ndarray
            (x (M, K+1), y (M, K+1), yaw (M, K+1), t (K+1,)), the start pose first.
        """
        ro = self.rollouts(pose, velocity, v, w)
        x, y, yaw = ro.full()
        return x, y, yaw, ro.t_s

    def rollouts(
        self, pose: Pose2D, velocity: tuple[float, float], v: FloatArray, w: FloatArray
    ) -> Rollouts:
        """The roll-outs, factored (:func:`~jackson.host.nav.dwb.core.rollouts.build_rollouts`).

        Parameters
        ----------
        pose : Pose2D
            Start pose (map frame).
        velocity : tuple of float
            Current (v [m/s], w [rad/s]).
        v, w : ndarray, shape (M,)
            Targets [m/s], [rad/s].

        Returns
        -------
        Rollouts
            Evaluated on demand.
        """
        return build_rollouts(self.config, self.kinematics, pose, velocity, v, w)

    # ------------------------------------------------------------------ scoring

    def compute(
        self,
        pose: Pose2D,
        velocity: tuple[float, float],
        path: npt.ArrayLike,
        goal: Pose2D,
        costmap: Costmap,
    ) -> Command:
        """Choose the command for this control period.

        Parameters
        ----------
        pose : Pose2D
            Robot pose in the costmap's (map) frame.
        velocity : tuple of float
            Current (v [m/s], w [rad/s]).
        path : array_like, shape (N, 2)
            The global path [m], map frame.
        goal : Pose2D
            The goal pose.
        costmap : Costmap
            The local costmap.

        Returns
        -------
        Command
            The best legal command, or an invalid one with the reason.
        """
        v0, w0 = float(velocity[0]), float(velocity[1])
        made = front(self._layout(), pose, (v0, w0), costmap)
        if made is None:
            v, w, v_brake = self.samples(v0, w0)
            ro = self.rollouts(pose, (v0, w0), v, w)
            batch = Batch.of(v, w, v_brake, ro, costmap)
        else:
            ro, batch = made
            v, w = batch.v_m_s, batch.w_rad_s
        m = v.shape[0]
        context = Context(
            pose, (v0, w0), goal, costmap, self._plan_cells(pose, path, costmap), self._maps
        )
        unprepared = [critic.name for critic in self.critics if not critic.prepare(context)]
        if unprepared:
            reason = NO_PATH if context.plan is None else "not prepared: " + ", ".join(unprepared)
            return Command(0.0, 0.0, np.empty((0, 3)), valid=False, samples=m, reason=reason)
        deferred = self._deferred if self.config.short_circuit_trajectory_evaluation else {}
        scored: list[tuple[FloatArray, BoolArray | None]] = [
            (deferred[i].raw_scores(batch), None) if i in deferred else critic.score(batch)
            for i, critic in enumerate(self.critics)
        ]
        scales = [critic.scale for critic in self.critics]
        all_ok = np.ones(m, bool)
        for _, legal in scored:
            if legal is not None:
                all_ok &= legal
        total = np.zeros(m)
        for scale, (raw, _) in zip(scales, scored, strict=True):
            if scale != 0.0:
                total += scale * raw
        best, rejected = self._choose(batch, total, all_ok, deferred)
        if best < 0:  # none legal: every critic's legality of every roll-out, for the reason
            scored = [
                (raw, self.critics[i].score(batch)[1] if legal is None else legal)
                for i, (raw, legal) in enumerate(scored)
            ]
            shares = ", ".join(
                f"{critic.name} {100.0 * np.mean(~legal):.0f}%"
                for critic, (_, legal) in zip(self.critics, scored, strict=True)
                if legal is not None and np.any(~legal)
            )
            return Command(
                0.0, 0.0, np.empty((0, 3)), valid=False, samples=m,
                reason=f"no legal trajectory of {m} ({shares})",
            )  # fmt: skip
        scores = {
            critic.name: float(scale * raw[best])
            for critic, scale, (raw, _) in zip(self.critics, scales, scored, strict=True)
        }
        command = Command(
            float(v[best]), float(w[best]), ro.trajectory(best), scores,
            float(total[best]), True, "", m, int(np.count_nonzero(all_ok)) - rejected,
        )  # fmt: skip
        for critic in self.critics:
            critic.debrief(command)
        return command

    def _choose(
        self,
        batch: Batch,
        total: FloatArray,
        all_ok: BoolArray,
        deferred: Mapping[int, DeferredLegality],
    ) -> tuple[int, int]:
        """The roll-out of least total that every critic finds legal, the lowest index of
        equals (``all_ok``: the legality of the critics not deferred), and how many roll-outs
        the deferred critics were found to reject on the way; (-1, 0) when none is legal.

        Without deferred critics, the arg-min of the legal totals. With them, the roll-outs
        legal so far in order of (total, index), each deferred critic asked where the first
        one it allows is, from the position all agree on so far, until they all allow the
        same one: the same roll-out as testing them all, asking only as far as needed.
        """
        if not all_ok.any():
            return -1, 0
        if not deferred:
            return int(np.where(all_ok, total, np.inf).argmin()), 0
        candidates = np.flatnonzero(all_ok)
        order = candidates[np.argsort(total[candidates], kind="stable")]
        allowed: dict[int, int] = {}  # critic -> the position it allows
        at = 0
        while at < len(order):
            for key, critic in deferred.items():
                if allowed.get(key) != at:
                    found = critic.first_legal(batch, order[at:])
                    if found < 0:
                        return -1, 0
                    at += found
                    allowed[key] = at
            if all(allowed[key] == at for key in deferred):
                return int(order[at]), at
        return -1, 0

    def _layout(self) -> FrontLayout:
        """The compiled front's layout for the present bounds."""
        layout = self._front
        if layout is None or layout.kinematics is not self.kinematics:
            layout = self._front = FrontLayout.of(self.config, self.kinematics)
        return layout

    def _plan_cells(self, pose: Pose2D, path: npt.ArrayLike, costmap: Costmap) -> PlanCells | None:
        """The global path's cells in the window
        (:func:`~jackson.host.nav.dwb.core.path.plan_cells`): compiled, made each cycle; with
        numpy, kept while the costmap and the slice of the path stay the same."""
        full = np.asarray(path, np.float64).reshape(-1, 2)
        if len(full) == 0:
            return None
        c = self.config
        if native.LIB is not None:  # the same slice and cells, in one call
            found = native_grid.dwb_plan_cells(
                full, (pose.x, pose.y), (c.prune_distance_m, c.forward_prune_distance_m),
                costmap.geometry.as_tuple(), costmap.costs_padded,
            )  # fmt: skip
            return None if found is None else PlanCells(*found[1:])
        span = plan_span(pose, full, costmap, c.prune_distance_m, c.forward_prune_distance_m)
        key = (id(costmap), costmap.version, span, full.tobytes())
        if key != self._plan_key:
            self._plan_key = key
            self._plan = plan_cells(full, span, costmap)
        return self._plan


def _deferred(critics: Sequence[Critic]) -> dict[int, DeferredLegality]:
    """The critics whose legality may be asked about only as far as the choice needs, by their
    position in the list."""
    return {i: c for i, c in enumerate(critics) if isinstance(c, DeferredLegality)}
