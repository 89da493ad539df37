"""Does the EKF's covariance tell the truth? NEES of the pose against the twin's ground truth.

At every row of a run's ``ekf.csv`` (30 Hz of MCU time) the pose error is

    e_k = [x_ekf - x_gt, y_ekf - y_gt, wrap(yaw_ekf - yaw_gt)]

with the ground truth (``ground_truth.csv``, every physics step) linearly interpolated at the
row's MCU time (its heading unwrapped first) and carried into the EKF's odom frame: the truth
is moved rigidly so that at the first usable row it coincides with the EKF's pose there (the
filter starts at (0, 0, 0) where the robot stands). The NEES eps_k = e_k^T P_k^-1 e_k with P_k
the row's 3x3 pose covariance (p_xx ... p_yyaw) is chi-square with 3 degrees of freedom when
the covariance is right (:func:`jackson.experiments.metrics.nees`); the share of rows inside,
above (optimistic: the errors are larger than P says) and below (pessimistic) the two-sided
95 % band [0.216, 9.348] is the verdict. The rows are evenly spaced in time, so a share of
rows is a share of time.

Left out, and counted: rows before the filter is initialised (a pose or covariance field that
is empty or not finite), rows outside the ground truth's time span, rows before the robot
first moves (the truth within :data:`MOTION_M` and :data:`MOTION_RAD` of where it stood at the
first row: the truth is put onto the estimate there, so their error is zero by construction,
not by estimation, and below the band whatever P says), and rows whose P is singular (the NEES
is undefined; :data:`jackson.experiments.metrics.SINGULAR_RCOND`).

At the end of the run: the true end-point error ||p_ekf - p_gt|| beside the covariance's own
2-sigma radius 2 sqrt(lambda_max(P_xy)) (:func:`jackson.experiments.metrics.position_two_sigma`),
and the closure figures of the paper (ground truth, EKF, the optimism gap between them).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from jackson.common.errors import JacksonError
from jackson.experiments import metrics as m

FloatArray = npt.NDArray[np.float64]

POSE_DOF = 3  # [x, y, yaw]
EKF_POSE = ("x_m", "y_m", "yaw_rad")
EKF_COVARIANCE = ("p_xx", "p_yy", "p_yawyaw", "p_xy", "p_xyaw", "p_yyaw")
TRUTH_POSE = ("t_s", "x_m", "y_m", "yaw_rad")
PAPER_OPTIMISM_GAP_CM = (4.69, 2.82)  # physical robot, figure-eight: mean, SD (Sec. 4.2)
AVERAGE_GRID_S = 1.0 / 30.0  # [s] time step of the campaign's average NEES (the EKF's rate)
MOTION_M = 1e-3  # [m] the truth this far from where it stood: the robot has moved
MOTION_RAD = 1e-3  # [rad] or turned this far


class ConsistencyError(JacksonError, ValueError):
    """A run folder the NEES cannot be computed from (missing file, column or rows)."""


@dataclass(frozen=True)
class RunConsistency:
    """The consistency of one run's EKF covariance against its ground truth.

    Attributes
    ----------
    folder : Path
        The run folder.
    t_s : numpy.ndarray, shape (N,)
        MCU time of each ekf.csv row used [s].
    errors : numpy.ndarray, shape (N, 3)
        EKF pose minus ground truth [m, m, rad], the heading wrapped.
    covariances : numpy.ndarray, shape (N, 3, 3)
        The EKF's pose covariance at those rows.
    nees : numpy.ndarray, shape (N,)
        e^T P^-1 e of the pose (3 degrees of freedom).
    nees_xy, nees_yaw : numpy.ndarray, shape (N,)
        The same of the position alone (2 dof, the 2x2 block) and of the heading alone (1 dof),
        to tell which error breaks the band.
    band : tuple of float
        The two-sided 95 % chi-square band of a 3-dof NEES.
    rows_uninitialised, rows_without_truth, rows_before_motion, rows_singular : int
        ekf.csv rows left out: before the filter is initialised (empty or non-finite fields),
        outside the ground truth's time span, before the robot first moves (none of
        ``t_s``, ``errors``, ``covariances`` or the NEES), with a singular P.
    end_error_m : float
        ||p_ekf - p_gt|| at the last row [m].
    end_position_2sigma_m : float
        2 sqrt(lambda_max) of the last row's position covariance [m].
    gt_closure_m, ekf_closure_m : float
        Closure error ||p_N - p_1|| of the ground truth and of the EKF (Sec. 2.5.2) [m].
    """

    folder: Path
    t_s: FloatArray
    errors: FloatArray
    covariances: FloatArray
    nees: FloatArray
    nees_xy: FloatArray
    nees_yaw: FloatArray
    band: tuple[float, float]
    rows_uninitialised: int
    rows_without_truth: int
    rows_before_motion: int
    rows_singular: int
    end_error_m: float
    end_position_2sigma_m: float
    gt_closure_m: float
    ekf_closure_m: float

    @property
    def rows(self) -> int:
        """Rows with a defined NEES."""
        return int(np.count_nonzero(np.isfinite(self.nees)))

    def _fraction(self, mask: npt.NDArray[np.bool_]) -> float:
        return float(np.count_nonzero(mask)) / self.rows if self.rows else math.nan

    @property
    def in_band_fraction(self) -> float:
        """Share of rows (of time) with lower <= NEES <= upper."""
        lo, hi = self.band
        return self._fraction((self.nees >= lo) & (self.nees <= hi))

    @property
    def above_fraction(self) -> float:
        """Share above the band: the covariance is optimistic."""
        return self._fraction(self.nees > self.band[1])

    @property
    def below_fraction(self) -> float:
        """Share below the band: the covariance is pessimistic."""
        return self._fraction(self.nees < self.band[0])

    @property
    def nees_mean(self) -> float:
        """Time average of the NEES (3 for a consistent filter)."""
        return _nanmean(self.nees)

    @property
    def end_error_covered(self) -> bool:
        """Whether the end position's 2-sigma radius reaches the true end-point error."""
        return bool(self.end_error_m <= self.end_position_2sigma_m)

    @property
    def optimism_gap_m(self) -> float:
        """Ground-truth minus EKF closure (Sec. 4.2) [m]."""
        return m.optimism_gap(self.ekf_closure_m, self.gt_closure_m)

    def metrics(self) -> dict[str, Any]:
        """The per-run figures a trial's ``metrics.json`` carries (lengths in cm).

        Returns
        -------
        dict
            ``nees_in_band_fraction``, ``nees_above_fraction``, ``nees_below_fraction``,
            ``nees_mean``, ``nees_xy_mean``, ``nees_yaw_mean``, ``nees_rows`` and the rows
            left out (``nees_rows_uninitialised``, ``nees_rows_without_truth``,
            ``nees_rows_before_motion``, ``nees_rows_singular``), ``end_error_cm``,
            ``end_position_2sigma_cm`` (2 sqrt of the largest eigenvalue of the end position's
            2x2 covariance) and
            ``end_error_covered``.
        """
        return {
            "nees_in_band_fraction": self.in_band_fraction,
            "nees_above_fraction": self.above_fraction,
            "nees_below_fraction": self.below_fraction,
            "nees_mean": self.nees_mean,
            "nees_xy_mean": _nanmean(self.nees_xy),
            "nees_yaw_mean": _nanmean(self.nees_yaw),
            "nees_rows": self.rows,
            "nees_rows_uninitialised": self.rows_uninitialised,
            "nees_rows_without_truth": self.rows_without_truth,
            "nees_rows_before_motion": self.rows_before_motion,
            "nees_rows_singular": self.rows_singular,
            "end_error_cm": self.end_error_m * 100.0,
            "end_position_2sigma_cm": self.end_position_2sigma_m * 100.0,
            "end_error_covered": self.end_error_covered,
        }


def _nanmean(values: FloatArray) -> float:
    finite = values[np.isfinite(values)]
    return float(np.mean(finite)) if finite.size else math.nan


def significant(value: float, digits: int = 3) -> str:
    """``value`` with ``digits`` significant digits, trailing zeros kept: 3.00, 0.000944, 545.

    Parameters
    ----------
    value : float
        The number (a NEES spans decades).
    digits : int
        Significant digits, >= 1.

    Returns
    -------
    str
        Fixed-point text; "0", "nan" or "inf" as they are.
    """
    if not math.isfinite(value) or value == 0.0:
        return f"{value:.0f}"
    return f"{value:.{max(0, digits - 1 - math.floor(math.log10(abs(value))))}f}"


def read_columns(path: Path, columns: Sequence[str]) -> FloatArray:
    """The named columns of a CSV file with a header, as an (N, len(columns)) float array.

    Empty fields become NaN (how a row without a value reads).

    Raises
    ------
    ConsistencyError
        The file is missing or unreadable, or lacks one of the columns.
    """
    try:
        with path.open(encoding="utf-8") as f:
            header = f.readline().strip().split(",")
            missing = [c for c in columns if c not in header]
            if missing:
                raise ConsistencyError(
                    f"{path}: no column {', '.join(missing)} (recorded before the EKF's pose "
                    "covariance was logged?)"
                )
            data = np.genfromtxt(
                f,
                delimiter=",",
                usecols=[header.index(c) for c in columns],
                dtype=np.float64,
                ndmin=2,
            )
    except OSError as exc:
        raise ConsistencyError(f"{path}: cannot read it ({exc.strerror or exc})") from exc
    except ValueError as exc:
        raise ConsistencyError(f"{path}: not a table of numbers ({exc})") from exc
    return np.asarray(data, dtype=np.float64).reshape(-1, len(columns))


def pose_covariances(p: FloatArray) -> FloatArray:
    """(N, 3, 3) pose covariances from the columns p_xx, p_yy, p_yawyaw, p_xy, p_xyaw, p_yyaw.

    Parameters
    ----------
    p : numpy.ndarray, shape (N, 6)
        The six columns in that order.

    Returns
    -------
    numpy.ndarray, shape (N, 3, 3)
        Symmetric matrices over [x, y, yaw].
    """
    xx, yy, aa, xy, xa, ya = (p[:, i] for i in range(6))
    return np.stack(
        (np.stack((xx, xy, xa), -1), np.stack((xy, yy, ya), -1), np.stack((xa, ya, aa), -1)),
        axis=1,
    )


def truth_in_odom_frame(
    t_s: FloatArray, truth: FloatArray, t_gt_s: FloatArray, anchor: FloatArray
) -> FloatArray:
    """Ground truth interpolated at ``t_s`` and moved into the EKF's odom frame.

    The rigid motion T maps the truth's pose at t_s[0] onto ``anchor`` (the EKF's pose then):
    T = anchor * truth(t_s[0])^-1, applied to the truth at every time. The heading is unwrapped
    before the interpolation and not wrapped after.

    Parameters
    ----------
    t_s : numpy.ndarray, shape (N,)
        Times to interpolate at [s], within the truth's span.
    truth : numpy.ndarray, shape (M, 3)
        x [m], y [m], yaw [rad] of the ground truth.
    t_gt_s : numpy.ndarray, shape (M,)
        Its times [s], increasing.
    anchor : numpy.ndarray, shape (3,)
        The EKF's pose at t_s[0].

    Returns
    -------
    numpy.ndarray, shape (N, 3)
        The truth in the odom frame at t_s.
    """
    yaw = np.unwrap(truth[:, 2])
    gx, gy, gyaw = (np.interp(t_s, t_gt_s, col) for col in (truth[:, 0], truth[:, 1], yaw))
    rot = float(anchor[2]) - float(gyaw[0])
    c, s = math.cos(rot), math.sin(rot)
    dx, dy = gx - gx[0], gy - gy[0]
    return np.column_stack(
        (anchor[0] + c * dx - s * dy, anchor[1] + s * dx + c * dy, gyaw + rot)
    ).astype(np.float64)


def consistency_of(
    t_s: FloatArray,
    pose: FloatArray,
    covariance: FloatArray,
    t_gt_s: FloatArray,
    truth: FloatArray,
    folder: Path = Path("."),
) -> RunConsistency:
    """The consistency figures of an EKF output series against a ground truth.

    Parameters
    ----------
    t_s : numpy.ndarray, shape (N,)
        MCU time of each EKF output [s].
    pose : numpy.ndarray, shape (N, 3)
        EKF x [m], y [m], yaw [rad]; non-finite in rows before the filter is initialised.
    covariance : numpy.ndarray, shape (N, 3, 3)
        The EKF's pose covariance at each row.
    t_gt_s : numpy.ndarray, shape (M,)
        Ground-truth times on the same clock [s], increasing.
    truth : numpy.ndarray, shape (M, 3)
        Ground-truth x, y, yaw in any fixed frame.
    folder : Path
        Where the data came from, kept in the result.

    Returns
    -------
    RunConsistency

    Raises
    ------
    ConsistencyError
        No row is initialised and inside the truth's time span.
    """
    initialised = (
        np.isfinite(t_s) & np.isfinite(pose).all(axis=1) & np.isfinite(covariance).all(axis=(1, 2))
    )
    if t_gt_s.size == 0:
        raise ConsistencyError(f"{folder}: the ground truth is empty")
    with_truth = (t_s >= t_gt_s[0]) & (t_s <= t_gt_s[-1])
    use = initialised & with_truth
    if not use.any():
        raise ConsistencyError(
            f"{folder}: no EKF output is initialised and within the ground truth's time span"
        )
    t, p_est, cov = t_s[use], pose[use], covariance[use]
    gt = truth_in_odom_frame(t, truth, t_gt_s, p_est[0])
    err = p_est - gt
    err[:, 2] = m.wrap_angle(err[:, 2])
    first = first_motion(gt)
    moving = slice(first, None)
    eps = m.nees(err[moving], cov[moving])
    eps_xy = m.nees(err[moving, :2], cov[moving, :2, :2])
    eps_yaw = m.nees(err[moving, 2:], cov[moving, 2:, 2:])
    gt_valid = np.isfinite(truth).all(axis=1)
    return RunConsistency(
        folder=folder,
        t_s=t[moving],
        errors=err[moving],
        covariances=cov[moving],
        nees=eps,
        nees_xy=eps_xy,
        nees_yaw=eps_yaw,
        band=m.nees_band(POSE_DOF),
        rows_uninitialised=int(np.count_nonzero(~initialised)),
        rows_without_truth=int(np.count_nonzero(initialised & ~with_truth)),
        rows_before_motion=first,
        rows_singular=int(np.count_nonzero(~np.isfinite(eps))),
        end_error_m=float(np.hypot(err[-1, 0], err[-1, 1])),
        end_position_2sigma_m=m.position_two_sigma(cov[-1, :2, :2]),
        gt_closure_m=m.closure_error(truth[gt_valid, :2]),
        ekf_closure_m=m.closure_error(p_est[:, :2]),
    )


def first_motion(truth: FloatArray) -> int:
    """Index of the first row where the truth (x, y, yaw rows) is more than :data:`MOTION_M`
    or :data:`MOTION_RAD` from its first row; its length when the robot never moves."""
    moved = (np.hypot(truth[:, 0] - truth[0, 0], truth[:, 1] - truth[0, 1]) > MOTION_M) | (
        np.abs(m.wrap_angle(truth[:, 2] - truth[0, 2])) > MOTION_RAD
    )
    return int(np.argmax(moved)) if moved.any() else int(truth.shape[0])


def run_consistency(folder: Path) -> RunConsistency:
    """The consistency figures of a run folder with ``ekf.csv`` and ``ground_truth.csv``.

    Parameters
    ----------
    folder : Path
        A twin run (``jackson run``, a campaign's ``runs/Rnn``).

    Returns
    -------
    RunConsistency

    Raises
    ------
    ConsistencyError
        A file or column is missing, or no row can be compared.
    """
    ekf = read_columns(folder / "ekf.csv", ("t_s", *EKF_POSE, *EKF_COVARIANCE))
    gt = read_columns(folder / "ground_truth.csv", TRUTH_POSE)
    if gt.shape[0] < 2 or np.any(np.diff(gt[:, 0]) <= 0.0):
        raise ConsistencyError(
            f"{folder / 'ground_truth.csv'}: needs two or more rows, time increasing"
        )
    return consistency_of(
        ekf[:, 0], ekf[:, 1:4], pose_covariances(ekf[:, 4:10]), gt[:, 0], gt[:, 1:4], folder
    )


@dataclass(frozen=True)
class CampaignConsistency:
    """The runs of a campaign pooled, and their average NEES over time.

    Attributes
    ----------
    runs : tuple of RunConsistency
    in_band_fraction, above_fraction, below_fraction : float
        Shares of all runs' rows together.
    nees_mean : float
        Mean NEES over all rows.
    t_s : numpy.ndarray, shape (K,)
        MCU times of the average, every 1/30 s over the span all runs cover [s].
    average_nees : numpy.ndarray, shape (K,)
        The N runs' mean NEES at those times (each run interpolated).
    average_band : tuple of float
        The 95 % band of an N-run mean (:func:`jackson.experiments.metrics.nees_band`).
    average_in_band_fraction : float
        Share of ``t_s`` with the average inside its band.
    covered : int
        Runs whose end-position 2-sigma reaches the true end-point error.
    """

    runs: tuple[RunConsistency, ...]
    in_band_fraction: float
    above_fraction: float
    below_fraction: float
    nees_mean: float
    t_s: FloatArray
    average_nees: FloatArray
    average_band: tuple[float, float]
    average_in_band_fraction: float
    covered: int

    def summary(self) -> dict[str, Any]:
        """The pooled figures as plain data (a campaign's ``summary.json``)."""
        skipped = {
            "uninitialised": sum(r.rows_uninitialised for r in self.runs),
            "without_truth": sum(r.rows_without_truth for r in self.runs),
            "before_motion": sum(r.rows_before_motion for r in self.runs),
            "singular": sum(r.rows_singular for r in self.runs),
        }
        return {
            "band": list(self.runs[0].band),
            "rows": sum(r.rows for r in self.runs),
            "rows_skipped": skipped,
            "in_band_fraction": self.in_band_fraction,
            "above_fraction": self.above_fraction,
            "below_fraction": self.below_fraction,
            "nees_mean": self.nees_mean,
            "average_band": list(self.average_band),
            "average_in_band_fraction": self.average_in_band_fraction,
            "end_error_covered_runs": self.covered,
            "runs_total": len(self.runs),
        }


def campaign_consistency(runs: Sequence[RunConsistency]) -> CampaignConsistency:
    """Pool the rows of several runs and average their NEES on a common time grid.

    Parameters
    ----------
    runs : sequence of RunConsistency
        At least one run.

    Returns
    -------
    CampaignConsistency
    """
    if not runs:
        raise ConsistencyError("no run to pool")
    eps = np.concatenate([r.nees[np.isfinite(r.nees)] for r in runs])
    lo, hi = runs[0].band
    n = eps.size

    def share(mask: npt.NDArray[np.bool_]) -> float:
        return float(np.count_nonzero(mask)) / n if n else math.nan

    spans = [r.t_s for r in runs if r.t_s.size]  # a run that never moved has no rows
    start = max((float(t[0]) for t in spans), default=0.0)
    stop = min((float(t[-1]) for t in spans), default=-1.0)
    grid: FloatArray = np.arange(start, stop + 1e-9, AVERAGE_GRID_S, dtype=np.float64)
    columns = []
    for r in runs:
        ok = np.isfinite(r.nees)
        columns.append(np.interp(grid, r.t_s[ok], r.nees[ok]) if ok.any() else grid * math.nan)
    average = np.mean(np.column_stack(columns), axis=1) if grid.size else np.zeros(0)
    a_lo, a_hi = m.nees_band(POSE_DOF, runs=len(runs))
    inside = (average >= a_lo) & (average <= a_hi)
    return CampaignConsistency(
        runs=tuple(runs),
        in_band_fraction=share((eps >= lo) & (eps <= hi)),
        above_fraction=share(eps > hi),
        below_fraction=share(eps < lo),
        nees_mean=float(np.mean(eps)) if n else math.nan,
        t_s=grid,
        average_nees=average,
        average_band=(a_lo, a_hi),
        average_in_band_fraction=float(np.mean(inside)) if grid.size else math.nan,
        covered=sum(1 for r in runs if r.end_error_covered),
    )


def plot_consistency(
    png: Path, campaign: CampaignConsistency, title: str = "", closed_path: bool = True
) -> None:
    """The NEES figure: NEES over time per run with the band, and the end point per run.

    Top: every run's NEES against MCU time (log scale), the 95 % band of one run shaded, the
    N-run average NEES with its own (narrower) band dashed, the expected value 3 dotted.
    Bottom, per run (symmetric log scale, linear within +-1 cm): ground-truth closure, EKF
    closure, their difference the optimism gap with the paper's 4.69 +- 2.82 cm shaded, the
    EKF's true end-point error and the covariance's end-position 2-sigma radius; the error is
    covered when its dot lies under the 2-sigma bar. A route that does not come back to its start
    (``closed_path`` False: a navigation) has no closure and no optimism gap: the bottom panel
    keeps the end-point error and the 2-sigma.

    Parameters
    ----------
    png : Path
        Output file (150 dpi).
    campaign : CampaignConsistency
        The runs (:func:`campaign_consistency`).
    title : str
        Title of the top panel.
    closed_path : bool
        The runs end where they started (the square, the figure-eight).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    runs = campaign.runs
    lo, hi = runs[0].band
    fig, (ax, bx) = plt.subplots(
        2, 1, figsize=(8.0, 8.5), gridspec_kw={"height_ratios": [3, 2]}, constrained_layout=True
    )
    ax.axhspan(lo, hi, color="C2", alpha=0.15, label=f"95 % band, one run [{lo:.3g}, {hi:.3g}]")
    for i, r in enumerate(runs):
        ok = np.isfinite(r.nees) & (r.nees > 0.0)
        ax.plot(r.t_s[ok], r.nees[ok], lw=0.6, alpha=0.5, label="each run" if i == 0 else None)
    if campaign.t_s.size:
        a_lo, a_hi = campaign.average_band
        ax.plot(campaign.t_s, campaign.average_nees, "k-", lw=1.6, label="average NEES")
        for y in (a_lo, a_hi):
            ax.axhline(y, color="k", ls="--", lw=0.8)
        ax.plot([], [], "k--", lw=0.8, label=f"band of a {len(runs)}-run average")
    ax.axhline(POSE_DOF, color="k", ls=":", lw=0.8, label="expected value 3")
    ax.set_yscale("log")
    positive = np.concatenate([r.nees[np.isfinite(r.nees) & (r.nees > 0.0)] for r in runs])
    if positive.size:  # the start's few rows of zero error would stretch the axis decades down
        ax.set_ylim(bottom=min(lo / 10.0, float(np.percentile(positive, 1.0)) / 2.0))
    ax.set_xlabel("MCU time (s)")
    ax.set_ylabel("NEES of [x, y, yaw]")
    ax.grid(alpha=0.3)
    ax.set_title(
        (f"{title}: " if title else "")
        + f"{campaign.in_band_fraction:.1%} in band, {campaign.above_fraction:.1%} above, "
        f"{campaign.below_fraction:.1%} below, mean {significant(campaign.nees_mean)}",
        fontsize=10,
    )
    ax.legend(fontsize=7, loc="best")

    idx = np.arange(len(runs))
    if closed_path:
        mean_gap, sd_gap = PAPER_OPTIMISM_GAP_CM
        bx.axhspan(
            mean_gap - sd_gap, mean_gap + sd_gap, color="C4", alpha=0.15, label="paper's gap ± SD"
        )
        bx.axhline(mean_gap, color="C4", lw=0.8)
    bx.bar(
        idx,
        [r.end_position_2sigma_m * 100 for r in runs],
        0.6,
        color="0.85",
        edgecolor="0.5",
        label="covariance 2-sigma at the end",
    )
    for key, marker, color, label in (
        ("gt", "o", "C0", "ground-truth closure"),
        ("ekf", "s", "C2", "EKF closure"),
        ("gap", "D", "C4", "optimism gap (GT - EKF)"),
        ("end", "x", "C3", "true end-point error of the EKF"),
    ):
        if not closed_path and key != "end":
            continue
        values = [
            {
                "gt": r.gt_closure_m,
                "ekf": r.ekf_closure_m,
                "gap": r.optimism_gap_m,
                "end": r.end_error_m,
            }[key]
            * 100
            for r in runs
        ]
        bx.plot(idx, values, marker, color=color, ls="none", ms=5, label=label)
    bx.set_yscale("symlog", linthresh=1.0)
    bx.set_xticks(idx, [r.folder.name or f"R{i + 1:02d}" for i, r in enumerate(runs)])
    bx.set_ylabel("cm")
    bx.grid(axis="y", alpha=0.3)
    bx.set_title(
        f"end point: 2-sigma covers the true error in {campaign.covered}/{len(runs)} runs",
        fontsize=10,
    )
    bx.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.1), ncol=3)
    from jackson.common.figures import save_figure

    save_figure(fig, png)
