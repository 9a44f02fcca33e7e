"""The root-help check (controllers/core/root_help.py): every force or torque from outside the
joint actuators that a run did not declare as a push makes ``root_force_max_N`` or
``root_torque_max_Nm`` non-zero, so ``Result.unaided`` (the claim "no root force") is false;
declared pushes are not help."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mjchar.controllers import Character, make_controller
from mjchar.controllers.core.action import Action
from mjchar.controllers.core.scenarios.shared import PushEvent, simulate, standing_pose, with_push


class Helped:
    """Static balance with hidden help added by ``cheat(character, action) -> action``."""

    def __init__(self, character, cheat):
        self.inner = make_controller("static_balance", character)
        self.cheat = cheat
        self.name = "helped"

    def reset(self, character):
        self.inner.reset(character)

    def act(self, character, t):
        return self.cheat(character, self.inner.act(character, t))


def _run(cheat=None, push: PushEvent | None = None, character=None, duration=0.6):
    ch = character or Character()
    ctrl = Helped(ch, cheat or (lambda c, a: a))
    return simulate(ch, ctrl, duration=duration, scenario="stand", qpos=standing_pose(ch),
                    **with_push(push, {}))


def test_standing_on_its_own_feet_is_unaided():
    r = _run()
    assert r.unaided and r.root_force_max_N == 0.0 and r.root_torque_max_Nm == 0.0


@pytest.mark.parametrize("body", [None, "head"])
def test_a_declared_push_is_not_help(body):
    ch = Character()
    push = PushEvent(60.0, 90.0, time=0.1, duration=0.2, body=body and ch.role(body))
    r = _run(push=push, character=ch)
    assert r.unaided, (r.root_force_max_N, r.root_torque_max_Nm)


def _root_torque(ch, action):
    tau = np.zeros(ch.nv) if action.torque is None else action.torque.copy()
    tau[ch.root_dofs[3:]] = [0.0, 0.0, 7.0]  # a torque-only root wrench, 7 N m about z
    return Action(torque=tau, target=action.target)


def test_a_hidden_root_torque_is_caught():
    r = _run(_root_torque)
    assert not r.unaided
    assert r.root_force_max_N == 0.0  # no force: only the torque gives it away
    assert r.root_torque_max_Nm == pytest.approx(7.0)


def _hidden_xfrc(ch, action):
    ch.data.xfrc_applied[ch.body_id(ch.role("head")), 2] = 25.0  # lifts the head, 25 N
    return action


def test_a_hidden_xfrc_applied_on_a_body_that_is_not_the_root_is_caught():
    r = _run(_hidden_xfrc)
    assert not r.unaided and r.root_force_max_N == pytest.approx(25.0)


def test_a_hidden_xfrc_applied_is_caught_beside_a_declared_push():
    """A 100 N declared push on the pelvis from 0.1 to 0.3 s and 25 N hidden on the head: the
    check reads the 25 N, not the push."""
    r = _run(_hidden_xfrc, push=PushEvent(100.0, 0.0, time=0.1, duration=0.2))
    assert not r.unaided and r.root_force_max_N == pytest.approx(25.0)


def test_a_hidden_torque_in_xfrc_applied_is_caught():
    def cheat(ch, action):
        ch.data.xfrc_applied[ch.body_id(ch.role("head")), 3:] = [0.0, 3.0, 0.0]
        return action

    r = _run(cheat)
    assert not r.unaided and r.root_force_max_N == 0.0
    assert r.root_torque_max_Nm == pytest.approx(3.0)


def test_qfrc_applied_written_on_the_roots_dofs_is_caught():
    """Written straight into MjData with no action (the last controls held): the actuation
    never sees it."""
    def cheat(ch, action):
        ch.data.qfrc_applied[ch.root_dofs[2]] = 40.0
        return None

    r = _run(cheat)
    assert not r.unaided and r.root_force_max_N == pytest.approx(40.0)


def test_gravity_compensation_of_a_body_is_caught():
    """A model whose head floats (``gravcomp="1"``, compiled in: MuJoCo counts such bodies at
    compile time)."""
    import mujoco

    from mjchar.bvh.bundled.assets import HUMANOID_XML

    ch = Character()
    head = ch.role("head")
    text = Path(HUMANOID_XML).read_text()
    old = f'<body name="{head}"'
    assert text.count(old) == 1
    model = mujoco.MjModel.from_xml_string(text.replace(old, old + ' gravcomp="1"'))
    ch = Character(model, info=ch.info)
    r = _run(character=ch)
    head_weight = model.body_mass[ch.body_id(head)] * 9.81
    assert not r.unaided and r.root_force_max_N == pytest.approx(head_weight, rel=1e-3)
