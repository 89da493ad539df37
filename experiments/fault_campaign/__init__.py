"""``jackson campaign faults``: the sensor health monitor against the twin's sensor faults.

Each case (:data:`CASES`) injects one sensor fault (:mod:`jackson.sim.faults`) at
:data:`ONSET_S` of MCU time into a figure-eight (or a square) on the twin, or a LiDAR fault at
:data:`MAZE_ONSET_S` into the maze's navigation trial (:mod:`jackson.experiments.stage3`: the
default ``jackson run maze``, amcl on a map made once by a mapping run before the trials), and
names the sensor the health monitor (:mod:`jackson.host.health`) should blame. Every
trial of a case runs twice on the same seed: with the monitor (the host configuration as it is) and
without it (the same configuration with ``health.enabled: false``: the paper's filter). Clean runs
of both missions, without any fault and with the monitor, measure its false alarms; with maze cases,
as many clean maze runs as there are trials join them (the only runs where the LiDAR is judged).
Trials run in worker processes as :mod:`jackson.experiments.campaign` runs them; each keeps its
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

from jackson.experiments.fault_campaign.analysis import (
    detect as detect,
)
from jackson.experiments.fault_campaign.analysis import (
    false_alarm_rate as false_alarm_rate,
)
from jackson.experiments.fault_campaign.analysis import (
    load_run as load_run,
)
from jackson.experiments.fault_campaign.analysis import (
    nav_outcome as nav_outcome,
)
from jackson.experiments.fault_campaign.analysis import (
    outcome as outcome,
)
from jackson.experiments.fault_campaign.analysis import (
    poisson_upper as poisson_upper,
)
from jackson.experiments.fault_campaign.analysis import (
    stat as stat,
)
from jackson.experiments.fault_campaign.analysis import (
    summarise_case as summarise_case,
)
from jackson.experiments.fault_campaign.analysis import (
    summarise_clean as summarise_clean,
)
from jackson.experiments.fault_campaign.analysis import (
    transitions_of as transitions_of,
)
from jackson.experiments.fault_campaign.cases import (
    BLIND_CASES as BLIND_CASES,
)
from jackson.experiments.fault_campaign.cases import (
    BLIND_LIMIT_M as BLIND_LIMIT_M,
)
from jackson.experiments.fault_campaign.cases import (
    CASE_NAMES as CASE_NAMES,
)
from jackson.experiments.fault_campaign.cases import (
    CASES as CASES,
)
from jackson.experiments.fault_campaign.cases import (
    CONFIDENCE as CONFIDENCE,
)
from jackson.experiments.fault_campaign.cases import (
    DETECTION_TARGET as DETECTION_TARGET,
)
from jackson.experiments.fault_campaign.cases import (
    LIDAR as LIDAR,
)
from jackson.experiments.fault_campaign.cases import (
    MAZE_ONSET_S as MAZE_ONSET_S,
)
from jackson.experiments.fault_campaign.cases import (
    MONITOR_YAML as MONITOR_YAML,
)
from jackson.experiments.fault_campaign.cases import (
    NO_MONITOR_YAML as NO_MONITOR_YAML,
)
from jackson.experiments.fault_campaign.cases import (
    ONSET_S as ONSET_S,
)
from jackson.experiments.fault_campaign.cases import (
    PLANNED_DRIVE_S as PLANNED_DRIVE_S,
)
from jackson.experiments.fault_campaign.cases import (
    SENSORS as SENSORS,
)
from jackson.experiments.fault_campaign.cases import (
    SLIP as SLIP,
)
from jackson.experiments.fault_campaign.cases import (
    UNHEALTHY as UNHEALTHY,
)
from jackson.experiments.fault_campaign.cases import (
    WORLDS as WORLDS,
)
from jackson.experiments.fault_campaign.cases import (
    FaultCampaignError as FaultCampaignError,
)
from jackson.experiments.fault_campaign.cases import (
    FaultCase as FaultCase,
)
from jackson.experiments.fault_campaign.records import (
    CaseDetection as CaseDetection,
)
from jackson.experiments.fault_campaign.records import (
    CaseExclusion as CaseExclusion,
)
from jackson.experiments.fault_campaign.records import (
    CaseSummary as CaseSummary,
)
from jackson.experiments.fault_campaign.records import (
    Detection as Detection,
)
from jackson.experiments.fault_campaign.records import (
    FalseAlarms as FalseAlarms,
)
from jackson.experiments.fault_campaign.records import (
    NavOutcome as NavOutcome,
)
from jackson.experiments.fault_campaign.records import (
    Outcome as Outcome,
)
from jackson.experiments.fault_campaign.records import (
    Rate as Rate,
)
from jackson.experiments.fault_campaign.records import (
    RunRecord as RunRecord,
)
from jackson.experiments.fault_campaign.records import (
    Stat as Stat,
)
from jackson.experiments.fault_campaign.records import (
    Transition as Transition,
)
from jackson.experiments.fault_campaign.report import (
    plot_faults as plot_faults,
)
from jackson.experiments.fault_campaign.report import (
    summary_markdown as summary_markdown,
)
from jackson.experiments.fault_campaign.report import (
    write_report as write_report,
)
from jackson.experiments.fault_campaign.run import (
    Job as Job,
)
from jackson.experiments.fault_campaign.run import (
    clean_plan as clean_plan,
)
from jackson.experiments.fault_campaign.run import (
    describe as describe,
)
from jackson.experiments.fault_campaign.run import (
    map_maze as map_maze,
)
from jackson.experiments.fault_campaign.run import (
    plan_jobs as plan_jobs,
)
from jackson.experiments.fault_campaign.run import (
    run_fault_campaign as run_fault_campaign,
)
from jackson.experiments.fault_campaign.run import (
    run_job as run_job,
)
from jackson.experiments.fault_campaign.run import (
    summarise as summarise,
)
from jackson.experiments.fault_campaign.run import (
    write_host_configs as write_host_configs,
)
