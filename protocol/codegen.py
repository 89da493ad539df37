"""Generate the Python and C++ message code from ``protocol/schema.yaml``.

The schema is the single source of truth for the message layout. This script
writes ``protocol/messages.py`` and ``protocol/include/jackson/protocol/messages.hpp``;
``--check`` exits non-zero when either file differs from what the schema gives,
which is how ``make test`` catches a stale header.

Usage::

    python -m jackson.protocol.codegen           # rewrite both files
    python -m jackson.protocol.codegen --check   # fail if either is stale
"""

from __future__ import annotations

import argparse
import hashlib
import json
import re
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from jackson.common.errors import JacksonError

PROTOCOL_DIR = Path(__file__).resolve().parent
SCHEMA_PATH = PROTOCOL_DIR / "schema.yaml"
PY_OUT = PROTOCOL_DIR / "messages.py"
CPP_OUT = PROTOCOL_DIR / "include" / "jackson" / "protocol" / "messages.hpp"

# scalar type -> (struct code, size in bytes, C++ type, Python annotation)
SCALARS: dict[str, tuple[str, int, str, str]] = {
    "u8": ("B", 1, "uint8_t", "int"),
    "i8": ("b", 1, "int8_t", "int"),
    "u16": ("H", 2, "uint16_t", "int"),
    "i16": ("h", 2, "int16_t", "int"),
    "u32": ("I", 4, "uint32_t", "int"),
    "i32": ("i", 4, "int32_t", "int"),
    "f32": ("f", 4, "float", "float"),
}
_TYPE_RE = re.compile(r"^(?P<base>[a-z0-9]+)(\[(?P<n>\d+)\])?$")


class SchemaError(JacksonError, ValueError):
    """The schema file is malformed."""


@dataclass(frozen=True)
class Field:
    name: str
    base: str  # a SCALARS key or "text"
    count: int  # 1 for scalars, N for arrays and text
    is_array: bool
    doc: str

    @property
    def size(self) -> int:
        """Bytes on the wire (for text: 0, it fills the rest of the payload)."""
        return 0 if self.base == "text" else SCALARS[self.base][1] * self.count


@dataclass(frozen=True)
class Message:
    name: str
    type_id: int
    doc: str
    fields: tuple[Field, ...]

    @property
    def class_name(self) -> str:
        return "".join(part.capitalize() for part in self.name.split("_"))

    @property
    def fixed_size(self) -> int:
        return sum(f.size for f in self.fields)

    @property
    def text_field(self) -> Field | None:
        return next((f for f in self.fields if f.base == "text"), None)

    @property
    def struct_format(self) -> str:
        return "<" + "".join(
            (str(f.count) if f.count > 1 else "") + SCALARS[f.base][0]
            for f in self.fields
            if f.base != "text"
        )


@dataclass(frozen=True)
class Schema:
    protocol_version: int
    max_payload: int
    partial_timeout_us: int
    enums: dict[str, dict[str, int]]
    flags: dict[str, dict[str, int]]
    bit_fields: dict[str, dict[str, tuple[int, int]]]  # word -> name -> (shift, bits)
    scales: dict[str, float | tuple[float, ...]]
    limits: dict[str, tuple[float, float]]
    defaults: dict[str, int]  # power-up settings, each within its limit (not hashed)
    messages: tuple[Message, ...]
    schema_hash: int


def _parse_field(raw: dict[str, Any], msg: str, is_last: bool) -> Field:
    match = _TYPE_RE.match(str(raw.get("type", "")))
    if not match:
        raise SchemaError(f"{msg}.{raw.get('name')}: bad type {raw.get('type')!r}")
    base, n = match.group("base"), match.group("n")
    if base == "text":
        if n is None or not is_last:
            raise SchemaError(f"{msg}.{raw['name']}: text needs a size and must be the last field")
        return Field(raw["name"], "text", int(n), False, str(raw.get("doc", "")))
    if base not in SCALARS:
        raise SchemaError(f"{msg}.{raw['name']}: unknown type {base!r}")
    count = int(n) if n is not None else 1
    return Field(raw["name"], base, count, n is not None, str(raw.get("doc", "")))


def load_schema(path: Path = SCHEMA_PATH) -> Schema:
    """Read and validate the schema, and compute its hash.

    The hash is the first 4 bytes (big-endian) of SHA-256 over a canonical JSON
    form of everything that affects the bytes or their meaning: version, limits,
    enum and flag values, message names, ids, field names and types. Comments,
    docs and units are excluded, so rewording a doc does not break compatibility.
    """
    raw = yaml.safe_load(path.read_text(encoding="utf-8"))
    messages: list[Message] = []
    seen_ids: set[int] = set()
    for m in raw["messages"]:
        raw_fields = m.get("fields") or []
        fields = tuple(
            _parse_field(f, m["name"], i == len(raw_fields) - 1) for i, f in enumerate(raw_fields)
        )
        if m["id"] in seen_ids:
            raise SchemaError(f"{m['name']}: duplicate id {m['id']:#04x}")
        seen_ids.add(m["id"])
        msg = Message(m["name"], int(m["id"]), " ".join(str(m.get("doc", "")).split()), fields)
        text = msg.text_field
        longest = msg.fixed_size + (text.count if text else 0)
        if longest > raw["max_payload"]:
            raise SchemaError(f"{msg.name}: {longest} bytes exceed max_payload")
        messages.append(msg)
    bit_fields = {
        word: {k: (int(v["shift"]), int(v["bits"])) for k, v in entries.items()}
        for word, entries in (raw.get("bit_fields") or {}).items()
    }
    for word, entries in bit_fields.items():
        for k, (shift, bits) in entries.items():
            if not (0 <= shift and 1 <= bits and shift + bits <= 16):
                raise SchemaError(f"bit_fields.{word}.{k}: shift {shift}, bits {bits} exceed u16")
    scales: dict[str, float | tuple[float, ...]] = {
        k: tuple(float(x) for x in v) if isinstance(v, list) else float(v)
        for k, v in (raw.get("scales") or {}).items()
    }
    limits = {k: (float(v[0]), float(v[1])) for k, v in (raw.get("limits") or {}).items()}
    defaults = {k: int(v) for k, v in (raw.get("defaults") or {}).items()}
    for k, v in defaults.items():
        if k not in limits or not limits[k][0] <= v <= limits[k][1]:
            raise SchemaError(f"defaults.{k}: {v} has no limit or lies outside it")
    canonical = {
        "protocol_version": raw["protocol_version"],
        "max_payload": raw["max_payload"],
        "partial_timeout_us": raw["partial_timeout_us"],
        "enums": raw["enums"],
        "flags": raw["flags"],
        "bit_fields": raw.get("bit_fields") or {},
        "scales": raw.get("scales") or {},
        "limits": raw.get("limits") or {},
        "messages": [
            [m.name, m.type_id, [[f.name, f.base, f.count, f.is_array] for f in m.fields]]
            for m in messages
        ],
    }
    digest = hashlib.sha256(
        json.dumps(canonical, sort_keys=True, separators=(",", ":")).encode()
    ).digest()
    return Schema(
        protocol_version=int(raw["protocol_version"]),
        max_payload=int(raw["max_payload"]),
        partial_timeout_us=int(raw["partial_timeout_us"]),
        enums={k: dict(v) for k, v in raw["enums"].items()},
        flags={k: dict(v) for k, v in raw["flags"].items()},
        bit_fields=bit_fields,
        scales=scales,
        limits=limits,
        defaults=defaults,
        messages=tuple(messages),
        schema_hash=int.from_bytes(digest[:4], "big"),
    )


def _camel(name: str) -> str:
    return "".join(part.capitalize() for part in name.lower().split("_"))


# --------------------------------------------------------------------- Python


def _py_annotation(f: Field) -> str:
    if f.base == "text":
        return "str"
    scalar = SCALARS[f.base][3]
    if f.is_array:
        return "tuple[" + ", ".join([scalar] * f.count) + "]"
    return scalar


def _py_default(f: Field) -> str:
    if f.base == "text":
        return '""'
    zero = "0.0" if f.base == "f32" else "0"
    if f.is_array:
        return "(" + ", ".join([zero] * f.count) + ("," if f.count == 1 else "") + ")"
    return zero


def _py_message(m: Message) -> list[str]:
    cls = m.class_name
    const = f"_{m.name.upper()}"
    text = m.text_field
    fixed = [f for f in m.fields if f.base != "text"]
    out = [
        "",
        "",
        "@dataclass(frozen=True, slots=True)",
        f"class {cls}:",
        f'    """{m.doc or m.name}"""',
        "",
        f"    TYPE: ClassVar[int] = {m.type_id:#04x}",
        f"    NAME: ClassVar[str] = {m.name!r}",
        f"    SIZE: ClassVar[int] = {m.fixed_size}",
    ]
    for f in m.fields:
        out.append(f"    {f.name}: {_py_annotation(f)} = {_py_default(f)}")
    # pack
    out += ["", "    def pack(self) -> bytes:", '        """Payload bytes of this message."""']
    args: list[str] = []
    for f in fixed:
        args.append(f"*self.{f.name}" if f.is_array else f"self.{f.name}")
    head = f"{const}.pack({', '.join(args)})" if fixed else 'b""'
    if text:
        out += [
            f'        text = self.{text.name}.encode("utf-8")',
            f"        if len(text) > {text.count}:",
            f'            raise ValueError(f"{text.name} is {{len(text)}} bytes, at most {text.count}")',  # noqa: E501
            f"        return {head} + text",
        ]
    else:
        out.append(f"        return {head}")
    # unpack
    out += [
        "",
        "    @classmethod",
        f"    def unpack(cls, payload: Buffer) -> {cls}:",
        '        """Decode a payload; missing trailing bytes read as zero, extra bytes are ignored."""',  # noqa: E501
    ]
    if not fixed and not text:
        out.append("        return cls()")
        return out
    if fixed:
        out += [
            f"        if len(payload) < {m.fixed_size}:",
            f"            payload = bytes(payload) + bytes({m.fixed_size} - len(payload))",
            f"        v = {const}.unpack_from(payload)",
        ]
    ctor: list[str] = []
    i = 0
    for f in fixed:
        if f.is_array:
            items = ", ".join(f"v[{i + k}]" for k in range(f.count))
            ctor.append(f"({items}{',' if f.count == 1 else ''})")
            i += f.count
        else:
            ctor.append(f"v[{i}]")
            i += 1
    if text:
        ctor.append(f'bytes(payload[{m.fixed_size}:]).decode("utf-8", "replace")')
    out.append(f"        return cls({', '.join(ctor)})")
    return out


def _number(v: float) -> str:
    return str(int(v)) if float(v).is_integer() and abs(v) >= 1 else repr(float(v))


def _py_constants(s: Schema) -> list[str]:
    """Bit fields (shifts and getters), scales, limits and defaults as module constants."""
    lines: list[str] = [""]
    for fields in s.bit_fields.values():
        lines += [f"{k}_SHIFT = {shift}" for k, (shift, _) in fields.items()]
    for k, v in s.scales.items():
        value = f"({', '.join(repr(float(x)) for x in v)})" if isinstance(v, tuple) else repr(v)
        lines.append(f"{k.upper()} = {value}")
    for k, (lo, hi) in s.limits.items():
        integral = float(lo).is_integer() and float(hi).is_integer() and abs(hi) >= 1
        pair = (_number(lo), _number(hi)) if integral else (repr(lo), repr(hi))
        lines.append(f"{k.upper()}_RANGE = ({pair[0]}, {pair[1]})")
    lines += [f"{k.upper()}_DEFAULT = {v}" for k, v in s.defaults.items()]
    for word, fields in s.bit_fields.items():
        for k, (shift, bits) in fields.items():
            lines += [
                "",
                "",
                f"def {k.lower()}(flags: int) -> int:",
                f'    """{k} of a {word} word: bits {shift}-{shift + bits - 1}."""',
                f"    return (flags >> {shift}) & {(1 << bits) - 1:#x}",
            ]
    return lines


def render_python(s: Schema) -> str:
    lines = [
        f'"""Message classes generated from protocol/schema.yaml (schema {s.schema_hash:#010x}).',
        "",
        "Do not edit: change the schema and run ``python -m jackson.protocol.codegen``.",
        '"""',
        "",
        "from __future__ import annotations",
        "",
        "import enum",
        "import struct",
        "from dataclasses import dataclass",
        "from typing import ClassVar",
        "",
        "Buffer = bytes | bytearray | memoryview",
        "",
        f"PROTOCOL_VERSION = {s.protocol_version}",
        f"SCHEMA_HASH = {s.schema_hash:#010x}",
        f"MAX_PAYLOAD = {s.max_payload}",
        f"PARTIAL_TIMEOUT_US = {s.partial_timeout_us}",
    ]
    for name, values in s.enums.items():
        lines += ["", "", f"class {_camel(name)}(enum.IntEnum):", f'    """{name} values."""', ""]
        lines += [f"    {k} = {v}" for k, v in values.items()]
    for name, bits in s.flags.items():
        lines += ["", "", f"class {_camel(name)}(enum.IntFlag):", f'    """{name} bits."""', ""]
        lines += [f"    {k} = 1 << {v}" for k, v in bits.items()]
    lines += _py_constants(s)
    lines.append("")
    for m in s.messages:
        if m.fields and any(f.base != "text" for f in m.fields):
            lines.append(f'_{m.name.upper()} = struct.Struct("{m.struct_format}")')
    for m in s.messages:
        lines += _py_message(m)
    union = "\n    | ".join(m.class_name for m in s.messages)
    lines += [
        "",
        "",
        f"Message = (\n    {union}\n)",
        "",
        "MESSAGES: dict[int, type[Message]] = {",
        *[f"    {m.class_name}.TYPE: {m.class_name}," for m in s.messages],
        "}",
        '"""Message class by TYPE id."""',
        "",
    ]
    return "\n".join(lines)


# ------------------------------------------------------------------------ C++


def _cpp_type(f: Field) -> str:
    if f.base == "text":
        return f"Text<{f.count}>"
    scalar = SCALARS[f.base][2]
    return f"std::array<{scalar}, {f.count}>" if f.is_array else scalar


def _cpp_message(m: Message) -> list[str]:
    text = m.text_field
    max_size = m.fixed_size + (text.count if text else 0)
    out = [
        f"/// {m.doc or m.name}",
        f"struct {m.class_name} {{",
        f"  static constexpr uint8_t kType = {m.type_id:#04x};",
        f'  static constexpr const char* kName = "{m.name}";',
        f"  static constexpr size_t kSize = {m.fixed_size};  ///< fixed part, bytes",
        f"  static constexpr size_t kMaxSize = {max_size};",
    ]
    for f in m.fields:
        init = "{}" if (f.is_array or f.base == "text") else " = 0"
        out.append(f"  {_cpp_type(f)} {f.name}{init};")
    out += [
        "",
        "  /// Writes the payload to `out` (at least kMaxSize bytes); returns its length.",
        "  size_t encode(uint8_t* out) const noexcept {",
        "    size_t o = 0;",
    ]
    for f in m.fields:
        out.append(f"    o += wire::put(out + o, {f.name});")
    out += [
        "    (void)out;",
        "    return o;",
        "  }",
        "",
        "  /// Reads a payload; missing trailing bytes read as zero, extra bytes are ignored.",
        "  void decode(const uint8_t* in, size_t n) noexcept {",
        "    uint8_t buf[kSize + 1] = {};",
        "    std::memcpy(buf, in, n < kSize ? n : kSize);",
        "    size_t o = 0;",
    ]
    for f in m.fields:
        if f.base == "text":
            out.append(
                f"    {f.name}.assign(n > kSize ? in + kSize : in, n > kSize ? n - kSize : 0);"
            )
        else:
            out.append(f"    o += wire::get(buf + o, {f.name});")
    out += ["    (void)buf;", "    (void)o;", "  }", ""]
    for const in ("", " const"):
        out += ["  template <class F>", f"  void for_each_field(F&& f){const} {{"]
        out += [f'    f("{f.name}", {f.name});' for f in m.fields]
        out += ["    (void)f;", "  }"]
    out += ["};", ""]
    return out


def render_cpp(s: Schema) -> str:
    lines = [
        f"// Message structs generated from protocol/schema.yaml (schema {s.schema_hash:#010x}).",
        "// Do not edit: change the schema and run `python -m jackson.protocol.codegen`.",
        "#pragma once",
        "",
        "#include <array>",
        "#include <cstddef>",
        "#include <cstdint>",
        "#include <cstring>",
        "",
        '#include "jackson/protocol/wire.hpp"',
        "",
        "namespace jackson::protocol {",
        "",
        f"constexpr uint8_t kProtocolVersion = {s.protocol_version};",
        f"constexpr uint32_t kSchemaHash = {s.schema_hash:#010x}u;",
        f"constexpr size_t kMaxPayload = {s.max_payload};",
        f"constexpr uint32_t kPartialTimeoutUs = {s.partial_timeout_us};",
        "",
    ]
    for name, values in s.enums.items():
        lines.append(f"enum class {_camel(name)} : uint8_t {{")
        lines += [f"  k{_camel(k)} = {v}," for k, v in values.items()]
        lines += ["};", ""]
    for name, bits in s.flags.items():
        lines.append(f"namespace {name} {{")
        lines += [f"constexpr uint16_t k{_camel(k)} = 1u << {v};" for k, v in bits.items()]
        for k, (shift, width) in s.bit_fields.get(name, {}).items():
            lines += [
                f"constexpr unsigned k{_camel(k)}Shift = {shift};",
                f"/// {k}: bits {shift}-{shift + width - 1}.",
                f"constexpr uint8_t {k.lower()}(uint16_t flags) noexcept {{",
                f"  return static_cast<uint8_t>((flags >> {shift}) & {(1 << width) - 1:#x}u);",
                "}",
            ]
        lines += [f"}}  // namespace {name}", ""]
    for k, v in s.scales.items():
        if isinstance(v, tuple):
            items = ", ".join(f"{float(x)!r}f" for x in v)
            lines.append(f"constexpr std::array<float, {len(v)}> k{_camel(k)} = {{{items}}};")
        else:
            lines.append(f"constexpr float k{_camel(k)} = {float(v)!r}f;")
    for k, (lo, hi) in s.limits.items():
        integral = float(lo).is_integer() and float(hi).is_integer() and abs(hi) >= 1
        ctype, suffix = ("int32_t", "") if integral else ("float", "f")
        lo_s, hi_s = (_number(lo), _number(hi)) if integral else (f"{lo!r}", f"{hi!r}")
        lines.append(f"constexpr {ctype} k{_camel(k)}Min = {lo_s}{suffix};")
        lines.append(f"constexpr {ctype} k{_camel(k)}Max = {hi_s}{suffix};")
    lines += [f"constexpr int32_t k{_camel(k)}Default = {v};" for k, v in s.defaults.items()]
    lines.append("")
    for m in s.messages:
        lines += _cpp_message(m)
    lines += [
        "/// True for every TYPE id the schema defines.",
        "constexpr bool is_known_type(uint8_t type) noexcept {",
        "  switch (type) {",
        *[f"    case {m.class_name}::kType:" for m in s.messages],
        "      return true;",
        "    default:",
        "      return false;",
        "  }",
        "}",
        "",
        "/// Schema name of a TYPE id, or nullptr.",
        "constexpr const char* message_name(uint8_t type) noexcept {",
        "  switch (type) {",
        *[f"    case {m.class_name}::kType: return {m.class_name}::kName;" for m in s.messages],
        "    default: return nullptr;",
        "  }",
        "}",
        "",
        "/// Decodes a payload of TYPE `type` into its struct and calls `v(msg)`.",
        "/// Returns false (and calls nothing) for an unknown type.",
        "template <class V>",
        "bool visit_message(uint8_t type, const uint8_t* payload, size_t n, V&& v) {",
        "  switch (type) {",
    ]
    for m in s.messages:
        lines += [
            f"    case {m.class_name}::kType: {{",
            f"      {m.class_name} msg;",
            "      msg.decode(payload, n);",
            "      v(msg);",
            "      return true;",
            "    }",
        ]
    lines += [
        "    default:",
        "      return false;",
        "  }",
        "}",
        "",
        "}  // namespace jackson::protocol",
        "",
    ]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="fail if a generated file is stale")
    args = parser.parse_args(argv)
    try:
        schema = load_schema()
    except (SchemaError, KeyError, OSError, yaml.YAMLError) as exc:
        print(f"codegen: {SCHEMA_PATH.name}: {exc}", file=sys.stderr)
        return 2
    stale = []
    for path, text in ((PY_OUT, render_python(schema)), (CPP_OUT, render_cpp(schema))):
        current = path.read_text(encoding="utf-8") if path.exists() else None
        if current == text:
            continue
        if args.check:
            stale.append(path.relative_to(PROTOCOL_DIR.parent))
        else:
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(text, encoding="utf-8")
            print(f"codegen: wrote {path.relative_to(PROTOCOL_DIR.parent)}")
    if stale:
        names = ", ".join(str(p) for p in stale)
        print(
            f"codegen: {names} out of date with protocol/schema.yaml; "
            "run `python -m jackson.protocol.codegen` and commit the result",
            file=sys.stderr,
        )
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
