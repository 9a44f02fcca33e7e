"""Forward kinematics for all frames at once."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from mjchar.bvh.io.motion import Motion
from mjchar.bvh.rotations import quat_mul, quat_rotate


class FKResult(NamedTuple):
    """Global joint transforms.

    Attributes:
        positions: ``(F, J, 3)`` global joint positions, in the file's units and axes.
        orientations: ``(F, J, 4)`` global joint orientations, wxyz unit quaternions.
    """

    positions: np.ndarray
    orientations: np.ndarray


def forward_kinematics(motion: Motion) -> FKResult:
    """Global positions and orientations of every joint in every frame.

    ``p_j = p_parent + R_parent t_j`` and ``R_j = R_parent r_j``, with ``t_j`` the local
    translation and ``r_j`` the local rotation; vectorised over frames (one pass over joints).
    """
    sk = motion.skeleton
    n_f, n_j = motion.n_frames, sk.n_joints
    pos = np.empty((n_f, n_j, 3))
    rot = np.empty((n_f, n_j, 4))
    for j in range(n_j):
        p = sk.parents[j]
        if p < 0:
            pos[:, j] = motion.local_positions[:, j]
            rot[:, j] = motion.rotations[:, j]
        else:
            pos[:, j] = pos[:, p] + quat_rotate(rot[:, p], motion.local_positions[:, j])
            rot[:, j] = quat_mul(rot[:, p], motion.rotations[:, j])
    return FKResult(pos, rot)


def end_site_positions(motion: Motion, fk: FKResult | None = None) -> np.ndarray:
    """``(F, E, 3)`` global end site positions (pass ``fk`` to reuse a computed result)."""
    fk = fk or forward_kinematics(motion)
    sk = motion.skeleton
    par = sk.end_site_parents
    return fk.positions[:, par] + quat_rotate(fk.orientations[:, par], sk.end_site_offsets[None])
