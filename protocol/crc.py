"""CRC-32C (Castagnoli) of the frame, through crcmod's C extension.

Same parameters as crcmod.predefined 'crc-32c': polynomial 0x1EDC6F41 reflected,
initial value and final XOR 0xFFFFFFFF. The check value of b"123456789" is 0xE3069283.
"""

from __future__ import annotations

from collections.abc import Callable

import crcmod.predefined

try:  # the pure-Python fallback of crcmod is ~50x slower; refuse to run silently on it
    import crcmod._crcfunext
except ImportError as exc:  # pragma: no cover - depends on the install
    raise ImportError(
        "crcmod was installed without its C extension; reinstall it with a C compiler and "
        "the Python headers present (make setup does this)"
    ) from exc

CHECK_VALUE = 0xE3069283
"""crc32c(b"123456789")."""

crc32c: Callable[[bytes | bytearray | memoryview], int] = crcmod.predefined.mkCrcFun("crc-32c")
"""CRC-32C of a byte string."""
