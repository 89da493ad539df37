"""A patrol: one navigation service serving goal after goal on one floor, as in service.

``jackson patrol`` runs the processes users run: the twin (``jackson sim``, lockstep, with its
ground truth written as it goes) and the daemon (``jackson daemon`` in service mode, recording
with its disk budget), and drives the daemon through its control socket as an operator's
client would, for a number of goals or of robot-hours (the soak):

- **goals**: random free points of the floor with 0.5 m of clearance, reachable from the start,
  at least 2.5 m from where the robot is and 1 m from every drop spot; reached when the service
  says so *and* the ground truth ends within the goal tolerance (0.25 m);
- **unreachable goals**: the floor's enclosed points (``patrol.unreachable`` of the world file),
  which the service must refuse at once, with its reason;
- **cancels**: a goal cancelled after 3-10 s of MCU time: the goal must end ``canceled`` and the
  robot come to rest;
- **preemptions**: a second goal 3-10 s after the first: the first ends ``canceled``
  (preempted), the second is reached;
- **teleop bursts**: velocity commands (a turn on the spot) while a goal is active: the goal
  ends ``aborted`` (teleop took over), navigation does not resume, the service goes idle;
- **obstacles**: cylinders dropped at random MCU times on the floor's drop spots
  (``patrol.drop_spots``), each taken away again after 20-90 s (the world's timed triggers).

It samples both processes' resident memory and CPU, the MCU time and the recording folder's size
every ``sample_s`` of wall time (``soak.csv``), and writes every goal (``patrol.csv``), the
summary (``summary.json``) and a plot (``patrol.png``). The daemon must never exit: a patrol
whose daemon dies stops there and says so.

One idea per module: what a patrol is and what it records (:mod:`.records`), the floor's goals
and drops (:mod:`.floor`), the processes it watches (:mod:`.processes`), the loop that drives the
service (:mod:`.loop`) and its summary and plot (:mod:`.report`).
"""

from __future__ import annotations

from jackson.experiments.patrol.floor import (
    CLEARANCE_M,
    DROP_KEEPOUT_M,
    DROP_RADIUS_M,
    MIN_TRIP_M,
    drops,
    goal_cells,
    patrol_world,
)
from jackson.experiments.patrol.loop import (
    GOAL_TOLERANCE_M,
    READY_S,
    REST_M,
    STALL_S,
    WALL_PER_GOAL_S,
    Patrol,
)
from jackson.experiments.patrol.processes import TruthTail, rss_mb
from jackson.experiments.patrol.records import (
    GoalOutcome,
    PatrolError,
    PatrolResult,
    PatrolSpec,
    Sample,
)
from jackson.experiments.patrol.report import plot_patrol, summarise

__all__ = [
    "CLEARANCE_M",
    "DROP_KEEPOUT_M",
    "DROP_RADIUS_M",
    "GOAL_TOLERANCE_M",
    "MIN_TRIP_M",
    "READY_S",
    "REST_M",
    "STALL_S",
    "WALL_PER_GOAL_S",
    "GoalOutcome",
    "Patrol",
    "PatrolError",
    "PatrolResult",
    "PatrolSpec",
    "Sample",
    "TruthTail",
    "drops",
    "goal_cells",
    "patrol_world",
    "plot_patrol",
    "rss_mb",
    "summarise",
]
