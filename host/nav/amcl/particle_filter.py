"""The particle filter: Nav2's ``pf`` with its motion and sensor models, in AMCL's role.

:class:`ParticleFilter` holds the particles, their weights and the odometry they belong to, and
runs one filter update per scan when the robot has moved far enough: the motion model
(:mod:`~jackson.host.nav.amcl.motion_model`), the likelihood field
(:mod:`~jackson.host.nav.amcl.sensor_model`), low-variance resampling
(:mod:`~jackson.host.nav.amcl.resample`) with a KLD-sampled count
(:mod:`~jackson.host.nav.amcl.kld`) and, when the recovery alphas are set, random particles
injected while the measurement fits worse than it used to (augmented MCL). Its outputs are the
estimate (the heaviest cluster's weighted mean), its covariance and the ``map -> odom``
correction.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from jackson.common.geometry import wrap_angle, wrap_angles
from jackson.host.nav import native
from jackson.host.nav.amcl.config import AmclConfig, LocalizationError
from jackson.host.nav.amcl.kld import heaviest_cluster, histogram_bins, kld_sample_count
from jackson.host.nav.amcl.motion_model import sample_motion_model_odometry
from jackson.host.nav.amcl.resample import systematic_resample
from jackson.host.nav.amcl.sensor_model import (
    beam_cubes,
    beam_end_points,
    likelihood_field_model,
)
from jackson.host.nav.grid import FREE, OccupancyGrid
from jackson.host.nav.likelihood import LikelihoodField
from jackson.host.nav.types import Pose2D, Scan

FloatArray = npt.NDArray[np.float64]

IDENTITY_POSE = Pose2D()
"""The sensor at the base's origin (the default mount)."""


class ParticleFilter:
    """Monte Carlo localization of the robot's base on a known occupancy grid (AMCL's role).

    Call :meth:`initialise` with the pose the robot starts from, then :meth:`update` with every
    odometry pose (and the scan taken there, when there is one). The particles move and are
    weighed only when the robot has moved ``update_min_d`` or turned ``update_min_a`` since the
    last sensor update (or at the first scan): the odometry model's noise grows with the square
    of each step, so sampling it over the whole change, as AMCL does, keeps the cloud's growth
    independent of how often ``update`` is called. Between filter updates the pose follows
    odometry through the ``map -> odom`` correction.

    The estimate is AMCL's: the weighted mean of the cluster of particles holding the most
    weight (clusters are touching histogram bins). While the cloud has one mode this is the
    mean of all particles; when it has several (after random injection, or in a symmetric
    room) it is the mean of the likeliest one rather than a point between them.

    Parameters
    ----------
    grid : OccupancyGrid
        The map.
    config : AmclConfig
        Parameters.
    rng : numpy.random.Generator
        The only source of randomness.

    Attributes
    ----------
    sensor_updates : int
        Scans weighed so far.
    resamples : int
        Resampling steps so far.
    motion_updates : int
        Motion-model samplings so far.
    injected : int
        Random particles injected so far (0 unless the recovery alphas are set).
    """

    def __init__(self, grid: OccupancyGrid, config: AmclConfig, rng: np.random.Generator) -> None:
        self._config = config
        self._rng = rng
        self._grid = grid
        self._field = LikelihoodField.from_grid(grid, config.laser_likelihood_max_dist)
        rows, cols = np.nonzero(grid.data == FREE)
        self._free_x, self._free_y = grid.cell_to_world(rows, cols)
        self._particles: FloatArray = np.zeros((0, 3))
        self._weights: FloatArray = np.zeros(0)
        self._stats: tuple[Pose2D, FloatArray] | None = None
        self._odom_particles: Pose2D | None = None  # odometry the particles belong to
        self._odom_sensor: Pose2D | None = None  # odometry at the last sensor update
        self._odom_latest: Pose2D | None = None
        self._w_slow = 0.0
        self._w_fast = 0.0
        self.sensor_updates = 0
        self.resamples = 0
        self.motion_updates = 0
        self.injected = 0

    # each padded cell's beam score cubed, made at the first weighing with the compiled library
    # (not pickled: a snapshot stays the map's size; a filter pickled before it existed has none)
    _cubes: FloatArray | None = None

    def __getstate__(self) -> dict[str, object]:
        state = dict(self.__dict__)
        state.pop("_cubes", None)
        return state

    # ------------------------------------------------------------------ state

    @property
    def config(self) -> AmclConfig:
        """The parameters."""
        return self._config

    @property
    def particle_count(self) -> int:
        """Particles in the set now."""
        return len(self._particles)

    @property
    def particles(self) -> FloatArray:
        """A copy of the particles, shape (N, 3): ``x [m], y [m], yaw [rad]`` in the map."""
        return self._particles.copy()

    @property
    def weights(self) -> FloatArray:
        """A copy of the normalised weights, shape (N,)."""
        return self._weights.copy()

    def initialise(self, pose: Pose2D, std_xy_m: float = 0.1, std_yaw_rad: float = 0.1) -> None:
        """Spread ``max_particles`` particles normally around ``pose`` (as AMCL's initial pose).

        The pose is where the robot is at the odometry pose of the next :meth:`update` call;
        the counters restart.

        Parameters
        ----------
        pose : Pose2D
            The robot's base in the map frame.
        std_xy_m : float
            Standard deviation of x and y [m].
        std_yaw_rad : float
            Standard deviation of the yaw [rad].

        Raises
        ------
        ValueError
            A negative or non-finite standard deviation.
        """
        for name, value in (("std_xy_m", std_xy_m), ("std_yaw_rad", std_yaw_rad)):
            if not 0.0 <= value < math.inf:
                raise ValueError(f"{name}: expected a finite number >= 0, got {value}")
        n = self._config.max_particles
        draws = self._rng.standard_normal((n, 3))
        draws *= (std_xy_m, std_xy_m, std_yaw_rad)
        draws += (pose.x, pose.y, pose.yaw)
        draws[:, 2] = wrap_angles(draws[:, 2])
        self._particles = draws
        self._weights = np.full(n, 1.0 / n)
        self._stats = None
        self._odom_particles = self._odom_sensor = self._odom_latest = None
        self._w_slow = self._w_fast = 0.0
        self.sensor_updates = self.resamples = self.motion_updates = self.injected = 0

    def _require_initialised(self) -> None:
        if len(self._particles) == 0:
            raise LocalizationError("the particle filter has no pose yet: call initialise()")

    # ------------------------------------------------------------------ updates

    def predict(self, odom_pose: Pose2D) -> None:
        """Move the particles by the odometry change since they last moved (the motion update).

        The first call after :meth:`initialise` only anchors the particles to this odometry
        pose. :meth:`update` calls this before each sensor update.

        Parameters
        ----------
        odom_pose : Pose2D
            The robot's odometry pose (odometry frame).

        Raises
        ------
        LocalizationError
            Before :meth:`initialise`.
        """
        self._require_initialised()
        if self._odom_particles is not None and odom_pose != self._odom_particles:
            c = self._config
            self._particles = sample_motion_model_odometry(
                self._particles,
                self._odom_particles,
                odom_pose,
                (c.alpha1, c.alpha2, c.alpha3, c.alpha4),
                self._rng,
            )
            self._stats = None
            self.motion_updates += 1
        self._odom_particles = odom_pose
        self._odom_latest = odom_pose

    def update(self, odom_pose: Pose2D, scan: Scan | None, mount: Pose2D = IDENTITY_POSE) -> bool:
        """Take one odometry pose and, when there is one, the scan taken there.

        When the robot has moved ``update_min_d`` or turned ``update_min_a`` since the last
        sensor update (or this is the first scan), the particles move (:meth:`predict`), are
        weighed against the scan and, every ``resample_interval`` sensor updates, resampled.

        Parameters
        ----------
        odom_pose : Pose2D
            The robot's odometry pose at the time of the scan (odometry frame).
        scan : Scan or None
            The scan, or None for odometry alone.
        mount : Pose2D
            The sensor's pose on the robot's base.

        Returns
        -------
        bool
            Whether a sensor update happened.

        Raises
        ------
        LocalizationError
            Before :meth:`initialise`.
        """
        self._require_initialised()
        if self._odom_particles is None:
            self._odom_particles = odom_pose
        self._odom_latest = odom_pose
        if scan is None:
            return False
        if self._odom_sensor is not None and not self._moved_enough(self._odom_sensor, odom_pose):
            return False
        self.predict(odom_pose)
        c = self._config
        beams = beam_end_points(scan, mount, c.laser_min_range, c.laser_max_range, c.max_beams)
        if beams is None:
            return False
        self._weigh(beams)
        self._odom_sensor = odom_pose
        self.sensor_updates += 1
        if self.sensor_updates % self._config.resample_interval == 0:
            self._resample()
        return True

    def _moved_enough(self, before: Pose2D, after: Pose2D) -> bool:
        c = self._config
        return (
            before.distance(after) >= c.update_min_d
            or abs(wrap_angle(after.yaw - before.yaw)) >= c.update_min_a
        )

    def _weigh(self, beams: FloatArray) -> None:
        """Multiply the weights by the likelihood field and normalise them."""
        c = self._config
        if native.LIB is not None and self._cubes is None:
            self._cubes = beam_cubes(self._field, c.z_hit, c.z_rand, c.sigma_hit, c.laser_max_range)
        likelihood = likelihood_field_model(
            self._particles,
            beams,
            self._field,
            c.z_hit,
            c.z_rand,
            c.sigma_hit,
            c.laser_max_range,
            self._cubes,
        )
        weighted = self._weights * likelihood
        total = float(weighted.sum())
        self._weights = weighted / total
        self._stats = None
        if c.recovery_alpha_slow > 0.0 or c.recovery_alpha_fast > 0.0:
            # ``total`` is the weighted mean likelihood: the measurement's fit to the set.
            if self._w_slow == 0.0:
                self._w_slow = self._w_fast = total
            else:
                self._w_slow += c.recovery_alpha_slow * (total - self._w_slow)
                self._w_fast += c.recovery_alpha_fast * (total - self._w_fast)

    def _resample(self) -> None:
        """Low-variance resampling with a KLD-sampled count and optional random injection.

        ``max_particles`` systematic draws are shuffled and taken in that order until the
        draws so far fill enough histogram bins to need no more (:func:`kld_sample_count`);
        shuffling makes each prefix a fair sample of the weights.
        """
        c = self._config
        m = c.max_particles
        draws = self._particles[systematic_resample(self._weights, m, self._rng)]
        draws = draws[self._rng.permutation(m)]
        w_diff = 0.0
        if self._w_slow > 0.0:
            w_diff = max(0.0, 1.0 - self._w_fast / self._w_slow)
        random: npt.NDArray[np.bool_] = np.zeros(m, np.bool_)
        if w_diff > 0.0 and len(self._free_x) > 0:
            random = self._rng.random(m) < w_diff
            k = int(random.sum())
            cells = self._rng.integers(0, len(self._free_x), k)
            jitter = (self._rng.random((k, 2)) - 0.5) * self._grid.resolution_m
            draws[random, 0] = self._free_x[cells] + jitter[:, 0]
            draws[random, 1] = self._free_y[cells] + jitter[:, 1]
            draws[random, 2] = self._rng.uniform(-math.pi, math.pi, k)
            self._w_slow = self._w_fast = 0.0  # as AMCL: restart the averages after injecting
        n = kld_sample_count(
            draws, c.kld_bin_xy_m, c.kld_bin_yaw_rad, c.pf_err, c.pf_z, c.min_particles
        )
        self._particles = np.ascontiguousarray(draws[:n])
        self._weights = np.full(n, 1.0 / n)
        self._stats = None
        self.injected += int(np.count_nonzero(random[:n]))
        self.resamples += 1

    # ------------------------------------------------------------------ outputs

    def _statistics(self) -> tuple[Pose2D, FloatArray]:
        """Weighted mean and covariance of the heaviest cluster (cached until the set changes)."""
        if self._stats is None:
            c = self._config
            bins, yaw_bins = histogram_bins(self._particles, c.kld_bin_xy_m, c.kld_bin_yaw_rad)
            members = heaviest_cluster(bins, yaw_bins, self._weights)
            p = self._particles[members]
            w = self._weights[members] / self._weights[members].sum()
            yaw = math.atan2(float(w @ np.sin(p[:, 2])), float(w @ np.cos(p[:, 2])))
            mean = Pose2D(float(w @ p[:, 0]), float(w @ p[:, 1]), yaw)
            dev = p - (mean.x, mean.y, mean.yaw)
            dev[:, 2] = wrap_angles(dev[:, 2])
            self._stats = (mean, np.asarray((dev * w[:, None]).T @ dev, np.float64))
        return self._stats

    def estimate(self) -> Pose2D:
        """The robot's base in the map at the latest odometry pose given.

        The weighted mean of the heaviest cluster (circular mean for the yaw), carried from the
        odometry pose the particles belong to to the latest one by the odometry change between
        them (exactly the cluster's mean right after a sensor update).

        Raises
        ------
        LocalizationError
            Before :meth:`initialise`.
        """
        self._require_initialised()
        mean = self._statistics()[0]
        if self._odom_particles is None or self._odom_latest is None:
            return mean
        return mean.compose(self._odom_particles.inverse().compose(self._odom_latest))

    def covariance(self) -> FloatArray:
        """Weighted covariance of the heaviest cluster, 3x3 over ``(x [m], y [m], yaw [rad])``.

        The yaw deviations are taken about the circular mean, wrapped to [-pi, pi). It belongs
        to the last filter update (it does not grow between them).

        Raises
        ------
        LocalizationError
            Before :meth:`initialise`.
        """
        self._require_initialised()
        return self._statistics()[1].copy()

    def map_to_odom(self, odom_pose: Pose2D) -> Pose2D:
        """The ``map -> odom`` correction: ``estimate ⊕ odom_pose⁻¹``.

        Composed with the odometry pose (``map_to_odom(odom) ⊕ odom``) it gives the estimate;
        published as a transform it places the odometry frame in the map.

        Parameters
        ----------
        odom_pose : Pose2D
            The odometry pose the estimate belongs to (the latest one given to :meth:`update`).

        Raises
        ------
        LocalizationError
            Before :meth:`initialise`.
        """
        return self.estimate().compose(odom_pose.inverse())
