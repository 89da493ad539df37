"""Writing calibrated values into the host's YAML, keeping its comments, key order and layout.

The host configuration (``host/config/jackson.yaml``) is a commented file people read, so a
calibration changes the values of the fields it calibrates and nothing else. The file is
edited in ruamel.yaml's round-trip mode, which keeps every comment (in its column), the key
order, flow or block style, quotes and number formats of what is not changed:

- a changed number is written shortest-exact (``617.2``, ``1.0e-05``: always with a dot, which
  YAML 1.1 readers need to see a float), a list as a flow sequence ``[a, b]``; a list of the
  same length is changed item by item, in its own style;
- a per-side field written as one number (``ticks_per_rev: 621``) becomes a flow mapping
  ``{left: 617.2, right: 625.9}`` when the sides differ, and a per-direction one
  (``deadband.gain.left: 1.0``) becomes ``{forward: 0.92, reverse: 0.95}``; the number stays
  the value of the pair's other key until that is set too;
- a missing field is appended after the last field of its section, before the blank line that
  ends it (a missing section, such as ``imu.calibration``, as a block), a new top-level section
  at the end of the file after a blank line; ``key: null`` becomes a block;
- a field that already holds the value is left as written (``0.10`` stays ``0.10``), so writing
  the same result twice changes nothing the second time.

The result is checked with the host's own reader and validator
(:func:`jackson.host.config.load_config`) before it replaces the file: every written value
must read back equal. The old file is kept as ``FILE.bak-<YYYYmmdd-HHMMSS>`` and the caller
gets the field-by-field and the unified diff.
"""

from __future__ import annotations

import datetime as dt
import difflib
import io
import numbers
import os
import re
import shutil
import tempfile
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ruamel.yaml import YAML
from ruamel.yaml.comments import CommentedBase, CommentedMap, CommentedSeq
from ruamel.yaml.error import CommentMark, MarkedYAMLError, YAMLError
from ruamel.yaml.nodes import ScalarNode
from ruamel.yaml.representer import RoundTripRepresenter
from ruamel.yaml.scalarbool import ScalarBoolean
from ruamel.yaml.tokens import CommentToken

from jackson.common.errors import JacksonError
from jackson.common.fields import read_yaml
from jackson.host.config import ConfigError, load_config

Value = float | int | Sequence[float]
Updates = Mapping[str, Value]
Collection = CommentedMap | CommentedSeq

_PAIRS = (("left", "right"), ("forward", "reverse"))  # keys one number can stand for together
_LAYOUTS = ((2, 4, 2), (2, 2, 0), (4, 6, 4), (4, 4, 0), (4, 6, 2), (3, 5, 3), (3, 3, 0))
"""Block indentations tried, (mapping, sequence, dash offset): the first whose unedited
round trip reproduces the file is used."""


class YamlUpdateError(JacksonError, ValueError):
    """The configuration cannot be updated (unreadable, or the result would be invalid)."""


@dataclass(frozen=True)
class UpdateResult:
    """What :func:`update_config` did.

    Attributes
    ----------
    path : Path
        The configuration file.
    backup : Path or None
        The copy of the file before the change; None when nothing changed (and nothing was
        written).
    changes : list of str
        One line per changed field, named by its YAML path as the file spells it
        (``robot.ticks_per_rev.left: 621 -> 617.2``).
    diff : str
        Unified diff of the file's text ("" when nothing changed).
    """

    path: Path
    backup: Path | None
    changes: list[str]
    diff: str


def format_value(value: Value) -> str:
    """A YAML flow value: numbers shortest-exact (``617.2``, ``1.0e-05``), lists ``[a, b]``."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, numbers.Integral):
        return str(int(value))
    if isinstance(value, (int, float)):
        text = repr(float(value))
        if "e" in text and "." not in text.split("e")[0]:  # YAML 1.1 floats need the dot
            mantissa, exponent = text.split("e")
            text = f"{mantissa}.0e{exponent}"
        return text
    return "[" + ", ".join(format_value(v) for v in value) + "]"


# ------------------------------------------------------------------------- ruamel.yaml set-up


class _Representer(RoundTripRepresenter):
    """The round-trip representer, writing new floats with :func:`format_value` and None as
    ``null`` (ruamel.yaml writes ``1e-05``, which YAML 1.1 reads as text, and an empty value).
    A subclass, so that ruamel.yaml's own representer is left as other users expect it."""


def _represent_float(rep: RoundTripRepresenter, data: float) -> ScalarNode:
    return rep.represent_scalar("tag:yaml.org,2002:float", format_value(data))


def _represent_none(rep: RoundTripRepresenter, data: None) -> ScalarNode:
    return rep.represent_scalar("tag:yaml.org,2002:null", "null")


_Representer.add_representer(float, _represent_float)
_Representer.add_representer(type(None), _represent_none)


def _yaml(layout: tuple[int, int, int], text: str = "") -> YAML:
    yaml = YAML()  # round-trip
    yaml.explicit_start = re.search(r"^---", text, re.MULTILINE) is not None
    yaml.explicit_end = re.search(r"^\.\.\.[ \t]*$", text, re.MULTILINE) is not None
    yaml.Representer = _Representer
    yaml.preserve_quotes = True
    yaml.width = 1 << 30  # never fold a long line
    mapping, sequence, offset = layout
    yaml.indent(mapping=mapping, sequence=sequence, offset=offset)
    return yaml


def _dump(yaml: YAML, data: Any) -> str:
    out = io.StringIO()
    yaml.dump(data, out)
    return out.getvalue()


def _plain(text: str) -> str:
    """The text as ruamel.yaml writes it back: ``\\n`` line ends, no byte-order mark."""
    return text.removeprefix("\ufeff").replace("\r\n", "\n")


def _restore(text: str, out: str) -> str:
    """The line endings and byte-order mark of ``text`` on ruamel.yaml's output."""
    if "\r\n" in text:
        out = out.replace("\n", "\r\n")
    if text.startswith("\ufeff"):
        out = "\ufeff" + out
    return out


def _load(text: str, where: str) -> tuple[YAML, CommentedMap]:
    """The document and the layout that writes it back unchanged (or closest to that)."""
    try:
        data = _yaml(_LAYOUTS[0]).load(text)
    except YAMLError as exc:
        mark = exc.problem_mark if isinstance(exc, MarkedYAMLError) else None
        line = f" line {mark.line + 1}:" if mark is not None else ""
        problem = " ".join(str(getattr(exc, "problem", None) or type(exc).__name__).split())
        raise YamlUpdateError(f"{where}:{line} cannot be edited as YAML ({problem})") from exc
    if not isinstance(data, CommentedMap):
        raise YamlUpdateError(f"{where}: the top level is not a mapping of fields")
    best: tuple[int, YAML] | None = None
    for layout in _LAYOUTS:
        yaml = _yaml(layout, text)
        out = _dump(yaml, data)
        if out == text:
            return yaml, data
        changed = sum(1 for _ in difflib.unified_diff(text.splitlines(), out.splitlines(), n=0))
        if best is None or changed < best[0]:
            best = (changed, yaml)
    assert best is not None
    return best[1], data


# ------------------------------------------------------------------------- comments

# ruamel.yaml keeps the comment after a value, the blank and comment lines that follow it
# included, in ``container.ca.items[key][2]`` (mapping) or ``[index][0]`` (sequence); for a
# block collection it is held by its last item, at the deepest level.


def _is_block(node: Any) -> bool:
    return isinstance(node, (CommentedMap, CommentedSeq)) and len(node) > 0 and not _is_flow(node)


def _is_flow(node: CommentedBase) -> bool:
    """Whether a mapping or sequence is written in flow style (``{a: 1}``, ``[1, 2]``)."""
    return bool(node.fa.flow_style())


def _last(node: CommentedMap | CommentedSeq) -> Any:
    return len(node) - 1 if isinstance(node, CommentedSeq) else next(reversed(node))


def _slot(parent: Collection, key: Any) -> tuple[Collection, Any]:
    """The container and key holding the comment after ``parent[key]`` and all it contains."""
    while _is_block(parent[key]):
        parent, key = parent[key], _last(parent[key])
    return parent, key


def _slot_index(container: Collection) -> int:
    return 0 if isinstance(container, CommentedSeq) else 2


def _split_tail(parent: Collection, key: Any) -> list[str]:
    """Cut the lines after the comment of ``parent[key]`` from its first blank line on.

    The end-of-line comment and the comment lines right below it stay; what follows the first
    blank line (the gap to the next section, a heading) is removed and returned as lines.
    """
    container, k = _slot(parent, key)
    entry = container.ca.items.get(k)
    token = entry[_slot_index(container)] if entry else None
    if not isinstance(token, CommentToken):
        return []
    eol, *rest = token.value.split("\n")
    if rest and rest[-1] == "":
        rest.pop()
    blank = next((i for i, line in enumerate(rest) if not line.strip()), len(rest))
    head, tail = rest[:blank], rest[blank:]
    if not eol and not head:
        entry[_slot_index(container)] = None
    else:
        token.value = "\n".join([eol, *head]) + "\n"
    return tail


def _add_tail(parent: Collection, key: Any, lines: list[str]) -> None:
    """Append lines after the comment of ``parent[key]`` and all it contains."""
    if not lines:
        return
    container, k = _slot(parent, key)
    text = "".join(f"{line}\n" for line in lines)
    entry = container.ca.items.setdefault(k, [None, None, None, None])
    token = entry[_slot_index(container)]
    if isinstance(token, CommentToken):
        token.value = token.value + text
    else:
        entry[_slot_index(container)] = CommentToken("\n" + text, CommentMark(0))


# ------------------------------------------------------------------------- editing


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, (bool, ScalarBoolean))


def _same(a: Any, b: Value) -> bool:
    if isinstance(b, (int, float)):
        return _is_number(a) and float(a) == float(b)
    return (
        isinstance(a, list)
        and len(a) == len(b)
        and all(_same(x, y) for x, y in zip(a, b, strict=True))
    )


def _pair(key: str) -> tuple[str, ...]:
    """The keys one number stands for when ``key`` of it is set (``left, right``;
    ``forward, reverse``), in the file's order, or nothing."""
    return next((pair for pair in _PAIRS if key in pair), ())


def _number(value: Any, dotted: str) -> int | float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise YamlUpdateError(f"{dotted}: {value!r} is not a number")
    if isinstance(value, numbers.Integral):
        return int(value)
    number = float(value)
    if number != number or number in (float("inf"), float("-inf")):
        raise YamlUpdateError(f"{dotted}: the value is not a finite number ({number})")
    return number


def _node(value: Value, dotted: str) -> Any:
    """The ruamel.yaml node of a new value: a number or a flow sequence."""
    if isinstance(value, (str, bytes)) or not isinstance(value, (numbers.Real, Sequence)):
        raise YamlUpdateError(f"{dotted}: {value!r} is not a number or a list of numbers")
    if isinstance(value, numbers.Real):
        return _number(value, dotted)
    seq = CommentedSeq(_number(v, dotted) for v in value)
    seq.fa.set_flow_style()
    return seq


def _new_map(flow: bool) -> CommentedMap:
    section = CommentedMap()
    if flow:
        section.fa.set_flow_style()
    return section


def _insert(node: CommentedMap, owner: tuple[Collection, Any] | None, key: str, value: Any) -> None:
    """Append a new key to ``node`` (which sits at ``owner``; None: the document)."""
    if _is_flow(node):
        node[key] = value
        return
    if len(node):
        tail = _split_tail(node, _last(node))
        if owner is None:  # a new top-level section: after a blank line
            _add_tail(node, _last(node), [""])
    elif owner is not None:
        tail = _split_tail(*owner)
    else:
        tail = []
    node[key] = value
    _add_tail(node, key, tail)


def _replace(node: CommentedMap, key: str, old: Any, new: Any) -> None:
    if isinstance(old, CommentedSeq) and isinstance(new, CommentedSeq) and len(old) == len(new):
        for i, v in enumerate(new):  # item by item, in the list's own style
            if not _same(old[i], v):
                old[i] = v
        return
    tail = _split_tail(node, key) if _is_block(old) else []
    node[key] = new
    _add_tail(node, key, tail)


def _what(value: Any) -> str:
    if _is_number(value):
        return "a number"
    if isinstance(value, list):
        return "a list"
    if isinstance(value, str):
        return "text"
    return "a value"


def _apply(root: CommentedMap, dotted: str, value: Value) -> bool:
    """Set one dotted field in the document; False when it already holds the value."""
    keys = dotted.split(".")
    if not all(keys):
        raise YamlUpdateError(f"{dotted!r}: not a dotted field name")
    node = root
    owner: tuple[Collection, Any] | None = None
    for depth, key in enumerate(keys[:-1]):
        here = ".".join(keys[: depth + 1])
        child = node.get(key)
        if isinstance(child, CommentedMap):
            pass
        elif child is None:  # missing, or null: a new section
            child = _new_map(_is_flow(node))
            if key in node:
                node[key] = child
            else:
                _insert(node, owner, key, child)
        elif _is_number(child) and depth == len(keys) - 2 and _pair(keys[-1]):
            if _same(child, value):
                return False  # the one number already stands for this side or direction
            child = _new_map(flow=True)  # one number for both: a pair, the other one kept
            child.update((k, node[key]) for k in _pair(keys[-1]))
            node[key] = child
        else:
            raise YamlUpdateError(f"{dotted}: {here} is {_what(child)}, not a section")
        owner, node = (node, key), child
    leaf = keys[-1]
    if leaf in node and _same(node[leaf], value):
        return False
    new = _node(value, dotted)
    if leaf in node:
        _replace(node, leaf, node[leaf], new)
    else:
        _insert(node, owner, leaf, new)
    return True


def edit_text(text: str, updates: Updates, where: str = "config") -> str:
    """Apply ``updates`` (dotted YAML paths to numbers or lists) to a YAML text.

    Parameters
    ----------
    text : str
        The YAML document, a mapping at the top level.
    updates : Updates
        Dotted paths to new values, e.g. ``{"robot.ticks_per_rev.left": 617.2}``.
    where : str
        What the text is, for messages (``config jackson.yaml``).

    Returns
    -------
    str
        The new text: comments, key order and every unchanged line as they were; the text
        itself when every field already holds its value.

    Raises
    ------
    YamlUpdateError
        The text is not YAML, its top level or a section on a path is not a mapping, or a
        value is not a finite number or a list of them.
    """
    yaml, data = _load(_plain(text), where)
    try:
        changed = [_apply(data, dotted, value) for dotted, value in updates.items()]
    except YamlUpdateError as exc:
        raise YamlUpdateError(f"{where}: {exc}") from exc
    if not any(changed):
        return text
    try:
        return _restore(text, _dump(yaml, data))
    except YAMLError as exc:  # not expected from numbers and lists; reported, not raised raw
        raise YamlUpdateError(f"{where}: cannot write the new values ({exc})") from exc


# ------------------------------------------------------------------------- the file


def _read_back(data: Any, keys: Sequence[str]) -> Any:
    """The value the host reads at a dotted path (one number standing for a pair included)."""
    for depth, key in enumerate(keys):
        if _is_number(data) and depth == len(keys) - 1 and _pair(key):
            return data
        if not isinstance(data, Mapping) or key not in data:
            return None
        data = data[key]
    return data


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
        What changed, the diff, and where the backup is (no backup, no write when every
        field already held its value).

    Raises
    ------
    YamlUpdateError
        The file cannot be read, edited or written, or the result is not a valid
        configuration (the file is then left untouched).
    """
    p = Path(path)
    where = f"config {p.name}"
    try:
        load_config(p)  # a file the host cannot read is not edited
        text = p.read_text(encoding="utf-8")
    except ConfigError as exc:
        raise YamlUpdateError(str(exc)) from exc
    except OSError as exc:
        raise YamlUpdateError(f"config file {p}: cannot read it ({exc.strerror})") from exc
    new_text = edit_text(text, updates, where)
    if new_text == text:
        return UpdateResult(p, None, [], "")
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
            load_config(tmp)  # the host's own reader and checks
            _, data = read_yaml(Path(tmp), "config")
        except ConfigError as exc:
            detail = str(exc).split(": ", 1)[-1]
            raise YamlUpdateError(
                f"{where}: the calibrated values would be invalid: {detail}"
            ) from exc
        _, old_data = read_yaml(p, "config")
        changes: list[str] = []
        for dotted, value in updates.items():
            got = _read_back(data, dotted.split("."))
            was = _read_back(old_data, dotted.split("."))
            if was is None or not _same(was, value):
                before = "(not set)" if was is None else _shown(was)
                changes.append(f"{dotted}: {before} -> {format_value(value)}")
            if not _same(got, value):
                raise YamlUpdateError(
                    f"{where}: {dotted} would read back as {got!r}, not {format_value(value)}"
                )
        backup = _backup_path(p, now or dt.datetime.now())
        shutil.copy2(p, backup)
        os.replace(tmp, p)
        tmp = None
    except OSError as exc:
        raise YamlUpdateError(f"config file {p}: cannot write it ({exc.strerror})") from exc
    finally:
        if tmp is not None:
            Path(tmp).unlink(missing_ok=True)
    return UpdateResult(p, backup, changes, diff)


def _shown(value: Any) -> str:
    """A value read from the YAML as the change summary shows it."""
    if _is_number(value) or isinstance(value, list):
        try:
            return format_value(value)
        except TypeError:
            return str(value)
    return str(value)
