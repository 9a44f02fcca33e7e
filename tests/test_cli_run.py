"""``mjchar run``: one JSON object with --json, readable summaries, one-line errors with a
non-zero exit for malformed options, and --render writing an MP4."""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import shared_clip

from mjchar.cli import main
from mjchar.controllers.core.scenarios import registry as scenarios

ROOT = Path(__file__).resolve().parents[1]


def mjchar(*args: str, timeout: float = 300) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return subprocess.run([sys.executable, "-m", "mjchar", *args], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=timeout)


def test_static_balance_json_is_exactly_one_object():
    p = mjchar("run", "static_balance", "--json")
    assert p.returncode == 0, p.stderr
    out = json.loads(p.stdout)  # the whole stdout is one JSON document
    assert isinstance(out, dict) and p.stdout.strip().count("\n") == 0
    assert out["controller"] == "static_balance" and out["scenario"] == "stand"
    assert out["fell"] is False and out["sim_time_s"] == pytest.approx(10.0)
    assert out["root_force_mean_N"] == 0.0
    for key in ("fall_time_s", "distance_m", "mean_speed_mps", "tracking_error_m",
                "max_push_N", "wall_s", "steps_per_s", "seed"):
        assert key in out


@pytest.mark.parametrize("args,needle", [
    (["run", "static_balance", "--duration", "abc"], "duration must be a number"),
    (["run", "static_balance", "--duration", "-2"], "duration must be positive"),
    (["run", "wobbly"], "invalid choice"),
    (["run", "spd", "--scenario", "dance"], "invalid choice"),
    (["run", "spd", "--seed", "x"], "seed must be an integer"),
    (["run", "spd", "--direction", "up"], "direction must be degrees"),
    (["run", "spd", "--scenario", "push"], "needs a force (mjchar run: --push"),
    (["run", "spd", "--scenario", "track", "--motion", "/no/such.bvh"], "/no/such.bvh"),
    (["run", "spd", "--render", "out.gif"], "give a .mp4 path"),
    (["run", "spd", "--floor", "lowest"], "invalid choice"),
])
def test_malformed_options_give_one_line_and_non_zero_exit(args, needle, capsys):
    with pytest.raises(SystemExit) as e:
        code = main(args)
        raise SystemExit(code)
    assert e.value.code != 0
    err = capsys.readouterr().err
    assert needle in err
    assert "Traceback" not in err
    assert len(err.strip().splitlines()) == 1


@pytest.mark.parametrize("args,needle", [
    # each controller's own validation sees the value: the tunable reached the factory
    (["run", "mpc", "--param", "samples=1"], "samples must be an integer >= 2"),
    (["run", "mpc", "--param", "plan_timestep=0.003"], "not a whole number"),
    (["run", "mpc", "--param", "sample=8"], "unknown MPC option(s) sample; valid: samples"),
    (["run", "ipm", "--param", "timing.step_time=-1"],
     "IPM parameter timing.step_time must be a finite number > 0 and <= 10 (s), got -1"),
    (["run", "ipm", "--param", "timing.stepp_time=0.5"],
     "unknown IPM parameter(s) timing.stepp_time (did you mean timing.step_time?); valid: "),
    (["run", "ipm", "--param", "step_time=0.5"],
     "step_time (did you mean timing.step_time, human.step_time?)"),
    (["run", "simbicon", "--param", "torso_pitchx=0.2"], "unknown gait parameter"),
    (["run", "ipm", "--param", "speed=1"], "give it as --speed"),
    (["run", "mpc", "--param", "samples"], "must be NAME=VALUE"),
    (["run", "mpc", "--param", "samples=8", "--param", "samples=9"], "given twice"),
    (["run", "spd", "--param", "samples=8"], "used by"),
])
def test_param_reaches_the_controller_or_is_refused_in_one_line(args, needle, capsys):
    try:
        code = main(args + ["--duration", "0.1"])
    except SystemExit as e:  # argparse's own errors
        code = e.code
    assert code == 2
    err = capsys.readouterr().err
    assert needle in err and "Traceback" not in err and len(err.strip().splitlines()) == 1


def test_param_values_are_json_or_text():
    from mjchar.commands.argtypes import assignment

    parse = assignment("--param")
    assert parse("samples=96") == ("samples", 96)
    assert parse("update=cem") == ("update", "cem")
    assert parse("swing.heights=[0.04, 0.1, 0.02]") == ("swing.heights", [0.04, 0.1, 0.02])
    assert parse("antithetic=true") == ("antithetic", True)
    for bad in ("timing..step_time=1", ".step_time=1", "timing.=1", "timing step=1"):
        with pytest.raises(argparse.ArgumentTypeError, match="must be NAME=VALUE"):
            parse(bad)


def test_param_changes_the_run(capsys):
    """A tunable typed on the command line changes what the controller does."""
    import json

    def steps(*extra):
        assert main(["run", "ipm", "--duration", "3", "--json", *extra]) == 0
        return json.loads(capsys.readouterr().out)["foot_travel_m"]

    assert steps() != pytest.approx(steps("--param", "timing.step_time=0.45"), rel=1e-3)


def test_malformed_option_in_a_subprocess():
    p = mjchar("run", "static_balance", "--push", "lots")
    assert p.returncode == 2
    assert p.stderr.strip().count("\n") == 0 and "Traceback" not in p.stderr


def test_summary_of_a_push(capsys):
    assert main(["run", "static_balance", "--scenario", "push", "--push", "50",
                 "--direction", "backward", "--duration", "2.5"]) == 0
    out = capsys.readouterr().out
    assert "static_balance / push: no fall in 2.5 s" in out
    assert "push 50.0 N, towards 180 deg" in out


def test_track_with_a_motion_file(capsys):
    clip = shared_clip("walk60.bvh")
    assert main(["run", "hand_of_god", "--motion", str(clip), "--json",
                 "--duration", "1.0"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["scenario"] == "track" and out["tracking_error_m"] < 0.05
    assert out["root_force_mean_N"] > 0


def test_floor_modes_place_the_reference(capsys):
    clip = str(shared_clip("walk60.bvh"))
    runs = {}
    for floor in ("clip", "frame", "contact"):
        assert main(["run", "hand_of_god", "--motion", clip, "--json", "--duration", "1.0",
                     "--floor", floor]) == 0
        runs[floor] = json.loads(capsys.readouterr().out)
    # another reference, so another run: both track it closely
    assert runs["clip"]["tracking_error_m"] != runs["frame"]["tracking_error_m"]
    assert max(r["tracking_error_m"] for r in runs.values()) < 0.05
    # a foot supports every frame of walk60: contact places it as frame does
    assert runs["contact"]["tracking_error_m"] == runs["frame"]["tracking_error_m"]
    # hand-of-god, which has a root force, follows the clip as recorded by default
    assert main(["run", "hand_of_god", "--motion", clip, "--json", "--duration", "1.0"]) == 0
    assert json.loads(capsys.readouterr().out)["tracking_error_m"] == \
        runs["clip"]["tracking_error_m"]


def test_run_offers_every_registered_controller_and_scenario(capsys):
    from mjchar.controllers.core import registry

    with pytest.raises(SystemExit):
        main(["run", "--help"])
    text = capsys.readouterr().out
    for name in registry.names():
        assert name in text
    for scenario in scenarios.names():
        assert scenario in text


def test_run_refuses_a_scenario_the_controller_does_not_support():
    assert main(["run", "simbicon", "--scenario", "track"]) == 2
    assert main(["run", "static_balance", "--scenario", "walk"]) == 2


def test_render_writes_an_mp4(tmp_path):
    pytest.importorskip("imageio_ffmpeg")
    out = tmp_path / "stand.mp4"
    p = mjchar("run", "native_pd", "--duration", "0.5", "--render", str(out), "--json")
    if p.returncode != 0 and "OpenGL" in p.stderr:
        pytest.skip(f"no OpenGL here: {p.stderr.strip()}")
    assert p.returncode == 0, p.stderr
    info = json.loads(p.stdout)
    assert info["video_frames"] == 16  # 30 fps over 0.5 s, first frame at t = 0
    assert out.is_file() and out.stat().st_size > 1000
    assert out.read_bytes()[4:8] == b"ftyp"  # an MP4 container


def test_push_search_reports_rates_over_the_grid(capsys):
    assert main(["run", "static_balance", "--scenario", "push-search", "--max-force", "100",
                 "--tolerance", "50", "--phases", "1", "--seeds", "1", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["protocol"]["forces"] == [50.0, 100.0] and out["protocol"]["phases"] == 1
    assert not out["falls_unpushed"]
    assert set(out["largest_100_N"]) == {"forward", "left", "backward", "right"}
    assert all(v in (0.0, 50.0, 100.0) for v in out["largest_100_N"].values())
    assert out["largest_100_N"]["forward"] == 100.0 and out["at_cap"]["forward"]
    assert "grid 50-100 N in 50 N steps" in out["description"]
