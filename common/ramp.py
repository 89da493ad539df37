"""One rate-limited step of one velocity axis: the ramp the daemon's velocity limiter applies
(:mod:`jackson.host.actuation.limiter`) and DWB's dynamic window expects
(:mod:`jackson.host.nav.dwb.core.kinematics`), kept in one place.

For previous output u, target r (already within the speed limit), acceleration bound a,
deceleration bound d and step dt [s]:

* same side of zero, speeding up (|r| >= |u|):  u' = u + clamp(r - u, -a dt, a dt)
* same side of zero, slowing down (|r| < |u|):  u' = u + clamp(r - u, -d dt, d dt)
* through zero (r = 0 or sign(r) != sign(u)): decelerate to 0 at d, which takes
  t_0 = |u| / d; if dt <= t_0 then u' = u - sign(u) d dt, else the rest of the step
  accelerates the other way at a: u' = sign(r) min(|r|, a (dt - t_0)).
"""

from __future__ import annotations

import math


def clamp(x: float, low: float, high: float) -> float:
    """``x`` within [low, high]."""
    return max(low, min(high, x))


def ramp(u: float, r: float, dt_s: float, accel: float, decel: float) -> float:
    """One rate-limited step of one axis from output ``u`` towards target ``r``.

    Parameters
    ----------
    u : float
        Previous output (m/s or rad/s).
    r : float
        Target, already clamped to the speed limit (same unit as ``u``).
    dt_s : float
        Step length [s]; ``dt_s <= 0`` returns ``u`` unchanged.
    accel : float
        Bound on the growth of |u| per second (unit/s).
    decel : float
        Bound on the fall of |u| per second (unit/s).

    Returns
    -------
    float
        The new output, by the three cases in the module docstring.
    """
    if dt_s <= 0.0 or u == r:
        return u
    if u == 0.0 or (r != 0.0 and (u > 0.0) == (r > 0.0)):
        bound = (accel if abs(r) >= abs(u) else decel) * dt_s
        return u + clamp(r - u, -bound, bound)
    t_zero_s = abs(u) / decel
    if dt_s < t_zero_s:
        return u - math.copysign(decel * dt_s, u)
    magnitude = min(abs(r), accel * (dt_s - t_zero_s))
    return math.copysign(magnitude, r) if magnitude > 0.0 else 0.0
