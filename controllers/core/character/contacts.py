"""``character.contacts``: the floor and what touches it.

Contacts between the floor plane and the character's geoms at the current state (after
``mj_step1``): every ground contact, which feet are down, the normal force under each foot, the
support polygon, bodies other than the feet on the ground (a fall), the soles' sites; and the
floor plane itself (its normal and height, tilted at run time for slopes).

The feet are the ankle and toe bodies of each side (the ``left_ankle``/``left_toe`` roles, ...);
the sole sites are ``left_foot`` and ``right_foot`` (docs/model-contract.md).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from ..errors import CharacterError
from ..geometry import convex_hull_2d


@dataclass(frozen=True)
class GroundContact:
    """One contact between the floor and a character geom.

    Attributes:
        body: name of the character body touching the floor.
        position: ``(3,)`` world contact point (m).
        distance: penetration distance (m, negative when penetrating).
    """

    body: str
    position: np.ndarray
    distance: float


class Contacts:
    """The floor contacts of one character (built by the Character; see the module docstring).

    Args:
        floor_geom: geom id of the floor plane.
        foot_side: ``(nbody,)`` 0 for the left foot's bodies, 1 for the right's, -1 elsewhere.
        foot_bodies: ``(k,)`` ids of the foot bodies (both sides).
        foot_sites: site ids of ``left_foot`` and ``right_foot`` (``-1`` when absent).

    Attributes:
        floor_geom: geom id of the floor plane.
        foot_bodies: ``(k,)`` sorted body ids of the feet (ankle and toe bodies).
    """

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, floor_geom: int,
                 foot_side: np.ndarray, foot_bodies: np.ndarray, foot_sites: tuple[int, int]):
        self._model, self._data = model, data
        self.floor_geom = int(floor_geom)
        self.foot_bodies = foot_bodies
        self._is_foot = np.zeros(model.nbody, dtype=bool)
        self._is_foot[foot_bodies] = True
        self._geom_body = model.geom_bodyid.astype(int)
        self._geom_side = foot_side[self._geom_body]
        self._foot_side = foot_side
        self._foot_sites = foot_sites
        self._force = np.zeros(6)
        # per (geom, geom) pair of a contact: the character geom touching the floor (-1: not a
        # floor contact), and from it, as nested lists (a contact list is short: Python reads
        # it faster than numpy gathers it), whether that is a body other than a foot (a fall,
        # non_foot()), which foot it is (feet()) and which body (ground_points())
        ng = int(model.ngeom)
        other = np.full((ng, ng), -1)
        other[self.floor_geom, :] = np.arange(ng)
        rows = np.flatnonzero(np.arange(ng) != self.floor_geom)
        other[rows, self.floor_geom] = rows
        body = self._geom_body[np.maximum(other, 0)]
        self._pair_non_foot = ((other >= 0) & ~self._is_foot[body]).tolist()
        self._pair_side = np.where(other >= 0, self._geom_side[np.maximum(other, 0)], -1).tolist()
        self._pair_body = np.where(other >= 0, body, -1).tolist()  # (ground_points)

    # -- contacts -----------------------------------------------------------------------------
    def _floor_geoms(self) -> tuple[np.ndarray, np.ndarray]:
        """(character geoms touching the floor (k,), their contact indices (k,))."""
        n = self._data.ncon
        if n == 0:
            return np.zeros(0, int), np.zeros(0, int)
        g = self._data.contact.geom[:n]
        g0, g1 = g[:, 0], g[:, 1]
        f = self.floor_geom
        other = np.where(g0 == f, g1, np.where(g1 == f, g0, -1))
        idx = np.flatnonzero(other >= 0)
        return other[idx], idx

    def _floor_contacts(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(bodies (k,), positions (k, 3), distances (k,)) of floor contacts."""
        geoms, idx = self._floor_geoms()
        if len(idx) == 0:
            return np.zeros(0, int), np.zeros((0, 3)), np.zeros(0)
        c = self._data.contact
        return (self._model.geom_bodyid[geoms].astype(int), c.pos[idx].copy(),
                c.dist[idx].copy())

    def _body_name(self, b: int) -> str:
        return mujoco.mj_id2name(self._model, mujoco.mjtObj.mjOBJ_BODY, b) or str(b)

    def ground(self) -> list[GroundContact]:
        """Every contact between the floor and the character (list of :class:`GroundContact`)."""
        return [GroundContact(self._body_name(b), p, float(d))
                for b, p, d in zip(*self._floor_contacts(), strict=True)]

    def ground_points(self, bodies: tuple[int, ...]) -> np.ndarray:
        """``(k, 2)`` horizontal positions (x, y, m) of the floor contacts of the bodies
        ``bodies`` (ids), in contact order: :meth:`ground`'s positions for those bodies, without
        naming every contact."""
        if self._data.ncon == 0:
            return np.zeros((0, 2))
        body = self._pair_body
        c = self._data.contact
        rows = [i for i, (a, b) in enumerate(c.geom.tolist()) if body[a][b] in bodies]
        return np.ascontiguousarray(c.pos[rows, :2])

    def feet(self) -> tuple[bool, bool]:
        """``(left, right)``: whether each foot (ankle or toe body) touches the floor."""
        if self._data.ncon == 0:
            return False, False
        side = self._pair_side
        sides = [side[a][b] for a, b in self._data.contact.geom.tolist()]
        return 0 in sides, 1 in sides

    def any_non_foot(self) -> bool:
        """Whether a character body other than the feet touches the floor (a fall; the names
        are :meth:`non_foot`'s)."""
        if self._data.ncon == 0:
            return False
        bad = self._pair_non_foot
        return any(bad[a][b] for a, b in self._data.contact.geom.tolist())

    def non_foot(self) -> list[str]:
        """Names of character bodies other than the feet that touch the floor (a fall)."""
        geoms, _ = self._floor_geoms()
        bodies = self._geom_body[geoms]
        return [self._body_name(b) for b in sorted(set(bodies[~self._is_foot[bodies]].tolist()))]

    def foot_forces(self) -> np.ndarray:
        """``(2,)`` total floor normal force (N) under the left and the right foot.

        The contacts are those of the current state; their forces are solved for the current
        state and the controls last applied (``mj_fwdActuation``, ``mj_fwdAcceleration``,
        ``mj_fwdConstraint``: the stages the next step recomputes anyway, so the simulation is
        unchanged), then read per contact (``mj_contactForce``).
        """
        m, d = self._model, self._data
        out = np.zeros(2)
        n = d.ncon
        if n == 0:
            return out
        mujoco.mj_fwdActuation(m, d)
        mujoco.mj_fwdAcceleration(m, d)
        mujoco.mj_fwdConstraint(m, d)
        f = self._force
        floor = self.floor_geom
        for i in range(n):
            c = d.contact[i]
            g1, g2 = int(c.geom[0]), int(c.geom[1])
            if g1 != floor and g2 != floor or c.efc_address < 0:
                continue
            s = int(self._foot_side[m.geom_bodyid[g2 if g1 == floor else g1]])
            if s >= 0:
                mujoco.mj_contactForce(m, d, i, f)
                out[s] += abs(f[0])
        return out

    def support_polygon(self) -> np.ndarray:
        """``(K, 2)`` counter-clockwise convex hull of the feet's floor contact points (x, y, m).

        Empty ``(0, 2)`` when no foot touches the floor; fewer than 3 rows when the contacts are
        a point or a segment.
        """
        bodies, pos, _ = self._floor_contacts()
        return convex_hull_2d(pos[self._is_foot[bodies], :2])

    def foot_sites(self) -> tuple[np.ndarray, np.ndarray]:
        """World positions ``(3,)`` of the ``left_foot`` and ``right_foot`` sites (sole
        centres; copies)."""
        left, right = self._foot_sites
        if left < 0 or right < 0:
            raise CharacterError(f"unknown site {'left_foot' if left < 0 else 'right_foot'!r}")
        xs = self._data.site_xpos
        return xs[left].copy(), xs[right].copy()

    # -- the floor ----------------------------------------------------------------------------
    def floor_normal(self) -> np.ndarray:
        """``(3,)`` unit upward normal of the floor plane."""
        q = self._model.geom_quat[self.floor_geom]
        w, x, y, z = q / np.linalg.norm(q)
        return np.array([2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)])

    def floor_origin(self) -> np.ndarray:
        """``(3,)`` a point of the floor plane (its geom's position, m; a copy)."""
        return self._model.geom_pos[self.floor_geom].copy()

    def floor_height(self, xy) -> float:
        """Height (m) of the floor plane at world horizontal position ``xy`` ``(2,)``."""
        n = self.floor_normal()
        p0 = self._model.geom_pos[self.floor_geom]
        x = np.asarray(xy, dtype=float)[:2]
        return float(p0[2] - (n[0] * (x[0] - p0[0]) + n[1] * (x[1] - p0[1])) / n[2])

    def set_floor(self, quat, height: float) -> None:
        """Turn the floor plane to orientation ``quat`` ``(4,)`` wxyz and put it at ``height`` m
        over the world origin (a run-time edit of the model: no XML). Takes effect at the next
        ``character.reset``."""
        m, g = self._model, self.floor_geom
        m.geom_quat[g] = quat
        m.geom_pos[g] = [0.0, 0.0, height]
        # the compiler marks a geom at its body's frame ("sameframe") and kinematics then skips
        # its own transform: clear the flag so the new pose is used
        m.geom_sameframe[g] = 0
