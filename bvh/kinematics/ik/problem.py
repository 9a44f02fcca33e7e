"""The inverse-kinematics problem shared by every solver of :mod:`mjchar.bvh.kinematics.ik`.

:class:`IKProblem` owns everything that is not a solver's update rule: effectors (joints or end
sites, :class:`Effector`) and their targets and weights, which joints may move, effector positions
and residuals (:class:`IKState`), the analytic Jacobian (column for world axis ``a`` of joint ``i``
and effector ``e``: ``a x (p_e - p_i)``; root translation columns ``length_scale * I``), how a
joint-space step is limited (``max_angle`` per iteration) and applied
(``r_i <- exp([R_parent^T omega_i]) r_i``), and the convergence test. :func:`_iterate` is the loop
every solver runs, recording the history in an :class:`IKResult`. The parameterisation and the
objective ``E = sqrt(sum_k w_k |t_k - p_k|^2)`` are described in :mod:`mjchar.bvh.kinematics.ik`.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from mjchar.bvh.errors import IKError, SkeletonError, name_list
from mjchar.bvh.io.motion import Motion
from mjchar.bvh.io.skeleton import Skeleton
from mjchar.bvh.kinematics.ik.pose import (
    Pose,
    _check_finite,
    _depth_levels,
    _fk,
    _rotation_matrices,
)
from mjchar.bvh.rotations import (
    quat_conj,
    quat_from_rotvec,
    quat_mul,
    quat_normalize,
    quat_to_rotvec,
)


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


def _check_options(max_angle: float, tolerance: float, max_translation: float | None,
                   min_improvement: float) -> None:
    """:class:`IKError` for an iteration limit, tolerance or stopping rule out of range."""
    for opt, val in (("max_angle", max_angle), ("tolerance", tolerance)):
        if not (np.isfinite(val) and val > 0):
            raise IKError(f"{opt} must be a positive number, got {val}")
    if max_translation is not None and not (np.isfinite(max_translation)
                                            and max_translation > 0):
        raise IKError(f"max_translation must be positive or None, got {max_translation}")
    if not (np.isfinite(min_improvement) and min_improvement >= 0):
        raise IKError(f"min_improvement must be >= 0, got {min_improvement}")


class IKProblem:
    """Which effectors go where, which joints may move, and how much per iteration.

    Args:
        skeleton: the :class:`~mjchar.bvh.io.skeleton.Skeleton`.
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
        if isinstance(effectors, Mapping):
            effectors = [Effector(k, v) for k, v in effectors.items()]
        effectors = list(effectors)
        if not effectors:
            raise IKError("at least one effector is needed")
        _check_options(max_angle, tolerance, max_translation, min_improvement)
        self.max_angle = float(max_angle)
        self.max_translation = None if max_translation is None else float(max_translation)
        self.tolerance = float(tolerance)
        self.min_improvement = float(min_improvement)
        self._levels = _depth_levels(skeleton.parents)
        self._set_effectors(effectors)
        self._set_movable(joints, root_may_move, root_translation, joint_weights, locked)
        # length that makes a unit of root-translation parameter comparable to a radian
        rest = np.concatenate([skeleton.rest_positions(), skeleton.rest_end_sites()])
        self.length_scale = max(float(np.max(np.linalg.norm(rest - rest[0], axis=1))), 1e-9)

    # -- set-up helpers ------------------------------------------------------------------------
    def _set_effectors(self, effectors: list[Effector]) -> None:
        """Effectors: names, attachment joints and constant local offsets (zero for a joint
        effector), targets and weights."""
        skeleton = self.skeleton
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
                              f"{name_list(skeleton.names)}; end sites: "
                              f"{name_list(skeleton.end_site_names)}")
        self.attach = np.array(attach, dtype=int)
        self.local_offsets = np.array(offsets, dtype=float).reshape(-1, 3)
        self.targets = np.stack([_check_finite(f"target of {e.name!r}", e.target, (3,))
                                 for e in effectors])
        w = np.array([e.weight for e in effectors], dtype=float)
        if not np.all(np.isfinite(w)) or np.any(w < 0) or not np.any(w > 0):
            raise IKError(f"effector weights must be finite, >= 0 and not all 0, got {w}")
        self.effector_weights = w

    def _set_movable(self, joints: Iterable[str] | None, root_may_move: bool,
                     root_translation: bool | None, joint_weights: Mapping[str, float] | None,
                     locked: Iterable[str]) -> None:
        """Which joints move (and how willingly), whether the root translates, and which
        movable joint moves which effector."""
        n = self.skeleton.n_joints
        # which joint moves which effector: ancestors of the attachment joint, and the joint
        # itself when the effector is offset from it
        anc = np.zeros((len(self.attach), n), dtype=bool)
        for k, a in enumerate(self.attach):
            anc[k, self.skeleton.chain(int(a))] = True
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
        """The solved pose as a one-frame :class:`~mjchar.bvh.io.motion.Motion`."""
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
