"""The Python API gives what the command line gives: the README's Python example (character,
controller, scenario, gait analysis) reproduces ``mjchar gait`` number for number with no time
step set by hand, and ``mjchar.controllers.run`` reproduces ``mjchar run``."""

from __future__ import annotations

import contextlib
import io
import json
import re
from pathlib import Path

import pytest

from mjchar.cli import main

README = Path(__file__).resolve().parents[1] / "README.md"


def _readme_example() -> str:
    text = README.read_text()
    m = re.search(r"<!-- python-example[^>]*-->\s*```python\n(.*?)```", text, re.S)
    assert m, "the README's Python example is marked with <!-- python-example -->"
    return m.group(1)


def _cli_json(argv, capsys) -> dict:
    assert main(argv) == 0
    return json.loads(capsys.readouterr().out)


def test_the_readme_python_example_reproduces_mjchar_gait(capsys):
    out = io.StringIO()
    scope: dict = {}
    with contextlib.redirect_stdout(out):
        exec(compile(_readme_example(), str(README), "exec"), scope)
    printed = out.getvalue().strip()
    cli = _cli_json(["gait", "simbicon", "--gait", "natural", "--speed", "1.2", "--json"],
                    capsys)["source"]
    expected = (f"{cli['trunk_lean_deg']:.1f} deg lean, {cli['cadence_spm']:.1f} steps/min, "
                f"{cli['speed_mps']:.2f} m/s")
    assert printed == expected
    gait = scope["gait"]  # the same walk, not only the same rounding
    assert gait.trunk_lean_deg == pytest.approx(cli["trunk_lean_deg"], abs=1e-9)
    assert gait.cadence_spm == pytest.approx(cli["cadence_spm"], abs=1e-9)
    assert gait.speed_mps == pytest.approx(cli["speed_mps"], abs=1e-9)
    assert scope["character"].timestep == 0.001  # SIMBICON's registered step, applied for us
    assert 5.0 < gait.trunk_lean_deg < 10.0  # the natural gait's lean (2 ms gave 18 deg)


def test_run_reproduces_mjchar_run(capsys):
    from mjchar.controllers import run

    cli = _cli_json(["run", "ipm", "--scenario", "push", "--push", "100", "--direction", "left",
                     "--json"], capsys)
    r = run("ipm", "push", force=100.0, direction=90.0).to_dict()
    for key in ("fell", "sim_time_s", "distance_m", "com_drop_m", "foot_travel_m",
                "max_push_N", "timestep_s"):
        assert r[key] == cli[key], key


def test_run_routes_options_and_refuses_unknown_ones():
    from mjchar.bvh.errors import MjcharError
    from mjchar.controllers import RunError, run

    with pytest.raises(RunError, match="'speeed' is neither an option of static_balance nor"):
        run("static_balance", "stand", speeed=1.0)
    with pytest.raises(MjcharError, match="speeed"):  # ipm's own tunables are checked by it
        run("ipm", "walk", speeed=1.0, duration=0.1)
    with pytest.raises(RunError, match="simbicon does not run the stand scenario"):
        run("simbicon", "stand")
    with pytest.raises(RunError, match="walks at 0 to 1.6 m/s"):
        run("ipm", "walk", speed=9.0, duration=0.1)
