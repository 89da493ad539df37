"""``jackson campaign fidelity``'s run: the stages, the ablation, and the report folder."""

from __future__ import annotations

import dataclasses
import json
import shutil
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from jackson.common.fields import read_yaml
from jackson.experiments.campaign import run_campaign
from jackson.experiments.fidelity.ablation import (
    Ablated,
    AblationColumn,
    ablate,
    robot_file,
    write_ablated,
)
from jackson.experiments.fidelity.errors import FidelityError
from jackson.experiments.fidelity.figures import CHECKS, DEFAULT_ROBOT, STAGES
from jackson.experiments.fidelity.mechanisms import BRINGUP_CONFIG, MECHANISMS, Mechanism
from jackson.experiments.fidelity.page import fidelity_markdown
from jackson.experiments.fidelity.plot import plot_fidelity
from jackson.experiments.fidelity.report import FidelityReport, report_json, seeds_text
from jackson.experiments.fidelity.verdicts import assess, figure_result
from jackson.experiments.stage3 import MappingError, run_stage3_campaign


def shown(path: Path) -> str:
    """A path as a page shows it: relative to the working folder when under it, else its name
    (no machine paths in a page)."""
    try:
        return path.absolute().relative_to(Path.cwd()).as_posix()
    except ValueError:
        return path.name


def robot_shown(robot: str) -> str:
    """A robot as a page names it: a bundled name as is, a file as :func:`shown`."""
    p = Path(robot)
    return robot if p.suffix not in (".yaml", ".yml") and not p.exists() else shown(p)


def regenerate_command(
    *,
    trials: int,
    seed: int,
    robot: str = DEFAULT_ROBOT,
    config: Path | None = None,
    stages: Sequence[str] = STAGES,
    docs: Path | None = None,
    out: Path | None = None,
    ablation: bool = False,
    notes: Path | None = None,
    ablation_trials: int | None = None,
) -> str:
    """The ``jackson campaign fidelity`` command that gives the same page again.

    Parameters
    ----------
    trials, seed : int
        As run.
    robot, config, stages, docs, out, ablation, notes
        As run; the defaults are left out, paths shown by :func:`shown`. ``out`` is named
        only without ``docs``.
    ablation_trials : int or None
        The ablation's trials per stage when fewer than ``trials``.

    Returns
    -------
    str
    """
    parts = ["jackson campaign fidelity", f"--trials {trials}", f"--seed {seed}"]
    if robot != DEFAULT_ROBOT:
        parts.append(f"--robot {robot_shown(robot)}")
    if config is not None and config.resolve() != BRINGUP_CONFIG.resolve():  # the default
        parts.append(f"--config {shown(config)}")
    if tuple(stages) != STAGES:
        parts.append(f"--stages {','.join(stages)}")
    if docs is not None:
        parts.append(f"--docs {shown(docs)}")
    elif out is not None:
        parts.append(f"--out {shown(out)}")
    if ablation:
        few = ablation_trials is not None and ablation_trials < trials
        parts.append(f"--ablation {ablation_trials}" if few else "--ablation")
    if notes is not None:
        parts.append(f"--notes {shown(notes)}")
    return " ".join(parts)


def read_notes(path: Path) -> str:
    """The notes file's markdown.

    Raises
    ------
    FidelityError
        It cannot be read or is not UTF-8 text.
    """
    try:
        return path.read_text(encoding="utf-8")
    except OSError as exc:
        raise FidelityError(f"{path}: cannot read it ({exc.strerror or exc})") from exc
    except UnicodeDecodeError as exc:
        raise FidelityError(f"{path}: not UTF-8 text") from exc


def check_docs(path: Path) -> Path:
    """A page to write: a ``.md`` file name in an existing folder, its PNG beside it.

    Parameters
    ----------
    path : Path
        ``docs/fidelity.md``.

    Returns
    -------
    Path
        The PNG beside it (``docs/fidelity.png``).

    Raises
    ------
    FidelityError
        Not a ``.md`` name, a folder, or in a folder that does not exist.
    """
    if path.suffix != ".md":
        raise FidelityError(f"{path}: give a markdown file name ending in .md")
    if path.is_dir():
        raise FidelityError(f"{path}: is a folder, give a markdown file name")
    if not path.parent.is_dir():
        raise FidelityError(f"{path}: the folder {path.parent} does not exist")
    png = path.with_suffix(".png")
    if png.is_dir():
        raise FidelityError(f"{path}: {png} is a folder")
    return png


def _phase(progress: bool, text: str) -> None:
    if progress:
        print(f"fidelity: {text}", file=sys.stderr, flush=True)


def _trials_text(trials: int, seed: int) -> str:
    """``"1 trial (seed 0)"``, ``"10 trials (seeds 0-9)"``."""
    return f"{trials} trial{'' if trials == 1 else 's'} ({seeds_text(seed, trials)})"


@dataclass(frozen=True)
class _Campaigns:
    """What every campaign of one report shares: its trials and seeds, where they run.

    Attributes
    ----------
    trials, seed : int
        Trials per stage; trial i has seed ``seed + i``.
    workers : int
        Worker processes of each campaign.
    cluster : str or None
        A Ray cluster for the trials.
    progress : bool
        The campaigns' progress and one line per phase on stderr.
    """

    trials: int
    seed: int
    workers: int
    cluster: str | None
    progress: bool

    def run(
        self, stages: Sequence[str], out: Path, label: str, robot: str, config: Path | None
    ) -> tuple[dict[str, list[dict[str, Any]]], str | None]:
        """Run ``stages`` into ``out/<stage>``; the per-trial results and why the maze did not
        navigate (its mapping run failed), if so."""
        trials, seed, progress = self.trials, self.seed, self.progress
        results: dict[str, list[dict[str, Any]]] = {}
        failure = None
        common: dict[str, Any] = {
            "robot": robot,
            "seed": seed,
            "workers": self.workers,
            "config": config,
            "progress": progress,
            "cluster": self.cluster,
        }
        for stage in stages:
            _phase(progress, f"{label}{stage}, {_trials_text(trials, seed)} -> {out / stage}")
            if stage == "maze":
                try:
                    results[stage] = run_stage3_campaign("maze", trials, out / stage, **common)
                except MappingError as exc:  # no map: no navigation
                    results[stage], failure = [], str(exc)
            else:
                results[stage] = run_campaign(stage, trials, out / stage, **common)
        return results, failure

    def ablation(
        self, ablated: Sequence[Ablated], stages: Sequence[str], out: Path
    ) -> tuple[AblationColumn, ...]:
        """Each mechanism of ``ablated`` switched off in turn, on the same seeds: its robot file
        and configuration written to ``out/ablation/<name>/``, its campaigns run there."""
        columns = []
        for k, a in enumerate(ablated, 1):
            m = a.mechanism
            folder = out / "ablation" / m.name
            robot_off, config_off = write_ablated(folder, a)
            runs = [s for s in stages if s != "maze" or m.stage3]
            label = f"ablation {k}/{len(ablated)}, {m.name} off: "
            off, failure = self.run(
                runs, folder, label, str(robot_off.absolute()), config_off.absolute()
            )
            off_figures, off_stage3, _ = assess(off, failure)
            columns.append(AblationColumn(m, off_figures + off_stage3, failure))
        return tuple(columns)


def run_fidelity(
    trials: int,
    out: Path,
    *,
    seed: int = 0,
    robot: str = DEFAULT_ROBOT,
    config: Path | None = None,
    workers: int = 2,
    cluster: str | None = None,
    progress: bool = True,
    ablation: bool = False,
    stages: Sequence[str] = STAGES,
    docs: Path | None = None,
    notes: Path | None = None,
    mechanisms: Sequence[Mechanism] = MECHANISMS,
    ablation_trials: int | None = None,
) -> FidelityReport:
    """Run the stages, the ablation if asked, and write the report folder (and the page).

    Parameters
    ----------
    trials : int
        Trials per stage (and per stage and mechanism in the ablation); trial i has seed
        ``seed + i``.
    out : Path
        The report folder: ``square/``, ``figure8/``, ``maze/``, ``ablation/<name>/``,
        ``fidelity.json``, ``fidelity.md``, ``fidelity.png``.
    seed : int
        Seed of the first trial.
    robot : str
        The twin's robot (name or YAML).
    config : Path or None
        Host configuration YAML (None: the packaged defaults).
    workers : int
        Worker processes of each campaign.
    cluster : str or None
        A Ray cluster for the trials (:func:`jackson.experiments.cluster.map_trials`).
    progress : bool
        The campaigns' progress and one line per phase on stderr.
    ablation : bool
        Also run each of ``mechanisms`` switched off.
    ablation_trials : int or None
        The ablation's trials per stage, on the first seeds (None: ``trials``; at most
        ``trials``): a report of 30 trials ablated on its first ten.
    stages : sequence of str
        The stages to run, of :data:`STAGES`.
    docs : Path or None
        Also write the page here and its PNG beside it (``docs/fidelity.md``,
        ``docs/fidelity.png``).
    notes : Path or None
        Markdown appended verbatim at the end of the page.
    mechanisms : sequence of Mechanism
        The mechanisms the page lists and the ablation switches off.

    Returns
    -------
    FidelityReport

    Raises
    ------
    FidelityError
        The notes cannot be read, ``docs`` is unusable, or a mechanism's patch does not fit
        (:class:`MechanismError`); all checked before anything runs or is written.
    """
    stages = tuple(s for s in STAGES if s in stages)
    n_off = trials if ablation_trials is None else ablation_trials
    if not 1 <= n_off <= trials:
        raise FidelityError(f"the ablation's trials must be 1-{trials} (--trials), got {n_off}")
    notes_text = read_notes(notes) if notes is not None else ""
    docs_png = check_docs(docs) if docs is not None else None
    inactive: list[str] = []
    ablated = ablate(mechanisms, robot, config, inactive) if ablation else []
    robot_doc = dict(read_yaml(robot_file(robot), "robot")[1])
    config_doc = dict(read_yaml(config, "config")[1]) if config is not None else {}
    if cluster is not None:
        out, config = out.absolute(), config.absolute() if config is not None else None
    wall0 = time.perf_counter()
    campaigns = _Campaigns(trials, seed, workers, cluster, progress)
    results, nav_failure = campaigns.run(stages, out, "", robot, config)
    figures, stage3, nav = assess(results, nav_failure)
    columns = dataclasses.replace(campaigns, trials=n_off).ablation(ablated, stages, out)
    command = regenerate_command(
        trials=trials,
        seed=seed,
        robot=robot,
        config=config,
        stages=stages,
        docs=docs,
        out=out,
        ablation=ablation,
        notes=notes,
        ablation_trials=n_off,
    )
    report = FidelityReport(
        command=command,
        robot=robot_shown(robot),
        trials=trials,
        seed=seed,
        stages=stages,
        figures=figures,
        stage3=stage3,
        nav=nav,
        mechanisms=tuple(mechanisms),
        ablation=columns,
        ablation_trials=n_off,
        config=shown(config) if config is not None else "",
        robot_doc=robot_doc,
        config_doc=config_doc,
        inactive=tuple(inactive),
        checks=tuple(figure_result(f, results.get(f.mission, ())) for f in CHECKS),
    )
    _phase(progress, f"report -> {out / 'fidelity.md'} ({time.perf_counter() - wall0:.0f} s)")
    write_report_files(out, report, notes_text)
    if docs is not None and docs_png is not None:
        docs.write_text(fidelity_markdown(report, docs_png.name, notes_text))
        shutil.copyfile(out / "fidelity.png", docs_png)
        _phase(progress, f"page -> {docs}, {docs_png}")
    return report


def write_report_files(out: Path, report: FidelityReport, notes: str = "") -> None:
    """``fidelity.json``, ``fidelity.md`` and ``fidelity.png`` in ``out``.

    Parameters
    ----------
    out : Path
        The report folder.
    report : FidelityReport
        The figures.
    notes : str
        Markdown appended to the page.
    """
    out.mkdir(parents=True, exist_ok=True)
    (out / "fidelity.json").write_text(json.dumps(report_json(report), indent=2) + "\n")
    (out / "fidelity.md").write_text(fidelity_markdown(report, "fidelity.png", notes))
    plot_fidelity(out / "fidelity.png", report)
