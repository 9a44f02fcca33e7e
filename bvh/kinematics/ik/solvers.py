"""The three inverse-kinematics solvers of :mod:`mjchar.bvh.kinematics.ik`, each only an update rule
on an :class:`~mjchar.bvh.kinematics.ik.problem.IKProblem`.

- :func:`solve_ccd`: cyclic coordinate descent (Wang & Chen 1991); each joint takes the rotation
  that best aligns the effectors below it with their targets (Wahba's problem by Davenport's
  q-method, :func:`_best_rotation`).
- :func:`solve_jacobian_transpose`: gradient descent along ``W J^T e`` (Wolovich & Elliott 1984)
  with Buss & Kim's step and an Armijo backtracking line search.
- :func:`solve_dls`: damped least squares / Levenberg-Marquardt (Wampler 1986; Nakamura &
  Hanafusa 1986) with Nielsen's (1999) adaptive damping.

:data:`METHODS` maps names to solvers and :func:`solve` picks one by name. See Buss,
"Introduction to Inverse Kinematics with Jacobian Transpose, Pseudoinverse and Damped Least
Squares methods" (2004/2009).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from mjchar.bvh.errors import IKError
from mjchar.bvh.kinematics.ik.pose import Pose
from mjchar.bvh.kinematics.ik.problem import IKProblem, IKResult, IKState, _iterate
from mjchar.bvh.rotations import quat_from_rotvec, quat_to_rotvec, to_rotation


# ---------------------------------------------------------------------------------------------
# CCD
# ---------------------------------------------------------------------------------------------
def _best_rotation(a: np.ndarray, b: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Rotation vector ``(3,)`` of the rotation ``R`` maximising ``sum_k w_k b_k . R a_k``.

    Wahba's problem by Davenport's q-method: the optimal unit quaternion is the top eigenvector
    of ``K = [[tr B, z^T], [z, B + B^T - tr(B) I]]`` with ``B = sum w b a^T``,
    ``z = sum w a x b``. When the top eigenvalue is repeated (one effector, or collinear ones)
    every rotation of that eigenspace is optimal; the one closest to the identity is taken
    (projection of the identity quaternion), which for one effector is the minimal rotation
    taking ``a`` towards ``b``.
    """
    bmat = np.einsum("k,ki,kj->ij", w, b, a)
    tr = np.trace(bmat)
    z = np.einsum("k,ki->i", w, np.cross(a, b))
    kmat = np.empty((4, 4))
    kmat[0, 0] = tr
    kmat[0, 1:] = kmat[1:, 0] = z
    kmat[1:, 1:] = bmat + bmat.T - tr * np.eye(3)
    vals, vecs = np.linalg.eigh(kmat)
    scale = float(np.sum(w * np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1)))
    if not np.isfinite(scale) or scale <= 1e-300:
        return np.zeros(3)
    top = vecs[:, vals >= vals[-1] - 1e-9 * scale]
    q = top @ top[0]  # projection of the identity (1, 0, 0, 0) onto the top eigenspace
    norm = np.linalg.norm(q)
    q = q / norm if norm > 1e-6 else vecs[:, -1]
    return quat_to_rotvec(q)


def _rotvec_matrix(omega: np.ndarray) -> np.ndarray:
    return to_rotation(quat_from_rotvec(omega)).as_matrix().reshape(3, 3)


def solve_ccd(problem: IKProblem, pose: Pose, *, max_iterations: int = 200,
              record_poses: bool = False) -> IKResult:
    """Cyclic coordinate descent.

    One iteration sweeps the movable joints from the leaves to the root (reverse skeleton order,
    so a joint comes after all its descendants). Joint ``i`` at ``p_i`` takes the rotation that
    best aligns the vectors ``a_k = p_k - p_i`` of the effectors it moves with
    ``b_k = t_k - p_i`` (weights ``w_k``), scaled by its relative joint weight and limited to
    ``max_angle``; the objective along the geodesic from the identity to that optimum only
    decreases, so each joint update lowers the error. Then a free root translation moves by the
    weighted mean residual. Effector positions are updated incrementally during a sweep
    (a joint's rotation moves only the effectors below it; joints visited later are never below
    it), and the pose is re-evaluated once per sweep.

    Args:
        problem: the :class:`IKProblem`.
        pose: start :class:`Pose` (not modified).
        max_iterations: maximum number of sweeps.
        record_poses: keep every iterate in ``result.poses``.

    Returns:
        :class:`IKResult` with ``method="ccd"``.
    """
    w = problem.effector_weights
    top = max(problem.joint_weights.max(initial=0.0),
              problem.root_translation_weight if problem.translate_root else 0.0)
    rel = problem.joint_weights / top  # relative joint weights in [0, 1]
    rel_root = problem.root_translation_weight / top
    order = np.arange(len(problem.dof_joints))[::-1]
    nj = len(problem.dof_joints)

    def step(state: IKState) -> IKState | None:
        eff = state.effectors.copy()
        delta = np.zeros(problem.n_dof)
        for i in order:
            ks = np.flatnonzero(problem.moves[:, i] & (w > 0))
            if len(ks) == 0:
                continue
            p = state.positions[problem.dof_joints[i]]
            a, b = eff[ks] - p, problem.targets[ks] - p
            omega = _best_rotation(a, b, w[ks])
            angle = float(np.linalg.norm(omega))
            if angle <= 1e-15:
                continue
            omega = omega * min(rel[i], problem.max_angle / angle)
            rmat = _rotvec_matrix(omega)
            moved = a @ rmat.T
            before = np.sum(w[ks] * np.sum((a - b) ** 2, axis=1))
            after = np.sum(w[ks] * np.sum((moved - b) ** 2, axis=1))
            if not after < before:
                continue
            eff[ks] = p + moved
            delta[3 * i: 3 * i + 3] = omega
        if problem.translate_root:
            shift = np.sum(w[:, None] * (problem.targets - eff), axis=0) / np.sum(w)
            shift = shift * min(1.0, rel_root)
            if problem.max_translation is not None:
                norm = float(np.linalg.norm(shift))
                if norm > problem.max_translation:
                    shift = shift * (problem.max_translation / norm)
            delta[3 * nj:] = shift / problem.length_scale
        if not np.any(delta):
            return None
        new_pose = problem.apply(state, delta)  # each joint was limited to max_angle above
        if new_pose is None:
            return None
        new = problem.evaluate(new_pose)
        return new if new.error < state.error else None

    return _iterate(problem, pose, step, "ccd", max_iterations, record_poses)


# ---------------------------------------------------------------------------------------------
# Jacobian transpose
# ---------------------------------------------------------------------------------------------
def solve_jacobian_transpose(problem: IKProblem, pose: Pose, *, max_iterations: int = 1000,
                             armijo: float = 1e-4, max_backtracks: int = 30,
                             record_poses: bool = False) -> IKResult:
    """Jacobian transpose: gradient descent on ``E^2 / 2``.

    Direction ``d = W J^T e`` (``W``: per-dof joint weights; ``e``: weighted residual), first
    step ``alpha = <e, J d> / |J d|^2`` (Buss & Kim: the exact minimiser of the linearised error
    along ``d``), then limited to ``max_angle`` and halved until the Armijo condition
    ``E_new^2/2 <= E^2/2 - armijo * <e, J dq>`` holds. If no step length works the solver stops,
    so the error history never increases.

    Args:
        problem: the :class:`IKProblem`.
        pose: start :class:`Pose` (not modified).
        max_iterations: maximum number of accepted steps.
        armijo: sufficient-decrease constant in (0, 1).
        max_backtracks: step halvings tried per iteration.
        record_poses: keep every iterate in ``result.poses``.

    Returns:
        :class:`IKResult` with ``method="jacobian_transpose"``.
    """
    if not 0 < armijo < 1:
        raise IKError(f"armijo must be in (0, 1), got {armijo}")
    wd = problem.dof_weights

    def step(state: IKState) -> IKState | None:
        jac, r = problem.weighted_system(state)
        d = wd * (jac.T @ r)
        jd = jac @ d
        denom = float(jd @ jd)
        if not denom > 1e-300:
            return None  # stationary: the gradient vanishes
        alpha = float(r @ jd) / denom
        half_sq = 0.5 * state.error**2
        for _ in range(int(max_backtracks) + 1):
            dq = problem.limit_step(alpha * d)
            new_pose = problem.apply(state, dq)
            if new_pose is not None:
                new = problem.evaluate(new_pose)
                decrease = half_sq - 0.5 * new.error**2
                if new.error < state.error and decrease >= armijo * float(r @ (jac @ dq)):
                    return new
            alpha *= 0.5
        return None

    return _iterate(problem, pose, step, "jacobian_transpose", max_iterations, record_poses)


# ---------------------------------------------------------------------------------------------
# damped least squares
# ---------------------------------------------------------------------------------------------
def solve_dls(problem: IKProblem, pose: Pose, *, max_iterations: int = 100,
              damping: float = 1e-2, max_retries: int = 30,
              record_poses: bool = False) -> IKResult:
    """Damped least squares (Levenberg-Marquardt) with per-joint weights and adaptive damping.

    ``dq = W J^T (J W J^T + lambda^2 I)^-1 e``: the step minimising
    ``|e - J dq|^2 + lambda^2 dq^T W^-1 dq``, so a joint with a small weight barely moves.
    ``lambda^2 = mu * trace(J W J^T) / 3K`` (scale-free ``mu``, starting at ``damping``). After
    the step (limited to ``max_angle``) the gain ratio ``rho`` = actual / predicted decrease of
    ``E^2/2`` is computed: if the error decreased the step is accepted and
    ``mu *= max(1/3, 1 - (2 rho - 1)^3)`` (Nielsen 1999), otherwise it is rejected and ``mu``
    grows (x2, x4, x8, ...) until a step decreases the error or ``max_retries`` is exhausted.

    Args:
        problem: the :class:`IKProblem`.
        pose: start :class:`Pose` (not modified).
        max_iterations: maximum number of accepted steps.
        damping: initial relative damping ``mu`` (> 0).
        max_retries: rejected steps tolerated per iteration before giving up.
        record_poses: keep every iterate in ``result.poses``.

    Returns:
        :class:`IKResult` with ``method="dls"``.
    """
    if not (np.isfinite(damping) and damping > 0):
        raise IKError(f"damping must be a positive number, got {damping}")
    wd = problem.dof_weights
    mu = [float(damping)]  # carried across iterations

    def step(state: IKState) -> IKState | None:
        jac, r = problem.weighted_system(state)
        jw = jac * wd
        a = jw @ jac.T
        m = len(r)
        scale = float(np.trace(a)) / m
        if not scale > 1e-300:
            return None  # no movable joint can move a weighted effector from here
        half_sq = 0.5 * state.error**2
        nu = 2.0
        for _ in range(int(max_retries) + 1):
            lam2 = max(mu[0], 1e-12) * scale
            try:
                y = np.linalg.solve(a + lam2 * np.eye(m), r)
            except np.linalg.LinAlgError:
                y = None
            if y is not None:
                dq = problem.limit_step(jw.T @ y)
                predicted = half_sq - 0.5 * float(np.sum((r - jac @ dq) ** 2))
                new_pose = problem.apply(state, dq)
                if new_pose is not None and predicted > 0:
                    new = problem.evaluate(new_pose)
                    if new.error < state.error:
                        rho = (half_sq - 0.5 * new.error**2) / predicted
                        mu[0] = max(mu[0] * max(1.0 / 3.0, 1.0 - (2.0 * rho - 1.0) ** 3), 1e-12)
                        return new
            mu[0] *= nu
            nu *= 2.0
        return None

    return _iterate(problem, pose, step, "dls", max_iterations, record_poses)


# ---------------------------------------------------------------------------------------------
# conveniences
# ---------------------------------------------------------------------------------------------
METHODS: dict[str, Callable[..., IKResult]] = {
    "ccd": solve_ccd,
    "jacobian_transpose": solve_jacobian_transpose,
    "dls": solve_dls,
}


def solve(problem: IKProblem, pose: Pose, method: str = "dls", **options) -> IKResult:
    """Solve with ``method`` (``"ccd"``, ``"jacobian_transpose"`` or ``"dls"``).

    ``options`` go to the solver (e.g. ``max_iterations``). Returns an :class:`IKResult`.
    """
    try:
        solver = METHODS[method]
    except KeyError:
        raise IKError(f"unknown IK method {method!r}; expected one of {sorted(METHODS)}") from None
    return solver(problem, pose, **options)
