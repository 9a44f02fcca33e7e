"""The converter's dynamics (steps 4-6): body masses, joints and actuators.

- :func:`_masses`: de Leva (1996) segment mass fractions per role group, split inside a group by
  geometric volume; bodies of unknown role weigh by volume at water density; the whole sums to
  the requested mass (kg) exactly.
- :func:`_joints`: free root; hinge triplets (Euler order per role, or the order whose middle
  angle stays smallest over the clip for unknown joints), single flexion hinges for knees and
  elbows, or balls; anatomical ranges (degrees) in the ``hinge`` model, none in ``full``.
- :func:`_actuators`: a ``<position>`` actuator per hinge with gains per role scaled by the
  subtree mass they move (N m/rad, N m s/rad, N m), ``<motor>`` triplets for balls; user
  overrides by joint name, role or base role.

Part of :func:`mjchar.bvh.mjcf.convert`.
"""

from __future__ import annotations

import warnings as _warnings

import numpy as np
from scipy.spatial.transform import Rotation

from mjchar.bvh.io.motion import Motion
from mjchar.bvh.io.skeleton import Skeleton
from mjchar.bvh.kinematics.fk import forward_kinematics
from mjchar.bvh.mjcf import tables as T
from mjchar.bvh.mjcf.info import ConversionError
from mjchar.bvh.mjcf.layout import _Body
from mjchar.bvh.rotations import from_rotation, quat_conj, quat_mul, quat_to_rotvec, to_rotation


# ------------------------------------------------------------------------------------------------
# 4. masses
# ------------------------------------------------------------------------------------------------
def _masses(bodies: dict[int, _Body], total: float) -> None:
    """Body and geom masses summing to ``total`` kg (see the module docstring)."""
    min_mass = 1e-3 * total
    vols = {j: b.volume for j, b in bodies.items()}
    all_vol = sum(vols.values())
    fixed = 0.0
    groups: dict[tuple[str, str | None], list[int]] = {}
    for j, b in bodies.items():
        if vols[j] <= 0:
            b.mass = min_mass
            fixed += min_mass
            continue
        g = T.ROLE_GROUP.get(b.base)
        if g is None:
            b.mass = T.DENSITY * vols[j] * total / max(T.DENSITY * all_vol, 1e-12)
            fixed += b.mass
            continue
        side = b.side if g not in ("trunk", "head_neck") else None
        groups.setdefault((g, side), []).append(j)
    remaining = total - fixed
    if remaining <= 0:
        raise ConversionError("the bodies of unknown role leave no mass for the recognised ones")
    frac = {k: T.GROUP_FRACTION[k[0]] for k in groups}
    f_sum = sum(frac.values())
    for key, members in groups.items():
        m_group = remaining * frac[key] / f_sum
        if key[0] == "trunk":
            fixed_share = {j: T.TRUNK_SHARE[bodies[j].base] for j in members
                           if bodies[j].base in T.TRUNK_SHARE}
            spine = [j for j in members if j not in fixed_share]
            share_total = T.GROUP_FRACTION["trunk"]
            if not spine:  # no spine bodies: the fixed shares take all of the trunk
                share_total = sum(fixed_share.values())
            for j, sh in fixed_share.items():
                bodies[j].mass = m_group * sh / share_total
            rest = m_group - sum(bodies[j].mass for j in fixed_share)
            v = sum(vols[j] for j in spine)
            for j in spine:
                bodies[j].mass = rest * vols[j] / v
        else:
            v = sum(vols[j] for j in members)
            for j in members:
                bodies[j].mass = m_group * vols[j] / v
    for j, b in bodies.items():
        if vols[j] > 0:
            for g in b.geoms:
                g.mass = b.mass * g.volume / vols[j]


# ------------------------------------------------------------------------------------------------
# 5. joints
# ------------------------------------------------------------------------------------------------
def _flexion_axis(b: _Body, bodies: dict[int, _Body]) -> tuple[str, float]:
    """(world axis name, sign) of the flexion hinge of a knee or an elbow.

    Knee flexion moves the shank backward (-x), elbow flexion moves the forearm forward (+x): the
    rotation axis is ``e x flex_dir`` for the distal segment direction ``e``, snapped to the
    nearest world axis; ``sign`` is +1 when flexion is a positive rotation about that axis.
    """
    kids = [bodies[c].pos for c in b.children]
    ends = [g.b for g in b.geoms if g.kind == "capsule"]
    tip = kids[0] if kids else (ends[0] if ends else None)
    flex_dir = np.array([-1.0, 0.0, 0.0]) if b.base == "knee" else np.array([1.0, 0.0, 0.0])
    if tip is not None and np.linalg.norm(tip - b.pos) > 1e-9:
        e = (tip - b.pos) / np.linalg.norm(tip - b.pos)
        a = np.cross(e, flex_dir)
        if np.linalg.norm(a) > 0.3:
            i = int(np.argmax(np.abs(a)))
            return "xyz"[i], float(np.sign(a[i]))
    return ("y", 1.0) if b.base == "knee" else ("z", -1.0 if b.side == "left" else 1.0)


#: degrees: a flexion axis found from the clip within this of a world axis is snapped to it
SNAP_AXIS_DEG = 25.0
#: degrees: a clip whose knee or elbow turns less than this says nothing about its axis
MIN_FLEXION_DEG = 5.0


def _snap_axis(a: np.ndarray) -> tuple[str, float, np.ndarray]:
    """``(axis name, sign, unit vector)`` of the unit axis ``a``: the nearest world axis names
    it; within :data:`SNAP_AXIS_DEG` of that axis the vector becomes the axis itself."""
    i = int(np.argmax(np.abs(a)))
    if abs(a[i]) >= np.cos(np.radians(SNAP_AXIS_DEG)):
        e = np.zeros(3)
        e[i] = np.sign(a[i])
        a = e
    return "xyz"[i], float(np.sign(a[i])), a


def _distal_bone(b: _Body, bodies: dict[int, _Body]) -> np.ndarray | None:
    """``(3,)`` unit vector along the bone below a knee or an elbow at rest (MuJoCo axes), or
    ``None`` when it has no length."""
    kids = [bodies[c].pos for c in b.children]
    ends = [g.b for g in b.geoms if g.kind == "capsule"]
    tip = kids[0] if kids else (ends[0] if ends else None)
    if tip is None or np.linalg.norm(tip - b.pos) < 1e-9:
        return None
    return (tip - b.pos) / np.linalg.norm(tip - b.pos)


def _flexion_from_clip(b: _Body, rotvec: np.ndarray,
                       bone: np.ndarray | None = None) -> tuple[str, float, np.ndarray] | None:
    """(nearest world axis, sign, exact unit axis) of a knee's or elbow's flexion hinge from
    how it turns in the clip: ``rotvec`` ``(F, 3)`` are its local rotations (relative to its
    parent body, MuJoCo axes) as rotation vectors; ``bone`` ``(3,)`` the distal bone's rest
    direction. The axis is fitted on the flexion, not the twist: each frame's rotation is
    reduced to its swing, the least rotation taking the bone where the frame puts it (a knee
    that twists while it bends moves its shank only by the swing), and the axis is the principal
    direction of the swing vectors (angle-weighted), signed so that the clip's mean angle about
    it is positive (a knee or an elbow bends one way: that way is flexion). Without a bone the
    whole rotation vectors are used. ``None`` when it hardly turns."""
    if bone is not None:
        moved = Rotation.from_rotvec(rotvec).apply(bone)
        axis = np.cross(bone, moved)
        s = np.linalg.norm(axis, axis=1, keepdims=True)
        angle = np.arctan2(s, (moved @ bone)[:, None])
        rotvec = np.where(s > 1e-12, axis / np.maximum(s, 1e-300) * angle, 0.0)
    ang = np.linalg.norm(rotvec, axis=1)
    if len(rotvec) < 2 or np.degrees(ang.max()) < MIN_FLEXION_DEG:
        return None
    w, v = np.linalg.eigh(rotvec.T @ rotvec)
    a = v[:, int(np.argmax(w))]
    if float(np.mean(rotvec @ a)) < 0:
        a = -a
    return _snap_axis(a)


def _flexion_from_rest(b: _Body, bodies: dict[int, _Body]) -> tuple[str, float, np.ndarray] | None:
    """The flexion axis of a limb already bent at rest (more than 10 degrees): the normal of
    the plane of its two bones, signed so that bending further is positive. ``None`` else."""
    if b.parent < 0 or not b.children:
        return None
    up_bone = b.pos - bodies[b.parent].pos
    low_bone = bodies[b.children[0]].pos - b.pos
    n1, n2 = np.linalg.norm(up_bone), np.linalg.norm(low_bone)
    if n1 < 1e-9 or n2 < 1e-9:
        return None
    a = np.cross(up_bone / n1, low_bone / n2)
    if np.linalg.norm(a) < np.sin(np.radians(10.0)):
        return None
    a /= np.linalg.norm(a)
    return _snap_axis(a)


def _best_order(q_mj: np.ndarray) -> str:
    """Hinge order (of the six Tait-Bryan ones) whose middle angle stays smallest over ``q_mj``."""
    r = to_rotation(q_mj)
    best, best_val = "zyx", np.inf
    with _warnings.catch_warnings():
        _warnings.simplefilter("ignore")
        for order in ("zyx", "yxz", "zxy", "xyz", "xzy", "yzx"):
            mid = float(np.max(np.abs(r.as_euler(order.upper())[:, 1])))
            if mid < best_val - 1e-9:
                best, best_val = order, mid
    return best


def _joints(sk: Skeleton, bodies: dict[int, _Body], joint_model: str, motion: Motion | None,
            B: np.ndarray) -> None:
    basis_r = Rotation.from_matrix(B)
    fk = forward_kinematics(motion) if motion is not None and motion.n_frames > 1 else None
    for j, b in bodies.items():
        if b.parent < 0:
            b.joints = [{"name": "root", "type": "free"}]
            b.order = "free"
            continue
        if not sk.rotation_order(j):
            b.joints, b.order = [], ""
            continue
        role_rng = T.RANGE_DEG.get(b.base, T.RANGE_DEG["unknown"])
        if b.base in ("knee", "elbow") and joint_model in ("hinge", "ball") and b.side:
            found = None
            if fk is not None:
                local = quat_mul(quat_conj(fk.orientations[:, b.parent]), fk.orientations[:, j])
                found = _flexion_from_clip(b, quat_to_rotvec(local) @ B.T,
                                           _distal_bone(b, bodies))
            found = found or _flexion_from_rest(b, bodies)
            if found is not None:
                axis, sign, vec = found
            else:
                axis, sign = _flexion_axis(b, bodies)
                vec = None
            lo, hi = T.FLEXION_RANGE[b.base]
            rng = (lo, hi) if sign > 0 else (-hi, -lo)
            b.joints = [{"name": f"{b.name}_{axis}", "type": "hinge", "axis": axis, "range": rng}]
            if vec is not None and np.count_nonzero(vec) > 1:  # not a world axis: exact vector
                b.joints[0]["vector"] = vec  # flexion is a positive turn about it
                b.joints[0]["range"] = (lo, hi)
            b.order = axis
            continue
        if joint_model == "ball":
            cone = max(max(abs(v) for v in role_rng[a]) for a in "xyz")
            b.joints = [{"name": b.name, "type": "ball", "range": (0.0, min(cone, 180.0))}]
            b.order = "ball"
            continue
        order = T.EULER_ORDER.get(b.base, "zyx")
        if b.base in ("unknown", "end") and motion is not None:
            q = to_rotation(motion.rotations[:, j])
            order = _best_order(from_rotation(basis_r * q * basis_r.inv()))
        b.order = order
        b.joints = []
        for a in order:
            rng = None
            if joint_model == "hinge":
                rng = T.mirrored_range(role_rng[a], a, b.side)
            b.joints.append({"name": f"{b.name}_{a}", "type": "hinge", "axis": a, "range": rng})


# ------------------------------------------------------------------------------------------------
# 6. actuators
# ------------------------------------------------------------------------------------------------
def _subtree_mass(bodies: dict[int, _Body], j: int) -> float:
    b = bodies[j]
    return b.mass + sum(_subtree_mass(bodies, c) for c in b.children)


def _actuators(bodies: dict[int, _Body], joint_model: str, total: float, overrides: dict,
               sk: Skeleton) -> list[dict]:
    used: set[str] = set()
    out = []
    for j, b in bodies.items():
        if not b.joints or b.joints[0]["type"] == "free":
            continue
        m_sub = _subtree_mass(bodies, j)
        if b.base in T.GAINS:
            kp, kd, tau, frac = T.GAINS[b.base]
            f = float(np.clip(m_sub / (frac * total), *T.GAIN_SCALE_BOUNDS))
            f *= total / T.REFERENCE_MASS
            kp, kd, tau = kp * f, kd * f, tau * f
        else:
            kp = float(np.clip(T.UNKNOWN_KP_PER_KG * m_sub, 5.0, 1000.0))
            kd, tau = 0.1 * kp, 0.3 * kp
        arm = T.ARMATURE.get(b.base, T.ARMATURE["unknown"])
        damp = T.DAMPING.get(b.base, T.DAMPING["unknown"])
        gains = {"kp": kp, "kd": kd, "torque": tau, "armature": arm, "damping": damp}
        for key in ("default", b.base, b.role, b.name):
            if key in overrides:
                gains.update(overrides[key])
                used.add(key)
        for jt in b.joints:
            jt["armature"] = gains["armature"]
            jt["damping"] = gains["damping"]
            if jt["type"] == "hinge":
                out.append({"type": "position", "name": jt["name"], "joint": jt["name"],
                            "kp": gains["kp"], "kv": gains["kd"], "torque": gains["torque"]})
            else:
                for i, a in enumerate("xyz"):
                    gear = [0.0, 0.0, 0.0]
                    gear[i] = 1.0
                    out.append({"type": "motor", "name": f"{jt['name']}_{a}", "joint": jt["name"],
                                "gear": gear, "torque": gains["torque"]})
    unused = set(overrides) - used
    if unused:
        raise ConversionError(
            "gains: keys match no kept joint or role: " + ", ".join(sorted(unused))
            + "; use BVH joint names, roles (left_knee) or base roles (knee), or 'default'")
    return out

