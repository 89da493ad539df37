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
from typing import Any

import numpy as np
import numpy.typing as npt

DIGEST_HEX = 16

# Arrays go to the C functions as bare addresses (c_void_p): numpy's ctypes adapters
# (ndpointer, ndarray.ctypes) build reference cycles on every call, garbage the daemon's
# settled collector reaches only rarely, so its memory grew with the calls.
_BYTE = ctypes.c_char
_DTYPES: dict[type[np.generic], np.dtype[Any]] = {}  # each element type's dtype, made once


def pointer(a: npt.NDArray[Any], dtype: type[np.generic]) -> int:
    """The address of a C-contiguous array of ``dtype`` (the caller keeps the array alive).

    A writable array's through ctypes' buffer view (0.4 us, no cycle), a read-only or empty
    one's through ``__array_interface__`` (2 us: a navigating daemon takes about a hundred
    addresses a frame).

    Raises
    ------
    TypeError
        Another element type, or an array that is not C-contiguous.
    """
    want = _DTYPES.get(dtype)
    if want is None:
        want = _DTYPES.setdefault(dtype, np.dtype(dtype))
    if a.dtype is want or a.dtype == want:  # the same object but for an unpickled array's
        if a.size:
            try:  # ctypes refuses a buffer that is read-only or not C-contiguous
                return ctypes.addressof(_BYTE.from_buffer(a))  # type: ignore[arg-type]
            except TypeError:
                pass
        if a.flags.c_contiguous:
            return int(a.__array_interface__["data"][0])
    raise TypeError(f"expected a C-contiguous {np.dtype(dtype)} array, got {a.dtype}")


def address(a: npt.NDArray[Any]) -> int:
    """The address of a writable, C-contiguous, non-empty array (the caller keeps it alive and
    knows its type): :func:`pointer`'s fast case without its checks, for buffers made to
    measure."""
    return ctypes.addressof(_BYTE.from_buffer(a))  # type: ignore[arg-type]  # a buffer


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
