"""Encoder and MPU-6050 models of the twin.

Encoders are quantised at the robot's *true* ticks per revolution (which the host may believe
differently). The IMU follows Eq. 7-8 of the paper, a = a_true + b_a + eta_a and
omega = omega_true + b_omega + eta_omega, with white noise of the configured sigma per
telemetry sample, gravity on z with an optional scale error, and quantisation at the configured
MPU-6050 sensitivity; the result is the 14 register bytes 0x3B..0x48 the firmware reads. The gyro
bias b_omega may drift as a random walk, ``b += sigma_d sqrt(dt) N(0, 1)`` per axis between
samples (``imu.gyro_bias_drift_rad_s_per_sqrt_s`` = sigma_d): after T seconds its SD is
sigma_d sqrt(T).
"""

from __future__ import annotations

import math

import numpy as np

from jackson.protocol.messages import ACCEL_LSB_PER_G, GRAVITY_M_S2, GYRO_LSB_PER_DPS
from jackson.sim.config import ImuSpec, Sides

TEMP_RAW_AT_25C = round((25.0 - 36.53) * 340.0)  # raw/340 + 36.53 deg C


def encoder_counts(angle_l_rad: float, angle_r_rad: float, ticks_per_rev: Sides) -> tuple[int, int]:
    """Cumulative 4x quadrature counts of wheel angles: floor(angle / 2 pi * TPR)."""
    return (
        math.floor(angle_l_rad / (2.0 * math.pi) * ticks_per_rev.left),
        math.floor(angle_r_rad / (2.0 * math.pi) * ticks_per_rev.right),
    )


def _lsb(value: float, scale: float) -> int:
    return max(-32768, min(32767, round(value * scale)))


class ImuModel:
    """Turns true body-frame specific force and rate into MPU-6050 register values.

    Parameters
    ----------
    spec : ImuSpec
        The error model (its ``gyro_bias_rad_s`` is the bias at the start).
    rng : numpy.random.Generator
        White noise.
    drift_rng : numpy.random.Generator or None
        The bias random walk's steps (needed when the spec has a drift).

    Attributes
    ----------
    gyro_bias_rad_s : tuple of float
        The gyro bias now, xyz [rad/s].
    """

    def __init__(
        self,
        spec: ImuSpec,
        rng: np.random.Generator,
        drift_rng: np.random.Generator | None = None,
    ) -> None:
        self.spec = spec
        self.rng = rng
        self.accel_fs = 0
        self.gyro_fs = 0
        self._noise: list[float] = []  # drawn in blocks: the same stream as one draw per sample
        self.gyro_bias_rad_s = spec.gyro_bias_rad_s
        self._drift = spec.gyro_bias_drift_rad_s_per_sqrt_s
        if self._drift > 0.0 and drift_rng is None:
            raise ValueError("imu.gyro_bias_drift_rad_s_per_sqrt_s: needs a drift_rng")
        self._drift_rng = drift_rng
        self._steps: list[float] = []

    def drift(self, elapsed_s: float) -> None:
        """Let the gyro bias walk for ``elapsed_s`` (nothing without a drift).

        Parameters
        ----------
        elapsed_s : float
            Time since the previous call [s].
        """
        if self._drift <= 0.0 or elapsed_s <= 0.0:
            return
        if len(self._steps) < 3:
            assert self._drift_rng is not None
            self._steps = self._drift_rng.standard_normal(3 * 256).tolist()[::-1]
        pop = self._steps.pop
        k = self._drift * math.sqrt(elapsed_s)
        bx, by, bz = self.gyro_bias_rad_s
        self.gyro_bias_rad_s = (bx + k * pop(), by + k * pop(), bz + k * pop())

    def sample(
        self, accel_body: tuple[float, float], yaw_rate: float, gyro_z_offset_rad_s: float = 0.0
    ) -> tuple[tuple[int, int, int], int, tuple[int, int, int]]:
        """One telemetry sample.

        Parameters
        ----------
        accel_body : tuple of float
            True body-frame specific force x, y [m/s^2].
        yaw_rate : float
            True yaw rate [rad/s].
        gyro_z_offset_rad_s : float
            A fault's addition to the gyro's z rate (a spike, a bias step), before
            quantisation [rad/s] (:mod:`jackson.sim.faults`).

        Returns
        -------
        tuple
            (accel LSB xyz, temperature raw, gyro LSB xyz).
        """
        s = self.spec
        bx, by, bz = self.gyro_bias_rad_s
        if len(self._noise) < 6:
            self._noise = self.rng.standard_normal(6 * 256).tolist()[::-1]
        pop = self._noise.pop
        n_ax, n_ay, n_az, n_gx, n_gy, n_gz = pop(), pop(), pop(), pop(), pop(), pop()
        w_z = yaw_rate * s.yaw_scale
        if gyro_z_offset_rad_s:
            w_z = w_z + gyro_z_offset_rad_s
        a_scale = ACCEL_LSB_PER_G[self.accel_fs] / GRAVITY_M_S2
        g_scale = GYRO_LSB_PER_DPS[self.gyro_fs] * 180.0 / math.pi
        a_bx, a_by, a_bz = s.accel_bias_m_s2
        a_sigma, g_sigma = s.accel_noise_sigma_m_s2, s.gyro_noise_sigma_rad_s
        accel = (
            _lsb(accel_body[0] + a_bx + a_sigma * n_ax, a_scale),
            _lsb(accel_body[1] + a_by + a_sigma * n_ay, a_scale),
            _lsb(GRAVITY_M_S2 * s.gravity_scale + a_bz + a_sigma * n_az, a_scale),
        )
        gyro = (
            _lsb(0.0 + bx + g_sigma * n_gx, g_scale),
            _lsb(0.0 + by + g_sigma * n_gy, g_scale),
            _lsb(w_z + bz + g_sigma * n_gz, g_scale),
        )
        return accel, TEMP_RAW_AT_25C, gyro
