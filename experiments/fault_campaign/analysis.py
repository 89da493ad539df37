"""From run folders to verdicts: detections, outcomes, false-alarm rates, case summaries."""

from __future__ import annotations

import itertools
import json
import math
import statistics
from collections import Counter
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from jackson.experiments.fault_campaign.cases import (
    BLIND_CASES,
    BLIND_LIMIT_M,
    CONFIDENCE,
    DETECTION_TARGET,
    LIDAR,
    SENSORS,
    UNHEALTHY,
    FaultCase,
)
from jackson.experiments.fault_campaign.records import (
    CaseDetection,
    CaseExclusion,
    CaseSummary,
    Detection,
    FalseAlarms,
    NavOutcome,
    Outcome,
    Rate,
    RunRecord,
    Stat,
    Transition,
)

if TYPE_CHECKING:  # the twin and the host load when a campaign runs, not for jackson --help
    pass


# --------------------------------------------------------------------------- analysis


def transitions_of(health: Mapping[str, Any]) -> tuple[Transition, ...]:
    """The transitions of a run's ``health.json`` document (none when the monitor was off).

    Parameters
    ----------
    health : Mapping
        The parsed ``health.json``.

    Returns
    -------
    tuple of Transition
        In the order the monitor made them (by time).
    """
    sensors = health.get("sensors") or {}
    return tuple(
        Transition(float(t["t_s"]), str(t["sensor"]), str(t["from"]), str(t["to"]), t["reason"])
        for t in sensors.get("transitions", [])
    )


def detect(transitions: Sequence[Transition], sensor: str, onset_s: float | None) -> Detection:
    """Whether, how soon and how rightly the monitor blamed ``sensor`` for a fault.

    A detection is a transition to ``suspect`` or ``excluded`` at ``t_s >= onset_s`` (a sensor
    leaving ``ok`` or ``recovered``, or a suspect one excluded). The fault is isolated when the
    expected sensor is the first, and alone at that instant, to make such a transition.

    Parameters
    ----------
    transitions : sequence of Transition
        The run's transitions in time order.
    sensor : str
        The sensor that should be blamed.
    onset_s : float or None
        The fault's first reading [s]; None (the fault never acted): nothing is detected.

    Returns
    -------
    Detection
        Detected, time to detect, first sensor out after the onset, isolated, excluded.
    """
    if onset_s is None:
        return Detection(False, None, None, False, False)
    after = [t for t in transitions if t.t_s >= onset_s and t.new in UNHEALTHY]
    mine = [t for t in after if t.sensor == sensor]
    first = None
    if after:
        at_first = [t.sensor for t in after if t.t_s == after[0].t_s]
        first = "+".join(dict.fromkeys(at_first))
    out = [t.sensor for t in after if t.new == "excluded"]
    others = set(out) - {sensor}
    return Detection(
        detected=bool(mine),
        time_to_detect_s=mine[0].t_s - onset_s if mine else None,
        first_sensor=first,
        isolated=first == sensor,
        excluded=any(t.new == "excluded" for t in mine),
        others_excluded=tuple(sorted(others)),
        first_excluded=out[0] if out else None,
        time_to_exclude_s=next((t.t_s - onset_s for t in mine if t.new == "excluded"), None),
    )


def poisson_upper(count: int, confidence: float = CONFIDENCE) -> float:
    """One-sided upper confidence bound of a Poisson mean after ``count`` events.

        mu_up = chi2^-1(confidence; 2 count + 2) / 2

    (Garwood's exact bound; for 0 events it is -ln(1 - confidence): 3.00 at 95 %).

    Parameters
    ----------
    count : int
        Events observed.
    confidence : float
        One-sided confidence.

    Returns
    -------
    float
        Upper bound of the expected number of events.
    """
    from scipy.stats import chi2

    return float(chi2.ppf(confidence, 2 * count + 2)) / 2.0


def false_alarm_rate(count: int, hours: float, confidence: float = CONFIDENCE) -> Rate:
    """Events per hour over ``hours`` of exposure, with :func:`poisson_upper` per hour.

    Parameters
    ----------
    count : int
        Events observed.
    hours : float
        Exposure [h].
    confidence : float
        One-sided confidence of the upper bound.

    Returns
    -------
    Rate
        The count, the hours, the rate and its upper bound [1/h] (None without exposure).
    """
    if hours <= 0.0:
        return Rate(count, hours, None, None)
    return Rate(count, hours, count / hours, poisson_upper(count, confidence) / hours)


def stat(values: Sequence[float]) -> Stat:
    """Mean and sample SD (ddof 1) of ``values``.

    Parameters
    ----------
    values : sequence of float
        The values.

    Returns
    -------
    Stat
        Mean (None if empty), SD (None below two values), n.
    """
    n = len(values)
    mean = statistics.fmean(values) if n else None
    sd = statistics.stdev(values) if n >= 2 else None
    return Stat(mean, sd, n)


def load_run(
    folder: Path, *, case: str, monitor: bool, root: Path | None = None, error: str | None = None
) -> RunRecord:
    """Read one run folder's ``metrics.json`` and ``health.json`` into a :class:`RunRecord`.

    Parameters
    ----------
    folder : Path
        The run folder.
    case : str
        The case's name (or ``clean``).
    monitor : bool
        Whether the monitor ran.
    root : Path, optional
        The report folder; ``folder`` is recorded relative to it.
    error : str, optional
        The trial failed with this message: the record says so and reads what the folder has.

    Returns
    -------
    RunRecord
        What the run did.
    """
    metrics = _read_json(folder / "metrics.json")
    health = _read_json(folder / "health.json")
    meta = _read_json(folder / "meta.json")
    faults = metrics.get("faults") or []
    onset = faults[0].get("first_s") if faults else None
    if "faults" not in metrics and meta.get("faults"):  # no metrics (a run cut short): on time
        onset = meta["faults"][0].get("at_s")
    rel = folder.relative_to(root) if root is not None else folder
    abort_reason = health.get("abort_reason")
    failure = metrics.get("failure")  # a navigation's: the abort's reason, or the navigator's
    navigation = meta.get("mission") == "navigate"
    return RunRecord(
        case=case,
        mission=str(metrics.get("mission", "maze" if navigation else "")),
        monitor=monitor,
        trial=int(metrics.get("trial", -1)),
        seed=int(metrics.get("seed", -1)),
        folder=rel.as_posix(),
        completed=bool(metrics.get("completed", False)) and error is None,
        abort_reason=abort_reason,
        error=error,
        gt_closure_cm=_number(metrics.get("gt_closure_cm")),
        ekf_closure_cm=_number(metrics.get("ekf_closure_cm")),
        duration_s=float(metrics.get("duration_s", 0.0)),
        sim_s=float(metrics.get("sim_s", 0.0)),
        onset_s=None if onset is None else float(onset),
        transitions=transitions_of(health),
        spikes=int(faults[0].get("spikes", 0)) if faults else 0,
        gated=int(((health.get("sensors") or {}).get("counts") or {}).get("gated", 0)),
        failure=None if failure is None or failure == abort_reason else str(failure),
        collisions=int(metrics.get("collisions", 0)),
        d_min_m=_number(metrics.get("d_min_m")),
        scans=int(metrics["scans"]) if "scans" in metrics else None,
        after_onset_m=None if onset is None else _path_after(folder, float(onset)),
        stall_retried=metrics.get("stall_retried"),
        stalled=bool(metrics.get("stalled", False)),
    )


def _path_after(folder: Path, onset_s: float) -> float | None:
    """Ground-truth path length [m] from ``onset_s`` to the end (``ground_truth.csv``)."""
    import csv

    try:
        with (folder / "ground_truth.csv").open(newline="") as f:
            rows = [(float(r["t_s"]), float(r["x_m"]), float(r["y_m"])) for r in csv.DictReader(f)]
    except (OSError, KeyError, ValueError):
        return None
    after = [(x, y) for t, x, y in rows if t >= onset_s - 1e-9]
    return sum(math.dist(a, b) for a, b in itertools.pairwise(after)) if after else 0.0


def _read_json(path: Path) -> dict[str, Any]:
    try:
        doc = json.loads(path.read_text())
    except (OSError, ValueError):
        return {}
    return doc if isinstance(doc, dict) else {}


def _number(value: Any) -> float | None:
    if isinstance(value, (int, float)) and math.isfinite(value):
        return float(value)
    return None


def outcome(records: Sequence[RunRecord]) -> Outcome:
    """How ``records`` ended, and the closures of the completed ones.

    Parameters
    ----------
    records : sequence of RunRecord
        The runs.

    Returns
    -------
    Outcome
        Counts and closure statistics.
    """
    done = [r for r in records if r.completed]
    return Outcome(
        runs=len(records),
        completed=len(done),
        aborted=sum(1 for r in records if not r.completed and r.end_reason is not None),
        not_ended=sum(1 for r in records if not r.ended),
        gt_closure_cm=stat([r.gt_closure_cm for r in done if r.gt_closure_cm is not None]),
        ekf_closure_cm=stat([r.ekf_closure_cm for r in done if r.ekf_closure_cm is not None]),
    )


def nav_outcome(records: Sequence[RunRecord]) -> NavOutcome:
    """How the maze runs ``records`` ended, their contacts and their clearance.

    Parameters
    ----------
    records : sequence of RunRecord
        The runs.

    Returns
    -------
    NavOutcome
        Counts, the reasons of the aborted runs, contacts, d_min and scans.
    """
    reasons = Counter(r.end_reason for r in records if not r.completed and r.end_reason is not None)
    d_min = [100.0 * r.d_min_m for r in records if r.d_min_m is not None]
    return NavOutcome(
        runs=len(records),
        reached=sum(r.completed for r in records),
        aborted=sum(reasons.values()),
        not_ended=sum(not r.ended for r in records),
        reasons=dict(reasons.most_common()),
        collisions=sum(r.collisions for r in records),
        runs_with_contact=sum(r.collisions > 0 for r in records),
        d_min_cm=stat(d_min),
        d_min_lowest_cm=min(d_min) if d_min else None,
        scans=stat([float(r.scans) for r in records if r.scans is not None]),
        driving_s=stat([r.duration_s for r in records]),
    )


def summarise_case(
    case: FaultCase, with_monitor: Sequence[RunRecord], without_monitor: Sequence[RunRecord]
) -> CaseSummary:
    """The figures of one case from its runs with and without the monitor.

    Parameters
    ----------
    case : FaultCase
        The case.
    with_monitor, without_monitor : sequence of RunRecord
        Its runs (the detection figures come from the monitored ones).

    Returns
    -------
    CaseSummary
        Detection, isolation, time to detect, exclusion, outcomes and whether it met its target.
    """
    n = len(with_monitor)
    found = [detect(r.transitions, case.sensor, r.onset_s) for r in with_monitor]
    ttd = [d.time_to_detect_s for d in found if d.time_to_detect_s is not None]
    tte = [d.time_to_exclude_s for d in found if d.time_to_exclude_s is not None]
    first = Counter(d.first_sensor or "none" for d in found)
    early = sum(
        1
        for r in with_monitor
        for t in r.transitions
        if t.new in UNHEALTHY and (r.onset_s is None or t.t_s < r.onset_s)
    )
    on, off = outcome(with_monitor), outcome(without_monitor)
    detected = sum(d.detected for d in found)
    rate = detected / n if n else 0.0
    missed = []
    if rate < DETECTION_TARGET:
        missed.append(f"detected {detected}/{n} (target {DETECTION_TARGET:.0%})")
    blind = None
    if case.name in BLIND_CASES:
        drove = [r.after_onset_m for r in with_monitor if r.after_onset_m is not None]
        blind = max(drove) if drove else None
        if blind is None or blind > BLIND_LIMIT_M:
            missed.append(f"drove {blind} m blind (target {BLIND_LIMIT_M:g} m)")
    for label, o in (("with", on), ("without", off)):
        if o.not_ended:
            missed.append(f"{o.not_ended}/{o.runs} runs {label} the monitor did not end")
    look = []
    for r, d in zip(with_monitor, found, strict=True):
        what = []
        if not d.detected:
            what.append(f"{case.sensor} not detected")
        elif not d.isolated:
            what.append(f"first out: {d.first_sensor}")
        if d.others_excluded:
            what.append(f"excluded: {', '.join(d.others_excluded)}")
        if not r.ended:
            what.append(f"did not end{f' ({r.error})' if r.error else ''}")
        if what:
            look.append({"run": r.folder, "what": "; ".join(what)})
    look += [
        {"run": r.folder, "what": f"did not end{f' ({r.error})' if r.error else ''}"}
        for r in without_monitor
        if not r.ended
    ]
    return CaseSummary(
        name=case.name,
        mission=case.mission,
        fault=case.fault,
        sensor=case.sensor,
        trials=n,
        detection=CaseDetection(
            detected=detected,
            detection_rate=rate,
            isolated=sum(d.isolated for d in found),
            isolation_rate=sum(d.isolated for d in found) / n if n else 0.0,
            isolated_by_exclusion=sum(d.first_excluded == case.sensor for d in found),
            first_sensors=dict(sorted(first.items())),
            time_to_detect_s=ttd,
            time_to_detect_median_s=statistics.median(ttd) if ttd else None,
            time_to_detect_max_s=max(ttd) if ttd else None,
        ),
        exclusion=CaseExclusion(
            time_to_exclude_median_s=statistics.median(tte) if tte else None,
            time_to_exclude_max_s=max(tte) if tte else None,
            excluded=sum(d.excluded for d in found),
            exclusion_rate=sum(d.excluded for d in found) / n if n else 0.0,
            others_excluded=dict(
                sorted(Counter(s for d in found for s in d.others_excluded).items())
            ),
        ),
        pre_onset_alarms=early,
        spikes=sum(r.spikes for r in with_monitor),
        gated=sum(r.gated for r in with_monitor),
        with_monitor=on,
        without_monitor=off,
        met_target=not missed,
        missed=missed,
        runs_to_look_at=look,
        navigation_with_monitor=nav_outcome(with_monitor) if case.mission == "maze" else None,
        navigation_without_monitor=nav_outcome(without_monitor) if case.mission == "maze" else None,
        after_onset_max_m=blind,
    )


def summarise_clean(records: Sequence[RunRecord], confidence: float = CONFIDENCE) -> FalseAlarms:
    """False alarms of the monitor on runs without faults.

    Parameters
    ----------
    records : sequence of RunRecord
        The clean runs (with the monitor).
    confidence : float
        One-sided confidence of the upper bounds.

    Returns
    -------
    FalseAlarms
        Hours, transitions per hour driven to ``excluded`` and to ``suspect``, per sensor.
    """
    hours = sum(r.duration_s for r in records) / 3600.0
    missions = dict.fromkeys(r.mission for r in records)
    judged = (*SENSORS, LIDAR) if "maze" in missions else SENSORS
    by_sensor = {s: {"excluded": 0, "suspect": 0} for s in judged}
    alarms = []
    for r in records:
        for t in r.transitions:
            if t.new in UNHEALTHY:
                by_sensor.setdefault(t.sensor, {"excluded": 0, "suspect": 0})[t.new] += 1
                alarms.append({"run": r.folder, **t._asdict()})
    excluded = sum(v["excluded"] for v in by_sensor.values())
    suspect = sum(v["suspect"] for v in by_sensor.values())
    return FalseAlarms(
        runs=len(records),
        completed=sum(r.completed for r in records),
        not_ended=sum(not r.ended for r in records),
        hours_driven=hours,
        hours_monitored=sum(r.sim_s for r in records) / 3600.0,
        excluded=false_alarm_rate(excluded, hours, confidence),
        suspect=false_alarm_rate(suspect, hours, confidence),
        by_sensor=by_sensor,
        alarms=alarms,
        by_mission={
            m: {
                "runs": sum(r.mission == m for r in records),
                "hours_driven": sum(r.duration_s for r in records if r.mission == m) / 3600.0,
            }
            for m in missions
        },
    )
