"""What a character-tracking policy observes of the body: DeepMimic-style features in the
character's *heading frame* (the world rotated about z by the root's yaw, origin at the root).

Computed here, below the environments, so the Gymnasium envs (:mod:`mjchar.envs`) and a learned
policy running as a controller (:mod:`mjchar.controllers.learned`) share one function and the
same numbers.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from .character import Character
from .geometry import cross_rows, heading_yaw

__all__ = ["BodyObserver", "heading_rotation", "OBS_POSITION_LIMIT", "OBS_VELOCITY_LIMIT"]

#: metres: bound of heights and root-relative positions in observations (values are clipped)
OBS_POSITION_LIMIT = 10.0
#: m/s and rad/s: bound of velocities in observations (values are clipped)
OBS_VELOCITY_LIMIT = 250.0

def heading_rotation(root_xmat: np.ndarray) -> np.ndarray:
    """``(3, 3)`` rotation about world z by the heading (yaw) of a body whose world rotation
    matrix is ``root_xmat`` (``(9,)`` or ``(3, 3)``): the yaw of the body's x axis (facing
    direction) projected on the floor. World vectors ``v`` (rows) map to the heading frame as
    ``v @ R``."""
    yaw = heading_yaw(np.asarray(root_xmat, dtype=float))
    c, s = math.cos(yaw), math.sin(yaw)
    R = _IDENTITY.copy()  # (cheaper than building the matrix from nested lists)
    R[0, 0], R[0, 1], R[1, 0], R[1, 1] = c, -s, s, c
    return R


_IDENTITY = np.eye(3)


class BodyObserver:
    """Body features of a character in its heading frame (DeepMimic's state, Peng et al. 2018).

    For the character's bodies ``b`` (the root's subtree, ``K`` bodies, root first), with ``H`` the
    heading rotation of the root (:func:`heading_rotation`) and ``r`` the root position, the
    features are, in this order:

    - root height ``r_z`` (1);
    - positions ``H^T (x_b - r)`` of the ``K - 1`` non-root bodies (``3 (K - 1)``);
    - rotations as tangent-normal vectors: every body's x axis ``H^T R_b e_x`` (``3 K``), then
      every body's z axis ``H^T R_b e_z`` (``3 K``);
    - linear velocities of the body origins ``H^T v_b`` (``3 K``) and angular velocities
      ``H^T w_b`` (``3 K``): world velocities (MuJoCo's ``cvel`` moved to the body origins)
      expressed in the heading frame.

    All of them come out of one ``(5 K - 1, 3) @ H`` product.

    Args:
        character: the character observed (read after ``mj_step1``, which the Character
            guarantees after every step and reset).
    """

    def __init__(self, character: Character):
        m = character.model
        self.root = int(character.root_body)
        others = [int(b) for b in character.character_bodies if int(b) != self.root]
        self.bodies = np.array([self.root, *others], dtype=int)
        k = self.n_bodies = len(self.bodies)
        # a contiguous block of body ids (the converter's layout) is read through a slice (a view)
        contiguous = np.array_equal(self.bodies, np.arange(self.root, self.root + k))
        self._sel = slice(self.root, self.root + k) if contiguous else self.bodies
        # cvel is expressed at the subtree centre of mass of each body's tree root
        com_of = m.body_rootid[self.bodies].astype(int)
        self._com_of = int(com_of[0]) if np.all(com_of == com_of[0]) else com_of
        self._rows = {"pos": slice(0, k - 1), "x": slice(k - 1, 2 * k - 1),
                      "z": slice(2 * k - 1, 3 * k - 1), "lin": slice(3 * k - 1, 4 * k - 1),
                      "ang": slice(4 * k - 1, 5 * k - 1)}
        self._V = np.empty((5 * k - 1, 3))
        #: number of features of :meth:`observe`
        self.size = 1 + 3 * (5 * k - 1)

    def frame(self, data: mujoco.MjData) -> tuple[np.ndarray, np.ndarray]:
        """``(H (3, 3), r (3,))``: heading rotation and root position of ``data``."""
        return heading_rotation(data.xmat[self.root]), data.xpos[self.root].copy()

    def pose(self, data: mujoco.MjData, H: np.ndarray, origin: np.ndarray) -> np.ndarray:
        """``(9 K,)``: the positions of all ``K`` bodies (root included) relative to ``origin``,
        then their x axes, then their z axes, in the frame ``H`` (m; unit vectors)."""
        xm = data.xmat[self._sel]
        V = np.concatenate([data.xpos[self._sel] - origin, xm[:, 0::3], xm[:, 2::3]])
        return (V @ H).ravel()

    def observe(self, data: mujoco.MjData, extra: int = 0,
                frame: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
        """``(size + extra,)`` float64 features (see the class docstring), not yet clipped;
        the last ``extra`` entries are left for the caller to fill. ``frame``: :meth:`frame`
        of ``data`` when already computed."""
        H, r = self.frame(data) if frame is None else frame
        V, rows, sel = self._V, self._rows, self._sel
        xpos = data.xpos[sel]
        np.subtract(xpos[1:], r, out=V[rows["pos"]])
        xm = data.xmat[sel]
        V[rows["x"]] = xm[:, 0::3]  # row-major 3x3: column 0 (the x axis) is elements 0, 3, 6
        V[rows["z"]] = xm[:, 2::3]
        cv = data.cvel[sel]
        ang = cv[:, :3]
        V[rows["ang"]] = ang
        V[rows["lin"]] = cv[:, 3:] + cross_rows(ang, xpos - data.subtree_com[self._com_of])
        out = np.empty(self.size + extra)
        out[0] = r[2]
        np.matmul(V, H, out=out[1:self.size].reshape(-1, 3))
        return out

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """``(low, high)``, each ``(size,)``: the clip limits of :meth:`observe`'s features
        (:data:`OBS_POSITION_LIMIT` for heights/positions, 1 for rotations,
        :data:`OBS_VELOCITY_LIMIT` for velocities)."""
        k = self.n_bodies
        hi = np.concatenate([np.full(1 + 3 * (k - 1), OBS_POSITION_LIMIT), np.ones(6 * k),
                             np.full(6 * k, OBS_VELOCITY_LIMIT)])
        return -hi, hi
