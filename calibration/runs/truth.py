"""The twin's ground truth as the tape measure: a run's true poses from ``jackson sim --truth``.

``jackson sim --truth PATH`` writes the twin's pose at every telemetry instant to a growing
CSV file (:class:`jackson.sim.runner.TruthStream`), flushed before the frame of that instant
is sent; so when a run has ended, its truth is in the file, whichever process reads it. A run
folder holds the MCU's 32-bit telemetry clock [us]; the twin's simulated time is that clock
without the wrap, so the run's first frame is found in the file at the newest time congruent
to it modulo 2^32 that covers the whole run, and the boot_id the run's INFO carries must be
the one in the file's first line (a run of another twin session is refused).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from jackson.calibration.procedures import CalibrationError, Reference, RunData
from jackson.sim.runner import TruthFileError, TruthTrack, read_truth

WRAP_US = 1 << 32  # the MCU's telemetry clock wraps here (protocol/spec.md: u32 t_us)


def load_twin_truth(path: str | Path) -> TruthTrack:
    """Read the ground-truth file of ``jackson sim --truth`` (as far as it is written).

    Parameters
    ----------
    path : str or Path
        The file.

    Returns
    -------
    TruthTrack
        Its rows.

    Raises
    ------
    CalibrationError
        A missing or damaged file, or another format.
    """
    try:
        return read_truth(path)
    except TruthFileError as exc:
        raise CalibrationError(str(exc)) from exc


def truth_reference(run: RunData, truth: TruthTrack, boot_ids: set[int]) -> Reference:
    """The twin's true pose at each frame of a run, on the run's clock.

    Parameters
    ----------
    run : RunData
        A run recorded on the twin that wrote ``truth``.
    truth : TruthTrack
        The twin's ground truth (:func:`load_twin_truth`).
    boot_ids : set of int
        The boot_ids the run's INFO messages carried (:func:`run_boot_ids`); empty: unchecked.

    Returns
    -------
    Reference
        Times ``run.t_s`` and the true x, y [m] and unwrapped heading [rad] at them.

    Raises
    ------
    CalibrationError
        The run was recorded on another twin session, or the file does not cover it.
    """
    if truth.boot_id is not None and boot_ids and truth.boot_id not in boot_ids:
        ids = ", ".join(f"{b:#010x}" for b in sorted(boot_ids))
        raise CalibrationError(
            f"run {run.name}: recorded on a twin with boot_id {ids}, but {truth.path} is the "
            f"truth of boot_id {truth.boot_id:#010x}: give the truth file of that twin session"
        )
    offsets_us = np.rint((run.t_s - run.t_s[0]) * 1e6).astype(np.int64)
    raw0 = round(float(run.t_s[0]) * 1e6) % WRAP_US
    span = int(offsets_us[-1])
    lo, hi = int(truth.t_us[0]), int(truth.t_us[-1])
    newest = (hi - span - raw0) // WRAP_US
    oldest = -((raw0 - lo) // WRAP_US)
    if newest < oldest:
        raise CalibrationError(
            f"run {run.name}: its frames (MCU time {raw0 / 1e6:.2f}-{(raw0 + span) / 1e6:.2f} s) "
            f"are not in the twin's truth {truth.path} ({lo / 1e6:.2f}-{hi / 1e6:.2f} s): was it "
            "recorded on the twin that writes that file?"
        )
    t_us = (raw0 + newest * WRAP_US + offsets_us).astype(np.float64)
    t_truth = truth.t_us.astype(np.float64)
    return Reference(
        run.t_s.copy(),
        np.interp(t_us, t_truth, truth.x_m),
        np.interp(t_us, t_truth, truth.y_m),
        np.interp(t_us, t_truth, truth.yaw_rad),
    )


def truth_distance_m(reference: Reference) -> float:
    """What a tape measures after a straight run: the axle midpoint's displacement from the
    first frame to the last [m]."""
    return float(
        np.hypot(reference.x_m[-1] - reference.x_m[0], reference.y_m[-1] - reference.y_m[0])
    )


def truth_rotation_rad(reference: Reference) -> float:
    """The rotation a run really made, counter-clockwise positive [rad]: the change of the
    unwrapped heading from the first frame to the last (what counting the turns gives)."""
    return float(reference.yaw_rad[-1] - reference.yaw_rad[0])
