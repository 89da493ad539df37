"""The LiDAR's checks together, as the LiDAR's intake runs them
(:class:`~jackson.host.lidar.intake.ScanIntake`): its bytes (:mod:`.lidar_garbage`), each
revolution (its span, :mod:`.lidar_garbage`; its spacing, :mod:`.lidar_silence`; its noise,
:mod:`.lidar_noise`), and its port failing. The silence on each telemetry frame
(:meth:`LidarHealth.frame`) is judged with the frame's other checks, before the policy.

A scan may be used (mapping, localisation, the costmaps) unless it is too noisy to trust or
not a turn, garbage arrives, or the LiDAR is excluded. Every finding moves the ``lidar``
state of the monitor's :class:`~jackson.host.health.states.SensorStates`.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from jackson.host.health.config import HealthConfig
from jackson.host.health.lidar_garbage import LidarGarbage
from jackson.host.health.lidar_noise import LidarNoise
from jackson.host.health.lidar_silence import LidarSilence
from jackson.host.health.states import SensorStates
from jackson.host.health.types import (
    ByteCount,
    Finding,
    Health,
    LidarFrame,
    ScanInput,
    Transition,
    failing,
    passing,
)


class LidarHealth:
    """The LiDAR's checks and what they say of its scans (module docstring).

    Parameters
    ----------
    cfg : HealthConfig
        The ``lidar_*`` thresholds.
    states : SensorStates
        The monitor's states: the ``lidar`` one is moved here, the transitions recorded.

    Attributes
    ----------
    needed : bool
        A mission navigates by the scans (set by the intake at each frame that brings some):
        a LiDAR lost then stops it, a silence holds it.
    unused : int
        Scans not used so far.
    """

    def __init__(self, cfg: HealthConfig, states: SensorStates) -> None:
        self.cfg = cfg
        self.states = states
        self.needed = False
        self.unused = 0
        self.garbage = LidarGarbage(cfg)
        self.noise = LidarNoise(cfg)
        self.silence = LidarSilence(cfg, states)

    @property
    def blind(self) -> bool:
        """Navigating without a usable scan for too long: hold the robot (braked)."""
        return self.silence.blind

    @property
    def counts(self) -> dict[str, int]:
        """Scans judged and scans not used."""
        return {"scans": self.silence.scans, "unused": self.unused}

    @property
    def roughness_m(self) -> float:
        """The last judged scan's estimated range noise [m]."""
        return self.noise.roughness_m

    @property
    def missing(self) -> float:
        """Fraction of revolutions missing over the last window."""
        return self.silence.missing

    def bytes_read(self, t_s: float, received: int, malformed: int) -> None:
        """The LiDAR's bytes read before the frame of MCU time ``t_s``: ``received`` in all,
        ``malformed`` of them skipped by its decoder (:mod:`.lidar_garbage`). Garbage while a
        mission navigates holds it until clean scans come."""
        found = self.garbage.observe(ByteCount(t_s, received, malformed))
        if found and self.needed:
            self.silence.blind = True  # its scans cannot be trusted: hold until clean ones come
        self._commit(found)

    def scan(
        self,
        t_s: float,
        ranges_m: npt.NDArray[np.float64],
        angles_rad: npt.NDArray[np.float64] | None = None,
    ) -> bool:
        """Judge one revolution; whether the scan may be used.

        Parameters
        ----------
        t_s : float
            The scan's MCU time [s].
        ranges_m : ndarray of float
            Its ranges in the order measured [m]; ``inf`` (or 0) where there was no return.
        angles_rad : ndarray of float or None
            Its angles [rad]: a revolution spanning less than half a turn is not a turn
            (decoded garbage) and is not used.

        Returns
        -------
        bool
            False for a scan too noisy to trust or not a turn, while garbage arrives, and
            while the LiDAR is excluded.
        """
        x = ScanInput(t_s, ranges_m, angles_rad)
        turn = self.garbage.turn(x)
        if turn:
            self.unused += 1
            self._commit(turn)
            return False
        out: list[Transition] = []
        self.states.apply(self.silence.revolution(t_s) + self.noise.observe(x), out)
        if self.noise.smooth and self.silence.spacing_ok:
            self.states.apply([passing("lidar", t_s)], out)
        use = self.noise.usable
        if self.states["lidar"] is Health.EXCLUDED or self.garbage.since is not None:
            use = False
        if not use:
            self.unused += 1
        else:
            self.silence.used(t_s)
        self.states.commit(out)
        return use

    def gone(self, t_s: float, why: str) -> None:
        """The LiDAR's port failed (a read error: unplugged): excluded at once."""
        self._commit([failing("lidar", t_s, why, exclude=True)])

    def frame(self, t_s: float, speed_m_s: float) -> list[Finding]:
        """A telemetry frame: the silence check's findings (:mod:`.lidar_silence`), for the
        monitor to apply with the frame's others."""
        return self.silence.observe(LidarFrame(t_s, speed_m_s, self.needed))

    def host_stalled(self, t_s: float, stalled_s: float) -> None:
        """The daemon did not run for ``stalled_s`` wall seconds after its frame of MCU time
        ``t_s``: a silence it began is not the LiDAR's (:meth:`LidarSilence.host_stalled`)."""
        self.silence.host_stalled(t_s, stalled_s)

    def silence_limit_s(self) -> float:
        """How long the LiDAR may be silent now [s] (:meth:`LidarSilence.limit_s`)."""
        return self.silence.limit_s()

    def _commit(self, found: list[Finding]) -> None:
        out: list[Transition] = []
        self.states.apply(found, out)
        self.states.commit(out)
