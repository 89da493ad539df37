"""What mapping from a recording raises: one line naming the run folder and what to do."""

from __future__ import annotations

from jackson.common.errors import JacksonError


class RecordingMapError(JacksonError, ValueError):
    """A run folder cannot be mapped (one line naming the folder and what to do)."""


class NoBagError(RecordingMapError):
    """The folder does not exist or holds no bag."""


class NoScanError(RecordingMapError):
    """The bag has no /scan messages."""


class NoOdometryError(RecordingMapError):
    """The bag has neither /odometry/filtered nor /wheel/odom messages."""


class NoOverlapError(RecordingMapError):
    """No scan falls within the odometry's time span."""


class DamagedBagError(RecordingMapError):
    """A bag cannot be read (never closed, or corrupt)."""
