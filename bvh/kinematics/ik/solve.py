"""Inverse kinematics on one skeleton pose: CCD, Jacobian transpose and damped least squares.

The problem: move some joints of a :class:`Pose` so that effectors (joints or end sites) reach
target positions. All three solvers share one problem definition, :class:`IKProblem`, which owns
everything that is not the update rule itself: forward kinematics of the pose, effector positions
and residuals, the Jacobian, how a joint-space step is applied to the pose (including the
per-iteration angle limit) and the convergence test. A solver only decides the step.

Parameterisation. Every movable 3-DoF joint ``i`` changes by a rotation vector ``omega_i``
(radians) expressed in **world** axes and applied to its global orientation,
``R_i <- exp([omega_i]) R_i``, i.e. its local rotation becomes
``r_i <- exp([R_parent^T omega_i]) r_i``. Increments are re-linearised about the current pose at
every iteration, so there are no Euler angles and no gimbal singularities. The Jacobian is
analytic: the column for world axis ``a`` of joint ``i`` and effector ``e`` is
``a x (p_e - p_i)``. When the root may move, its rotation is one more such joint and its
translation adds three columns (the identity, scaled by a length so that the damping of damped
least squares is unit-consistent).

Objective. With effector targets ``t_k``, positions ``p_k`` and weights ``w_k``, the error is
``E = sqrt(sum_k w_k |t_k - p_k|^2)`` (the norm of the weighted residual, in length units); every
solver decreases it monotonically. Convergence means every effector with a positive weight is
within ``tolerance`` of its target.

Solvers (same signature, same :class:`IKResult`):

- :func:`solve_ccd`: cyclic coordinate descent (Wang & Chen 1991). One iteration is a sweep over
  the movable joints from the leaves to the root; each joint takes the rotation about its own
  position that best aligns the effectors below it with their targets (Wahba's problem, solved
  with Davenport's q-method; for one effector it is the classic minimal rotation), then the root
  translation (if free) moves by the weighted mean residual. Each update lowers ``E``. CCD is
  sequential over joints by nature; everything else is vectorised over joints.
- :func:`solve_jacobian_transpose`: gradient descent on ``E^2 / 2`` along
  ``d = W J^T e`` (Wolovich & Elliott 1984) with Buss & Kim's step
  ``alpha = <e, J d> / |J d|^2`` refined by a backtracking (Armijo) line search, so every
  accepted iteration decreases ``E``.
- :func:`solve_dls`: damped least squares / Levenberg-Marquardt (Wampler 1986; Nakamura & Hanafusa
  1986), ``dq = W J^T (J W J^T + lambda^2 I)^-1 e`` with per-joint weights ``W`` and adaptive
  damping (Nielsen's gain-ratio rule): a step that does not decrease ``E`` is rejected and retried
  with more damping.

Every step is scaled (as a whole, keeping its direction) so that no joint turns by more than
``max_angle`` radians per iteration; a step that would produce non-finite numbers is rejected.
See Buss, "Introduction to Inverse Kinematics with Jacobian Transpose, Pseudoinverse and Damped
Least Squares methods" (2004/2009) for the Jacobian methods.

Example::

    pose = Pose.from_motion(motion, frame=10)
    problem = IKProblem(motion.skeleton, {"lWrist_end": target})
    result = solve_dls(problem, pose)
    result.pose, result.converged, result.errors

Where the parts live: :class:`Pose` and its forward kinematics in
:mod:`mjchar.bvh.kinematics.ik.pose`, the problem (:class:`IKProblem`, :class:`IKResult`, the shared
iteration loop) in :mod:`mjchar.bvh.kinematics.ik.problem`, the solvers in
:mod:`mjchar.bvh.kinematics.ik.solvers`; this module re-exports them and holds :func:`solve_frames`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import NamedTuple

import numpy as np

from mjchar.bvh.errors import IKError
from mjchar.bvh.io.motion import Motion
from mjchar.bvh.kinematics.ik.pose import Pose
from mjchar.bvh.kinematics.ik.problem import (
    Effector,
    IKProblem,
    IKResult,
    IKState,
    Step,  # noqa: F401  (kept importable from mjchar.bvh.kinematics.ik)
)
from mjchar.bvh.kinematics.ik.solvers import (
    METHODS,
    solve,
    solve_ccd,
    solve_dls,
    solve_jacobian_transpose,
)

__all__ = [
    "IKError", "Pose", "Effector", "IKProblem", "IKState", "IKResult", "FramesResult",
    "solve", "solve_ccd", "solve_jacobian_transpose", "solve_dls", "solve_frames", "METHODS",
]


class FramesResult(NamedTuple):
    """What :func:`solve_frames` returns.

    Attributes:
        motion: a new :class:`~mjchar.bvh.io.motion.Motion` with the solved frames replaced.
        frames: ``(N,)`` indices of the solved frames.
        converged: ``(N,)`` bool per solved frame.
        distances: ``(N, K)`` final effector-to-target distances.
        iterations: ``(N,)`` iterations used per solved frame.
    """

    motion: Motion
    frames: np.ndarray
    converged: np.ndarray
    distances: np.ndarray
    iterations: np.ndarray


def solve_frames(motion: Motion, targets: Mapping[str, np.ndarray], method: str = "dls", *,
                 frames: Sequence[int] | np.ndarray | None = None,
                 effector_weights: Mapping[str, float] | None = None,
                 solver_options: Mapping[str, object] | None = None,
                 **problem_options) -> FramesResult:
    """Apply IK to many frames of ``motion``, each frame starting from its own pose.

    Args:
        motion: the :class:`~mjchar.bvh.io.motion.Motion` (not modified).
        targets: ``effector name -> (N, 3)`` targets, one row per solved frame (or ``(3,)`` for
            a fixed target).
        method: ``"ccd"``, ``"jacobian_transpose"`` or ``"dls"``.
        frames: which frames to solve (default: all ``F``); ``N = len(frames)``.
        effector_weights: ``name -> weight`` (default 1).
        solver_options: keyword options for the solver (e.g. ``{"max_iterations": 50}``).
        **problem_options: keyword options of :class:`IKProblem` (``joints``, ``root_may_move``,
            ``joint_weights``, ``locked``, ``max_angle``, ``tolerance``, ...).

    Returns:
        :class:`FramesResult`. The loop over frames is in Python; each frame's solve is
        vectorised over joints.
    """
    idx = np.arange(motion.n_frames) if frames is None else np.asarray(frames, dtype=int)
    if idx.ndim != 1 or np.any(idx < -motion.n_frames) or np.any(idx >= motion.n_frames):
        raise IKError(f"frames must be indices into {motion.n_frames} frames")
    names = list(targets)
    tgt = []
    for name in names:
        t = np.asarray(targets[name], dtype=float)
        if t.shape == (3,):
            t = np.broadcast_to(t, (len(idx), 3))
        if t.shape != (len(idx), 3):
            raise IKError(f"targets of {name!r} must be (3,) or ({len(idx)}, 3), got {t.shape}")
        tgt.append(t)
    tgt = np.stack(tgt, axis=1) if names else np.zeros((len(idx), 0, 3))
    ew = effector_weights or {}
    problem = IKProblem(motion.skeleton,
                        [Effector(n, tgt[0, k] if len(idx) else np.zeros(3), ew.get(n, 1.0))
                         for k, n in enumerate(names)], **problem_options)
    out = motion.copy()
    conv = np.zeros(len(idx), dtype=bool)
    dist = np.zeros((len(idx), len(names)))
    iters = np.zeros(len(idx), dtype=int)
    for n, f in enumerate(idx):
        res = solve(problem.with_targets(tgt[n]), Pose.from_motion(motion, int(f)), method,
                    **dict(solver_options or {}))
        res.pose.write_to(out, int(f))
        conv[n], dist[n], iters[n] = res.converged, res.distances, res.iterations
    return FramesResult(out, idx, conv, dist, iters)
