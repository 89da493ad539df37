"""Writing calibrated values into the host's YAML, keeping its comments.

The host configuration (``host/config/jackson.yaml``) is a commented file people read, so a
calibration edits the lines of the fields it changes and nothing else:

- a scalar line ``  wheel_separation_m: 0.198    # [m] ...`` gets its value replaced, the comment
  kept in its column;
- a per-side field written as one number (``ticks_per_rev: 621``) becomes a flow mapping
  ``{left: 617.2, right: 625.9}`` when the sides differ, and a per-direction one
  (``deadband.gain.left: 1.0``) becomes ``{forward: 0.92, reverse: 0.95}``; the number stays
  the value of the pair's other key until that is set too (setting only ``left`` of
  ``ticks_per_rev: 621`` gives ``{left: 617.2, right: 621}``); a flow mapping is rewritten in
  place;
- a missing field is inserted after the last field of its section (a missing section, such as
  ``imu.calibration``, is inserted as a block), ``key: null`` becomes a block.

The result is then read back with the host's own loader (:func:`jackson.host.config.load_config`)
and every edited value is checked. If the line editor cannot place a value (an unusual
layout), the whole file is written from :func:`jackson.host.config.dump_config` instead, and
the comments are lost (:attr:`UpdateResult.in_place` is False). Either way the old file is kept
as ``FILE.bak-<YYYYmmdd-HHMMSS>`` and the caller gets the field-by-field and the textual diff.
"""

from __future__ import annotations

import datetime as dt
import difflib
import itertools
import os
import re
import shutil
import tempfile
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from jackson.host.config import ConfigError, config_diff, dump_config, load_config

Value = float | int | Sequence[float]
Updates = Mapping[str, Value]

_KEY = re.compile(r"^(?P<indent>[ ]*)(?P<key>[A-Za-z_][A-Za-z0-9_\-]*)[ ]*:(?P<rest>.*)$")
_COMMENT = re.compile(r"(^|\s)#")
_PAIRS = (("left", "right"), ("forward", "reverse"))  # keys one number can stand for together


class YamlUpdateError(ValueError):
    """The configuration cannot be updated (unreadable, or the result would be invalid)."""


@dataclass(frozen=True)
class UpdateResult:
    """What :func:`update_config` did.

    Attributes
    ----------
    path : Path
        The configuration file written.
    backup : Path
        The copy of the file before the change.
    changes : list of str
        One line per changed field, ``robot.ticks_per_rev_left: 621 -> 617.2``.
    diff : str
        Unified diff of the file's text.
    in_place : bool
        True when the lines were edited (comments kept), False when rewritten.
    """

    path: Path
    backup: Path
    changes: list[str]
    diff: str
    in_place: bool


def format_value(value: Value) -> str:
    """A YAML flow value: numbers shortest-exact (``617.2``, ``1.0e-05``), lists ``[a, b]``."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        if isinstance(value, int):
            return str(value)
        text = repr(float(value))
        if "e" in text and "." not in text.split("e")[0]:  # YAML 1.1 floats need the dot
            mantissa, exponent = text.split("e")
            text = f"{mantissa}.0e{exponent}"
        return text
    return "[" + ", ".join(format_value(v) for v in value) + "]"


@dataclass
class _Node:
    line: int  # index of the key's line
    indent: int
    key: str
    value: str  # the value text without the comment ("" for a block parent)
    comment: str  # "# ..." or ""
    comment_col: int  # column of the comment, -1 without
    end: int  # index after the last line of this node's block (children included)


def _split_comment(rest: str) -> tuple[str, str, int]:
    """Value text, comment, and the comment's offset in ``rest`` (-1 without)."""
    in_quote: str | None = None
    for i, ch in enumerate(rest):
        if in_quote:
            if ch == in_quote:
                in_quote = None
        elif ch in "'\"":
            in_quote = ch
        elif ch == "#" and (i == 0 or rest[i - 1] in " \t"):
            return rest[:i].strip(), rest[i:], i
    return rest.strip(), "", -1


def _index(lines: list[str]) -> dict[tuple[str, ...], _Node]:
    """Every block-mapping key of the file by its path, with the extent of its block."""
    nodes: dict[tuple[str, ...], _Node] = {}
    stack: list[tuple[int, tuple[str, ...]]] = []
    for i, raw in enumerate(lines):
        if not raw.strip() or raw.lstrip().startswith("#"):
            continue
        m = _KEY.match(raw)
        if m is None:
            continue  # a list item or a continuation: part of the current block
        indent = len(m["indent"])
        while stack and stack[-1][0] >= indent:
            stack.pop()
        path = (*stack[-1][1], m["key"]) if stack else (m["key"],)
        rest = m["rest"]
        value, comment, off = _split_comment(rest)
        col = len(raw) - len(rest) + off if off >= 0 else -1
        nodes[path] = _Node(i, indent, m["key"], value, comment, col, i + 1)
        if value == "":
            stack.append((indent, path))
    # block extents: up to the last content line before a key at the same or lower indent
    ordered = sorted(nodes.values(), key=lambda n: n.line)
    content = [i for i, raw in enumerate(lines) if raw.strip() and not raw.lstrip().startswith("#")]
    for node in ordered:
        end = node.line + 1
        for i in content:
            if i <= node.line:
                continue
            m = _KEY.match(lines[i])
            ind = len(lines[i]) - len(lines[i].lstrip())
            if ind <= node.indent and (m is not None or not lines[i].lstrip().startswith("-")):
                break
            end = i + 1
        node.end = end
    return nodes


def _render(indent: int, key: str, value: str, comment: str, comment_col: int) -> str:
    head = f"{' ' * indent}{key}: {value}" if value else f"{' ' * indent}{key}:"
    if not comment:
        return head
    pad = comment_col - len(head) if comment_col >= 0 else 2
    if pad < 1:  # the value grew past the comment column
        pad = 2
    return head + " " * pad + comment


def _child_indent(
    lines: list[str], nodes: dict[tuple[str, ...], _Node], path: tuple[str, ...]
) -> int:
    parent = nodes[path]
    children = [n for p, n in nodes.items() if len(p) == len(path) + 1 and p[:-1] == path]
    return min(n.indent for n in children) if children else parent.indent + 2


def _block(indent: int, path: Sequence[str], value: str) -> list[str]:
    """``a:\\n  b: value`` lines for a path below an existing parent."""
    out = [f"{' ' * (indent + 2 * k)}{key}:" for k, key in enumerate(path[:-1])]
    out.append(f"{' ' * (indent + 2 * (len(path) - 1))}{path[-1]}: {value}")
    return out


def _set(lines: list[str], path: tuple[str, ...], value: str) -> bool:
    """Set one leaf in the text lines; False when the layout is not one this editor knows."""
    nodes = _index(lines)
    node = nodes.get(path)
    if node is not None:
        if node.value == "":
            return False  # a block where a value should be
        lines[node.line] = _render(node.indent, node.key, value, node.comment, node.comment_col)
        return True
    # the deepest existing ancestor
    for depth in range(len(path) - 1, 0, -1):
        anc = nodes.get(path[:depth])
        if anc is None:
            continue
        rest = path[depth:]
        if anc.value.startswith("{"):
            try:
                flow = yaml.safe_load(anc.value)
            except yaml.YAMLError:
                return False
            if not isinstance(flow, dict) or len(rest) != 1:
                return False
            items = [
                f"{k}: {format_value(v) if not isinstance(v, str) else v}"
                for k, v in flow.items()
                if k != rest[0]
            ]
            items.append(f"{rest[0]}: {value}")
            text = "{" + ", ".join(items) + "}"
            lines[anc.line] = _render(anc.indent, anc.key, text, anc.comment, anc.comment_col)
            return True
        if anc.value in ("", "null", "~", "{}"):
            if anc.value:
                lines[anc.line] = _render(anc.indent, anc.key, "", anc.comment, anc.comment_col)
            indent = _child_indent(lines, nodes, path[:depth])
            lines[anc.end : anc.end] = _block(indent, rest, value)
            return True
        if len(rest) == 1:  # a scalar that becomes a mapping, e.g. per-side values
            pair = {k: anc.value for k in _pair(rest[0])} if _is_number(anc.value) else {}
            pair[rest[0]] = value
            text = "{" + ", ".join(f"{k}: {v}" for k, v in pair.items()) + "}"
            lines[anc.line] = _render(anc.indent, anc.key, text, anc.comment, anc.comment_col)
            return True
        return False
    # a new top-level section at the end
    if lines and lines[-1].strip():
        lines.append("")
    lines.extend(_block(0, path, value))
    return True


def _pair(key: str) -> tuple[str, ...]:
    """The keys a single number stood for when ``key`` of it is set: the pair it belongs to,
    in the file's order (``left, right``; ``forward, reverse``), or ``key`` alone."""
    for pair in _PAIRS:
        if key in pair:
            return pair
    return (key,)


def _is_number(text: str) -> bool:
    try:
        value = yaml.safe_load(text)
    except yaml.YAMLError:
        return False
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _mapping_get(data: Any, path: Sequence[str]) -> Any:
    for key in path:
        if not isinstance(data, Mapping) or key not in data:
            return None
        data = data[key]
    return data


def _same(a: Any, b: Value) -> bool:
    if isinstance(b, (int, float)):
        return isinstance(a, (int, float)) and float(a) == float(b)
    return (
        isinstance(a, list)
        and len(a) == len(b)
        and all(_same(x, y) for x, y in zip(a, b, strict=True))
    )


def edit_text(text: str, updates: Updates) -> str | None:
    """Apply ``updates`` (dotted YAML paths to numbers or lists) to the text, line by line.

    Returns
    -------
    str or None
        The new text, or None when a value could not be placed or does not read back.
    """
    lines = text.splitlines()
    for dotted, value in updates.items():
        if not _set(lines, tuple(dotted.split(".")), format_value(value)):
            return None
    out = "\n".join(lines) + "\n"
    try:
        data = yaml.safe_load(out)
    except yaml.YAMLError:
        return None
    for dotted, value in updates.items():
        if not _same(_mapping_get(data, dotted.split(".")), value):
            return None
    return out


def _rewrite(path: Path, updates: Updates) -> str:
    """The whole file from dump_config with the updates applied (comments are lost)."""
    cfg = load_config(path)
    data = dump_config(cfg)
    for dotted, value in updates.items():
        keys = dotted.split(".")
        node = data
        for key, next_key in itertools.pairwise(keys):
            child = node.get(key)
            if not isinstance(child, dict):
                child = (
                    {}
                    if not isinstance(child, (int, float))
                    else dict.fromkeys(_pair(next_key), child)
                )
                node[key] = child
            node = child
        node[keys[-1]] = list(value) if not isinstance(value, (int, float)) else value
    return yaml.safe_dump(data, sort_keys=False)


def _backup_path(path: Path, now: dt.datetime) -> Path:
    stamp = now.strftime("%Y%m%d-%H%M%S")
    candidate = path.with_name(f"{path.name}.bak-{stamp}")
    n = 1
    while candidate.exists():
        candidate = path.with_name(f"{path.name}.bak-{stamp}-{n}")
        n += 1
    return candidate


def update_config(
    path: str | Path, updates: Updates, *, now: dt.datetime | None = None
) -> UpdateResult:
    """Write calibrated values into a host YAML, keeping a backup and the comments.

    Parameters
    ----------
    path : str or Path
        The host configuration file (it must exist and be valid).
    updates : Updates
        Dotted YAML paths to new values, e.g. ``{"robot.wheel_separation_m": 0.205,
        "deadband.left.forward": 0.1205, "robot.ticks_per_rev.left": 617.2}``.
    now : datetime or None
        The time of the backup's name (default: now).

    Returns
    -------
    UpdateResult
        What changed, the diff, and where the backup is.

    Raises
    ------
    YamlUpdateError
        The file cannot be read or written, or the result is not a valid
        configuration (the file is then left untouched).
    """
    p = Path(path)
    try:
        old_cfg = load_config(p)
        text = p.read_text(encoding="utf-8")
    except ConfigError as exc:
        raise YamlUpdateError(str(exc)) from exc
    except OSError as exc:
        raise YamlUpdateError(f"config file {p}: cannot read it ({exc.strerror})") from exc
    new_text = edit_text(text, updates)
    in_place = new_text is not None
    if new_text is None:
        new_text = _rewrite(p, updates)
    backup = _backup_path(p, now or dt.datetime.now())
    diff = "".join(
        difflib.unified_diff(
            text.splitlines(keepends=True),
            new_text.splitlines(keepends=True),
            fromfile=f"{p} (before)",
            tofile=f"{p}",
        )
    )
    tmp: str | None = None
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{p.name}.", suffix=".yaml", dir=p.parent)
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(new_text)
        shutil.copymode(p, tmp)
        try:
            new_cfg = load_config(tmp)  # the host's own loader and checks
        except ConfigError as exc:
            detail = str(exc).split(": ", 1)[-1]
            raise YamlUpdateError(
                f"config {p.name}: the calibrated values would be invalid: {detail}"
            ) from exc
        shutil.copy2(p, backup)
        os.replace(tmp, p)
        tmp = None
    except OSError as exc:
        raise YamlUpdateError(f"config file {p}: cannot write it ({exc.strerror})") from exc
    finally:
        if tmp is not None:
            Path(tmp).unlink(missing_ok=True)
    return UpdateResult(p, backup, config_diff(old_cfg, new_cfg), diff, in_place)
