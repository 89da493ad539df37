"""What the fault campaign keeps of each run and of each case: records, detections, rates."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, NamedTuple

if TYPE_CHECKING:  # the twin and the host load when a campaign runs, not for jackson --help
    pass


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
    stall_retried : str or None
        The run was retried after a lockstep stall (the machine's failure): the first
        attempt's line (:mod:`jackson.experiments.stall_retry`), None if it did not stall.
    stalled : bool
        The retry stalled too: no verdict on the robot; the run is reported apart.
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
    stall_retried: str | None = None
    stalled: bool = False

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
class CaseDetection:
    """How the monitored runs of one case met its fault: detected, isolated, and how soon.

    Attributes
    ----------
    detected, isolated : int
        Runs where the expected sensor left its healthy state after the onset, and where it was
        the first (alone) to do so.
    detection_rate, isolation_rate : float
        The same as fractions of the case's trials.
    isolated_by_exclusion : int
        Runs whose first sensor excluded after the onset is the expected one.
    first_sensors : dict
        How often each sensor (or sensors at one instant, ``imu+encoder_left``) was the first to
        leave its healthy state after the onset (``none``: no sensor did).
    time_to_detect_s : list of float
        Each detection's time from the onset [s].
    time_to_detect_median_s, time_to_detect_max_s : float or None
        Their median and largest [s] (None: no detection).
    """

    detected: int
    detection_rate: float
    isolated: int
    isolation_rate: float
    isolated_by_exclusion: int
    first_sensors: dict[str, int]
    time_to_detect_s: list[float]
    time_to_detect_median_s: float | None
    time_to_detect_max_s: float | None


@dataclass(frozen=True)
class CaseExclusion:
    """How the monitored runs of one case excluded sensors after the onset.

    Attributes
    ----------
    time_to_exclude_median_s, time_to_exclude_max_s : float or None
        The median and largest time from the onset to the expected sensor's exclusion [s].
    excluded : int
        Runs that excluded the expected sensor.
    exclusion_rate : float
        The same as a fraction of the case's trials.
    others_excluded : dict
        In how many runs each other sensor was excluded after the onset.
    """

    time_to_exclude_median_s: float | None
    time_to_exclude_max_s: float | None
    excluded: int
    exclusion_rate: float
    others_excluded: dict[str, int]


@dataclass(frozen=True)
class CaseSummary:
    """The figures of one case (:func:`summarise_case`); rates are fractions of its trials.

    Attributes
    ----------
    name, mission, fault, sensor : str
        The case (:class:`FaultCase`).
    trials : int
        Its monitored runs.
    detection : CaseDetection
        Detected, isolated, and how soon.
    exclusion : CaseExclusion
        Which sensors were excluded, and how soon.
    pre_onset_alarms : int
        Transitions to ``suspect`` or ``excluded`` before the onset in the monitored runs
        (false alarms while the robot was healthy).
    spikes, gated : int
        Gyro spikes injected and samples gated, summed over the monitored runs (a spike case
        catches every spike when they are equal).
    with_monitor, without_monitor : Outcome
        How the runs ended, and their closures.
    met_target : bool
        The case met its target (``missed`` is empty).
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
    detection: CaseDetection
    exclusion: CaseExclusion
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

    def as_json(self) -> dict[str, Any]:
        """``summary.json``'s entry of the case: one flat mapping, the detection's and the
        exclusion's figures in line with the rest (in the order of the table)."""
        out: dict[str, Any] = {}
        for key, value in dataclasses.asdict(self).items():
            if key in ("detection", "exclusion"):
                out.update(value)
            else:
                out[key] = value
        return out


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
