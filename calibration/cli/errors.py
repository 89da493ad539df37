"""The error a user of ``jackson calibrate`` can cause with its options or answers."""

from __future__ import annotations

from jackson.common.errors import JacksonError


class CalibrateCliError(JacksonError):
    """A bad combination of options or answers: one line, exit status 2."""
