"""Human-readable output is rounded to what each unit needs; ``--json`` keeps every digit."""

from __future__ import annotations

import json
import re

from mjchar.cli import main
from mjchar.controllers.core.metrics import readable


def test_readable_rounds_by_unit():
    assert readable("min_root_height_m", 0.8709750797498103) == 0.871
    assert readable("trajectory_duration_s", 3.0199999) == 3.02
    assert readable("push_N", 123.456) == 123.5
    assert readable("ratio", 0.123456789) == 0.1235
    assert readable("method", "samcon") == "samcon"
    assert readable("per_direction_m", {"forward_m": 1.23456}) == {"forward_m": 1.235}


def test_the_summary_has_no_raw_floats_and_json_keeps_them(capsys):
    assert main(["run", "samcon_replay", "--duration", "1"]) == 0
    out = capsys.readouterr().out
    assert "no fall in 1 s" in out
    assert not re.search(r"\d\.\d{5,}", out), out
    assert main(["run", "samcon_replay", "--duration", "1", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert len(repr(doc["extra"]["min_root_height_m"])) > 8  # every digit
