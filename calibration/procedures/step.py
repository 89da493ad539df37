"""Step-response identification: a first-order motor model per wheel and direction.

The paper's robot had no identified motor model, and a static right-side PWM scale did not
remove its CW/CCW asymmetry (Sec. 4.2). Here each wheel's speed after a duty step d from rest
is fitted, per wheel and per direction, by a first-order lag with dead time::

    omega(t) = K (|d| - d_0) (1 - exp(-(t - t_d) / tau))    for t > t_d, else 0

with K the steady-state gain [rad/s per unit duty above d_0], d_0 the duty the speed line
starts from (the host's breakaway duty, or fitted when the steps hold two or more duty levels),
tau the time constant [s] and t_d the dead time [s] from the frame the duty was written after.
The fit works on the wheel angle itself, the integral of that law::

    phi(t) = K (|d| - d_0) (u - tau (1 - exp(-u / tau))),    u = max(t - t_d, 0)

so the encoder counts enter as they are (unwrapped, no differencing of quantised counts), by
:func:`scipy.optimize.least_squares`, one fit per wheel and direction over all its steps.

**Host gains.** The host maps a wheel-speed command onto a duty by
``d = d_b + (1 - d_b) g |omega| / omega_max`` (:func:`jackson.host.actuation.deadband.wheel_duty`),
so with the model above a wheel reaches ``K (1 - d_b) g omega / omega_max`` (when d_0 = d_b):
the command itself when ``g / omega_max = 1 / (K (1 - d_b))``.
:meth:`StepIdentification.host_gains` takes the slowest wheel and direction, the one with the
smallest top speed ``K (1 - d_b)``, as the reference: ``omega_max`` becomes that top speed
and every gain ``g = K_ref (1 - d_b,ref) / (K (1 - d_b))`` (the reference's is 1, the others
below 1), so both wheels in both directions reach the same speed for the same command and no
wheel runs out of duty before the commanded top speed. A wheel twice as strong gets half the
gain: the host's gain is the *inverse* of the ratio K / K_ref of identified gains (at equal
breakaways).

:class:`WheelStepScript` records the steps through the daemon (a
:class:`jackson.host.core.DutySource`): by default both wheels together, forward then back,
at two duty levels (0.35 and 0.7, 1.5 s each: about 0.3 m of floor ahead on the paper's
robot), so the robot ends near where it started.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from jackson.calibration.procedures.base import (
    CalibrationError,
    FloatArray,
    RunData,
    check_start,
    wheel_angle_rad,
)
from jackson.host.actuation.deadband import DeadbandConfig, Direction, Side
from jackson.host.estimation.odometry import RobotGeometry

SIDES: tuple[Side, Side] = ("left", "right")
DIRECTIONS: tuple[Direction, Direction] = ("forward", "reverse")
STEP_DUTIES = (0.35, 0.7)  # two levels above the paper robot's 0.10 breakaway: K and d_0 apart
STEP_DRIVE_S = 1.5  # [s] many time constants of a small gear motor (tens of ms)
MIN_STEP_FRAMES = 10  # a step shorter than this cannot show a lag and a steady state
MIN_STEP_TICKS = 20  # a wheel that turned less did not run up (12 degrees at 621 TPR)
MAX_DEAD_TIME_S = 0.5  # [s] a longer dead time is a wheel that did not start, not a lag
MAX_TIME_CONSTANT_S = 5.0  # [s]
MAX_GAP_PERIODS = 3.0  # a step with a longer gap between frames lost frames on the link
MAX_RMS_TICKS = 3.0  # a fit whose angle residual exceeds this many ticks (RMS) is not a motor:
# a clean fit on the twin leaves about half a tick (0.0056 rad at 621 TPR, encoder quantisation
# 0.29 tick RMS); fits on streams with seconds of frames missing left 40-70 times that


# ------------------------------------------------------------------------- the recording


@dataclass(frozen=True)
class DutyStep:
    """One step of :class:`WheelStepScript`: both wheels' signed duties, held ``drive_s``.

    Attributes
    ----------
    left : float
        Signed left duty in [-1, 1] (0: braked).
    right : float
        Signed right duty in [-1, 1].
    drive_s : float
        How long the duties are held [s].
    """

    left: float
    right: float
    drive_s: float

    def __post_init__(self) -> None:
        for name in ("left", "right"):
            value = getattr(self, name)
            if not -1.0 <= value <= 1.0:
                raise ValueError(f"DutyStep.{name} must be in [-1, 1], got {value}")
        if self.left == 0.0 and self.right == 0.0:
            raise ValueError("DutyStep: at least one wheel must be driven")
        if not 0.0 < self.drive_s < math.inf:
            raise ValueError(f"DutyStep.drive_s must be finite and > 0, got {self.drive_s}")


def step_plan(
    duties: Sequence[float] = STEP_DUTIES,
    drive_s: float = STEP_DRIVE_S,
    *,
    single_wheel: bool = False,
) -> tuple[DutyStep, ...]:
    """The steps that give every wheel and direction a step from rest at every duty level.

    Both wheels together (the default): forward then back at each level, so the robot drives
    straight and ends near its start, and each wheel carries half the chassis as it does when
    driving. ``single_wheel``: each wheel alone, forward then back, the other braked (the robot
    pivots about the braked wheel: less floor, a different load).

    Parameters
    ----------
    duties : sequence of float
        Duty levels in (0, 1].
    drive_s : float
        How long each step is held [s].
    single_wheel : bool
        One wheel at a time instead of both.

    Returns
    -------
    tuple of DutyStep
        The steps in order.

    Raises
    ------
    ValueError
        No duty level, or one outside (0, 1].
    """
    if not duties:
        raise ValueError("step_plan: no duty level")
    for d in duties:
        if not 0.0 < d <= 1.0:
            raise ValueError(f"step_plan: a duty level must be in (0, 1], got {d}")
    steps: list[DutyStep] = []
    for d in duties:
        if single_wheel:
            steps += [
                DutyStep(d, 0.0, drive_s),
                DutyStep(-d, 0.0, drive_s),
                DutyStep(0.0, d, drive_s),
                DutyStep(0.0, -d, drive_s),
            ]
        else:
            steps += [DutyStep(d, d, drive_s), DutyStep(-d, -d, drive_s)]
    return tuple(steps)


class WheelStepScript:
    """Duty steps from rest, one after another, with a brake to standstill before each.

    A :class:`jackson.host.core.DutySource` (and a
    :class:`jackson.calibration.runs.duty.DutyScript`): brake at least ``settle_s`` and until
    both counts have stood still for ``still_s`` (at most ``max_stop_s``), write the step's
    duties for its ``drive_s``, and so on; after the last step, brake to standstill and set
    ``done``. The duties are written after a frame, so a step acts from that frame's time
    (what :func:`find_steps` assumes).

    Parameters
    ----------
    steps : sequence of DutyStep or None
        The steps (default :func:`step_plan`).
    settle_s : float
        Braked time before the first step and at least before each next one [s].
    still_s : float
        How long the counts must stand still before a step [s].
    max_stop_s : float
        The longest wait for standstill after a step [s].

    Attributes
    ----------
    done : bool
        True once the last step has ended at rest.
    total_s : float
        The expected length of the run [s], for a progress display.
    """

    def __init__(
        self,
        steps: Sequence[DutyStep] | None = None,
        *,
        settle_s: float = 1.0,
        still_s: float = 0.5,
        max_stop_s: float = 3.0,
    ) -> None:
        self.steps = tuple(step_plan() if steps is None else steps)
        if not self.steps:
            raise ValueError("WheelStepScript: no step")
        self.settle_s = settle_s
        self.still_s = still_s
        self.max_stop_s = max_stop_s
        self.total_s = settle_s + sum(s.drive_s + max(settle_s, still_s) for s in self.steps)
        self.done = False
        self._index = 0
        self._driving = False
        self._t_phase: float | None = None
        self._counts: tuple[int, int] | None = None
        self._t_change = 0.0

    def step(self, t_s: float, enc_left: int, enc_right: int) -> tuple[float, float]:
        if self.done:
            return 0.0, 0.0
        if self._t_phase is None:
            self._t_phase = self._t_change = t_s
        counts = (enc_left, enc_right)
        if counts != self._counts:
            self._counts, self._t_change = counts, t_s
        if self._driving:
            current = self.steps[self._index]
            if t_s - self._t_phase < current.drive_s - 1e-9:
                return current.left, current.right
            self._driving, self._t_phase, self._index = False, t_s, self._index + 1
            self._t_change = t_s  # the wheels were turning up to now
        waited = t_s - self._t_phase
        still = t_s - self._t_change >= self.still_s - 1e-9
        if waited < self.settle_s - 1e-9 or (not still and waited < self.max_stop_s):
            return 0.0, 0.0
        if self._index >= len(self.steps):
            self.done = True
            return 0.0, 0.0
        self._driving, self._t_phase = True, t_s
        current = self.steps[self._index]
        return current.left, current.right


# ------------------------------------------------------------------------- the steps


@dataclass(frozen=True)
class WheelStep:
    """One wheel's response to one duty step from rest, in the step's direction.

    Attributes
    ----------
    run : str
        The run it comes from.
    side : Side
        The wheel.
    direction : Direction
        ``"forward"`` for a positive duty, ``"reverse"`` for a negative one.
    duty : float
        |d|, the step's duty magnitude.
    t_s : numpy.ndarray
        Frame times from the frame the duty was written after (t = 0) to the frame the step
        ended at [s].
    angle_rad : numpy.ndarray
        The wheel's rotation since t = 0, positive in the step's direction [rad].
    """

    run: str
    side: Side
    direction: Direction
    duty: float
    t_s: FloatArray
    angle_rad: FloatArray

    @property
    def final_speed_rad_s(self) -> float:
        """Mean speed over the step's last third [rad/s] (in the step's direction)."""
        t, a = self.t_s, self.angle_rad
        k = int(np.searchsorted(t, t[-1] * 2.0 / 3.0))
        k = min(k, len(t) - 2)
        return float((a[-1] - a[k]) / (t[-1] - t[k]))


def find_steps(
    run: RunData, geometry: RobotGeometry, breakaway: DeadbandConfig | None = None
) -> list[WheelStep]:
    """Every duty step from rest of either wheel in a raw duty run.

    A wheel's step starts at a frame whose duty (written after it, commands.csv) is nonzero
    where the previous frame's was zero, with the wheel's count unchanged over the previous
    frame (at rest); it ends at the first later frame with another duty (or the run's end).

    Parameters
    ----------
    run : RunData
        A run with raw duties.
    geometry : RobotGeometry
        Encoder resolution per wheel.
    breakaway : DeadbandConfig or None
        The host's breakaway duties, to tell a wheel that did not move at a duty well above
        its breakaway (link, motor or wiring) from one below it.

    Returns
    -------
    list of WheelStep
        The steps in the order of the run, left before right at the same frame.

    Raises
    ------
    CalibrationError
        A step whose wheel did not move, that ended too soon, or with frames missing (a gap
        longer than :data:`MAX_GAP_PERIODS` telemetry periods).
    """
    out: list[tuple[int, WheelStep]] = []
    period = float(np.median(np.diff(run.t_s))) if run.frames > 1 else math.inf
    for side in SIDES:
        duty = np.nan_to_num(run.duty_left if side == "left" else run.duty_right)
        counts = run.enc_left if side == "left" else run.enc_right
        tpr = geometry.ticks_per_rev_left if side == "left" else geometry.ticks_per_rev_right
        starts = np.flatnonzero((duty[1:] != 0.0) & (duty[:-1] == 0.0)) + 1
        for a in map(int, starts):
            if a < 1 or counts[a] != counts[a - 1]:
                continue  # not from rest
            changed = np.flatnonzero(duty[a:] != duty[a])
            b = a + int(changed[0]) if len(changed) else run.frames - 1
            d = float(duty[a])
            direction: Direction = "forward" if d > 0.0 else "reverse"
            label = f"run {run.name}: the {side} wheel's {direction} step at duty {abs(d):g}"
            if b - a < MIN_STEP_FRAMES:
                raise CalibrationError(f"{label} lasts only {b - a} frames")
            gap = float(np.max(np.diff(run.t_s[a : b + 1])))
            if gap > MAX_GAP_PERIODS * period:
                raise CalibrationError(
                    f"{label} has {gap:.2f} s without a frame ({gap / period - 1:.0f} frames "
                    "missing): the link lost them; run it again (a busy machine? another "
                    "program on the port?)"
                )
            sign = 1.0 if d > 0.0 else -1.0
            ticks = sign * (counts[a : b + 1] - counts[a])
            if ticks[-1] < MIN_STEP_TICKS:
                d0 = breakaway.breakaway(side, direction) if breakaway is not None else None
                if d0 is not None and abs(d) >= 1.5 * d0:
                    raise CalibrationError(
                        f"{label} turned it {int(ticks[-1])} ticks, well above its breakaway "
                        f"duty {d0:g}: the wheel did not move (check the motor, its wiring and "
                        "the driver's power) or its encoder does not count"
                    )
                raise CalibrationError(
                    f"{label} turned it {int(ticks[-1])} ticks: below its breakaway duty?"
                )
            check_start(label, run.t_s[a : b + 1] - run.t_s[a], ticks, MAX_DEAD_TIME_S)
            step = WheelStep(
                run=run.name,
                side=side,
                direction=direction,
                duty=abs(d),
                t_s=np.asarray(run.t_s[a : b + 1] - run.t_s[a], dtype=np.float64),
                angle_rad=wheel_angle_rad(ticks, tpr),
            )
            out.append((a, step))
    out.sort(key=lambda item: (item[0], SIDES.index(item[1].side)))
    return [step for _, step in out]


# ------------------------------------------------------------------------- the model


def step_angle(
    t_s: FloatArray,
    duty: float,
    gain_rad_s: float,
    breakaway_duty: float,
    time_constant_s: float,
    dead_time_s: float = 0.0,
) -> FloatArray:
    """Wheel angle after a duty step from rest by the first-order model (the fit's law).

    phi(t) = K (|d| - d_0) (u - tau (1 - exp(-u / tau))), u = max(t - t_d, 0): the integral of
    omega(t) = K (|d| - d_0) (1 - exp(-u / tau)).

    Parameters
    ----------
    t_s : numpy.ndarray
        Times since the step [s].
    duty : float
        |d|.
    gain_rad_s : float
        K [rad/s per unit duty].
    breakaway_duty : float
        d_0.
    time_constant_s : float
        tau [s], > 0.
    dead_time_s : float
        t_d [s].

    Returns
    -------
    numpy.ndarray
        phi [rad], positive in the step's direction.
    """
    u = np.maximum(np.asarray(t_s, dtype=np.float64) - dead_time_s, 0.0)
    top = gain_rad_s * (duty - breakaway_duty)
    return np.asarray(top * (u + time_constant_s * np.expm1(-u / time_constant_s)))


@dataclass(frozen=True)
class WheelModel:
    """The identified first-order model of one wheel in one direction.

    Attributes
    ----------
    side : Side
        The wheel.
    direction : Direction
        The direction.
    gain_rad_s : float
        K, steady-state speed per unit duty above d_0 [rad/s].
    breakaway_duty : float
        d_0, where the steady-state speed line meets zero (given or fitted).
    breakaway_fitted : bool
        Whether d_0 was fitted (two or more duty levels) rather than given.
    time_constant_s : float
        tau [s].
    dead_time_s : float
        t_d [s] (0 when the fit had none).
    gain_sd_rad_s : float
        Standard error of K from the fit's Jacobian [rad/s].
    time_constant_sd_s : float
        Standard error of tau [s].
    rms_residual_rad : float
        RMS of the angle residuals over all its steps [rad].
    duties : tuple of float
        |d| of each step fitted.
    final_speeds_rad_s : tuple of float
        Each step's measured speed over its last third [rad/s].
    """

    side: Side
    direction: Direction
    gain_rad_s: float
    breakaway_duty: float
    breakaway_fitted: bool
    time_constant_s: float
    dead_time_s: float
    gain_sd_rad_s: float
    time_constant_sd_s: float
    rms_residual_rad: float
    duties: tuple[float, ...]
    final_speeds_rad_s: tuple[float, ...]

    @property
    def delay_s(self) -> float:
        """tau + t_d, the angle's lag behind the steady speed once settled [s].

        The best-determined timing of the fit. For a DC motor whose winding lag tau_e sits
        inside its back-EMF loop, omega / d = K / (tau_e tau_m s^2 + tau_m s + 1), this lag
        is the mechanical time constant tau_m = J / k_e alone (the first moment of the
        response), while tau_e shapes the rise (an overshoot when tau_e > tau_m / 4), which
        the first-order fit takes up as dead time.
        """
        return self.time_constant_s + self.dead_time_s

    def speed_rad_s(self, duty: float) -> float:
        """Steady-state speed at duty |d|: K max(|d| - d_0, 0) [rad/s].

        Parameters
        ----------
        duty : float
            |d|.

        Returns
        -------
        float
            The speed in this model's direction [rad/s].
        """
        return self.gain_rad_s * max(abs(duty) - self.breakaway_duty, 0.0)


def fit_wheel(
    steps: Sequence[WheelStep],
    *,
    breakaway_duty: float | None = None,
    dead_time: bool = True,
) -> WheelModel:
    """Least-squares fit of the first-order model to one wheel's steps in one direction.

    Parameters
    ----------
    steps : sequence of WheelStep
        Steps of one wheel in one direction.
    breakaway_duty : float or None
        d_0 held fixed (the host's breakaway duty); None fits it, which needs steps at two or
        more duty levels.
    dead_time : bool
        Fit a dead time t_d (else t_d = 0).

    Returns
    -------
    WheelModel
        The model.

    Raises
    ------
    CalibrationError
        No step, steps of several wheels or directions, d_0 to fit from one duty level, or a
        d_0 at or above a step's duty.
    """
    if not steps:
        raise CalibrationError("no duty step to fit")
    side, direction = steps[0].side, steps[0].direction
    where = f"the {side} wheel {direction}"
    if any(s.side != side or s.direction != direction for s in steps):
        raise CalibrationError(f"{where}: steps of another wheel or direction mixed in")
    duties = np.array([s.duty for s in steps])
    speeds = np.array([s.final_speed_rad_s for s in steps])
    levels = np.unique(np.round(duties, 6))
    fit_d0 = breakaway_duty is None
    if fit_d0 and len(levels) < 2:
        raise CalibrationError(
            f"{where}: steps at one duty level ({levels[0]:g}) cannot separate K from the "
            "breakaway duty: record two levels or give the breakaway"
        )
    if breakaway_duty is not None and breakaway_duty >= duties.min():
        raise CalibrationError(
            f"{where}: the breakaway duty {breakaway_duty:g} is not below the step duty "
            f"{duties.min():g}"
        )
    if fit_d0:
        slope, intercept = np.polyfit(duties, speeds, 1)
        k0 = max(float(slope), 1e-3)
        d0 = float(np.clip(-intercept / k0, 0.0, 0.9 * duties.min()))
    else:
        assert breakaway_duty is not None
        d0 = breakaway_duty
        k0 = float(np.mean(speeds / (duties - d0)))
    tau0 = _initial_time_constant(steps)
    x0 = [k0, tau0] + ([0.0] if dead_time else []) + ([d0] if fit_d0 else [])
    lo = [0.0, 1e-4] + ([0.0] if dead_time else []) + ([0.0] if fit_d0 else [])
    hi = (
        [np.inf, MAX_TIME_CONSTANT_S]
        + ([MAX_DEAD_TIME_S] if dead_time else [])
        + ([float(duties.min()) - 1e-4] if fit_d0 else [])
    )
    x0 = list(np.clip(x0, np.array(lo) + 1e-9, np.array(hi) - 1e-9))

    def unpack(x: FloatArray) -> tuple[float, float, float, float]:
        k, tau = float(x[0]), float(x[1])
        t_d = float(x[2]) if dead_time else 0.0
        return k, tau, t_d, float(x[-1]) if fit_d0 else d0

    def residuals(x: FloatArray) -> FloatArray:
        k, tau, t_d, d_0 = unpack(x)
        return np.concatenate(
            [step_angle(s.t_s, s.duty, k, d_0, tau, t_d) - s.angle_rad for s in steps]
        )

    sol = least_squares(residuals, np.array(x0, dtype=np.float64), bounds=(lo, hi), x_scale="jac")
    k, tau, t_d, d_0 = unpack(sol.x)
    r = np.asarray(sol.fun)
    dof = max(len(r) - len(sol.x), 1)
    sd = _standard_errors(np.asarray(sol.jac), float(r @ r) / dof)
    return WheelModel(
        side=side,
        direction=direction,
        gain_rad_s=k,
        breakaway_duty=d_0,
        breakaway_fitted=fit_d0,
        time_constant_s=tau,
        dead_time_s=t_d,
        gain_sd_rad_s=float(sd[0]),
        time_constant_sd_s=float(sd[1]),
        rms_residual_rad=float(np.sqrt(np.mean(r * r))),
        duties=tuple(float(d) for d in duties),
        final_speeds_rad_s=tuple(float(v) for v in speeds),
    )


def _initial_time_constant(steps: Sequence[WheelStep]) -> float:
    """tau from the angle's lag behind the final speed: phi -> w (t - tau) once settled."""
    lags = []
    for s in steps:
        w = s.final_speed_rad_s
        if w > 0.0:
            lags.append(float(s.t_s[-1] - s.angle_rad[-1] / w))
    lag = float(np.median(lags)) if lags else 0.05
    return float(np.clip(lag, 1e-3, MAX_TIME_CONSTANT_S / 2))


def _standard_errors(jac: FloatArray, variance: float) -> FloatArray:
    """Parameter standard errors sqrt(diag(s^2 (J^T J)^-1)); NaN where J^T J is singular."""
    try:
        cov = np.linalg.inv(jac.T @ jac) * variance
    except np.linalg.LinAlgError:
        return np.full(jac.shape[1], np.nan)
    return np.asarray(np.sqrt(np.clip(np.diag(cov), 0.0, None)))


# ------------------------------------------------------------------------- the result


@dataclass(frozen=True)
class HostGains:
    """The deadband compensation's gains that make every wheel and direction reach the command.

    Attributes
    ----------
    max_wheel_rad_s : float
        omega_max: the reference's top speed K_ref (1 - d_b,ref) [rad/s].
    reference : tuple of str
        (side, direction) of the reference, the slowest; its gain is 1.
    gains : mapping of (side, direction) to float
        g = K_ref (1 - d_b,ref) / (K (1 - d_b)) per wheel and direction.
    """

    max_wheel_rad_s: float
    reference: tuple[Side, Direction]
    gains: Mapping[tuple[Side, Direction], float]

    def apply(self, deadband: DeadbandConfig) -> DeadbandConfig:
        """``deadband`` with these gains and omega_max (breakaways and threshold kept).

        Parameters
        ----------
        deadband : DeadbandConfig
            The configuration the gains were computed for.

        Returns
        -------
        DeadbandConfig
            The new configuration.
        """
        g = self.gains
        return dataclasses.replace(
            deadband,
            max_wheel_rad_s=self.max_wheel_rad_s,
            gain_left=g[("left", "forward")],
            gain_right=g[("right", "forward")],
            gain_reverse_left=g[("left", "reverse")],
            gain_reverse_right=g[("right", "reverse")],
        )

    def yaml_updates(self) -> dict[str, float]:
        """The dotted host-YAML fields for :func:`jackson.calibration.yaml_update.update_config`:
        ``deadband.max_wheel_rad_s`` (0.001 rad/s) and ``deadband.gain.<side>.<direction>``
        (0.0001).

        Returns
        -------
        dict of str to float
            Field to value.
        """
        out = {"deadband.max_wheel_rad_s": round(self.max_wheel_rad_s, 3)}
        for side in SIDES:
            for direction in DIRECTIONS:
                out[f"deadband.gain.{side}.{direction}"] = round(self.gains[(side, direction)], 4)
        return out


@dataclass(frozen=True)
class StepIdentification:
    """Each wheel's first-order model in each direction, from duty steps.

    Attributes
    ----------
    left_forward : WheelModel
        The left wheel driving forward.
    left_reverse : WheelModel
        The left wheel driving backward.
    right_forward : WheelModel
        The right wheel driving forward.
    right_reverse : WheelModel
        The right wheel driving backward.
    """

    left_forward: WheelModel
    left_reverse: WheelModel
    right_forward: WheelModel
    right_reverse: WheelModel

    def model(self, side: Side, direction: Direction) -> WheelModel:
        """One wheel's model in one direction.

        Parameters
        ----------
        side : Side
            ``"left"`` or ``"right"``.
        direction : Direction
            ``"forward"`` or ``"reverse"``.

        Returns
        -------
        WheelModel
            The model.
        """
        model: WheelModel = getattr(self, f"{side}_{direction}")
        return model

    @property
    def models(self) -> tuple[WheelModel, ...]:
        """The four models: left forward, left reverse, right forward, right reverse."""
        return (self.left_forward, self.left_reverse, self.right_forward, self.right_reverse)

    def host_gains(self, deadband: DeadbandConfig) -> HostGains:
        """The gains (and omega_max) for the host's deadband compensation.

        With the host's breakaway d_b per wheel and direction, wheel_duty's line
        d = d_b + (1 - d_b) g |omega| / omega_max meets the model's K (d - d_b) = omega when
        g / omega_max = 1 / (K (1 - d_b)). The slowest top speed K (1 - d_b) becomes
        omega_max and its gain 1; each other gain is the ratio of that top speed to its own.
        Where a fitted d_0 differs from d_b, the model's speed differs from the command by
        the constant K (d_b - d_0), which gains cannot remove.

        Parameters
        ----------
        deadband : DeadbandConfig
            The host's deadband compensation (its breakaway duties are used).

        Returns
        -------
        HostGains
            omega_max, the reference and the four gains.
        """
        top = {
            (m.side, m.direction): m.gain_rad_s * (1.0 - deadband.breakaway(m.side, m.direction))
            for m in self.models
        }
        reference = min(top, key=lambda key: top[key])
        omega_max = top[reference]
        return HostGains(
            max_wheel_rad_s=omega_max,
            reference=reference,
            gains={key: omega_max / value for key, value in top.items()},
        )


def identify_steps(
    runs: Sequence[RunData],
    geometry: RobotGeometry,
    *,
    breakaway: DeadbandConfig | None = None,
    dead_time: bool = True,
    expected: DeadbandConfig | None = None,
) -> StepIdentification:
    """Each wheel's first-order motor model per direction from duty-step runs (the motor model
    the paper did not identify).

    The steps of every run (:func:`find_steps`) are pooled per wheel and direction and fitted
    by :func:`fit_wheel`. Record them with :class:`WheelStepScript` at a high telemetry rate
    (200 Hz): the lag of a small gear motor lasts a few tens of milliseconds.

    Parameters
    ----------
    runs : sequence of RunData
        Raw duty runs holding steps from rest.
    geometry : RobotGeometry
        Encoder resolution per wheel (the calibrated one; K is in rad/s of the wheel).
    breakaway : DeadbandConfig or None
        Hold d_0 at these breakaway duties (the host's); None: fit d_0 per wheel and
        direction, which needs two or more duty levels.
    dead_time : bool
        Fit a dead time.
    expected : DeadbandConfig or None
        The breakaway duties the host believes, for messages only: a wheel that did not move
        at a duty well above its breakaway is named as such (link, motor or wiring).

    Returns
    -------
    StepIdentification
        The four models.

    Raises
    ------
    CalibrationError
        A wheel or direction without a step, a step the wheel did not follow or with frames
        missing, or a fit whose residual exceeds :data:`MAX_RMS_TICKS` ticks RMS.
    """
    steps: dict[tuple[Side, Direction], list[WheelStep]] = {
        (side, direction): [] for side in SIDES for direction in DIRECTIONS
    }
    for run in runs:
        for s in find_steps(run, geometry, breakaway if breakaway is not None else expected):
            steps[(s.side, s.direction)].append(s)
    names = ", ".join(r.name for r in runs) or "(none)"
    models: dict[str, WheelModel] = {}
    for (side, direction), found in steps.items():
        if not found:
            raise CalibrationError(f"runs {names}: no {direction} step of the {side} wheel")
        d0 = breakaway.breakaway(side, direction) if breakaway is not None else None
        model = fit_wheel(found, breakaway_duty=d0, dead_time=dead_time)
        tpr = geometry.ticks_per_rev_left if side == "left" else geometry.ticks_per_rev_right
        tick_rad = 2.0 * math.pi / tpr
        if model.rms_residual_rad > MAX_RMS_TICKS * tick_rad:
            raise CalibrationError(
                f"runs {names}: the {side} wheel's {direction} steps do not follow a first-order "
                f"motor (residual {model.rms_residual_rad / tick_rad:.1f} ticks RMS, at most "
                f"{MAX_RMS_TICKS:g}): the wheel slipped or stalled, or frames were lost; "
                "nothing was written, run it again"
            )
        models[f"{side}_{direction}"] = model
    return StepIdentification(**models)
