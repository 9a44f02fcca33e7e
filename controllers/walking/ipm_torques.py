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
from .leg import Leg, index_selector, matvec3, solve3

_PAIR_SUM = np.ones(2)


class GravityCompensation:
    """Torques holding up the links below ``dofs`` (an upward ``m g`` at each dof's subtree
    centre of mass): ``tau_j = a_j . ((C_j - p_j) x M_j g z)`` for dof ``j`` with axis ``a_j`` at
    ``p_j``, subtree mass ``M_j`` and subtree COM ``C_j``; the dofs' bodies, joints and weights
    ``M_j g`` are looked up once. Call it with the Character's state for the ``(len(dofs),)``
    torques, or :meth:`add_to` a ``(nv,)`` torque vector."""

    def __init__(self, ch: Character, dofs: np.ndarray):
        self.dofs = dofs
        self._bodies = ch.dof_body[dofs]
        self._joints = ch.dof_joint[dofs]
        self._weight = GRAVITY * np.array([ch.dynamics.subtree_mass(b) for b in self._bodies])
        # over every dof, weightless outside ``dofs`` (add_to: no gather and scatter)
        weight = np.zeros(ch.nv)
        weight[dofs] = self._weight
        self._full = self._flat(np.arange(ch.nv), ch.dof_body, ch.dof_joint, weight)
        self._sel = self._flat(np.arange(len(dofs)), self._bodies, self._joints, self._weight)

    @staticmethod
    def _flat(rows, bodies, joints, weight):
        """Flat indices into the ``(n, 3)`` state arrays: (x, y) of each subtree COM and joint
        anchor, (y, x) of each joint axis; the weight with the signs of ``a_x l_y - a_y l_x``."""
        xy = np.array([0, 1])
        b, j = np.asarray(bodies)[rows], np.asarray(joints)[rows]
        return (3 * b[:, None] + xy, 3 * j[:, None] + xy, 3 * j[:, None] + xy[::-1],
                np.asarray(weight)[rows, None] * np.array([-1.0, 1.0]))

    @staticmethod
    def _torques(s, flat) -> np.ndarray:
        com_xy, jnt_xy, jnt_yx, signed_weight = flat
        lever = s.subtree_coms.ravel().take(com_xy) - s.joint_anchors.ravel().take(jnt_xy)
        # a . (lever x z) = a_x lever_y - a_y lever_x: (a_y l_x, a_x l_y) weighted (-1, +1)
        return (s.joint_axes.ravel().take(jnt_yx) * lever * signed_weight) @ _PAIR_SUM

    def __call__(self, s) -> np.ndarray:
        return self._torques(s, self._sel)

    def add_to(self, tau: np.ndarray, s) -> None:
        """Add the torques to ``tau`` ``(nv,)`` (zero on the other dofs)."""
        tau += self._torques(s, self._full)


class Damping:
    """The damping of the PD terms, ``tau = tau0 - D qdot``, in the form the terms give it::

        D = diag(d) + B + P^T W

    per-dof damping ``d`` ``(nv,)`` (fixed: the gains); a symmetric block ``B`` on the hinges
    ``block_dofs`` of one joint (the stance foot's twist damping), used while
    :attr:`has_block`; and full rows ``W`` ``(k, nv)`` on the dofs ``rows``, given in groups
    (the hips': a world-frame PD term's damping acts on every dof that turns its body), written
    every physics step. The rows and the block are on different dofs. :meth:`clear` drops the
    block for the next step.
    """

    def __init__(self, ch: Character, d: np.ndarray, rows: list[np.ndarray],
                 block_dofs: np.ndarray):
        nv = ch.nv
        self.rows = np.concatenate([np.asarray(r, dtype=int) for r in rows])
        self.block_dofs = np.asarray(block_dofs, dtype=int)
        if np.intersect1d(self.rows, self.block_dofs).size:
            raise ValueError("Damping: the full rows and the block share dofs")
        self.d = np.array(d, dtype=float)
        self.W = np.zeros((len(self.rows), nv))
        self.B = np.zeros((len(self.block_dofs), len(self.block_dofs)))
        self.has_block = False
        self.u = np.zeros(nv)  # the velocity the damping was evaluated at in the last step
        # D itself, dense, for its products (one matrix-vector product each): the diagonal is
        # fixed, the rows are copied from W and the block added at every step
        self._D = np.diag(self.d)
        ends = np.cumsum([len(r) for r in rows]).tolist()
        self._groups = [(index_selector(r), slice(e - len(r), e)) for r, e in zip(rows, ends,
                                                                                  strict=True)]
        b = index_selector(self.block_dofs)
        self._block = (b, b) if isinstance(b, slice) else np.ix_(b, b)
        self._block_d = self._D[self._block].copy()
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

    def matrix(self) -> np.ndarray:
        """``(nv, nv)`` ``D`` as it stands (a view, valid until the next change)."""
        D = self._D
        for dofs, rows in self._groups:
            D[dofs] = self.W[rows]
        D[self._block] = self._block_d + self.B if self.has_block else self._block_d
        return D

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
        D = self.matrix()
        if not implicit:
            self.u[:] = qvel
            return tau - D @ qvel
        dt = ch.timestep
        if dt != self._dt:  # the time step changed since reset
            self._dt = dt
            self._add_d = ch.dynamics.mass_addition(dt * self.d)
        dyn = ch.dynamics
        rhs = self._rhs
        r = rhs[0]
        np.subtract(tau, D @ qvel, out=r)
        r -= dyn.bias_forces()
        r += dyn.passive_forces()
        r += dyn.constraint_forces()
        add = self._add_d
        if self.has_block:
            add = self._add
            add[:] = self._add_d
            add[self._block_adr] += dt * self.B.ravel()[self._block_flat]
        X = dyn.solve_mass_plus(rhs, add)           # rows: y, then Z^T (rows A^-1 e_r)
        WX = (dt * self.W) @ X.T                    # (k, 1 + k): dt W y, dt W Z
        corr = np.linalg.solve(self._eye + WX[:, 1:], WX[:, 0])
        u = self.u
        np.subtract(X[0], corr @ X[1:], out=u)      # qddot
        u *= dt
        u += qvel
        return tau - D @ u


def yaw_capacity(ch: Character, st: Leg, friction: float, limit: float, mass: float) -> float:
    """Yaw moment (N m) the stance foot can hold: ``friction x m g x r``, with ``r`` the mean
    distance of its floor contact points from their centroid (a flat foot ~0.1 m, a foot on its
    toes or heel much less), at most ``limit``."""
    pts = ch.contacts.ground_points(st.sole_bodies).tolist()
    k = len(pts)
    if k < 2:
        return 0.0
    sx = sy = 0.0
    for x, y in pts:
        sx += x
        sy += y
    mx, my = sx / k, sy / k
    r = 0.0
    for x, y in pts:
        r += math.sqrt((x - mx) ** 2 + (y - my) ** 2)
    r /= k
    return min(limit, friction * mass * GRAVITY * r)


def limit_stance_yaw(ch: Character, st: Leg, tau: np.ndarray, friction: float, limit: float,
                     mass: float) -> None:
    """Clamp the vertical component of the stance hip's world torque in ``tau`` to what the
    stance foot holds before it spins on the ground (:func:`yaw_capacity`)."""
    A_st = ch.state.joint_axes[st.hip_jnt_sel].tolist()     # rows = hinge axes
    T_st = solve3(A_st, tau[st.hip_sel].tolist())
    if abs(T_st[2]) > 2.0:
        lim = yaw_capacity(ch, st, friction, limit, mass)
        if abs(T_st[2]) > lim:
            T_st[2] = math.copysign(lim, T_st[2])
            tau[st.hip_sel] = matvec3(A_st, T_st)


def limit_stance_ankle(ch: Character, st: Leg, tau: np.ndarray, fwd: float, back: float,
                       roll: float, weight: float) -> None:
    """Clamp the stance ankle's moment in ``tau`` (in the foot's frame: pitch within ``-back``
    .. ``fwd``, roll within ``+-roll``, each metres x ``weight``) so the foot holds it without
    rolling."""
    s = ch.state
    A = s.joint_axes[st.ankle_jnt_sel].tolist()              # rows = hinge axes
    T = solve3(A, tau[st.ankle_sel].tolist())                # the world moment
    R = s.body_rotations[st.foot].tolist()
    # in the foot's frame (R^T T)
    (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = R
    roll_m = r00 * T[0] + r10 * T[1] + r20 * T[2]
    pitch_m = r01 * T[0] + r11 * T[1] + r21 * T[2]
    yaw_m = r02 * T[0] + r12 * T[1] + r22 * T[2]
    # the moment on the foot about +y (toes down) shifts the pressure forward
    pitch_m = min(max(pitch_m, -back * weight), fwd * weight)
    roll_m = min(max(roll_m, -roll * weight), roll * weight)
    tau[st.ankle_sel] = matvec3(A, matvec3(R, [roll_m, pitch_m, yaw_m]))
