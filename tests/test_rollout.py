"""Batched rollouts (mjchar.controllers.sampling.rollout) on the bundled humanoid: determinism,
equality with a plain mj_step loop, cost quantities, contacts, divergence reporting, input
validation."""

from __future__ import annotations

import pickle

import mujoco
import numpy as np
import pytest

from mjchar.bvh.bundled.assets import humanoid_path
from mjchar.bvh.errors import MjcharError
from mjchar.controllers.sampling.rollout import (
    RolloutError,
    RolloutModel,
    RolloutRequest,
    RolloutResult,
    RolloutRunner,
    get_state,
    reference_rollout,
    rollout,
    set_state,
    state_slices,
    to_fullphysics,
)

FIELDS = ("states", "com", "com_vel", "sites", "contacts", "ok", "failed_step")
K = 10  # physics steps per control: 20 ms slices keep the tests fast


def assert_results_identical(a: RolloutResult, b: RolloutResult) -> None:
    for name in FIELDS:
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)


@pytest.fixture(scope="module")
def rmodel() -> RolloutModel:
    return RolloutModel.from_source(humanoid_path())


@pytest.fixture(scope="module")
def plain() -> mujoco.MjModel:
    """The humanoid compiled without the rollout sensors."""
    return mujoco.MjModel.from_xml_path(str(humanoid_path()))


def standing_targets(rm: RolloutModel) -> np.ndarray:
    """(nu,) PD targets holding the rest pose: qpos0 of each actuated hinge."""
    m = rm.model
    return m.qpos0[m.jnt_qposadr[m.actuator_trnid[:, 0]]]


@pytest.fixture(scope="module")
def varied_states(rmodel) -> np.ndarray:
    """(6, nstate) distinct moving states with feet on the floor: the rest pose after 0.1 s of
    random PD targets."""
    rng = np.random.default_rng(7)
    targets = standing_targets(rmodel) + rng.normal(0.0, 0.15, (6, 1, rmodel.nu))
    result = rollout(RolloutRequest(rmodel, rmodel.initial_state(), targets, 50), threads=1)
    assert result.ok.all()
    return result.final_states


def random_request(rm, states, rng, horizon=3, sigma=0.3, xfrc=None) -> RolloutRequest:
    batch = states.shape[0]
    targets = standing_targets(rm) + rng.normal(0.0, sigma, (batch, horizon, rm.nu))
    return RolloutRequest(rm, states, targets, K, xfrc)


def test_same_result_at_any_thread_count_and_chunking(rmodel, varied_states):
    req = random_request(rmodel, varied_states, np.random.default_rng(0))
    one = rollout(req, threads=1)
    assert_results_identical(one, rollout(req, threads=2))
    assert_results_identical(one, rollout(req, threads=2, chunk=4))  # uneven chunks
    with RolloutRunner(rmodel, threads=2, chunk=1) as runner:
        assert_results_identical(one, runner.run(req))
        assert_results_identical(one, runner.run(req))  # reused pool and MjData: no carry-over
    assert one.ok.all() and one.states.shape == (6, 3, rmodel.nstate)


def test_equals_python_mj_step_loop_bit_for_bit(rmodel, plain, varied_states):
    req = random_request(rmodel, varied_states, np.random.default_rng(1))
    result = rollout(req, threads=2)
    expected = reference_rollout(plain, req.initial_states, req.controls, K)
    np.testing.assert_array_equal(result.states, expected)
    sl = state_slices(plain)
    np.testing.assert_array_equal(result.qpos, expected[..., sl["qpos"]])
    np.testing.assert_array_equal(result.qvel, expected[..., sl["qvel"]])
    np.testing.assert_array_equal(result.final_states, expected[:, -1])
    # time advanced by exactly T k steps
    np.testing.assert_allclose(result.final_states[:, 0] - req.initial_states[:, 0],
                               3 * K * plain.opt.timestep, rtol=0, atol=1e-12)


def test_external_forces_per_sample(rmodel, plain, varied_states):
    rng = np.random.default_rng(2)
    states = np.repeat(varied_states[:1], 3, axis=0)
    xfrc = np.zeros((3, 1, rmodel.model.nbody, 6))
    pelvis = mujoco.mj_name2id(rmodel.model, mujoco.mjtObj.mjOBJ_BODY, rmodel.root_body)
    xfrc[1, 0, pelvis, 0] = 300.0   # push forward (+x)
    xfrc[2, 0, pelvis, 0] = -300.0  # push backward
    req = random_request(rmodel, states, rng, sigma=0.0, xfrc=xfrc)
    result = rollout(req, threads=2)
    expected = reference_rollout(plain, req.initial_states, req.controls, K,
                                 np.broadcast_to(xfrc, (3, 3) + xfrc.shape[2:]))
    np.testing.assert_array_equal(result.states, expected)
    dx = result.com[:, -1, 0] - result.com[0, -1, 0]
    assert dx[1] > 0.005 and dx[2] < -0.005


def test_cost_quantities_describe_the_recorded_states(rmodel, varied_states):
    result = rollout(random_request(rmodel, varied_states, np.random.default_rng(3)), threads=2)
    m = rmodel.model
    data = mujoco.MjData(m)
    root = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, rmodel.root_body)
    sites = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, s) for s in rmodel.site_names]
    for b in range(result.states.shape[0]):
        for i in range(result.states.shape[1]):
            set_state(m, data, result.states[b, i])
            mujoco.mj_forward(m, data)
            np.testing.assert_allclose(result.com[b, i], data.subtree_com[root], atol=1e-12)
            np.testing.assert_allclose(result.sites[b, i], data.site_xpos[sites], atol=1e-12)
            vel = np.empty(3)
            mujoco.mj_subtreeVel(m, data)
            vel[:] = data.subtree_linvel[root]
            np.testing.assert_allclose(result.com_vel[b, i], vel, atol=1e-12)
    assert result.sites.shape == (6, 3, len(rmodel.site_names), 3)


def test_contacts_tell_feet_from_a_fall(rmodel):
    m = rmodel.model
    lying = m.qpos0.copy()
    lying[2] = 0.2
    lying[3:7] = [np.cos(np.pi / 4), 0.0, -np.sin(np.pi / 4), 0.0]  # on its back
    states = np.stack([rmodel.initial_state(), rmodel.initial_state(lying)])
    targets = np.broadcast_to(standing_targets(rmodel), (2, 4, m.nu))
    result = rollout(RolloutRequest(rmodel, states, targets, 25), threads=2)
    feet = result.contacts[..., result.foot_mask]
    assert feet[0].all()  # standing: both feet touch in every interval
    assert not result.non_foot_contact[0].any() and not result.fallen[0]
    assert result.non_foot_contact[1, -1] and result.fallen[1]
    assert not result.non_foot_contact[1, 0]  # still in the air during the first 50 ms


def test_divergence_is_reported_per_sample(rmodel, varied_states, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # MuJoCo appends its warnings to ./MUJOCO_LOG.TXT
    rng = np.random.default_rng(4)
    req = random_request(rmodel, varied_states[:4], rng, horizon=4)
    bad = np.array(req.controls)
    bad[1, 2, 0] = 1e12  # MuJoCo rejects the control: warning during step 2 K
    result = rollout(RolloutRequest(rmodel, req.initial_states, bad, K), threads=2)
    assert result.ok.tolist() == [True, False, True, True]
    assert result.failed_step.tolist() == [-1, 2 * K, -1, -1]
    assert np.isfinite(result.states[1, :2]).all() and np.isnan(result.states[1, 2:]).all()
    assert np.isnan(result.com[1, 2:]).all() and np.isnan(result.sites[1, 2:]).all()
    good = rollout(req, threads=1)  # the other samples are unaffected
    for name in ("states", "com", "sites", "contacts"):
        np.testing.assert_array_equal(getattr(result, name)[[0, 2, 3]],
                                      getattr(good, name)[[0, 2, 3]])
    np.testing.assert_array_equal(result.states[1, :2], good.states[1, :2])
    # a warning on the very last physics step is caught too (by the extra sensing step)
    last = np.array(req.controls[:2])
    last[0, -1] = 1e12
    one_step = rollout(RolloutRequest(rmodel, req.initial_states[:2], last, 1), threads=1)
    assert one_step.ok.tolist() == [False, True]
    assert one_step.failed_step.tolist() == [3, -1]
    # bad values that MuJoCo auto-resets during the very first step (qvel beyond 1e10)
    data = mujoco.MjData(rmodel.model)
    set_state(rmodel.model, data, req.initial_states[0])
    data.time, data.qvel[0] = 1.0, 1e11
    states = np.stack([get_state(rmodel.model, data), req.initial_states[0]])
    reset = rollout(RolloutRequest(rmodel, states, req.controls[:2], K), threads=2)
    assert reset.ok.tolist() == [False, True] and reset.failed_step.tolist() == [0, -1]
    assert np.isnan(reset.states[0]).all() and np.isfinite(reset.states[1]).all()


def test_shared_initial_state_and_controls_broadcast(rmodel):
    s0 = rmodel.initial_state()
    targets = standing_targets(rmodel)[None, None] + np.zeros((1, 2, rmodel.nu))
    req = RolloutRequest(rmodel, np.repeat(s0[None], 3, axis=0), targets, K)
    assert req.batch_size == 3 and req.horizon == 2 and req.physics_steps == 2 * K
    result = rollout(req, threads=2)
    np.testing.assert_array_equal(result.states[0], result.states[2])
    single = rollout(RolloutRequest(rmodel, s0, targets[0], K), threads=1)
    np.testing.assert_array_equal(single.states[0], result.states[0])
    parts = req.split(2)
    assert [p.batch_size for p in parts] == [2, 1] or [p.batch_size for p in parts] == [1, 2]
    joined = RolloutResult.concatenate([rollout(p, threads=1) for p in parts])
    assert_results_identical(joined, result)


def test_pickled_model_gives_identical_results(rmodel, varied_states):
    req = random_request(rmodel, varied_states[:3], np.random.default_rng(5))
    copy = pickle.loads(pickle.dumps(rmodel))
    assert copy.site_names == rmodel.site_names and copy.root_body == rmodel.root_body
    again = RolloutRequest(copy, req.initial_states, req.controls, K)
    assert_results_identical(rollout(req, threads=1), rollout(again, threads=1))


def test_state_helpers_round_trip(rmodel, varied_states):
    m = rmodel.model
    data = mujoco.MjData(m)
    set_state(m, data, varied_states[0])
    np.testing.assert_array_equal(get_state(m, data), varied_states[0])
    sl = state_slices(m)
    np.testing.assert_array_equal(varied_states[0][sl["qpos"]], data.qpos)
    np.testing.assert_array_equal(varied_states[0][sl["qvel"]], data.qvel)
    assert varied_states[0][sl["time"]][0] == data.time
    with pytest.raises(RolloutError, match="FULLPHYSICS"):
        set_state(m, data, varied_states[0][:-1])
    # a Character-style mjSTATE_INTEGRATION state converts to the same full-physics state
    spec = int(mujoco.mjtState.mjSTATE_INTEGRATION)
    integ = np.empty(mujoco.mj_stateSize(m, spec))
    mujoco.mj_getState(m, data, integ, spec)
    np.testing.assert_array_equal(to_fullphysics(m, integ), varied_states[0])
    np.testing.assert_array_equal(to_fullphysics(m, np.stack([integ, integ]))[1], varied_states[0])
    with pytest.raises(RolloutError, match="shape"):
        to_fullphysics(m, varied_states[0])


def test_humanoid_sensor_layout(rmodel):
    assert rmodel.root_body == "RootJoint"
    assert {"head", "left_hand", "right_hand", "left_foot", "right_foot"} <= set(
        rmodel.site_names)
    feet = {b for b, f in zip(rmodel.contact_bodies, rmodel.foot_mask, strict=True) if f}
    assert feet == {"lAnkle", "lToeJoint", "rAnkle", "rToeJoint"}  # from the metadata roles
    assert rmodel.nu == rmodel.model.nu and rmodel.dt == pytest.approx(0.002)


SMALL = """<mujoco><worldbody><geom name="ground" type="plane" size="5 5 .1"/>
<body name="trunk" pos="0 0 .5"><freejoint/><geom type="capsule" size=".05 .2"/><site name="tip"/>
 <body name="shoe" pos="0 0 -.3"><joint name="j" axis="0 1 0"/><geom type="box" size=".1 .05 .02"/>
 </body></body></worldbody><actuator><position joint="j" kp="50" kv="5"/></actuator></mujoco>"""


def test_model_options_and_errors():
    small = RolloutModel.from_source(SMALL, floor="ground")
    assert small.contact_bodies == ("trunk", "shoe") and small.foot_mask.tolist() == [False, True]
    assert small.site_names == ("tip",) and small.root_body == "trunk"
    spec = mujoco.MjSpec.from_string(SMALL)
    none = RolloutModel.from_source(spec, floor=None, sites=[])
    assert none.contact_bodies == () and none.site_names == ()
    assert len(spec.sensors) == 0  # the caller's spec is not modified
    result = rollout(RolloutRequest(none, none.initial_state(), np.zeros((2, 1)), 5), threads=1)
    assert result.contacts.shape == (1, 2, 0) and result.sites.shape == (1, 2, 0, 3)
    for kwargs, match in (({}, "floor"), ({"floor": "ground", "sites": ["nope"]}, "nope"),
                          ({"floor": "ground", "foot_bodies": ["heel"]}, "heel")):
        with pytest.raises(RolloutError, match=match):
            RolloutModel.from_source(SMALL, **kwargs)
    with pytest.raises(RolloutError, match="no such model file"):
        RolloutModel.from_source("/nonexistent/model.xml")
    with pytest.raises(RolloutError, match="parse"):
        RolloutModel.from_source("<mujoco><worldbody><body></mujoco>")


def test_bad_requests_raise_project_errors(rmodel):
    s0 = rmodel.initial_state()
    ok = np.zeros((2, 3, rmodel.nu))
    bad = [
        dict(initial_states=s0[:-1], controls=ok, steps_per_control=K),
        dict(initial_states=s0, controls=ok[..., :-1], steps_per_control=K),
        dict(initial_states=np.stack([s0] * 3), controls=ok, steps_per_control=K),
        dict(initial_states=s0, controls=ok, steps_per_control=0),
        dict(initial_states=s0, controls=ok, steps_per_control=2.5),
        dict(initial_states=s0, controls=np.full_like(ok, np.nan), steps_per_control=K),
        dict(initial_states=s0, controls=ok, steps_per_control=K,
             xfrc_applied=np.zeros((2, 3, 1, 6))),
    ]
    for kwargs in bad:
        with pytest.raises(MjcharError):
            RolloutRequest(rmodel, **kwargs)
    with pytest.raises(RolloutError, match="RolloutModel"):
        RolloutRequest(rmodel.model, s0, ok, K)
    with pytest.raises(RolloutError, match="threads"):
        RolloutRunner(rmodel, threads=0)
    runner = RolloutRunner(rmodel, threads=1)
    runner.close()
    with pytest.raises(RolloutError, match="closed"):
        runner.run(RolloutRequest(rmodel, s0, ok, K))
