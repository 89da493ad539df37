"""What the bag package raises."""

from __future__ import annotations

from jackson.common.errors import JacksonError


class BagError(JacksonError, RuntimeError):
    """A bag cannot be created, written or repaired (the message names the folder)."""
