"""Foot points of a converted model: where a reference motion looks for its feet.

:class:`_FootPoints` picks, per side, the geoms of the ankle and toe bodies' subtrees (boxes when
there are any), else the ``left_foot``/``right_foot``/``*_toe`` sites, else (no feet known) every
non-plane geom of the character, and samples points bounding them from below in world coordinates
(box corners, capsule and cylinder ends minus the radius, sphere centres minus the radius).
:class:`mjchar.bvh.reference.reference_motion.ReferenceMotion` uses them to place the clip on the
floor (``z = 0``) and to label foot contacts.
"""

from __future__ import annotations

import mujoco
import numpy as np

from mjchar.bvh.reference.joint_map import _subtree_bodies

FOOT_SIDES = ("left", "right")

# MuJoCo enum values as plain ints (numpy ints and pybind enums do not compare inside ``in``)
_PLANE, _SPHERE, _CAPSULE, _ELLIPSOID, _CYLINDER, _BOX = (
    int(mujoco.mjtGeom.mjGEOM_PLANE), int(mujoco.mjtGeom.mjGEOM_SPHERE),
    int(mujoco.mjtGeom.mjGEOM_CAPSULE), int(mujoco.mjtGeom.mjGEOM_ELLIPSOID),
    int(mujoco.mjtGeom.mjGEOM_CYLINDER), int(mujoco.mjtGeom.mjGEOM_BOX))


def _geom_local_points(model: mujoco.MjModel, g: int) -> np.ndarray:
    """``(P, 3)`` points in the geom frame whose lowest one bounds the geom from below (corners
    of a box; ends of a capsule/cylinder; centre of a sphere), radius handled by the caller."""
    s = model.geom_size[g]
    t = int(model.geom_type[g])
    if t in (_BOX, _ELLIPSOID):
        sign = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)], float)
        return sign * s
    if t in (_CAPSULE, _CYLINDER):
        return np.array([[0.0, 0.0, -s[1]], [0.0, 0.0, s[1]]])
    return np.zeros((1, 3))


def _geom_drop(model: mujoco.MjModel, g: int) -> float:
    """How far below its points the geom reaches (the radius of round geoms)."""
    t = int(model.geom_type[g])
    if t in (_CAPSULE, _SPHERE, _CYLINDER):
        return float(model.geom_size[g][0])
    if t in (_BOX, _ELLIPSOID):
        return 0.0
    return float(model.geom_rbound[g])


class _FootPoints:
    """Where to look for the feet: geoms (per side) or sites, as points sampled per frame."""

    def __init__(self, model: mujoco.MjModel, info):
        self.sides: dict[str, list[tuple[str, int]]] = {}
        roles = dict(getattr(info, "roles", {}) or {})
        for side in FOOT_SIDES:
            items: list[tuple[str, int]] = []
            for role in (f"{side}_ankle", f"{side}_toe"):
                joint = roles.get(role)
                if isinstance(joint, str) and joint in info.joints:
                    b = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, info.joints[joint].body)
                    if b < 0:
                        continue
                    for bb in _subtree_bodies(model, b):
                        for g in np.flatnonzero(model.geom_bodyid == bb):
                            if int(model.geom_type[g]) != _PLANE and \
                                    ("geom", int(g)) not in items:
                                items.append(("geom", int(g)))
            boxes = [it for it in items if int(model.geom_type[it[1]]) == _BOX]
            items = boxes or items
            if not items:
                for sname in (f"{side}_foot", f"{side}_toe"):
                    s = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, sname)
                    if s >= 0:
                        items.append(("site", int(s)))
            if items:
                self.sides[side] = items
        self.fallback: list[tuple[str, int]] = []
        if not self.sides:  # no feet known: every non-plane geom bounds the character from below
            self.fallback = [("geom", int(g)) for g in range(model.ngeom)
                             if int(model.geom_type[g]) != _PLANE
                             and model.geom_bodyid[g] != 0]
        self._local = {}
        for items in [*self.sides.values(), self.fallback]:
            for kind, i in items:
                if kind == "geom":
                    self._local[i] = (_geom_local_points(model, i), _geom_drop(model, i))

    def sample(self, data: mujoco.MjData, items) -> np.ndarray:
        """``(P, 3)`` world points of ``items`` in the current ``data`` kinematics."""
        pts = []
        for kind, i in items:
            if kind == "site":
                pts.append(data.site_xpos[i][None].copy())
            else:
                loc, drop = self._local[i]
                p = data.geom_xpos[i] + loc @ data.geom_xmat[i].reshape(3, 3).T
                p[:, 2] -= drop
                pts.append(p)
        return np.concatenate(pts) if pts else np.zeros((0, 3))


def foot_contact(points: np.ndarray, frame_time: float, height: float, speed: float,
                 velocity: np.ndarray | None = None) -> np.ndarray:
    """``(F,)`` bool: frames where one of a foot's points ``(F, P, 3)`` (z up, floor at 0) is
    below ``height`` metres and moves slower than ``speed`` m/s (3-D; ``velocity`` ``(F, P, 3)``
    when the caller has it, else central differences). Speed does most of the work: a swing foot
    moves at metres per second, a stance foot's contact points barely move; the height bound is
    generous because mocap feet are rarely level with the floor all through stance."""
    if velocity is None:
        velocity = (np.gradient(points, frame_time, axis=0) if len(points) > 1
                    else np.zeros_like(points))
    return np.any((points[..., 2] < height)
                  & (np.linalg.norm(velocity, axis=-1) < speed), axis=1)


#: a foot supports the body in a frame when one of its points is within this fraction of the
#: clip's mean root height above the clip's floor (the shared walks' stance feet sit up to 9 cm
#: above it: the take's floor is not the clip's lowest point) ...
CONTACT_HEIGHT = 0.12
#: ... and moves slower than this fraction of sqrt(g x mean root height) (Froude-scaled, so one
#: rule serves a child and a tall adult: about 0.75 m/s for a 0.93 m root height)
CONTACT_SPEED = 0.25


def contact_grounding(feet: dict[str, np.ndarray], frame_time: float,
                      root_height: float) -> tuple[np.ndarray, np.ndarray]:
    """Per-frame vertical shifts that put a supporting foot on the floor.

    Mocap stance feet float centimetres above the floor (marker offsets, a floor fitted to the
    whole take, feet that sink through stance), which a physical foot cannot do. A frame where
    some foot supports the body (:func:`foot_contact` with :data:`CONTACT_HEIGHT` x
    ``root_height`` and :data:`CONTACT_SPEED` x ``sqrt(g root_height)``) is shifted so that its
    lowest foot point is on the clip's floor (as ``floor="frame"``); a frame where no foot
    supports (the flight of a run or a jump) takes the shift interpolated linearly from the
    supported frames around it, so flight keeps its height above the floor, but never so much
    that a foot goes below the floor. A hop lower than the height bound counts as support.

    Args:
        feet: foot points per side ``(F, P, 3)`` (metres, z up) in the clip's placement.
        frame_time: seconds per frame.
        root_height: the clip's mean root height above its floor (metres): the length scale.

    Returns:
        ``grounding`` ``(F,)`` metres to add to each frame's heights (``<= 0``; all zero when no
        frame is supported) and ``support`` ``(F,)`` bool, the supported frames.
    """
    sides = [p for p in feet.values() if p.size]
    if not sides:
        raise ValueError("contact grounding needs foot points")
    floor = min(float(np.min(p[..., 2])) for p in sides)
    lift = np.array([0.0, 0.0, floor])
    support = np.any([foot_contact(p - lift, frame_time, CONTACT_HEIGHT * root_height,
                                   CONTACT_SPEED * np.sqrt(9.81 * root_height))
                      for p in sides], axis=0)
    frame = floor - np.min([np.min(p[..., 2], axis=1) for p in sides], axis=0)  # floor="frame"
    if not support.any():
        return np.zeros(len(frame)), support
    idx = np.flatnonzero(support)
    grounding = np.maximum(np.interp(np.arange(len(frame)), idx, frame[idx]), frame)
    return grounding, support
