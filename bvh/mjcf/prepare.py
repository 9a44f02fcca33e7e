"""The converter's step 0: a real export made into a standing rig in world axes.

:func:`prepare` takes the file's clip (or bare skeleton) and, without moving any joint
(:mod:`mjchar.bvh.rigs.layouts`):

1. **folds a static chain above the pelvis** (``Reference``, ``root``, ``joint_Root``: every
   joint above the joint where the legs part has a single child): the pelvis becomes the root
   and carries its global transform per frame; a constant rotation of the chain (a Z-up
   armature under a Y-up world) is folded into the rest pose;
2. **takes bones from translation channels** of non-root joints: the mean over the clip is the
   bone; a joint whose translation varies more than :data:`BONE_TOLERANCE_M` is named in a
   warning with its variation in mm;
3. **re-rests a rig whose rest pose is not a standing figure** (offsets along each bone's local
   X axis, as game engines export: legs not parallel, or the trunk not opposite the legs): the
   rest becomes the clip's frame with the straightest legs, turned to face along file axes,
   with each leg straightened to hang below its hip and each foot as in its flattest stance;
4. **guesses the unit and up axis from anatomy** (unless given): up is the file axis along the
   legs (hip above ankle), the unit the one that makes the figure nearest 1.6 m tall (in log scale),
   the height measured along up, or from the leg bones (hip to ankle = 0.49 of the stature)
   when the rest pose is not standing straight;
5. **recognises the roles** with that up axis and the user's role map, and checks the
   essential ones (pelvis, hips, knees, ankles): one :class:`ConversionError` that lists what is
   missing and shows how to map it.

What was done is kept in the model's metadata as ``rig``
(:func:`mjchar.bvh.rigs.layouts.apply_record`), so
:class:`mjchar.bvh.reference.reference_motion.ReferenceMotion` replays the file's own clip through
the same steps.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from mjchar.bvh.io.motion import Motion
from mjchar.bvh.io.skeleton import Skeleton
from mjchar.bvh.kinematics.fk import forward_kinematics
from mjchar.bvh.mjcf.info import ConversionError
from mjchar.bvh.mjcf.roles import ESSENTIAL_ROLES, check_roles, missing_roles_error
from mjchar.bvh.rigs.layouts import (
    bones_from_channels,
    fold_record,
    fold_root,
    rerest,
    static_chain_above,
)
from mjchar.bvh.rigs.naming import Recognition, recognise
from mjchar.bvh.rigs.units import AXIS_VECTORS, guess_up_axis, unit_for_height
from mjchar.bvh.rotations import from_rotation, quat_conj, quat_mul

#: metres: a non-root translation channel varying more than this from its mean is warned about
BONE_TOLERANCE_M = 0.001
#: the largest extent (m) of a rest pose the converter builds a body from
MAX_SPAN_M = 100.0
#: hip-to-ankle length (thigh + shank bones) as a fraction of the standing height
LEG_FRACTION = 0.49
#: degrees: leg bones within this of their mean direction count as a standing leg
STRAIGHT_LEG_DEG = 35.0


@dataclass
class Prepared:
    """A rig ready for conversion (see the module docstring).

    Attributes:
        motion: the normalised clip (file units and axes), or ``None`` for a bare skeleton.
        skeleton: the normalised skeleton.
        scale: metres per file unit; ``up``: the file's up axis.
        rec: the roles.
        record: the ``rig`` metadata (``{}`` when the file needed nothing).
        warnings: what was done and what looks wrong.
    """

    motion: Motion | None
    skeleton: Skeleton
    scale: float
    up: str
    rec: Recognition
    record: dict = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)


def prepare(motion: Motion | None, skeleton: Skeleton, unit: float | None = None,
            up_axis: str | None = None, roles: dict | None = None) -> Prepared:
    """Normalise a rig for conversion (steps 1-5 of the module docstring)."""
    roles = roles or {}
    check_roles(roles, skeleton.names, "the roles file")
    has_motion = motion is not None and motion.n_frames > 0
    work = motion if has_motion else Motion.rest(skeleton)
    warns: list[str] = []
    record: dict = {}
    up0 = AXIS_VECTORS[up_axis or guess_up_axis(work.skeleton)]

    # 1. a static chain above the pelvis
    rec = recognise(work.skeleton, up0, roles)
    pelvis = rec.roles.get("pelvis")
    k = work.skeleton.index(pelvis) if isinstance(pelvis, str) else 0
    if k > 0 and static_chain_above(work.skeleton, k):
        fr = fold_record(work, k)
        fr["fold_pose"] = {work.skeleton.names[j]: {
            "position": [float(x) for x in work.local_positions[0, j]],
            "rotation": [float(x) for x in work.rotations[0, j]]} for j in range(k)}
        record.update(fr)
        work = fold_root(work, k)
        if fr["fold_rotation"] is not None:
            q = np.asarray(fr["fold_rotation"])
            work = rerest(work, np.tile(q, (work.skeleton.n_joints, 1)))
        warns.append(f"joints above the pelvis folded into the root {work.skeleton.names[0]!r}: "
                     + ", ".join(fr["fold"])
                     + (" (with their constant rotation)" if fr["fold_rotation"] else ""))

    # 2. bones from translation channels
    variation: dict[str, float] = {}
    if any(work.skeleton.has_position_channels()[1:]):
        work, variation = bones_from_channels(work)
        record["bones"] = True

    # 3. a rest pose that is not a standing figure
    rec = recognise(work.skeleton, up0, roles)
    if not _standing(work.skeleton, rec):
        if has_motion:
            f, rest_q, up_w = _rest_from_clip(work, rec)
            work = rerest(work, rest_q)
            record["rest"] = {n: [float(x) for x in q]
                              for n, q in zip(work.skeleton.names, rest_q, strict=True)}
            warns.append(f"the rest pose is not a standing figure (bones along local axes?): the "
                         f"rest is the clip's frame {f} (legs straightest), turned to face along "
                         f"the file's axes")
        else:
            warns.append("the rest pose is not a standing figure and there is no clip to take "
                         "one from: the model may be unusable")

    # 4. unit and up axis from anatomy
    sk = work.skeleton
    rec = recognise(sk, up0, roles)
    up = up_axis or _up_from_legs(sk, rec) or guess_up_axis(sk)
    rec = recognise(sk, AXIS_VECTORS[up], roles)
    scale = float(unit) if unit is not None else _unit_from_anatomy(sk, rec, up)
    points = np.vstack([sk.rest_positions(), sk.rest_end_sites().reshape(-1, 3)])
    span = float((points.max(axis=0) - points.min(axis=0)).max()) * scale
    if span > MAX_SPAN_M:
        raise ConversionError(f"the skeleton spans {span:.3g} m at {scale:g} m per unit: not a "
                              f"body (at most {MAX_SPAN_M:g} m; check the OFFSETs or --unit)")
    noisy = {n: v * scale * 1000.0 for n, v in variation.items() if v * scale > BONE_TOLERANCE_M}
    if noisy:
        warns.append("translation channels vary (the mean is the bone): "
                     + ", ".join(f"{n} by {v:.1f} mm" for n, v in noisy.items()))

    # 5. essential roles
    missing = [r for r in ESSENTIAL_ROLES if r not in rec.roles]
    if missing:
        legs = [r for r in missing if r != "pelvis"]
        problem = rec.problem
        if problem is None and len(legs) == 6:
            problem = "no legs: no knee names and no two limb chains reaching the floor"
        elif problem is None and len(legs) == 3:
            problem = "one leg only"
        raise missing_roles_error(missing, skeleton.names, rec.roles, problem)
    return Prepared(work if has_motion else None, sk, scale, up, rec, record, warns)


# ------------------------------------------------------------------------------------------------
# helpers
# ------------------------------------------------------------------------------------------------
def _leg_joints(sk: Skeleton, rec: Recognition) -> list[tuple[int, int, int]] | None:
    out = []
    for s in ("left", "right"):
        names = [rec.roles.get(f"{s}_{r}") for r in ("hip", "knee", "ankle")]
        if not all(isinstance(n, str) for n in names):
            return None
        out.append(tuple(sk.index(n) for n in names))
    return out


def _standing(sk: Skeleton, rec: Recognition) -> bool:
    """The rest pose looks like a standing figure: the four leg bones nearly parallel, and the
    head (or the highest trunk joint) on the other side of the pelvis. True when unknown."""
    legs = _leg_joints(sk, rec)
    if legs is None:
        return True
    rest = sk.rest_positions()
    dirs = []
    for h, k, a in legs:
        for u, v in ((h, k), (k, a)):
            d = rest[v] - rest[u]
            if np.linalg.norm(d) > 1e-9:
                dirs.append(d / np.linalg.norm(d))
    if len(dirs) < 2:
        return True
    m = np.mean(dirs, axis=0)
    if np.linalg.norm(m) < 1e-9:
        return False
    m /= np.linalg.norm(m)
    if min(float(d @ m) for d in dirs) < np.cos(np.radians(STRAIGHT_LEG_DEG)):
        return False
    pelvis = sk.index(rec.roles["pelvis"]) if isinstance(rec.roles.get("pelvis"), str) else 0
    top = rec.roles.get("head")
    if not isinstance(top, str):
        spine = rec.roles.get("spine") or []
        top = spine[-1] if spine else None
    if top is None:
        return True
    t = rest[sk.index(top)] - rest[pelvis]
    return bool(np.linalg.norm(t) > 1e-9 and float(t @ m) < -0.5 * np.linalg.norm(t))


def _rest_from_clip(motion: Motion, rec: Recognition) -> tuple[int, np.ndarray, str]:
    """``(frame, rest orientations (J, 4), up)``: the frame whose legs are straightest, its
    global orientations turned about the legs' up so that its left lies along a file axis."""
    sk = motion.skeleton
    fk = forward_kinematics(motion)
    p = fk.positions
    legs = _leg_joints(sk, rec)
    straight = np.zeros(motion.n_frames)
    up_v = np.zeros(3)
    for h, k, a in legs:
        bone = np.linalg.norm(sk.offsets[k]) + np.linalg.norm(sk.offsets[a])
        straight += np.linalg.norm(p[:, a] - p[:, h], axis=1) / max(bone, 1e-12)
    f = int(np.argmax(straight))
    for h, _, a in legs:
        up_v += p[f, h] - p[f, a]
    i = int(np.argmax(np.abs(up_v)))
    up = "xyz"[i]
    u = np.sign(up_v[i]) * AXIS_VECTORS[up]
    left = p[f, legs[0][0]] - p[f, legs[1][0]]
    left = left - (left @ u) * u
    cands = [s * AXIS_VECTORS[a] for a in "xyz" if a != up for s in (1.0, -1.0)]
    target = max(cands, key=lambda c: float(c @ left))
    ang = np.arctan2(float(np.cross(left, target) @ u), float(left @ target))
    from scipy.spatial.transform import Rotation

    turn = from_rotation(Rotation.from_rotvec(ang * u))  # takes the pose's left to the axis
    rest = _stand_legs(sk, fk, f, legs, u, quat_conj(turn))
    return f, rest, up


def _yaw_between(a: np.ndarray, b: np.ndarray, u: np.ndarray):
    """Rotation about ``u`` taking the horizontal part of ``a`` to that of ``b``."""
    from scipy.spatial.transform import Rotation

    a = a - (a @ u) * u
    b = b - (b @ u) * u
    ang = np.arctan2(float(np.cross(a, b) @ u), float(a @ b))
    return Rotation.from_rotvec(ang * u)


def _stand_legs(sk: Skeleton, fk, f: int, legs, u: np.ndarray, turn: np.ndarray) -> np.ndarray:
    """Rest orientations ``(J, 4)``: frame ``f``'s pose turned by ``turn``, with each leg made a
    standing leg: thigh and shank straight down (the least rotation of each), the foot and the
    joints below it as in that foot's flattest stance of the clip (its ankle's lowest frame),
    turned about ``u`` from that frame's facing to the rest's. A walking frame has one foot ahead
    of the other and the feet near the midline; this stands the figure on its hips' width."""
    from scipy.spatial.transform import Rotation

    def R(q: np.ndarray) -> Rotation:
        return Rotation.from_quat(np.reshape(q, 4), scalar_first=True)

    p, g = fk.positions, fk.orientations
    rest = quat_mul(np.reshape(turn, (1, 4)), g[f])
    rot = R(turn)

    def left(frame: int) -> np.ndarray:
        return p[frame, legs[0][0]] - p[frame, legs[1][0]]

    left_rest = rot.apply(left(f))
    for h, k, a in legs:
        for j, c in ((h, k), (k, a)):  # the bone from j to its leg child c points down
            d = R(rest[j]).apply(sk.offsets[c])
            n = np.linalg.norm(d)
            if n < 1e-12:
                continue
            r, _ = Rotation.align_vectors([-u], [d / n])
            rest[j] = from_rotation(r * R(rest[j]))
        ff = int(np.argmin(p[:, a] @ u))  # the ankle's lowest frame: the foot flat in stance
        yaw = _yaw_between(left(ff), left_rest, u)
        for j in _subtree(sk, a):
            rest[j] = from_rotation(yaw * R(g[ff, j]))
    return rest


def _subtree(sk: Skeleton, j: int) -> list[int]:
    out, todo = [], [j]
    while todo:
        i = todo.pop()
        out.append(i)
        todo += sk.children(i)
    return out


def _up_from_legs(sk: Skeleton, rec: Recognition) -> str | None:
    """The file axis along the legs (hip minus ankle), when the legs are recognised."""
    legs = _leg_joints(sk, rec)
    if legs is None:
        return None
    rest = sk.rest_positions()
    v = sum(rest[h] - rest[a] for h, _, a in legs)
    n = np.linalg.norm(v)
    if n < 1e-12 or np.max(np.abs(v)) < 0.8 * n:
        return None
    return "xyz"[int(np.argmax(np.abs(v)))]


def _unit_from_anatomy(sk: Skeleton, rec: Recognition, up: str) -> float:
    """Metres per unit: the height along ``up`` (or from the leg bones when the rest pose is
    not standing straight) made nearest 1.6 m."""
    pts = sk.rest_positions()
    if sk.n_end_sites:
        pts = np.concatenate([pts, sk.rest_end_sites()])
    i = "xyz".index(up)
    extent = float(pts[:, i].max() - pts[:, i].min())
    legs = _leg_joints(sk, rec)
    if legs is not None:
        leg = np.mean([np.linalg.norm(sk.offsets[k]) + np.linalg.norm(sk.offsets[a])
                       for _, k, a in legs])
        from_legs = leg / LEG_FRACTION
        if from_legs > 0 and not (0.75 < extent / from_legs < 1.35):
            extent = from_legs
    if extent <= 0:
        raise ConversionError("cannot guess the unit: the skeleton has no height; pass --unit")
    return unit_for_height(extent)
