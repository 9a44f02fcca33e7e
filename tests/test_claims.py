"""The claims tier: every figure README.md states, asserted at the protocol the README states.

Run with ``python -m pytest -m claims`` (CI runs it after the default suite, on both cores:
``-n 2``). Each test names the README line it backs; ``tests/test_readme_claims.py`` checks that
every number in the README is covered by one of them. The protocols are the README's: pushes
of 0.2 s at 4 phases of the stride (walkers) or 4 moments (standing controllers) x 2 seeds in
the four directions; walks from the standing pose; the clips' full length.
"""

from __future__ import annotations

import pytest
from conftest import assert_no_root_help, shared_clip

from mjchar.bvh.gait import analyse, analyse_clip
from mjchar.controllers import Character, MotionRecorder, RunSpec, run
from mjchar.controllers.core.scenarios.push_search import PushProtocol, survival_rates

pytestmark = pytest.mark.claims

DIRECTIONS = ("forward", "left", "backward", "right")


def _protocol(force: float) -> PushProtocol:
    """The README's push protocol at one force: 0.2 s, 4 phases or moments x seeds 0 and 1,
    every direction, 5 s after the push (walkers: in the first stride after 4 s)."""
    return PushProtocol(forces=(float(force),), phases=4, seeds=(0, 1)).check()


def _survives_everywhere(run_spec, force: float) -> None:
    rates = survival_rates(run_spec, _protocol(force), processes=1)
    assert not rates.falls_unpushed, rates.summary()
    assert {d: rates.largest_100_N[d] for d in DIRECTIONS} == dict.fromkeys(DIRECTIONS, force), \
        rates.summary()


# "On the bundled humanoid (1.63 m, 70 kg)"
def test_the_bundled_humanoid_is_1_63_m_and_70_kg():
    ch = Character()
    assert round(ch.info.extra["height"], 2) == 1.63
    assert round(ch.dynamics.mass) == 70


# hand_of_god: "tracks walk60 within 2 cm"
def test_hand_of_god_tracks_walk60_within_2_cm():
    r = run("hand_of_god", "track", motion=shared_clip("walk60.bvh"))
    assert not r.fell and r.tracking_error_m < 0.02
    assert r.root_force_mean_N > 0  # the hand of god at work


# static_balance: "stands 30 s under 10 N random pushes"
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_static_balance_stands_30_s_under_10_N_random_pushes(seed):
    r = run("static_balance", "random-push", duration=30.0, seed=seed)
    assert r.push_N == 10.0 and r.sim_time_s == pytest.approx(30.0, abs=0.01)
    assert not r.fell
    assert_no_root_help(r)


# static_balance: "survives 100 N pushes in every direction"
def test_static_balance_survives_100_N_pushes_in_every_direction():
    _survives_everywhere(RunSpec("static_balance"), 100.0)


# simbicon: "walks 60 s in either gait"
@pytest.mark.parametrize("gait", ["walk", "natural"])
def test_simbicon_walks_60_s_in_either_gait(gait):
    r = run("simbicon", "walk", gait=gait, duration=60.0)
    assert not r.fell and r.sim_time_s == pytest.approx(60.0, abs=0.01)
    assert_no_root_help(r)
    assert r.distance_m > 30.0


# simbicon: "the walk gait survives 200 N pushes in every direction while walking"
def test_simbicon_walk_gait_survives_200_N_pushes_while_walking():
    _survives_everywhere(RunSpec("simbicon", options={"gait": "walk"}), 200.0)


# ipm: "walks 60 s at a commanded 1.0 m/s within 0.15 m/s"
def test_ipm_walks_60_s_at_1_m_s_within_0_15():
    r = run("ipm", "walk", speed=1.0, duration=60.0, steady_window=10.0)
    assert not r.fell
    assert_no_root_help(r)
    assert abs(r.extra["steady_speed_mps"] - 1.0) <= 0.15


# ipm: "recovers 150 N pushes by stepping"
def test_ipm_recovers_150_N_pushes_by_stepping():
    _survives_everywhere(RunSpec("ipm"), 150.0)


# samcon_replay, cmaes_replay: "replay walk60 within 5 cm and 3.5 cm"
@pytest.mark.parametrize("name,bar", [("samcon_replay", 0.05), ("cmaes_replay", 0.035)])
def test_saved_trajectories_replay_walk60(name, bar):
    r = run(name)
    assert not r.fell and r.tracking_error_m < bar
    assert_no_root_help(r)
    assert r.extra["source_motion"] == "walk60.bvh"


# mpc: "tracks walk60 within 2.5 cm"
def test_mpc_tracks_walk60_within_2_5_cm():
    r = run("mpc", "track", motion=shared_clip("walk60.bvh"))
    assert not r.fell and r.tracking_error_m < 0.025
    assert_no_root_help(r)


# the gait table: "at 1.2 m/s | cadence | step | width | lean | knee | slip", three rows
GAIT_TABLE = {  # label: (cadence /min, step m, width m, lean deg, knee deg, slip cm/step)
    "simbicon natural": (121, 0.59, 0.115, 7.3, 19.4, 0.86),
    "ipm": (120, 0.57, 0.139, 1.8, 32.7, 0.80),
    "walk60": (100, 0.72, 0.06, 4.0, 25.3, 2.8),
}


def _row(stats) -> tuple:
    return (stats.cadence_spm, stats.step_length_m, stats.step_width_m, stats.trunk_lean_deg,
            stats.knee_flexion_deg, 100.0 * stats.stance_slip_m)


def _as_printed(values, printed) -> tuple:
    """``values`` rounded to the decimals of the README's ``printed`` figures."""
    def decimals(x) -> int:
        text = repr(float(x)) if not isinstance(x, int) else str(x)
        return 0 if isinstance(x, int) else len(text.split(".")[1])
    return tuple(round(v, decimals(p)) if decimals(p) else round(v) for v, p in
                 zip(values, printed, strict=True))


@pytest.mark.parametrize("label,options", [("simbicon natural", ("simbicon", {"gait": "natural"})),
                                           ("ipm", ("ipm", {}))])
def test_the_walkers_gait_figures_at_1_2_m_s(label, options):
    """As ``mjchar gait NAME --speed 1.2``: 20 s from the standing pose, analysed from 3 s."""
    name, extra = options
    recorder = MotionRecorder()
    built = RunSpec(name, "walk", options={"speed": 1.2, **extra},
                    scenario_options={"duration": 20.0}).build(frame_callback=recorder)
    from mjchar.controllers.core.runs import execute

    result = execute(built)
    ch = built.character
    stats = analyse(ch.model, recorder.times, recorder.qpos, start=3.0, end=result.fall_time_s,
                    info=ch.info)
    assert not result.fell
    assert _as_printed(_row(stats), GAIT_TABLE[label]) == pytest.approx(GAIT_TABLE[label])


def test_walk60s_gait_figures():
    stats = analyse_clip(shared_clip("walk60.bvh"))
    assert _as_printed(_row(stats), GAIT_TABLE["walk60"]) == pytest.approx(GAIT_TABLE["walk60"])
