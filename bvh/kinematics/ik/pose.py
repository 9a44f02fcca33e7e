"""One skeleton pose for inverse kinematics, and its forward kinematics vectorised over joints.

:class:`Pose` is one frame of a skeleton (root position, local wxyz rotations, bone offsets) that
the solvers of :mod:`mjchar.bvh.kinematics.ik` move. Forward kinematics runs one numpy pass per tree
depth (:func:`_depth_levels`, :func:`_fk`): every joint of a level is composed with its parent at
once.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mjchar.bvh.errors import IKError
from mjchar.bvh.io.motion import Motion
from mjchar.bvh.io.skeleton import Skeleton
from mjchar.bvh.rotations import quat_mul, quat_normalize, to_rotation


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
        skeleton: the :class:`~mjchar.bvh.io.skeleton.Skeleton` posed.
        root_position: ``(3,)`` root translation, in the skeleton's units.
        rotations: ``(J, 4)`` local joint rotations, unit wxyz quaternions (normalised on
            construction).
        bone_offsets: ``(J, 3)`` local translation of every joint in its parent's frame (row 0,
            the root, is ignored: ``root_position`` is used). Defaults to the skeleton's rest
            offsets; differs from them only for non-root joints with position channels. IK never
            changes it.
        frame_time: seconds per frame of the :class:`~mjchar.bvh.io.motion.Motion` made by
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
        """A one-frame :class:`~mjchar.bvh.io.motion.Motion` of this pose."""
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

