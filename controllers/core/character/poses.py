"""``character.poses``: kinematic queries on a pose, computed on a scratch ``MjData`` so the
simulation state is untouched: the rest and standing poses, the leg length, the lowest point of
the character's geoms (above a level or a tilted floor), a pose put on the floor, a body's world
pose, the world frames of every body, joint and site (:class:`Kinematics`), the offsets of bodies
and sites in their parents' frames (model constants), and damped least-squares inverse
kinematics (``mj_jacBody``, ``mj_integratePos``).

:class:`Poses` is the part a controller uses (names resolved, shapes checked); the functions
below it take a model and ids.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import mujoco
import numpy as np

from .model import as_vector

_GEOM_SPHERE = int(mujoco.mjtGeom.mjGEOM_SPHERE)
_GEOM_CAPSULE = int(mujoco.mjtGeom.mjGEOM_CAPSULE)
_GEOM_BOX = int(mujoco.mjtGeom.mjGEOM_BOX)


class _GeomsByShape:
    """The geoms of some bodies split by shape (what :func:`lowest_point` needs, computed once
    per model and bodies)."""

    def __init__(self, model: mujoco.MjModel, bodies: np.ndarray):
        geoms = np.flatnonzero(np.isin(model.geom_bodyid, bodies))
        t = model.geom_type[geoms]
        self.boxes = geoms[t == _GEOM_BOX]
        self.capsules = geoms[t == _GEOM_CAPSULE]
        self.spheres = geoms[t == _GEOM_SPHERE]
        self.others = geoms[~np.isin(t, (_GEOM_BOX, _GEOM_CAPSULE, _GEOM_SPHERE))]
        self.size = len(geoms)


def _lowest(m: mujoco.MjModel, sd: mujoco.MjData, shapes: _GeomsByShape) -> float:
    """Lowest world z of the geoms ``shapes`` of the kinematics in ``sd`` (see
    :func:`lowest_point`; capsules, spheres and other shapes element-wise over the geoms, boxes
    one product each)."""
    if shapes.size == 0:
        raise ValueError("lowest_point of no geoms")
    xpos, xmat, size = sd.geom_xpos, sd.geom_xmat, m.geom_size
    low = math.inf
    for g in shapes.boxes:
        low = min(low, float(xpos[g, 2] - np.abs(xmat[g, 6:9]) @ size[g]))
    g = shapes.capsules
    if len(g):
        low = min(low, float((xpos[g, 2] - np.abs(xmat[g, 8]) * size[g, 1] - size[g, 0]).min()))
    g = shapes.spheres
    if len(g):
        low = min(low, float((xpos[g, 2] - size[g, 0]).min()))
    g = shapes.others
    if len(g):
        low = min(low, float((xpos[g, 2] - m.geom_rbound[g]).min()))
    return low


def lowest_point(model: mujoco.MjModel, qpos: np.ndarray, bodies: np.ndarray, *,
                 scratch: mujoco.MjData | None = None,
                 shapes: _GeomsByShape | None = None) -> float:
    """Lowest world z (m) of the geoms of ``bodies`` (ids) at pose ``qpos`` ``(nq,)``: boxes,
    capsules and spheres exactly, other shapes by their bounding sphere. ``scratch``: an
    ``MjData`` of ``model`` to compute the kinematics in (default: a new one); ``shapes``: the
    geoms of ``bodies`` sorted by shape, when already known."""
    m = model
    sd = mujoco.MjData(m) if scratch is None else scratch
    sd.qpos[:] = qpos
    mujoco.mj_kinematics(m, sd)
    return _lowest(m, sd, _GeomsByShape(m, bodies) if shapes is None else shapes)


def body_pose(model: mujoco.MjModel, qpos: np.ndarray, body: int) -> tuple[np.ndarray, np.ndarray]:
    """World position ``(3,)`` and wxyz orientation ``(4,)`` of body id ``body`` at ``qpos``."""
    sd = mujoco.MjData(model)
    sd.qpos[:] = qpos
    mujoco.mj_kinematics(model, sd)
    return sd.xpos[body].copy(), sd.xquat[body].copy()


def solve_ik(model: mujoco.MjModel, qpos: np.ndarray, targets: list, dofs: np.ndarray, *,
             iterations: int = 100, damping: float = 1e-3, tol: float = 1e-11) -> np.ndarray:
    """Damped least-squares IK from ``qpos`` ``(nq,)``.

    Args:
        targets: list of ``(body id, position, quat)``: the body's world origin target ``(3,)``
            m (or ``None``) and world orientation target ``(4,)`` wxyz (or ``None``).
        dofs: ``(k,)`` dof indices allowed to move.
        iterations, damping, tol: DLS iterations, damping (m), squared-error tolerance.
    Returns:
        ``(nq,)`` the solved pose.
    """
    m = model
    sd = mujoco.MjData(m)
    sd.qpos[:] = qpos
    dofs = np.asarray(dofs, dtype=int)
    jacp = np.zeros((3, m.nv))
    jacr = np.zeros((3, m.nv))
    for _ in range(iterations):
        mujoco.mj_kinematics(m, sd)
        mujoco.mj_comPos(m, sd)
        rows, errs = [], []
        for b, pos, quat in targets:
            mujoco.mj_jacBody(m, sd, jacp, jacr, b)
            if pos is not None:
                rows.append(jacp[:, dofs].copy())
                errs.append(np.asarray(pos, float) - sd.xpos[b])
            if quat is not None:
                dq = np.empty(4)
                mujoco.mju_mulQuat(dq, np.asarray(quat, float),
                                   sd.xquat[b] * np.array([1.0, -1.0, -1.0, -1.0]))
                rv = np.empty(3)
                mujoco.mju_quat2Vel(rv, dq, 1.0)
                rows.append(jacr[:, dofs].copy())
                errs.append(rv)
        J = np.vstack(rows)
        e = np.concatenate(errs)
        if e @ e < tol:
            break
        dq = J.T @ np.linalg.solve(J @ J.T + damping ** 2 * np.eye(len(e)), e)
        v = np.zeros(m.nv)
        v[dofs] = dq
        mujoco.mj_integratePos(m, sd.qpos, v, 1.0)
    return sd.qpos.copy()


def plane_clearance(model: mujoco.MjModel, qpos: np.ndarray, bodies: np.ndarray,
                    normal: np.ndarray, origin: np.ndarray) -> float:
    """Lowest signed distance (m) of the geoms of ``bodies`` (ids) at pose ``qpos`` ``(nq,)``
    from the plane through ``origin`` ``(3,)`` with unit ``normal`` ``(3,)`` (boxes, capsules
    and spheres exactly, other shapes by their bounding sphere)."""
    m = model
    scratch = mujoco.MjData(m)
    scratch.qpos[:] = qpos
    mujoco.mj_kinematics(m, scratch)
    n, p0 = normal, origin
    lowest = math.inf
    for gid in np.flatnonzero(np.isin(m.geom_bodyid, bodies)):
        c = scratch.geom_xpos[gid]
        R = scratch.geom_xmat[gid].reshape(3, 3)
        s = m.geom_size[gid]
        t = m.geom_type[gid]
        if t == _GEOM_BOX:
            dist = (c - p0) @ n - np.abs(R.T @ n) @ s
        elif t == _GEOM_CAPSULE:
            dist = (c - p0) @ n - abs(R[:, 2] @ n) * s[1] - s[0]
        elif t == _GEOM_SPHERE:
            dist = (c - p0) @ n - s[0]
        else:
            dist = (c - p0) @ n - m.geom_rbound[gid]
        lowest = min(lowest, float(dist))
    return lowest


@dataclass(frozen=True)
class Kinematics:
    """World frames of a pose (the arrays of :class:`~mjchar.controllers.core.character.state.
    State`, for a pose that need not be the current one).

    Attributes:
        body_positions: ``(nbody, 3)`` body origins (m).
        body_rotations: ``(nbody, 3, 3)`` body rotation matrices.
        joint_axes: ``(njnt, 3)`` joint axes (unit).
        joint_anchors: ``(njnt, 3)`` joint anchors (m).
        site_positions: ``(nsite, 3)`` sites (m).
    """

    body_positions: np.ndarray
    body_rotations: np.ndarray
    joint_axes: np.ndarray
    joint_anchors: np.ndarray
    site_positions: np.ndarray


class Poses:
    """Kinematics on poses of one character (built by the Character; see the module docstring).

    Args:
        model: the character's model.
        root_qpos: ``(7,)`` qpos indices of the root's free joint.
        bodies: ``(k,)`` ids of the character's bodies (the root's subtree).
        body_id: the Character's body lookup (name -> id).
        role: the Character's role lookup (role -> joint name).
    """

    def __init__(self, model: mujoco.MjModel, root_qpos: np.ndarray, bodies: np.ndarray,
                 body_id: Callable[[str], int], role: Callable[[str], str]):
        self._model = model
        self._nq = int(model.nq)
        self._root_z = int(root_qpos[2])
        self._bodies = bodies
        self._body_id = body_id
        self._role = role
        self._scratch: mujoco.MjData | None = None  # made at the first query that needs one
        self._shapes = _GeomsByShape(model, bodies)

    def _scratch_data(self) -> mujoco.MjData:
        """The scratch ``MjData`` the pose queries compute kinematics in (one per character:
        ``mj_kinematics`` reads only ``qpos`` and the model, so what it held before is
        irrelevant)."""
        if self._scratch is None:
            self._scratch = mujoco.MjData(self._model)
        return self._scratch

    def _qpos(self, qpos) -> np.ndarray:
        return as_vector(qpos, self._nq, "qpos")

    def _body(self, body: str | int) -> int:
        return self._body_id(body) if isinstance(body, str) else int(body)

    def rest(self) -> np.ndarray:
        """``(nq,)`` the model's rest pose ``qpos0`` (every joint at zero; a copy)."""
        return self._model.qpos0.copy()

    def standing(self) -> np.ndarray:
        """``(nq,)`` the rest pose with its lowest point on the floor z = 0 (:meth:`on_floor`)."""
        return self.on_floor(self._model.qpos0)

    def body_offset(self, body: str | int) -> np.ndarray:
        """``(3,)`` position (m) of ``body``'s origin (name or id) in its parent body's frame:
        the model's constant ``body_pos``, the same in every pose (a bone: the offset of a BVH
        joint from its parent; a copy)."""
        return self._model.body_pos[self._body(body)].copy()

    def site_offset(self, site: int) -> tuple[int, np.ndarray]:
        """The body (id) that site id ``site`` is attached to, and the site's position ``(3,)``
        (m) in that body's frame: the model's constants ``site_bodyid``, ``site_pos`` (a
        copy)."""
        m = self._model
        return int(m.site_bodyid[site]), m.site_pos[site].copy()

    def dof_limits(self, dofs: np.ndarray) -> np.ndarray:
        """``(k, 2)`` lower and upper limits (rad, or m on slides) of the joints of hinge or slide
        dofs ``dofs`` ``(k,)`` (the model's joint ``range``)."""
        m = self._model
        return m.jnt_range[m.dof_jntid[dofs]]

    def leg_length(self) -> float:
        """The leg length (m): the hips' mean height over the character's lowest point at rest
        (``qpos0``, every joint at zero). Walkers scale their gaits and speeds with it (equal
        Froude speed ``v / sqrt(g L)`` on every body)."""
        q = self._model.qpos0
        hips = [body_pose(self._model, q, self._body_id(self._role(f"{side}_hip")))[0][2]
                for side in ("left", "right")]
        return float(np.mean(hips)) - self.lowest_point(q)

    def lowest_point(self, qpos: np.ndarray) -> float:
        """Lowest world z (m) of the character's geoms at pose ``qpos`` ``(nq,)`` (boxes,
        capsules, spheres exactly; other shapes by their bounding sphere)."""
        return lowest_point(self._model, self._qpos(qpos), self._bodies,
                            scratch=self._scratch_data(), shapes=self._shapes)

    def clearance(self, qpos: np.ndarray, normal: np.ndarray, origin: np.ndarray) -> float:
        """Lowest signed distance (m) of the character's geoms at pose ``qpos`` ``(nq,)`` from
        the plane through ``origin`` ``(3,)`` with unit ``normal`` ``(3,)`` (a tilted floor:
        ``character.contacts.floor_normal()``, ``floor_origin()``)."""
        return plane_clearance(self._model, self._qpos(qpos), self._bodies, normal, origin)

    def on_floor(self, qpos: np.ndarray, clearance: float = 0.0) -> np.ndarray:
        """``(nq,)`` copy of ``qpos`` with the root raised/lowered so the lowest geom point is
        ``clearance`` m above the floor z = 0."""
        q = np.array(self._qpos(qpos))
        q[self._root_z] += clearance - self.lowest_point(q)
        return q

    def body_pose(self, qpos: np.ndarray, body: str | int) -> tuple[np.ndarray, np.ndarray]:
        """World position ``(3,)`` and wxyz orientation ``(4,)`` of ``body`` (name or id) at pose
        ``qpos`` ``(nq,)``."""
        return body_pose(self._model, self._qpos(qpos), self._body(body))

    def kinematics(self, qpos: np.ndarray) -> Kinematics:
        """The world frames of every body, joint and site at pose ``qpos`` ``(nq,)``
        (``mj_kinematics``)."""
        m = self._model
        sd = mujoco.MjData(m)
        sd.qpos[:] = self._qpos(qpos)
        mujoco.mj_kinematics(m, sd)
        return Kinematics(sd.xpos.copy(), sd.xmat.reshape(-1, 3, 3).copy(), sd.xaxis.copy(),
                          sd.xanchor.copy(), sd.site_xpos.copy())

    def solve_ik(self, qpos: np.ndarray, targets: list, dofs: np.ndarray, *,
                 iterations: int = 100, damping: float = 1e-3, tol: float = 1e-11) -> np.ndarray:
        """Damped least-squares IK (:func:`solve_ik` with body names resolved).

        Args:
            qpos: ``(nq,)`` starting pose.
            targets: list of ``(body, position, quat)``: a body name or id, its world origin
                target ``(3,)`` m (or ``None``) and world orientation target ``(4,)`` wxyz (or
                ``None``).
            dofs: ``(k,)`` dof indices allowed to move.
            iterations, damping, tol: DLS iterations, damping (m), squared-error tolerance.
        Returns:
            ``(nq,)`` the solved pose.
        """
        ids = [(self._body(b), pos, quat) for b, pos, quat in targets]
        return solve_ik(self._model, self._qpos(qpos), ids, dofs, iterations=iterations,
                        damping=damping, tol=tol)
