"""The ablation: each mechanism switched off alone, in a robot file and host configuration of its
own, and the figures that run gives.

:func:`ablate` checks every patch with the real loaders before anything runs;
:func:`write_ablated` writes the patched documents the ablation's campaigns read.
"""

from __future__ import annotations

import tempfile
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from jackson.common.fields import ConfigError, read_yaml
from jackson.experiments.fidelity.errors import MechanismError
from jackson.experiments.fidelity.mechanisms import Mechanism, deep_merge, dotted
from jackson.experiments.fidelity.verdicts import FigureResult
from jackson.host.config import parse_config
from jackson.sim.config import ROBOTS_DIR, RobotSpec, load_robot, resolve


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
