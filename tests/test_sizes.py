"""Size limits that keep the code readable by someone who did not write it.

A module holds one idea (at most 800 lines), a function fits on two screens (at most 120 lines),
and a class that keeps more than 25 pieces of state is several classes (parameter and record
dataclasses, whose fields are the parameters themselves, are exempt). Exempt: generated code.
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FOLDERS = ("cli", "bench", "common", "protocol", "host", "sim", "calibration", "experiments")
MODULE_LINES = 800
FUNCTION_LINES = 120
CLASS_STATE = 25
EXEMPT_MODULES = {
    "protocol/messages.py",  # generated from protocol/schema.yaml (protocol/codegen.py)
}
EXEMPT_CLASSES: set[str] = set()


def _modules() -> list[Path]:
    return sorted(
        p for folder in FOLDERS if (ROOT / folder).is_dir() for p in (ROOT / folder).rglob("*.py")
    )


def _rel(path: Path) -> str:
    return path.relative_to(ROOT).as_posix()


def _is_dataclass(node: ast.ClassDef) -> bool:
    for d in node.decorator_list:
        target = d.func if isinstance(d, ast.Call) else d
        name = target.attr if isinstance(target, ast.Attribute) else getattr(target, "id", "")
        if name == "dataclass":
            return True
    return False


def _state(node: ast.ClassDef) -> set[str]:
    """The instance attributes a class assigns (``self.X = ...`` anywhere in its body)."""
    names = set()
    for sub in ast.walk(node):
        if (
            isinstance(sub, ast.Attribute)
            and isinstance(sub.ctx, ast.Store)
            and isinstance(sub.value, ast.Name)
            and sub.value.id == "self"
        ):
            names.add(sub.attr)
    return names


def test_the_limits_see_the_whole_package() -> None:
    assert len(_modules()) > 150


def test_no_module_is_over_800_lines() -> None:
    long = {
        _rel(p): n
        for p in _modules()
        if _rel(p) not in EXEMPT_MODULES and (n := p.read_text().count("\n")) > MODULE_LINES
    }
    assert long == {}, f"split these modules by idea: {long}"


def test_no_function_is_over_120_lines() -> None:
    long = {}
    for p in _modules():
        for node in ast.walk(ast.parse(p.read_text())):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                assert node.end_lineno is not None
                n = node.end_lineno - node.lineno + 1
                if n > FUNCTION_LINES:
                    long[f"{_rel(p)}:{node.lineno} {node.name}"] = n
    assert long == {}, f"split these functions into named steps: {long}"


def test_no_class_keeps_more_than_25_attributes() -> None:
    big = {}
    for p in _modules():
        if _rel(p) in EXEMPT_CLASSES:
            continue
        for node in ast.walk(ast.parse(p.read_text())):
            if isinstance(node, ast.ClassDef) and not _is_dataclass(node):
                n = len(_state(node))
                if n > CLASS_STATE:
                    big[f"{_rel(p)}:{node.lineno} {node.name}"] = n
    assert big == {}, f"group these classes' state into smaller objects: {big}"
