"""The torque terms of IPM stepping that need no controller state (the steps are described in
:mod:`mjchar.controllers.walking.ipm`): gravity compensation, the PD damping evaluated
explicitly or at the next step's velocity, and the stance foot's limits (the yaw moment its
contact patch holds, the ankle moment that keeps the centre of pressure inside the foot).

Each takes the Character's state and returns or edits a ``(nv,)`` torque vector."""

from __future__ import annotations

import math

import numpy as np

from ..core.character import Character
from .ipm_params import GRAVITY
from .leg import Leg, inverse3


class GravityCompensation:
    """Torques holding up the links below ``dofs`` (an upward ``m g`` at each dof's subtree
    centre of mass): ``tau_j = a_j . ((C_j - p_j) x M_j g z)`` for dof ``j`` with axis ``a_j`` at
    ``p_j``, subtree mass ``M_j`` and subtree COM ``C_j``; the dofs' bodies, joints and weights
    ``M_j g`` are looked up once. Call it with the Character's state for the ``(len(dofs),)``
    torques."""

    def __init__(self, ch: Character, dofs: np.ndarray):
        self.dofs = dofs
        self._bodies = ch.dof_body[dofs]
        self._joints = ch.dof_joint[dofs]
        self._weight = GRAVITY * np.array([ch.dynamics.subtree_mass(b) for b in self._bodies])

    def __call__(self, s) -> np.ndarray:
        lever = s.subtree_coms[self._bodies] - s.joint_anchors[self._joints]
        ax = s.joint_axes[self._joints]
        # a . (lever x z) = a_x lever_y - a_y lever_x
        return self._weight * (ax[:, 0] * lever[:, 1] - ax[:, 1] * lever[:, 0])


def damped(ch: Character, tau: np.ndarray, D: np.ndarray, implicit: bool) -> np.ndarray:
    """``tau - D qdot``; with ``implicit`` the damping at the next step's velocity (stable PD,
    Tan, Liu and Turk 2011, with a non-diagonal ``D``)::

        (M + dt D) qddot = tau - D qdot - C + tau_ext,    tau - D (qdot + dt qddot)
    """
    qvel = ch.state.qvel
    if not implicit:
        return tau - D @ qvel
    dt = ch.timestep
    dyn = ch.dynamics
    M = dyn.mass_matrix()
    rhs = (tau - D @ qvel - dyn.bias_forces() + dyn.passive_forces()
           + dyn.constraint_forces())
    qacc = np.linalg.solve(M + dt * D, rhs)
    return tau - D @ (qvel + dt * qacc)


def yaw_capacity(ch: Character, st: Leg, friction: float, limit: float, mass: float) -> float:
    """Yaw moment (N m) the stance foot can hold: ``friction x m g x r``, with ``r`` the mean
    distance of its floor contact points from their centroid (a flat foot ~0.1 m, a foot on its
    toes or heel much less), at most ``limit``."""
    pts = ch.contacts.ground_points(st.sole_bodies)
    if len(pts) < 2:
        return 0.0
    # the mean distance from the centroid: pts.mean(axis=0), norm(axis=1), .mean() in numpy's
    # own reductions (their summation order), without their wrappers' per-call overhead
    k = len(pts)
    d = pts - np.add.reduce(pts, axis=0) / k
    r = float(np.add.reduce(np.sqrt(np.add.reduce(d * d, axis=1))) / k)
    return min(limit, friction * mass * GRAVITY * r)


def limit_stance_yaw(ch: Character, st: Leg, tau: np.ndarray, friction: float, limit: float,
                     mass: float) -> None:
    """Clamp the vertical component of the stance hip's world torque in ``tau`` to what the
    stance foot holds before it spins on the ground (:func:`yaw_capacity`)."""
    A_st = ch.state.joint_axes[st.hip_jnt]
    T_st = inverse3(A_st) @ tau[st.hip]
    lim = yaw_capacity(ch, st, friction, limit, mass) if abs(T_st[2]) > 2.0 else math.inf
    if abs(T_st[2]) > lim:
        T_st[2] = math.copysign(lim, T_st[2])
        tau[st.hip] = A_st @ T_st


def limit_stance_ankle(ch: Character, st: Leg, tau: np.ndarray, fwd: float, back: float,
                       roll: float, weight: float) -> None:
    """Clamp the stance ankle's moment in ``tau`` (in the foot's frame: pitch within ``-back``
    .. ``fwd``, roll within ``+-roll``, each metres x ``weight``) so the foot holds it without
    rolling."""
    s = ch.state
    A = s.joint_axes[st.ankle_jnt].T
    T = inverse3(A.T) @ tau[st.ankle]
    R_foot = s.body_rotations[st.foot]
    roll_m, pitch_m, yaw_m = (R_foot.T @ T).tolist()
    # the moment on the foot about +y (toes down) shifts the pressure forward
    pitch_m = min(max(pitch_m, -back * weight), fwd * weight)
    roll_m = min(max(roll_m, -roll * weight), roll * weight)
    tau[st.ankle] = A.T @ (R_foot @ np.array([roll_m, pitch_m, yaw_m]))
