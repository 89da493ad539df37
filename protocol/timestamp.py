"""Unwrapping the MCU's u32 microsecond timestamp (protocol/spec.md, "Time")."""

from __future__ import annotations

WRAP_US = 1 << 32
"""The timestamp wraps every 2^32 us (71.6 min)."""

RESET_BACKSTEP_US = 1_000_000
"""A step back larger than this is taken as an MCU reset, not reordering."""


class TimestampUnwrapper:
    """Turns successive u32 timestamps into a monotonic 64-bit microsecond count.

    Each new stamp is placed at the signed 32-bit difference from the previous one,
    so a wrap (0xFFFFFFF0 -> 0x10) moves forward by 0x20 us. A step back of more than
    :data:`RESET_BACKSTEP_US` means the MCU restarted: the count then continues from
    the last value, and :attr:`resets` counts it.
    """

    def __init__(self) -> None:
        self._last_raw: int | None = None
        self.value_us = 0
        self.resets = 0
        self._reanchor = False

    def reanchor(self) -> None:
        """The next stamp belongs to a new MCU clock (a reset the host knows of, e.g. a new
        ``boot_id``): it is placed 1 us after the last value, whatever its raw value."""
        self._reanchor = self._last_raw is not None

    def unwrap(self, t_us: int) -> int:
        """The unwrapped time of a raw u32 stamp."""
        if self._last_raw is None:
            self.value_us = t_us
        elif self._reanchor:
            self._reanchor = False
            self.value_us += 1
        else:
            delta = (t_us - self._last_raw) % WRAP_US
            if delta >= WRAP_US // 2:
                delta -= WRAP_US
            if delta < -RESET_BACKSTEP_US:
                self.resets += 1
                delta = 0
            self.value_us += delta
        self._last_raw = t_us
        return self.value_us
