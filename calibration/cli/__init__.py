"""``jackson calibrate``: the calibration procedures of Appendix A and B on the command line.

Each procedure either records the runs it needs on a connected robot or twin
(``--port P [--i2c BUS]``) or works from run folders recorded before (``--runs DIR...``),
prints its result next to the paper's values, and with ``--write CONFIG`` writes the new values
into the host YAML (showing the diff, keeping ``CONFIG.bak-<time>``, keeping the comments).

    jackson calibrate encoders      straight floor runs and a tape measure: ticks_per_rev
    jackson calibrate track         in-place rotations: wheel_separation_m
    jackson calibrate imu           standing still and a spin: imu.calibration, yaw-sign audit
    jackson calibrate deadband      raw duty staircases: deadband.{left,right}.{forward,reverse}
    jackson calibrate characterise  a full-duty step and a brake: top speed, t90, stopping
    jackson calibrate twin-fit      runs and reference trajectories: effective r, B, yaw scale

On the twin, ``--twin-truth PATH`` (the file ``jackson sim --truth PATH`` writes) answers the
tape measure and the turn count of ``encoders`` and ``track`` and is the reference of
``twin-fit``, read for each run by its MCU time, from another process as well.

Errors a user can cause end as one line and exit status 2; so does a result that is not a
number (it is never printed or written as one).
"""

from __future__ import annotations

from jackson.calibration.cli.commands import COMMANDS, run
from jackson.calibration.cli.errors import CalibrateCliError
from jackson.calibration.cli.parser import add_parser

__all__ = ["COMMANDS", "CalibrateCliError", "add_parser", "run"]
