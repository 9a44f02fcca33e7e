"""Roles from geometry: limbs, sides and the head of a skeleton whose names say nothing.

Used by :func:`mjchar.bvh.rigs.naming.recognise` where names fail (``Joint0`` ... ``Joint21``,
``j12``, names in a language the tables do not know). It never looks at names but for end
markers and twist helpers, and it does not trust the rest pose's shape (T, A, arms hanging, bones
along local axes: any of them):

1. **Limbs from the hierarchy and the bone lengths** (pose-free). A human has two mirror-image
   limb pairs: sibling chains whose bone lengths match, bone for bone (:func:`mirror_pairs`). In
   a limb chain the two longest consecutive bones are the limb proper (thigh and shank, upper arm
   and forearm): the joint between them is the knee or the elbow (:func:`limb_joint`), so a
   finger or a toe can never be taken for one. The legs are the pair with the longest limbs, the
   arms the next; twist helpers (named ``twist``/``roll``) are walked over.
2. **Sides from the motion** (or the rest pose without a clip): forward is where the feet point
   (toe ahead of ankle) or, without toes, where the knees bend; left = up x forward; the limb
   whose root lies on the left over the clip is the left one.
3. **The head**: from the arms' branch point up the remaining chain that reaches farthest; its
   last joint, unless that is an end marker (a leaf that never rotates in the clip).

:class:`Clip` is the view of a motion these steps use (joint positions over a subsample of the
frames, and which joints never rotate).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mjchar.bvh.io.skeleton import Skeleton
from mjchar.bvh.rigs.words import is_end, is_twist

#: relative tolerance on matching bone lengths of a mirror pair (left and right bones measured
#: apart, as in a CMU ASF file, differ by a few percent)
MIRROR_TOLERANCE = 0.12
#: a limb (two consecutive bones) is at least this fraction of the skeleton's longest bone
MIN_LIMB = 0.9


@dataclass
class Clip:
    """What the role finder reads from a motion.

    Attributes:
        positions: ``(F, J, 3)`` global joint positions (file units and axes) on at most
            :attr:`MAX_FRAMES` frames spread over the clip.
        still: ``(J,)`` bool, True for joints whose local rotation never changes.
        orientations: ``(F, J, 4)`` wxyz global joint orientations on the same frames.
    """

    positions: np.ndarray
    still: np.ndarray
    orientations: np.ndarray | None = None
    MAX_FRAMES = 240

    @classmethod
    def of(cls, motion) -> Clip | None:
        """The view of ``motion`` (``None`` for a motion without frames)."""
        from mjchar.bvh.kinematics.fk import forward_kinematics

        if motion is None or motion.n_frames == 0:
            return None
        step = max(1, int(np.ceil(motion.n_frames / cls.MAX_FRAMES)))
        fk = forward_kinematics(motion[::step])
        q = motion.rotations
        dots = np.abs(np.sum(q * q[:1], axis=-1))  # |<q_t, q_0>|: 1 while the joint is still
        still = np.all(dots > 1.0 - 1e-9, axis=0)
        return cls(fk.positions, still, fk.orientations)


def _depths(sk: Skeleton, lengths: np.ndarray) -> np.ndarray:
    """Bone-length depth of each joint's subtree (the longest path down, end sites included)."""
    n = sk.n_joints
    depth = np.zeros(n)
    for e in range(sk.n_end_sites):
        p = int(sk.end_site_parents[e])
        depth[p] = max(depth[p], float(np.linalg.norm(sk.end_site_offsets[e])))
    for j in range(n - 1, 0, -1):  # children come after their parents in BVH order
        p = int(sk.parents[j])
        depth[p] = max(depth[p], depth[j] + lengths[j])
    return depth


def main_path(sk: Skeleton, c: int, depth: np.ndarray, lengths: np.ndarray) -> list[int]:
    """The chain from ``c`` down, always into the child whose subtree reaches farthest."""
    path = [c]
    while True:
        kids = sk.children(path[-1])
        if not kids:
            return path
        path.append(max(kids, key=lambda k: (depth[k] + lengths[k], -k)))


def _segments(sk: Skeleton, path: list[int], lengths: np.ndarray) -> tuple[list[int], list[float]]:
    """The path's joints without twist helpers, and the bone into each (into the first: from
    the branch point), a walked-over twist helper's bone added to the next one's."""
    joints, bones, carry = [], [], 0.0
    for j in path:
        if is_twist(sk.names[j]) and j != path[-1]:
            carry += lengths[j]
            continue
        joints.append(j)
        bones.append(lengths[j] + carry)
        carry = 0.0
    return joints, bones


def limb_joint(sk: Skeleton, path: list[int], lengths: np.ndarray) -> tuple[int, int, float]:
    """``(joint, upper, limb)``: the joint between the two longest consecutive bones of a limb
    path (the knee or the elbow), the joint above it (hip or shoulder; twist helpers walked
    over) and the two bones' total length; ``(-1, -1, 0)`` when the path has no such pair below
    its first joint."""
    joints, bones = _segments(sk, path, lengths)
    best, at = 0.0, -1
    for i in range(1, len(joints) - 1):
        s = bones[i] + bones[i + 1]
        if s > best + 1e-12:
            best, at = s, i
    if at < 1:
        return -1, -1, 0.0
    return joints[at], joints[at - 1], best


@dataclass
class _Pair:
    branch: int
    paths: tuple[list[int], list[int]]
    joints: tuple[int, int]   # knees or elbows
    uppers: tuple[int, int]   # hips or shoulders
    limb: float


def mirror_pairs(sk: Skeleton) -> list[_Pair]:
    """Sibling chains whose bone lengths match bone for bone (>= 3 bones), with a limb
    (:func:`limb_joint`) at least :data:`MIN_LIMB` of the longest bone; longest limb first."""
    lengths = sk.bone_lengths()
    if sk.n_joints < 4 or lengths.max() <= 0:
        return []
    depth = _depths(sk, lengths)
    scale = float(lengths.max())
    out = []
    for b in range(sk.n_joints):
        kids = sk.children(b)
        for i, c1 in enumerate(kids):
            for c2 in kids[i + 1:]:
                p1, p2 = main_path(sk, c1, depth, lengths), main_path(sk, c2, depth, lengths)
                s1, s2 = _segments(sk, p1, lengths)[1], _segments(sk, p2, lengths)[1]
                n = min(len(s1), len(s2))
                if n < 3 or not all(abs(a - bb) <= MIRROR_TOLERANCE * max(a, bb) + 0.02 * scale
                                    for a, bb in zip(s1[:n], s2[:n], strict=True)):
                    continue
                k1, u1, limb1 = limb_joint(sk, p1, lengths)
                k2, u2, limb2 = limb_joint(sk, p2, lengths)
                limb = min(limb1, limb2)
                if k1 < 0 or k2 < 0 or limb < MIN_LIMB * scale:
                    continue
                out.append(_Pair(b, (p1, p2), (k1, k2), (u1, u2), limb))
    return sorted(out, key=lambda p: -p.limb)


def _frames(sk: Skeleton, clip: Clip | None) -> np.ndarray:
    """``(F, J, 3)``: the clip's positions, or the rest pose as one frame."""
    return clip.positions if clip is not None else sk.rest_positions()[None]


def _forward(P: np.ndarray, up: np.ndarray, legs, toes) -> np.ndarray:
    """``(F, 3)``: per frame, the horizontal unit vector the character faces (zero where
    nothing tells): where the feet point (toe ahead of ankle), else where the knees bend (knee
    ahead of the hip-ankle line)."""
    v = np.zeros((P.shape[0], 3))
    if toes and all(t is not None for t in toes):
        for (_, _, a), t in zip(legs, toes, strict=True):
            v += P[:, t] - P[:, a]
    else:
        for h, k, a in legs:
            v += P[:, k] - 0.5 * (P[:, h] + P[:, a])
    v = v - (v @ up)[:, None] * up
    n = np.linalg.norm(v, axis=1, keepdims=True)
    size = np.ptp(P @ up, axis=1)[:, None]
    return np.where(n > 0.03 * np.maximum(size, 1e-12), v / np.maximum(n, 1e-300), 0.0)


def hips_left(sk: Skeleton, left_hip: int, right_hip: int, clip: Clip | None) -> np.ndarray:
    """``(F, 3)``: the character's left per frame of the clip (or the rest pose) from its known
    hips: the line from the right hip to the left one."""
    P = _frames(sk, clip)
    return P[:, left_hip] - P[:, right_hip]


def _lefts(P: np.ndarray, up: np.ndarray, legs, toes) -> np.ndarray:
    """``(F, 3)``: the character's left per frame (up x forward); the file's +X (made
    horizontal) where the frame tells no forward: Y-up files facing +Z and Z-up files facing
    -Y both have their left at +X."""
    fwd = _forward(P, up, legs, toes)
    left = np.cross(up, fwd)
    x = np.array([1.0, 0.0, 0.0]) - up * up[0]
    x /= max(np.linalg.norm(x), 1e-12)
    if not np.any(np.linalg.norm(left, axis=1) > 0.5):
        return np.broadcast_to(x, left.shape).copy()
    return left


def pair_legs(pair: _Pair) -> list[tuple[int, int, int]]:
    """``[(hip, knee, ankle), ...]`` of a limb pair (for arms: shoulder, elbow, wrist)."""
    out = []
    for k, h, path in zip(pair.joints, pair.uppers, pair.paths, strict=True):
        i = path.index(k)
        out.append((h, k, path[i + 1] if i + 1 < len(path) else k))
    return out


def up_axis(sk: Skeleton, legs, clip: Clip | None) -> str | None:
    """The file's up axis from the legs (``[(hip, knee, ankle)...]``), or ``None`` when it
    cannot tell: ``"y"``, or ``"-y"`` when the hips stand above the ankles towards -Y (an
    up axis pointing down, as Azure Kinect exports have). In the rest pose: the axis along the
    hips-above-ankles vector when it dominates. Over a clip: among the axes along which the
    hips stand above the ankles by at least 30% of that vector on average, the one along which
    the body's lowest point stays on a floor in most frames (a crawl or a fall has its legs
    along the ground for a while, its lowest point on the floor throughout); ties go to the
    larger leg component."""
    P = _frames(sk, clip)
    v = np.zeros(3)
    for h, _, a in legs:
        v += np.mean(P[:, h] - P[:, a], axis=0)
    n = np.linalg.norm(v)
    if n < 1e-12:
        return None
    if P.shape[0] < 2:
        i = int(np.argmax(np.abs(v)))
        return _signed(i, v[i]) if abs(v[i]) >= 0.8 * n else None
    size = float(np.median(np.ptp(P, axis=1).max(axis=1)))

    def floor(i: int) -> float:
        low = np.min(np.sign(v[i]) * P[:, :, i], axis=1)  # the lowest point along +-axis i
        return float(np.mean(np.abs(low - np.median(low)) < 0.05 * size))

    cands = [i for i in range(3) if abs(v[i]) >= 0.3 * n]
    best = max(cands, key=lambda i: (round(floor(i), 1), abs(v[i])))
    return _signed(best, v[best])


def _signed(i: int, component: float) -> str:
    """``"y"`` or ``"-y"``: file axis ``i`` signed by ``component``."""
    return ("-" if component < 0 else "") + "xyz"[i]


def _chirality(P: np.ndarray, legs, pelvis: int, upper: list[int]) -> tuple[np.ndarray,
                                                                              np.ndarray]:
    """``(lefts (F, 3), weights (F,))``: per frame, the character's left as the trunk's
    direction (pelvis to the upper body's centre) x the knees' bend (the knee's offset from the
    hip-ankle line: a knee bends forward in any pose, standing, crawling or lying), unit
    vectors; the weights are the bends' size (zero for straight knees)."""
    b = P[:, upper].mean(axis=1) - P[:, pelvis]
    b /= np.maximum(np.linalg.norm(b, axis=1, keepdims=True), 1e-300)
    acc = np.zeros_like(b)
    for h, k, a in legs:
        u = P[:, a] - P[:, h]
        u /= np.maximum(np.linalg.norm(u, axis=1, keepdims=True), 1e-300)
        d = P[:, k] - P[:, h]
        acc += np.cross(b, d - np.sum(d * u, axis=1, keepdims=True) * u)
    w = np.linalg.norm(acc, axis=1)
    return acc / np.maximum(w, 1e-300)[:, None], w


def side_legs(sk: Skeleton, pair: _Pair, up: np.ndarray, clip: Clip | None,
              toe_of) -> tuple[dict[str, int], np.ndarray | None, str | None]:
    """``(knees, lefts, problem)``: which of the pair's knees is left and right, the left axis
    per frame used (``(F, 3)``, file axes), or ``problem`` when the legs are not apart
    sideways. Each frame is judged in its own facing, so a clip that turns round is fine. The
    facing is the trunk x the knees' bend where the knees bend (:func:`_chirality`), else up x
    where the feet point (the rest pose)."""
    P = _frames(sk, clip)
    legs = pair_legs(pair)
    toes = [toe_of(a) for _, _, a in legs]
    in_legs = {j for p in pair.paths for j in range(sk.n_joints)
               if p[0] in sk.chain(j)}
    upper = [j for j in range(sk.n_joints) if j not in in_legs and j != pair.branch]
    lefts = _lefts(P, up, legs, toes)
    thigh = np.mean([np.linalg.norm(P[:, k] - P[:, h], axis=1).mean() for h, k, _ in legs])
    if upper:
        chiral, w = _chirality(P, legs, pair.branch, upper)
        bent = w > 0.05 * thigh  # knees bent by more than about 3 degrees
        if bent.any():
            lefts = np.where(bent[:, None], chiral, 0.0)
    height = float(np.mean(np.ptp(P @ up, axis=1)))
    (h1, k1, _), (h2, k2, _) = legs
    on = np.linalg.norm(lefts, axis=1) > 0.5
    sep = float(np.mean(np.sum((P[on, h1] - P[on, h2]) * lefts[on], axis=1))) if on.any() else 0.0
    if abs(sep) < 0.02 * height:
        sep = float(np.mean(np.sum((P[on, k1] - P[on, k2]) * lefts[on], axis=1))) \
            if on.any() else 0.0
    if abs(sep) < 0.02 * height:
        return {}, lefts, (f"two leg chains ({sk.names[pair.paths[0][0]]}, "
                           f"{sk.names[pair.paths[1][0]]}) but their hips and knees are not "
                           "apart sideways, so left and right cannot be told apart")
    return ({"left": k1, "right": k2} if sep > 0 else {"left": k2, "right": k1}), lefts, None


def side_arms(sk: Skeleton, pair: _Pair, lefts: np.ndarray, clip: Clip | None) -> dict[int, str]:
    """``{elbow: side}`` for an arm pair, by where its shoulders lie along the left axis
    (``(3,)``, or ``(F, 3)`` per frame; frames with a zero axis are skipped)."""
    P = _frames(sk, clip)
    lefts = np.broadcast_to(lefts, (P.shape[0], 3))
    on = np.linalg.norm(lefts, axis=1) > 1e-9
    if not on.any():
        return {}
    (e1, e2), (s1, s2) = pair.joints, pair.uppers
    sep = float(np.mean(np.sum((P[on, s1] - P[on, s2]) * lefts[on], axis=1)))
    if abs(sep) < 1e-9:
        sep = float(np.mean(np.sum((P[on, e1] - P[on, e2]) * lefts[on], axis=1)))
    if abs(sep) < 1e-9:
        return {}
    return {e1: "left", e2: "right"} if sep > 0 else {e1: "right", e2: "left"}


def find_limbs(sk: Skeleton, taken: set[int]) -> tuple[_Pair | None, _Pair | None]:
    """``(legs, arms)``: the mirror pair with the longest limbs and the next one, among pairs
    that share no joint with ``taken`` (joints whose names already gave them another limb's
    role) nor with each other."""
    legs = arms = None
    for p in mirror_pairs(sk):
        joints = set(p.paths[0]) | set(p.paths[1])
        if joints & taken:
            continue
        if legs is None:
            legs = p
        elif arms is None and not joints & (set(legs.paths[0]) | set(legs.paths[1])):
            arms = p
    return legs, arms


def head_by_structure(sk: Skeleton, top: int, avoid: set[int], clip: Clip | None) -> list[int]:
    """The chain from ``top`` (the arms' branch point, or the highest spine joint) to the head:
    into the child (not in ``avoid``) whose subtree reaches farthest, down to a leaf. The leaf is
    dropped from the chain when it is an end marker (its name, or it never rotates in the clip
    while its parent does). Returns ``[]`` when ``top`` has no such child."""
    lengths = sk.bone_lengths()
    depth = _depths(sk, lengths)
    kids = [c for c in sk.children(top) if c not in avoid]
    if not kids:
        return []
    c = max(kids, key=lambda k: (depth[k] + lengths[k], -k))
    path = main_path(sk, c, depth, lengths)
    for i, j in enumerate(path):  # a head with a face: many children (jaw, eyes, tongue)
        if len(sk.children(j)) >= 3:
            return path[:i + 1]
    leaf = path[-1]
    if len(path) > 1 and (is_end(sk.names[leaf]) or (
            clip is not None and clip.still[leaf] and not clip.still[path[-2]])):
        path = path[:-1]
    return path
