"""The paper's Stage 1-2 figures beside which a campaign's report sets ours.

Per mission and metric, the paper's physical robot and its Isaac Sim twin (REFERENCE.md,
"Results to compare against"), as the paper prints them.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from jackson.experiments.consistency import PAPER_OPTIMISM_GAP_CM


@dataclass(frozen=True)
class PaperFigure:
    """One of the paper's figures: mean ± SD, or a single value (``sd`` None).

    Attributes
    ----------
    mean : float
        The paper's mean (or its only value).
    sd : float or None
        Its SD, None when the paper gives none.
    decimals : int
        Digits after the point as the paper prints them.
    note : str
        What differs from ours ("floor": a floor-tape measurement, not ground truth).
    """

    mean: float
    sd: float | None = None
    decimals: int = 2
    note: str = ""

    @property
    def text(self) -> str:
        """As the paper prints it, e.g. ``"11.59 ± 3.14 (floor)"``."""
        d = self.decimals
        out = f"{self.mean:.{d}f}" + (f" ± {self.sd:.{d}f}" if self.sd is not None else "")
        return f"{out} ({self.note})" if self.note else out

    def as_json(self) -> dict[str, Any]:
        """``{"mean", "sd", "note"}`` (sd null when the paper gives none)."""
        return {"mean": self.mean, "sd": self.sd, "note": self.note or None}


_GAP_MEAN_CM, _GAP_SD_CM = PAPER_OPTIMISM_GAP_CM

# The paper's figures (REFERENCE.md, "Results to compare against"): (physical, Isaac twin).
PAPER: dict[str, dict[str, tuple[PaperFigure | None, PaperFigure | None]]] = {
    "square": {
        "ekf_closure_cm": (PaperFigure(1.18, 0.96), PaperFigure(0.95, 0.17)),
        "gt_closure_cm": (None, PaperFigure(3.39, 0.90)),
        "odom_closure_cm": (PaperFigure(36.35, 13.90), None),
        "ekf_final_heading_deg": (PaperFigure(1.41, 1.02), None),
        "odom_final_heading_deg": (PaperFigure(25.97, 10.21), None),
        "ekf_cross_track_rmse_cm": (PaperFigure(2.46, 0.36), None),
        "ekf_position_rmse_vs_gt_cm": (None, PaperFigure(1.70, 0.55)),
        "ekf_yaw_rmse_vs_gt_deg": (None, PaperFigure(0.97, 0.24)),
        "ekf_path_m": (
            PaperFigure(4.133, 0.020, decimals=3),
            PaperFigure(3.9877, 0.0109, decimals=4),
        ),
        "duration_s": (PaperFigure(47.52, 0.26), PaperFigure(67.17, 0.15)),
    },
    "figure8": {
        "gt_loop_diameter_ccw_m": (
            PaperFigure(1.0795, 0.0167, decimals=4, note="floor"),
            PaperFigure(1.0429, decimals=4),
        ),
        "gt_loop_diameter_cw_m": (
            PaperFigure(1.1280, 0.0322, decimals=4, note="floor"),
            PaperFigure(1.0187, decimals=4),
        ),
        "gt_closure_cm": (PaperFigure(11.59, 3.14, note="floor"), PaperFigure(7.08, 0.41)),
        "ekf_closure_cm": (PaperFigure(6.90, 0.73), PaperFigure(1.92, 0.10)),
        "odom_closure_cm": (PaperFigure(207.0, 26.0, decimals=0), None),
        "optimism_gap_cm": (PaperFigure(_GAP_MEAN_CM, _GAP_SD_CM), PaperFigure(5.16, 0.41)),
        "ekf_final_heading_deg": (PaperFigure(1.42, 0.22), PaperFigure(1.41, 0.15)),
        "ekf_max_cross_track_cm": (PaperFigure(22.52, 3.04), None),
        "ekf_path_m": (PaperFigure(6.96, 0.11), None),
        "duration_s": (PaperFigure(96.43, 2.07), PaperFigure(98.26, 0.04)),
    },
}
"""The paper's physical robot and Isaac Sim twin per mission and metric (None: not given)."""
