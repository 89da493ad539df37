"""Wall time of the paper's campaigns on the twin (run by ``jackson bench``).

Square x10 plus figure-eight x10, each trial the real host against the twin in lockstep, on 2
worker processes; target under 60 s together.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

from jackson.calibration.campaign import run_campaign
from jackson.common.bench import BenchResult


def run(quick: bool = False) -> list[BenchResult]:
    trials = 4 if quick else 10
    with tempfile.TemporaryDirectory(prefix="jackson-bench-") as tmp:
        t0 = time.perf_counter()
        run_campaign("square", trials, Path(tmp) / "square", workers=2, progress=False)
        run_campaign("figure8", trials, Path(tmp) / "figure8", workers=2, progress=False)
        wall = time.perf_counter() - t0
    return [
        BenchResult(
            f"campaign.square_x{trials}_plus_figure8_x{trials}_2_workers",
            wall,
            "s",
            60.0 if not quick else 24.0,
            "lower",
        )
    ]
