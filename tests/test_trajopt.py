"""CMA-ES trajectory optimisation: spline knots, windows, tracking and the jump objective.

Default tests run a few generations on short horizons (seconds) and assert that CMA-ES improves
on its start and that the results replay; the full tasks (1.5 s of walk60 at >= 50 % lower
tracking cost than plain PD; a jump clearing 10 cm and landing standing) are slow tests
(``-m slow``) and benchmark entries (``python -m mjchar.perf.samcon``).
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import run_command, run_json, shared_clip

from mjchar import bvh
from mjchar.bvh.bundled.assets import humanoid_path, motion_path
from mjchar.bvh.errors import MjcharError
from mjchar.bvh.reference.reference_motion import ReferenceMotion
from mjchar.controllers.core.character import Character
from mjchar.controllers.sampling.executors import LocalExecutor
from mjchar.controllers.sampling.rollout import RolloutRequest
from mjchar.controllers.sampling.tracking import FALL_COST, tracking_rollout_model
from mjchar.controllers.sampling.trajectory import replay
from mjchar.controllers.sampling.trajopt import (
    JumpObjective,
    KnotSpline,
    TrajoptError,
    TrajoptOptions,
    _jump_matrix,
    jump_initial_knots,
    optimise_jump,
    plain_pd_trajectory,
    standing_targets,
    track_clip,
    trajectory_cost,
)


def test_knot_spline_interpolates_linearly_between_knots():
    G = np.eye(2)
    sp = KnotSpline(n_controls=10, control_dt=0.02, knot_dt=0.1, G=G)
    assert sp.n_knots == 3 and sp.B.shape == (10, 3)
    np.testing.assert_allclose(sp.B.sum(axis=1), 1.0)  # partition of unity
    X = np.array([[0.0, 1.0], [1.0, 1.0], [3.0, 1.0]])
    off = sp.offsets(X)
    t = (np.arange(10) + 0.5) * 0.02
    np.testing.assert_allclose(off[:, 0], np.interp(t, [0, 0.1, 0.2], [0, 1, 3]))
    np.testing.assert_allclose(off[:, 1], 1.0)
    assert sp.knots_acting(0, 5).tolist() == [0, 1]
    assert sp.knots_acting(5, 10).tolist() == [1, 2]
    assert sp.offsets(np.stack([X, 2 * X])).shape == (2, 10, 2)  # batched


def test_windows_overlap_and_commit_everything(character, walk_ref, executor):
    from mjchar.controllers.sampling.trajopt import TrackingObjective, TrajectoryOptimizer

    rm = tracking_rollout_model(humanoid_path(), character)
    o = TrajoptOptions(window=0.5, commit=0.2)
    T = 50
    sp = KnotSpline(T, 0.02, 0.1, np.eye(character.nu))
    obj = TrackingObjective(character, walk_ref, rm, 0.02, T)
    opt = TrajectoryOptimizer(character, rm, np.zeros((T, character.nu)), sp, obj,
                              walk_ref.qpos(0), walk_ref.qvel(0), o, executor)
    w = opt._windows()
    assert w[0] == (0, 25, 10) and w[-1][1] == T and w[-1][2] == T
    assert all(w[i][2] == w[i + 1][0] for i in range(len(w) - 1))  # commits tile the horizon


def test_short_tracking_improves_on_the_start_and_replays(walk_ref, executor):
    """From a start that is not optimal (plain PD on the raw reference, ``id_targets=False``),
    6 generations of 8 lower the tracking cost of the first 0.4 s by at least 10 % (measured:
    16.3 % at seed 1, 14.8 % at seed 0). From the inverse-dynamics start the same budget finds
    nothing better (4-12 generations return the start itself): that start is not used here."""
    o = TrajoptOptions(duration=0.4, window=0.4, commit=0.2, generations=6, popsize=8,
                       sigma0=0.5, seed=1, id_targets=False)
    res = track_clip(walk_ref, options=o, executor=executor, source_motion="walk.bvh",
                     progress=False)
    tr = res.trajectory
    assert tr.n_controls == 20 and tr.metadata["method"] == "cmaes-track"
    assert res.evaluations >= 6 * 8
    t = (np.arange(tr.n_controls) + 0.5) * tr.control_dt
    start = type(tr).for_model(Character().model, walk_ref.qpos(t)[:, Character().actuator_qpos],
                               tr.control_dt, tr.initial_qpos, tr.initial_qvel,
                               warmstart_resets=tr.warmstart_resets)
    assert trajectory_cost(tr, walk_ref) <= 0.9 * trajectory_cost(start, walk_ref)
    r = replay(tr)
    assert not r.fell and r.root_force_mean_N == 0.0


def test_plain_pd_trajectory_is_the_native_pd_tracker(walk_ref, character):
    tr = plain_pd_trajectory(walk_ref, duration=0.2)
    assert tr.control_dt == character.timestep and tr.n_controls == 100
    kp, kd = character.actuation.default_gains()
    a = character.actuator_dof
    u0 = walk_ref.qpos(0.0)[character.actuator_qpos] + kd[a] / kp[a] * walk_ref.qvel(0.0)[a]
    np.testing.assert_allclose(tr.targets[0], u0)


def test_jump_objective_rewards_flight_and_standing(character, executor):
    rm = tracking_rollout_model(humanoid_path(), character)
    q0, u = standing_targets(character)
    obj = JumpObjective(character, rm, q0, 0.02)
    T = 40
    stand = np.tile(u, (T, 1))
    s0 = rm.initial_state(q0)
    res = executor.evaluate(RolloutRequest(rm, s0, stand[None], 10))
    assert obj.clearance(res).max() == 0.0  # standing never leaves the ground
    # the same standing rollout lifted 0.2 m: airborne, and a higher clearance is rewarded
    q_up = q0.copy()
    q_up[2] += 0.2
    res_up = executor.evaluate(RolloutRequest(rm, rm.initial_state(q_up), stand[None, :5], 10))
    assert obj.clearance(res_up)[0, 0] > 0.1
    # standing holds: no fall penalty, small standing error
    assert obj(res, 0, T)[0] < 10


def test_short_jump_optimisation_improves_the_designed_start(executor):
    """The designed start (JUMP_KEYS) falls, so its cost carries the fall penalty: it is not
    optimal. Three generations of 8 must remove the penalty (cost below 1 % of the start's) and
    give a replay that leaves the floor by 3 cm and does not fall (measured: 10.2 cm at seed 0;
    5.2 and 5.3 cm at seeds 1 and 2)."""
    o = TrajoptOptions(generations=3, popsize=8, sigma0=0.15, seed=0)
    res = optimise_jump(options=o, executor=executor, duration=2.2, progress=False)
    tr = res.trajectory
    assert tr.metadata["method"] == "cmaes-jump" and tr.source_motion == ""
    assert tr.reference_qpos is None
    # the designed start's objective vs the optimised one
    ch = Character()
    rm = tracking_rollout_model(humanoid_path(), ch)
    q0, u = standing_targets(ch)
    sp = KnotSpline(tr.n_controls, tr.control_dt, 0.1, _jump_matrix(ch))
    obj = JumpObjective(ch, rm, q0, tr.control_dt)
    s0 = rm.initial_state(q0)
    with LocalExecutor(2) as ex:
        f0 = obj(ex.evaluate(RolloutRequest(rm, s0, (u + sp.offsets(jump_initial_knots(sp)))
                                            [None], 10)), 0, tr.n_controls)[0]
        f1 = obj(ex.evaluate(RolloutRequest(rm, s0, tr.targets[None], 10)), 0,
                 tr.n_controls)[0]
    assert f0 > 0.1 * FALL_COST  # the start falls
    assert f1 < 0.01 * f0
    assert res.window_costs[0] == pytest.approx(f1)
    r = replay(tr)
    assert r.tracking_error_m is None and not r.fell
    assert r.extra["max_clearance_m"] > 0.03


def test_bad_options(walk_ref):
    with pytest.raises(TrajoptError, match="commit"):
        track_clip(walk_ref, options=TrajoptOptions(window=0.2, commit=0.4), progress=False)
    with pytest.raises(TrajoptError, match="whole number"):
        track_clip(walk_ref, options=TrajoptOptions(control_dt=0.003), progress=False)


# -- the CLI ---------------------------------------------------------------------------------------
def test_cli_trajopt_tracks_and_saves(tmp_path, capsys):
    out = tmp_path / "t.npz"
    info = run_json(["trajopt", str(motion_path("walk")), "-o", str(out), "--duration", "0.2",
                     "--window", "0.2", "--commit", "0.2", "--generations", "2", "--popsize", "6",
                     "--threads", "2", "--json"], capsys)
    assert info["task"] == "track" and info["replay"]["fell"] is False
    assert out.is_file()


@pytest.mark.parametrize("argv,match", [
    (["trajopt", "-o", "x.npz"], "give a MOTION.bvh"),
    (["trajopt", "walk.bvh", "--task", "jump", "-o", "x.npz"], "takes no motion"),
    (["trajopt", "--task", "track", "-o", "x.npz"], "needs a MOTION"),
    (["trajopt", "/no/such.bvh", "-o", "x.npz"], "/no/such.bvh"),
])
def test_cli_errors(argv, match, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(MjcharError, match=match) as e:
        run_command(argv)
    assert "\n" not in str(e.value)


# -- slow: the real tasks --------------------------------------------------------------------------
@pytest.mark.slow
def test_cmaes_halves_the_tracking_cost_of_plain_pd_on_walk60(character):
    ref = ReferenceMotion(character.model, bvh.load(shared_clip("walk60.bvh")),
                          info=character.info)
    res = track_clip(ref, options=TrajoptOptions(duration=1.5), progress=False)
    pd = plain_pd_trajectory(ref, duration=1.5)
    assert replay(pd).fell  # plain PD of the raw reference falls
    assert trajectory_cost(res.trajectory, ref) <= 0.5 * trajectory_cost(pd, ref)
    assert not replay(res.trajectory).fell


@pytest.mark.slow
def test_jump_leaves_the_ground_by_10cm_and_lands_standing():
    from mjchar.controllers.sampling.trajopt import JUMP_OPTIONS

    res = optimise_jump(options=TrajoptOptions(**JUMP_OPTIONS), progress=False)
    tr = res.trajectory
    r = replay(tr, duration=tr.duration + 1.0, hold_last=True)
    assert not r.fell
    assert r.extra["max_clearance_m"] >= 0.10
    assert r.extra["final_root_height_m"] > 0.9 * tr.initial_qpos[2]
