"""The closed-loop sampling MPC tracker (controllers/sampling/mpc.py) and cyclic clips.

Fast tests run a few tenths of a second with few samples and short horizons; the figures of
docs/mpc.md (whole shared clips, a 60 s loop, pushes, perturbed starts) are slow tests
(``-m slow``, minutes each).
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import run_json, shared_clip

from mjchar import bvh
from mjchar.bvh.editing.clips import EditingError, make_cyclic
from mjchar.bvh.errors import MjcharError
from mjchar.bvh.reference.reference_motion import ReferenceMotion
from mjchar.controllers.core import scenarios as S
from mjchar.controllers.core.character import Character
from mjchar.controllers.core.registry import get, make_controller
from mjchar.controllers.sampling.mpc import (
    MpcController,
    MpcError,
    MpcOptions,
    Plan,
    make_mpc,
    shift_matrix,
)
from mjchar.controllers.sampling.rollout import RolloutRequest, get_state

#: small, fast settings (about 1 s of wall time per 0.1 s simulated on 2 cores); one batch
#: per plan, so the counts of rollouts and steps are fixed (the second batch has its own test)
FAST = {"samples": 8, "horizon": 0.2, "knots": 2, "replan": 0.04, "threads": 2,
        "second_batch": None}


def _track(character, reference, duration, **options):
    """Run the MPC in the track scenario; returns ``(result, qpos rows per control step)``."""
    controller = make_mpc(character, reference, **{**FAST, **options})
    rows = []
    r = S.track(character, controller, reference, duration=duration,
                frame_callback=lambda ch: rows.append(ch.state.qpos.copy()))
    controller.close()
    return r, np.array(rows), controller


# -- options -------------------------------------------------------------------------------------
@pytest.mark.parametrize("options, match", [
    ({"samples": 1}, "samples"),
    ({"knots": 1}, "knots"),
    ({"update": "newton"}, "update must be one of 'sampling', 'mppi', 'cem'"),
    ({"horizon": 0.25}, "horizon .* whole number of controls"),
    ({"replan": 0.5, "horizon": 0.3}, "replan .* cannot exceed horizon"),
    ({"noise": -1.0}, "noise must be a finite number > 0"),
    ({"threads": 0}, "threads"),
    ({"plan_timestep": 0.003}, "control_dt 0.02 s is not a whole number of plan_timestep"),
    ({"plan_timestep": -0.004}, r"plan_timestep must be a finite number >= 1e-05 .*or null"),
    ({"plan_timestep": 0.008}, "not a whole number of plan_timestep"),
    ({"plan_timestep": 0.05}, r"plan_timestep must be a finite number >= 1e-05 and <= 0.01"),
    ({"samples": 10**9}, "samples must be an integer >= 2 and <= 4096"),
    ({"samples": 48.0}, "samples must be an integer"),
    ({"horizon": 1e9}, r"horizon must be a finite number > 0 and <= 5 \(s\)"),
    ({"weights": {"pose": 1e300}}, "weights must be an object"),
    ({"smoothness": float("nan")}, "smoothness"),
    ({"plan_solver": "quick"}, "plan_solver must be one of 'fast', 'exact'"),
    ({"near": 0.25}, "near .* whole number of controls"),
    ({"near": -0.02}, r"near must be a finite number >= 0 and <= 5 \(s\)"),
    ({"keep": 0.0}, "keep must be a finite number > 0 and <= 1"),
    ({"keep": 1.5}, "keep must be a finite number > 0 and <= 1"),
    ({"tail_timestep": 0.003}, "not a whole number of tail_timestep"),
    ({"tail_timestep": 0.05}, r"tail_timestep must be a finite number >= 1e-05 and <= 0.01"),
    ({"stance_height": 0.0}, "stance_height must be a finite number > 0 and <= 1"),
    ({"stance_height": "low"}, "stance_height must be a finite number > 0 and <= 1"),
    ({"colour": "red"}, "unknown MPC option.*colour.*valid: samples"),
    ({"weights": {"pose": -1.0}}, "cost weight pose"),
    ({"widths": {"tail": 0.1}}, r"widths must be an object of names \(hip, knee"),
])
def test_bad_options_are_refused_with_a_clear_message(character, walk_ref, options, match):
    with pytest.raises(MjcharError, match=match):  # MpcError, or TrackingError for costs/widths
        c = make_mpc(character, walk_ref, **options)
        c.reset(character)


def test_control_dt_must_be_whole_physics_steps(character, walk_ref):
    c = make_mpc(character, walk_ref, control_dt=0.015, horizon=0.3, replan=0.03)
    with pytest.raises(MpcError, match="whole number of .* physics steps"):
        c.reset(character)


def test_the_planning_model_has_its_own_time_step(character, walk_ref):
    """plan_timestep changes the rollout model's step only: the character keeps its own, the
    rest of the physics is checked to be the character's. By default it is the coarsest
    divisor of the control at which the contacts keep their time constant (0.005 s here) with
    the fast solver, a sparse Jacobian without warm start; the character's own step and solver
    make the rollouts exact."""
    import mujoco

    from mjchar.controllers.sampling.trajectory import model_fingerprint

    c = make_mpc(character, walk_ref, **FAST)
    c.reset(character)
    assert c.options.plan_solver == "fast"  # the default
    m = c._rmodel.model
    assert m.opt.timestep == 0.005 and character.model.opt.timestep == 0.002
    assert (c.k, c.k_plan) == (10, 4)
    assert m.opt.jacobian == mujoco.mjtJacobian.mjJAC_SPARSE
    assert m.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_WARMSTART
    assert character.model.opt.disableflags == 0  # the character's own physics untouched
    c.act(character, 0.0)  # one replanning step: rollouts of k_plan steps per control
    assert c.stats["physics_steps"] == 8 * 10 * 4
    c.options.plan_solver = "exact"
    c.reset(character)
    assert c._rmodel.model.opt.disableflags == 0
    c.options.plan_timestep = 0.002  # the character's own step and solver: the same physics
    c.reset(character)
    assert c._rmodel.model.opt.timestep == 0.002 and c.k_plan == 10
    assert model_fingerprint(c._rmodel.model) == model_fingerprint(character.model)
    c.close()


@pytest.mark.parametrize(("contact", "control_dt", "expected"), [
    (0.01, 0.02, 0.005),  # the converter's contacts: half their time constant
    (0.02, 0.02, 0.01),  # softer contacts: the joint limits' 0.02 s bound it as well
    (0.012, 0.02, 0.005),  # 0.006 does not divide the control: the next finer divisor
    (0.003, 0.02, 0.002),  # stiffer than two model steps: the model's own step
    (0.01, 0.002, 0.002),  # one physics step per control: the model's own
])
def test_default_planning_step_follows_the_model(contact, control_dt, expected):
    from mjchar.controllers.sampling.mpc import plan_timestep

    m = Character().model
    m.geom_solref[:, 0] = contact
    o = MpcOptions(control_dt=control_dt, horizon=10 * control_dt, replan=control_dt)
    assert plan_timestep(o, m) == pytest.approx(expected)
    o.plan_timestep = 0.001
    assert plan_timestep(o, m) == 0.001  # given: taken as it is


def test_a_model_without_a_file_is_refused(walk_ref):
    m = Character().model
    make_mpc(None, walk_ref).reset(Character(m))  # an MjModel of the bundled humanoid: found
    m.body_mass[1] += 1.0  # another model given as an MjModel: no file to compile rollouts from
    ch = Character(m)
    with pytest.raises(MpcError, match="MJCF path"):
        make_mpc(ch, walk_ref).reset(ch)


def test_registered_as_a_closed_loop_tracker():
    spec = get("mpc")
    assert spec.default_scenario == "track" and "track" in spec.bench
    assert isinstance(make_controller("mpc", None, None, samples=4), MpcController)


# -- the plan --------------------------------------------------------------------------------------
def test_shift_matrix_moves_the_knots_and_holds_the_last():
    X = np.array([[0.0], [1.0], [2.0], [3.0]])
    np.testing.assert_allclose(shift_matrix(4, 0.1, 0.0) @ X, X)
    np.testing.assert_allclose(shift_matrix(4, 0.1, 0.1) @ X, [[1], [2], [3], [3]])
    np.testing.assert_allclose(shift_matrix(4, 0.1, 0.05) @ X, [[0.5], [1.5], [2.5], [3]])


def test_reference_grid_blocks_join_without_a_seam(character, walk_ref):
    """Base targets computed in blocks (with a smoothing margin) match a one-shot computation."""
    from mjchar.bvh.reference.foot_points import CONTACT_HEIGHT
    from mjchar.controllers.sampling.mpc import MPC_STANCE_HEIGHT, ReferenceGrid
    from mjchar.controllers.sampling.tracking import (
        inverse_dynamics_targets,
        tracking_rollout_model,
    )

    rm = tracking_rollout_model(character.source, character)
    n = np.arange(-10, 70)
    for height in (MPC_STANCE_HEIGHT, CONTACT_HEIGHT):
        grid = ReferenceGrid(character, walk_ref, rm, 0.02, 0.03, block=20, stance_height=height)
        base = grid.base(0, 60)
        whole = inverse_dynamics_targets(character, walk_ref, (n + 0.5) * 0.02, smoothing=0.03,
                                         unlabelled="both", stance_height=height)
        np.testing.assert_allclose(base, whole[10:70], atol=1e-6)
    assert grid.features.qpos.shape[0] == 60
    np.testing.assert_allclose(grid.features.times, (np.arange(60) + 1) * 0.02)


def test_stance_height_default_follows_the_reference_floor(character, walk_ref):
    """Grounded labels on a contact-floor reference, the raw-mocap rule on a floating clip."""
    from mjchar import bvh
    from mjchar.bvh.bundled.assets import motion_path
    from mjchar.bvh.reference.foot_points import CONTACT_HEIGHT
    from mjchar.bvh.reference.reference_motion import ReferenceMotion
    from mjchar.controllers.sampling.mpc import MPC_STANCE_HEIGHT, stance_height

    clip_ref = ReferenceMotion(character.model, bvh.load(motion_path("walk")),
                               info=character.info, floor="clip")
    assert stance_height(MpcOptions(), walk_ref) == MPC_STANCE_HEIGHT
    assert stance_height(MpcOptions(), clip_ref) == CONTACT_HEIGHT
    assert stance_height(MpcOptions(stance_height=0.05), clip_ref) == 0.05
    c = make_mpc(character, walk_ref, **FAST)
    c.reset(character)
    assert c.grid.stance_height == MPC_STANCE_HEIGHT
    c.close()


def test_tracks_the_bundled_walk_without_falling(walk_ref):
    ch = Character()
    r, _, c = _track(ch, walk_ref, 0.4)
    assert not r.fell
    assert r.root_force_mean_N == 0.0  # no hand of god
    assert r.tracking_error_m < 0.04
    assert c.stats["replans"] == 10 and c.stats["rollouts"] == 80


@pytest.mark.parametrize("update", ["mppi", "cem"])
def test_every_update_tracks(walk_ref, update):
    r, _, _ = _track(Character(), walk_ref, 0.3, update=update)
    assert not r.fell and r.tracking_error_m < 0.04


def test_holds_a_pose_in_the_stand_scenario():
    ch = Character()
    c = make_mpc(ch, S.standing_pose(ch), **FAST)
    r = S.stand(ch, c, duration=0.3)
    assert not r.fell and r.com_drop_m < 0.02


def test_same_seed_same_trajectory_bit_for_bit_whatever_the_threads(walk_ref):
    # MPPI: every sample moves the plan, so another seed gives another trajectory
    _, a, _ = _track(Character(), walk_ref, 0.3, seed=5, update="mppi")
    _, b, _ = _track(Character(), walk_ref, 0.3, seed=5, update="mppi")
    _, c, _ = _track(Character(), walk_ref, 0.3, seed=5, update="mppi", threads=1)
    _, d, _ = _track(Character(), walk_ref, 0.3, seed=6, update="mppi")
    assert np.array_equal(a, b) and np.array_equal(a, c)
    assert not np.array_equal(a, d)


@pytest.mark.parametrize("plan_timestep", [None, 0.002])
def test_deterministic_with_either_planning_step(walk_ref, plan_timestep):
    o = {"seed": 3, "plan_timestep": plan_timestep}
    _, a, _ = _track(Character(), walk_ref, 0.2, **o)
    _, b, _ = _track(Character(), walk_ref, 0.2, **o, threads=1)
    assert np.array_equal(a, b)


def test_deterministic_with_second_batches(walk_ref):
    """Plans that draw a second batch (a bound every plan exceeds) are deterministic too."""
    o = {"seed": 3, "second_batch": 1e-4}
    _, a, c = _track(Character(), walk_ref, 0.2, **o)
    _, b, _ = _track(Character(), walk_ref, 0.2, **o, threads=1)
    assert np.array_equal(a, b)
    assert c.stats["rollouts"] == 2 * 8 * c.stats["replans"]


def test_without_disturbance_the_character_follows_the_chosen_rollout(walk_ref):
    """Predictive sampling applies the cheapest candidate, and the solver warm start is cleared
    at every replanning as in the rollouts: the simulation lands exactly on its prediction."""
    ch = Character()
    c = make_mpc(ch, walk_ref, plan_timestep=0.002, plan_solver="exact",
                 **FAST)  # the character's own step and solver
    ch.reset(walk_ref.qpos(0.0), walk_ref.qvel(0.0))
    c.reset(ch)
    c.act(ch, 0.0)
    res = c._executor.evaluate(RolloutRequest(c._rmodel, get_state(ch.model, ch.data),
                                              c.last_plan.targets[None], c.k))
    for _ in range(c.R * c.k):
        ch.step(c.act(ch, ch.time))
    np.testing.assert_array_equal(get_state(ch.model, ch.data)[1:],
                                  res.states[0, c.R - 1][1:])
    c.close()


def test_mjchar_run_mpc(capsys):
    out = run_json(["run", "mpc", "--duration", "0.2", "--json"], capsys)
    assert out["controller"] == "mpc" and not out["fell"] and out["tracking_error_m"] < 0.05


# -- planning from any state (the expert interface) --------------------------------------------
def test_plan_from_a_given_state_and_clip_time(walk_ref):
    """plan() plans from a full-physics state at a clip time without touching the character;
    the same random stream gives the same plan; a Plan warm starts the next one."""
    ch = Character()
    c = make_mpc(ch, walk_ref, **FAST)
    c.reset(ch)
    ch.reset(walk_ref.qpos(0.3), walk_ref.qvel(0.3))
    state = ch.state.get_physics()
    before = ch.state.get()
    p = c.plan(state, 0.3, rng=np.random.default_rng(1))
    assert np.array_equal(ch.state.get(), before)  # the character is not touched
    assert isinstance(p, Plan) and p.time == pytest.approx(0.3)
    assert p.targets.shape == (c.T, ch.nu) and p.knots.shape == (2, ch.nu)
    assert p.physics_steps == 8 * c.T * c.k_plan and p.rollouts == 8
    np.testing.assert_allclose(p.target(0.305), p.targets[0])
    np.testing.assert_allclose(p.target(0.345), p.targets[2])
    np.testing.assert_allclose(p.target(5.0), p.targets[-1])
    q = c.plan(state, 0.3, rng=np.random.default_rng(1))
    assert np.array_equal(p.targets, q.targets)  # same stream, same plan (boost 1 both times)
    nxt = c.plan(state, 0.34, p, rng=np.random.default_rng(2))  # warm started by p
    assert nxt.time == pytest.approx(0.34) and c.last_plan is nxt
    c.close()


def test_plan_off_the_control_grid_uses_a_grid_of_its_own(walk_ref):
    """A 30 Hz learner's states fall between the MPC's 0.02 s controls: the base targets and
    cost features are sampled from the state's own time on."""
    ch = Character()
    c = make_mpc(ch, walk_ref, **FAST)
    c.reset(ch)
    t = 1 / 30
    ch.reset(walk_ref.qpos(t), walk_ref.qvel(t))
    p = c.plan(ch.state.get_physics(), t)
    assert p.time == pytest.approx(t)
    grid, n0 = c._grid_at(t)
    assert grid is not c.grid and n0 == 1
    np.testing.assert_allclose(grid.features.times[n0:n0 + 2], t + np.array([1, 2]) * 0.02)
    with pytest.raises(MpcError, match="full-physics state"):
        c.plan(ch.state.qpos, t)
    with pytest.raises(MpcError, match="non-negative"):
        c.plan(ch.state.get_physics(), -1.0)
    c.close()


def test_a_nominal_of_pd_targets_is_fitted_to_the_knots(walk_ref):
    """Targets the knots can represent come back exactly: the nominal candidate is them."""
    ch = Character()
    c = make_mpc(ch, walk_ref, **FAST)
    c.reset(ch)
    grid, n0 = c._grid_at(0.2)
    base = grid.base(n0, n0 + c.T)
    X0 = np.random.default_rng(0).standard_normal((2, ch.nu)) * (c.widths > 0)
    u = base + c.spline.offsets(X0)
    X, sigma, applied = c._warm(u, 0.2, base)
    np.testing.assert_allclose(X, X0, atol=1e-9)
    np.testing.assert_allclose(applied, u[0] - base[0])
    held = c._warm(u[0], 0.2, base)[0]  # one action held over the horizon: a least-squares fit
    assert held.shape == X0.shape and np.all(held[:, c.widths == 0] == 0)
    with pytest.raises(MpcError, match="nominal"):
        c._warm(np.zeros(3), 0.2, base)
    c.close()


def test_the_closed_loop_plans_through_plan(walk_ref):
    ch = Character()
    c = make_mpc(ch, walk_ref, **FAST)
    S.track(ch, c, walk_ref, duration=0.12)
    c.close()
    assert c.stats["replans"] == 3 and isinstance(c.last_plan, Plan)
    assert c.last_plan.time == pytest.approx(0.08)


def test_a_labeller_gets_the_closed_loops_action_from_a_recorded_state(walk_ref):
    """plan() is the closed loop's planning step: a second controller given the states the
    closed loop visited (recorded at its replanning times), the same clip times and each
    previous plan as nominal returns, bit for bit, the first action the closed loop applied
    there. With no nominal (a learner's labeller from a state of its own), the plan starts
    from the base targets."""
    ch = Character()
    loop = make_mpc(ch, walk_ref, **FAST)
    applied, states = {}, {}
    act = loop.act

    def record_act(character, t):
        a = act(character, t)
        applied.setdefault(round(t, 6), np.array(a.target, copy=True))
        return a

    def record_state(character):
        states[round(character.time, 6)] = character.state.get_physics().copy()

    loop.act = record_act
    S.track(ch, loop, walk_ref, duration=0.12, frame_callback=record_state)
    loop.close()
    times = (0.0, 0.04, 0.08)  # the replanning times (replan 0.04 s)
    assert set(times) <= set(states) and set(times) <= set(applied)

    other = Character()
    labeller = make_mpc(other, walk_ref, **FAST)
    labeller.reset(other)
    plan = None
    for t in times:
        plan = labeller.plan(states[t], t, plan)
        assert plan.time == pytest.approx(t)
        assert np.array_equal(plan.target(t), applied[t]), t
        assert np.array_equal(plan.targets[0], applied[t])
    cold = labeller.plan(states[0.08], 0.08, rng=np.random.default_rng(0), boost=1.0)
    assert cold.targets.shape == plan.targets.shape and np.isfinite(cold.targets).all()
    assert not np.array_equal(cold.targets[0], plan.targets[0])  # the warm start mattered
    labeller.close()


# -- early termination and the coarse tail ------------------------------------------------------
def test_a_rollout_continued_without_warm_start_is_the_same_rollout(character, walk_ref):
    """With the solver's warm start off (the fast planning model), a rollout stopped and
    continued from its recorded state is bit-identical to one that ran on."""
    from mjchar.controllers.sampling.executors import LocalExecutor
    from mjchar.controllers.sampling.mpc import planning_model

    rm = planning_model(character.source, character, 0.004, "fast")
    character.reset(walk_ref.qpos(0.2), walk_ref.qvel(0.2))
    state = character.state.get_physics()
    rng = np.random.default_rng(0)
    ctrl = walk_ref.qpos(0.2)[character.actuator_qpos] + 0.05 * rng.standard_normal((3, 10, 49))
    with LocalExecutor(threads=2) as ex:
        whole = ex.evaluate(RolloutRequest(rm, state, ctrl, 5))
        near = ex.evaluate(RolloutRequest(rm, state, ctrl[:, :4], 5))
        joined = near.then(ex.evaluate(RolloutRequest(rm, near.final_states, ctrl[:, 4:], 5)))
        sub = whole.take(np.array([2, 0]))
    for name in ("states", "com", "com_vel", "sites", "contacts", "ok", "failed_step"):
        assert np.array_equal(getattr(joined, name), getattr(whole, name)), name
    assert np.array_equal(sub.states, whole.states[[2, 0]])


def test_cost_over_time_matches_the_cost_per_control(walk_ref):
    ch = Character()
    c = make_mpc(ch, walk_ref, **FAST)
    c.reset(ch)
    ch.reset(walk_ref.qpos(0.0), walk_ref.qvel(0.0))
    base = c.grid.base(0, c.T)
    ctrl = base[None] + 0.05 * np.random.default_rng(0).standard_normal((4,) + base.shape)
    res = c._executor.evaluate(RolloutRequest(c._rmodel, ch.state.get_physics(), ctrl,
                                              c.k_plan))
    f = c.grid.features
    whole = c.cost.over_time(res.qpos, res.qvel, res.com, res.com_vel, res.sites, f,
                             np.arange(c.T))
    for i in range(c.T):
        each = c.cost(res.qpos[:, i], res.qvel[:, i], res.com[:, i], res.com_vel[:, i],
                      res.sites[:, i], f, i)
        np.testing.assert_allclose(whole[:, i], each, rtol=1e-12)
    per_control = [c.cost.terms(res.qpos[:, i], res.qvel[:, i], res.com[:, i],
                                res.com_vel[:, i], res.sites[:, i], f, i)["joints"]
                   for i in range(c.T)]
    np.testing.assert_allclose(c.cost.joint_error(res.sites, f, np.arange(c.T)),
                               np.mean(per_control, axis=0), rtol=1e-12)
    both = c.cost.over_time(res.qpos, res.qvel, res.com, res.com_vel, res.sites, f,
                            np.arange(c.T), joint_error=True)  # the planner's one pass
    np.testing.assert_array_equal(both[0], whole)
    np.testing.assert_allclose(both[1], np.mean(per_control, axis=0), rtol=1e-12)
    c.close()


def test_a_second_batch_where_the_plan_stays_off_the_clip(walk_ref):
    """``second_batch``: on the clip's own state the plan predicts a few centimetres and draws
    one batch, the very plan of no second batch; from a state 0.3 m to the side of the clip,
    the cheapest candidate stays further than 6 cm and ``samples`` more are drawn (twice the
    rollouts and steps), a different plan from the same stream."""
    ch = Character()
    plans = {}
    for bound in (None, 0.06):
        c = make_mpc(ch, walk_ref, **{**FAST, "second_batch": bound})
        c.reset(ch)
        for side in (0.0, 0.3):
            q = walk_ref.qpos(0.3).copy()
            q[1] += side
            ch.reset(q, walk_ref.qvel(0.3))
            plans[bound, side] = c.plan(ch.state.get_physics(), 0.3,
                                        rng=np.random.default_rng(1))
        c.close()
    steps = plans[None, 0.0].physics_steps
    assert plans[0.06, 0.0].rollouts == 8 and plans[0.06, 0.0].physics_steps == steps
    assert np.array_equal(plans[0.06, 0.0].targets, plans[None, 0.0].targets)
    assert plans[0.06, 0.3].rollouts == 16 and plans[0.06, 0.3].physics_steps == 2 * steps
    assert plans[None, 0.3].rollouts == 8
    assert not np.array_equal(plans[0.06, 0.3].targets, plans[None, 0.3].targets)


def test_early_termination_and_the_coarse_tail(walk_ref):
    """With a split, every candidate runs the near part, the kept ones the tail on the coarse
    model: the steps add up, the dropped candidates get no weight, and the result does not
    depend on the thread count."""
    o = {**FAST, "horizon": 0.2, "near": 0.08, "keep": 0.5, "tail_timestep": 0.01,
         "plan_solver": "fast"}
    ch = Character()
    c = make_mpc(ch, walk_ref, **o)
    c.reset(ch)
    assert c._tail_model.model.opt.timestep == 0.01 and (c.T_near, c.k_tail) == (4, 2)
    p = c.plan(ch.state.get_physics(), 0.0)
    assert p.physics_steps == 8 * 4 * 4 + 4 * 6 * 2  # the near part at 0.005 s, the tail at 0.01
    c.close()
    _, a, _ = _track(Character(), walk_ref, 0.2, **o)
    _, b, _ = _track(Character(), walk_ref, 0.2, **{**o, "threads": 1})
    assert np.array_equal(a, b)


# -- cyclic clips ----------------------------------------------------------------------------------
def test_make_cyclic_cuts_a_seamless_gait_cycle():
    ch = Character()
    cycle = make_cyclic(bvh.load(shared_clip("walk60.bvh")))
    ref = ReferenceMotion(ch.model, cycle, info=ch.info)
    assert ref.cyclic  # detected: first and last poses agree
    assert 0.9 < ref.duration < 1.4  # one gait cycle of a 1.2 m/s walk
    assert 1.0 < np.linalg.norm(ref.cycle_displacement) < 1.8
    T = ref.duration
    seam = ref.body_positions(np.array([T - 1e-4, T + 1e-4]))[:, ref.joint_body_ids]
    assert np.abs(seam[1] - seam[0]).max() < 0.005


def test_make_cyclic_refuses_a_clip_too_short():
    m = bvh.load(shared_clip("walk_forward.bvh"))
    with pytest.raises(EditingError, match="no cycle"):
        make_cyclic(m, min_period=5.0)


def test_options_dataclass_defaults_are_valid():
    MpcOptions().check(0.002)


def test_looped_clip_runs_as_long_as_asked(capsys):
    """``mjchar run --loop``: a cycle of walk60 repeated with its root advanced (hand-of-god:
    fast), well past the clip's own 3 s."""
    path = str(shared_clip("walk60.bvh"))
    out = run_json(["run", "hand_of_god", "--motion", path, "--loop", "--duration", "5", "--json"],
                   capsys)
    assert out["sim_time_s"] == pytest.approx(5.0, abs=0.01) and not out["fell"]
    assert out["distance_m"] > 5.0 and out["tracking_error_m"] < 0.05


# -- pushes while tracking and perturbed starts -------------------------------------------------
def test_a_push_while_tracking_moves_the_character(walk_ref):
    def run(force):
        ch = Character()
        c = make_controller("native_pd", ch, walk_ref)
        return S.track(ch, c, walk_ref, duration=0.5, push=S.PushEvent(force, 90.0, 0.1, 0.2))

    quiet, pushed = run(0.0), run(300.0)
    assert pushed.push_N == 300.0 and pushed.push_direction_deg == 90.0
    assert pushed.tracking_error_m > quiet.tracking_error_m + 0.005


def test_a_push_past_the_end_of_the_run_is_refused(walk_ref):
    ch = Character()
    with pytest.raises(S.ScenarioError, match="ends after the run"):
        S.track(ch, make_controller("native_pd", ch, walk_ref), walk_ref, duration=0.5,
                push=S.PushEvent(100.0, 0.0, 0.4, 0.2))
    with pytest.raises(S.ScenarioError, match="non-negative"):
        S.PushEvent(-5.0)


def test_mjchar_run_pushes_in_the_track_scenario(capsys):
    out = run_json(["run", "hand_of_god", "--duration", "0.6", "--push", "100", "--push-time",
                    "0.2", "--direction", "left", "--json"], capsys)
    assert out["scenario"] == "track" and out["push_N"] == 100.0
    assert out["push_direction_deg"] == 90.0


def test_perturbed_start_is_seeded_and_on_the_floor(character, walk_ref):
    q0, v0 = walk_ref.qpos(0.0), walk_ref.qvel(0.0)
    a = S.perturbed_start(character, q0, v0, 3)
    b = S.perturbed_start(character, q0, v0, 3)
    c = S.perturbed_start(character, q0, v0, 4)
    assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])
    assert not np.array_equal(a[0], c[0])
    assert character.poses.lowest_point(a[0]) == pytest.approx(0.0, abs=1e-6)
    dv = a[1] - v0
    assert np.all(dv[character.root_dofs[2:]] == 0) and np.abs(dv[:2]).max() > 0


# -- slow: the figures of docs/mpc.md (default settings; minutes each) ---------------------------
def _shared_ref(ch, name, cyclic=False):
    motion = bvh.load(shared_clip(f"{name}.bvh"))
    if cyclic:
        motion = make_cyclic(motion)
    return ReferenceMotion(ch.model, motion, info=ch.info, cyclic=True if cyclic else None)


@pytest.mark.slow
@pytest.mark.parametrize("clip, bound", [
    ("walk60", 0.05), ("walk_forward", 0.05), ("walk_and_turn_right", 0.05), ("idle", 0.03)])
def test_slow_tracks_the_shared_clips(clip, bound):
    ch = Character()
    ref = _shared_ref(ch, clip)
    c = make_mpc(ch, ref)
    r = S.track(ch, c, ref)
    c.close()
    assert not r.fell and r.root_force_mean_N == 0.0
    assert r.tracking_error_m < bound


@pytest.mark.slow
def test_slow_loops_walk60_for_a_minute():
    ch = Character()
    ref = _shared_ref(ch, "walk60", cyclic=True)
    c = make_mpc(ch, ref)
    r = S.track(ch, c, ref, duration=60.0)
    c.close()
    assert not r.fell and r.tracking_error_m < 0.06


@pytest.mark.slow
@pytest.mark.parametrize("direction", [0.0, 90.0, 180.0, 270.0])
@pytest.mark.parametrize("moment", [0, 1, 2, 3])
def test_slow_recovers_from_pushes_while_walking(moment, direction):
    """100 N x 0.2 s on the pelvis at 4 moments of the gait cycle x 4 directions: no fall, and
    the mean joint error back below 8 cm within 2 s of the push's end (and staying there for
    the 4 s simulated after it)."""
    ch = Character()
    ref = _shared_ref(ch, "walk60", cyclic=True)
    push = S.PushEvent(100.0, direction, round(0.5 + moment * ref.duration / 4, 3), 0.2)
    c = make_mpc(ch, ref)
    t, pos = [], []

    def probe(ch):
        if not t or ch.time >= t[-1] + 0.02 - 1e-9:
            t.append(ch.time)
            pos.append(ch.state.joint_positions())

    r = S.track(ch, c, ref, duration=push.end + 4.0, push=push, frame_callback=probe)
    c.close()
    assert not r.fell
    times = np.array(t)
    err = np.linalg.norm(np.array(pos) - ref.body_positions(times)[:, ref.joint_body_ids],
                         axis=-1).mean(axis=1)
    high = times[(times >= push.end) & (err >= 0.08)]  # below 8 cm for good after 2 s
    assert not len(high) or high[-1] - push.end <= 2.0


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(5))
def test_slow_survives_perturbed_starts(seed):
    ch = Character()
    ref = _shared_ref(ch, "walk60")
    start = S.perturbed_start(ch, ref.qpos(0.0), ref.qvel(0.0), seed)
    c = make_mpc(ch, ref)
    r = S.track(ch, c, ref, start=start)
    c.close()
    assert not r.fell


def test_mjchar_run_pushes_a_replay_too(capsys):
    quiet, pushed = [run_json(["run", "samcon_replay", "--duration", "1.0", "--json"] + extra,
                              capsys)
                     for extra in ([], ["--push", "300", "--push-time", "0.3", "--direction",
                                        "right"])]
    assert quiet["push_N"] is None and pushed["push_N"] == 300.0
    assert pushed["tracking_error_m"] > quiet["tracking_error_m"] + 0.005
