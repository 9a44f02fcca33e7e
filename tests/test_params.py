"""``mjchar params``: what it lists is what ``--param`` takes, read from the declarations that
check the values (no second list): every row names a tunable its controller accepts with the
listed default, has a meaning, and its range refuses what lies outside it."""

from __future__ import annotations

import json

import pytest

from mjchar.cli import main
from mjchar.controllers import registry
from mjchar.controllers.core.param_fields import REFUSED

WITH_PARAMS = [s.name for s in registry.specs() if "params" in s.options]


def test_every_controller_taking_params_lists_them():
    assert set(WITH_PARAMS) == {"simbicon", "ipm", "mpc"}
    assert all(registry.get(n).tunables is not None for n in WITH_PARAMS)
    assert all(s.tunables is None for s in registry.specs() if s.name not in WITH_PARAMS)


@pytest.mark.parametrize("name", WITH_PARAMS)
def test_rows_have_a_type_a_meaning_and_an_accepted_default(name):
    rows = registry.get(name).tunables()
    assert len({t.name for t in rows}) == len(rows)
    for t in rows:
        assert t.meaning and t.spec.type_name(), t.name
        if t.default is not None:
            assert t.spec.coerce(t.default) is not REFUSED, t.name


@pytest.mark.parametrize("name", WITH_PARAMS)
def test_every_listed_name_is_taken_with_its_default(name):
    """Each listed tunable, given its listed default, is accepted by the controller's factory
    (the listing is what --param takes)."""
    spec = registry.get(name)
    for t in spec.tunables():
        if t.default is None:
            continue
        value = list(t.default) if isinstance(t.default, tuple) else t.default
        spec.factory(None, None, **{t.name: value})


@pytest.mark.parametrize("name", WITH_PARAMS)
def test_a_value_beyond_a_listed_bound_is_refused(name):
    from mjchar.bvh.errors import MjcharError

    spec = registry.get(name)
    numbers = [t for t in spec.tunables() if t.spec.kind == "number" and t.spec.size == 0
               and t.spec.high is not None]
    for t in numbers[:12]:
        with pytest.raises(MjcharError, match=t.name):
            spec.factory(None, None, **{t.name: t.spec.high * 2 + 1})


def test_the_command_prints_a_table_and_json(capsys):
    assert main(["params", "ipm"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("ipm: 79 tunables")
    assert out[1].split()[:6] == ["NAME", "TYPE", "UNIT", "RANGE", "DEFAULT", "MEANING"]
    assert out[2].split()[0] == "timing.step_time"
    assert main(["params", "simbicon", "--gait", "natural", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    row = next(r for r in doc["tunables"] if r["name"] == "torso_pitch")
    assert row["default"] == 0.3677 and row["unit"] == "rad" and row["type"] == "number"
    assert main(["params", "mpc", "--gait", "walk"]) == 2
    assert "--gait applies to controllers with gaits" in capsys.readouterr().err


def test_run_help_points_to_params(capsys):
    with pytest.raises(SystemExit):
        main(["run", "--help"])
    assert "mjchar params CONTROLLER" in " ".join(capsys.readouterr().out.split())
