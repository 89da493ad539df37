"""The MCU's outputs on the twin's wheels: interlock line, PCA9685, TB6612.

The MCU's motor interlock line (docs/firmware.md, "Motor interlock") drives the pin the robot
file's ``wiring.interlock`` names, the PCA9685's OE or the TB6612's STBY, before the bridge
outputs are computed; so a host that stops sending heartbeats has its last PCA9685 duty cut at
the instant the MCU drops the line. With ``mcu_motors`` the MCU drives the TB6612 itself and
its duties go to the wheels as they are.
"""

from __future__ import annotations

from jackson.sim.config import WiringSpec
from jackson.sim.pca9685 import Pca9685
from jackson.sim.port import McuPort
from jackson.sim.robot import WheelDrive
from jackson.sim.tb6612 import BridgeOutput, bridge_outputs
from jackson.sim.twin import Twin


def wheel(b: BridgeOutput) -> WheelDrive:
    """A bridge's output as the wheel's drive: signed drive, and the brake on top of it."""
    return WheelDrive(b.drive, abs(b.drive) + b.brake_fraction)


class Drive:
    """What the twin's motors get from the MCU and the PCA9685.

    Parameters
    ----------
    twin : Twin
        The twin commanded.
    pca : Pca9685
        The PCA9685 the host writes on the virtual I2C bus.
    wiring : WiringSpec
        The robot's wiring (bridge channels, STBY channel, the interlock's pin).
    mcu_motors : bool
        The MCU drives the TB6612 itself (no PCA9685 in the path).
    """

    def __init__(self, twin: Twin, pca: Pca9685, wiring: WiringSpec, *, mcu_motors: bool) -> None:
        self.twin = twin
        self.pca = pca
        self.wiring = wiring
        self.mcu_motors = mcu_motors
        # bridge outputs of the last PCA9685 state (generation, which counts register writes and
        # OE changes) and STBY level, recomputed when either changes
        self._bridges: (
            tuple[tuple[int, bool, bool | None], tuple[BridgeOutput, BridgeOutput]] | None
        ) = None
        self.line_applied: bool | None = None  # the interlock level the models last saw

    def bridges(self, enable: bool) -> tuple[BridgeOutput, BridgeOutput]:
        """Both TB6612 bridges' outputs now: the interlock line ``enable`` applied to the pin
        it is wired to (``wiring.interlock``), then the PCA9685's channels through the truth
        table."""
        w, pca = self.wiring, self.pca
        self.line_applied = enable
        # OE is pulled up: released (False) disables the outputs; unwired, OE is tied low
        pca.output_enable = enable if w.interlock == "pca9685_oe" else True
        stby = enable if w.interlock == "tb6612_stby" else None  # pulled down: released = low
        key = (pca.generation, pca.output_enable, stby)
        if self._bridges is None or self._bridges[0] != key:
            outputs = bridge_outputs(pca, w.left, w.right, w.stby_channel, stby)
            self._bridges = (key, outputs)
        return self._bridges[1]

    def line_changed(self, enable: bool) -> bool:
        """The interlock line is not at the level the models last saw."""
        return enable != self.line_applied

    def actuate(self, port: McuPort) -> None:
        """Command the wheels: the MCU's own duties with ``mcu_motors``, else the bridges'
        outputs under its interlock line."""
        if self.mcu_motors:
            self.line_applied = port.motor_enable
            left, right, braked = port.wheel_duty()
            if braked:
                self.twin.command(WheelDrive.brake(), WheelDrive.brake())
            else:
                self.twin.command(WheelDrive(left, 1.0), WheelDrive(right, 1.0))
            return
        b_left, b_right = self.bridges(port.motor_enable)
        self.twin.command(wheel(b_left), wheel(b_right))
