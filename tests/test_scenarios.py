"""Scenarios and metrics: fall detection, determinism per seed, the push-search bisection,
Result serialisation, divergence reported as a failure, walk/track metrics."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from conftest import shared_clip

from mjchar import bvh
from mjchar.bvh.reference.reference_motion import ReferenceMotion
from mjchar.controllers.core import scenarios as S
from mjchar.controllers.core.base import Action
from mjchar.controllers.core.character import Character
from mjchar.controllers.core.metrics import FallDetector, Result
from mjchar.controllers.core.registry import RegistryError, default_timestep, make_controller


@pytest.fixture(scope="module")
def ch() -> Character:
    return Character()


class Limp:
    """Zero torque everywhere: the character collapses."""

    name = "limp"
    actuation = "torque"

    def reset(self, character):
        character.actuation.set_mode("torque")

    def act(self, character, t):
        return Action(torque=np.zeros(character.nv))


class Exploder(Limp):
    """Returns a NaN torque after 0.1 s."""

    name = "exploder"

    def act(self, character, t):
        tau = np.zeros(character.nv)
        if t > 0.1:
            tau[character.actuator_dof[0]] = np.nan
        return Action(torque=tau)


def test_limp_character_falls_and_the_reason_is_reported(ch):
    r = S.stand(ch, Limp(), duration=3.0)
    assert r.fell and 0 < r.fall_time_s < 2.0
    assert r.fall_reason and ("touched the ground" in r.fall_reason or "height" in r.fall_reason)
    assert r.sim_time_s == pytest.approx(r.fall_time_s)  # stops at the fall


def test_divergence_is_a_reported_failure_not_a_crash(ch):
    r = S.stand(ch, Exploder(), duration=1.0)
    assert r.fell and r.diverged and r.fall_time_s == pytest.approx(0.1, abs=0.01)
    json.dumps(r.to_dict())


def test_fall_detector_threshold(ch):
    f = FallDetector(ch)
    standing = S.standing_pose(ch)[ch.root_qpos[2]]
    assert f.fall_height == pytest.approx(0.55 * standing)
    ch.reset(S.standing_pose(ch))
    assert f.check(ch) is None


def test_random_push_is_deterministic_per_seed(ch):
    a = S.random_push(ch, make_controller("static_balance", ch), seed=3, duration=2.0)
    pushes_a = list(ch.pushes.scheduled)
    b = S.random_push(ch, make_controller("static_balance", ch), seed=3, duration=2.0)
    pushes_b = list(ch.pushes.scheduled)
    S.random_push(ch, make_controller("static_balance", ch), seed=4, duration=2.0)
    pushes_c = list(ch.pushes.scheduled)
    assert pushes_a == pushes_b and pushes_a != pushes_c
    assert a.distance_m == b.distance_m and a.foot_travel_m == b.foot_travel_m
    assert len(pushes_a) == 2
    for p in pushes_a:
        f = np.array(p.force)
        assert np.linalg.norm(f) == pytest.approx(10.0) and f[2] == 0
        assert p.body == ch.role("pelvis") and p.duration == 1.0


def test_result_to_dict_is_json_with_nulls_for_nan():
    r = Result(controller="c", scenario="s", fell=False, fall_time_s=None, sim_time_s=1.0,
               distance_m=np.float64(0.5), mean_speed_mps=math.nan, tracking_error_m=None,
               root_error_m=None, root_force_mean_N=0.0, root_force_max_N=0.0,
               root_torque_mean_Nm=0.0, max_push_N=None, wall_s=0.1, steps_per_s=10.0,
               timestep_s=0.002, control_dt_s=0.002, n_steps=500,
               max_push_by_direction_N={"forward": np.float64(3.0)})
    d = json.loads(json.dumps(r.to_dict()))
    assert d["mean_speed_mps"] is None and d["distance_m"] == 0.5
    assert d["max_push_by_direction_N"] == {"forward": 3.0}
    assert "FELL" not in r.summary()


def test_push_scenario_validates_its_input(ch):
    with pytest.raises(S.ScenarioError):
        S.push(ch, make_controller("spd", ch), force=-1.0)
    with pytest.raises(S.ScenarioError):
        S.push(ch, make_controller("spd", ch), force=10.0, push_time=3.9, duration=4.0)
    with pytest.raises(RegistryError, match="unknown controller 'nope'; choose from pd, spd"):
        make_controller("nope", ch)
    with pytest.raises(S.ScenarioError):
        S.run_scenario("dance", ch, make_controller("spd", ch))
    with pytest.raises(S.ScenarioError, match="reference"):
        S.track(ch, make_controller("spd", ch), None)


def test_push_is_applied_in_the_heading_frame(ch):
    r = S.push(ch, make_controller("static_balance", ch), force=40.0, direction=90.0,
               duration=1.5)
    (p,) = ch.pushes.scheduled
    np.testing.assert_allclose(np.array(p.force) / 40.0, [0, 1, 0], atol=0.05)  # left is +y
    assert r.push_N == 40.0 and r.push_direction_deg == 90.0


def test_walk_reports_distance_and_speed(ch):
    ref = ReferenceMotion(ch.model, bvh.load(shared_clip("walk60.bvh")))
    r = S.walk(ch, make_controller("hand_of_god", ch, ref), ref)
    assert r.scenario == "walk" and not r.fell
    assert r.distance_m > 3.0 and 1.0 < r.mean_speed_mps < 1.4  # the clip walks ~1.2 m/s
    assert r.tracking_error_m is not None


def test_control_dt_holds_actions_over_substeps(ch):
    r = S.stand(ch, make_controller("native_pd", ch, S.standing_pose(ch)), duration=1.0,
                control_dt=0.01)
    assert not r.fell and r.control_dt_s == pytest.approx(0.01) and r.n_steps == 500


def test_hold_pose_rejects_non_pd(ch):
    with pytest.raises(S.ScenarioError):
        S.hold_pose(ch, "static_balance", kp=100.0, timestep=0.002)


def test_make_controller_builds_the_walkers_with_their_options_and_time_steps():
    ch = Character()
    ipm = make_controller("ipm", ch, speed=0.7, heading=0.5)
    assert ipm.name == "ipm" and ipm.speed(3.0) == 0.7
    sim = make_controller("simbicon", ch, gait="crouch")
    assert sim.name == "simbicon" and sim.gait.name == "crouch"
    from mjchar.controllers.walking.simbicon import DEFAULT_TIMESTEP

    assert default_timestep("simbicon") == DEFAULT_TIMESTEP
    assert default_timestep("pd") == 1 / 2000
    assert default_timestep("ipm") is None
    with pytest.raises(RegistryError, match="simbicon, ipm"):
        make_controller("walker", ch)


def test_walk_seeds_perturb_a_walker_without_its_own_start_state():
    """IPM has no ``start_state``: the walk scenario's seed still perturbs its standing start
    (so the seeds of a robustness rate are different runs), and the same seed repeats."""
    from mjchar.controllers.core.scenarios import walk

    ch = Character()
    if default_timestep("ipm"):
        ch.set_timestep(default_timestep("ipm"))

    def final(seed):
        ctrl = make_controller("ipm", ch, speed=0.6)
        r = walk(ch, ctrl, duration=1.0, seed=seed, steady_window=0.5)
        assert not r.fell
        return ch.data.qpos.copy()

    a, b, c = final(0), final(1), final(0)
    assert np.array_equal(a, c)
    assert np.abs(a - b).max() > 1e-4


def test_track_with_a_seed_starts_from_the_clips_first_frame_perturbed():
    """``track --seed S`` is the run from ``perturbed_start`` of the clip's first frame (an
    independent run from that state gives the same errors); without a seed, the frame itself."""
    from mjchar.controllers.core.builder import RunSpec, execute

    def built(seed):
        return RunSpec("pd", "track", seed=seed, scenario_options={"duration": 0.3}).build()

    perturbed, plain = execute(built(3)), execute(built(None))
    run = built(None)
    ref = run.reference
    start = S.perturbed_start(run.character, ref.qpos(0.0), ref.qvel(0.0), 3)
    by_hand = S.track(run.character, run.controller, ref, duration=0.3, start=start)
    assert perturbed.seed == 3 and plain.seed is None
    assert perturbed.tracking_error_m == by_hand.tracking_error_m
    assert perturbed.tracking_error_m != plain.tracking_error_m
