"""The root-help check: every force and torque from outside the character's own joint actuators
that a run did not declare, measured after each control step.

A controller that "needs no root force" must get no help from outside in any form. The check
reads, after each step, what acted during it:

- the root wrench of the last action (the hand of god, ``character.actuation.root_wrench``),
  force and torque;
- ``qfrc_applied`` on the root's 6 dofs (force on the 3 translations, torque on the 3
  rotations), whoever wrote it;
- actuator forces on the root's dofs (``qfrc_actuator``: a model with a motor on its root) and,
  on a model with gravity compensation, ``qfrc_gravcomp`` on them (the net lift on the body);
- ``xfrc_applied`` on every body, force and torque, minus what the declared pushes
  (``character.pushes``) wrote there: a scenario's push is part of its protocol, not help.

:meth:`RootHelp.measure` gives the largest force (N) and the largest torque (N m) among these;
both are 0 exactly when nothing helped. Each check is a sum of absolute values (MuJoCo's
``mju_L1``), the norms are taken only when one is not zero.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np


def _l1(x: np.ndarray) -> float:
    """Sum of the absolute values of the 1-D float64 array ``x`` (``mju_L1`` on a contiguous
    vector, numpy otherwise)."""
    try:
        return mujoco.mju_L1(x)
    except TypeError:
        return float(np.abs(x).sum())


def _norm3(v: np.ndarray) -> float:
    x, y, z = v.tolist()
    return math.sqrt(x * x + y * y + z * z)


class RootHelp:
    """Measures the outside help a character gets in one step (see the module docstring).

    Args:
        character: the :class:`~mjchar.controllers.core.character.Character` watched (its
            model, data, root dofs, actuation and push schedule).
    """

    def __init__(self, character):
        m, d = character.model, character.data
        self._actuation = character.actuation
        self._pushes = character.pushes
        first = int(character.root_dofs[0])  # a free joint's 6 dofs are consecutive
        root = slice(first, first + 6)
        # views into MjData's buffers (fixed for the data's life): no lookups per step
        self._rows = [d.qfrc_applied[root]]
        if self._actuators_may_reach_root(m, int(m.dof_jntid[first])):
            self._rows.append(d.qfrc_actuator[root])
        if np.any(m.body_gravcomp) and hasattr(d, "qfrc_gravcomp"):
            self._rows.append(d.qfrc_gravcomp[root])
        self._xfrc = d.xfrc_applied
        self._xfrc_flat = self._xfrc.reshape(-1)

    @staticmethod
    def _actuators_may_reach_root(m: mujoco.MjModel, root_joint: int) -> bool:
        """Whether some actuator can act on the root's dofs: one on the root joint, or one with a
        transmission other than a joint (a tendon or a site may span the root)."""
        # (against the enum's int: comparing an array with the enum object is ~50 us)
        joint = m.actuator_trntype == int(mujoco.mjtTrn.mjTRN_JOINT)
        return bool(np.any(~joint) or np.any(m.actuator_trnid[joint, 0] == root_joint))

    def external_wrenches(self) -> np.ndarray:
        """``(nbody, 6)`` ``xfrc_applied`` (world force N, torque N m) beyond the declared
        pushes."""
        return self._xfrc - self._pushes.written if self._pushes.applied else self._xfrc

    def measure(self) -> tuple[float, float]:
        """``(force N, torque N m)``: the largest undeclared outside force and torque on the
        character during the last step; ``(0.0, 0.0)`` when it had no help."""
        force = torque = 0.0
        act = self._actuation
        if act.root_wrench_applied:
            w = act.root_wrench
            force, torque = _norm3(w[:3]), _norm3(w[3:])
        for g in self._rows:
            if _l1(g) != 0.0:
                force, torque = max(force, _norm3(g[:3])), max(torque, _norm3(g[3:]))
        pushed = self._pushes.applied
        if pushed or _l1(self._xfrc_flat) != 0.0:
            xf = self.external_wrenches()
            if not pushed or xf.any():
                force = max(force, float(np.linalg.norm(xf[:, :3], axis=1).max()))
                torque = max(torque, float(np.linalg.norm(xf[:, 3:], axis=1).max()))
        return force, torque
