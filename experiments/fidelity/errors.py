"""The fidelity campaign's errors: what stops it before anything runs."""

from __future__ import annotations

from jackson.common.errors import JacksonError


class FidelityError(JacksonError):
    """A fidelity campaign cannot start: its notes file cannot be read, its docs path is
    unusable."""


class MechanismError(FidelityError):
    """A mechanism's patch does not fit the robot file or the host configuration."""
