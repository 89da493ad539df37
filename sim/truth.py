"""The twin's ground truth as a file another process reads while the twin runs.

``jackson sim --truth PATH`` streams one CSV row per advance of the twin's clock
(:class:`TruthStream`), written and flushed before the MCU acts at that instant, so the row of
every telemetry frame is in the file before the frame is on the wire; :func:`read_truth` reads
it back. This is the "tape measure" of ``jackson calibrate --twin-truth`` in another process.
"""

from __future__ import annotations

import io
from dataclasses import dataclass
from pathlib import Path
from typing import TextIO

import numpy as np
from numpy.typing import NDArray

from jackson.common.errors import JacksonError
from jackson.sim.twin import Twin

TRUTH_MAGIC = "# jackson twin ground truth"
TRUTH_COLUMNS = ("t_us", "t_s", "x_m", "y_m", "yaw_rad")


class TruthFileError(JacksonError, ValueError):
    """A ground-truth file that cannot be read (one line naming the file)."""


class TruthStream:
    """The twin's ground truth as a CSV file that grows while the twin runs.

    The file starts with one comment line naming the session (``# jackson twin ground truth:
    boot_id 0x........, robot NAME, world NAME``; the boot_id is the one the MCU reports in
    INFO, so a run folder can be matched to its twin session), then the header
    ``t_us,t_s,x_m,y_m,yaw_rad`` and one row per advance of the twin's clock: the 64-bit
    simulated time (which the MCU's 32-bit telemetry clock is, modulo 2^32) [us], the same in
    seconds, the axle midpoint in the world frame [m] and the heading, continuous (not
    wrapped) [rad]. Each row is flushed as it is written. The file is replaced at each start.

    Parameters
    ----------
    path : str or Path
        Where to write.
    twin : Twin
        The twin whose truth is written (its current instant is the first row).
    boot_id : int
        The MCU's boot_id for this session.

    Raises
    ------
    OSError
        The file cannot be created.
    """

    def __init__(self, path: str | Path, twin: Twin, boot_id: int) -> None:
        self.path = Path(path)
        self._file: TextIO = self.path.open("w", encoding="ascii", newline="\n")
        self._last_us: int | None = None
        self.rows = 0
        self._file.write(
            f"{TRUTH_MAGIC}: boot_id {boot_id:#010x}, robot {twin.robot_spec.name}, "
            f"world {twin.world_spec.name}\n{','.join(TRUTH_COLUMNS)}\n"
        )
        self.write(twin)

    def write(self, twin: Twin) -> None:
        """Append the twin's pose at its current instant (once per instant) and flush."""
        t_us = twin.t_us
        if t_us == self._last_us or self._file.closed:
            return
        self._last_us = t_us
        s = twin.truth()
        self._file.write(f"{t_us},{t_us / 1e6:.6f},{s.x:.9f},{s.y:.9f},{s.yaw:.9f}\n")
        self._file.flush()
        self.rows += 1

    def close(self) -> None:
        self._file.close()


@dataclass(frozen=True)
class TruthTrack:
    """A ground-truth file read back (:func:`read_truth`).

    Attributes
    ----------
    path : Path
        The file.
    boot_id : int or None
        The MCU's boot_id of the session that wrote it (None: the file does not say).
    t_us : numpy.ndarray
        Simulated time of each row, int64, rising [us].
    x_m : numpy.ndarray
        Axle midpoint x in the world frame [m].
    y_m : numpy.ndarray
        Axle midpoint y [m].
    yaw_rad : numpy.ndarray
        Heading, unwrapped [rad].
    """

    path: Path
    boot_id: int | None
    t_us: NDArray[np.int64]
    x_m: NDArray[np.float64]
    y_m: NDArray[np.float64]
    yaw_rad: NDArray[np.float64]


def read_truth(path: str | Path) -> TruthTrack:
    """Read a ground-truth file that :class:`TruthStream` writes (possibly still growing: a
    last row without its newline is left out).

    Parameters
    ----------
    path : str or Path
        The file ``jackson sim --truth PATH`` writes.

    Returns
    -------
    TruthTrack
        Its rows.

    Raises
    ------
    TruthFileError
        A missing file, another format, or fewer than two rows.
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="ascii")
    except OSError as exc:
        raise TruthFileError(f"twin truth {p}: cannot read it ({exc.strerror})") from exc
    except UnicodeDecodeError as exc:
        raise TruthFileError(f"twin truth {p}: not a ground-truth file (not text)") from exc
    first, _, rest = text.partition("\n")
    header, _, body = rest.partition("\n")
    if not first.startswith(TRUTH_MAGIC) or header.strip() != ",".join(TRUTH_COLUMNS):
        raise TruthFileError(
            f"twin truth {p}: not a ground-truth file of jackson sim --truth (expected "
            f"{TRUTH_MAGIC!r} and the header {','.join(TRUTH_COLUMNS)})"
        )
    boot_id: int | None = None
    if "boot_id " in first:
        try:
            boot_id = int(first.split("boot_id ", 1)[1].split(",", 1)[0], 16)
        except ValueError:
            boot_id = None
    body = body[: body.rfind("\n") + 1]  # a row still being written is not a row yet
    try:
        data = np.loadtxt(io.StringIO(body), delimiter=",", ndmin=2, dtype=np.float64)
    except ValueError as exc:
        raise TruthFileError(f"twin truth {p}: a damaged row ({exc})") from exc
    if data.shape[0] < 2 or data.shape[1] != len(TRUTH_COLUMNS):
        raise TruthFileError(f"twin truth {p}: needs two or more rows of 5 numbers")
    t_us = data[:, 0].astype(np.int64)
    if np.any(np.diff(t_us) <= 0) or not np.all(np.isfinite(data)):
        raise TruthFileError(f"twin truth {p}: times must rise and every number be finite")
    yaw = np.asarray(np.unwrap(data[:, 4]), dtype=np.float64)
    return TruthTrack(p, boot_id, t_us, data[:, 2], data[:, 3], yaw)
