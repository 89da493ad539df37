"""``python -m jackson`` is the ``jackson`` command."""

from jackson.main import entry

entry()
