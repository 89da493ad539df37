"""``jackson campaign fidelity``: the twin against the paper's physical robot, in one report.

Runs the three validation stages on the twin (square and figure-eight campaigns,
:func:`jackson.experiments.campaign.run_campaign`; Stage 3's maze,
:func:`jackson.experiments.stage3.run_stage3_campaign`) and holds every figure the paper gives
for its physical robot beside ours: the 16 Stage 1-2 figures of :data:`FIGURES` (Tables 5-7,
11 and 13) and the Stage 3 outcomes of :data:`STAGE3_FIGURES` (Table 14).

A figure agrees when our mean lies within ``k`` of the paper's SDs of the paper's mean,

    z = (mean_ours - mean_paper) / sd_paper,    |z| <= k,

with k = 1 for Stage 1-2 and k = 2 for Stage 3's t_nav, d_min and path length; and its spread
agrees when ``sd_ours / sd_paper`` lies within 0.5-2 (:data:`SD_RATIO_RANGE`: two samples of
ten whose SDs differ by less cannot be told apart by a two-sided F test at 5 %). Only completed
trials enter the statistics; completed / attempted is reported beside them.

:data:`MECHANISMS` lists the twin's imperfections (``sim/robots/jackson_physical.yaml``) and
host settings as plain data, each with the patch that switches it off: a nested mapping
deep-merged (:func:`deep_merge`) into the robot file or the host configuration. The ablation
(``ablation=True``) runs the square and the figure-eight (and the maze for a mechanism marked
``stage3``) once per mechanism with it off, on the full model's seeds, and tabulates what each
figure becomes.

The report folder holds ``square/``, ``figure8/``, ``maze/`` (each a campaign's own folder),
``ablation/<mechanism>/`` (its ``robot.yaml``, ``config.yaml`` and campaigns), and
``fidelity.json`` (every number), ``fidelity.md`` and ``fidelity.png``.
"""

from __future__ import annotations

import dataclasses
import json
import math
import shutil
import sys
import tempfile
import textwrap
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from jackson.common.errors import JacksonError
from jackson.common.fields import ConfigError, read_yaml
from jackson.experiments.campaign import run_campaign
from jackson.experiments.metrics import median_iqr
from jackson.experiments.stage3 import MappingError, run_stage3_campaign
from jackson.host.config import DEFAULT_CONFIG, parse_config
from jackson.host.control.square import SquareConfig
from jackson.sim.config import ROBOTS_DIR, RobotSpec, load_robot, resolve

STAGES = ("square", "figure8", "maze")
"""The campaigns of the report, in the order they run."""

STAGE_NAMES = {"square": "square", "figure8": "figure-eight", "maze": "Stage 3"}
DEFAULT_ROBOT = "jackson_physical"
SD_RATIO_RANGE = (0.5, 2.0)  # our SD over the paper's that passes (F test, n = 10, 5 %)
PNG_DPI = 120  # the overview's 20 panels at 1500 x 1650 pixels
TITLE_CHARS = 48  # a panel's title wraps after this many characters


class FidelityError(JacksonError):
    """A fidelity campaign cannot start: its notes file cannot be read, its docs path is
    unusable."""


class MechanismError(FidelityError):
    """A mechanism's patch does not fit the robot file or the host configuration."""


# ---------------------------------------------------------------------- the paper's figures


@dataclass(frozen=True)
class Figure:
    """One of the paper's figures for its physical robot, and the run metric we hold to it.

    Attributes
    ----------
    mission : str
        The campaign that gives it: ``square``, ``figure8`` or ``maze``.
    key : str
        The per-trial metric (a key of the campaign's ``runs.json``).
    label : str
        Name with its unit, as the tables print it (``"EKF closure [cm]"``).
    table : str
        The paper's table (``"T5"``).
    paper_mean, paper_sd : float
        The physical robot's mean and SD.
    decimals : int
        Digits after the point in the tables.
    within_sd : float
        Our mean agrees when within this many of the paper's SDs of its mean.
    isaac : str
        The paper's Isaac Sim twin, as text ("" where not quoted).
    """

    mission: str
    key: str
    label: str
    table: str
    paper_mean: float
    paper_sd: float
    decimals: int = 2
    within_sd: float = 1.0
    isaac: str = ""

    @property
    def stage(self) -> str:
        """``square``, ``figure-eight`` or ``Stage 3``."""
        return STAGE_NAMES[self.mission]

    @property
    def heading(self) -> str:
        """``"EKF closure [cm] (T5)"``."""
        return f"{self.label} ({self.table})"

    def number(self, value: float) -> str:
        """``value`` with this figure's decimals."""
        return f"{value:.{self.decimals}f}"

    @property
    def paper_text(self) -> str:
        """``"1.18 ± 0.96"``."""
        return f"{self.number(self.paper_mean)} ± {self.number(self.paper_sd)}"


FIGURES: tuple[Figure, ...] = (
    Figure("square", "ekf_closure_cm", "EKF closure [cm]", "T5", 1.18, 0.96),
    Figure("square", "ekf_final_heading_deg", "EKF final heading error [deg]", "T5", 1.41, 1.02),
    Figure("square", "ekf_cross_track_rmse_cm",
           "EKF RMSE to the nominal square [cm]", "T5", 2.46, 0.36),
    Figure("square", "duration_s", "duration [s]", "T11", 47.52, 0.26),
    Figure("square", "odom_closure_cm", "raw-odometry closure [cm]", "T5", 36.35, 13.90),
    Figure("square", "odom_final_heading_deg",
           "raw-odometry final heading error [deg]", "T5", 25.97, 10.21),
    Figure("square", "odom_cross_track_rmse_cm",
           "raw-odometry RMSE to the nominal square [cm]", "T5", 14.75, 4.09),
    Figure("figure8", "gt_loop_diameter_ccw_m",
           "CCW loop diameter (floor) [m]", "T6", 1.0795, 0.0167, decimals=4),
    Figure("figure8", "gt_loop_diameter_cw_m",
           "CW loop diameter (floor) [m]", "T6", 1.1280, 0.0322, decimals=4),
    Figure("figure8", "gt_closure_cm", "closure, floor (ground truth) [cm]", "T6", 11.59, 3.14),
    Figure("figure8", "ekf_closure_cm", "EKF closure [cm]", "T6", 6.90, 0.73),
    Figure("figure8", "odom_closure_cm", "raw-odometry closure [cm]", "T7", 207.0, 26.0),
    Figure("figure8", "optimism_gap_cm", "optimism gap (floor - EKF) [cm]", "T13", 4.69, 2.82),
    Figure("figure8", "ekf_final_heading_deg",
           "EKF final heading residual [deg]", "T6", 1.42, 0.22),
    Figure("figure8", "duration_s", "duration [s]", "T6", 96.43, 2.07),
    Figure("figure8", "ekf_cross_track_rmse_cm", "EKF cross-track RMSE [cm]", "T6", 9.48, 1.39),
)  # fmt: skip
"""The 16 Stage 1-2 figures of the physical robot (REFERENCE.md), in the order of the table."""

STAGE3_FIGURES: tuple[Figure, ...] = (
    Figure("maze", "t_nav_s", "t_nav [s]", "T14", 22.405, 0.816,
           decimals=3, within_sd=2.0, isaac="median 13.317"),
    Figure("maze", "d_min_m", "d_min, truth [m]", "T14", 0.122, 0.007,
           decimals=3, within_sd=2.0, isaac="0.074 ± 0.016"),
    Figure("maze", "d_min_estimate_m", "d_min, the robot's own estimate [m]", "T14", 0.122,
           0.007, decimals=3, within_sd=2.0),
    Figure("maze", "path_length_m", "path length [m]", "T14", 1.958, 0.014,
           decimals=3, within_sd=2.0, isaac="1.888 ± 0.039"),
)  # fmt: skip
"""Stage 3's continuous outcomes on the physical robot (Table 14; the Isaac twin beside). The
physical robot's d_min is of its own AMCL estimate (it had no ground truth), the Isaac twin's of
its ground truth: ours is given both ways."""

CHECKS: tuple[Figure, ...] = (
    Figure("square", "ekf_path_m", "EKF path length [m]", "T5", 4.133, 0.020, decimals=3),
    Figure("figure8", "ekf_path_m", "EKF path length [m]", "T6", 6.96, 0.11),
    Figure("figure8", "ekf_max_cross_track_cm",
           "EKF largest cross-track deviation [cm]", "T7", 22.52, 3.04),
)  # fmt: skip
"""Further figures of the physical robot that no value of the twin or the configuration was
identified from: the page shows them as checks, outside the count of 16."""

PAPER_STAGE3_SUCCESS = (10, 10)  # goals reached / runs, physical and Isaac alike (T14)
PAPER_STAGE3_CONTACTS = 0


# ---------------------------------------------------------------------- statistics and verdicts


@dataclass(frozen=True)
class FigureResult:
    """Our trials of one figure beside the paper's.

    Attributes
    ----------
    figure : Figure
        The paper's figure.
    attempted, completed : int
        Trials of its campaign run and completed (0 attempted: the campaign was not run).
    values : tuple of float
        The metric of every completed trial that has a finite value.
    """

    figure: Figure
    attempted: int
    completed: int
    values: tuple[float, ...]

    @property
    def n(self) -> int:
        """Trials in the statistics."""
        return len(self.values)

    @property
    def mean(self) -> float:
        """Our mean (NaN without a value)."""
        return float(np.mean(self.values)) if self.values else math.nan

    @property
    def sd(self) -> float:
        """Our sample SD, ddof = 1 (NaN below two values)."""
        return float(np.std(self.values, ddof=1)) if self.n > 1 else math.nan

    @property
    def z(self) -> float:
        """``(mean - paper_mean) / paper_sd``: our mean in the paper's SDs from its mean."""
        return (self.mean - self.figure.paper_mean) / self.figure.paper_sd

    @property
    def within(self) -> bool | None:
        """``|z| <= within_sd``; None without a value."""
        return None if not self.values else abs(self.z) <= self.figure.within_sd

    @property
    def sd_ratio(self) -> float:
        """Our SD over the paper's (NaN below two values)."""
        return self.sd / self.figure.paper_sd

    @property
    def sd_ok(self) -> bool | None:
        """The SD ratio within :data:`SD_RATIO_RANGE`; None below two values."""
        lo, hi = SD_RATIO_RANGE
        return None if not math.isfinite(self.sd_ratio) else lo <= self.sd_ratio <= hi

    @property
    def quartiles(self) -> tuple[float, float, float]:
        """Median, first and third quartile (NaN without a value)."""
        if not self.values:
            return math.nan, math.nan, math.nan
        q = median_iqr(self.values)  # the paper's Stage 3 summary, as every campaign's
        return q.median, q.q1, q.q3

    @property
    def missing(self) -> str | None:
        """Why there is no statistic: ``"not run"``, ``"no completed trial (0/10)"``; None when
        there is one."""
        if self.values:
            return None
        if self.attempted == 0:
            return "not run"
        if self.completed == 0:
            return f"no completed trial (0/{self.attempted})"
        return f"no value in {self.completed} completed trials"

    def as_json(self) -> dict[str, Any]:
        """Every number, NaN as null."""
        f = self.figure
        med, q1, q3 = self.quartiles
        return {
            "mission": f.mission,
            "key": f.key,
            "label": f.label,
            "table": f.table,
            "paper": {"mean": f.paper_mean, "sd": f.paper_sd, "isaac": f.isaac or None},
            "within_sd": f.within_sd,
            "attempted": self.attempted,
            "completed": self.completed,
            "n": self.n,
            "mean": _finite(self.mean),
            "sd": _finite(self.sd),
            "median": _finite(med),
            "q1": _finite(q1),
            "q3": _finite(q3),
            "z": _finite(self.z),
            "within": self.within,
            "sd_ratio": _finite(self.sd_ratio),
            "sd_ok": self.sd_ok,
            "missing": self.missing,
            "values": list(self.values),
        }


def _finite(value: float) -> float | None:
    return value if math.isfinite(value) else None


def figure_result(figure: Figure, results: Sequence[Mapping[str, Any]]) -> FigureResult:
    """Our trials of ``figure``: the completed ones with a finite value enter the statistics.

    Parameters
    ----------
    figure : Figure
        The paper's figure.
    results : sequence of mapping
        Every attempted trial of the figure's campaign (empty: not run).

    Returns
    -------
    FigureResult
    """
    done = [r for r in results if r.get("completed")]
    values = []
    for r in done:
        v = r.get(figure.key)
        if isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v):
            values.append(float(v))
    return FigureResult(figure, len(results), len(done), tuple(values))


@dataclass(frozen=True)
class Agreement:
    """How many figures agree with the paper.

    Attributes
    ----------
    within : int
        Figures whose mean is within the paper's band.
    within_and_sd : int
        Of those, figures whose SD is also within :data:`SD_RATIO_RANGE` of the paper's.
    total : int
        Figures counted.
    """

    within: int
    within_and_sd: int
    total: int


def agreement(rows: Sequence[FigureResult]) -> Agreement:
    """Count the figures within the paper's band, and those with a fitting SD too.

    Parameters
    ----------
    rows : sequence of FigureResult
        The figures (a figure without a value counts as outside).

    Returns
    -------
    Agreement
    """
    within = [r for r in rows if r.within]
    return Agreement(len(within), sum(1 for r in within if r.sd_ok), len(rows))


@dataclass(frozen=True)
class NavOutcome:
    """Stage 3's discrete outcomes: goals reached and contacts over every attempted run.

    Attributes
    ----------
    attempted, completed : int
        Navigation runs started and successful (P_success = completed / attempted).
    contacts : int
        The twin's contacts over all runs (C_count).
    failure : str or None
        Why no navigation ran (the mapping run failed), None otherwise.
    """

    attempted: int
    completed: int
    contacts: int
    failure: str | None = None

    @property
    def success_within(self) -> bool:
        """Every attempted run reached the goal, as the paper's 10/10."""
        return self.attempted > 0 and self.completed == self.attempted

    @property
    def contacts_within(self) -> bool:
        """No contact, as the paper's 0."""
        return self.attempted > 0 and self.contacts == PAPER_STAGE3_CONTACTS


def nav_outcome(results: Sequence[Mapping[str, Any]], failure: str | None = None) -> NavOutcome:
    """Stage 3's success and contacts from the maze campaign's runs.

    Parameters
    ----------
    results : sequence of mapping
        Every attempted navigation run.
    failure : str or None
        Why none ran.

    Returns
    -------
    NavOutcome
    """
    done = sum(1 for r in results if r.get("completed"))
    contacts = sum(int(r.get("collisions", 0) or 0) for r in results)
    return NavOutcome(len(results), done, contacts, failure)


# ---------------------------------------------------------------------- mechanisms and patches


@dataclass(frozen=True)
class Mechanism:
    """A mechanism of the twin (its robot file) or of the host configuration, and the patch
    that switches it off.

    Attributes
    ----------
    name : str
        Identifier, also the ablation's folder name (``tyre_creep_scrub``).
    what : str
        What it does on the robot and which of the paper's figures it reproduces.
    source : str
        Where its value comes from (measured, fitted to which figures).
    robot_patch, config_patch : mapping
        Nested fields deep-merged (:func:`deep_merge`) into the robot YAML and the host
        configuration YAML to switch the mechanism off.
    stage3 : bool
        The ablation runs the maze with it off too.
    """

    name: str
    what: str
    source: str
    robot_patch: Mapping[str, Any] = field(default_factory=dict)
    config_patch: Mapping[str, Any] = field(default_factory=dict)
    stage3: bool = False


BRINGUP_CONFIG = DEFAULT_CONFIG.with_name("jackson_bringup.yaml")
"""The host configuration the campaign runs by default: the paper's robot commanded as its
bringup drove it (the deceleration limits and Stage 3's top speed below)."""


SQUARE_BRINGUP_FIELDS = ("a_dec_m_s2", "heading_tolerance_rad", "settle_rad_s", "w_max_rad_s")
"""The square controller's fields the bringup sets; ``square_controller`` off: their defaults."""

MECHANISMS: tuple[Mechanism, ...] = (
    Mechanism(
        "tyre_creep_scrub",
        "tyre creep and yaw scrub: the robot turns slower than its encoders say, more in wide "
        "arcs than on the spot (a wider effective track)",
        "fitted: the square's raw-odometry heading and closure, the loop diameters, the durations",
        robot_patch={"tyre": {"longitudinal_compliance": 0.0, "scrub_arm_m": 0.0}},
    ),
    Mechanism(
        "caster_drag",
        "a draggy caster: a force against forward motion, none on the spot; it slows the "
        "figure-eight's 0.08 m/s more than the square's 0.15 m/s",
        "fitted: the square's and the figure-eight's durations together",
        robot_patch={"caster_rolling_coeff": 0.0},
        stage3=True,
    ),
    Mechanism(
        "left_drive_weaker",
        "the left drive weaker than the right: CCW loops narrower than CW ones",
        "fitted: the CCW / CW loop diameters (T6)",
        robot_patch={"motor": {"gain": {"left": 1.0}}},
    ),
    Mechanism(
        "gyro_scale",
        "the gyro reads low: each loop the EKF closes at 2 pi turns further on the floor",
        "fitted: the optimism gap (T13); within the MPU-6050's ±3 % sensitivity tolerance",
        robot_patch={"imu": {"yaw_scale": 1.0}},
    ),
    Mechanism(
        "gyro_bias_drift",
        "the gyro bias wanders (a random walk) after the host's start-up bias window",
        "fitted: the SDs of the figure-eight's floor closure and optimism gap",
        robot_patch={"imu": {"gyro_bias_drift_rad_s_per_sqrt_s": 0.0}},
    ),
    Mechanism(
        "actuation_latency",
        "a delay between a command and the motors",
        "measured on the physical robot: the paper's command-transport latency, about 50 ms",
        robot_patch={"actuation_latency_s": 0.0},
        stage3=True,
    ),
    Mechanism(
        "trial_variation",
        "per-trial draws of supply voltage, wheel radii, encoder scales, turn-on gyro bias "
        "and floor friction",
        "fitted: the SDs of every figure (docs/fidelity.md, 'Spreads')",
        robot_patch={
            "variation": {
                "battery_v_sigma": 0.0,
                "wheel_radius_sigma": 0.0,
                "encoder_scale_sigma": 0.0,
                "gyro_bias_sigma_rad_s": 0.0,
                "floor_mu_sigma": 0.0,
            }
        },
    ),
    Mechanism(
        "deceleration_limits",
        "the robot's commands slow down at 0.10 m/s^2 and 1.0 rad/s^2 at most (the host's "
        "limiter, host/config/jackson_bringup.yaml): it stops, and reverses its turn between "
        "the figure-eight's loops, no faster; a finished mission's stop is ramped the same way",
        "the paper's 'conservative physical motor acceleration limits' (Sec. 2.2.3, "
        "Discussion), values not published: 0.10 m/s^2 identified from the figure-eight's EKF "
        "closure, 1.0 rad/s^2 from its final heading residual (T6)",
        config_patch={"limits": {"max_decel_m_s2": 1.0, "max_alpha_decel_rad_s2": 6.0}},
        stage3=True,
    ),
    Mechanism(
        "square_controller",
        "the square's waypoint controller as the paper's bringup ran it (host config square:): "
        "it plans its stops at the robot's 0.10 m/s^2, ends a turn within 0.03 rad (1.7 deg) "
        "without waiting for it to settle, and turns at up to 0.55 rad/s",
        "the paper's 'explicit velocity deceleration bounds and closed-loop final heading "
        "alignment' (Sec. 3.1), values not published: the tolerance identified from the "
        "square's EKF final heading error (T5), the turn rate from its duration (T11)",
        config_patch={"square": {k: getattr(SquareConfig(), k) for k in SQUARE_BRINGUP_FIELDS}},
    ),
    Mechanism(
        "navigation_top_speed",
        "Stage 3's local planner drives at 0.10 m/s at most (navigation.max_vel_x_m_s, "
        "Nav2's max_vel_x); off, it drives up to the limiter's 0.30 m/s",
        "not published: identified from the physical t_nav (22.4 s over 1.958 m, T14)",
        config_patch={"navigation": {"max_vel_x_m_s": None}},
        stage3=True,
    ),
)
"""The mechanisms of ``jackson_physical`` and the host, each with the patch that switches it
off (docs/fidelity.md, "What the robot file holds"). Plain data: append more."""


def deep_merge(base: Mapping[str, Any], patch: Mapping[str, Any]) -> dict[str, Any]:
    """``base`` with ``patch`` merged in: mappings merged key by key, anything else replaced.

    Parameters
    ----------
    base : mapping
        A YAML document (neither argument is changed).
    patch : mapping
        The fields to set, nested as in ``base``.

    Returns
    -------
    dict
        A new document.
    """
    out = dict(base)
    for key, value in patch.items():
        old = out.get(key)
        if isinstance(value, Mapping) and isinstance(old, Mapping):
            out[key] = deep_merge(old, value)
        else:
            out[key] = value
    return out


def dotted(patch: Mapping[str, Any], doc: Mapping[str, Any] | None = None) -> list[str]:
    """A patch as one ``field.sub = value`` per field; with ``doc``, the value it replaces too.

    Parameters
    ----------
    patch : mapping
        A nested patch.
    doc : mapping or None
        The document it patches: each line reads ``field.sub: old -> new`` (``old`` is
        ``default`` for a field the document leaves to the loader's default).

    Returns
    -------
    list of str
        E.g. ``["tyre.scrub_arm_m = 0.0"]``, or ``["tyre.scrub_arm_m: 0.0058 -> 0.0"]``.
    """

    def lines(p: Mapping[str, Any], d: Any, prefix: str) -> list[str]:
        out = []
        for key, value in p.items():
            old = d.get(key, "default") if isinstance(d, Mapping) else "default"
            if isinstance(value, Mapping):
                out += lines(value, old, f"{prefix}{key}.")
            elif doc is None:
                out.append(f"{prefix}{key} = {value}")
            else:
                out.append(f"{prefix}{key}: {old} -> {value}")
        return out

    return lines(patch, doc, "")


def robot_file(robot: str) -> Path:
    """The YAML file of a robot name (``jackson_physical``) or path, as ``load_robot`` finds it.

    Raises
    ------
    ConfigError
        No such file nor bundled robot.
    """
    return resolve(robot, ROBOTS_DIR, "robot")


@dataclass(frozen=True)
class Ablated:
    """A mechanism switched off: the robot file and host configuration to run.

    Attributes
    ----------
    mechanism : Mechanism
        The mechanism.
    robot, config : dict
        The robot YAML and host configuration YAML with the mechanism off.
    robot_name : str
        The robot file's name (``jackson_physical.yaml``).
    """

    mechanism: Mechanism
    robot: dict[str, Any]
    config: dict[str, Any]
    robot_name: str


def ablate(
    mechanisms: Sequence[Mechanism],
    robot: str,
    config: Path | None = None,
    inactive: list[str] | None = None,
) -> list[Ablated]:
    """Every mechanism's patched robot file and host configuration, checked by the real loaders.

    Parameters
    ----------
    mechanisms : sequence of Mechanism
        The mechanisms to switch off, one at a time.
    robot : str
        The robot name or YAML path the campaigns run.
    config : Path or None
        The host configuration YAML (None: the packaged defaults, an empty document).
    inactive : list of str or None
        Where to put the names of mechanisms this robot and configuration already lack
        (switching them off changes nothing); None: such a mechanism is an error.

    Returns
    -------
    list of Ablated

    Raises
    ------
    MechanismError
        A name repeats or is no folder name, a patch names a field the loader refuses or
        gives it a value it refuses, or (without ``inactive``) a mechanism switches nothing
        off in this robot and configuration.
    """
    path = robot_file(robot)
    _, robot_doc = read_yaml(path, "robot")
    config_doc: Mapping[str, Any] = read_yaml(config, "config")[1] if config is not None else {}
    where = f"config {config.name}" if config is not None else "config (the defaults)"
    base_robot = load_robot(path)
    base_config = parse_config(config_doc, where)
    out = []
    seen: set[str] = set()
    for m in mechanisms:
        if not m.name or m.name in seen or not m.name.replace("_", "").isalnum():
            raise MechanismError(
                f"mechanism {m.name!r}: a name must be unique and of letters, digits and _"
            )
        seen.add(m.name)
        if not m.robot_patch and not m.config_patch:
            raise MechanismError(f"mechanism {m.name}: its patch is empty")
        robot_off = deep_merge(robot_doc, m.robot_patch)
        config_off = deep_merge(config_doc, m.config_patch)
        try:
            spec = _load_robot_doc(robot_off, path.name)
            cfg = parse_config(config_off, where)
        except ConfigError as exc:
            raise MechanismError(f"mechanism {m.name}: {exc}") from exc
        if spec == base_robot and cfg == base_config:
            if inactive is not None:
                inactive.append(m.name)
                continue
            raise MechanismError(
                f"mechanism {m.name}: its patch switches nothing off in robot {path.name} and "
                f"{where} ({', '.join(dotted(m.robot_patch) + dotted(m.config_patch)) or 'empty'})"
            )
        out.append(Ablated(m, robot_off, config_off, path.name))
    return out


def _load_robot_doc(doc: Mapping[str, Any], name: str) -> RobotSpec:
    """``load_robot`` of a document not on disk (written under its own file name)."""
    with tempfile.TemporaryDirectory(prefix="jackson-fidelity-") as tmp:
        path = Path(tmp) / name
        path.write_text(yaml.safe_dump(dict(doc), sort_keys=False))
        return load_robot(path)


def write_ablated(folder: Path, ablated: Ablated) -> tuple[Path, Path]:
    """``folder/robot.yaml`` and ``folder/config.yaml`` of a mechanism switched off.

    Parameters
    ----------
    folder : Path
        ``out/ablation/<name>``.
    ablated : Ablated
        The patched documents.

    Returns
    -------
    tuple of Path
        The robot file and the configuration file.
    """
    folder.mkdir(parents=True, exist_ok=True)
    m = ablated.mechanism
    head = f"# {ablated.robot_name} with {m.name} off (jackson campaign fidelity --ablation)\n"
    robot, config = folder / "robot.yaml", folder / "config.yaml"
    robot.write_text(head + yaml.safe_dump(ablated.robot, sort_keys=False))
    config.write_text(head + yaml.safe_dump(ablated.config, sort_keys=False))
    return robot, config


# ---------------------------------------------------------------------- the report


@dataclass(frozen=True)
class AblationColumn:
    """The figures with one mechanism off.

    Attributes
    ----------
    mechanism : Mechanism
        The mechanism switched off.
    figures : tuple of FigureResult
        The 16 Stage 1-2 figures, then Stage 3's three (not run unless ``mechanism.stage3``).
    nav_failure : str or None
        Why its maze campaign ran no navigation (the mapping run failed).
    """

    mechanism: Mechanism
    figures: tuple[FigureResult, ...]
    nav_failure: str | None = None


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
    config: str = ""
    robot_doc: Mapping[str, Any] = field(default_factory=dict)
    config_doc: Mapping[str, Any] = field(default_factory=dict)
    inactive: tuple[str, ...] = ()  # mechanisms this robot and configuration already lack
    checks: tuple[FigureResult, ...] = ()  # CHECKS: shown, not counted

    @property
    def agreement(self) -> Agreement:
        """The Stage 1-2 figures within the paper's band (and with a fitting SD)."""
        return agreement(self.figures)


def assess(
    results: Mapping[str, Sequence[Mapping[str, Any]]], nav_failure: str | None = None
) -> tuple[tuple[FigureResult, ...], tuple[FigureResult, ...], NavOutcome]:
    """Every figure of the report from the campaigns' per-trial results.

    Parameters
    ----------
    results : mapping
        ``{"square": [...], "figure8": [...], "maze": [...]}``, every attempted trial; a
        stage that is missing was not run.
    nav_failure : str or None
        Why the maze campaign ran no navigation (its mapping run failed).

    Returns
    -------
    tuple
        The Stage 1-2 figures, Stage 3's continuous figures, Stage 3's success and contacts.
    """
    figures = tuple(figure_result(f, results.get(f.mission, ())) for f in FIGURES)
    maze = results.get("maze", ())
    stage3 = tuple(figure_result(f, maze) for f in STAGE3_FIGURES)
    return figures, stage3, nav_outcome(maze, nav_failure)


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
) -> str:
    """The ``jackson campaign fidelity`` command that gives the same page again.

    Parameters
    ----------
    trials, seed : int
        As run.
    robot, config, stages, docs, out, ablation, notes
        As run; the defaults are left out, paths shown by :func:`shown`. ``out`` is named
        only without ``docs``.

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
        parts.append("--ablation")
    if notes is not None:
        parts.append(f"--notes {shown(notes)}")
    return " ".join(parts)


# ---------------------------------------------------------------------- markdown


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


def agreement_line(a: Agreement) -> str:
    """``"N of 16 within the paper's mean ± 1 SD; M of them also with an SD within 0.5-2 times
    the paper's"`` (an en dash and a multiplication sign in the text)."""
    lo, hi = SD_RATIO_RANGE
    return (
        f"{a.within} of {a.total} within the paper's mean ± 1 SD; {a.within_and_sd} of them "
        f"also with an SD within {lo:g}\u2013{hi:g}\u00d7 the paper's"
    )


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
    lines = [
        "Each mechanism switched off alone (the patch above), on the full model's seeds; "
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
    lines.append(
        f"| | within ±1 SD (of {len(report.figures)}) | | {report.agreement.within} | "
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
    seeds = _seeds(report.seed, report.trials)
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
        "agreement": {"within": a.within, "within_and_sd": a.within_and_sd, "total": a.total},
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


# ---------------------------------------------------------------------- the figure

WITHIN_COLOUR = "tab:green"
OUTSIDE_COLOUR = "tab:red"
NO_VALUE_COLOUR = "0.6"
BAND_1SD = "0.82"
BAND_2SD = "0.92"


def _marker_colour(row: FigureResult) -> str:
    if row.within is None:
        return NO_VALUE_COLOUR
    return WITHIN_COLOUR if row.within else OUTSIDE_COLOUR


def _panel(ax: Any, row: FigureResult, rng: np.random.Generator) -> None:
    """One figure: the paper's band and mean, our trials (jittered) and our mean ± SD."""
    f = row.figure
    mean, sd = f.paper_mean, f.paper_sd
    if f.within_sd > 1.0:
        k = f.within_sd
        ax.axhspan(mean - k * sd, mean + k * sd, color=BAND_2SD, lw=0, zorder=0)
    ax.axhspan(mean - sd, mean + sd, color=BAND_1SD, lw=0, zorder=1)
    ax.axhline(mean, color="0.3", lw=1.0, zorder=2)
    if row.values:
        x = rng.uniform(-0.22, 0.22, row.n)
        ax.scatter(x, row.values, s=13, color="tab:blue", alpha=0.8, lw=0, zorder=3)
        err = row.sd if math.isfinite(row.sd) else None
        ax.errorbar(
            1.0,
            row.mean,
            yerr=err,
            fmt="s",
            color=OUTSIDE_COLOUR if not row.within else "k",
            ms=5,
            capsize=4,
            lw=1.3,
            zorder=4,
        )
        detail = f"z {row.z:+.2f}"
        if row.sd_ok is not None:
            detail += f", SD \u00d7{row.sd_ratio:.2f}"
    else:
        ax.text(
            0.5,
            0.5,
            row.missing,
            transform=ax.transAxes,
            ha="center",
            va="center",
            fontsize=8,
            color="0.3",
        )
        detail = "no value"
    ax.set_xlim(-0.6, 1.5)
    ax.set_xticks([0.0, 1.0], ["trials", "ours"], fontsize=7)
    ax.tick_params(axis="y", labelsize=7)
    ax.grid(axis="y", alpha=0.25)
    head = textwrap.fill(f"{f.stage}: {f.label}", TITLE_CHARS)
    title = ax.set_title(f"{head}\n({f.table}) {detail}", fontsize=7.5)
    ax.annotate(
        "●",
        xy=(0.0, 0.5),
        xycoords=title,
        xytext=(-3, 0),
        textcoords="offset points",
        ha="right",
        va="center",
        fontsize=11,
        color=_marker_colour(row),
    )


def plot_fidelity(png: Path, report: FidelityReport) -> None:
    """``fidelity.png``: one small panel per figure (16 Stage 1-2, 3 Stage 3) and a legend.

    Each panel: the paper's mean (line) and mean ± SD (grey band; Stage 3 also ± 2 SD, lighter),
    our completed trials as dots (jittered), our mean ± SD as an error bar, and a dot before
    the title: green when our mean is within the paper's band, red outside, grey without a
    value. The title's second line gives z and our SD over the paper's.

    Parameters
    ----------
    png : Path
        The PNG to write.
    report : FidelityReport
        The figures.
    """
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    from jackson.experiments.report import _pyplot

    plt = _pyplot()
    rows = [*report.figures, *report.stage3]
    ncols = 4
    nrows = math.ceil((len(rows) + 1) / ncols)
    fig, axes = plt.subplots(
        nrows, ncols, figsize=(12.5, 2.6 * nrows + 0.6), layout="constrained", squeeze=False
    )
    rng = np.random.default_rng(0)
    flat = list(axes.flat)
    for ax, row in zip(flat, rows, strict=False):
        _panel(ax, row, rng)
    for ax in flat[len(rows) :]:
        ax.axis("off")
    legend = flat[len(rows)]
    handles = [
        Line2D([], [], color="0.3", lw=1.0, label="the paper's mean"),
        Patch(color=BAND_1SD, label="the paper's mean ± 1 SD"),
        Patch(color=BAND_2SD, label="± 2 SD (Stage 3's criterion)"),
        Line2D([], [], marker="o", ls="none", color="tab:blue", ms=4, label="our trials"),
        Line2D([], [], marker="s", color="k", ms=5, label="our mean ± SD (red: outside)"),
        Line2D([], [], marker="o", ls="none", color=WITHIN_COLOUR, ms=7, label="within"),
        Line2D([], [], marker="o", ls="none", color=OUTSIDE_COLOUR, ms=7, label="outside"),
    ]
    legend.legend(handles=handles, loc="upper left", fontsize=8, frameon=False)
    legend.text(
        0.0,
        0.02,
        textwrap.fill(agreement_line(report.agreement), 44),
        transform=legend.transAxes,
        fontsize=8,
        va="bottom",
        wrap=True,
    )
    seeds = _seeds(report.seed, report.trials)
    fig.suptitle(
        f"{report.robot} on the twin against the paper's physical robot: {report.trials} "
        f"trials per stage ({seeds})",
        fontsize=10,
    )
    png.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(png, dpi=PNG_DPI)
    plt.close(fig)


# ---------------------------------------------------------------------- the campaign


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


def _seeds(seed: int, trials: int) -> str:
    return f"seed {seed}" if trials == 1 else f"seeds {seed}-{seed + trials - 1}"


def _trials_text(trials: int, seed: int) -> str:
    """``"1 trial (seed 0)"``, ``"10 trials (seeds 0-9)"``."""
    return f"{trials} trial{'' if trials == 1 else 's'} ({_seeds(seed, trials)})"


def _run_stages(
    stages: Sequence[str],
    trials: int,
    out: Path,
    *,
    label: str,
    seed: int,
    robot: str,
    config: Path | None,
    workers: int,
    cluster: str | None,
    progress: bool,
) -> tuple[dict[str, list[dict[str, Any]]], str | None]:
    """Run ``stages`` into ``out/<stage>``; the per-trial results and why the maze did not
    navigate (its mapping run failed), if so."""
    results: dict[str, list[dict[str, Any]]] = {}
    failure = None
    common: dict[str, Any] = {
        "robot": robot,
        "seed": seed,
        "workers": workers,
        "config": config,
        "progress": progress,
        "cluster": cluster,
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
    notes_text = read_notes(notes) if notes is not None else ""
    docs_png = check_docs(docs) if docs is not None else None
    inactive: list[str] = []
    ablated = ablate(mechanisms, robot, config, inactive) if ablation else []
    robot_doc = dict(read_yaml(robot_file(robot), "robot")[1])
    config_doc = dict(read_yaml(config, "config")[1]) if config is not None else {}
    if cluster is not None:
        out, config = out.absolute(), config.absolute() if config is not None else None
    wall0 = time.perf_counter()
    results, nav_failure = _run_stages(
        stages,
        trials,
        out,
        label="",
        seed=seed,
        robot=robot,
        config=config,
        workers=workers,
        cluster=cluster,
        progress=progress,
    )
    figures, stage3, nav = assess(results, nav_failure)
    columns = []
    for k, a in enumerate(ablated, 1):
        m = a.mechanism
        folder = out / "ablation" / m.name
        robot_off, config_off = write_ablated(folder, a)
        runs = [s for s in stages if s != "maze" or m.stage3]
        off, failure = _run_stages(
            runs,
            trials,
            folder,
            label=f"ablation {k}/{len(ablated)}, {m.name} off: ",
            seed=seed,
            robot=str(robot_off.absolute()),
            config=config_off.absolute(),
            workers=workers,
            cluster=cluster,
            progress=progress,
        )
        off_figures, off_stage3, _ = assess(off, failure)
        columns.append(AblationColumn(m, off_figures + off_stage3, failure))
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
        ablation=tuple(columns),
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
