"""``jackson campaign fidelity``: the twin against the paper's physical robot, in one report.

Runs the three validation stages on the twin (square and figure-eight campaigns,
:func:`jackson.experiments.campaign.run_campaign`; Stage 3's maze,
:func:`jackson.experiments.stage3.run_stage3_campaign`) and holds every figure the paper gives
for its physical robot beside ours: the 16 Stage 1-2 figures of :data:`FIGURES` (Tables 5-7,
11 and 13) and the Stage 3 outcomes of :data:`STAGE3_FIGURES` (Table 14).

A figure agrees when our mean lies within ``k`` of the paper's SDs of the paper's mean,

    z = (mean_ours - mean_paper) / sd_paper,    |z| <= k,

with k = 1 for Stage 1-2 and k = 2 for Stage 3's t_nav, d_min and path length; and its spread
agrees when ``sd_ours / sd_paper`` lies within 0.5-2 (:data:`SD_RATIO_RANGE`: two samples of
ten whose SDs differ by less cannot be told apart by a two-sided F test at 5 %). Only completed
trials enter the statistics; completed / attempted is reported beside them.

:data:`MECHANISMS` lists the twin's imperfections (``sim/robots/jackson_physical.yaml``) and
host settings as plain data, each with the patch that switches it off: a nested mapping
deep-merged (:func:`deep_merge`) into the robot file or the host configuration. The ablation
(``ablation=True``) runs the square and the figure-eight (and the maze for a mechanism marked
``stage3``) once per mechanism with it off, on the full model's seeds, and tabulates what each
figure becomes.

The report folder holds ``square/``, ``figure8/``, ``maze/`` (each a campaign's own folder),
``ablation/<mechanism>/`` (its ``robot.yaml``, ``config.yaml`` and campaigns), and
``fidelity.json`` (every number), ``fidelity.md`` and ``fidelity.png``.

One idea per module: the paper's figures (:mod:`.figures`), our trials' verdicts
(:mod:`.verdicts`), the mechanisms (:mod:`.mechanisms`), the ablation (:mod:`.ablation`), the
report and its JSON (:mod:`.report`), the page (:mod:`.page`), the figure (:mod:`.plot`) and
the run (:mod:`.run`).
"""

from __future__ import annotations

from jackson.experiments.fidelity.ablation import (
    Ablated,
    AblationColumn,
    ablate,
    robot_file,
    write_ablated,
)
from jackson.experiments.fidelity.errors import FidelityError, MechanismError
from jackson.experiments.fidelity.figures import (
    CHECKS,
    DEFAULT_ROBOT,
    FIGURES,
    PAPER_STAGE3_CONTACTS,
    PAPER_STAGE3_SUCCESS,
    SD_RATIO_RANGE,
    STAGE3_FIGURES,
    STAGE_NAMES,
    STAGES,
    Figure,
)
from jackson.experiments.fidelity.mechanisms import (
    BRINGUP_CONFIG,
    MECHANISMS,
    SQUARE_BRINGUP_FIELDS,
    Mechanism,
    deep_merge,
    dotted,
)
from jackson.experiments.fidelity.page import fidelity_markdown
from jackson.experiments.fidelity.plot import plot_fidelity
from jackson.experiments.fidelity.report import FidelityReport, report_json, seeds_text
from jackson.experiments.fidelity.run import (
    check_docs,
    read_notes,
    regenerate_command,
    robot_shown,
    run_fidelity,
    shown,
    write_report_files,
)
from jackson.experiments.fidelity.verdicts import (
    Agreement,
    FigureResult,
    NavOutcome,
    SeedSet,
    agreement,
    agreement_line,
    assess,
    figure_result,
    nav_outcome,
    seed_set,
    seed_sets,
)

__all__ = [
    "BRINGUP_CONFIG",
    "CHECKS",
    "DEFAULT_ROBOT",
    "FIGURES",
    "MECHANISMS",
    "PAPER_STAGE3_CONTACTS",
    "PAPER_STAGE3_SUCCESS",
    "SD_RATIO_RANGE",
    "SQUARE_BRINGUP_FIELDS",
    "STAGE3_FIGURES",
    "STAGES",
    "STAGE_NAMES",
    "Ablated",
    "AblationColumn",
    "Agreement",
    "FidelityError",
    "FidelityReport",
    "Figure",
    "FigureResult",
    "Mechanism",
    "MechanismError",
    "NavOutcome",
    "SeedSet",
    "ablate",
    "agreement",
    "agreement_line",
    "assess",
    "check_docs",
    "deep_merge",
    "dotted",
    "fidelity_markdown",
    "figure_result",
    "nav_outcome",
    "plot_fidelity",
    "read_notes",
    "regenerate_command",
    "report_json",
    "robot_file",
    "robot_shown",
    "run_fidelity",
    "seed_set",
    "seed_sets",
    "seeds_text",
    "shown",
    "write_ablated",
    "write_report_files",
]
