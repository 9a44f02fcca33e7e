"""``mjchar run`` refuses what does not apply: every option a controller x scenario does not use
is a one-line error with exit status 2 (the whole matrix), and so is every value outside what the
controller supports. Nothing is silently ignored."""

from __future__ import annotations

import pytest

from mjchar.bvh.bundled.assets import TRAJECTORIES, motion_path
from mjchar.cli import main
from mjchar.commands.run_options import check_applicable, options
from mjchar.controllers import registry
from mjchar.controllers.core.scenarios import registry as scenarios

OPTIONS = options()
#: the push's details, which need the push in the moving scenarios
PUSH_DETAILS = ("direction", "push_time", "push_duration")
#: a valid value for each option (flags take none)
VALUES = {
    "speed": "0.5", "heading": "10", "gait": "walk", "tracker": "spd", "squat": "0.1",
    "motion": str(motion_path("walk")), "floor": "clip", "duration": "1", "force": "50",
    "direction": "left", "push_duration": "0.2", "push_time": "0.5", "allow_steps": None,
    "max_force": "100", "tolerance": "50", "phases": "2", "seeds": "1", "seed": "1",
    "timestep": "0.001", "control_dt": "0.002", "render": "x.mp4", "export_bvh": "x.bvh",
    "loop": None, "param": "samples=8", "steady_window": "2", "degrees": "3",
    "distance": "5", "view": None, "calibration": "none",
}


def _base(spec, scenario: str) -> list[str]:
    args = ["run", spec.name]
    if spec.name == "replay":
        args.append(str(TRAJECTORIES / "samcon_walk60.npz"))
    return args + ["--scenario", scenario]


def _typed(opt) -> list[str]:
    value = VALUES[opt.dest]
    return [opt.flag] if value is None else [opt.flag, value]


def _matrix(applies: bool):
    cases = []
    for spec in registry.specs():
        for scenario in spec.scenarios():
            for opt in OPTIONS:
                if opt.applies(spec, scenarios.get(scenario)) == applies:
                    cases.append(pytest.param(spec, scenario, opt,
                                              id=f"{spec.name}-{scenario}-{opt.dest}"))
    return cases


def _one_line_error(capsys, argv) -> str:
    code = main(argv)
    assert code == 2, f"exit {code} for {' '.join(argv)}"
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    return err


def test_every_option_is_in_the_table():
    """The table covers every option of `mjchar run` but the always-valid ones."""
    from mjchar.cli import build_parser

    sub = next(a for a in build_parser()._actions if a.dest == "command")
    dests = {a.dest for a in sub.choices["run"]._actions}
    covered = {o.dest for o in OPTIONS} | {"fps", "export_fps"}
    always = {"help", "controller", "trajectory", "scenario", "model", "json"}
    assert dests - always == covered
    assert set(VALUES) == {o.dest for o in OPTIONS}


@pytest.mark.parametrize("spec,scenario,opt", _matrix(applies=False))
def test_an_option_that_does_not_apply_is_refused(spec, scenario, opt, capsys):
    err = _one_line_error(capsys, _base(spec, scenario) + _typed(opt))
    assert f"{opt.flag} does not apply to {spec.name} in the {scenario} scenario" in err


@pytest.mark.parametrize("spec,scenario,opt", _matrix(applies=True))
def test_an_option_that_applies_passes_the_check(spec, scenario, opt):
    """The same table lets through what is used (the runs themselves are tested elsewhere)."""
    import argparse

    args = argparse.Namespace(**{o.dest: None for o in OPTIONS}, fps=None, export_fps=None)
    setattr(args, opt.dest, VALUES[opt.dest] or True)
    sspec = scenarios.get(scenario)
    if opt.dest in PUSH_DETAILS and sspec.moving:
        args.force = "50"                          # a push's details need the push there
    check_applicable(args, spec, sspec)


@pytest.mark.parametrize("argv,needle", [
    (["run", "hand_of_god", "--direction", "left"], "needs --push N"),
    (["run", "simbicon", "--push-time", "2"], "needs --push N"),
    (["run", "spd", "--fps", "10"], "--fps needs --render"),
    (["run", "spd", "--export-fps", "10"], "--export-fps needs --export-bvh"),
])
def test_refinements_need_their_option(argv, needle, capsys):
    assert needle in _one_line_error(capsys, argv)


@pytest.mark.parametrize("argv,needle", [
    (["run", "ipm", "--speed", "1e9"], "ipm walks at 0 to 1.6 m/s"),
    (["run", "simbicon", "--scenario", "stand"], "simbicon does not run the stand scenario"),
    (["run", "ipm", "--scenario", "push", "--speed", "1"],
     "--speed does not apply to ipm in the push scenario"),
    (["run", "ipm", "--speed", "-0.5"], "ipm walks at 0 to 1.6 m/s"),
    (["run", "ipm", "--heading", "1e4"], "--heading 10000 is out of range"),
    (["run", "static_balance", "--scenario", "push", "--push", "1e6"], "body weights"),
    (["run", "static_balance", "--scenario", "push-search", "--max-force", "1e6"],
     "body weights"),
    (["run", "static_balance", "--scenario", "push-search", "--max-force", "100",
      "--tolerance", "200"], "must not exceed --max-force"),
    (["run", "static_balance", "--scenario", "push", "--push", "50", "--push-time", "9"],
     "must start within the 4 s run"),
    (["run", "static_balance", "--scenario", "push", "--push", "50", "--push-time", "3",
      "--duration", "2"], "must start within the 2 s run"),
    (["run", "static_balance", "--squat", "5"], "standing height"),
    (["run", "static_balance", "--duration", "1e7"], "at most 3600"),
    (["run", "static_balance", "--timestep", "0.5"], "at most 0.01 s"),
    (["run", "static_balance", "--timestep", "0.002", "--control-dt", "0.001"],
     "shorter than the physics step"),
    (["run", "static_balance", "--export-bvh", "out.txt"], "give a .bvh path"),
    (["run", "static_balance", "--export-bvh", "/no/such/folder/x.bvh"], "does not exist"),
    (["run", "static_balance", "--render", "x.mp4", "--fps", "5000"], "at most 1000"),
    (["run", "replay", str(TRAJECTORIES / "samcon_walk60.npz"), "--scenario", "push",
      "--push", "100"], "replay does not run the push scenario"),
    (["run", "spd", str(TRAJECTORIES / "samcon_walk60.npz")], "only the replays"),
])
def test_values_outside_what_the_controller_supports(argv, needle, capsys):
    assert needle in _one_line_error(capsys, argv)


def test_nan_speed_is_an_argument_error(capsys):
    with pytest.raises(SystemExit) as e:
        main(["run", "ipm", "--speed", "nan"])
    assert e.value.code == 2
    assert "finite" in capsys.readouterr().err


def test_speed_limits_come_from_the_registry():
    spec = registry.get("ipm")
    assert spec.limit("speed") == (0.0, 1.6)
    assert registry.get("static_balance").limit("speed") is None


def test_speed_limits_scale_with_the_body():
    """Walkers register their speed limits on one body; on a body of leg length L they are the
    same Froude speeds, times sqrt(L / speed_leg_length), rounded outward to 0.01 m/s and
    widened to what was measured on every body (SIMBICON: 0.7-1.5 m/s on every zoo rig)."""
    ipm, sim = registry.get("ipm"), registry.get("simbicon")
    assert sim.limit("speed") == (0.6, 1.6)  # the measured range, on the bundled humanoid
    for spec in (ipm, sim):
        assert spec.limit("speed", spec.speed_leg_length) == spec.limit("speed")
    assert ipm.limit("speed", 4.0 * ipm.speed_leg_length) == (0.0, 3.2)
    assert ipm.limit("speed", 0.9 * ipm.speed_leg_length) == (0.0, 1.52)  # 1.5179 outward
    assert sim.limit("speed", 4.0 * sim.speed_leg_length) == (0.7, 3.2)  # 1.2 widened to 0.7
    assert sim.limit("speed", 0.64 * sim.speed_leg_length) == (0.48, 1.5)  # 1.28 widened
    assert sim.limit("speed", 0.99 * sim.speed_leg_length) == (0.59, 1.6)  # 0.597, 1.592 outward
    assert registry.get("static_balance").limit("speed", 1.0) is None


def test_leg_length_follows_the_body(zoo_humanoids):
    from mjchar.controllers.core.character import Character
    from mjchar.controllers.walking.gaits import BUNDLED_LEG_LENGTH

    assert Character().poses.leg_length() == pytest.approx(BUNDLED_LEG_LENGTH, abs=1e-9)
    small, tall = (Character(zoo_humanoids[h]).poses.leg_length() for h in (1.5, 1.95))
    assert 0.7 < small < tall < 1.2
    assert tall / small == pytest.approx(1.95 / 1.5, rel=1e-3)  # one skeleton, scaled


def test_speed_range_on_another_body_is_checked_in_its_units(zoo_humanoids, capsys):
    """The 1.95 m body's SIMBICON range is 0.66-1.77 m/s: 0.62 m/s, inside the bundled
    humanoid's 0.6-1.6, is refused on it, naming the body's range; 1.7 m/s is taken."""
    from mjchar.controllers.core.character import Character

    xml = zoo_humanoids[1.95]
    leg = Character(xml).poses.leg_length()
    assert registry.get("simbicon").limit("speed", leg) == (0.66, 1.77)
    expected = "walks at 0.66 to 1.77 m/s on this body (leg length 1.06 m; 0.6 to 1.6 m/s"
    for command in ("run", "gait"):
        argv = [command, "simbicon", "--model", xml, "--speed", "0.62"]
        assert expected in _one_line_error(capsys, argv)
    assert main(["run", "simbicon", "--model", xml, "--speed", "1.7", "--duration", "0.2"]) == 0


@pytest.mark.parametrize("argv,scenario", [
    (["run", "mpc", "track"], "track"),
    (["run", "ipm", "stand"], "stand"),
    (["run", "ipm", "walk", "--scenario", "walk"], "walk"),
])
def test_a_scenario_word_after_the_controller_is_the_scenario(argv, scenario):
    from mjchar.cli import build_parser
    from mjchar.commands.run import describe

    assert describe(build_parser().parse_args(argv)).scenario == scenario


@pytest.mark.parametrize("argv,needle", [
    (["run", "simbicon", "stand"], "simbicon does not run the stand scenario"),
    (["run", "mpc", "track", "--scenario", "stand"], "only the replays"),
])
def test_a_scenario_word_is_checked_like_the_option(argv, needle, capsys):
    assert needle in _one_line_error(capsys, argv)
