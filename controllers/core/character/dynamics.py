"""``character.dynamics``: the equations of motion at the current state, and joint-space
arithmetic.

``M(q) qddot + C(q, qdot) = tau + tau_passive + tau_constraint``: the mass matrix ``M`` (and
solves with it, on MuJoCo's sparse factorisation), the bias forces ``C`` (Coriolis, centrifugal,
gravity), passive and constraint forces; Jacobians of points and of centres of mass
(``mj_jac``, ``mj_jacSubtreeCom``); masses and gravity; and positions moved or compared in joint
space (``mj_integratePos``, ``mj_differentiatePos``: quaternion-aware for free and ball joints).
"""

from __future__ import annotations

from collections.abc import Callable

import mujoco
import numpy as np


class Dynamics:
    """The dynamics of one character (built by the Character; see the module docstring).

    Attributes:
        mass: total mass of the character (kg).
    """

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, root_body: int,
                 body_id: Callable[[str], int]):
        self._model, self._data = model, data
        self._root = int(root_body)
        self._body_id = body_id
        self._nv = int(model.nv)
        self.mass = float(model.body_subtreemass[self._root])
        self._jac = np.zeros((3, self._nv))
        self._M = np.zeros((self._nv, self._nv))
        self._scratch = mujoco.MjData(model)
        # the diagonal of the CSR mass matrix (as intp: int32 indices are converted per use)
        self._M_diag = (model.M_rowadr + model.M_rownnz - 1).astype(np.intp)
        self._M_add = np.full(len(self._data.M), -0.0)

    def _body(self, body: str | int) -> int:
        return int(body) if isinstance(body, (int, np.integer)) else self._body_id(body)

    # -- masses and gravity -------------------------------------------------------------------
    @property
    def gravity(self) -> np.ndarray:
        """``(3,)`` gravitational acceleration of the world (m/s^2; a copy)."""
        return self._model.opt.gravity.copy()

    def subtree_mass(self, body: str | int) -> float:
        """Mass (kg) of ``body`` (name or id) and every body below it (a leg from its hip)."""
        return float(self._model.body_subtreemass[self._body(body)])

    # -- equations of motion ------------------------------------------------------------------
    def mass_matrix(self) -> np.ndarray:
        """``(nv, nv)`` joint-space inertia matrix M(q) (``mj_fullM``; includes armature)."""
        mujoco.mj_fullM(self._model, self._data, self._M)
        return self._M.copy()

    def solve_mass(self, rhs: np.ndarray, diagonal: np.ndarray | None = None) -> np.ndarray:
        """``(nv,)`` solution ``x`` of ``(M(q) + diag(diagonal)) x = rhs`` for ``rhs`` ``(nv,)``.

        Uses MuJoCo's sparse ``L^T D L`` factorisation of the tree-structured mass matrix on a
        scratch copy (``mj_factorM``/``mj_solveM``), a few microseconds for a humanoid.
        """
        sd = self._scratch
        if diagonal is None:
            sd.M[:] = self._data.M
        else:
            # M + diag in one pass: the diagonal's entries where they go, -0.0 elsewhere
            # (x + -0.0 is x for every x, signed zeros included)
            add = self._M_add
            add[self._M_diag] = diagonal
            np.add(self._data.M, add, out=sd.M)
        mujoco.mj_factorM(self._model, sd)
        x = np.empty((1, self._nv))
        mujoco.mj_solveM(self._model, sd, x, np.ascontiguousarray(rhs, dtype=float).reshape(1, -1))
        return x[0]

    def mass_addition(self, diagonal: np.ndarray) -> np.ndarray:
        """A diagonal matrix ``diag(diagonal)`` (``diagonal`` ``(nv,)``) in the layout of MuJoCo's
        sparse mass matrix (``MjData.M``; -0.0 off the diagonal), to add to ``M`` in
        :meth:`solve_mass_plus`."""
        add = np.full(len(self._data.M), -0.0)
        add[self._M_diag] = diagonal
        return add

    def block_addresses(self, dofs: np.ndarray) -> np.ndarray:
        """``(k, k)`` addresses in MuJoCo's sparse mass matrix (``MjData.M``) of the entries
        ``M[i, j]`` of the dofs ``dofs`` ``(k,)`` (both triangles point at the one stored
        entry), to add a symmetric block to ``M`` in :meth:`solve_mass_plus`. The dofs must lie
        on one branch of the tree (each an ancestor of the next, as the hinges of one joint), so
        that every pair is stored."""
        m = self._model
        dofs = np.asarray(dofs, dtype=int)
        out = np.empty((len(dofs), len(dofs)), dtype=np.intp)
        for a, i in enumerate(dofs.tolist()):
            for b, j in enumerate(dofs.tolist()):
                r, col = max(i, j), min(i, j)
                start = int(m.M_rowadr[r])
                cols = m.M_colind[start:start + int(m.M_rownnz[r])].tolist()
                if col not in cols:
                    raise ValueError(f"dofs {i} and {j} are not on one branch: M[{i}, {j}] is not "
                                     "stored")
                out[a, b] = start + cols.index(col)
        return out

    def solve_mass_plus(self, rhs: np.ndarray, addition: np.ndarray) -> np.ndarray:
        """``(n, nv)`` solutions ``X`` of ``(M(q) + A) x = rhs_i`` for every row of ``rhs``
        ``(n, nv)``, with ``A`` a symmetric matrix of ``M``'s sparsity given in its sparse
        layout (``addition``: :meth:`mass_addition`, plus blocks at :meth:`block_addresses`):
        one sparse ``L^T D L`` factorisation (``mj_factorM``) and one ``mj_solveM`` for every
        row, as :meth:`solve_mass`."""
        sd = self._scratch
        np.add(self._data.M, addition, out=sd.M)
        mujoco.mj_factorM(self._model, sd)
        x = np.empty_like(rhs)
        mujoco.mj_solveM(self._model, sd, x, rhs)
        return x

    def bias_forces(self) -> np.ndarray:
        """``(nv,)`` Coriolis, centrifugal and gravity forces C(q, qdot) (``qfrc_bias``)."""
        return self._data.qfrc_bias.copy()

    def passive_forces(self) -> np.ndarray:
        """``(nv,)`` passive forces (joint damping, springs) at the current state."""
        return self._data.qfrc_passive.copy()

    def constraint_forces(self) -> np.ndarray:
        """``(nv,)`` contact/limit/equality forces of the last completed step (one step old)."""
        return self._data.qfrc_constraint.copy()

    # -- Jacobians ----------------------------------------------------------------------------
    def com_jacobian(self, body: str | int | None = None, out: np.ndarray | None = None
                     ) -> np.ndarray:
        """``(3, nv)`` Jacobian of the centre of mass of ``body``'s subtree (name or id; default:
        the whole character), ``mj_jacSubtreeCom``. Written into ``out`` ``(3, nv)`` when given
        (no allocation per call), else into a new array."""
        if out is None:
            out = np.zeros((3, self._nv))
        b = self._root if body is None else self._body(body)
        mujoco.mj_jacSubtreeCom(self._model, self._data, out, b)
        return out

    def point_jacobian(self, body: str | int, point: np.ndarray,
                       out: tuple[np.ndarray, np.ndarray] | None = None
                       ) -> tuple[np.ndarray, np.ndarray]:
        """Jacobians ``(jacp, jacr)``, each ``(3, nv)``, of a world ``point`` (m) fixed to
        ``body`` (name or id). Written into ``out`` (two ``(3, nv)`` arrays) when given (no
        allocation per call), else into new arrays."""
        jacp, jacr = (np.zeros((3, self._nv)), np.zeros((3, self._nv))) if out is None else out
        mujoco.mj_jac(self._model, self._data, jacp, jacr, np.asarray(point, dtype=float),
                      self._body(body))
        return jacp, jacr

    # -- joint space --------------------------------------------------------------------------
    def integrate(self, qpos: np.ndarray, qvel: np.ndarray, dt: float) -> np.ndarray:
        """``(nq,)`` ``qpos`` moved by velocity ``qvel`` ``(nv,)`` for ``dt`` s
        (quaternion-aware, ``mj_integratePos``)."""
        q = np.array(qpos, dtype=float)
        mujoco.mj_integratePos(self._model, q, np.asarray(qvel, dtype=float), float(dt))
        return q

    def difference(self, qpos1: np.ndarray, qpos2: np.ndarray) -> np.ndarray:
        """``(nv,)`` joint-space difference ``qpos2 - qpos1`` (``mj_differentiatePos`` with dt=1).

        Hinges: angle difference; ball and free-joint rotations: the rotation vector of
        ``q1^-1 q2`` in the child frame; free-joint translation: world difference.
        """
        v = np.empty(self._nv)
        mujoco.mj_differentiatePos(self._model, v, 1.0, np.asarray(qpos1, dtype=float),
                                   np.asarray(qpos2, dtype=float))
        return v
