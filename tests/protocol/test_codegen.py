"""The schema is the single source of truth: generated code must match it."""

from __future__ import annotations

from pathlib import Path

import pytest

from jackson.protocol import SCHEMA_HASH, Telemetry
from jackson.protocol.codegen import (
    CPP_OUT,
    PY_OUT,
    SCHEMA_PATH,
    SchemaError,
    load_schema,
    render_cpp,
    render_python,
)


def test_generated_files_are_up_to_date() -> None:
    schema = load_schema()
    assert PY_OUT.read_text() == render_python(schema), "run python -m jackson.protocol.codegen"
    assert CPP_OUT.read_text() == render_cpp(schema), "run python -m jackson.protocol.codegen"


def test_schema_hash_is_in_both_generated_files() -> None:
    assert load_schema().schema_hash == SCHEMA_HASH
    assert f"kSchemaHash = {SCHEMA_HASH:#010x}u" in CPP_OUT.read_text()


def test_docs_do_not_change_the_hash_but_layout_does(tmp_path: Path) -> None:
    text = SCHEMA_PATH.read_text()
    reworded = tmp_path / "reworded.yaml"
    reworded.write_text(text.replace("MCU clock at sampling", "time of the sample"))
    assert load_schema(reworded).schema_hash == SCHEMA_HASH
    widened = tmp_path / "widened.yaml"
    widened.write_text(text.replace("{name: temp, type: i16", "{name: temp, type: i32", 1))
    assert load_schema(widened).schema_hash != SCHEMA_HASH


def test_struct_layout_matches_the_schema_sizes() -> None:
    sizes = {m.name: m.fixed_size for m in load_schema().messages}
    assert sizes["telemetry"] == Telemetry.SIZE == 28


def test_text_must_be_the_last_field(tmp_path: Path) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text(
        SCHEMA_PATH.read_text().replace(
            '- {name: text, type: "text[100]", doc: UTF-8}',
            '- {name: text, type: "text[100]", doc: UTF-8}\n      - {name: extra, type: u8}',
        )
    )
    with pytest.raises(SchemaError, match="last field"):
        load_schema(bad)
