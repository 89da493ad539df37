"""``fidelity.md``: the page of the fidelity report, its tables and its text."""

from __future__ import annotations

from jackson.experiments.fidelity.figures import (
    PAPER_STAGE3_CONTACTS,
    PAPER_STAGE3_SUCCESS,
    SD_RATIO_RANGE,
    STAGE_NAMES,
    STAGES,
)
from jackson.experiments.fidelity.mechanisms import dotted
from jackson.experiments.fidelity.report import FidelityReport, seeds_text
from jackson.experiments.fidelity.verdicts import (
    FigureResult,
    agreement,
    agreement_line,
    seed_set,
)


def _ours(row: FigureResult) -> str:
    if row.missing is not None:
        return row.missing
    f = row.figure
    return f.number(row.mean) + (f" ± {f.number(row.sd)}" if row.n > 1 else "")


def _z_cell(row: FigureResult) -> str:
    if row.within is None:
        return "—"
    text = f"{row.z:+.2f} ({'yes' if row.within else 'no'})"
    return text if row.within else f"**{text}**"


def _sd_cell(row: FigureResult) -> str:
    if row.sd_ok is None:
        return "—" if row.n == 0 else "n/a (one trial)"
    text = f"{row.sd_ratio:.2f} ({'ok' if row.sd_ok else 'not'})"
    return text if row.sd_ok else f"**{text}**"


def _runs_line(report: FidelityReport) -> str:
    parts = []
    for mission in STAGES:
        if mission not in report.stages:
            parts.append(f"{STAGE_NAMES[mission]} not run")
            continue
        if mission == "maze":
            attempted, done = report.nav.attempted, report.nav.completed
        else:
            row = next(r for r in report.figures if r.figure.mission == mission)
            attempted, done = row.attempted, row.completed
        parts.append(f"{STAGE_NAMES[mission]} {done}/{attempted}")
    return "Trials completed (only these enter the statistics): " + ", ".join(parts) + "."


def _seed_set_lines(report: FidelityReport) -> list[str]:
    sets = report.seed_sets
    if not sets:
        return []
    parts = [
        f"seeds {ss.first}-{ss.last}: {ss.agreement.within} of {ss.agreement.total}" for ss in sets
    ]
    return [
        f"Each set of ten seeds alone, within the paper's mean ± 1 SD: {'; '.join(parts)}.",
        "",
    ]


def _median_iqr(row: FigureResult) -> str:
    if row.missing is not None:
        return "—"
    med, q1, q3 = row.quartiles
    f = row.figure
    return f"{f.number(med)} [{f.number(q1)}, {f.number(q3)}]"


def _check_lines(report: FidelityReport) -> list[str]:
    rows = [r for r in report.checks if r.n > 0]
    if not rows:
        return []
    lines = [
        "Further figures of the paper, checks outside the count: no value of the twin or of the "
        "configuration was identified from them.",
        "",
        "| stage | figure [unit] (paper table) | paper, physical | ours | z (within ±1 SD) |",
        "|---|---|---|---|---|",
    ]
    for row in rows:
        f = row.figure
        lines.append(
            f"| {f.stage} | {f.heading} | {f.paper_text} | {_ours(row)} | {_z_cell(row)} |"
        )
    return [*lines, ""]


def _stage3_lines(report: FidelityReport) -> list[str]:
    if "maze" not in report.stages:
        return ["Not run (`--stages` without `maze`)."]
    nav = report.nav
    k = report.stage3[0].figure.within_sd if report.stage3 else 2.0
    lines = []
    if nav.failure is not None:
        lines += [f"No navigation ran: {nav.failure}.", ""]
    ok, runs = PAPER_STAGE3_SUCCESS
    yes = {True: "yes", False: "**no**"}
    lines += [
        f"| figure [unit] (paper table) | paper, physical | paper, Isaac twin | ours, mean ± SD "
        f"| ours, median [IQR] | within the paper's ±{k:g} SD |",
        "|---|---|---|---|---|---|",
        f"| success (P_success) (T14) | {ok}/{runs} | {ok}/{runs} | "
        f"{nav.completed}/{nav.attempted} | — | {yes[nav.success_within]} |",
        f"| contacts (C_count) (T14) | {PAPER_STAGE3_CONTACTS} | {PAPER_STAGE3_CONTACTS} | "
        f"{nav.contacts} | — | {yes[nav.contacts_within]} |",
    ]
    for row in report.stage3:
        f = row.figure
        lines.append(
            f"| {f.heading} | {f.paper_text} | {f.isaac or '—'} | {_ours(row)} | "
            f"{_median_iqr(row)} | {_z_cell(row)} |"
        )
    return lines


def _mechanism_lines(report: FidelityReport) -> list[str]:
    lines = [
        "| mechanism | what | source | switched off (value in the file -> off) |",
        "|---|---|---|---|",
    ]
    for m in report.mechanisms:
        off = [f"robot `{d}`" for d in dotted(m.robot_patch, report.robot_doc)]
        off += [f"host config `{d}`" for d in dotted(m.config_patch, report.config_doc)]
        stage3 = " (the ablation runs the maze too)" if m.stage3 else ""
        lines.append(f"| `{m.name}` | {m.what}{stage3} | {m.source} | {', '.join(off)} |")
    return lines


def _ablation_cell(full: FigureResult, off: FigureResult, nav_failure: str | None) -> str:
    if off.missing is not None:
        mapless = off.figure.mission == "maze" and nav_failure is not None
        return "no map (the mapping run failed)" if mapless else off.missing
    text = off.figure.number(off.mean)
    changed = full.within is not None and off.within is not None and full.within != off.within
    return f"**{text}**" if changed else text


def _ablation_lines(report: FidelityReport) -> list[str]:
    columns = report.ablation
    stage3 = any(c.mechanism.stage3 for c in columns) and "maze" in report.stages
    rows = list(report.figures) + (list(report.stage3) if stage3 else [])
    first, last = report.ablation_seeds
    few = last - first + 1 < report.trials
    if few:  # the full model on the ablation's seeds
        rows = [seed_set(r, first, last) if r.seeds else r for r in rows]
    seeds = f"the full model's seeds {first}-{last}" if few else "the full model's seeds"
    lines = [
        f"Each mechanism switched off alone (the patch above), on {seeds}; "
        "means over the completed trials. **Bold**: the figure leaves or enters the paper's "
        "band (±1 SD; Stage 3 ±2 SD) against the full model."
        + (
            " Not in this robot and configuration, so not ablated: "
            + ", ".join(f"`{n}`" for n in report.inactive)
            + "."
            if report.inactive
            else ""
        ),
        "",
        "| stage | figure [unit] (paper table) | paper | full model | "
        + " | ".join(f"`{c.mechanism.name}` off" for c in columns)
        + " |",
        "|---|---|---|---|" + "---|" * len(columns),
    ]
    for i, full in enumerate(rows):
        f = full.figure
        cells = [_ablation_cell(full, c.figures[i], c.nav_failure) for c in columns]
        ours = f.number(full.mean) if full.missing is None else full.missing
        lines.append(
            f"| {f.stage} | {f.heading} | {f.paper_text} | {ours} | " + " | ".join(cells) + " |"
        )
    counts = [agreement(c.figures[: len(report.figures)]) for c in columns]
    full_count = agreement(rows[: len(report.figures)]).within
    lines.append(
        f"| | within ±1 SD (of {len(report.figures)}) | | {full_count} | "
        + " | ".join(str(a.within) for a in counts)
        + " |"
    )
    return lines


def fidelity_markdown(
    report: FidelityReport, png_name: str = "fidelity.png", notes: str = ""
) -> str:
    """The page: what it is, how to regenerate it, the tables, the figure, the notes.

    Parameters
    ----------
    report : FidelityReport
        The figures.
    png_name : str
        The figure's file name beside the page.
    notes : str
        Markdown appended verbatim at the end (hand-written explanations).

    Returns
    -------
    str
    """
    seeds = seeds_text(report.seed, report.trials)
    missions = [STAGE_NAMES[s] for s in report.stages]
    config = f"host configuration `{report.config}`" if report.config else "the paper's host "
    config += "" if report.config else "configuration (the packaged defaults)"
    lo, hi = SD_RATIO_RANGE
    lines = [
        f"# Fidelity: `{report.robot}` against the paper's physical robot",
        "",
        f"Generated by `jackson campaign fidelity`: {report.trials} trials of each stage "
        f"({', '.join(missions)}; {seeds}) on the twin with the robot `{report.robot}`, driven by "
        f"the real host with {config}, and every figure the paper gives for its physical robot "
        "(Tables 5-7, 11, 13 and 14) beside ours. A Stage 1-2 figure agrees when our mean is "
        f"within the paper's mean ± 1 SD (z = (ours - paper) / paper's SD) and our SD within "
        f"{lo:g}-{hi:g} times the paper's (two samples of ten whose SDs differ by less cannot be "
        "told apart by a two-sided F test at 5 %); a Stage 3 figure when our mean is within "
        "± 2 SD. Only completed trials enter the statistics. Regenerate this page with:",
        "",
        "```",
        report.command,
        "```",
        "",
        "## Stage 1-2: the square and the figure-eight",
        "",
        "| stage | figure [unit] (paper table) | paper, physical | ours | "
        "z (within ±1 SD) | SD ours / paper (0.5-2) |",
        "|---|---|---|---|---|---|",
    ]
    for row in report.figures:
        f = row.figure
        lines.append(
            f"| {f.stage} | {f.heading} | {f.paper_text} | {_ours(row)} | {_z_cell(row)} | "
            f"{_sd_cell(row)} |"
        )
    lines += [
        "",
        _runs_line(report),
        "",
        f"**{agreement_line(report.agreement)}.**",
        "",
        *_seed_set_lines(report),
        *_check_lines(report),
        "## Stage 3: the maze with the dropped cylinder",
        "",
        *_stage3_lines(report),
        "",
        "## The twin's mechanisms",
        "",
        *_mechanism_lines(report),
        "",
    ]
    if report.ablation:
        lines += ["## Ablation: one mechanism off at a time", "", *_ablation_lines(report), ""]
    lines += [
        f"![our trials, our mean ± SD and the paper's mean ± SD for every figure]({png_name})",
        "",
    ]
    text = "\n".join(lines)
    return text + "\n" + notes if notes else text
