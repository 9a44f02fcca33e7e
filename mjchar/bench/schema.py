"""The results document's JSON Schema (``mjchar/bench/schema.json``, shipped with the package)
and validation against it (with the ``jsonschema`` library, Draft 2020-12)."""

from __future__ import annotations

import json
import os
from pathlib import Path

from .config import SCHEMA_PATH, BenchError


def load_schema(path: str | os.PathLike | None = None) -> dict:
    """The documented schema (``mjchar/bench/schema.json``)."""
    p = Path(SCHEMA_PATH if path is None else path)
    try:
        return json.loads(p.read_text())
    except (OSError, ValueError) as e:
        raise BenchError(f"cannot read the bench schema {p}: {e}") from None


def validate(doc, schema: dict | None = None) -> list[str]:
    """Errors of ``doc`` against ``schema`` (default :func:`load_schema`), one line each naming
    where (``$.cells[0].runs``) and what; empty when valid."""
    try:
        from jsonschema import Draft202012Validator
    except ImportError:
        raise BenchError("validating a results document needs jsonschema: "
                         'pip install "mjchar[bench]"') from None
    schema = load_schema() if schema is None else schema
    validator = Draft202012Validator(schema)
    return [f"{e.json_path}: {e.message}"
            for e in sorted(validator.iter_errors(doc), key=lambda e: list(e.absolute_path))]
