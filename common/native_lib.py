"""Shared libraries compiled from one C++ source each and loaded with :mod:`ctypes` only while
the source is the one they were built from (``jackson.host.nav.native``,
``jackson.protocol.native``; docs/compiled.md).

``make setup`` (``tools/build_compiled.py``) names a build by the digest of its source's bytes,
``build/compiled-<what>/<digest>/lib<name>.so``; :func:`select` loads the build of the source
as it is now, or says in one line why the interpreted code runs instead.
"""

from __future__ import annotations

import ctypes
import hashlib
import os
from collections.abc import Callable
from pathlib import Path

DIGEST_HEX = 16


def source_digest(source: bytes) -> str:
    """A build's name: the first :data:`DIGEST_HEX` hex digits of the source's SHA-256."""
    return hashlib.sha256(source).hexdigest()[:DIGEST_HEX]


def select(
    source: Path,
    build_path: Callable[[str], Path],
    load: Callable[[Path], ctypes.CDLL],
    env_interpreted: str,
) -> tuple[ctypes.CDLL | None, str]:
    """The build of ``source`` as it is now, loaded, or None; and why, one line.

    Parameters
    ----------
    source : Path
        The C++ source.
    build_path : callable
        The build's path for a digest.
    load : callable
        Loads a build and declares its functions (raises OSError when it cannot).
    env_interpreted : str
        The environment variable that, set to anything but ``0``, keeps the interpreted code.

    Returns
    -------
    tuple
        (the library or None, "compiled (path)" or "numpy (why)").
    """
    if os.environ.get(env_interpreted, "") not in ("", "0"):
        return None, f"numpy ({env_interpreted} is set)"
    try:
        digest = source_digest(source.read_bytes())
    except OSError as e:
        return None, f"numpy (cannot read the source: {e})"
    path = build_path(digest)
    if not path.is_file():
        return None, f"numpy (no build of {source.name} {digest}; make setup)"
    try:
        return load(path), f"compiled ({path})"
    except OSError as e:
        return None, f"numpy (the build does not load: {e})"
