"""``jackson campaign faults``: the sensor health monitor against the twin's sensor faults.

Each case (:data:`CASES`) injects one sensor fault (:mod:`jackson.sim.faults`) at
:data:`ONSET_S` of MCU time into a figure-eight (or a square) on the twin, or a LiDAR fault at
:data:`MAZE_ONSET_S` into the maze's navigation trial (:mod:`jackson.calibration.stage3`: the
default ``jackson run maze``, amcl on a map made once by a mapping run before the trials), and
names the sensor the health monitor (:mod:`jackson.host.health`) should blame. Every trial of a
case runs twice on the same seed: with the monitor (the host configuration as it is) and without
it (the same configuration with ``health.enabled: false``: the paper's filter). Clean runs of
both missions, without any fault and with the monitor, measure its false alarms; with maze cases,
as many clean maze runs as there are trials join them (the only runs where the LiDAR is judged).
Trials run in worker processes as :mod:`jackson.calibration.campaign` runs them; each keeps its
run folder.

What is measured, from each run folder's ``health.json`` (``sensors.transitions``) and
``metrics.json`` (the fault's record: ``first_s``, the first reading it acted on, is the onset):

- **detection**: a transition of the expected sensor to ``suspect`` or ``excluded`` at or after
  the onset, within the run (:func:`detect`); its time minus the onset is the time to detect;
- **isolation**: the first sensor to leave its healthy state at or after the onset is the
  expected one (otherwise that sensor is named);
- **exclusion**: a transition of the expected sensor to ``excluded`` at or after the onset;
- **ended**: every run ends, completed or aborted with a reason (a mission that never ends is
  stopped by the trial's wall-clock limit and counts as not ended); a navigation that gives up
  (the navigator's reason) ended too, and counts with the aborted runs;
- **closure**: ground-truth and EKF closure of the completed runs, mean and SD, with and without
  the monitor (square and figure-eight);
- **navigation** (maze): goal reached, aborted (with the reasons) or not ended, contacts with the
  world and d_min to the dropped cylinder (Eq. 21), with and without the monitor;
- **false alarms**: transitions to ``excluded`` (and, apart, to ``suspect``) on the clean runs
  per hour driven, with the exact one-sided Poisson upper bound (:func:`poisson_upper`).

A case meets its target when the detection rate is at least :data:`DETECTION_TARGET` and every
run of it, with and without the monitor, ended.
"""

from __future__ import annotations

import contextlib
import dataclasses
import itertools
import json
import math
import statistics
import time
from collections import Counter
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple

from jackson.common.errors import JacksonError

if TYPE_CHECKING:  # the twin and the host load when a campaign runs, not for jackson --help
    from jackson.calibration.stage3 import NavTrialSpec
    from jackson.calibration.trial import TrialSpec
    from jackson.sim.faults import FaultSpec

ONSET_S = 30.0  # [s] MCU time of the square's and the figure-eight's fault onsets
# [s] the maze cases' onset: the maze's navigation drives from 2.05 s to 9.5-10.3 s of MCU time
# (seeds 0-2; the cylinder drops at 2.9 s), so the fault meets the last 5.5-6.3 s of the drive
MAZE_ONSET_S = 4.0
DETECTION_TARGET = 0.95  # a case's detection rate must reach this
CONFIDENCE = 0.95  # one-sided confidence of the false-alarm upper bounds
UNHEALTHY = ("suspect", "excluded")  # states a detection moves a sensor into
SENSORS = ("imu", "encoder_left", "encoder_right")
LIDAR = "lidar"  # the monitor's LiDAR: judged on the maze only (the other missions run without)
WORLDS = {"figure8": "open_floor", "square": "square_room", "maze": "maze"}
# [s] a little under a clean run's driving time, so that a plan of clean runs reaches its hours
PLANNED_DRIVE_S = {"square": 45.0, "figure8": 90.0}
MONITOR_YAML = "host-monitor.yaml"
NO_MONITOR_YAML = "host-no-monitor.yaml"


class FaultCampaignError(JacksonError, RuntimeError):
    """The campaign cannot run its trials: the maze's mapping run did not finish."""


@dataclass(frozen=True)
class FaultCase:
    """One case of the campaign: a mission, the fault injected, the sensor to blame.

    Attributes
    ----------
    name : str
        Its name on the command line (``--case``) and in the report.
    mission : str
        ``figure8``, ``square`` or ``maze`` (the navigation trial).
    fault : str
        The fault as ``KIND@AT_S[+DURATION_S][:key=value,...]`` (:func:`parse_fault`).
    sensor : str
        The health monitor's sensor that should be blamed (``imu``, ``encoder_left``,
        ``encoder_right``, ``lidar``).
    """

    name: str
    mission: str
    fault: str
    sensor: str

    @property
    def spec(self) -> FaultSpec:
        """The fault as the twin takes it."""
        from jackson.sim.faults import parse_fault

        return parse_fault(self.fault)


SLIP = "wheel_slip@30+2:side=right,mu_scale=0.01"  # 0.1 barely slips at 0.08 m/s (docs)
CASES = (
    FaultCase("imu_dead", "figure8", "imu_dead@30", "imu"),
    FaultCase("imu_stuck", "figure8", "imu_stuck@30", "imu"),
    FaultCase("imu_spike", "figure8", "imu_spike@30+30", "imu"),
    FaultCase("imu_bias_step", "figure8", "imu_bias_step@30", "imu"),
    FaultCase("encoder_dropout_left", "figure8", "encoder_dropout@30:side=left", "encoder_left"),
    FaultCase("wheel_slip_right", "figure8", SLIP, "encoder_right"),
    FaultCase("square_imu_bias_step", "square", "imu_bias_step@30", "imu"),
    FaultCase("square_wheel_slip_right", "square", SLIP, "encoder_right"),
    FaultCase("lidar_noise", "maze", "lidar_noise@4:sigma_m=0.05", LIDAR),
    FaultCase("lidar_dropout", "maze", "lidar_dropout@4:probability=0.3", LIDAR),
    FaultCase("lidar_dead", "maze", "lidar_dropout@4:probability=1", LIDAR),
    FaultCase("lidar_garbage", "maze", "lidar_garbage@4", LIDAR),
    FaultCase("lidar_closed", "maze", "lidar_closed@4", LIDAR),
)
"""Every case, in the report's order."""
BLIND_CASES = frozenset({"lidar_dead", "lidar_garbage", "lidar_closed"})
"""Cases whose LiDAR goes blind: the robot must stand within :data:`BLIND_LIMIT_M`."""
BLIND_LIMIT_M = 0.1  # [m] the farthest a navigating robot may drive on its last scans
CASE_NAMES = tuple(c.name for c in CASES)


class Transition(NamedTuple):
    """One entry of ``health.json`` ``sensors.transitions``."""

    t_s: float
    sensor: str
    old: str
    new: str
    reason: str


@dataclass(frozen=True)
class RunRecord:
    """What one run of the campaign did, read back from its folder (:func:`load_run`).

    Attributes
    ----------
    case : str
        The case's name, or ``clean``.
    mission : str
        ``figure8``, ``square`` or ``maze``.
    monitor : bool
        Whether the health monitor ran.
    trial, seed : int
        The trial's index and its twin seed.
    folder : str
        The run folder, relative to the report folder.
    completed : bool
        The mission finished (the maze: the goal reached).
    abort_reason : str or None
        Why the mission was aborted (``health.json``), None if it was not.
    error : str or None
        The trial failed to run (an exception in the worker), None if it ran.
    gt_closure_cm, ekf_closure_cm : float or None
        Ground-truth and EKF closure [cm] (None if the trial failed).
    duration_s : float
        Driving time, from the first command to move to the last [s].
    sim_s : float
        MCU time the run lasted [s].
    onset_s : float or None
        The first instant the fault acted (``first_s``), None without a fault or if it never did.
    transitions : tuple of Transition
        Every health-state transition of the run (none without the monitor).
    spikes : int
        Gyro spikes the fault injected (``imu_spike``; 0 for the other kinds).
    gated : int
        Samples the monitor's per-sample gate refused (``health.json`` counts).
    failure : str or None
        Why a navigation gave up without an abort (the navigator's reason), None otherwise.
    collisions : int
        Contacts of the robot with the world (the twin's count).
    d_min_m : float or None
        The maze: d_min (Eq. 21) from the dropped cylinder to the robot's envelope [m], None
        elsewhere or when no cylinder dropped.
    scans : int or None
        The maze: LiDAR revolutions the host decoded, None elsewhere.
    after_onset_m : float or None
        Ground-truth path length from the fault's onset to the end of the run [m] (for a
        LiDAR that goes blind: how far the robot drove on its last scans before it stood).
    """

    case: str
    mission: str
    monitor: bool
    trial: int
    seed: int
    folder: str
    completed: bool
    abort_reason: str | None
    error: str | None
    gt_closure_cm: float | None
    ekf_closure_cm: float | None
    duration_s: float
    sim_s: float
    onset_s: float | None
    transitions: tuple[Transition, ...] = ()
    spikes: int = 0
    gated: int = 0
    failure: str | None = None
    collisions: int = 0
    d_min_m: float | None = None
    after_onset_m: float | None = None
    scans: int | None = None

    @property
    def end_reason(self) -> str | None:
        """Why the mission ended without completing: the abort's reason, or the navigation's."""
        return self.abort_reason if self.abort_reason is not None else self.failure

    @property
    def ended(self) -> bool:
        """Completed, or aborted with a reason: the run did not go on without end."""
        return self.completed or self.end_reason is not None


@dataclass(frozen=True)
class Detection:
    """How the monitor met one fault (:func:`detect`).

    Attributes
    ----------
    detected : bool
        The expected sensor left its healthy state at or after the onset.
    time_to_detect_s : float or None
        That first transition's time minus the onset [s].
    first_sensor : str or None
        The sensor that first left its healthy state at or after the onset, or the sensors
        that left it at that same instant joined by ``+`` (None: none did).
    isolated : bool
        ``first_sensor`` is the expected sensor alone.
    excluded : bool
        The expected sensor was excluded at or after the onset.
    others_excluded : tuple of str
        Other sensors excluded at or after the onset (blamed wrongly, or besides).
    first_excluded : str or None
        The first sensor excluded at or after the onset (None: none was).
    time_to_exclude_s : float or None
        The expected sensor's first exclusion after the onset, minus the onset [s].
    """

    detected: bool
    time_to_detect_s: float | None
    first_sensor: str | None
    isolated: bool
    excluded: bool
    others_excluded: tuple[str, ...] = ()
    first_excluded: str | None = None
    time_to_exclude_s: float | None = None


@dataclass(frozen=True)
class Stat:
    """Mean and sample SD of ``n`` values (None where undefined)."""

    mean: float | None
    sd: float | None
    n: int


@dataclass(frozen=True)
class Outcome:
    """How the runs of one case ended, and their closures.

    Attributes
    ----------
    runs, completed, aborted, not_ended : int
        Counts of runs; ``not_ended`` neither completed nor aborted (or failed to run).
    gt_closure_cm, ekf_closure_cm : Stat
        Over the completed runs [cm].
    """

    runs: int
    completed: int
    aborted: int
    not_ended: int
    gt_closure_cm: Stat
    ekf_closure_cm: Stat


@dataclass(frozen=True)
class NavOutcome:
    """How the maze runs of one case ended, and how close they came to the world.

    Attributes
    ----------
    runs, reached, aborted, not_ended : int
        Counts of runs: the goal reached, aborted (by the daemon or a navigation that gave up),
        neither (or failed to run).
    reasons : dict
        Why the aborted runs ended: ``{reason: runs}``.
    collisions : int
        Contacts with the world, summed over the runs.
    runs_with_contact : int
        Runs with at least one contact.
    d_min_cm : Stat
        d_min (Eq. 21) from the dropped cylinder over every run it dropped in [cm].
    d_min_lowest_cm : float or None
        The smallest of them [cm].
    scans : Stat
        LiDAR revolutions the host decoded per run.
    driving_s : Stat
        Driving time per run, from the first command to move to the goal or the run's end [s].
    """

    runs: int
    reached: int
    aborted: int
    not_ended: int
    reasons: dict[str, int]
    collisions: int
    runs_with_contact: int
    d_min_cm: Stat
    d_min_lowest_cm: float | None
    scans: Stat
    driving_s: Stat


@dataclass(frozen=True)
class CaseSummary:
    """The figures of one case (:func:`summarise_case`); rates are fractions of its trials.

    Attributes
    ----------
    first_sensors : dict
        How often each sensor (or sensors at one instant, ``imu+encoder_left``) was the first to
        leave its healthy state after the onset (``none``: no sensor did).
    isolated_by_exclusion : int
        Runs whose first sensor excluded after the onset is the expected one.
    others_excluded : dict
        In how many runs each other sensor was excluded after the onset.
    pre_onset_alarms : int
        Transitions to ``suspect`` or ``excluded`` before the onset in the monitored runs
        (false alarms while the robot was healthy).
    spikes, gated : int
        Gyro spikes injected and samples gated, summed over the monitored runs (a spike case
        catches every spike when they are equal).
    missed : list of str
        Why the case missed its target (empty: it met it).
    runs_to_look_at : list of dict
        Runs (``run``: folder) where the fault was not detected, not isolated, another sensor
        was excluded, or that did not end, and ``what`` happened.
    navigation_with_monitor, navigation_without_monitor : NavOutcome or None
        A maze case's navigation outcomes (None for the other missions).
    after_onset_max_m : float or None
        A LiDAR that goes blind (``lidar_dead``, ``lidar_garbage``, ``lidar_closed``): the
        farthest a monitored run drove after the onset, to standstill (target
        :data:`BLIND_LIMIT_M`); None for the other cases.
    """

    name: str
    mission: str
    fault: str
    sensor: str
    trials: int
    detected: int
    detection_rate: float
    isolated: int
    isolation_rate: float
    isolated_by_exclusion: int
    first_sensors: dict[str, int]
    time_to_detect_s: list[float]
    time_to_detect_median_s: float | None
    time_to_detect_max_s: float | None
    time_to_exclude_median_s: float | None
    time_to_exclude_max_s: float | None
    excluded: int
    exclusion_rate: float
    others_excluded: dict[str, int]
    pre_onset_alarms: int
    spikes: int
    gated: int
    with_monitor: Outcome
    without_monitor: Outcome
    met_target: bool
    missed: list[str] = field(default_factory=list)
    runs_to_look_at: list[dict[str, str]] = field(default_factory=list)
    navigation_with_monitor: NavOutcome | None = None
    navigation_without_monitor: NavOutcome | None = None
    after_onset_max_m: float | None = None


@dataclass(frozen=True)
class Rate:
    """Events per hour over an exposure, with a one-sided Poisson upper bound.

    Attributes
    ----------
    count : int
        Events.
    hours : float
        Exposure [h].
    per_hour : float or None
        count / hours [1/h] (None without exposure).
    upper_per_hour : float or None
        One-sided :data:`CONFIDENCE` upper bound of the rate [1/h] (:func:`poisson_upper`).
    """

    count: int
    hours: float
    per_hour: float | None
    upper_per_hour: float | None


@dataclass(frozen=True)
class FalseAlarms:
    """The monitor on clean runs (:func:`summarise_clean`).

    Attributes
    ----------
    runs, completed, not_ended : int
        Clean runs, how many completed, how many did not end.
    hours_driven : float
        Sum of the runs' driving time [h]: the exposure of the rates.
    hours_monitored : float
        Sum of the runs' MCU time, standing still before and after included [h].
    excluded, suspect : Rate
        Transitions to ``excluded`` and to ``suspect`` (any sensor, any time of the run) per
        hour driven.
    by_sensor : dict
        Those transitions per sensor: ``{sensor: {"excluded": n, "suspect": n}}`` (``lidar``
        with clean maze runs among them).
    alarms : list of dict
        Each transition: run folder, time, sensor, states, reason.
    by_mission : dict
        Runs and hours driven per mission: ``{mission: {"runs": n, "hours_driven": h}}``.
    """

    runs: int
    completed: int
    not_ended: int
    hours_driven: float
    hours_monitored: float
    excluded: Rate
    suspect: Rate
    by_sensor: dict[str, dict[str, int]]
    alarms: list[dict[str, Any]]
    by_mission: dict[str, dict[str, float]] = field(default_factory=dict)


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
        detected=detected,
        detection_rate=rate,
        isolated=sum(d.isolated for d in found),
        isolation_rate=sum(d.isolated for d in found) / n if n else 0.0,
        isolated_by_exclusion=sum(d.first_excluded == case.sensor for d in found),
        first_sensors=dict(sorted(first.items())),
        time_to_detect_s=ttd,
        time_to_detect_median_s=statistics.median(ttd) if ttd else None,
        time_to_detect_max_s=max(ttd) if ttd else None,
        time_to_exclude_median_s=statistics.median(tte) if tte else None,
        time_to_exclude_max_s=max(tte) if tte else None,
        excluded=sum(d.excluded for d in found),
        exclusion_rate=sum(d.excluded for d in found) / n if n else 0.0,
        others_excluded=dict(sorted(Counter(s for d in found for s in d.others_excluded).items())),
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
        from jackson.calibration.trial import TrialSpec

        return self.spec.mission if isinstance(self.spec, TrialSpec) else "maze"


def run_job(job: Job) -> RunRecord:
    """Run one trial (:func:`jackson.calibration.trial.run_trial`, the maze's
    :func:`jackson.calibration.stage3.run_nav_trial`) and read its folder back.

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
    from jackson.calibration.stage3 import run_nav_trial
    from jackson.calibration.trial import TrialSpec, run_trial

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
    from jackson.calibration.stage3 import NavTrialSpec
    from jackson.calibration.trial import TrialSpec

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
        (:func:`jackson.calibration.cluster.map_trials`; the paths are then made absolute).

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

    from jackson.calibration.cluster import map_trials

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
    (:func:`jackson.calibration.stage3.mapping_spec`), its daemon's lines in ``daemon.log``.

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
    from jackson.calibration.stage3 import mapping_spec, run_nav_trial

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
        (:class:`FalseAlarms`), ``all_met`` and ``missed`` (``{case: [reasons]}``).
    """
    summaries = [
        summarise_case(
            c,
            [r for r in records if r.case == c.name and r.monitor],
            [r for r in records if r.case == c.name and not r.monitor],
        )
        for c in cases
    ]
    clean = summarise_clean([r for r in records if r.case == "clean"])
    return {
        "meta": dict(meta),
        "cases": [dataclasses.asdict(s) for s in summaries],
        "false_alarms": dataclasses.asdict(clean),
        "all_met": all(s.met_target for s in summaries),
        "missed": {s.name: s.missed for s in summaries if s.missed},
    }


# --------------------------------------------------------------------------- report


def write_report(out: Path, summary: Mapping[str, Any], records: Sequence[RunRecord]) -> None:
    """``runs.json``, ``summary.json``, ``summary.md`` and ``faults.png`` in ``out``.

    Parameters
    ----------
    out : Path
        The report folder.
    summary : Mapping
        :func:`summarise`'s result.
    records : sequence of RunRecord
        Every run.
    """
    runs = [dataclasses.asdict(r) | {"ended": r.ended} for r in records]
    for r in runs:
        r["transitions"] = [t._asdict() for t in r["transitions"]]
    (out / "runs.json").write_text(json.dumps(runs, indent=2) + "\n")
    (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    (out / "summary.md").write_text(summary_markdown(summary))
    plot_faults(out / "faults.png", summary)


def _pm(s: Mapping[str, Any], digits: int = 2) -> str:
    if s["mean"] is None:
        return "-"
    sd = "" if s["sd"] is None else f" ± {s['sd']:.{digits}f}"
    return f"{s['mean']:.{digits}f}{sd} ({s['n']})"


def _seconds(x: float | None) -> str:
    return "-" if x is None else f"{x:.2f}"


def _per_h(rate: Mapping[str, Any]) -> str:
    if rate["per_hour"] is None:
        return "- (no driving)"
    upper = rate["upper_per_hour"]
    return f"{rate['count']} ({rate['per_hour']:.2f} /h, ≤ {upper:.2f} /h at {CONFIDENCE:.0%})"


def summary_markdown(summary: Mapping[str, Any]) -> str:
    """The report's tables (detection, closure, false alarms) as Markdown.

    Parameters
    ----------
    summary : Mapping
        :func:`summarise`'s result.

    Returns
    -------
    str
        ``summary.md``.
    """
    meta = summary["meta"]
    maze = [c for c in summary["cases"] if c["mission"] == "maze"]
    onsets = f"faults at {meta['onset_s']:g} s of MCU time"
    if maze:
        onsets = (
            f"faults at {meta['onset_s']:g} s of MCU time on the square and the figure-eight, "
            f"LiDAR faults at {meta['maze_onset_s']:g} s into the maze's navigation trial "
            f"(map `{meta['map']}`)"
        )
    lines = [
        "# Fault campaign",
        "",
        f"{meta['trials']} seeds per case from seed {meta['seed']} on `{meta['robot']}`, each "
        f"with and without the health monitor; {onsets}; "
        f"{meta['runs']} runs in {meta['wall_s'] / 60:.1f} min on {meta['workers']} workers.",
        "",
        "## Detection (runs with the monitor)",
        "",
        "| case | mission | fault | blame | detected | isolated (first out otherwise) | "
        "time to detect median / max [s] | excluded | time to exclude median / max [s] | "
        "first excluded | others excluded | monitor: completed / aborted / not ended | "
        "no monitor: completed / aborted / not ended | target |",
        "|---|---|---|---|---:|---|---:|---:|---:|---:|---|---:|---:|---|",
    ]
    for c in summary["cases"]:
        n = c["trials"]
        others = {k: v for k, v in c["first_sensors"].items() if k != c["sensor"]}
        other = ", ".join(f"{k} {v}" for k, v in others.items())
        wrong = ", ".join(f"{k} {v}" for k, v in c["others_excluded"].items())
        on, off = c["with_monitor"], c["without_monitor"]
        verdict = "met" if c["met_target"] else "MISSED: " + "; ".join(c["missed"])
        lines.append(
            f"| {c['name']} | {c['mission']} | `{c['fault']}` | {c['sensor']} | "
            f"{c['detected']}/{n} | {c['isolated']}/{n}{f' ({other})' if other else ''} | "
            f"{_seconds(c['time_to_detect_median_s'])} / {_seconds(c['time_to_detect_max_s'])} | "
            f"{c['excluded']}/{n} | {_seconds(c['time_to_exclude_median_s'])} / "
            f"{_seconds(c['time_to_exclude_max_s'])} | "
            f"{c['isolated_by_exclusion']}/{n} | {wrong or '-'} | "
            f"{on['completed']} / {on['aborted']} / {on['not_ended']} | "
            f"{off['completed']} / {off['aborted']} / {off['not_ended']} | {verdict} |"
        )
    for c in summary["cases"]:
        if c["spikes"]:
            lines.append(
                f"\n{c['name']}: {c['gated']} samples gated for {c['spikes']} spikes injected "
                f"over {c['trials']} runs."
            )
    for c in summary["cases"]:
        if c.get("after_onset_max_m") is not None:
            lines.append(
                f"\n{c['name']}: the robot stood at most {c['after_onset_max_m'] * 100:.1f} cm "
                f"(ground truth) after the LiDAR went blind (target {BLIND_LIMIT_M * 100:.0f} cm)."
            )
    early = sum(c["pre_onset_alarms"] for c in summary["cases"])
    lines.append(f"\nTransitions before the onset in the monitored runs: {early}.")
    looks: dict[tuple[str, str, str], list[str]] = {}
    for c in summary["cases"]:
        for x in c["runs_to_look_at"]:
            where, _, run = x["run"].rpartition("/")
            looks.setdefault((c["name"], where, x["what"]), []).append(run)
    if looks:
        lines += ["", "Runs to look at:", ""]
        lines += [
            f"- {name}: {what}: `{where}/` {', '.join(runs)}"
            for (name, where, what), runs in looks.items()
        ]
    loops = [c for c in summary["cases"] if c["mission"] != "maze"]  # the maze: no loop
    if loops:
        lines += [
            "",
            "## Closure of the completed runs [cm], mean ± SD (runs)",
            "",
            "| case | ground truth, monitor | ground truth, no monitor | EKF, monitor | "
            "EKF, no monitor |",
            "|---|---:|---:|---:|---:|",
        ]
    for c in loops:
        on, off = c["with_monitor"], c["without_monitor"]
        lines.append(
            f"| {c['name']} | {_pm(on['gt_closure_cm'])} | {_pm(off['gt_closure_cm'])} | "
            f"{_pm(on['ekf_closure_cm'])} | {_pm(off['ekf_closure_cm'])} |"
        )
    if maze:
        lines += _navigation_markdown(maze)
    fa = summary["false_alarms"]
    columns = [*SENSORS, *(s for s in fa["by_sensor"] if s not in SENSORS)]
    lines += [
        "",
        "## False alarms (clean runs, monitor on)",
        "",
        f"{fa['runs']} runs ({fa['completed']} completed, {fa['not_ended']} did not end): "
        f"{fa['hours_driven']:.3f} h driven, {fa['hours_monitored']:.3f} h monitored"
        + _clean_missions(fa.get("by_mission") or {})
        + ".",
        "",
        "| transitions to | count (per hour driven, one-sided upper bound) | "
        + " | ".join(columns)
        + " |",
        "|---|---|" + "---:|" * len(columns),
    ]
    for state in ("excluded", "suspect"):
        per = " | ".join(str(fa["by_sensor"].get(s, {}).get(state, 0)) for s in columns)
        lines.append(f"| {state} | {_per_h(fa[state])} | {per} |")
    if fa["alarms"]:
        lines += ["", "Alarms on clean runs:", ""]
        lines += [
            f"- `{a['run']}` {a['t_s']:.2f} s: {a['sensor']} {a['old']} -> {a['new']} "
            f"({a['reason']})"
            for a in fa["alarms"]
        ]
    missed = summary["missed"]
    lines += [
        "",
        "All cases met their target."
        if summary["all_met"]
        else "Missed: " + "; ".join(f"{k}: {', '.join(v)}" for k, v in missed.items()) + ".",
        "",
    ]
    return "\n".join(lines)


def _clean_missions(by_mission: Mapping[str, Mapping[str, float]]) -> str:
    """The clean runs per mission, when the maze's are among them (the LiDAR judged there)."""
    if "maze" not in by_mission:
        return ""
    parts = [
        f"{m} {v['runs']:g} run{'' if v['runs'] == 1 else 's'}, {v['hours_driven']:.3f} h"
        for m, v in by_mission.items()
    ]
    return f" ({'; '.join(parts)}; the LiDAR is judged on the maze only)"


def _navigation_markdown(cases: Sequence[Mapping[str, Any]]) -> list[str]:
    """The maze cases' table: how the navigations ended, contacts, d_min, driving time, scans."""
    lines = [
        "",
        "## Navigation of the maze cases (goal reached / aborted / not ended)",
        "",
        "d_min (Eq. 21): the dropped cylinder to the robot's envelope, mean ± SD (runs), lowest.",
        "",
        "| case | monitor: reached / aborted / not ended | no monitor: reached / aborted / "
        "not ended | contacts (runs) monitor / no monitor | d_min [cm] monitor | "
        "d_min [cm] no monitor | driving [s] monitor / no monitor | "
        "scans per run, monitor / no monitor |",
        "|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    reasons = []
    for c in cases:
        on, off = c["navigation_with_monitor"], c["navigation_without_monitor"]
        cells = []
        for o in (on, off):
            low = o["d_min_lowest_cm"]
            cells.append(f"{_pm(o['d_min_cm'], 1)}{'' if low is None else f', {low:.1f}'}")
        lines.append(
            f"| {c['name']} | {on['reached']} / {on['aborted']} / {on['not_ended']} | "
            f"{off['reached']} / {off['aborted']} / {off['not_ended']} | "
            f"{on['collisions']} ({on['runs_with_contact']}) / "
            f"{off['collisions']} ({off['runs_with_contact']}) | {cells[0]} | {cells[1]} | "
            f"{_pm(on['driving_s'], 1)} / {_pm(off['driving_s'], 1)} | "
            f"{_pm(on['scans'], 0)} / {_pm(off['scans'], 0)} |"
        )
        for label, o in (("monitor", on), ("no monitor", off)):
            name = c["name"]
            reasons += [f"- {name}, {label}: {n} aborted: {why}" for why, n in o["reasons"].items()]
    if reasons:
        lines += ["", "Why the aborted runs ended:", "", *reasons]
    return lines


def plot_faults(path: Path, summary: Mapping[str, Any]) -> None:
    """``faults.png``: per case, detection rate and time to detect (top); closure with and
    without the monitor for the square and the figure-eight, d_min and goals reached with and
    without it for the maze (below, error bars one SD).

    Parameters
    ----------
    path : Path
        The PNG to write.
    summary : Mapping
        :func:`summarise`'s result.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    every = summary["cases"]

    def label(c: Mapping[str, Any]) -> str:
        return str(c["name"]).replace("_", " ").replace("square ", "square:\n")

    names = [label(c) for c in every]
    x = np.arange(len(every))
    cases = [c for c in every if c["mission"] != "maze"]
    maze = [c for c in every if c["mission"] == "maze"]
    rows = 1 + bool(cases) + bool(maze)
    fig, axes = plt.subplots(
        rows, 1, figsize=(max(7.0, 1.2 * len(every) + 2), 3.75 * rows), dpi=150, squeeze=False
    )
    ax1 = axes[0, 0]

    det = [100 * c["detection_rate"] for c in every]
    iso = [100 * c["isolation_rate"] for c in every]
    ax1.bar(x - 0.18, det, 0.36, color="C0", label="detected")
    ax1.bar(x + 0.18, iso, 0.36, color="C0", alpha=0.45, label="isolated (first sensor out)")
    ax1.axhline(100 * DETECTION_TARGET, color="k", ls="--", lw=0.8)
    for xi, v in zip(x, iso, strict=True):
        if v == 0:
            ax1.text(xi + 0.18, 1, "0", fontsize=7, ha="center", va="bottom")
    ax1.set_ylim(0, 105)
    ax1.set_ylabel("runs [%]")
    ax1.set_xticks(x, names, fontsize=7)
    ax1.set_title(
        "Detection with the health monitor (dashed: target); time to detect", fontsize=9, pad=24
    )
    ax_t = ax1.twinx()
    med = np.array([c["time_to_detect_median_s"] or np.nan for c in every], dtype=float)
    top = np.array([c["time_to_detect_max_s"] or np.nan for c in every], dtype=float)
    ax_t.errorbar(
        x,
        med,
        yerr=[np.zeros_like(med), top - med],
        fmt="D",
        color="C3",
        ms=5,
        capsize=4,
        label="time to detect: median, bar to max",
    )
    positive = [v for v in np.r_[med, top] if np.isfinite(v) and v > 0]
    if positive and max(positive) / min(positive) > 30:
        ax_t.set_yscale("log")
    else:
        ax_t.set_ylim(0, (max(positive) * 1.1) if positive else 1.0)
    ax_t.set_ylabel("time to detect [s]", color="C3")
    h1, l1 = ax1.get_legend_handles_labels()
    h2, l2 = ax_t.get_legend_handles_labels()
    ax1.legend(h1 + h2, l1 + l2, fontsize=7, loc="lower center", bbox_to_anchor=(0.5, 1.0), ncol=3)
    if cases:
        _plot_closure(axes[1, 0], cases, [label(c) for c in cases])
    if maze:
        _plot_navigation(axes[-1, 0], maze, [label(c) for c in maze])
    fig.tight_layout()
    from jackson.common.figures import save_figure

    save_figure(fig, path)


def _plot_closure(ax2: Any, cases: Sequence[Mapping[str, Any]], names: Sequence[str]) -> None:
    """Closure of the completed runs with and without the monitor (error bars one SD)."""
    import numpy as np

    x = np.arange(len(cases))
    width = 0.2
    series = (
        ("with_monitor", "gt_closure_cm", "ground truth, monitor", "C0", 1.0),
        ("without_monitor", "gt_closure_cm", "ground truth, no monitor", "C1", 1.0),
        ("with_monitor", "ekf_closure_cm", "EKF, monitor", "C0", 0.45),
        ("without_monitor", "ekf_closure_cm", "EKF, no monitor", "C1", 0.45),
    )
    for k, (side, key, label, color, alpha) in enumerate(series):
        xs = x + (k - 1.5) * width
        mean = np.array([c[side][key]["mean"] or np.nan for c in cases], dtype=float)
        sd = np.array([c[side][key]["sd"] or 0.0 for c in cases], dtype=float)
        ax2.bar(xs, mean, width, yerr=sd, color=color, alpha=alpha, capsize=2, label=label)
        for xi, c in zip(xs, cases, strict=True):
            if c[side][key]["n"] == 0:
                ax2.text(
                    xi,
                    0.02,
                    "none completed",
                    rotation=90,
                    fontsize=6,
                    ha="center",
                    va="bottom",
                    transform=ax2.get_xaxis_transform(),
                )
    means = [
        c[s][k]["mean"]
        for c in cases
        for s in ("with_monitor", "without_monitor")
        for k in ("gt_closure_cm", "ekf_closure_cm")
        if c[s][k]["mean"]
    ]
    if means and max(means) / max(min(means), 1e-3) > 30:
        ax2.set_yscale("log")
    ax2.set_ylabel("closure of completed runs [cm]")
    ax2.set_xticks(x, names, fontsize=7)
    ax2.set_title("Closure with and without the monitor (error bars: one SD)", fontsize=9, pad=24)
    ax2.legend(fontsize=7, ncol=4, loc="lower center", bbox_to_anchor=(0.5, 1.0))
    ax2.grid(axis="y", alpha=0.3)


def _plot_navigation(ax: Any, cases: Sequence[Mapping[str, Any]], names: Sequence[str]) -> None:
    """The maze cases: d_min to the dropped cylinder with and without the monitor (error bars
    one SD), each bar labelled with the goals reached (inside a tall bar, above a short one)
    and, for a LiDAR that went blind, how far the monitored robot drove after the onset."""
    import numpy as np

    x = np.arange(len(cases))
    sides = (
        ("navigation_with_monitor", "monitor", "C0"),
        ("navigation_without_monitor", "no monitor", "C1"),
    )
    tallest = max(
        (c[side]["d_min_cm"]["mean"] or 0.0 for c in cases for side, _, _ in sides), default=0.0
    )
    for k, (side, text, color) in enumerate(sides):
        xs = x + (k - 0.5) * 0.36
        d = [c[side]["d_min_cm"] for c in cases]
        mean = np.array([s["mean"] if s["mean"] is not None else np.nan for s in d], dtype=float)
        sd = np.array([s["sd"] or 0.0 for s in d], dtype=float)
        ax.bar(xs, mean, 0.36, yerr=sd, color=color, capsize=3, label=f"d_min, {text}")
        for xi, c, m, e in zip(xs, cases, mean, sd, strict=True):
            o = c[side]
            label = f"goal {o['reached']}/{o['runs']}\naborted {o['aborted']}"
            if k == 0 and c.get("after_onset_max_m") is not None:
                label += f"\nstood \u2264 {c['after_onset_max_m'] * 100:.1f} cm"
            inside = bool(np.isfinite(m)) and m >= 0.35 * tallest  # room for the text
            ax.text(
                xi,
                0.02 * tallest if inside else (m + e if np.isfinite(m) else 0.0) + 0.02 * tallest,
                label,
                fontsize=6,
                ha="center",
                va="bottom",
                color="white" if inside else "k",
            )
    ax.set_ylabel("d_min to the dropped cylinder [cm]")
    ax.set_xticks(x, names, fontsize=7)
    ax.set_title(
        "Maze: clearance (Eq. 21) and goals reached with and without the monitor "
        "(error bars: one SD)",
        fontsize=9,
        pad=24,
    )
    ax.legend(fontsize=7, ncol=2, loc="lower center", bbox_to_anchor=(0.5, 1.0))
    ax.grid(axis="y", alpha=0.3)
