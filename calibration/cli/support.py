"""What the procedures' commands share: the config, where runs come from and go to, answers
asked on standard input, measured values per run, and writing the result into the host YAML."""

from __future__ import annotations

import argparse
import dataclasses
import datetime as dt
import math
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from jackson.calibration.yaml_update import Updates, update_config
from jackson.host.config import DEFAULT_CONFIG, HostConfig, load_config

if TYPE_CHECKING:  # numpy, scipy and the host's daemon load when a procedure runs
    from jackson.calibration import procedures as proc
    from jackson.calibration import runs


from jackson.calibration.cli.errors import CalibrateCliError


def host_config(args: argparse.Namespace) -> HostConfig:
    path = args.config or args.write or DEFAULT_CONFIG
    cfg = load_config(path)
    if getattr(args, "i2c", None):
        cfg = dataclasses.replace(cfg, pca9685=dataclasses.replace(cfg.pca9685, bus=args.i2c))
    return cfg


def run_source(args: argparse.Namespace) -> str:
    port = getattr(args, "port", None)
    if port and args.runs:
        raise CalibrateCliError("give either --port (record) or --runs (recorded), not both")
    if not port and not args.runs:
        raise CalibrateCliError("give --port PORT to record, or --runs DIR... to use recordings")
    return "record" if port else "runs"


def open_link(args: argparse.Namespace, cfg: HostConfig) -> runs.Link:
    from rich.console import Console

    from jackson.calibration import runs

    return runs.Link(args.port, cfg, Console(stderr=True))


def out_folder(args: argparse.Namespace, cfg: HostConfig) -> Path:
    if args.out is not None:
        return Path(args.out)
    stamp = dt.datetime.now().strftime("%Y%m%d-%H%M%S")
    return Path(cfg.recording_folder) / f"{stamp}-calibrate-{args.procedure}"


def ask_float(prompt: str, default: float | None = None) -> float:
    """A number from standard input (Enter takes the default)."""
    while True:
        try:
            text = input(prompt).strip()
        except EOFError as exc:
            raise CalibrateCliError(
                "no answer on standard input: give the value as an option"
            ) from exc
        if not text and default is not None:
            return default
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        if math.isfinite(value):
            return value
        print("  a number, please", file=sys.stderr)


def per_run(values: Sequence[float] | None, n: int, option: str) -> list[float] | None:
    if values is None:
        return None
    if len(values) == 1:
        return list(values) * n
    if len(values) != n:
        raise CalibrateCliError(
            f"{option}: give one value, or one per run ({n}), not {len(values)}"
        )
    return list(values)


def measured(
    data: Sequence[proc.RunData], given: list[float] | None, note: str, what: str, option: str
) -> list[float]:
    """Each run's measured value: from the command line, else from the note its recording
    kept (the value the user typed in during the run)."""
    if given is not None:
        return given
    missing = next((r for r in data if note not in r.notes), None)
    if missing is not None:
        raise CalibrateCliError(f"run {missing.name}: no {what}: give {option}")
    return [float(r.notes[note]) for r in data]


def load_runs(folders: Sequence[Path]) -> list[proc.RunData]:
    from jackson.calibration import procedures as proc
    from jackson.calibration import runs

    data = [runs.load_run(f) for f in folders]
    for run in data:
        proc.check_frames(run)
    return data


def truth_references(
    folders: Sequence[Path], data: Sequence[proc.RunData], path: Path
) -> list[proc.Reference]:
    """Each run's true poses from the twin's ground-truth file (``jackson sim --truth``)."""
    from jackson.calibration import runs

    truth = runs.load_twin_truth(path)
    return [
        runs.truth_reference(run, truth, runs.run_boot_ids(folder))
        for folder, run in zip(folders, data, strict=True)
    ]


def exclusive(args: argparse.Namespace, option: str, dest: str) -> None:
    if args.twin_truth is not None and getattr(args, dest) is not None:
        raise CalibrateCliError(f"give either {option} or --twin-truth, not both")


def check_finite(updates: Updates) -> None:
    """Refuse a result that is not a number: it is neither printed nor written as one."""
    for key, value in updates.items():
        values = value if isinstance(value, list) else [value]
        if any(isinstance(v, float) and not math.isfinite(v) for v in values):
            raise CalibrateCliError(f"{key}: the result is not a number ({value}); nothing written")


def write_updates(args: argparse.Namespace, updates: Updates) -> None:
    check_finite(updates)
    if args.write is None:
        print("(not written: add --write CONFIG to update the host YAML)")
        return
    result = update_config(args.write, updates)
    if result.backup is None:
        print(f"{result.path} already holds these values: not written")
        return
    print(f"wrote {result.path} (backup {result.backup}):")
    for line in result.changes:
        print(f"  {line}")
    if result.diff:
        print(result.diff, end="" if result.diff.endswith("\n") else "\n")


# ------------------------------------------------------------------------- procedures
