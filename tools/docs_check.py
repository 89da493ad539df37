"""Check the figures the docs quote against the commands that make them (``make docs-check``).

Reads docs/figures.yaml (its header says what each field means). For every entry: the quote
must be in its doc (whitespace runs count as one space), the doc must name the entry's command,
and an entry quoted again elsewhere (``same_as``) must carry the value of the one it repeats.
Then each distinct command of the entries with a metric (``cheap`` ones; all with ``--all``) is
run once into a temporary folder, and each figure is recomputed from the campaign's
``runs.json``: a figure further than its ``spread`` from the quoted value is a failure. Prints
one line per figure and exits 1 when any failed, 2 on a registry it cannot read.

    .venv/bin/python tools/docs_check.py            # the cheap figures (about 2 minutes)
    .venv/bin/python tools/docs_check.py --all      # every figure
    .venv/bin/python tools/docs_check.py --static   # quotes and commands only (no runs)
"""

from __future__ import annotations

import argparse
import json
import shlex
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

import yaml

ROOT = Path(__file__).resolve().parents[1]
REGISTRY = ROOT / "docs" / "figures.yaml"
JACKSON = str(Path(sys.executable).parent / "jackson")
FIELDS = {
    "name",
    "doc",
    "quote",
    "command",
    "metric",
    "stat",
    "value",
    "spread",
    "cheap",
    "same_as",
}


STATS = {"mean": statistics.fmean, "median": statistics.median, "sd": statistics.stdev}
"""How a figure is made of the runs' values (``stat``)."""


class RegistryError(ValueError):
    """docs/figures.yaml cannot be used: one line naming the entry and the field."""


def _flat(text: str) -> str:
    return " ".join(text.split())


def load(path: Path = REGISTRY) -> list[dict[str, Any]]:
    """The registry's entries, checked for their fields."""
    try:
        entries = yaml.safe_load(path.read_text(encoding="utf-8"))
    except (OSError, yaml.YAMLError) as exc:
        raise RegistryError(f"{path}: cannot read it ({exc})") from exc
    if not isinstance(entries, list):
        raise RegistryError(f"{path}: expected a list of figures")
    names = set()
    for k, e in enumerate(entries):
        where = f"{path.name} entry {k + 1}"
        if not isinstance(e, dict) or not {"name", "doc", "quote", "value"} <= set(e):
            raise RegistryError(f"{where}: needs name, doc, quote and value")
        unknown = set(e) - FIELDS
        if unknown:
            raise RegistryError(f"{where}: unknown field(s) {', '.join(sorted(unknown))}")
        if e["name"] in names:
            raise RegistryError(f"{where}: the name {e['name']!r} is taken")
        names.add(e["name"])
        if "metric" in e and not {"command", "stat", "spread"} <= set(e):
            raise RegistryError(f"{where}: a metric needs command, stat and spread")
        if e.get("stat", "mean") not in STATS:
            raise RegistryError(f"{where}: stat must be one of {', '.join(STATS)}")
    for e in entries:
        if "same_as" in e and e["same_as"] not in names:
            raise RegistryError(f"{e['name']}: same_as names no entry ({e['same_as']!r})")
    return entries


def static_problems(entries: list[dict[str, Any]]) -> list[str]:
    """What is wrong without running anything: quotes missing from their docs, commands the
    doc does not name, repeated figures that differ."""
    out = []
    by_name = {e["name"]: e for e in entries}
    for e in entries:
        doc = ROOT / e["doc"]
        try:
            text = _flat(doc.read_text(encoding="utf-8"))
        except OSError:
            out.append(f"{e['name']}: {e['doc']} does not exist")
            continue
        if _flat(e["quote"]) not in text:
            out.append(f"{e['name']}: {e['doc']} no longer says {_flat(e['quote'])!r}")
        if "command" in e and _flat(e["command"]) not in text:
            out.append(f"{e['name']}: {e['doc']} does not name the command {e['command']!r}")
        if "same_as" in e and float(by_name[e["same_as"]]["value"]) != float(e["value"]):
            out.append(
                f"{e['name']}: quotes {e['value']} where {e['same_as']!r} says "
                f"{by_name[e['same_as']]['value']}"
            )
    return out


def _run(command: str, out: Path) -> list[dict[str, Any]]:
    argv = shlex.split(command)
    if argv[0] == "jackson":
        argv[0] = JACKSON
    subprocess.run([*argv, "--out", str(out)], check=True, stdout=subprocess.DEVNULL)
    runs: list[dict[str, Any]] = json.loads((out / "runs.json").read_text())
    return runs


def recompute(entries: list[dict[str, Any]], every: bool) -> list[tuple[dict[str, Any], float]]:
    """Each entry with a metric (the cheap ones unless ``every``) and its value now."""
    todo = [e for e in entries if "metric" in e and (every or e.get("cheap", False))]
    results: dict[str, list[dict[str, Any]]] = {}
    out = []
    with tempfile.TemporaryDirectory(prefix="jackson-docs-check-") as tmp:
        for k, command in enumerate(dict.fromkeys(_flat(e["command"]) for e in todo)):
            print(f"running: {command}", file=sys.stderr, flush=True)
            results[command] = _run(command, Path(tmp) / f"c{k}")
    for e in todo:
        values = [float(r[e["metric"]]) for r in results[_flat(e["command"])]]
        got = STATS[e["stat"]](values)
        out.append((e, got))
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--all", action="store_true", help="also the figures that take long")
    ap.add_argument("--static", action="store_true", help="check quotes and commands only")
    args = ap.parse_args(argv)
    try:
        entries = load()
    except RegistryError as exc:
        print(f"docs-check: {exc}", file=sys.stderr)
        return 2
    problems = static_problems(entries)
    for line in problems:
        print(f"FAIL {line}")
    if not args.static:
        for e, got in recompute(entries, args.all):
            quoted, spread = float(e["value"]), float(e["spread"])
            ok = abs(got - quoted) <= spread
            print(
                f"{'ok  ' if ok else 'FAIL'} {e['name']}: quoted {quoted:g}, now {got:.3g} "
                f"(spread {spread:g}; {e['command']})"
            )
            if not ok:
                problems.append(e["name"])
    print(f"docs-check: {len(entries)} figures, {len(problems)} problem(s)")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
