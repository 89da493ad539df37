"""The wheel yaw model: what a healthy robot's wheels say of its yaw rate, w_e = s w_g + c v.

s is the scale of the wheels' yaw against the gyro's (tyre scrub and creep in turns), c a yaw
the wheels read per metre driven (unequal wheel radii or encoder scales). The yaw cross-check
(:mod:`jackson.host.health.yaw_check`) judges the residual w_e - (s w_g + c v) and teaches the
model while every sensor is ok; the isolation (:mod:`jackson.host.health.isolation`) reads it
to say what the wheels stand for; the policy hands its stand-in yaw rate to the EKF.
:func:`wheel_yaw_prior` is what the configured geometry says before any data.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from jackson.host.estimation.odometry import RobotGeometry
from jackson.host.health.config import HealthConfig


@dataclass(frozen=True)
class WheelYawPrior:
    """What the configured geometry says of the wheel yaw model before any data
    (:func:`wheel_yaw_prior`): s = 1 and c = 0, give or take these sigmas, within these bounds.

    Attributes
    ----------
    scale_sigma : float
        sigma_s0: one sigma of s about 1 [-].
    per_metre_sigma : float
        sigma_c0: one sigma of c about 0 [rad/m].
    scale_bounds : tuple of float
        1 -+ n sigma_s0: the scales a healthy robot can plausibly have [-].
    per_metre_bounds : tuple of float
        -+ n sigma_c0 [rad/m].
    """

    scale_sigma: float
    per_metre_sigma: float
    scale_bounds: tuple[float, float]
    per_metre_bounds: tuple[float, float]


def wheel_yaw_prior(cfg: HealthConfig, robot: RobotGeometry) -> WheelYawPrior:
    """The prior of the wheel yaw model from the configured geometry and its uncertainties.

    Each wheel reads its floor speed u_i as e_i u_i, with e_i = (r_i / r_i,cfg)^-1 (C_i / C_i,cfg)
    (its true rolling radius and counts per revolution against the configured ones), of relative
    sigma sigma_e^2 = sigma_r^2 + sigma_C^2, independently per wheel. With the effective track B'
    (scrub) against the configured B, the gyro's scale g (w_g = g w) and u_R,L = v +- w B' / 2,

        w_e = (e_R u_R - e_L u_L) / B = (e_mean B' / (B g)) w_g + ((e_R - e_L) / B) v

    so s = e_mean B' / (B g) and c = (e_R - e_L) / B, and to first order

        sigma_s0^2 = sigma_B^2 + sigma_g^2 + sigma_e^2 / 2,    sigma_c0^2 = 2 sigma_e^2 / B^2.

    The bounds are ``model_bound_sigmas`` of each sigma about s = 1, c = 0.

    Parameters
    ----------
    cfg : HealthConfig
        ``wheel_radius_uncertainty`` (sigma_r), ``ticks_per_rev_uncertainty`` (sigma_C),
        ``wheel_separation_uncertainty`` (sigma_B), ``gyro_scale_uncertainty`` (sigma_g),
        ``model_bound_sigmas`` (n).
    robot : RobotGeometry
        The configured geometry (B).

    Returns
    -------
    WheelYawPrior
        sigma_s0, sigma_c0 and the bounds.
    """
    var_e = cfg.wheel_radius_uncertainty**2 + cfg.ticks_per_rev_uncertainty**2
    sigma_s = math.sqrt(
        cfg.wheel_separation_uncertainty**2 + cfg.gyro_scale_uncertainty**2 + 0.5 * var_e
    )
    sigma_c = math.sqrt(2.0 * var_e) / robot.wheel_separation_m
    n = cfg.model_bound_sigmas
    return WheelYawPrior(
        scale_sigma=sigma_s,
        per_metre_sigma=sigma_c,
        scale_bounds=(1.0 - n * sigma_s, 1.0 + n * sigma_s),
        per_metre_bounds=(-n * sigma_c, n * sigma_c),
    )


class WheelYawModel:
    """What a healthy robot's wheels say of its yaw rate, learned while all sensors are ok:
    w_e = s w_g + c v.

    c is a yaw the wheels read per metre driven (unequal wheel radii or encoder scales: the
    paper's raw odometry drifts by it), s the scale of the wheels' yaw against the gyro's (tyre
    scrub and creep in turns). Each is a scalar Kalman filter (recursive least squares) started
    at its prior (:func:`wheel_yaw_prior`: s0 = 1, c0 = 0 with variances P0 = sigma_0^2), so the
    first samples move it only by the weight their information has against the prior's:

        K = P h / (h^2 P + R),   theta <- theta + K (y - h theta),   P <- (1 - K h)^2 P + K^2 R

    until the term is identified (below), then the same with K h capped at dt / ``tau_s``: a
    low-pass over ``tau_s`` of driving, which a slow fault (a bias step) cannot move in the
    second the windowed test needs. For c, y = w_e - s w_g, h = v and R = R_0 + P_s w_g^2 (the
    scale's own uncertainty); for s, y = w_e - c v, h = w_g and R = R_0 + P_c v^2, so that an
    arc of curvature kappa informs s with c's error P_c / kappa^2: s is learned from tight
    turns until c is known. R_0 is the sample's noise (:meth:`learn`). Before each sample P
    grows by the forgetting factor 1 / lambda, lambda = 1 - dt / ``tau_s``, never beyond P0.

    **Identifiability.** c is learned only from nearly straight driving (curvature
    |w_g / v| <= 0.3 rad/m and |v| >= 0.1 m/s: there s w_g is small against c v, and its error
    is counted in R), s only from turns (|w_g| > 0.1 rad/s), and either only from steady samples
    (the gyro's rate changed by less than 0.5 rad/s^2: under angular acceleration the tyres
    creep and the wheels' frame mean lags the gyro's sample) whose innovation is within 3 sigma
    of its prediction (h^2 P + R: a slip is not the robot's geometry). A term keeps its prior
    (s = 1 or c = 0, variance P0) until it is identified: at least 20 samples, covering 0.5 rad
    of turn (s) or 2 m of driving (c), that carry 4 times the prior's information
    (sum h^2 / R >= 4 / P0: a posterior sigma under 0.45 of the prior's), so that one transient
    cannot make the model. Each stays within its bounds. A robot that never drives straight
    keeps c = 0 and its s absorbs c v / w (:attr:`absorbed`); learning them apart keeps a gyro
    bias step out of both over the second the windowed test needs.
    """

    IDENTIFY_SAMPLES = 20  # samples a term needs before it leaves its prior ...
    IDENTIFY_SPAN = (0.5, 2.0)  # ... the turn [rad] (s) and the distance [m] (c) they cover ...
    IDENTIFY_INFORMATION = 4.0  # ... and the information they carry, in prior informations
    STRAIGHT_CURVATURE = 0.3  # [rad/m] c is learned below this curvature |w_g / v| ...
    STRAIGHT_SPEED = 0.1  # [m/s] ... and above this speed
    TURN_RATE = 0.1  # [rad/s] s is learned above this gyro rate
    STEADY_ALPHA = 0.5  # [rad/s^2] learned only while the gyro's rate changes less than this
    LEARN_GATE = 3.0  # [sigma] innovations beyond this are not learned

    def __init__(self, tau_s: float, prior: WheelYawPrior | None = None) -> None:
        self.tau_s = tau_s
        if prior is None:
            prior = wheel_yaw_prior(HealthConfig(), RobotGeometry())
        self.prior = p = prior
        self._center = (1.0, 0.0)
        self._p0 = (p.scale_sigma**2, p.per_metre_sigma**2)
        self._bounds = (p.scale_bounds, p.per_metre_bounds)
        self._est = [1.0, 0.0]  # the filters' s and c
        self._var = list(self._p0)  # their variances
        self._info = [0.0, 0.0]  # information of the data learned (forgotten as P is)
        self._n = [0, 0]  # samples learned
        self._cross = 0.0  # sum(w_g v / R) over the scale's samples, forgotten as _info[0]
        self._span = [0.0, 0.0]  # [rad] turned and [m] driven by the samples learned
        self.identified = [False, False]  # s, c have left their priors

    @property
    def scale(self) -> float:
        """s: the filter's once identified, the prior's 1 before."""
        return self._est[0] if self.identified[0] else self._center[0]

    @property
    def per_metre(self) -> float:
        """c [rad/m]: the filter's once identified, the prior's 0 before."""
        return self._est[1] if self.identified[1] else self._center[1]

    @property
    def scale_variance(self) -> float:
        """P_s: the variance of :attr:`scale` (the prior's until identified)."""
        return self._var[0] if self.identified[0] else self._p0[0]

    @property
    def per_metre_variance(self) -> float:
        """P_c [(rad/m)^2]: the variance of :attr:`per_metre` (the prior's until identified)."""
        return self._var[1] if self.identified[1] else self._p0[1]

    @property
    def scale_learned(self) -> bool:
        """s is identified (before, it is the prior 1 +- 0.15 for the gates)."""
        return self.tau_s <= 0.0 or self.identified[0]

    def predict(self, wz: float, v: float) -> float:
        """The wheels' yaw rate a healthy robot shows at gyro rate wz and speed v."""
        return self.scale * wz + self.per_metre * v

    @property
    def absorbed(self) -> float:
        """rho = sum(w_g v / R) / sum(w_g^2 / R) over the scale's samples [m/rad]: while c is
        not identified, s has absorbed rho times c's error (s = sum(w_g y / R) / sum(w_g^2 / R))."""
        return self._cross / self._info[0] if self._info[0] > 0.0 else 0.0

    def variance(self, wz: float, v: float, *, prior: bool = True) -> float:
        """The variance of :meth:`predict` from the model's own uncertainty.

            P_s wz^2 + P_c v^2                       (both identified)
            P_s wz^2 + P0_c (v - rho wz)^2           (c not identified: s took rho dc of its
                                                      error dc; none is left where it learned)

        Parameters
        ----------
        wz, v : float
            The gyro's rate [rad/s] and the forward speed [m/s].
        prior : bool
            Count s, while not identified, by its prior variance (the EKF's stand-in yaw
            rate); False: not at all (the gates, which widen ``scale_tolerance`` to 0.15
            until s is identified).
        """
        p_s = self.scale_variance if prior or self.identified[0] else 0.0
        if self.identified[1]:
            return p_s * wz * wz + self._var[1] * v * v
        lever = v - self.absorbed * wz
        return p_s * wz * wz + self._p0[1] * lever * lever

    def true_rate(self, w_e: float, v: float) -> float:
        """The yaw rate the wheels' w_e stands for: (w_e - c v) / s."""
        return (w_e - self.per_metre * v) / self.scale

    def learn(
        self, w_e: float, wz: float, v: float, dt_s: float, noise_var: float, steady: bool
    ) -> None:
        """One healthy sample (a no-op with ``tau_s`` 0: s = 1, c = 0 stay).

        Parameters
        ----------
        w_e, wz : float
            The wheels' and the gyro's yaw rates [rad/s].
        v : float
            The wheels' forward speed [m/s].
        dt_s : float
            The frame's interval [s].
        noise_var : float
            R_0: the sample's noise variance about the model [(rad/s)^2] (the gyro's and the
            encoders' noise, and how much s and c vary on a healthy robot).
        steady : bool
            The gyro's rate changed by less than ``STEADY_ALPHA`` over the frame.
        """
        if self.tau_s <= 0.0 or not steady or dt_s <= 0.0:
            return
        forget = max(0.0, 1.0 - dt_s / self.tau_s)
        if abs(v) >= self.STRAIGHT_SPEED and abs(wz) <= self.STRAIGHT_CURVATURE * abs(v):
            r = noise_var + self._var[0] * wz * wz
            self._update(1, w_e - self._est[0] * wz, v, r, forget, abs(v) * dt_s)
        elif abs(wz) > self.TURN_RATE:
            r = noise_var + self._var[1] * v * v
            if self._update(0, w_e - self._est[1] * v, wz, r, forget, abs(wz) * dt_s):
                self._cross = forget * self._cross + wz * v / r

    def _update(self, i: int, y: float, h: float, r: float, forget: float, span: float) -> bool:
        """The scalar Kalman update of term i (0: s, 1: c) by y = h theta_i + noise(r), the
        sample covering ``span`` (rad turned or m driven); whether it was learned."""
        p0 = self._p0[i]
        p = min(self._var[i] / forget, p0) if forget > 0.0 else p0
        innovation = y - h * self._est[i]
        predicted = h * h * p + r
        if innovation * innovation > self.LEARN_GATE**2 * predicted:
            return False  # a slip or a transient: not the robot's geometry
        gain = p * h / predicted
        if self.identified[i]:
            # from then on a low-pass over tau_s: a slow fault must not be learned in seconds
            gain = math.copysign(min(abs(gain), (1.0 - forget) / abs(h)), gain)
        lo, hi = self._bounds[i]
        self._est[i] = min(hi, max(lo, self._est[i] + gain * innovation))
        self._var[i] = (1.0 - gain * h) ** 2 * p + gain * gain * r  # Joseph: any gain
        self._info[i] = forget * self._info[i] + h * h / r
        self._n[i] += 1
        self._span[i] += span
        if (
            not self.identified[i]
            and self._n[i] >= self.IDENTIFY_SAMPLES
            and self._span[i] >= self.IDENTIFY_SPAN[i]
            and self._info[i] * p0 >= self.IDENTIFY_INFORMATION
        ):
            self.identified[i] = True
        return True
