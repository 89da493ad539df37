"""Localization on a known map: a particle filter in the role of Nav2's AMCL.

The filter keeps a set of pose hypotheses (particles) of the robot's base in the map frame and
follows Probabilistic Robotics (Thrun, Burgard, Fox), as AMCL does. Its parts sit in one module
each, as nav2_amcl's do:

* :mod:`~jackson.host.nav.amcl.config`: the parameters, named as Nav2's ``amcl`` parameters;
* :mod:`~jackson.host.nav.amcl.motion_model`: ``sample_motion_model_odometry`` (Table 5.6), the
  differential model, sampled once per filter update on the odometry change since the
  previous one;
* :mod:`~jackson.host.nav.amcl.sensor_model`: the likelihood field (Table 6.3) over
  ``max_beams`` beams, each beam ``p = z_hit exp(-d^2 / 2 sigma_hit^2) + z_rand /
  laser_max_range`` with ``d`` the distance from its end point to the nearest occupied cell
  (read off the map's :class:`~jackson.host.nav.likelihood.LikelihoodField`), the beams
  combined as AMCL combines them, ``1 + sum p^3``;
* :mod:`~jackson.host.nav.amcl.resample`: low-variance (systematic) resampling (Table 4.4);
* :mod:`~jackson.host.nav.amcl.kld`: KLD sampling (Fox 2003) for the particle count over the
  histogram bins of AMCL's kd-tree (0.5 m, 0.5 m, 10 degrees), and the clusters of those bins;
* :mod:`~jackson.host.nav.amcl.particle_filter`: the filter that runs them, with optional
  random-particle injection (augmented MCL, Table 8.3, off by default as in Nav2) and AMCL's
  estimate, the weighted mean of the heaviest cluster of particles.

Its output is the correction AMCL publishes as the ``map -> odom`` transform: the pose estimate
composed with the inverse of the odometry pose it belongs to, so that ``map_to_odom ⊕ odom``
places the robot in the map between filter updates as well.

All randomness comes from the ``numpy.random.Generator`` passed in: the same seed and the same
inputs give bit-identical particles and estimates. All particles and beams are handled at once
with numpy (no per-particle Python loop).
"""

from __future__ import annotations

from jackson.host.nav.amcl.config import AmclConfig, LocalizationError
from jackson.host.nav.amcl.kld import (
    heaviest_cluster,
    histogram_bins,
    kld_particle_limit,
    kld_sample_count,
)
from jackson.host.nav.amcl.motion_model import sample_motion_model_odometry
from jackson.host.nav.amcl.particle_filter import ParticleFilter
from jackson.host.nav.amcl.resample import systematic_resample
from jackson.host.nav.amcl.sensor_model import (
    beam_end_points,
    likelihood_field_model,
    likelihood_field_weights,
)

__all__ = [
    "AmclConfig",
    "LocalizationError",
    "ParticleFilter",
    "beam_end_points",
    "heaviest_cluster",
    "histogram_bins",
    "kld_particle_limit",
    "kld_sample_count",
    "likelihood_field_model",
    "likelihood_field_weights",
    "sample_motion_model_odometry",
    "systematic_resample",
]
