"""The planar EKF behaves like robot_localization with the paper's settings (Table 2)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from jackson.common.geometry import wrap_angle
from jackson.host.estimation.ekf import (
    AX,
    DEFAULT_PROCESS_NOISE,
    PAPER_EKF,
    PAPER_PROCESS_NOISE,
    VX,
    VY,
    VYAW,
    YAW,
    Ekf,
    EkfConfig,
    GyroBiasEstimator,
    ProcessNoise,
    X,
    Y,
    transition,
    transition_jacobian,
)

DT_S = 0.05  # [s] telemetry period (20 Hz)
OUTPUT_DT_S = 1.0 / 30.0  # [s] EKF output period (30 Hz)


def test_vx_for_one_second_from_rest_gives_half_a_meter() -> None:
    ekf = Ekf()
    assert not ekf.initialized
    ekf.update_wheel(0.0, 0.5)
    assert ekf.initialized
    assert ekf.vx_m_s == 0.5  # the first measurement initialises vx at once
    for k in range(1, 21):
        assert ekf.update_wheel(k * DT_S, 0.5)
    assert ekf.t_s == pytest.approx(1.0)
    assert ekf.x_m == pytest.approx(0.5, abs=1e-3)
    assert ekf.y_m == pytest.approx(0.0, abs=1e-12)
    assert ekf.yaw_rad == pytest.approx(0.0, abs=1e-12)


def test_first_measurement_initialises_only_what_it_measures() -> None:
    cfg = EkfConfig()
    ekf = Ekf(cfg)
    ekf.predict_to(5.0)  # no prediction before the filter has a state
    assert ekf.t_s is None
    assert not ekf.update_gyro(1.0, math.nan)  # nothing finite: ignored
    assert not ekf.initialized
    assert ekf.update_gyro(1.0, 0.3)
    assert ekf.t_s == 1.0
    x = ekf.x
    assert x[VYAW] == 0.3
    assert np.count_nonzero(x) == 1
    p = ekf.P
    assert p[VYAW, VYAW] == cfg.r_wz
    expected = np.eye(7) * cfg.initial_covariance
    expected[VYAW, VYAW] = cfg.r_wz
    np.testing.assert_array_equal(p, expected)
    assert ekf.mahalanobis_sq == 0.0


def test_wheel_initialisation_sets_vx_vy_and_their_covariance() -> None:
    cfg = EkfConfig()
    ekf = Ekf(cfg)
    ekf.update_wheel(2.0, 0.2, 0.01)
    assert (ekf.vx_m_s, ekf.vy_m_s) == (0.2, 0.01)
    assert ekf.P[VX, VX] == cfg.r_vx
    assert ekf.P[VY, VY] == cfg.r_vy
    assert ekf.P[VX, VY] == 0.0


def test_yaw_350_deg_away_is_a_minus_10_deg_innovation() -> None:
    ekf = Ekf()
    covariance = [1e-9] * 7
    covariance[YAW] = 0.01
    ekf.set_state(0.0, [0.0] * 7, covariance)
    assert ekf.update_yaw(0.0, math.radians(350.0), variance=0.01)
    assert ekf.y[0] == pytest.approx(math.radians(-10.0), abs=1e-12)
    assert ekf.S[0, 0] == pytest.approx(0.02, rel=1e-12)
    assert ekf.yaw_rad == pytest.approx(math.radians(-5.0), abs=1e-12)  # K = 1/2


def test_yaw_innovation_wraps_across_pi_and_the_state_stays_wrapped() -> None:
    ekf = Ekf()
    covariance = [1e-9] * 7
    covariance[YAW] = 1.0
    ekf.set_state(0.0, [0.0, 0.0, math.radians(179.0), 0.0, 0.0, 0.0, 0.0], covariance)
    ekf.update_yaw(0.0, math.radians(-179.0), variance=1e-9)
    assert ekf.y[0] == pytest.approx(math.radians(2.0), abs=1e-12)
    assert ekf.yaw_rad == pytest.approx(math.radians(-179.0), abs=1e-6)
    assert -math.pi <= ekf.yaw_rad < math.pi


def test_gate_accepts_just_below_and_rejects_exactly_at_the_threshold() -> None:
    # P_vyaw = r_wz = 0.5 after the first gyro sample, so S = P + R = 1.0 exactly and
    # d^2 = y^2: y = 2 sits exactly on n = 2 (d^2 = n^2 = 4), the float below 2 just under.
    ekf = Ekf(EkfConfig(r_wz=0.5, mahalanobis_imu=2.0))
    ekf.update_gyro(0.0, 0.0)
    before = ekf.x

    assert not ekf.update_gyro(0.0, 2.0)
    np.testing.assert_array_equal(ekf.S, [[1.0]])
    assert ekf.mahalanobis_sq == 4.0
    assert ekf.mahalanobis == 2.0
    assert ekf.rejected["gyro"] == 1
    assert not ekf.innovations["gyro"].accepted
    np.testing.assert_array_equal(ekf.x, before)

    just_below = math.nextafter(2.0, 0.0)
    assert ekf.update_gyro(0.0, just_below)
    assert ekf.mahalanobis_sq < 4.0
    assert ekf.rejected["gyro"] == 1
    assert ekf.vyaw_rad_s == pytest.approx(1.0)  # K = 1/2


def test_wheel_gate_uses_the_joint_distance_of_vx_and_vy() -> None:
    cfg = EkfConfig(mahalanobis_wheel=3.0)
    ekf = Ekf(cfg)
    ekf.update_wheel(0.0, 0.0)
    s_vy = 2.0 * cfg.r_vy  # P_vy = r_vy after initialisation, no prediction at the same time
    limit_vy = 3.0 * math.sqrt(s_vy)  # d^2 = vy^2 / S_vy = 9 here
    assert ekf.update_wheel(0.0, 0.0, 0.999 * limit_vy)
    ekf2 = Ekf(cfg)
    ekf2.update_wheel(0.0, 0.0)
    assert not ekf2.update_wheel(0.0, 0.0, 1.001 * limit_vy)
    assert ekf2.mahalanobis_sq == pytest.approx(1.001**2 * 9.0, rel=1e-12)
    assert ekf2.rejected == {"wheel": 1, "gyro": 0, "yaw": 0}
    # The vx part of the innovation adds to the same d^2.
    ekf3 = Ekf(cfg)
    ekf3.update_wheel(0.0, 0.0)
    vx = 0.5 * 3.0 * math.sqrt(2.0 * cfg.r_vx)
    assert not ekf3.update_wheel(0.0, vx, 0.9 * limit_vy)  # 0.25 * 9 + 0.81 * 9 >= 9


def test_without_input_p_xx_grows_by_q_dt() -> None:
    ekf = Ekf(PAPER_EKF)  # Table 2's Q: every state's noise non-zero
    ekf.set_state(0.0, [0.0] * 7)  # P = 1e-9 I, state at rest
    q = np.diag(PAPER_PROCESS_NOISE.diagonal)

    ekf.predict_to(OUTPUT_DT_S)
    assert ekf.P[X, X] == pytest.approx(1e-9 + 0.05 * OUTPUT_DT_S, rel=1e-6)

    for k in range(2, 31):
        ekf.predict_to(k * OUTPUT_DT_S)

    # Independently: at rest F is constant, the identity plus dt couplings of the model.
    dt = OUTPUT_DT_S
    f = np.eye(7)
    f[X, VX] = f[Y, VY] = f[YAW, VYAW] = f[VX, AX] = dt
    f[X, AX] = 0.5 * dt * dt
    p = np.eye(7) * 1e-9
    for _ in range(30):
        p = f @ p @ f.T + dt * q
    assert ekf.P[X, X] == pytest.approx(p[X, X], rel=1e-6)
    assert ekf.P[YAW, YAW] == pytest.approx(p[YAW, YAW], rel=1e-6)
    np.testing.assert_allclose(ekf.P, p, rtol=1e-6, atol=1e-15)
    # ~ Q_xx per second, plus the vx coupling (~ Q_vx t^3 / 3 = 0.008).
    assert 0.05 < ekf.P[X, X] < 0.06
    assert ekf.P[VX, VX] == pytest.approx(1e-9 + 0.025 + 0.01 / 3.0, rel=0.02)
    np.testing.assert_array_equal(ekf.x, np.zeros(7))


def test_predict_to_never_goes_backwards() -> None:
    ekf = Ekf()
    ekf.update_wheel(1.0, 0.4)
    ekf.predict_to(1.5)
    x, p = ekf.x, ekf.P
    ekf.predict_to(1.5)
    ekf.predict_to(1.2)
    np.testing.assert_array_equal(ekf.x, x)
    np.testing.assert_array_equal(ekf.P, p)
    assert ekf.t_s == 1.5
    # An older measurement is corrected without prediction (robot_localization).
    assert ekf.update_wheel(1.4, 0.4)
    assert ekf.t_s == 1.5
    assert ekf.last_measurement_t_s == 1.4


def test_gyro_fuses_into_vyaw() -> None:
    ekf = Ekf()
    ekf.update_wheel(0.0, 0.0)
    for k in range(1, 21):
        t_s = k * DT_S
        ekf.update_wheel(t_s, 0.0)
        assert ekf.update_gyro(t_s, 0.4)
    assert ekf.vyaw_rad_s == pytest.approx(0.4, abs=1e-3)
    assert 0.3 < ekf.yaw_rad < 0.4  # integrated, one sample of lag
    assert ekf.P[VYAW, VYAW] < EkfConfig().r_wz


def test_first_gyro_sample_sets_vyaw_at_once() -> None:
    ekf = Ekf()
    ekf.update_gyro(0.0, -0.25)
    assert ekf.vyaw_rad_s == -0.25


def test_correction_is_the_kalman_update() -> None:
    ekf = Ekf()
    covariance = [1e-9] * 7
    covariance[VX] = 0.03
    ekf.set_state(0.0, [0.0] * 7, covariance)
    ekf.update_wheel(0.0, 0.8)
    gain = 0.03 / (0.03 + EkfConfig().r_vx)
    assert ekf.vx_m_s == pytest.approx(gain * 0.8, rel=1e-12)
    assert ekf.P[VX, VX] == pytest.approx((1.0 - gain) * 0.03, rel=1e-9)
    np.testing.assert_allclose(ekf.y, [0.8, 0.0])


def test_silence_of_0_2_s_times_out() -> None:
    ekf = Ekf()
    assert ekf.timed_out(0.0)  # nothing ever arrived
    for k in range(21):
        ekf.update_wheel(k * DT_S, 0.3)
    last_s = 20 * DT_S
    assert not ekf.timed_out(last_s + 0.1)
    assert not ekf.timed_out(last_s + 0.19)
    assert ekf.timed_out(24 * DT_S)  # 4 frames missing: 0.2 s of silence
    assert ekf.timed_out(last_s + 0.2)
    # The daemon then only predicts: the pose keeps moving with the last velocity.
    x_before = ekf.x_m
    ekf.predict_to(last_s + 0.3)
    assert ekf.x_m == pytest.approx(x_before + 0.3 * 0.3, abs=1e-9)
    assert ekf.timed_out(last_s + 0.3)
    ekf.update_wheel(last_s + 0.35, 0.3)
    assert not ekf.timed_out(last_s + 0.35)


def test_state_snapshot_is_frozen_and_complete() -> None:
    ekf = Ekf()
    snapshot = ekf.state()
    assert not snapshot.initialized
    assert snapshot.t_s is None
    ekf.update_wheel(0.0, 0.25)
    ekf.predict_to(0.5)
    snapshot = ekf.state()
    assert snapshot.initialized
    assert snapshot.t_s == 0.5
    assert len(snapshot.x) == len(snapshot.covariance_diagonal) == 7
    assert snapshot.vx_m_s == 0.25
    assert snapshot.x_m == pytest.approx(0.125)
    assert snapshot.p_xx == ekf.P[X, X]
    with pytest.raises(AttributeError):
        snapshot.t_s = 1.0  # type: ignore[misc]


def test_state_at_extrapolates_without_moving_the_filter() -> None:
    ekf = Ekf()
    ekf.update_wheel(0.0, 0.4)
    ekf.update_gyro(0.0, 0.1)
    x, p = ekf.x, ekf.P
    ahead = ekf.state_at(0.1)
    np.testing.assert_array_equal(ekf.x, x)
    np.testing.assert_array_equal(ekf.P, p)
    assert ekf.t_s == 0.0
    assert ahead.t_s == 0.1
    ekf.predict_to(0.1)
    assert ahead == ekf.state()
    assert ekf.state_at(0.05) == ekf.state()  # never backwards


def test_transition_follows_the_body_frame_model() -> None:
    x = np.array([1.0, 2.0, math.pi / 2, 0.5, 0.1, 0.2, 0.4])
    out = transition(x, 0.1)
    # yaw = 90 deg: body x is world y, body y is world -x.
    assert out[X] == pytest.approx(1.0 - 0.1 * 0.1, abs=1e-15)
    assert out[Y] == pytest.approx(2.0 + 0.5 * 0.1 + 0.5 * 0.4 * 0.01, abs=1e-15)
    assert out[YAW] == pytest.approx(math.pi / 2 + 0.02)
    assert out[VX] == pytest.approx(0.54)
    assert (out[VY], out[VYAW], out[AX]) == (0.1, 0.2, 0.4)
    wrapped = transition(np.array([0, 0, 3.1, 0, 0, 1.0, 0]), 0.1)
    assert wrapped[YAW] == pytest.approx(3.2 - 2 * math.pi)


def test_jacobian_matches_finite_differences() -> None:
    x = np.array([0.3, -0.7, 2.5, 0.4, -0.05, 0.3, 0.2])
    dt = 0.07
    analytic = transition_jacobian(x, dt)
    numeric = np.zeros((7, 7))
    h = 1e-6
    for j in range(7):
        step = np.zeros(7)
        step[j] = h
        diff = transition(x + step, dt) - transition(x - step, dt)
        numeric[:, j] = diff / (2 * h)
    np.testing.assert_allclose(analytic, numeric, atol=1e-8)


def test_wrap_angle_range() -> None:
    assert wrap_angle(math.pi) == -math.pi
    assert wrap_angle(-math.pi) == -math.pi
    assert wrap_angle(math.radians(350.0)) == pytest.approx(math.radians(-10.0))
    assert wrap_angle(7 * math.pi / 2) == pytest.approx(-math.pi / 2)


@pytest.mark.parametrize(
    "kwargs",
    [
        {"gyro_bias_window_s": -1.0},
        {"r_vx": 0.0},
        {"sensor_timeout_s": -0.2},
        {"frequency_hz": 0.0},
        {"mahalanobis_imu": 0.0},
        {"mahalanobis_wheel": math.nan},
    ],
)
def test_config_rejects_bad_values(kwargs: dict[str, object]) -> None:
    with pytest.raises(ValueError):
        EkfConfig(**kwargs)  # type: ignore[arg-type]


def test_process_noise_rejects_a_negative_variance() -> None:
    with pytest.raises(ValueError, match=r"ProcessNoise\.vyaw"):
        ProcessNoise(vyaw=-1.0)
    assert ProcessNoise().diagonal == DEFAULT_PROCESS_NOISE


def test_gyro_bias_window_zero_switches_the_estimate_off() -> None:
    est = GyroBiasEstimator(window_s=0.0)
    assert est.bias_rad_s == 0.0  # ready from the start: the daemon fuses the gyro at once
    est.add(0.0, 0.3, True)
    assert est.bias_rad_s == 0.0


def test_gyro_bias_is_the_mean_of_a_still_window() -> None:
    est = GyroBiasEstimator(window_s=2.0, min_samples=20)
    rates = [0.01 + 0.002 * ((-1) ** k) + 0.0001 * k for k in range(41)]
    for k, wz in enumerate(rates[:-1]):
        est.add(k * DT_S, wz, standing_still=True)
        assert est.bias_rad_s is None  # 40 samples span 1.95 s: not yet
    est.add(40 * DT_S, rates[-1], standing_still=True)
    assert est.ready
    assert est.bias_rad_s == pytest.approx(math.fsum(rates) / 41, rel=1e-12)
    est.add(41 * DT_S, 5.0, standing_still=True)  # frozen once ready
    est.add(42 * DT_S, 5.0, standing_still=False)
    assert est.bias_rad_s == pytest.approx(math.fsum(rates) / 41, rel=1e-12)


def test_gyro_bias_window_restarts_on_motion() -> None:
    est = GyroBiasEstimator(window_s=2.0, min_samples=20)
    for k in range(30):  # 1.5 s still, then the robot moves
        est.add(k * DT_S, 0.5, standing_still=True)
    est.add(30 * DT_S, 0.9, standing_still=False)
    assert est.sample_count == 0
    assert est.bias_rad_s is None
    for k in range(31, 72):  # 2 s still again with another rate
        est.add(k * DT_S, -0.02, standing_still=True)
    assert est.bias_rad_s == pytest.approx(-0.02, rel=1e-12)


def test_gyro_bias_needs_enough_samples() -> None:
    est = GyroBiasEstimator(window_s=2.0, min_samples=20)
    for k in range(11):  # 2.5 s, but only 11 samples
        est.add(k * 0.25, 0.1, standing_still=True)
    assert est.bias_rad_s is None
    for k in range(11, 20):
        est.add(k * 0.25, 0.1, standing_still=True)
    assert est.bias_rad_s == pytest.approx(0.1)


class FilterpyReference:
    """The same filter on filterpy's ``ExtendedKalmanFilter.update`` (the generic form)."""

    def __init__(self, config: EkfConfig, ekf: Ekf) -> None:
        from filterpy.kalman import ExtendedKalmanFilter

        self.kf = ExtendedKalmanFilter(dim_x=7, dim_z=1)
        self.kf.x = ekf.x.reshape(7, 1)
        self.kf.P = ekf.P
        self.t_s = ekf.t_s
        self.q = np.asarray(config.process_noise.diagonal)

    def update(
        self,
        t_s: float,
        z: list[float],
        indices: list[int],
        r: list[float],
        threshold: float | None,
    ) -> bool:
        assert self.t_s is not None
        dt_s = t_s - self.t_s
        if dt_s > 0.0:
            x = self.kf.x.reshape(7)
            jac = transition_jacobian(x, dt_s)
            self.kf.P = jac @ self.kf.P @ jac.T + np.diag(dt_s * self.q)
            self.kf.x = transition(x, dt_s).reshape(7, 1)
            self.t_s = t_s
        h = np.zeros((len(indices), 7))
        for row, col in enumerate(indices):
            h[row, col] = 1.0

        def residual(a: np.ndarray, b: np.ndarray) -> np.ndarray:
            y = np.asarray(a, dtype=np.float64) - b
            for row, col in enumerate(indices):
                if col == YAW:
                    y[row, 0] = wrap_angle(float(y[row, 0]))
            return y

        zc = np.array(z, dtype=np.float64).reshape(-1, 1)
        rm = np.diag(r)
        if threshold is not None:
            y = residual(zc, h @ self.kf.x).reshape(-1)
            s = h @ self.kf.P @ h.T + rm
            if not float(y @ np.linalg.solve(s, y)) < threshold * threshold:
                return False
        self.kf.update(zc, HJacobian=lambda _x: h, Hx=lambda s: h @ s, R=rm, residual=residual)
        self.kf.x[YAW, 0] = wrap_angle(float(self.kf.x[YAW, 0]))
        return True


def test_the_written_out_correction_is_filterpys_update() -> None:
    """Every measurement kind, gated and not, angles across +-pi: x and P as filterpy's."""
    cfg = EkfConfig(mahalanobis_wheel=3.0, mahalanobis_imu=2.0)
    ekf = Ekf(cfg)
    ekf.set_state(0.0, [0.1, -0.2, 3.1, 0.3, 0.0, 0.5, 0.1], [1e-3] * 7)
    ref = FilterpyReference(cfg, ekf)
    rng = np.random.default_rng(7)
    t_s = 0.0
    rejected = 0
    for k in range(400):
        t_s += float(rng.uniform(0.01, 0.06))
        kind = k % 5
        if kind == 0:
            vx = float(rng.normal(0.3, 0.3))
            ok = ekf.update_wheel(t_s, vx, 0.0)
            ok_ref = ref.update(t_s, [vx, 0.0], [VX, VY], [cfg.r_vx, cfg.r_vy], 3.0)
        elif kind == 1:
            wz = float(rng.normal(0.5, 0.2))
            ok = ekf.update_gyro(t_s, wz)
            ok_ref = ref.update(t_s, [wz], [VYAW], [cfg.r_wz], 2.0)
        elif kind == 2:
            yaw = float(rng.uniform(-4.0, 4.0))
            ok = ekf.update_yaw(t_s, yaw, 0.05)
            ok_ref = ref.update(t_s, [wrap_angle(yaw)], [YAW], [0.05], None)
        elif kind == 3:
            wz = float(rng.normal(0.5, 0.2))
            ok = ekf.update_yaw_rate(t_s, wz, 0.01)
            ok_ref = ref.update(t_s, [wz], [VYAW], [0.01], None)
        else:
            ekf.stationary = False
            ok = ekf.update_zero_velocity(t_s, 1e-4)
            ok_ref = ref.update(t_s, [0.0] * 4, [VX, VY, VYAW, AX], [1e-4] * 4, None)
        assert ok == ok_ref, k
        rejected += not ok
        np.testing.assert_allclose(ekf.x, ref.kf.x.reshape(7), rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(ekf.P, ref.kf.P, rtol=1e-9, atol=1e-15)
    assert 0 < rejected < 200  # the gates were exercised both ways (160 gated)
