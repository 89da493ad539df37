"""Running the fault campaign: the plan of jobs, the workers, the maze's map, the summary."""

from __future__ import annotations

import contextlib
import dataclasses
import math
import time
from collections import Counter
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from jackson.experiments.fault_campaign.analysis import (
    detect,
    load_run,
    summarise_case,
    summarise_clean,
)
from jackson.experiments.fault_campaign.cases import (
    CASES,
    CONFIDENCE,
    DETECTION_TARGET,
    MAZE_ONSET_S,
    MONITOR_YAML,
    NO_MONITOR_YAML,
    ONSET_S,
    PLANNED_DRIVE_S,
    UNHEALTHY,
    WORLDS,
    FaultCampaignError,
    FaultCase,
)
from jackson.experiments.fault_campaign.records import RunRecord
from jackson.experiments.fault_campaign.report import write_report

if TYPE_CHECKING:  # the twin and the host load when a campaign runs, not for jackson --help
    from jackson.experiments.stage3 import NavTrialSpec
    from jackson.experiments.trial import TrialSpec
    from jackson.sim.faults import FaultSpec


def clean_plan(hours: float) -> list[str]:
    """The missions of the clean runs: squares and figure-eights in turn until their planned
    driving time (:data:`PLANNED_DRIVE_S`) reaches ``hours``.

    Parameters
    ----------
    hours : float
        Driving time wanted [h]; 0: no clean runs.

    Returns
    -------
    list of str
        One mission per run.
    """
    plan: list[str] = []
    driven = 0.0
    while driven < hours * 3600.0:
        mission = ("square", "figure8")[len(plan) % 2]
        plan.append(mission)
        driven += PLANNED_DRIVE_S[mission]
    return plan


# --------------------------------------------------------------------------- running


@dataclass(frozen=True)
class Job:
    """One trial to run in a worker: which case (or ``clean``), with the monitor or not; a
    square or figure-eight trial, or the maze's navigation trial."""

    case: str
    monitor: bool
    spec: TrialSpec | NavTrialSpec
    root: Path

    @property
    def mission(self) -> str:
        """``square``, ``figure8`` or ``maze``."""
        from jackson.experiments.trial import TrialSpec

        return self.spec.mission if isinstance(self.spec, TrialSpec) else "maze"


def run_job(job: Job) -> RunRecord:
    """Run one trial (:func:`jackson.experiments.trial.run_trial`, the maze's
    :func:`jackson.experiments.stage3.run_nav_trial`) and read its folder back.

    What the daemon tells the operator goes to the run folder's ``daemon.log``. A trial that
    raises is recorded with its error, so one broken run does not end the campaign (a run the
    daemon aborted whose metrics cannot be computed, a figure-eight cut short, still counts as
    aborted).

    Parameters
    ----------
    job : Job
        The trial.

    Returns
    -------
    RunRecord
        What the run did.
    """
    from jackson.experiments.stage3 import run_nav_trial
    from jackson.experiments.trial import TrialSpec, run_trial

    error = None
    job.spec.out.mkdir(parents=True, exist_ok=True)
    with (job.spec.out / "daemon.log").open("w") as told, contextlib.redirect_stdout(told):
        try:
            if isinstance(job.spec, TrialSpec):
                run_trial(job.spec)
            else:
                run_nav_trial(job.spec)
        except Exception as exc:  # recorded: the report names the run
            error = f"{type(exc).__name__}: {' '.join(str(exc).split())}"
    record = load_run(job.spec.out, case=job.case, monitor=job.monitor, root=job.root, error=error)
    s = job.spec
    return dataclasses.replace(record, mission=job.mission, trial=s.index, seed=s.seed)


def write_host_configs(out: Path, config: Path | None) -> tuple[Path, Path]:
    """The host YAMLs of the runs with and without the monitor, written into ``out``.

    Parameters
    ----------
    out : Path
        The report folder.
    config : Path or None
        The host YAML the robot runs with (None: the default configuration).

    Returns
    -------
    tuple of Path
        ``host-monitor.yaml`` (the configuration as it is) and ``host-no-monitor.yaml`` (the
        same with ``health.enabled: false``).
    """
    import yaml

    from jackson.host.config import HostConfig, dump_config, load_config

    cfg = load_config(config) if config is not None else HostConfig()
    off = dataclasses.replace(cfg, health=dataclasses.replace(cfg.health, enabled=False))
    paths = (out / MONITOR_YAML, out / NO_MONITOR_YAML)
    for path, c in zip(paths, (cfg, off), strict=True):
        path.write_text(yaml.safe_dump(dump_config(c), sort_keys=False))
    return paths[0].resolve(), paths[1].resolve()


def plan_jobs(
    out: Path,
    cases: Sequence[FaultCase],
    trials: int,
    clean_hours: float,
    *,
    robot: str,
    seed: int,
    configs: tuple[Path, Path],
    map_yaml: Path | None = None,
) -> list[Job]:
    """Every trial of a campaign: per case ``trials`` seeds with and without the monitor, then
    the clean runs (:func:`clean_plan`; with maze cases and ``clean_hours`` > 0, ``trials``
    clean maze runs besides); trial ``i`` of a mission has seed ``seed + i``, so a case's runs
    and the clean runs of its mission are the same twins but for the fault.

    Parameters
    ----------
    out : Path
        The report folder; the runs go under ``runs/``.
    cases : sequence of FaultCase
        The cases.
    trials : int
        Seeds per case.
    clean_hours : float
        Driving time of the square and figure-eight clean runs [h] (0: no clean runs).
    robot : str
        The twin's robot file.
    seed : int
        Seed of trial 0.
    configs : tuple of Path
        The host YAMLs with and without the monitor (:func:`write_host_configs`).
    map_yaml : Path, optional
        The maze's map the navigation trials localise on (needed with maze cases).

    Returns
    -------
    list of Job
        The cases' runs in :data:`CASES` order, then the clean runs.

    Raises
    ------
    ValueError
        Maze cases without ``map_yaml``.
    """
    from jackson.experiments.stage3 import NavTrialSpec
    from jackson.experiments.trial import TrialSpec

    maze = any(c.mission == "maze" for c in cases)
    if maze and map_yaml is None:
        raise ValueError("the maze cases need a map (map_yaml)")

    def trial(
        mission: str, i: int, folder: Path, cfg: Path, faults: tuple[FaultSpec, ...]
    ) -> TrialSpec | NavTrialSpec:
        if mission == "maze":
            return NavTrialSpec(
                i, seed + i, robot, WORLDS[mission], folder, map_yaml, config=cfg, faults=faults
            )
        return TrialSpec(mission, i, seed + i, robot, WORLDS[mission], folder, cfg, faults)

    jobs = []
    for case in cases:
        for monitor, cfg, sub in ((True, configs[0], "monitor"), (False, configs[1], "no-monitor")):
            for i in range(trials):
                folder = out / "runs" / case.name / sub / f"R{i + 1:02d}"
                spec = trial(case.mission, i, folder, cfg, (case.spec,))
                jobs.append(Job(case.name, monitor, spec, out))
    count: Counter[str] = Counter()
    plan = clean_plan(clean_hours) + (["maze"] * trials if maze and clean_hours > 0 else [])
    for mission in plan:
        i = count[mission]
        count[mission] += 1
        folder = out / "runs" / "clean" / mission / f"R{i + 1:02d}"
        jobs.append(Job("clean", True, trial(mission, i, folder, configs[0], ()), out))
    return jobs


def describe(record: RunRecord, cases: Mapping[str, FaultCase]) -> str:
    """One line for a finished trial (the progress log when stdout is not a terminal)."""
    how = "monitor" if record.monitor else "no monitor"
    head = f"{record.case} {record.mission} seed {record.seed} ({how}): "
    if record.completed and record.mission == "maze":
        clearance = "" if record.d_min_m is None else f", d_min {100 * record.d_min_m:.1f} cm"
        end = f"goal reached, {record.collisions} contact(s){clearance}"
    elif record.completed:
        end = f"completed, GT closure {record.gt_closure_cm or math.nan:.1f} cm"
    elif record.end_reason is not None:
        end = f"aborted ({record.end_reason})"
    elif record.error is not None:
        end = f"failed: {record.error}"
    else:
        end = "did not end"
    case = cases.get(record.case)
    if case is not None and record.monitor:
        d = detect(record.transitions, case.sensor, record.onset_s)
        if d.detected and d.time_to_detect_s is not None:
            end += f"; {case.sensor} detected after {d.time_to_detect_s:.2f} s"
        else:
            end += f"; {case.sensor} NOT detected"
        if d.first_sensor not in (None, case.sensor):
            end += f" (first out: {d.first_sensor})"
        if d.others_excluded:
            end += f" (also excluded: {', '.join(d.others_excluded)})"
    elif record.case == "clean":
        alarms = [t for t in record.transitions if t.new in UNHEALTHY]
        end += f"; {len(alarms)} alarm(s)" if alarms else "; no alarm"
    return head + end


def run_fault_campaign(
    out: Path,
    *,
    trials: int = 10,
    clean_hours: float = 1.0,
    cases: Sequence[FaultCase] = CASES,
    robot: str = "jackson_physical",
    seed: int = 0,
    workers: int = 2,
    config: Path | None = None,
    map_yaml: Path | None = None,
    progress: bool = True,
    log: Callable[[str], None] | None = None,
    cluster: str | None = None,
) -> dict[str, Any]:
    """Run the fault campaign and write its report folder.

    Parameters
    ----------
    out : Path
        The report folder: ``summary.md``, ``summary.json``, ``runs.json``, ``faults.png``, the
        two host YAMLs and ``runs/<case>/<monitor|no-monitor>/Rnn``, ``runs/clean/<mission>/Rnn``;
        with maze cases and no ``map_yaml``, the mapping run in ``map/``.
    trials : int
        Seeds per case (each run with and without the monitor); with maze cases, as many clean
        maze runs.
    clean_hours : float
        Driving time of the clean runs [h] (0: none).
    cases : sequence of FaultCase
        The cases (default :data:`CASES`).
    robot : str
        The twin's robot file.
    seed : int
        Seed of trial 0; trial ``i`` has ``seed + i``.
    workers : int
        Worker processes.
    config : Path or None
        The host YAML (None: the default configuration).
    map_yaml : Path or None
        The maze cases' map (None: a mapping run with ``config`` and ``seed`` makes it first,
        as ``jackson run maze`` does).
    progress : bool
        Show a progress bar.
    log : callable, optional
        Called with a line per finished trial.
    cluster : str or None
        None: the local pool; ``local``, ``auto`` or ``ray://HOST:PORT``: a Ray cluster
        (:func:`jackson.experiments.cluster.map_trials`; the paths are then made absolute).

    Returns
    -------
    dict
        The contents of ``summary.json``.

    Raises
    ------
    FaultCampaignError
        The mapping run did not finish (no trial has run).
    """
    from rich.progress import Progress

    from jackson.experiments.cluster import map_trials

    if cluster is not None:
        out = out.absolute()
        config = config.absolute() if config is not None else None
        map_yaml = map_yaml.absolute() if map_yaml is not None else None
    out.mkdir(parents=True, exist_ok=True)
    configs = write_host_configs(out, config)
    maze = any(c.mission == "maze" for c in cases)
    if maze and map_yaml is None:
        map_yaml = map_maze(out / "map", robot, seed, configs[0])
    jobs = plan_jobs(
        out,
        cases,
        trials,
        clean_hours,
        robot=robot,
        seed=seed,
        configs=configs,
        map_yaml=map_yaml,
    )
    by_name = {c.name: c for c in cases}
    records: list[RunRecord] = []
    wall0 = time.perf_counter()
    with Progress(disable=not progress, transient=True) as bar:
        task = bar.add_task(f"fault campaign: {len(jobs)} runs", total=len(jobs))
        finished = map_trials(run_job, jobs, workers=workers, cluster=cluster, folder=out)
        for k, (_, record) in enumerate(finished, 1):
            records.append(record)
            bar.advance(task)
            if log is not None:
                log(f"[{k}/{len(jobs)}] {describe(record, by_name)}")
    order = {j.spec.out.relative_to(out).as_posix(): k for k, j in enumerate(jobs)}
    records.sort(key=lambda r: order[r.folder])
    meta = {
        "robot": robot,
        "trials": trials,
        "clean_hours_planned": clean_hours,
        "seed": seed,
        "workers": workers,
        "onset_s": ONSET_S,
        **({"maze_onset_s": MAZE_ONSET_S, "map": str(map_yaml)} if maze else {}),
        "detection_target": DETECTION_TARGET,
        "confidence": CONFIDENCE,
        "runs": len(records),
        "wall_s": time.perf_counter() - wall0,
    }
    summary = summarise(cases, records, meta)
    write_report(out, summary, records)
    return summary


def map_maze(folder: Path, robot: str, seed: int, config: Path) -> Path:
    """The maze's map for the navigation trials: a mapping run of the static maze
    (:func:`jackson.experiments.stage3.mapping_spec`), its daemon's lines in ``daemon.log``.

    Parameters
    ----------
    folder : Path
        The mapping run's folder.
    robot : str
        The twin's robot file.
    seed : int
        The mapping run's seed.
    config : Path
        The host YAML.

    Returns
    -------
    Path
        ``built_map.yaml`` in ``folder``.

    Raises
    ------
    FaultCampaignError
        The survey did not finish.
    """
    from jackson.experiments.stage3 import mapping_spec, run_nav_trial

    folder.mkdir(parents=True, exist_ok=True)
    with (folder / "daemon.log").open("w") as told, contextlib.redirect_stdout(told):
        result = run_nav_trial(mapping_spec(robot, WORLDS["maze"], seed, folder, config))
    if not result["completed"]:
        raise FaultCampaignError(f"the maze's mapping run stopped: {result['failure']}")
    return folder / "built_map.yaml"


def summarise(
    cases: Sequence[FaultCase], records: Sequence[RunRecord], meta: Mapping[str, Any]
) -> dict[str, Any]:
    """``summary.json``: every case's figures, the false alarms, which cases missed.

    Parameters
    ----------
    cases : sequence of FaultCase
        The cases run.
    records : sequence of RunRecord
        Every run.
    meta : Mapping
        The campaign's settings.

    Returns
    -------
    dict
        ``meta``, ``cases`` (:class:`CaseSummary` as dicts), ``false_alarms``
        (:class:`FalseAlarms`), ``all_met``, ``missed`` (``{case: [reasons]}``) and
        ``stalls``: the runs retried after a lockstep stall (``stalled``: twice, so left out of
        every figure above), the machine's failures, not the robot's.
    """
    judged = [r for r in records if not r.stalled]  # twice stalled: the machine's, apart
    summaries = [
        summarise_case(
            c,
            [r for r in judged if r.case == c.name and r.monitor],
            [r for r in judged if r.case == c.name and not r.monitor],
        )
        for c in cases
    ]
    clean = summarise_clean([r for r in judged if r.case == "clean"])
    return {
        "meta": dict(meta),
        "cases": [s.as_json() for s in summaries],
        "false_alarms": dataclasses.asdict(clean),
        "all_met": all(s.met_target for s in summaries),
        "missed": {s.name: s.missed for s in summaries if s.missed},
        "stalls": [
            {
                "run": r.folder,
                "stalled": r.stalled,
                "failure": r.failure,
                "stall_retried": r.stall_retried,
            }
            for r in records
            if r.stall_retried is not None
        ],
    }
