"""A walker's legs and the small rotation algebra the walking controllers share: :class:`Leg`
(the dofs, bodies, sole site and segment lengths of one leg, read from the model), the rotation
error between two orientations, a 3 x 3 inverse, heading (yaw) and angle wrapping."""

from __future__ import annotations

import math

import mujoco
import numpy as np

from ..core.character import Character
from .ipm_params import IPMError
from .swing import frame_from_axes


def wrap_angle(a: float) -> float:
    """``a`` (rad) wrapped to ``[-pi, pi)``."""
    return (a + math.pi) % (2 * math.pi) - math.pi


def rotation_error(R_des: np.ndarray, R: np.ndarray) -> np.ndarray:
    """World rotation vector (rad) of ``R_des R^T``."""
    E = R_des @ R.T
    q = np.empty(4)
    mujoco.mju_mat2Quat(q, E.ravel())
    if q[0] < 0:
        q = -q
    s = math.sqrt(q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    if s < 1e-12:
        return 2.0 * q[1:]
    return q[1:] * (2.0 * math.atan2(s, q[0]) / s)


def inverse3(A: np.ndarray) -> np.ndarray:
    """Inverse of a ``(3, 3)`` matrix by the adjugate (cheaper than ``np.linalg.inv``)."""
    (a, b, c), (d, e, f), (g, h, i) = A.tolist()
    co = [e * i - f * h, f * g - d * i, d * h - e * g]
    det = a * co[0] + b * co[1] + c * co[2]
    if abs(det) < 1e-12:
        return np.linalg.pinv(A)
    return np.array([[co[0], c * h - b * i, b * f - c * e],
                     [co[1], a * i - c * g, c * d - a * f],
                     [co[2], b * g - a * h, a * e - b * d]]) / det


def yaw_of(R: np.ndarray) -> float:
    """Heading angle (rad) of a body orientation ``(3, 3)``: its x axis projected on the floor."""
    return math.atan2(R[1, 0], R[0, 0])


class Leg:
    """Indices of one leg (hip, knee, ankle, toe) of a Character."""

    def __init__(self, ch: Character, side: str):
        m = ch.model
        self.side = side
        self.hip_name = ch.role(f"{side}_hip")
        self.knee_name = ch.role(f"{side}_knee")
        self.ankle_name = ch.role(f"{side}_ankle")
        self.toe_name = ch.role(f"{side}_toe", required=False)
        self.hip = ch.joint_dofs(self.hip_name)
        self.knee = ch.joint_dofs(self.knee_name)
        self.ankle = ch.joint_dofs(self.ankle_name)
        self.toe = ch.joint_dofs(self.toe_name) if self.toe_name else np.zeros(0, int)
        if len(self.hip) != 3 or len(self.knee) != 1 or len(self.ankle) != 3:
            raise IPMError(f"IPM needs 3-dof hips and ankles and a hinge knee ({side} leg has "
                           f"{len(self.hip)}, {len(self.knee)}, {len(self.ankle)} dofs); convert "
                           "with joint_model='hinge'")
        self.thigh = ch.body_id(self.hip_name)
        self.shank = ch.body_id(self.knee_name)
        self.foot = ch.body_id(self.ankle_name)
        self.site = ch.site_id(f"{side}_foot")
        if int(m.site_bodyid[self.site]) != self.foot:
            raise IPMError(f"site {side}_foot is not on the {side} ankle body")
        self.site_offset = m.site_pos[self.site].copy()            # in the foot frame
        self.hip_jnt = m.dof_jntid[self.hip]
        self.ankle_jnt = m.dof_jntid[self.ankle]
        self.knee_q = ch.joint_qpos(self.knee_name)[0]
        self.knee_dof = int(self.knee[0])
        self.leg = np.concatenate([self.hip, self.knee, self.ankle])
        self.all = np.concatenate([self.leg, self.toe])
        # geometry from the model (bodies world-aligned at rest, contract)
        qk = m.body_quat[self.shank]
        knee_in_thigh = m.body_pos[self.shank].copy()
        ankle_in_shank = m.body_pos[self.foot].copy()
        self.l1 = float(np.linalg.norm(knee_in_thigh))
        self.l2 = float(np.linalg.norm(ankle_in_shank))
        Rk = np.empty(9)
        mujoco.mju_quat2Mat(Rk, qk)
        axis_in_thigh = Rk.reshape(3, 3) @ m.jnt_axis[m.dof_jntid[self.knee_dof]]
        self.thigh_rest = frame_from_axes(knee_in_thigh, axis_in_thigh)  # (3,3) columns
