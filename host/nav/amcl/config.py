"""The particle filter's parameters, named as Nav2's ``amcl`` parameters, and its error.

One frozen dataclass holds every number the filter uses: the motion model's ``alpha1``-``alpha4``,
the likelihood field's ``z_hit``, ``z_rand``, ``sigma_hit`` and distance cap, the beams and
ranges taken from a scan, when the filter updates, and the bounds and bins of KLD sampling. The
ROS bringup's ``amcl`` parameters are checked against these defaults, so the host's filter and
Nav2's are configured alike.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from jackson.common.errors import JacksonError


class LocalizationError(JacksonError, RuntimeError):
    """The filter was used before :meth:`ParticleFilter.initialise` gave it a pose."""


@dataclass(frozen=True)
class AmclConfig:
    """Parameters of :class:`ParticleFilter`, named as Nav2's ``amcl`` parameters.

    Defaults are Nav2's (``nav2_bringup`` ``nav2_params.yaml``) except where a line says why.

    Attributes
    ----------
    min_particles, max_particles : int
        Bounds of the KLD-sampled particle count (Nav2 default 500, 2000).
    alpha1 : float
        Rotation noise from rotation (Nav2 default 0.2).
    alpha2 : float
        Rotation noise from translation (Nav2 default 0.2).
    alpha3 : float
        Translation noise from translation. 0.05 here, Nav2 0.2: this robot's odometry (the
        EKF's ``odom`` frame) errs by 0.6 mm rms over a 5 cm update (0.9 %, fitted alpha3
        5e-5, alpha4 2e-4 on a ring_block patrol's bags against the twin's truth), and 0.2
        spreads the cloud by 45 % of each step along the robot's path. Where the scans say
        nothing about the position along a corridor, that spread and the resampling make the
        estimate wander: on ring_block's 18 m south corridor the localisation error's p99 was
        10-12 cm with 0.2 and 8-9 cm with 0.05 (30-goal patrols on two built maps; 0.02 did no
        better). 0.05 still allows 22 % of a step, twenty times the twin's error, for floors
        and tyres worse than the twin's.
    alpha4 : float
        Translation noise from rotation. 0.05 here, Nav2 0.2 (see ``alpha3``). The rotation
        noises ``alpha1``, ``alpha2`` keep Nav2's 0.2: lowering them too made the patrol
        worse (p99 10.6 cm against 7.8 cm), heading being what the robot's odometry gets wrong
        most.
    z_hit, z_rand : float
        Mixture weights of the likelihood field's Gaussian and uniform parts (Nav2 default 0.5,
        0.5).
    sigma_hit : float
        Standard deviation of the Gaussian part [m] (Nav2 default 0.2).
    laser_likelihood_max_dist : float
        Distances to the nearest obstacle are capped here [m] (Nav2 default 2.0).
    max_beams : int
        Beams used per sensor update, evenly spread over the valid returns (Nav2 default 60).
    laser_min_range, laser_max_range : float
        Returns outside [min, max) are ignored [m]. REFERENCE: the A1M8's 0.15 m minimum and
        the robot's 8 m software cap (Nav2's defaults, -1 and 100, defer to the scan).
    update_min_d : float
        Translation since the last sensor update that triggers the next one [m]. 0.05 here,
        Nav2 0.25: the robot drives at about 0.08 m/s through a maze whose route is 1.9 m
        long (REFERENCE: Stage 3), so 0.25 m would give one update every 3 s and seven on the
        whole route; 0.05 m gives one about every 0.6 s (every fourth or fifth scan).
    update_min_a : float
        Rotation since the last sensor update that triggers the next one [rad]. 0.1 here, Nav2
        0.2: the robot turns in place at the corners of a small maze, where a 0.2 rad
        (11 degree) turn already moves a wall 2 m away by 0.4 m.
    resample_interval : int
        Resample after every this many sensor updates (Nav2 default 1).
    pf_err : float
        KLD bound on the error between the true and the sampled distribution (Nav2 default
        0.05).
    pf_z : float
        The normal quantile ``z`` in the KLD bound, used as AMCL uses its ``pf_z`` (the value
        enters the bound directly; Nav2 default 0.99).
    kld_bin_xy_m, kld_bin_yaw_rad : float
        Histogram bin of the KLD count [m], [rad] (AMCL's kd-tree: 0.5 m, 10 degrees).
    recovery_alpha_slow, recovery_alpha_fast : float
        Decay rates of the slow and fast averages of the measurement likelihood; random
        particles are injected when the fast one drops below the slow one (augmented MCL).
        0 turns injection off (Nav2 default 0, 0).
    """

    min_particles: int = 500
    max_particles: int = 2000
    alpha1: float = 0.2
    alpha2: float = 0.2
    alpha3: float = 0.05
    alpha4: float = 0.05
    z_hit: float = 0.5
    z_rand: float = 0.5
    sigma_hit: float = 0.2
    laser_likelihood_max_dist: float = 2.0
    max_beams: int = 60
    laser_min_range: float = 0.15
    laser_max_range: float = 8.0
    update_min_d: float = 0.05
    update_min_a: float = 0.1
    resample_interval: int = 1
    pf_err: float = 0.05
    pf_z: float = 0.99
    kld_bin_xy_m: float = 0.5
    kld_bin_yaw_rad: float = math.radians(10.0)
    recovery_alpha_slow: float = 0.0
    recovery_alpha_fast: float = 0.0

    def __post_init__(self) -> None:
        if self.min_particles < 1:
            raise ValueError(f"min_particles: expected >= 1, got {self.min_particles}")
        if self.max_particles < self.min_particles:
            raise ValueError(
                f"max_particles: expected >= min_particles {self.min_particles}, "
                f"got {self.max_particles}"
            )
        for name in ("alpha1", "alpha2", "alpha3", "alpha4", "z_hit", "z_rand"):
            value = getattr(self, name)
            if not 0.0 <= value < math.inf:
                raise ValueError(f"{name}: expected a finite number >= 0, got {value}")
        if self.z_hit + self.z_rand <= 0.0:
            raise ValueError("z_hit: z_hit + z_rand must be > 0")
        for name in (
            "sigma_hit",
            "laser_likelihood_max_dist",
            "pf_err",
            "pf_z",
            "kld_bin_xy_m",
            "kld_bin_yaw_rad",
        ):
            value = getattr(self, name)
            if not 0.0 < value < math.inf:
                raise ValueError(f"{name}: expected a finite number > 0, got {value}")
        if self.max_beams < 2:
            raise ValueError(f"max_beams: expected >= 2, got {self.max_beams}")
        if not 0.0 <= self.laser_min_range < self.laser_max_range < math.inf:
            raise ValueError(
                f"laser_max_range: expected 0 <= laser_min_range < laser_max_range < inf, got "
                f"{self.laser_min_range} and {self.laser_max_range}"
            )
        for name in ("update_min_d", "update_min_a"):
            value = getattr(self, name)
            if not 0.0 <= value < math.inf:
                raise ValueError(f"{name}: expected a finite number >= 0, got {value}")
        if self.resample_interval < 1:
            raise ValueError(f"resample_interval: expected >= 1, got {self.resample_interval}")
        for name in ("recovery_alpha_slow", "recovery_alpha_fast"):
            value = getattr(self, name)
            if not 0.0 <= value <= 1.0:
                raise ValueError(f"{name}: expected a number in [0, 1], got {value}")
