"""Wall time of the paper's campaigns on the twin (run by ``jackson bench``).

Square x10 plus figure-eight x10, each trial the real host against the twin in lockstep, on 2
worker processes. Right after them, in the same run, the twin alone (:mod:`jackson.sim.bench`'s
figure-eight, no LiDAR) simulates as many seconds as all trials together. Figure, for
information: the campaigns' wall time over the twin alone's. Its reference is itself optimised
(the compiled physics step made the twin alone three times faster), so the ratio rose without
the campaigns getting slower; a trial's time is now mostly the host's, with its run folder and
bag. The campaigns' judged figure is the Stage 3 set's: 180 runs on 2 workers within 10 minutes
(:mod:`jackson.experiments.bench_stage3`).
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

from jackson.common.bench import BenchResult, reference_loop_us
from jackson.experiments.campaign import run_campaign


def run(quick: bool = False) -> list[BenchResult]:
    """The campaigns' figure for ``jackson bench``.

    Parameters
    ----------
    quick : bool
        Four trials of each mission instead of ten.

    Returns
    -------
    list[BenchResult]
        The campaigns' wall time over the twin alone's for the same simulated time.
    """
    from jackson.sim.bench import real_time_factor

    trials = 4 if quick else 10
    loop_us = reference_loop_us()
    with tempfile.TemporaryDirectory(prefix="jackson-bench-") as tmp:
        t0 = time.perf_counter()
        square = run_campaign("square", trials, Path(tmp) / "square", workers=2, progress=False)
        eight = run_campaign("figure8", trials, Path(tmp) / "figure8", workers=2, progress=False)
        wall = time.perf_counter() - t0
    sim_s = sum(float(m["duration_s"]) for m in [*square, *eight])
    twin_s = sim_s / real_time_factor(False, sim_s)
    loop_us = min(loop_us, reference_loop_us())
    return [
        BenchResult(
            f"campaign.square_x{trials}_plus_figure8_x{trials}_over_twin",
            wall / twin_s,
            "x the twin alone's time",
            None,
            "lower",
            f"the twin alone simulating the trials' {sim_s:.0f} s in this process (for "
            "information: the twin alone is itself optimised)",
            wall,
            "s",
            twin_s,
            loop_us,
        )
    ]
