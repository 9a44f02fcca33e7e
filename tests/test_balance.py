"""Static balance (PD pose + Jacobian-transpose virtual COM force) on the bundled humanoid, with no
root force: standing, the random 10 N push test, single pushes in four directions without a step,
push search and squatting. The 30 s x 5 seeds runs are marked slow; shorter versions run by
default."""

from __future__ import annotations

import numpy as np
import pytest

from mjchar.controllers.balance.static_balance import StaticBalance, squat_profile
from mjchar.controllers.core import scenarios as S
from mjchar.controllers.core.base import Action
from mjchar.controllers.core.character import Character
from mjchar.controllers.core.registry import make_controller
from mjchar.controllers.core.scenarios.push_search import PushProtocol, survival_rates


@pytest.fixture(scope="module")
def ch() -> Character:
    return Character()


def assert_no_root_force(r) -> None:
    assert r.root_force_mean_N == 0.0 and r.root_force_max_N == 0.0
    assert r.root_torque_mean_Nm == 0.0


def test_stands_10s(ch):
    r = S.stand(ch, StaticBalance(), duration=10.0)
    assert not r.fell and r.sim_time_s == pytest.approx(10.0)
    assert r.foot_travel_m < 0.01
    assert_no_root_force(r)


@pytest.mark.slow
def test_stands_30s(ch):
    r = S.stand(ch, StaticBalance(), duration=30.0)
    assert not r.fell and r.sim_time_s == pytest.approx(30.0)
    assert_no_root_force(r)


def test_random_10N_push_10s(ch):
    r = S.random_push(ch, StaticBalance(), seed=0, duration=10.0)
    assert not r.fell and not r.stepped
    assert_no_root_force(r)


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(5))
def test_random_10N_push_30s_five_seeds(ch, seed):
    r = S.random_push(ch, StaticBalance(), seed=seed, duration=30.0)
    assert not r.fell and not r.stepped
    assert r.sim_time_s == pytest.approx(30.0)
    assert_no_root_force(r)


@pytest.mark.parametrize("direction", ["forward", "left", "backward", "right"])
def test_survives_50N_pelvis_push_without_a_step(ch, direction):
    r = S.push(ch, StaticBalance(), force=50.0, direction=S.DIRECTIONS[direction])
    assert not r.fell
    assert r.foot_travel_m < 0.02  # feet stay where they were: no step
    assert r.max_push_N == 50.0
    assert_no_root_force(r)


def test_virtual_force_beats_the_pose_pd_alone(ch):
    """A backward push the PD pose alone cannot take, which the static balance survives."""
    pd_only = S.push(ch, make_controller("spd", ch), force=60.0,
                     direction=S.DIRECTIONS["backward"])
    balance = S.push(ch, StaticBalance(), force=60.0, direction=S.DIRECTIONS["backward"])
    assert pd_only.fell or pd_only.stepped
    assert not balance.fell and not balance.stepped


def test_survives_50N_pushes_at_every_moment_seed_and_direction():
    """The push protocol at 50 N (4 moments x 2 seeds x 4 directions): every run survived, with
    no step; the unpushed runs over the same window stand."""
    protocol = PushProtocol(forces=(50.0,), phases=4, seeds=(0, 1))
    rates = survival_rates("static_balance", protocol, processes=2)
    assert not rates.falls_unpushed
    assert len(rates.runs) == 4 * 2 * 4 and all(r["survived"] for r in rates.runs)
    assert rates.largest_100_N == {d: 50.0 for d in S.DIRECTIONS}
    assert all(rates.at_cap.values())


def test_squats_02m_and_rises(ch):
    c = StaticBalance(height=squat_profile(0.2, start=0.5, down=1.5, hold=1.0, up=1.5))
    com = []
    r = S.simulate(ch, c, duration=6.0, scenario="squat", qpos=S.standing_pose(ch),
                   frame_callback=lambda x: com.append(x.state.com()[2]))
    com = np.array(com)
    assert not r.fell and not r.stepped
    assert com.min() <= com[0] - 0.18          # went down ~0.2 m
    assert com[-1] >= com[0] - 0.02            # and came back up
    assert_no_root_force(r)


def test_virtual_force_torques_are_minus_jacobian_transpose(ch):
    """tau_i = a_i . ((p_i - x) x f) on the stance legs only (hip, knee, ankle; no toes)."""
    ch.reset(S.standing_pose(ch))
    ch.actuation.set_mode("native")
    for _ in range(50):
        ch.step()
    c = StaticBalance()
    c.reset(ch)
    f = np.array([12.0, -7.0, 30.0])
    tau = c.virtual_force_torques(ch, f)
    x = ch.state.com()
    knee = ch.role("left_knee")
    d = ch.joint_dofs(knee)[0]
    j = int(ch.model.dof_jntid[d])
    axis, anchor = ch.data.xaxis[j], ch.data.xanchor[j]
    assert tau[d] == pytest.approx(0.5 * axis @ np.cross(anchor - x, f), rel=1e-9)
    legs = ch.dofs(["left_hip", "left_knee", "left_ankle", "right_hip", "right_knee",
                    "right_ankle"])
    others = np.setdiff1d(np.arange(ch.nv), legs)
    assert not tau[others].any()  # no toes, no root, no upper body
    assert isinstance(c.act(ch, 0.0), Action)
