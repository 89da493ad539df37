"""The paper's figures for its physical robot that the fidelity campaign holds the twin to.

The 16 Stage 1-2 figures of :data:`FIGURES` (Tables 5-7, 11 and 13), Stage 3's continuous outcomes
of :data:`STAGE3_FIGURES` (Table 14) and its discrete ones (:data:`PAPER_STAGE3_SUCCESS`,
:data:`PAPER_STAGE3_CONTACTS`), and the further :data:`CHECKS` the page shows outside the count.
"""

from __future__ import annotations

from dataclasses import dataclass

STAGES = ("square", "figure8", "maze")
"""The campaigns of the report, in the order they run."""

STAGE_NAMES = {"square": "square", "figure8": "figure-eight", "maze": "Stage 3"}
DEFAULT_ROBOT = "jackson_physical"
SD_RATIO_RANGE = (0.5, 2.0)  # our SD over the paper's that passes (F test, n = 10, 5 %)


@dataclass(frozen=True)
class Figure:
    """One of the paper's figures for its physical robot, and the run metric we hold to it.

    Attributes
    ----------
    mission : str
        The campaign that gives it: ``square``, ``figure8`` or ``maze``.
    key : str
        The per-trial metric (a key of the campaign's ``runs.json``).
    label : str
        Name with its unit, as the tables print it (``"EKF closure [cm]"``).
    table : str
        The paper's table (``"T5"``).
    paper_mean, paper_sd : float
        The physical robot's mean and SD.
    decimals : int
        Digits after the point in the tables.
    within_sd : float
        Our mean agrees when within this many of the paper's SDs of its mean.
    isaac : str
        The paper's Isaac Sim twin, as text ("" where not quoted).
    """

    mission: str
    key: str
    label: str
    table: str
    paper_mean: float
    paper_sd: float
    decimals: int = 2
    within_sd: float = 1.0
    isaac: str = ""

    @property
    def stage(self) -> str:
        """``square``, ``figure-eight`` or ``Stage 3``."""
        return STAGE_NAMES[self.mission]

    @property
    def heading(self) -> str:
        """``"EKF closure [cm] (T5)"``."""
        return f"{self.label} ({self.table})"

    def number(self, value: float) -> str:
        """``value`` with this figure's decimals."""
        return f"{value:.{self.decimals}f}"

    @property
    def paper_text(self) -> str:
        """``"1.18 ± 0.96"``."""
        return f"{self.number(self.paper_mean)} ± {self.number(self.paper_sd)}"


FIGURES: tuple[Figure, ...] = (
    Figure("square", "ekf_closure_cm", "EKF closure [cm]", "T5", 1.18, 0.96),
    Figure("square", "ekf_final_heading_deg", "EKF final heading error [deg]", "T5", 1.41, 1.02),
    Figure("square", "ekf_cross_track_rmse_cm",
           "EKF RMSE to the nominal square [cm]", "T5", 2.46, 0.36),
    Figure("square", "duration_s", "duration [s]", "T11", 47.52, 0.26),
    Figure("square", "odom_closure_cm", "raw-odometry closure [cm]", "T5", 36.35, 13.90),
    Figure("square", "odom_final_heading_deg",
           "raw-odometry final heading error [deg]", "T5", 25.97, 10.21),
    Figure("square", "odom_cross_track_rmse_cm",
           "raw-odometry RMSE to the nominal square [cm]", "T5", 14.75, 4.09),
    Figure("figure8", "gt_loop_diameter_ccw_m",
           "CCW loop diameter (floor) [m]", "T6", 1.0795, 0.0167, decimals=4),
    Figure("figure8", "gt_loop_diameter_cw_m",
           "CW loop diameter (floor) [m]", "T6", 1.1280, 0.0322, decimals=4),
    Figure("figure8", "gt_closure_cm", "closure, floor (ground truth) [cm]", "T6", 11.59, 3.14),
    Figure("figure8", "ekf_closure_cm", "EKF closure [cm]", "T6", 6.90, 0.73),
    Figure("figure8", "odom_closure_cm", "raw-odometry closure [cm]", "T7", 207.0, 26.0),
    Figure("figure8", "optimism_gap_cm", "optimism gap (floor - EKF) [cm]", "T13", 4.69, 2.82),
    Figure("figure8", "ekf_final_heading_deg",
           "EKF final heading residual [deg]", "T6", 1.42, 0.22),
    Figure("figure8", "duration_s", "duration [s]", "T6", 96.43, 2.07),
    Figure("figure8", "ekf_cross_track_rmse_cm", "EKF cross-track RMSE [cm]", "T6", 9.48, 1.39),
)  # fmt: skip
"""The 16 Stage 1-2 figures of the physical robot (REFERENCE.md), in the order of the table."""

STAGE3_FIGURES: tuple[Figure, ...] = (
    Figure("maze", "t_nav_s", "t_nav [s]", "T14", 22.405, 0.816,
           decimals=3, within_sd=2.0, isaac="median 13.317"),
    Figure("maze", "d_min_m", "d_min, truth [m]", "T14", 0.122, 0.007,
           decimals=3, within_sd=2.0, isaac="0.074 ± 0.016"),
    Figure("maze", "d_min_estimate_m", "d_min, the robot's own estimate [m]", "T14", 0.122,
           0.007, decimals=3, within_sd=2.0),
    Figure("maze", "path_length_m", "path length [m]", "T14", 1.958, 0.014,
           decimals=3, within_sd=2.0, isaac="1.888 ± 0.039"),
)  # fmt: skip
"""Stage 3's continuous outcomes on the physical robot (Table 14; the Isaac twin beside). The
physical robot's d_min is of its own AMCL estimate (it had no ground truth), the Isaac twin's of
its ground truth: ours is given both ways."""

CHECKS: tuple[Figure, ...] = (
    Figure("square", "ekf_path_m", "EKF path length [m]", "T5", 4.133, 0.020, decimals=3),
    Figure("figure8", "ekf_path_m", "EKF path length [m]", "T6", 6.96, 0.11),
    Figure("figure8", "ekf_max_cross_track_cm",
           "EKF largest cross-track deviation [cm]", "T7", 22.52, 3.04),
)  # fmt: skip
"""Further figures of the physical robot that no value of the twin or the configuration was
identified from: the page shows them as checks, outside the count of 16."""

PAPER_STAGE3_SUCCESS = (10, 10)  # goals reached / runs, physical and Isaac alike (T14)
PAPER_STAGE3_CONTACTS = 0
