"""Motion editing: mirror, retarget between rest poses, align and concatenate clips.

All functions return new :class:`~mjchar.bvh.io.motion.Motion` objects (inputs are never modified)
and are vectorised over frames; loops run over joints only (a few dozen), never over frames.

- :func:`mirror` swaps left and right (joints paired by name, see :func:`mirror_name`) and reflects
  across the sagittal plane.
- :func:`retarget` moves a motion onto another rest pose of the same skeleton (e.g. A-pose data
  onto a T-pose skeleton) keeping every bone's global direction.
- :func:`align` turns and shifts a clip about the up axis; :func:`concatenate` appends one clip to
  another with matched facing and position and a blended transition.
- :func:`match_joint_order` expresses a motion in another skeleton's joint order (same names).
- :func:`make_cyclic` cuts the best-matching cycle out of a clip (a gait cycle of a walk) and
  spreads the remaining mismatch over it, so the cycle repeats seamlessly.
- :func:`leading_jumps` counts the frames a capture starts with that are no part of its motion
  (a zero pose written before the first real frame).
"""

from __future__ import annotations

import re

import numpy as np
from scipy.spatial.transform import Rotation

from mjchar.bvh.editing.interpolation import resample
from mjchar.bvh.errors import SkeletonError, name_list
from mjchar.bvh.io.motion import Motion
from mjchar.bvh.io.skeleton import Skeleton
from mjchar.bvh.rigs.units import guess_up_axis
from mjchar.bvh.rotations import (
    AXES,
    decompose_facing,
    heading_angle,
    quat_conj,
    quat_fix_continuity,
    quat_identity,
    quat_mul,
    quat_normalize,
    quat_rotate,
    quat_slerp,
)

__all__ = [
    "EditingError",
    "mirror_name",
    "mirror_pairs",
    "guess_lateral_axis",
    "mirror",
    "match_joint_order",
    "derive_rest_rotations",
    "retarget",
    "align",
    "concatenate",
    "make_cyclic",
    "leading_jumps",
]


class EditingError(SkeletonError):
    """A motion edit got motions, skeletons or options it cannot work with."""


# -- left/right names --------------------------------------------------------------------------
_SEP = r"[_\-. ]"
# (pattern, is_word): tried in order on the name without its namespace ("mixamorig:")
_SIDE_RULES: list[tuple[re.Pattern[str], bool]] = [
    (re.compile(r"^(?i:left|right)(?=[^a-z]|$)"), True),            # LeftArm, left_arm, LEFTARM
    (re.compile(rf"(?<={_SEP})(?i:left|right)(?={_SEP}|$)"), True),  # arm_left, Bip_Left_Arm
    (re.compile(r"(?<=[a-z0-9])(?:Left|Right|LEFT|RIGHT)$"), True),  # ArmLeft
    (re.compile(r"^[lLrR](?=[A-Z0-9]|" + _SEP + ")"), False),       # lHip, LHip, L_Hip, r.hip
    (re.compile(rf"(?<={_SEP})[lLrR](?={_SEP}|$)"), False),          # hip_l, Hip.R, Bip01 L Thigh
    (re.compile(r"(?<=[a-z])[LR]$"), False),                          # HipL
]


def _swap_side(text: str) -> str:
    if len(text) == 1:
        return {"l": "r", "r": "l", "L": "R", "R": "L"}[text]
    other = "right" if text.lower() == "left" else "left"
    if text.isupper():
        return other.upper()
    return other.capitalize() if text[0].isupper() else other


def _side_candidates(name: str) -> list[tuple[str, bool]]:
    """Mirrored-name candidates of ``name`` in rule order, with whether a side *word* matched."""
    ns, sep, base = name.rpartition(":")
    prefix = ns + sep
    out = []
    for pattern, is_word in _SIDE_RULES:
        m = pattern.search(base)
        if m:
            swapped = base[: m.start()] + _swap_side(m.group(0)) + base[m.end():]
            out.append((prefix + swapped, is_word))
    return out


def mirror_name(name: str, names: list[str] | None = None) -> str | None:
    """The left/right counterpart of joint ``name``, or ``None`` for a centre joint.

    Recognises ``l``/``r`` and ``L``/``R`` prefixes before a capital, digit or separator
    (``lHip``, ``LHip``, ``L_Hip``), ``Left``/``Right`` (any case) as prefix, suffix or a
    separated word (``LeftUpLeg``, ``hip_left``, ``Bip01_Left_Arm``), single-letter suffixes
    (``hip_l``, ``Hip.R``, ``HipL``), and namespaces (``mixamorig:LeftArm``). Separators are
    ``_ - . `` and space. With ``names``, only a counterpart present in ``names`` is returned
    (the first rule whose swap exists), so a name that merely looks sided (``LOWERBACK``) stays
    a centre joint.
    """
    for cand, _ in _side_candidates(name):
        if names is None or cand in names:
            return cand
    return None


def mirror_pairs(skeleton: Skeleton, pairs: dict[str, str] | None = None) -> np.ndarray:
    """``(J,)`` index of each joint's mirror partner (itself for centre joints).

    ``pairs``: optional explicit ``{left_name: right_name}`` entries that override the name rules
    (either direction may be given). Raises :class:`EditingError` when a joint named with a side
    word (``Left``/``Right``) has no partner, or when partners' parents are not partners.
    """
    names = skeleton.names
    explicit: dict[str, str] = {}
    for a, b in (pairs or {}).items():
        for n in (a, b):
            if n not in names:
                raise EditingError(
                    f"pairs names unknown joint {n!r}; joints are: {name_list(names)}")
        explicit[a], explicit[b] = b, a
    partner = np.arange(skeleton.n_joints)
    for j, name in enumerate(names):
        if name in explicit:
            partner[j] = names.index(explicit[name])
            continue
        cands = _side_candidates(name)
        found = next((c for c, _ in cands if c in names), None)
        if found is not None:
            partner[j] = names.index(found)
        elif any(word for _, word in cands):
            raise EditingError(
                f"joint {name!r} is named as a side but no mirrored joint "
                f"({', '.join(c for c, _ in cands)}) exists; pass pairs={{...}} explicitly")
    bad = [names[j] for j in range(len(names)) if partner[partner[j]] != j]
    if bad:
        raise EditingError(
            f"mirror pairing is not symmetric for joints {bad}; pass pairs explicitly")
    par = skeleton.parents
    for j in range(1, len(names)):
        pj, pm = par[j], par[partner[j]]
        if pm < 0 or partner[pj] != pm:
            raise EditingError(
                f"joints {names[j]!r} and {names[partner[j]]!r} are mirror partners but their "
                f"parents {names[pj]!r} and {names[pm] if pm >= 0 else None!r} are not")
    return partner


_LATERAL_HINTS = ("hip", "thigh", "upleg", "shoulder", "arm", "clavicle", "collar")


def guess_lateral_axis(skeleton: Skeleton, pairs: dict[str, str] | None = None) -> str:
    """``"x"``, ``"y"`` or ``"z"``: the axis along which left and right joints differ at rest.

    Uses hip/shoulder-like pairs (names containing hip, thigh, upleg, shoulder, arm, clavicle,
    collar) when there are any, else every left/right pair: the axis with the largest summed
    absolute difference of their rest positions.
    """
    partner = mirror_pairs(skeleton, pairs)
    sided = [j for j in range(skeleton.n_joints) if partner[j] > j]
    if not sided:
        raise EditingError("cannot guess the lateral axis: the skeleton has no left/right joint "
                           "pairs; pass axis= (and pairs= if the names are unusual)")
    hinted = [j for j in sided if any(h in skeleton.names[j].lower() for h in _LATERAL_HINTS)]
    use = np.array(hinted or sided)
    rest = skeleton.rest_positions()
    score = np.abs(rest[use] - rest[partner[use]]).sum(axis=0)
    if score.max() <= 0:
        raise EditingError("cannot guess the lateral axis: left and right joints coincide at rest")
    return "xyz"[int(np.argmax(score))]


def _axis_normal(axis: str | np.ndarray) -> np.ndarray:
    if isinstance(axis, str):
        if axis.lower() not in AXES:
            raise EditingError(f"axis must be 'x', 'y', 'z' or a 3-vector, got {axis!r}")
        return np.eye(3)[AXES[axis.lower()]]
    n = np.asarray(axis, dtype=float).reshape(-1)
    if n.shape != (3,) or not np.all(np.isfinite(n)) or np.linalg.norm(n) < 1e-12:
        raise EditingError(f"axis must be 'x', 'y', 'z' or a non-zero 3-vector, got {axis!r}")
    return n / np.linalg.norm(n)


def _reflect(v: np.ndarray, n: np.ndarray) -> np.ndarray:
    return v - 2.0 * (v @ n)[..., None] * n


def mirror(motion: Motion, axis: str | np.ndarray | None = None,
           pairs: dict[str, str] | None = None) -> Motion:
    """Left/right mirror image of ``motion`` on the same skeleton.

    Reflects across the plane through the origin normal to ``axis`` (``"x"``/``"y"``/``"z"`` or a
    3-vector; ``None`` guesses the lateral axis with :func:`guess_lateral_axis`) and swaps each
    joint's data with its mirror partner (:func:`mirror_pairs`, ``pairs`` overriding names).
    With ``M`` the reflection, joint ``j`` with partner ``m`` gets the local rotation
    ``M r_m M`` (for a quaternion ``(w, v) -> (w, -M v)``) and, if it has position channels,
    the local translation ``M t_m``; other joints keep their own local translations (the bone
    offsets). The result is exact for a skeleton whose rest pose is symmetric about that plane;
    an asymmetric skeleton keeps its own bone offsets. Mirroring twice gives back the input.
    """
    sk = motion.skeleton
    partner = mirror_pairs(sk, pairs)
    n = _axis_normal(guess_lateral_axis(sk, pairs) if axis is None else axis)
    rot = motion.rotations[:, partner]
    rot = np.concatenate([rot[..., :1], -_reflect(rot[..., 1:], n)], axis=-1)
    pos = motion.local_positions.copy()
    chan = sk.has_position_channels()
    chan[0] = True
    pos[:, chan] = _reflect(motion.local_positions[:, partner[chan]], n)
    return Motion(sk, motion.frame_time, pos, rot)


# -- joint order -------------------------------------------------------------------------------
def match_joint_order(motion: Motion, skeleton: Skeleton) -> Motion:
    """``motion`` with its joints reordered to ``skeleton``'s order (joints matched by name).

    Both skeletons must have the same joint names and the same parent of each joint (by name).
    The result keeps ``motion``'s own offsets and end sites, reordered; returns ``motion``
    itself when the order already matches. Raises :class:`EditingError` otherwise.
    """
    src = motion.skeleton
    if src.names == skeleton.names and np.array_equal(src.parents, skeleton.parents):
        return motion
    if sorted(src.names) != sorted(skeleton.names):
        missing = sorted(set(skeleton.names) - set(src.names))
        extra = sorted(set(src.names) - set(skeleton.names))
        raise EditingError(f"skeletons have different joints: missing {missing}, extra {extra}")
    order = np.array([src.names.index(n) for n in skeleton.names])
    for j, s in enumerate(order):
        ps, pt = src.parents[s], skeleton.parents[j]
        if (ps < 0) != (pt < 0) or (pt >= 0 and src.names[ps] != skeleton.names[pt]):
            raise EditingError(
                f"joint {skeleton.names[j]!r} has different parents in the two skeletons")
    inverse = np.argsort(order)
    new_sk = Skeleton(
        list(skeleton.names), skeleton.parents.copy(), src.offsets[order],
        [src.channels[s] for s in order], inverse[src.end_site_parents],
        src.end_site_offsets.copy(), list(src.end_site_names),
    )
    return Motion(new_sk, motion.frame_time, motion.local_positions[:, order],
                  motion.rotations[:, order])


# -- retargeting -------------------------------------------------------------------------------
def _child_bones(sk: Skeleton, j: int) -> list[np.ndarray]:
    bones = [sk.offsets[c] for c in sk.children(j)]
    bones += [sk.end_site_offsets[e] for e in np.flatnonzero(sk.end_site_parents == j)]
    return bones


def derive_rest_rotations(source: Skeleton, target: Skeleton) -> np.ndarray:
    """Global rest rotations ``R`` ``(J, 4)`` (wxyz, ``target``'s joint order) of two rest poses.

    ``R_j`` turns the directions of joint ``j``'s child bones (children's offsets and end sites)
    in ``source``'s rest pose onto their directions in ``target``'s: ``R_j o_c^s ~ o_c^t``. One
    bone gives the shortest-arc rotation; several give the least-squares rotation (Kabsch, with
    unit directions); joints without bones (or only zero-length ones) inherit their parent's
    ``R`` (identity at the root). The skeletons need the same joint names and parents.
    """
    src = match_joint_order(Motion.rest(source, 1), target).skeleton
    n_j = target.n_joints
    out = quat_identity((n_j,))
    for j in range(n_j):
        sb, tb = _child_bones(src, j), _child_bones(target, j)
        if len(sb) != len(tb):
            raise EditingError(f"joint {target.names[j]!r} has {len(sb)} child bones/end sites in "
                               f"the source skeleton and {len(tb)} in the target")
        keep = [(s, t) for s, t in zip(sb, tb, strict=True)
                if np.linalg.norm(s) > 1e-9 and np.linalg.norm(t) > 1e-9]
        if not keep:
            out[j] = out[target.parents[j]] if j > 0 else quat_identity()
            continue
        s = np.array([k[0] / np.linalg.norm(k[0]) for k in keep])
        t = np.array([k[1] / np.linalg.norm(k[1]) for k in keep])
        if len(keep) == 1:
            out[j] = _shortest_arc(s[0], t[0])
        else:
            r, _ = Rotation.align_vectors(t, s)
            out[j] = r.as_quat(scalar_first=True)
    return out


def _shortest_arc(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Unit wxyz quaternion of the smallest rotation taking unit ``a`` to unit ``b``."""
    c = float(np.dot(a, b))
    if c < -1.0 + 1e-12:  # opposite: any perpendicular axis
        perp = np.cross(a, np.eye(3)[int(np.argmin(np.abs(a)))])
        return np.array([0.0, *(perp / np.linalg.norm(perp))])
    return quat_normalize(np.array([1.0 + c, *np.cross(a, b)]))


def retarget(motion: Motion, target_skeleton: Skeleton,
             rest_rotations: np.ndarray | None = None) -> Motion:
    """``motion`` expressed on ``target_skeleton``: another rest pose of the same skeleton.

    Keeps the global direction of every bone. The rest-pose difference is the set of global
    rest rotations ``R_j`` (``(J, 4)`` wxyz in the target's joint order) with
    ``R_j o_c^source ~ o_c^target`` for each child bone ``c`` of ``j``; pass them as
    ``rest_rotations`` or let :func:`derive_rest_rotations` derive them from the two skeletons' bone
    directions (exact for any rest change that is rigid per joint; the twist about a single
    bone, which directions cannot tell, is taken as the smallest rotation). Then, with ``p`` the
    parent of ``j`` (``R_p = I`` above the root)::

        global:  G_j^t = G_j^s R_j^-1        local:  r_j^t = R_p r_j^s R_j^-1

    The root translation is kept; other joints with position channels get ``R_p t_j``; the rest
    use the target's offsets. With equal bone lengths the global joint positions are unchanged.
    """
    src = match_joint_order(motion, target_skeleton)
    n_j = target_skeleton.n_joints
    if rest_rotations is None:
        R = derive_rest_rotations(src.skeleton, target_skeleton)
    else:
        R = np.asarray(rest_rotations, dtype=float)
        if R.shape != (n_j, 4) or not np.all(np.isfinite(R)):
            raise EditingError(f"rest_rotations must be a finite ({n_j}, 4) array, got {R.shape}")
        R = quat_normalize(R)
    par = target_skeleton.parents
    R_par = np.where((par >= 0)[:, None], R[np.maximum(par, 0)], quat_identity((n_j,)))
    rot = quat_mul(quat_mul(R_par, src.rotations), quat_conj(R))
    pos = np.broadcast_to(target_skeleton.offsets, src.local_positions.shape).copy()
    chan = target_skeleton.has_position_channels()
    chan[0] = True
    pos[:, chan] = quat_rotate(R_par[chan], src.local_positions[:, chan])
    return Motion(target_skeleton, motion.frame_time, pos, quat_fix_continuity(rot, axis=0))


# -- align and concatenate ---------------------------------------------------------------------
def _up_index(up: str) -> int:
    if up not in AXES:
        raise EditingError(f"up must be 'x', 'y' or 'z', got {up!r}")
    return AXES[up]


def _about(up: str, angle: float) -> np.ndarray:
    q = np.zeros(4)
    q[0] = np.cos(0.5 * angle)
    q[1 + _up_index(up)] = np.sin(0.5 * angle)
    return q


def align(motion: Motion, root_rotation: np.ndarray, root_position: np.ndarray, frame: int = 0,
          up: str | None = None) -> Motion:
    """Turn ``motion`` about the up axis and shift it horizontally so that frame ``frame`` has the
    heading of ``root_rotation`` (wxyz ``(4,)``) and the horizontal position of ``root_position``
    (``(3,)``, file units). Heights and everything else are untouched.

    ``up``: ``"x"``, ``"y"`` or ``"z"`` (guessed with :func:`mjchar.bvh.rigs.units.guess_up_axis` if
    ``None``). The turn ``Q`` (about up, through the point) acts on the root only: ``r_0 -> Q r_0``,
    ``p_0 -> Q (p_0 - c) + c'`` with ``c``, ``c'`` the horizontal parts of the two positions.
    """
    up = up or guess_up_axis(motion.skeleton)
    i = _up_index(up)
    if not -motion.n_frames <= frame < motion.n_frames:
        raise EditingError(f"frame {frame} out of range for a motion of {motion.n_frames} frames")
    target_q = np.asarray(root_rotation, dtype=float).reshape(4)
    target_p = np.asarray(root_position, dtype=float).reshape(3)
    dh = float(heading_angle(target_q, up) - heading_angle(motion.rotations[frame, 0], up))
    q = _about(up, dh)
    c_from = motion.local_positions[frame, 0].copy()
    c_from[i] = 0.0
    c_to = target_p.copy()
    c_to[i] = 0.0
    pos = motion.local_positions.copy()
    rot = motion.rotations.copy()
    pos[:, 0] = quat_rotate(q, pos[:, 0] - c_from) + c_to
    rot[:, 0] = quat_mul(q, rot[:, 0])
    return Motion(motion.skeleton, motion.frame_time, pos, quat_fix_continuity(rot, axis=0))


def concatenate(a: Motion, b: Motion, blend_frames: int = 10, up: str | None = None) -> Motion:
    """``a`` followed by ``b``, with ``b`` turned and shifted to continue from ``a``'s last frame.

    1. ``b`` is put in ``a``'s joint order (:func:`match_joint_order`); a ``b`` with another frame
       time is first resampled to ``a``'s (:func:`~mjchar.bvh.editing.interpolation.resample`, cubic
       positions and spline rotations). The result uses ``a``'s skeleton.
    2. :func:`align`: ``b``'s first frame gets the heading (about ``up``, guessed from ``a``'s
       skeleton when ``None``) and horizontal root position of ``a``'s last frame.
    3. Transition: the remaining difference at the seam, ``d_j = a_last_j * b0_j^-1`` per joint
       (and ``a_last - b0`` for root height and other translations), is added to ``b``'s frames
       ``k = 0 .. blend_frames`` with weight ``1 - s(k / blend_frames)``, ``s`` the smoothstep
       ``3x^2 - 2x^3`` (rotations by slerp from identity to ``d``). ``b``'s frame 0 then equals
       ``a``'s last frame and is dropped, so the result has ``F_a + F_b - 1`` frames and no jump;
       ``blend_frames=0`` is a hard cut (aligned, no blending).

    Returns a new :class:`Motion` at ``a``'s frame time.
    """
    if a.n_frames == 0 or b.n_frames == 0:
        raise EditingError("cannot concatenate a motion with no frames")
    if int(blend_frames) != blend_frames or blend_frames < 0:
        raise EditingError(f"blend_frames must be a non-negative integer, got {blend_frames}")
    blend_frames = int(blend_frames)
    b = match_joint_order(b, a.skeleton)
    if not np.isclose(b.frame_time, a.frame_time, rtol=1e-6, atol=0.0):
        b = resample(b, frame_time=a.frame_time, position_method="cubic", rotation_method="spline")
    up = up or guess_up_axis(a.skeleton)
    b = align(b, a.rotations[-1, 0], a.local_positions[-1, 0], frame=0, up=up)
    rot = b.rotations.copy()
    pos = b.local_positions.copy()
    chan = a.skeleton.has_position_channels()
    chan[0] = True
    pos[:, ~chan] = a.local_positions[-1, ~chan]  # a's offsets for joints without translations
    n = min(blend_frames, b.n_frames - 1)
    if blend_frames > 0:
        d_rot = quat_mul(a.rotations[-1], quat_conj(rot[0]))  # (J, 4)
        d_pos = a.local_positions[-1, chan] - pos[0, chan]  # (C, 3)
        x = np.arange(n + 1) / blend_frames
        w = 1.0 - (3.0 * x**2 - 2.0 * x**3)  # (n+1,)
        off = quat_slerp(quat_identity(d_rot.shape[:1]), d_rot, w[:, None])  # (n+1, J, 4)
        rot[: n + 1] = quat_mul(off, rot[: n + 1])
        pos[: n + 1, chan] += w[:, None, None] * d_pos
    rot = np.concatenate([a.rotations, rot[1:]])
    pos = np.concatenate([a.local_positions, pos[1:]])
    return Motion(a.skeleton, a.frame_time, pos, quat_fix_continuity(rot, axis=0))


def _cycle_mismatch(motion: Motion, up: str) -> np.ndarray:
    """``(F, F)`` pose mismatch (radians summed over joints, plus 2 x root height in file units
    scaled by the leg length) between every pair of frames: local rotations of the non-root
    joints, root tilt (heading removed) and root height; plus the same for the next frames
    (velocities)."""
    i = _up_index(up)
    rot = motion.rotations
    _, tilt = decompose_facing(rot[:, 0], up)
    q = np.concatenate([tilt[:, None], rot[:, 1:]], axis=1)  # (F, J, 4)
    dots = np.abs(np.einsum("ajc,bjc->abj", q, q))
    ang = 2.0 * np.arccos(np.clip(dots, 0.0, 1.0)).sum(axis=2)  # (F, F)
    h = motion.local_positions[:, 0, i]
    scale = max(float(np.ptp(motion.skeleton.rest_positions()[:, i])), 1e-9)
    return ang + 2.0 * np.abs(h[:, None] - h[None, :]) / scale


def make_cyclic(motion: Motion, min_period: float = 0.8, max_period: float | None = None,
                up: str | None = None) -> Motion:
    """A seamless cycle cut from ``motion``, for looping (``ReferenceMotion(cyclic=True)``).

    1. Among frame pairs ``(a, b)`` with ``b - a`` between ``min_period`` and ``max_period``
       seconds (default: the whole clip), pick the one whose poses (local joint rotations, root
       tilt and height, heading and horizontal position removed) and next-frame poses (the
       velocities) differ least.
    2. Keep frames ``a .. b``. The remaining mismatch of the last frame against the first one,
       ``d_j = r_a_j r_b_j^-1`` per joint (the root's tilt only, so the loop keeps its turn and
       displacement) and the root height difference, is spread linearly over the cycle: frame
       ``k`` of ``n`` gets ``slerp(1, d_j, k / n)``. The last frame then equals the first up to
       the root's heading and horizontal position, which a loop carries over.

    Args:
        motion: a clip containing at least one cycle (e.g. two steps of a walk).
        min_period, max_period: seconds a cycle may last.
        up: ``"x"``, ``"y"`` or ``"z"`` (guessed if ``None``).

    Returns:
        the cycle, ``b - a + 1`` frames (the last is the first of the next cycle).
    """
    up = up or guess_up_axis(motion.skeleton)
    i = _up_index(up)
    dt = motion.frame_time
    lo = int(np.ceil(min_period / dt))
    hi = motion.n_frames - 2 if max_period is None else int(np.floor(max_period / dt))
    if lo < 2 or lo > min(hi, motion.n_frames - 2):
        raise EditingError(f"no cycle of {min_period}-{max_period or 'any'} s fits a clip of "
                           f"{(motion.n_frames - 1) * dt:.2f} s")
    m = _cycle_mismatch(motion, up)
    cost = m[:-1, :-1] + m[1:, 1:]  # pose and next pose
    a_idx, b_idx = np.indices(cost.shape)
    span = b_idx - a_idx
    cost = np.where((span >= lo) & (span <= hi), cost, np.inf)
    a, b = np.unravel_index(int(np.argmin(cost)), cost.shape)
    rot = motion.rotations[a:b + 1].copy()
    pos = motion.local_positions[a:b + 1].copy()
    n = b - a
    w = (np.arange(n + 1) / n)[:, None]
    head_a, tilt_a = decompose_facing(rot[0, 0], up)
    head_b, tilt_b = decompose_facing(rot[-1, 0], up)
    d = quat_mul(rot[0], quat_conj(rot[-1]))  # (J, 4)
    d[0] = quat_mul(head_b, quat_mul(quat_mul(tilt_a, quat_conj(tilt_b)), quat_conj(head_b)))
    d = quat_fix_continuity(np.where(d[:, :1] < 0, -d, d), axis=0)
    off = quat_slerp(quat_identity(d.shape[:1]), d, w)  # (n+1, J, 4)
    rot = quat_mul(off, rot)
    pos[:, 0, i] += w[:, 0] * (pos[0, 0, i] - pos[-1, 0, i])
    return Motion(motion.skeleton, dt, pos, quat_fix_continuity(rot, axis=0))


def leading_jumps(motion: Motion, *, zero_pose: float = 0.25, ratio: float = 3.0,
                  min_angle: float = 0.2, max_frames: int = 10) -> int:
    """How many frames ``motion`` starts with that are no part of its capture: a clip whose
    first frame is the skeleton's zero pose (every joint but the root within ``zero_pose`` rad
    of it) and which leaves it faster than it moves afterwards. Frame ``k`` is skipped while the
    largest joint rotation (rad) from frame ``k`` to ``k + 1`` is over ``min_angle`` and over
    ``ratio`` x its median over the clip, at most ``max_frames``. An Xsens MVN export writes its
    zero pose before the first captured frame (the root then turns by 90 degrees in one 0.01 s
    frame); the Daz conversion of a CMU clip blends from it into the capture over four frames.
    0 for a clip that does not start in its zero pose or moves continuously from there."""
    q = motion.rotations
    if len(q) < 3:
        return 0
    first = 2.0 * np.arccos(np.clip(np.abs(q[0, 1:, 0]), 0.0, 1.0))
    if len(first) and first.max() > zero_pose:
        return 0
    dots = np.abs(np.sum(q[1:] * q[:-1], axis=-1))              # (F - 1, J)
    jump = 2.0 * np.arccos(np.clip(dots, 0.0, 1.0)).max(axis=1)  # rad per frame
    limit = max(min_angle, ratio * float(np.median(jump)))
    k = 0
    while k < min(max_frames, len(jump) - 1) and jump[k] > limit:
        k += 1
    return k
