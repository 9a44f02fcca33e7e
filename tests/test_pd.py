"""The PD family (explicit, stable, native) and hand-of-god on the bundled humanoid: the control
laws against their formulas, the stability ordering at one time step, hand-of-god tracking of
walk60 and the fall of pure PD tracking."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from conftest import shared_clip

from mjchar import bvh
from mjchar.bvh.reference.reference_motion import ReferenceMotion
from mjchar.controllers.balance.hand_of_god import HandOfGod
from mjchar.controllers.core import scenarios as S
from mjchar.controllers.core.base import Action, ControllerError, Gains, PoseTarget, joint_error
from mjchar.controllers.core.character import Character
from mjchar.controllers.core.pd import NativePDController, PDController, StablePDController
from mjchar.controllers.core.registry import make_controller


@pytest.fixture(scope="module")
def ch() -> Character:
    return Character()


@pytest.fixture(scope="module")
def walk60_ref(ch) -> ReferenceMotion:
    return ReferenceMotion(ch.model, bvh.load(shared_clip("walk60.bvh")))


def random_state(ch: Character, seed: int = 0):
    """A standing pose with random joint offsets and velocities, and a random target."""
    rng = np.random.default_rng(seed)
    q0 = S.standing_pose(ch)
    v = np.zeros(ch.nv)
    v[ch.actuated] = rng.uniform(-0.3, 0.3, ch.actuated.sum())
    q = ch.dynamics.integrate(q0, v, 1.0)
    qd = rng.normal(0, 0.5, ch.nv)
    q_bar = ch.dynamics.integrate(q0, rng.normal(0, 0.2, ch.nv) * ch.actuated, 1.0)
    qd_bar = rng.normal(0, 0.5, ch.nv) * ch.actuated
    return q, qd, q_bar, qd_bar


class Fixed:
    """A target callable with a fixed (q_bar, qd_bar)."""

    def __init__(self, q, qd):
        self.q, self.qd = q, qd

    def __call__(self, t):
        return self.q, self.qd


def test_explicit_pd_is_the_textbook_law(ch):
    q, qd, q_bar, qd_bar = random_state(ch, 1)
    ch.reset(q, qd)
    c = PDController(Fixed(q_bar, qd_bar))
    c.reset(ch)
    tau = c.act(ch, 0.0).torque
    kp, kd = ch.actuation.default_gains()
    knee = ch.joint_dofs("lKnee")[0]
    kq = ch.joint_qpos("lKnee")[0]
    assert tau[knee] == pytest.approx(kp[knee] * (q_bar[kq] - q[kq]) + kd[knee] * (qd_bar[knee]
                                                                                    - qd[knee]))
    np.testing.assert_allclose(tau, kp * joint_error(ch, q_bar) + kd * (qd_bar - qd))
    assert not tau[ch.root_dofs].any()  # no root force


def test_stable_pd_matches_tan_liu_turk_with_dense_mass_matrix(ch):
    q, qd, q_bar, qd_bar = random_state(ch, 2)
    ch.reset(q, qd)
    ch.set_timestep(1 / 120)
    try:
        c = StablePDController(Fixed(q_bar, qd_bar))
        c.reset(ch)
        tau = c.act(ch, 0.0).torque
        dt = 1 / 120
        kp, kd = ch.actuation.default_gains()
        M = np.zeros((ch.nv, ch.nv))
        mujoco.mj_fullM(ch.model, ch.data, M)
        q_pred = q.copy()
        mujoco.mj_integratePos(ch.model, q_pred, qd, dt)
        e = np.zeros(ch.nv)
        mujoco.mj_differentiatePos(ch.model, e, 1.0, q_pred, q_bar)  # -(q + dt qdot - q_bar)
        tau_ext = ch.data.qfrc_passive + ch.data.qfrc_constraint
        qdd = np.linalg.solve(M + np.diag(kd * dt),
                              -ch.data.qfrc_bias + kp * e + kd * (qd_bar - qd) + tau_ext)
        expected = kp * e + kd * (qd_bar - qd - dt * qdd)
        np.testing.assert_allclose(tau, expected, rtol=1e-9, atol=1e-9)
        assert not tau[ch.root_dofs].any()
    finally:
        ch.set_timestep(0.002)


def test_native_pd_folds_target_velocity_into_the_setpoint(ch):
    q, qd, q_bar, qd_bar = random_state(ch, 3)
    ch.reset(q, qd)
    c = NativePDController(Fixed(q_bar, qd_bar))
    c.reset(ch)
    assert ch.actuation.mode == "native"
    ch.actuation.set_torque_limits(False)
    try:
        ch.actuation.apply(c.act(ch, 0.0))
        mujoco.mj_fwdActuation(ch.model, ch.data)
        kp, kd = ch.actuation.default_gains()
        expected = kp * joint_error(ch, q_bar) + kd * (qd_bar - qd)
        a = ch.actuator_dof
        np.testing.assert_allclose(ch.data.qfrc_actuator[a], expected[a], rtol=1e-9, atol=1e-8)
    finally:
        ch.actuation.set_torque_limits(True)


def test_gains_are_validated(ch):
    with pytest.raises(ControllerError):
        Gains.uniform(ch, -1.0)
    c = PDController(gains=Gains(np.ones(3), np.ones(3)))
    ch.reset(S.standing_pose(ch))
    with pytest.raises(ControllerError):
        c.reset(ch)
    with pytest.raises(ControllerError, match="before reset"):
        PDController().act(ch, 0.0)
    g = Gains.uniform(ch, 1000.0)
    assert g.kp[ch.actuated].min() == 1000 and g.kd[ch.actuated].max() == 100
    assert not g.kp[ch.root_dofs].any()


def test_pose_target_holds_and_action_shapes(ch):
    ch.reset(S.standing_pose(ch))
    c = StablePDController()  # holds the pose at reset
    c.reset(ch)
    assert isinstance(c.target, PoseTarget)
    a = c.act(ch, 0.0)
    assert isinstance(a, Action) and a.torque.shape == (ch.nv,) and a.target is None
    n = NativePDController()
    n.reset(ch)
    a = n.act(ch, 0.0)
    assert a.torque is None and a.target.shape == (ch.nu,)


@pytest.mark.parametrize("controller,holds", [("spd", True), ("native_pd", True), ("pd", False)])
def test_stability_ordering_at_one_120th_second(ch, controller, holds):
    """kp 1000, kd 100, root welded, 0.2 rad initial error, 5 s at 1/120 s: the implicit
    variants hold the pose, explicit PD does not."""
    r = S.hold_pose(ch, controller, kp=1000.0, timestep=1 / 120, duration=5.0)
    assert r.held is holds
    if holds:
        assert r.rms_error < 0.01
    ch.set_timestep(0.002)


def test_explicit_pd_needs_a_step_at_least_8x_smaller(ch):
    """Explicit PD (kp 1000) fails at 1/960 s (8x smaller than 1/120) and holds at 1/4000 s."""
    assert not S.hold_pose(ch, "pd", kp=1000.0, timestep=1 / 960, duration=2.0).held
    r = S.hold_pose(ch, "pd", kp=1000.0, timestep=1 / 4000, duration=2.0)
    assert r.held and r.rms_error < 0.01
    ch.set_timestep(0.002)


def test_hand_of_god_tracks_walk60_over_the_whole_clip(ch, walk60_ref):
    c = make_controller("hand_of_god", ch, walk60_ref)
    r = S.track(ch, c, walk60_ref)
    assert not r.fell
    assert r.sim_time_s == pytest.approx(walk60_ref.duration, abs=0.01)
    assert r.tracking_error_m < 0.03
    assert r.root_error_m < 0.05
    # the puppet string carries about the body weight (the reference's mid-stance feet float)
    assert 300.0 < r.root_force_mean_N < 1500.0
    assert r.distance_m > 3.0


def test_hand_of_god_with_native_pd_also_tracks(ch, walk60_ref):
    c = HandOfGod(NativePDController(walk60_ref))
    r = S.track(ch, c, walk60_ref)
    assert not r.fell and r.tracking_error_m < 0.03 and r.root_error_m < 0.05


@pytest.mark.parametrize("controller", ["spd", "native_pd"])
def test_pure_pd_tracking_of_walk60_falls(ch, walk60_ref, controller):
    r = S.track(ch, make_controller(controller, ch, walk60_ref), walk60_ref)
    assert r.fell and r.fall_time_s < walk60_ref.duration
    assert r.root_force_mean_N == 0.0
