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

try:  # np.linalg.solve's own kernel: the same LAPACK solve without the wrapper's checks
    from numpy.linalg._umath_linalg import solve1 as _solve
except ImportError:  # pragma: no cover - numpy's layout changed
    _solve = np.linalg.solve


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


class Damping:
    """The damping of the PD terms, ``tau = tau0 - D qdot``, in the form the terms give it::

        D = diag(d) + B + P^T W

    per-dof damping ``d`` ``(nv,)`` (fixed: the gains); a symmetric block ``B`` on the hinges
    ``block_dofs`` of one joint (the stance foot's twist damping), used while
    :attr:`has_block`; and full rows ``W`` ``(k, nv)`` on the dofs ``rows`` (the hips': a
    world-frame PD term's damping acts on every dof that turns its body), written every
    physics step. :meth:`clear` drops the block for the next step.
    """

    def __init__(self, ch: Character, d: np.ndarray, rows: np.ndarray, block_dofs: np.ndarray):
        nv = ch.nv
        self.rows = np.asarray(rows, dtype=int)
        self.block_dofs = np.asarray(block_dofs, dtype=int)
        self.d = np.array(d, dtype=float)
        self.W = np.zeros((len(self.rows), nv))
        self.B = np.zeros((len(self.block_dofs), len(self.block_dofs)))
        self.has_block = False
        self.u = np.zeros(nv)  # the velocity the damping was evaluated at in the last step
        dyn = ch.dynamics
        # M + dt (diag(d) + B) in the mass matrix's sparse layout: the diagonal part is fixed;
        # the block's lower triangle (diagonal included) goes where MuJoCo stores it
        self._dt = ch.timestep
        self._add_d = dyn.mass_addition(self._dt * self.d)
        self._add = self._add_d.copy()
        tri = np.tril_indices(len(self.block_dofs))
        self._block_adr = dyn.block_addresses(self.block_dofs)[tri]
        self._block_flat = np.ravel_multi_index(tri, self.B.shape)
        k = len(self.rows)
        # right-hand sides of the implicit solve: the torques, then the unit vectors of the rows
        self._rhs = np.zeros((1 + k, nv))
        self._rhs[np.arange(1, 1 + k), self.rows] = 1.0
        self._eye = np.eye(k)

    def clear(self) -> None:
        self.has_block = False

    def times(self, u: np.ndarray) -> np.ndarray:
        """``(nv,)`` ``D u`` for ``u`` ``(nv,)``."""
        out = self.d * u
        out[self.rows] += self.W @ u
        if self.has_block:
            b = self.block_dofs
            out[b] += self.B @ u[b]
        return out

    def damped(self, ch: Character, tau: np.ndarray, implicit: bool) -> np.ndarray:
        """``tau - D qdot``; with ``implicit`` the damping at the next step's velocity (stable
        PD, Tan, Liu and Turk 2011, with a non-diagonal ``D``)::

            (M + dt D) qddot = tau - D qdot - C + tau_ext,    tau - D (qdot + dt qddot)

        solved exactly without forming ``M + dt D``: ``A = M + dt (diag(d) + B)`` keeps the
        mass matrix's sparsity (MuJoCo's ``L^T D L`` factorisation,
        :meth:`~mjchar.controllers.core.character.dynamics.Dynamics.solve_mass_plus`), and
        the ``k`` full rows enter by the Woodbury identity, a ``k x k`` solve::

            qddot = y - Z (I + dt W Z)^-1 dt W y,    y = A^-1 rhs,  Z = A^-1 P^T
        """
        qvel = ch.state.qvel
        if not implicit:
            self.u[:] = qvel
            return tau - self.times(qvel)
        dt = ch.timestep
        if dt != self._dt:  # the time step changed since reset
            self._dt = dt
            self._add_d = ch.dynamics.mass_addition(dt * self.d)
        dyn = ch.dynamics
        rhs = self._rhs
        rhs[0] = tau - self.times(qvel) - dyn.bias_forces() + dyn.passive_forces()
        rhs[0] += dyn.constraint_forces()
        add = self._add_d
        if self.has_block:
            add = self._add
            add[:] = self._add_d
            add[self._block_adr] += dt * self.B.ravel()[self._block_flat]
        X = dyn.solve_mass_plus(rhs, add)
        y, Z = X[0], X[1:]                          # Z: rows A^-1 e_r (A is symmetric)
        W = self.W
        corr = _solve(self._eye + dt * (W @ Z.T), dt * (W @ y))
        u = self.u
        np.subtract(y, corr @ Z, out=u)
        u *= dt
        u += qvel
        return tau - self.times(u)


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
