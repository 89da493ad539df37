"""LiDAR noise: a revolution's range noise, from the second differences of neighbouring
returns, against the sensor's own ``lidar_noise_m``.

A smooth surface's second differences are nil at the A1M8's spacing, white noise's have a
variance of 6 sigma^2; edges are outliers, so sigma = 1.4826 median|d2| / sqrt(6) (at least
:data:`LIDAR_MIN_TRIPLETS` neighbouring returns). Beyond ``lidar_rough_factor`` x
``lidar_noise_m`` the LiDAR is ``suspect`` (its scans still used); beyond ``lidar_useless_m``
a scan is not used, and ``lidar_rough_scans`` of those in a row exclude it.
"""

from __future__ import annotations

import math

import numpy as np

from jackson.host.health.config import HealthConfig
from jackson.host.health.types import Finding, ScanInput, failing

LIDAR_MIN_TRIPLETS = 30  # neighbouring returns needed to judge a scan's noise


class LidarNoise:
    """A :class:`~jackson.host.health.check.Check` of revolutions (module docstring).

    Attributes
    ----------
    roughness_m : float
        The last judged scan's estimated range noise [m].
    smooth : bool
        The last scan passed (well inside the band: hysteresis).
    usable : bool
        The last scan is not too noisy to use.
    """

    def __init__(self, cfg: HealthConfig) -> None:
        self.cfg = cfg
        self.roughness_m = 0.0
        self.smooth = True
        self.usable = True
        self._useless = 0  # useless scans in a row

    def observe(self, x: ScanInput) -> list[Finding]:
        cfg, t_s = self.cfg, x.t_s
        found: list[Finding] = []
        r = np.asarray(x.ranges_m, dtype=float)
        ok = np.isfinite(r) & (r > 0.0)
        r = np.where(ok, r, 0.0)
        both = ok[:-2] & ok[1:-1] & ok[2:]
        self.usable = self.smooth = True
        if int(np.count_nonzero(both)) < LIDAR_MIN_TRIPLETS:
            return found
        d2 = (r[:-2] - 2.0 * r[1:-1] + r[2:])[both]
        sigma = float(1.4826 * np.median(np.abs(d2)) / math.sqrt(6.0))
        self.roughness_m = sigma
        if sigma > cfg.lidar_useless_m:
            self._useless += 1
            why = f"range noise {sigma * 100:.1f} cm: beyond {cfg.lidar_useless_m * 100:.0f} cm"
            exclude = self._useless >= cfg.lidar_rough_scans
            found.append(
                failing(
                    "lidar", t_s, why + (" scan after scan" if exclude else ""), exclude=exclude
                )
            )
            self.usable = self.smooth = False
            return found
        self._useless = 0
        if sigma > cfg.lidar_rough_factor * cfg.lidar_noise_m:
            why = (
                f"range noise {sigma * 100:.1f} cm: beyond {cfg.lidar_rough_factor:g} x "
                f"{cfg.lidar_noise_m * 100:.0f} cm"
            )
            found.append(failing("lidar", t_s, why, exclude=False))
            self.smooth = False
        elif sigma > 0.5 * cfg.lidar_rough_factor * cfg.lidar_noise_m + 0.5 * (cfg.lidar_noise_m):
            self.smooth = False  # hysteresis
        return found
