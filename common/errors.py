"""The one base of every error the project raises on purpose.

A :class:`JacksonError` is something a user can cause or meet (a bad file, a missing port, a
firmware of another version, a build that is missing): its message is one line that says what
was wrong and what to do. The command line catches it once (``jackson``'s ``main``) and prints
that line with exit status 2; anything else is a bug and shows its traceback. Each error keeps
the standard base it had (ValueError, OSError, RuntimeError), so callers that catch those still
do.
"""

from __future__ import annotations


class JacksonError(Exception):
    """An error with a one-line message for the user (module docstring)."""
