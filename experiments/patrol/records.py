"""What a patrol is (:class:`PatrolSpec`) and what it records: each step's outcome, each sample
of the processes, and the whole result."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

from jackson.common.errors import JacksonError
from jackson.experiments.patrol.localisation import LocalisationErrors


class PatrolError(JacksonError, RuntimeError):
    """The patrol could not start, or a process it runs died."""


@dataclass(frozen=True)
class PatrolSpec:
    """One patrol.

    Attributes
    ----------
    world : str
        A world with a ``patrol:`` section (name in sim/worlds or a path).
    out : Path
        The patrol's folder.
    seed : int
        Seeds the twin's noise, the goals and the drops.
    goals : int
        Goals to send (all kinds); ignored with ``robot_hours``.
    robot_hours : float or None
        Run until this much MCU time has passed (the soak).
    robot : str
        The twin's robot.
    config : Path or None
        Host configuration (default: the shipped one); its recording folder and budget are
        replaced by the patrol's.
    budget_mb : float
        The recording folder's budget [MB].
    drop_period_s : float
        Mean MCU time between two drops [s].
    mix : tuple of 4 float
        Shares of unreachable goals, cancels, preemptions and teleop bursts.
    sample_s : float
        Wall time between two samples of the processes [s].
    map_yaml : Path or None
        The map the daemon localises and plans on (map_server YAML, in the world's frame: as
        ``jackson map`` builds it from the world's start pose); None: the world's own raster.
    """

    world: str
    out: Path
    seed: int = 0
    goals: int = 70
    robot_hours: float | None = None
    robot: str = "jackson"
    config: Path | None = None
    budget_mb: float = 2000.0
    drop_period_s: float = 120.0
    mix: tuple[float, float, float, float] = (0.08, 0.08, 0.08, 0.05)
    sample_s: float = 20.0
    map_yaml: Path | None = None


@dataclass
class GoalOutcome:
    """One patrol step's outcome (a row of ``patrol.csv``)."""

    step: int
    kind: str  # goal, unreachable, cancel, preempt, teleop
    goal_id: int
    x: float
    y: float
    status: str
    reason: str
    t_sent_s: float  # MCU time when sent (the status before; a preemption's second goal's)
    t_end_s: float  # MCU time it ended
    truth_error_m: float  # truth at the end to the goal (nan for the kinds that do not arrive)
    ok: bool  # what this kind must do, done
    recoveries: int = 0
    path_m: float = math.nan  # the truth's path from sent to ended (reached goals)
    shortest_m: float = math.nan  # the shortest collision-free path between its ends
    path_ratio: float = math.nan  # path_m / shortest_m

    @property
    def answered_s(self) -> float:
        return self.t_end_s - self.t_sent_s


@dataclass
class Sample:
    """A row of ``soak.csv``."""

    wall_s: float
    robot_s: float
    daemon_rss_mb: float
    twin_rss_mb: float
    daemon_cpu_s: float
    twin_cpu_s: float
    disk_mb: float
    goals: int


@dataclass
class PatrolResult:
    """Everything a patrol recorded: its steps, its samples and what the processes said."""

    outcomes: list[GoalOutcome] = field(default_factory=list)
    samples: list[Sample] = field(default_factory=list)
    contacts: int | None = None
    exclusions: list[str] = field(default_factory=list)
    suspicions: int = 0  # health transitions to suspect (braked until the sensor passes again)
    daemon_exit: int | None = None
    failure: str | None = None
    localisation: LocalisationErrors | None = None  # the daemon's pose against the truth
    unread_bags: int = 0  # bags of the daemon's run folders that could not be read
