"""The fidelity report: everything its page, JSON and figure show, and ``fidelity.json``."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from jackson.experiments.fidelity.ablation import AblationColumn
from jackson.experiments.fidelity.figures import (
    PAPER_STAGE3_CONTACTS,
    PAPER_STAGE3_SUCCESS,
    SD_RATIO_RANGE,
)
from jackson.experiments.fidelity.mechanisms import Mechanism
from jackson.experiments.fidelity.verdicts import (
    Agreement,
    FigureResult,
    NavOutcome,
    SeedSet,
    agreement,
    seed_sets,
)


@dataclass(frozen=True)
class FidelityReport:
    """Everything ``fidelity.md``, ``fidelity.json`` and ``fidelity.png`` show.

    Attributes
    ----------
    command : str
        The command that regenerates the page.
    robot : str
        The robot as the page names it.
    trials, seed : int
        Trials per stage; trial i has seed ``seed + i``.
    stages : tuple of str
        The stages run (of :data:`STAGES`).
    figures : tuple of FigureResult
        The 16 Stage 1-2 figures (:data:`FIGURES`).
    stage3 : tuple of FigureResult
        Stage 3's continuous figures (:data:`STAGE3_FIGURES`).
    nav : NavOutcome
        Stage 3's success and contacts.
    mechanisms : tuple of Mechanism
        The mechanisms of the twin (:data:`MECHANISMS`).
    ablation : tuple of AblationColumn
        One per mechanism switched off (empty: no ablation).
    ablation_trials : int
        The ablation's trials per stage, on the first seeds (0: ``trials``).
    config : str
        The host configuration as the page names it ("" for the packaged defaults).
    robot_doc, config_doc : mapping
        The robot file and the host configuration as read: the mechanisms' values before they
        are switched off.
    """

    command: str
    robot: str
    trials: int
    seed: int
    stages: tuple[str, ...]
    figures: tuple[FigureResult, ...]
    stage3: tuple[FigureResult, ...]
    nav: NavOutcome
    mechanisms: tuple[Mechanism, ...] = ()
    ablation: tuple[AblationColumn, ...] = ()
    ablation_trials: int = 0
    config: str = ""
    robot_doc: Mapping[str, Any] = field(default_factory=dict)
    config_doc: Mapping[str, Any] = field(default_factory=dict)
    inactive: tuple[str, ...] = ()  # mechanisms this robot and configuration already lack
    checks: tuple[FigureResult, ...] = ()  # CHECKS: shown, not counted

    @property
    def agreement(self) -> Agreement:
        """The Stage 1-2 figures within the paper's band (and with a fitting SD)."""
        return agreement(self.figures)

    @property
    def seed_sets(self) -> tuple[SeedSet, ...]:
        """The Stage 1-2 figures of each set of ten seeds judged alone (campaigns of 20 trials
        and more)."""
        return seed_sets(self.figures, self.seed, self.trials)

    @property
    def ablation_seeds(self) -> tuple[int, int]:
        """The first and last seed of the ablation's trials."""
        n = self.ablation_trials or self.trials
        return self.seed, self.seed + n - 1


def seeds_text(seed: int, trials: int) -> str:
    """``"seed 0"``, ``"seeds 0-9"``: the seeds of ``trials`` trials from ``seed``."""
    return f"seed {seed}" if trials == 1 else f"seeds {seed}-{seed + trials - 1}"


def report_json(report: FidelityReport) -> dict[str, Any]:
    """``fidelity.json``: every number of the report.

    Parameters
    ----------
    report : FidelityReport
        The figures.

    Returns
    -------
    dict
    """
    a = report.agreement
    nav = report.nav
    return {
        "command": report.command,
        "robot": report.robot,
        "config": report.config or None,
        "trials": report.trials,
        "seed": report.seed,
        "stages": list(report.stages),
        "sd_ratio_range": list(SD_RATIO_RANGE),
        "agreement": {
            "within": a.within,
            "within_and_sd": a.within_and_sd,
            "sd_ok": a.sd_ok,
            "total": a.total,
        },
        "seed_sets": [
            {
                "seeds": [ss.first, ss.last],
                "within": ss.agreement.within,
                "total": ss.agreement.total,
            }
            for ss in report.seed_sets
        ],
        "figures": [r.as_json() for r in report.figures],
        "checks": [r.as_json() for r in report.checks],
        "stage3": {
            "attempted": nav.attempted,
            "completed": nav.completed,
            "contacts": nav.contacts,
            "failure": nav.failure,
            "success_within": nav.success_within,
            "contacts_within": nav.contacts_within,
            "paper": {
                "success": list(PAPER_STAGE3_SUCCESS),
                "contacts": PAPER_STAGE3_CONTACTS,
            },
            "figures": [r.as_json() for r in report.stage3],
        },
        "mechanisms": [
            {
                "name": m.name,
                "what": m.what,
                "source": m.source,
                "robot_patch": dict(m.robot_patch),
                "config_patch": dict(m.config_patch),
                "stage3": m.stage3,
            }
            for m in report.mechanisms
        ],
        "ablation": [
            {
                "mechanism": c.mechanism.name,
                "nav_failure": c.nav_failure,
                "agreement": dataclasses.asdict(agreement(c.figures[: len(report.figures)])),
                "figures": [r.as_json() for r in c.figures],
            }
            for c in report.ablation
        ],
    }
