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
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from .errors import MjcharError, SkeletonError
from .motion import Motion
from .rotations import (
    quat_conj,
    quat_from_rotvec,
    quat_mul,
    quat_normalize,
    quat_to_rotvec,
    to_rotation,
)
from .skeleton import Skeleton

__all__ = [
    "IKError", "Pose", "Effector", "IKProblem", "IKState", "IKResult", "FramesResult",
    "solve", "solve_ccd", "solve_jacobian_transpose", "solve_dls", "solve_frames", "METHODS",
]


class IKError(MjcharError):
    """An inverse-kinematics problem or option cannot be used (bad target, nothing can move...)."""


# ---------------------------------------------------------------------------------------------
# kinematics of one pose, vectorised over joints (one numpy pass per tree depth)
# ---------------------------------------------------------------------------------------------
def _depth_levels(parents: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """``[(joints, their parents), ...]`` for depths 1, 2, ...: all joints of a level at once."""
    depth = np.zeros(len(parents), dtype=int)
    for j in range(1, len(parents)):
        depth[j] = depth[parents[j]] + 1
    levels = []
    for d in range(1, int(depth.max(initial=0)) + 1):
        idx = np.flatnonzero(depth == d)
        levels.append((idx, parents[idx]))
    return levels


def _rotation_matrices(q: np.ndarray) -> np.ndarray:
    """``(J, 3, 3)`` rotation matrices of ``(J, 4)`` wxyz quaternions."""
    return to_rotation(q).as_matrix().reshape(len(q), 3, 3)


def _fk(levels, local_positions: np.ndarray, local_matrices: np.ndarray):
    """Global ``(J, 3)`` positions and ``(J, 3, 3)`` orientations from local transforms."""
    pos = np.empty_like(local_positions)
    rot = np.empty_like(local_matrices)
    pos[0] = local_positions[0]
    rot[0] = local_matrices[0]
    for idx, par in levels:
        rot[idx] = rot[par] @ local_matrices[idx]
        pos[idx] = pos[par] + np.einsum("jab,jb->ja", rot[par], local_positions[idx])
    return pos, rot


def _check_finite(name: str, value, shape: tuple[int, ...]) -> np.ndarray:
    arr = np.asarray(value, dtype=float)
    if arr.shape != shape:
        raise IKError(f"{name} must have shape {shape}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise IKError(f"{name} contains NaN or infinite values: {arr}")
    return arr


# ---------------------------------------------------------------------------------------------
# pose
# ---------------------------------------------------------------------------------------------
@dataclass
class Pose:
    """One frame of a skeleton: root position and local joint rotations.

    Attributes:
        skeleton: the :class:`~bvh.skeleton.Skeleton` posed.
        root_position: ``(3,)`` root translation, in the skeleton's units.
        rotations: ``(J, 4)`` local joint rotations, unit wxyz quaternions (normalised on
            construction).
        bone_offsets: ``(J, 3)`` local translation of every joint in its parent's frame (row 0,
            the root, is ignored: ``root_position`` is used). Defaults to the skeleton's rest
            offsets; differs from them only for non-root joints with position channels. IK never
            changes it.
        frame_time: seconds per frame of the :class:`~bvh.motion.Motion` made by
            :meth:`to_motion` (carried over from :meth:`from_motion`).
    """

    skeleton: Skeleton
    root_position: np.ndarray
    rotations: np.ndarray
    bone_offsets: np.ndarray | None = None
    frame_time: float = 1.0 / 30.0

    def __post_init__(self) -> None:
        n = self.skeleton.n_joints
        self.root_position = _check_finite("root_position", self.root_position, (3,)).copy()
        rot = _check_finite("rotations", self.rotations, (n, 4))
        norms = np.linalg.norm(rot, axis=1)
        if np.any(norms < 1e-9):
            raise IKError("rotations contains a zero quaternion (not a rotation)")
        self.rotations = rot / norms[:, None]
        if self.bone_offsets is None:
            self.bone_offsets = self.skeleton.offsets.copy()
        else:
            self.bone_offsets = _check_finite("bone_offsets", self.bone_offsets, (n, 3)).copy()

    # -- conversion to and from motions ------------------------------------------------------
    @classmethod
    def from_motion(cls, motion: Motion, frame: int) -> Pose:
        """The pose of ``motion`` at integer ``frame`` (negative indices count from the end)."""
        f = int(frame)
        if not -motion.n_frames <= f < motion.n_frames:
            raise IKError(f"frame {frame} out of range for a motion of {motion.n_frames} frames")
        return cls(motion.skeleton, motion.local_positions[f, 0], motion.rotations[f],
                   motion.local_positions[f], motion.frame_time)

    @classmethod
    def rest(cls, skeleton: Skeleton) -> Pose:
        """The rest pose: root at its offset, identity rotations."""
        q = np.zeros((skeleton.n_joints, 4))
        q[:, 0] = 1.0
        return cls(skeleton, skeleton.offsets[0], q)

    def copy(self) -> Pose:
        return Pose(self.skeleton, self.root_position.copy(), self.rotations.copy(),
                    self.bone_offsets.copy(), self.frame_time)

    def local_positions(self) -> np.ndarray:
        """``(J, 3)`` local translations as a Motion stores them (row 0 = root position)."""
        out = self.bone_offsets.copy()
        out[0] = self.root_position
        return out

    def to_motion(self) -> Motion:
        """A one-frame :class:`~bvh.motion.Motion` of this pose."""
        return Motion(self.skeleton, self.frame_time, self.local_positions()[None],
                      self.rotations[None].copy())

    def write_to(self, motion: Motion, frame: int) -> None:
        """Store this pose into ``motion`` at ``frame`` (in place; same skeleton required)."""
        if motion.skeleton.n_joints != self.skeleton.n_joints:
            raise IKError(f"pose has {self.skeleton.n_joints} joints, motion has "
                          f"{motion.skeleton.n_joints}")
        motion.local_positions[frame] = self.local_positions()
        motion.rotations[frame] = self.rotations

    # -- kinematics ----------------------------------------------------------------------------
    def forward_kinematics(self) -> tuple[np.ndarray, np.ndarray]:
        """Global joint positions ``(J, 3)`` and orientations ``(J, 4)`` (wxyz)."""
        levels = _depth_levels(self.skeleton.parents)
        pos, _ = _fk(levels, self.local_positions(), _rotation_matrices(self.rotations))
        orient = np.empty_like(self.rotations)
        orient[0] = self.rotations[0]
        for idx, par in levels:
            orient[idx] = quat_mul(orient[par], self.rotations[idx])
        return pos, quat_normalize(orient)

    def end_site_positions(self) -> np.ndarray:
        """Global end site positions ``(E, 3)``."""
        levels = _depth_levels(self.skeleton.parents)
        pos, rot = _fk(levels, self.local_positions(), _rotation_matrices(self.rotations))
        sk = self.skeleton
        par = sk.end_site_parents
        return pos[par] + np.einsum("eab,eb->ea", rot[par], sk.end_site_offsets)


# ---------------------------------------------------------------------------------------------
# problem definition, shared by all solvers
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Effector:
    """A point of the skeleton that should reach a target.

    Attributes:
        name: a joint name or an end site name (e.g. ``"lWrist"`` or ``"lWrist_end"``).
        target: ``(3,)`` world target position, in the skeleton's units.
        weight: importance (>= 0) in the weighted error ``sum_k w_k |t_k - p_k|^2``.
    """

    name: str
    target: np.ndarray
    weight: float = 1.0


class IKState(NamedTuple):
    """A pose evaluated by :meth:`IKProblem.evaluate`.

    Attributes:
        pose: the :class:`Pose`.
        positions: ``(J, 3)`` global joint positions.
        orientations: ``(J, 3, 3)`` global joint rotation matrices.
        effectors: ``(K, 3)`` effector positions.
        residual: ``(K, 3)`` ``target - effector``.
        distances: ``(K,)`` ``|residual|`` per effector.
        error: weighted residual norm ``sqrt(sum_k w_k |residual_k|^2)`` (length units).
    """

    pose: Pose
    positions: np.ndarray
    orientations: np.ndarray
    effectors: np.ndarray
    residual: np.ndarray
    distances: np.ndarray
    error: float


class IKProblem:
    """Which effectors go where, which joints may move, and how much per iteration.

    Args:
        skeleton: the :class:`~bvh.skeleton.Skeleton`.
        effectors: a sequence of :class:`Effector`, or a mapping ``name -> target (3,)``
            (weight 1 each). Names are joint names or end site names; at least one is needed.
        joints: names of the joints whose rotation may change. Default: the union of the chains
            from each effector up to, but excluding, the root (for a joint effector, its strict
            ancestors; for an end site, its joint and that joint's ancestors).
        root_may_move: also let the root rotate and translate (its rotation is added to the
            movable joints, its translation adds three degrees of freedom).
        root_translation: override whether the root may translate (default: ``root_may_move``).
        joint_weights: ``name -> weight >= 0``; relative willingness of a joint to move (default
            1). Damped least squares and Jacobian transpose scale the joint's step by it; CCD
            scales the joint's rotation by ``weight / max(weight)``. Weight 0 locks the joint.
            The root translation uses the root's weight.
        locked: names of joints that never move (wins over ``joints``).
        max_angle: largest rotation (radians) any joint may make in one iteration (> 0).
        max_translation: largest root translation per iteration (skeleton units), or ``None``.
        tolerance: convergence when every weighted effector is this close to its target
            (skeleton units; default 1e-4, a tenth of a millimetre for skeletons in metres).
        min_improvement: stop (not converged) when an iteration lowers the error by less than
            this fraction of it.

    Raises:
        IKError: unknown names, bad targets or weights, or no joint left that can move an
            effector.
    """

    def __init__(
        self,
        skeleton: Skeleton,
        effectors: Sequence[Effector] | Mapping[str, np.ndarray],
        *,
        joints: Iterable[str] | None = None,
        root_may_move: bool = False,
        root_translation: bool | None = None,
        joint_weights: Mapping[str, float] | None = None,
        locked: Iterable[str] = (),
        max_angle: float = 0.5,
        max_translation: float | None = None,
        tolerance: float = 1e-4,
        min_improvement: float = 1e-9,
    ) -> None:
        self.skeleton = skeleton
        n = skeleton.n_joints
        if isinstance(effectors, Mapping):
            effectors = [Effector(k, v) for k, v in effectors.items()]
        effectors = list(effectors)
        if not effectors:
            raise IKError("at least one effector is needed")
        for opt, val in (("max_angle", max_angle), ("tolerance", tolerance)):
            if not (np.isfinite(val) and val > 0):
                raise IKError(f"{opt} must be a positive number, got {val}")
        if max_translation is not None and not (np.isfinite(max_translation)
                                                and max_translation > 0):
            raise IKError(f"max_translation must be positive or None, got {max_translation}")
        if not (np.isfinite(min_improvement) and min_improvement >= 0):
            raise IKError(f"min_improvement must be >= 0, got {min_improvement}")
        self.max_angle = float(max_angle)
        self.max_translation = None if max_translation is None else float(max_translation)
        self.tolerance = float(tolerance)
        self.min_improvement = float(min_improvement)
        self._levels = _depth_levels(skeleton.parents)

        # effectors: attachment joint + constant local offset (zero for a joint effector)
        self.effector_names = [e.name for e in effectors]
        if len(set(self.effector_names)) != len(effectors):
            raise IKError(f"an effector is listed twice: {self.effector_names}")
        attach, offsets = [], []
        for e in effectors:
            if e.name in skeleton.names:
                attach.append(skeleton.names.index(e.name))
                offsets.append(np.zeros(3))
            elif e.name in skeleton.end_site_names:
                s = skeleton.end_site_names.index(e.name)
                attach.append(int(skeleton.end_site_parents[s]))
                offsets.append(skeleton.end_site_offsets[s])
            else:
                raise IKError(f"unknown effector {e.name!r}: not a joint or end site; joints: "
                              f"{', '.join(skeleton.names)}; end sites: "
                              f"{', '.join(skeleton.end_site_names)}")
        self.attach = np.array(attach, dtype=int)
        self.local_offsets = np.array(offsets, dtype=float).reshape(-1, 3)
        self.targets = np.stack([_check_finite(f"target of {e.name!r}", e.target, (3,))
                                 for e in effectors])
        w = np.array([e.weight for e in effectors], dtype=float)
        if not np.all(np.isfinite(w)) or np.any(w < 0) or not np.any(w > 0):
            raise IKError(f"effector weights must be finite, >= 0 and not all 0, got {w}")
        self.effector_weights = w

        # which joint moves which effector: ancestors of the attachment joint, and the joint
        # itself when the effector is offset from it
        anc = np.zeros((len(effectors), n), dtype=bool)
        for k, a in enumerate(self.attach):
            anc[k, skeleton.chain(int(a))] = True
            if not np.any(self.local_offsets[k]):
                anc[k, a] = False
        weights = np.ones(n)
        for name, val in (joint_weights or {}).items():
            if not (np.isfinite(val) and val >= 0):
                raise IKError(f"joint weight of {name!r} must be finite and >= 0, got {val}")
            weights[self._joint(name)] = float(val)
        if joints is None:
            movable = anc.any(axis=0)
            movable[0] = False
        else:
            movable = np.zeros(n, dtype=bool)
            movable[[self._joint(j) for j in joints]] = True
        if root_may_move:
            movable[0] = True
        for name in locked:
            movable[self._joint(name)] = False
        movable &= weights > 0
        self.translate_root = bool(root_may_move if root_translation is None
                                   else root_translation) and weights[0] > 0
        self.dof_joints = np.flatnonzero(movable)  # ascending = parents before children
        self.joint_weights = weights[self.dof_joints]
        self.root_translation_weight = float(weights[0])
        self.moves = anc[:, self.dof_joints]  # (K, n_j)
        if not (self.moves.any() or self.translate_root):
            raise IKError("no movable joint can move any effector (check joints/locked/weights)")
        # length that makes a unit of root-translation parameter comparable to a radian
        rest = np.concatenate([skeleton.rest_positions(), skeleton.rest_end_sites()])
        self.length_scale = max(float(np.max(np.linalg.norm(rest - rest[0], axis=1))), 1e-9)

    # -- set-up helpers ------------------------------------------------------------------------
    def _joint(self, name: str) -> int:
        try:
            return self.skeleton.index(name)
        except SkeletonError as exc:
            raise IKError(str(exc)) from None

    @property
    def n_effectors(self) -> int:
        return len(self.effector_names)

    @property
    def n_dof(self) -> int:
        """Size of a step: 3 per movable joint, plus 3 when the root translates."""
        return 3 * len(self.dof_joints) + (3 if self.translate_root else 0)

    @property
    def dof_weights(self) -> np.ndarray:
        """``(n_dof,)`` per-dof weights (each joint's weight repeated for its 3 dofs)."""
        w = np.repeat(self.joint_weights, 3)
        if self.translate_root:
            w = np.concatenate([w, np.full(3, self.root_translation_weight)])
        return w

    @property
    def dof_joint_names(self) -> list[str]:
        """Names of the joints whose rotation may change, in skeleton order."""
        return [self.skeleton.names[j] for j in self.dof_joints]

    def with_targets(self, targets: np.ndarray | Mapping[str, np.ndarray]) -> IKProblem:
        """The same problem with new targets: ``(K, 3)`` in effector order, or ``name -> (3,)``."""
        new = object.__new__(IKProblem)
        new.__dict__.update(self.__dict__)
        if isinstance(targets, Mapping):
            t = self.targets.copy()
            for name, val in targets.items():
                if name not in self.effector_names:
                    raise IKError(f"{name!r} is not an effector of this problem "
                                  f"({self.effector_names})")
                t[self.effector_names.index(name)] = _check_finite(f"target of {name!r}", val,
                                                                   (3,))
        else:
            t = _check_finite("targets", targets, (self.n_effectors, 3))
        new.targets = t.copy()
        return new

    # -- evaluation (shared by every solver) ---------------------------------------------------
    def _check_pose(self, pose: Pose) -> None:
        if pose.skeleton.n_joints != self.skeleton.n_joints:
            raise IKError(f"pose has {pose.skeleton.n_joints} joints, the problem's skeleton "
                          f"has {self.skeleton.n_joints}")

    def evaluate(self, pose: Pose) -> IKState:
        """Forward kinematics, effector positions and errors of ``pose``."""
        pos, rot = _fk(self._levels, pose.local_positions(), _rotation_matrices(pose.rotations))
        eff = pos[self.attach] + np.einsum("kab,kb->ka", rot[self.attach], self.local_offsets)
        res = self.targets - eff
        dist = np.linalg.norm(res, axis=1)
        err = float(np.sqrt(np.sum(self.effector_weights * dist**2)))
        return IKState(pose, pos, rot, eff, res, dist, err)

    def converged(self, state: IKState) -> bool:
        """Every effector with positive weight within ``tolerance`` of its target."""
        return bool(np.all(state.distances[self.effector_weights > 0] <= self.tolerance))

    def jacobian(self, state: IKState) -> np.ndarray:
        """``(3K, n_dof)`` derivative of the stacked effector positions w.r.t. a step.

        Columns ``3i .. 3i+2``: world-axis rotation-vector increments of the i-th movable joint;
        column for axis ``a`` is ``a x (p_e - p_i)`` (zero for effectors the joint does not
        move). Last three columns (root translation): ``length_scale * I``.
        """
        d = state.effectors[:, None, :] - state.positions[self.dof_joints][None, :, :]
        d = d * self.moves[:, :, None]  # (K, n_j, 3)
        axes = np.eye(3)
        # cols[k, i, a, c] = (e_a x d_ki)_c
        cols = np.cross(axes[None, None, :, :], d[:, :, None, :])
        k, nj = d.shape[:2]
        jac = cols.transpose(0, 3, 1, 2).reshape(3 * k, 3 * nj)
        if self.translate_root:
            jac = np.concatenate([jac, np.tile(self.length_scale * axes, (k, 1))], axis=1)
        return jac

    def weighted_system(self, state: IKState) -> tuple[np.ndarray, np.ndarray]:
        """``(J_w (3K, n_dof), r_w (3K,))``: Jacobian and residual scaled by ``sqrt(w_k)``.

        ``|r_w| = state.error``; the linearised error after a step ``dq`` is ``|r_w - J_w dq|``.
        """
        s = np.repeat(np.sqrt(self.effector_weights), 3)
        return self.jacobian(state) * s[:, None], state.residual.reshape(-1) * s

    def limit_step(self, step: np.ndarray) -> np.ndarray:
        """Scale a ``(n_dof,)`` step as a whole so no joint turns more than ``max_angle``.

        The direction is kept (so a descent direction stays one); the root translation is also
        limited to ``max_translation`` when set. Non-finite steps become zero.
        """
        step = np.asarray(step, dtype=float)
        if not np.all(np.isfinite(step)):
            return np.zeros_like(step)
        nj = len(self.dof_joints)
        angles = np.linalg.norm(step[: 3 * nj].reshape(nj, 3), axis=1)
        scale = 1.0
        biggest = float(angles.max(initial=0.0))
        if biggest > self.max_angle:
            scale = self.max_angle / biggest
        if self.translate_root and self.max_translation is not None:
            move = self.length_scale * float(np.linalg.norm(step[3 * nj:]))
            if move * scale > self.max_translation:
                scale = self.max_translation / move
        return step * scale

    def apply(self, state: IKState, step: np.ndarray) -> Pose | None:
        """The pose after a step; ``None`` if the result would not be finite.

        ``step``: ``(n_dof,)`` world rotation vectors (radians) of the movable joints, then the
        root translation in units of ``length_scale``. The step is first passed through
        :meth:`limit_step` (a no-op for a step already within the limits), so no solver can turn
        a joint by more than ``max_angle``. Rotations are composed exactly
        (``r_i <- exp(R_parent^T omega_i) r_i``), not added.
        """
        pose = state.pose
        step = self.limit_step(step)
        nj = len(self.dof_joints)
        omega = step[: 3 * nj].reshape(nj, 3)
        par = self.skeleton.parents[self.dof_joints]
        parent_rot = np.where((par >= 0)[:, None, None], state.orientations[np.maximum(par, 0)],
                              np.eye(3))
        local = np.einsum("jba,jb->ja", parent_rot, omega)  # R_parent^T omega
        rotations = pose.rotations.copy()
        rotations[self.dof_joints] = quat_normalize(
            quat_mul(quat_from_rotvec(local), rotations[self.dof_joints]))
        root = pose.root_position.copy()
        if self.translate_root:
            root = root + self.length_scale * step[3 * nj:]
        if not (np.all(np.isfinite(rotations)) and np.all(np.isfinite(root))):
            return None
        return Pose(pose.skeleton, root, rotations, pose.bone_offsets, pose.frame_time)

    @staticmethod
    def joint_changes(before: Pose, after: Pose) -> np.ndarray:
        """``(J,)`` angle (radians) each joint's local rotation turned between two poses."""
        dq = quat_mul(quat_conj(before.rotations), after.rotations)
        return np.linalg.norm(quat_to_rotvec(dq), axis=1)


# ---------------------------------------------------------------------------------------------
# results and the iteration loop shared by all solvers
# ---------------------------------------------------------------------------------------------
@dataclass
class IKResult:
    """What a solver returns.

    Attributes:
        pose: the solved :class:`Pose` (the input pose is left unchanged).
        method: ``"ccd"``, ``"jacobian_transpose"`` or ``"dls"``.
        converged: every weighted effector within the problem's tolerance.
        iterations: iterations performed (accepted steps; 0 if the start was converged).
        errors: ``(iterations + 1,)`` weighted error norm, start first (never increases).
        max_distances: ``(iterations + 1,)`` largest effector-to-target distance.
        max_joint_change: ``(iterations,)`` largest angle (radians) any joint turned in each
            iteration, measured on the poses (not the requested step).
        root_translation_change: ``(iterations,)`` root displacement per iteration.
        distances: ``(K,)`` final effector-to-target distances.
        effectors: ``(K, 3)`` final effector positions.
        poses: every iterate (start first) when the solver was asked to record them, else [].
    """

    pose: Pose
    method: str
    converged: bool
    iterations: int
    errors: np.ndarray
    max_distances: np.ndarray
    max_joint_change: np.ndarray
    root_translation_change: np.ndarray
    distances: np.ndarray
    effectors: np.ndarray
    poses: list[Pose] = field(default_factory=list)

    @property
    def motion(self) -> Motion:
        """The solved pose as a one-frame :class:`~bvh.motion.Motion`."""
        return self.pose.to_motion()

    @property
    def error(self) -> float:
        """Final weighted error norm."""
        return float(self.errors[-1])


Step = Callable[[IKState], "IKState | None"]


def _iterate(problem: IKProblem, pose: Pose, step: Step, method: str, max_iterations: int,
             record_poses: bool) -> IKResult:
    """Run ``step`` until convergence, no progress, or ``max_iterations``; record history.

    ``step`` maps the current state to a strictly better one, or ``None`` when it finds none.
    """
    if int(max_iterations) < 0:
        raise IKError(f"max_iterations must be >= 0, got {max_iterations}")
    problem._check_pose(pose)
    state = problem.evaluate(pose)
    errors, max_dist = [state.error], [float(state.distances.max())]
    changes, moves, poses = [], [], [state.pose] if record_poses else []
    done = problem.converged(state)
    while not done and len(changes) < int(max_iterations):
        new = step(state)
        if new is None:
            break
        changes.append(float(problem.joint_changes(state.pose, new.pose).max()))
        moves.append(float(np.linalg.norm(new.pose.root_position - state.pose.root_position)))
        errors.append(new.error)
        max_dist.append(float(new.distances.max()))
        if record_poses:
            poses.append(new.pose)
        stalled = state.error - new.error <= problem.min_improvement * state.error
        state = new
        done = problem.converged(state) or stalled
    return IKResult(
        pose=state.pose, method=method, converged=problem.converged(state),
        iterations=len(changes), errors=np.array(errors), max_distances=np.array(max_dist),
        max_joint_change=np.array(changes), root_translation_change=np.array(moves),
        distances=state.distances.copy(), effectors=state.effectors.copy(), poses=poses,
    )


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


class FramesResult(NamedTuple):
    """What :func:`solve_frames` returns.

    Attributes:
        motion: a new :class:`~bvh.motion.Motion` with the solved frames replaced.
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
        motion: the :class:`~bvh.motion.Motion` (not modified).
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
