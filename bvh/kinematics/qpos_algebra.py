"""Vectorised qpos algebra of one MuJoCo model: ``mj_differentiatePos`` / ``mj_integratePos``
semantics on stacks of qpos vectors ``(N, nq)``.

:class:`_QposAlgebra` splits a model's qpos into linear coordinates (free-joint positions, hinge
and slide angles/offsets: added) and unit quaternions (free-joint and ball orientations: composed,
``q1 = q0 exp(v)`` with the angular velocity ``v`` in the body frame), so differences, integration
and interpolation (linear angles, slerped quaternions) run in one numpy pass over many frames.
Used by :class:`mjchar.bvh.reference.reference_motion.ReferenceMotion` for its per-frame velocities,
interpolation between frames and the projection IK's steps.
"""

from __future__ import annotations

import mujoco
import numpy as np

from mjchar.bvh.rotations import (
    quat_conj,
    quat_from_rotvec,
    quat_mul,
    quat_normalize,
    quat_slerp,
    quat_to_rotvec,
)

# MuJoCo enum values as plain ints (numpy ints and pybind enums do not compare inside ``in``)
_FREE, _BALL, _SLIDE, _HINGE = (int(mujoco.mjtJoint.mjJNT_FREE), int(mujoco.mjtJoint.mjJNT_BALL),
                                int(mujoco.mjtJoint.mjJNT_SLIDE), int(mujoco.mjtJoint.mjJNT_HINGE))


class _QposAlgebra:
    """Differences and interpolation of stacks of qpos vectors ``(N, nq)`` for one model."""

    def __init__(self, model: mujoco.MjModel):
        self.nq, self.nv = model.nq, model.nv
        lin_q, lin_v, quat_q, quat_v = [], [], [], []
        for j in range(model.njnt):
            qa, va, t = int(model.jnt_qposadr[j]), int(model.jnt_dofadr[j]), int(model.jnt_type[j])
            if t == _FREE:
                lin_q += [qa, qa + 1, qa + 2]
                lin_v += [va, va + 1, va + 2]
                quat_q.append(qa + 3)
                quat_v.append(va + 3)
            elif t == _BALL:
                quat_q.append(qa)
                quat_v.append(va)
            else:
                lin_q.append(qa)
                lin_v.append(va)
        self.lin_q, self.lin_v = np.array(lin_q, int), np.array(lin_v, int)
        self.quat_q = np.array(quat_q, int)[:, None] + np.arange(4)
        self.quat_v = np.array(quat_v, int)[:, None] + np.arange(3)

    def diff(self, q0: np.ndarray, q1: np.ndarray) -> np.ndarray:
        """``(N, nv)`` velocity taking ``q0`` to ``q1`` in unit time (``mj_differentiatePos``)."""
        v = np.zeros((*q0.shape[:-1], self.nv))
        v[..., self.lin_v] = q1[..., self.lin_q] - q0[..., self.lin_q]
        if len(self.quat_q):
            a, b = q0[..., self.quat_q], q1[..., self.quat_q]
            v[..., self.quat_v] = quat_to_rotvec(quat_mul(quat_conj(quat_normalize(a)),
                                                          quat_normalize(b)))
        return v

    def integrate(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """``(N, nq)`` result of moving ``q`` with velocity ``v`` for unit time
        (``mj_integratePos``)."""
        out = np.array(q, dtype=float, copy=True)
        out[..., self.lin_q] += v[..., self.lin_v]
        if len(self.quat_q):
            out[..., self.quat_q] = quat_normalize(
                quat_mul(out[..., self.quat_q], quat_from_rotvec(v[..., self.quat_v])))
        return out

    def interpolate(self, q0: np.ndarray, q1: np.ndarray, alpha: np.ndarray) -> np.ndarray:
        """``(N, nq)``: ``integrate(q0, alpha * diff(q0, q1))`` (linear angles, slerp quats)."""
        out = np.array(q0, dtype=float, copy=True)
        a = np.asarray(alpha, dtype=float)
        out[..., self.lin_q] += a[..., None] * (q1[..., self.lin_q] - q0[..., self.lin_q])
        if len(self.quat_q):
            out[..., self.quat_q] = quat_slerp(q0[..., self.quat_q], q1[..., self.quat_q],
                                               a[..., None])
        return out
