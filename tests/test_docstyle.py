"""Docstrings use NumPy-style sections (as filterpy does), never Google-style ones.

A section is a title on its own line, underlined with as many dashes::

    Parameters
    ----------
    name : type
        Description.

Google headers (``Args:``, ``Returns:``, ...) are refused anywhere inside a docstring (any
bare string statement: module, class, function and attribute docstrings), in every ``.py``
file of the repository's packages except generated ones (their generator's templates are
checked instead).
"""

from __future__ import annotations

import ast
import re
from collections.abc import Iterator
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("calibration", "cli", "common", "experiments", "host", "protocol", "sim")
SKIP_PARTS = {".venv", "build", "__pycache__"}
# a generated module says so in its docstring (protocol/codegen.py writes protocol/messages.py)
GENERATED = re.compile(r"\bdo not edit\b", re.IGNORECASE)

GOOGLE_HEADER = re.compile(
    r"^\s+(Args|Arguments|Returns|Raises|Attributes|Yields|Examples?|Notes?):\s*$"
)
NUMPY_SECTIONS = (
    "Parameters",
    "Returns",
    "Raises",
    "Attributes",
    "Yields",
    "Notes",
    "Examples",
    "See Also",
)


def _source_files() -> Iterator[tuple[str, list[str], ast.Module]]:
    """(path relative to the repository, lines, parsed module) of every checked file."""
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            rel = path.relative_to(ROOT).as_posix()
            if SKIP_PARTS.intersection(path.relative_to(ROOT).parts):
                continue
            text = path.read_text(encoding="utf-8")
            tree = ast.parse(text, rel)
            if GENERATED.search(ast.get_docstring(tree, clean=False) or ""):
                continue
            yield rel, text.splitlines(), tree


def _docstring_lines(lines: list[str], tree: ast.Module) -> Iterator[tuple[int, list[str]]]:
    """(first line number, source lines) of each docstring: a bare string statement."""
    for node in ast.walk(tree):
        if (
            isinstance(node, ast.Expr)
            and isinstance(node.value, ast.Constant)
            and isinstance(node.value.value, str)
            and node.end_lineno is not None
        ):
            yield node.lineno, lines[node.lineno - 1 : node.end_lineno]


def _google_sections() -> list[str]:
    """file:line of each Google-style section header inside a docstring."""
    found: list[tuple[str, int, str]] = []
    for rel, lines, tree in _source_files():
        for first, doc in _docstring_lines(lines, tree):
            for offset, line in enumerate(doc):
                m = GOOGLE_HEADER.match(line)
                if m:
                    found.append((rel, first + offset, f"Google-style section {m.group(1)}:"))
    return [f"{rel}:{line}: {what}" for rel, line, what in sorted(found)]


def _bad_underlines() -> list[str]:
    """file:line of each NumPy section title not underlined with as many dashes."""
    found: list[tuple[str, int, str]] = []
    for rel, lines, tree in _source_files():
        for first, doc in _docstring_lines(lines, tree):
            for offset, line in enumerate(doc):
                title = line.strip()
                if title not in NUMPY_SECTIONS:
                    continue
                indent = line[: len(line) - len(line.lstrip())]
                below = doc[offset + 1] if offset + 1 < len(doc) else ""
                if below != indent + "-" * len(title):
                    found.append(
                        (
                            rel,
                            first + offset,
                            f"section {title} needs an underline of {len(title)} dashes "
                            "at its indentation on the next line",
                        )
                    )
    return [f"{rel}:{line}: {what}" for rel, line, what in sorted(found)]


def test_checks_the_packages() -> None:
    checked = {rel for rel, _, _ in _source_files()}
    assert "experiments/metrics/summaries.py" in checked
    assert "protocol/messages.py" not in checked  # generated: protocol/codegen.py is checked
    assert "protocol/codegen.py" in checked


def test_no_google_style_sections() -> None:
    found = _google_sections()
    assert not found, "use NumPy-style sections (Parameters / Returns / Raises ...):\n" + "\n".join(
        found
    )


def test_numpy_sections_are_underlined() -> None:
    found = _bad_underlines()
    assert not found, "\n".join(found)
