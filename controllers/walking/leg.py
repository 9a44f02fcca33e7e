"""A walker's legs and the small rotation algebra the walking controllers share: :class:`Leg`
(the dofs, bodies, sole site and segment lengths of one leg, read through the Character), the
rotation error between two orientations, a 3 x 3 inverse and angle wrapping (a body's heading:
:func:`~mjchar.controllers.core.geometry.heading_yaw`; the hinges of the bodies on the pelvis:
:func:`~mjchar.controllers.walking.rig_map.child_hinges`)."""

from __future__ import annotations

import math

import mujoco
import numpy as np

from ..core.character import Character, Kinematics
from .ipm_params import IPMError
from .rig_map import leg_joints
from .swing import frame_from_axes, rotation_about


def wrap_angle(a: float) -> float:
    """``a`` (rad) wrapped to ``[-pi, pi)``."""
    return (a + math.pi) % (2 * math.pi) - math.pi


def rotation_error(R_des: np.ndarray, R: np.ndarray) -> np.ndarray:
    """World rotation vector (rad) of ``R_des R^T`` (its quaternion's arithmetic on Python
    floats: numpy's element-wise IEEE operations without its per-call overhead)."""
    return np.array(rotation_error3(R_des, R))


def rotation_error3(R_des: np.ndarray, R: np.ndarray) -> list[float]:
    """:func:`rotation_error` as a list of three Python floats."""
    E = R_des @ R.T
    q = np.empty(4)
    mujoco.mju_mat2Quat(q, E.ravel())
    return rotvec_of_quat(*q.tolist())


def inverse3(A: np.ndarray) -> np.ndarray:
    """Inverse of a ``(3, 3)`` matrix by the adjugate (cheaper than ``np.linalg.inv``)."""
    (a, b, c), (d, e, f), (g, h, i) = A.tolist()
    co = [e * i - f * h, f * g - d * i, d * h - e * g]
    det = a * co[0] + b * co[1] + c * co[2]
    if abs(det) < 1e-12:
        return np.linalg.pinv(A)
    return np.array([[co[0] / det, (c * h - b * i) / det, (b * f - c * e) / det],
                     [co[1] / det, (a * i - c * g) / det, (c * d - a * f) / det],
                     [co[2] / det, (b * g - a * h) / det, (a * e - b * d) / det]])


def solve3(A: list[list[float]], b: list[float]) -> list[float]:
    """``inverse3(A) @ b`` for a ``(3, 3)`` matrix ``A`` given as rows of Python floats and
    ``b`` three floats (Cramer's rule; the pseudo-inverse when ``A`` is singular)."""
    (a, b_, c), (d, e, f), (g, h, i) = A
    co0, co1, co2 = e * i - f * h, f * g - d * i, d * h - e * g
    det = a * co0 + b_ * co1 + c * co2
    if abs(det) < 1e-12:
        return (np.linalg.pinv(np.array(A)) @ np.array(b)).tolist()
    x, y, z = b
    return [(co0 * x + (c * h - b_ * i) * y + (b_ * f - c * e) * z) / det,
            (co1 * x + (a * i - c * g) * y + (c * d - a * f) * z) / det,
            (co2 * x + (b_ * g - a * h) * y + (a * e - b_ * d) * z) / det]


def matvec3(A: list[list[float]], x: list[float]) -> list[float]:
    """``A @ x`` for a ``(3, 3)`` matrix given as rows of Python floats and three floats."""
    return [r[0] * x[0] + r[1] * x[1] + r[2] * x[2] for r in A]


def quat_mul(p: list[float], q: list[float]) -> list[float]:
    """The quaternion product ``p q`` (``(w, x, y, z)`` as Python floats)."""
    p0, p1, p2, p3 = p
    q0, q1, q2, q3 = q
    return [p0 * q0 - p1 * q1 - p2 * q2 - p3 * q3,
            p0 * q1 + p1 * q0 + p2 * q3 - p3 * q2,
            p0 * q2 - p1 * q3 + p2 * q0 + p3 * q1,
            p0 * q3 + p1 * q2 - p2 * q1 + p3 * q0]


def quat_about(axis: tuple[float, float, float], angle: float) -> list[float]:
    """Unit quaternion of the rotation about the unit ``axis`` by ``angle`` rad."""
    s = math.sin(0.5 * angle)
    return [math.cos(0.5 * angle), axis[0] * s, axis[1] * s, axis[2] * s]


def quat_error(q_des: list[float], q: list[float]) -> list[float]:
    """:func:`rotation_error` of two orientations given as unit quaternions: the world
    rotation vector (rad) of ``q_des q^-1``, three Python floats."""
    p0, p1, p2, p3 = q_des
    q0, q1, q2, q3 = q
    w = p0 * q0 + p1 * q1 + p2 * q2 + p3 * q3
    x = q0 * p1 - p0 * q1 - (p2 * q3 - p3 * q2)
    y = q0 * p2 - p0 * q2 - (p3 * q1 - p1 * q3)
    z = q0 * p3 - p0 * q3 - (p1 * q2 - p2 * q1)
    return rotvec_of_quat(w, x, y, z)


def rotvec_of_quat(w: float, x: float, y: float, z: float) -> list[float]:
    """Rotation vector (rad, three Python floats) of the unit quaternion ``(w, x, y, z)``, the
    short way round."""
    if w < 0:
        w, x, y, z = -w, -x, -y, -z
    s = math.sqrt(x * x + y * y + z * z)
    if s < 1e-12:
        return [2.0 * x, 2.0 * y, 2.0 * z]
    k = 2.0 * math.atan2(s, w) / s
    return [x * k, y * k, z * k]


def mat_quat(R) -> list[float]:
    """Unit quaternion ``(w, x, y, z)`` of a rotation matrix (``(3, 3)`` or row-major nine
    numbers), as Python floats (``mju_mat2Quat``)."""
    q = np.empty(4)
    mujoco.mju_mat2Quat(q, np.asarray(R, dtype=float).reshape(9))
    return q.tolist()


def index_selector(idx: np.ndarray) -> slice | np.ndarray:
    """Integer indices as a slice when they are a consecutive ascending run (a view to read and
    a cheaper write), else as they are."""
    idx = np.asarray(idx, dtype=int)
    if len(idx) and np.array_equal(idx, np.arange(idx[0], idx[0] + len(idx))):
        return slice(int(idx[0]), int(idx[0]) + len(idx))
    return idx


class Leg:
    """Indices and rest geometry of one leg (hip, knee, ankle, toe) of a Character as IPM
    drives it: the joints, bodies and dofs the walkers share
    (:func:`~mjchar.controllers.walking.rig_map.leg_joints`, ``joints``; here also as
    ``hip_name`` .. ``toe_name``, ``hip`` .. ``toe`` and ``thigh``, ``shank``, ``foot``),
    checked for IPM's hinges, with the sole site and the bones' geometry.

    ``rest``: the kinematics of the character's rest pose
    (``ch.poses.kinematics(ch.poses.rest())``; computed when ``None``).
    """

    def __init__(self, ch: Character, side: str, rest: Kinematics | None = None):
        self.side = side
        # the leg's joints by role, their bodies and dofs: what SIMBICON's leg map reads too
        self.joints = j = leg_joints(ch, side)
        self.hip_name, self.knee_name, self.ankle_name, self.toe_name = (j.hip, j.knee, j.ankle,
                                                                         j.toe)
        self.hip, self.knee, self.ankle, self.toe = (j.hip_dofs, j.knee_dofs, j.ankle_dofs,
                                                     j.toe_dofs)
        self.leg = np.concatenate([self.hip, self.knee, self.ankle])
        # the same as slices where they are consecutive (index_selector)
        self.hip_sel, self.ankle_sel = index_selector(self.hip), index_selector(self.ankle)
        self.all = np.concatenate([self.leg, self.toe])
        for role, name, dofs, n in (("hip", self.hip_name, self.hip, 3),
                                    ("knee", self.knee_name, self.knee, 1),
                                    ("ankle", self.ankle_name, self.ankle, 3)):
            if len(dofs) != n or not ch.hinge_dofs[dofs].all():
                kind = (f"has {len(dofs)} hinges" if ch.hinge_dofs[dofs].all()
                        else "is a ball joint")
                want = "3 hinges" if n == 3 else "one hinge"
                raise IPMError(f"IPM needs {want} at the {side} {role} (joint "
                               f"{name} {kind}): convert with --joint-model hinge "
                               "(joint_model='hinge')")
        self.thigh, self.shank, self.foot = j.thigh, j.shank, j.foot
        # the bodies named as the ankle and toe joints: those whose floor contacts hold the foot
        # (its yaw moment, ipm_torques.yaw_capacity)
        ids = (mujoco.mj_name2id(ch.model, mujoco.mjtObj.mjOBJ_BODY, n)
               for n in (self.ankle_name, self.toe_name) if n)
        self.sole_bodies = tuple(b for b in ids if b >= 0)
        self.site = j.site(ch)
        site_body, self.site_offset = ch.poses.site_offset(self.site)  # in the foot frame
        if site_body != self.foot:
            raise IPMError(f"site {side}_foot is not on the {side} ankle body")
        self.hip_jnt = ch.dof_joint[self.hip]
        self.ankle_jnt = ch.dof_joint[self.ankle]
        self.hip_jnt_sel = index_selector(self.hip_jnt)
        self.ankle_jnt_sel = index_selector(self.ankle_jnt)
        self.knee_q = ch.joint_qpos(self.knee_name)[0]
        self.knee_dof = int(self.knee[0])
        # geometry: the bones (model constants) and the knee's hinge axis in the thigh's frame
        if rest is None:
            rest = ch.poses.kinematics(ch.poses.rest())
        knee_in_thigh = ch.poses.body_offset(self.shank)
        ankle_in_shank = ch.poses.body_offset(self.foot)
        self.l1 = float(np.linalg.norm(knee_in_thigh))
        self.l2 = float(np.linalg.norm(ankle_in_shank))
        R_thigh = rest.body_rotations[self.thigh]
        axis_in_thigh = R_thigh.T @ rest.joint_axes[ch.dof_joint[self.knee_dof]]
        self.thigh_rest = frame_from_axes(knee_in_thigh, axis_in_thigh)  # (3,3) columns
        # the knee as the model has it, in the thigh's frame at zero flexion: the bones and the
        # hinge axis (a knee axis fitted to a capture may be tilted off the bones)
        self.bone1 = knee_in_thigh
        self.bone2 = R_thigh.T @ rest.body_rotations[self.shank] @ ankle_in_shank
        self.knee_axis = axis_in_thigh / np.linalg.norm(axis_in_thigh)
        lo, hi = ch.poses.dof_limits(self.knee)[0]
        if lo + hi < 0:  # the stance knee's targets are flexions, positive angles
            raise IPMError(f"IPM needs knees that flex to positive angles (joint "
                           f"{self.knee_name} turns {math.degrees(lo):.0f}..{math.degrees(hi):.0f}"
                           " deg): flip its axis, as mjchar convert does")
        # the textbook leg (axis across both bones, shank in line with the thigh): planar
        # two-link IK; any other knee: the hinge's own IK (Leg.planar, swing.hinge_leg_ik)
        u1 = knee_in_thigh / self.l1
        self.planar = bool(abs(float(self.knee_axis @ u1)) < 1e-6
                           and np.linalg.norm(np.cross(u1, self.bone2 / self.l2)) < 1e-6
                           and float(u1 @ self.bone2) > 0)

    def reach(self, knee: float) -> float:
        """Hip joint to ankle joint distance (m) with the knee at ``knee`` rad:
        ``|l1 + l2 e^(i knee)|`` for the textbook leg, else from the bones and the hinge axis."""
        if self.planar:
            return math.sqrt(self.l1 ** 2 + self.l2 ** 2 + 2 * self.l1 * self.l2 * math.cos(knee))
        return float(np.linalg.norm(self.bone1 + rotation_about(self.knee_axis, knee)
                                    @ self.bone2))
