"""Typed fields out of YAML files: the reader behind the host's config and the twin's robot and
world files (jackson.host.config, jackson.sim.config).

Every problem is one :class:`ConfigError` line that names the file and the dotted field, e.g.
``robot bad.yaml: motor.stall_torque_nm: expected a number > 0, got -1``. Unknown fields are
refused (:meth:`Fields.finish`), repeated fields too, and ``1e-9``, ``1e6`` and ``1.0e6`` read
as numbers (plain YAML 1.1 would read them as text).
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import yaml

from jackson.common.errors import JacksonError


class ConfigError(JacksonError, ValueError):
    """A configuration, robot or world file is missing, unreadable, not YAML, or has a bad
    field."""


def show(value: Any) -> str:
    """A value as the YAML author wrote it."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true" if value else "false"
    return repr(value)


def _interval(lo: float | None, hi: float | None, lo_open: bool, hi_open: bool) -> str:
    if lo is not None and hi is not None:
        return f" in {'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}"
    if lo is not None:
        return f" {'>' if lo_open else '>='} {lo:g}"
    if hi is not None:
        return f" {'<' if hi_open else '<='} {hi:g}"
    return ""


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


class Fields:
    """Pulls typed fields out of one YAML mapping, naming the dotted field in errors."""

    def __init__(self, where: str, data: Mapping[Any, Any], prefix: str = "") -> None:
        self.where = where
        self.data = data
        self.prefix = prefix
        self.used: set[str] = set()

    def fail(self, key: str, msg: str) -> ConfigError:
        return ConfigError(f"{self.where}: {self.prefix}{key}: {msg}")

    def has(self, key: str) -> bool:
        return key in self.data

    def number(
        self,
        key: str,
        default: float,
        lo: float | None = None,
        hi: float | None = None,
        *,
        lo_open: bool = False,
        hi_open: bool = False,
    ) -> float:
        self.used.add(key)
        if key not in self.data:
            return default
        v = self.data[key]
        ok = _is_number(v) and math.isfinite(v)
        if ok and lo is not None:
            ok = v > lo if lo_open else v >= lo
        if ok and hi is not None:
            ok = v < hi if hi_open else v <= hi
        if not ok:
            raise self.fail(
                key, f"expected a number{_interval(lo, hi, lo_open, hi_open)}, got {show(v)}"
            )
        return float(v)

    def optional_number(
        self, key: str, lo: float, hi: float | None = None, *, lo_open: bool = False
    ) -> float | None:
        """A number, or null (the default) for "off"."""
        if self.data.get(key) is None:
            self.used.add(key)
            return None
        v = self.data[key]
        ok = _is_number(v) and math.isfinite(v) and (v > lo if lo_open else v >= lo)
        if not ok or (hi is not None and v > hi):
            interval = _interval(lo, hi, lo_open, False)
            raise self.fail(key, f"expected a number{interval} or null, got {show(v)}")
        self.used.add(key)
        return float(v)

    def integer(
        self, key: str, default: int, lo: int, hi: int, *, hexadecimal: bool = False
    ) -> int:
        self.used.add(key)
        if key not in self.data:
            return default
        v = self.data[key]
        if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
            got = f"0x{v:02x}" if hexadecimal and isinstance(v, int) and v >= 0 else show(v)
            span = f"0x{lo:02x}-0x{hi:02x}" if hexadecimal else f"{lo}-{hi}"
            raise self.fail(key, f"expected an integer in {span}, got {got}")
        return v

    def optional_integer(self, key: str, lo: int, hi: int) -> int | None:
        if self.data.get(key) is None:
            self.used.add(key)
            return None
        v = self.data[key]
        if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
            raise self.fail(key, f"expected an integer in {lo}-{hi} or null, got {show(v)}")
        self.used.add(key)
        return v

    def boolean(self, key: str, default: bool) -> bool:
        self.used.add(key)
        v = self.data.get(key, default)
        if not isinstance(v, bool):
            raise self.fail(key, f"expected true or false, got {show(v)}")
        return v

    def text(self, key: str, default: str) -> str:
        self.used.add(key)
        v = self.data.get(key, default)
        if not isinstance(v, str) or not v.strip():
            raise self.fail(key, f"expected a non-empty text, got {show(v)}")
        return v

    def optional_text(self, key: str) -> str | None:
        """A non-empty text, or None when absent or null."""
        self.used.add(key)
        v = self.data.get(key)
        if v is None:
            return None
        if not isinstance(v, str) or not v.strip():
            raise self.fail(key, f"expected a non-empty text or null, got {show(v)}")
        return v

    def section(self, key: str) -> Fields:
        """A nested mapping; absent or null reads as empty (all defaults)."""
        self.used.add(key)
        v = self.data.get(key)
        if v is None:
            v = {}
        if not isinstance(v, Mapping):
            raise self.fail(key, f"expected a mapping of fields, got {show(v)}")
        return Fields(self.where, v, f"{self.prefix}{key}.")

    def sides(
        self,
        key: str,
        default: float,
        lo: float | None = None,
        hi: float | None = None,
        *,
        lo_open: bool = False,
    ) -> tuple[float, float]:
        """``key: 0.033`` (both wheels) or ``key: {left: 0.033, right: 0.0331}``."""
        if not isinstance(self.data.get(key), Mapping):
            v = self.number(key, default, lo, hi, lo_open=lo_open)
            return v, v
        s = self.section(key)
        for side in ("left", "right"):
            if not s.has(side):
                raise s.fail(side, "missing (give both left and right, or one number)")
        out = (
            s.number("left", default, lo, hi, lo_open=lo_open),
            s.number("right", default, lo, hi, lo_open=lo_open),
        )
        s.finish()
        return out

    def vector(self, key: str, default: tuple[float, ...], n: int) -> tuple[float, ...]:
        self.used.add(key)
        if key not in self.data:
            return default
        v = self.data[key]
        if (
            not isinstance(v, list)
            or len(v) != n
            or not all(_is_number(x) and math.isfinite(x) for x in v)
        ):
            raise self.fail(key, f"expected a list of {n} numbers, got {show(v)}")
        return tuple(float(x) for x in v)

    def items(self, key: str) -> list[Any]:
        """A list of entries (absent or null: empty), each checked by the caller."""
        self.used.add(key)
        v = self.data.get(key)
        if v is None:
            return []
        if not isinstance(v, list):
            raise self.fail(key, f"expected a list, got {show(v)}")
        return v

    def finish(self) -> None:
        unknown = sorted(str(k) for k in self.data if k not in self.used)
        if unknown:
            raise self.fail(unknown[0], "unknown field (check the spelling)")


class _StrictLoader(getattr(yaml, "CSafeLoader", yaml.SafeLoader)):  # type: ignore[misc]
    """Safe YAML that also reads ``1e-9`` and ``1.0e6`` as numbers and refuses duplicate keys;
    parsed by libyaml where PyYAML has it (the shipped host configuration: 1 ms instead of 19)."""

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
        seen: set[str] = set()
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=deep)
            if isinstance(key, str):
                if key in seen:
                    raise yaml.constructor.ConstructorError(
                        None, None, f"duplicate field {key!r}", key_node.start_mark
                    )
                seen.add(key)
        mapping: dict[Any, Any] = super().construct_mapping(node, deep)
        return mapping


_StrictLoader.add_implicit_resolver(  # YAML 1.1 wants a dot and a signed exponent: 1.0e+6
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9][0-9_]*(?:\.[0-9_]*)?|\.[0-9][0-9_]*)[eE][-+]?[0-9]+$"),
    list("-+.0123456789"),
)


def read_yaml(path: Path, kind: str) -> tuple[str, Mapping[Any, Any]]:
    """Load a YAML file whose top level is a mapping of fields.

    Parameters
    ----------
    path : Path
        The file.
    kind : str
        What it is, for messages ("config", "robot", "world").

    Returns
    -------
    tuple of (str, mapping)
        ``(where, data)``: ``where`` ("robot jackson.yaml") prefixes every error about it.

    Raises
    ------
    ConfigError
        The file cannot be read, is not UTF-8 or YAML, repeats a field, or its top
        level is not a mapping.
    """
    where = f"{kind} {path.name}"
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise ConfigError(f"{kind} file {path}: cannot read it ({exc.strerror or exc})") from exc
    except UnicodeDecodeError as exc:
        raise ConfigError(f"{kind} file {path}: not UTF-8 text") from exc
    try:
        data = yaml.load(text, Loader=_StrictLoader)  # a (C) SafeLoader
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        problem = getattr(exc, "problem", None)
        line = f" line {mark.line + 1}:" if mark is not None else ""
        detail = f" ({problem})" if problem else ""
        raise ConfigError(f"{where}:{line} not valid YAML{detail}") from exc
    if not isinstance(data, Mapping):
        raise ConfigError(
            f"{where}: expected a mapping of fields at the top level, got {show(data)}"
        )
    return where, data
