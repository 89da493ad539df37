"""The figures the docs quote stay tied to their registry (docs/figures.yaml): every quote is
still in its doc word for word, the doc names the command that makes it, and a figure quoted
again elsewhere carries the same value. ``make docs-check`` re-runs the commands themselves
(minutes); this runs on every ``make test``."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

import pytest

ROOT = Path(__file__).resolve().parents[1]


def docs_check() -> ModuleType:
    spec = importlib.util.spec_from_file_location("docs_check", ROOT / "tools" / "docs_check.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules["docs_check"] = module
    spec.loader.exec_module(module)
    return module


def test_every_quoted_figure_is_in_its_doc_with_its_command() -> None:
    dc = docs_check()
    entries = dc.load()
    assert len(entries) >= 5
    assert dc.static_problems(entries) == []


def test_a_drifted_quote_is_named(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    dc = docs_check()
    entries = dc.load()
    first = entries[0]
    value = f"{first['value']:.2f}"
    assert value in first["quote"]
    changed = [dict(first, quote=first["quote"].replace(value, "99.99"))]
    problems = dc.static_problems(changed)
    assert len(problems) == 1 and "no longer says" in problems[0]
    again = {
        "name": "repeated",
        "doc": first["doc"],
        "quote": first["quote"],
        "same_as": first["name"],
        "value": 99.0,
    }
    problems = dc.static_problems([*entries, again])
    assert any("quotes 99.0 where" in p for p in problems)


def test_registry_errors_are_one_line(tmp_path: Path) -> None:
    dc = docs_check()
    bad = tmp_path / "figures.yaml"
    bad.write_text("- name: x\n  doc: docs/x.md\n  quote: y\n  value: 1\n  metric: z\n")
    with pytest.raises(dc.RegistryError, match="a metric needs command, stat and spread"):
        dc.load(bad)
