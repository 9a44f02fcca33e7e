"""Is it a two-legged humanoid? Structure and geometry, not names alone.

The converter builds a biped. A quadruped written with 3ds Max Biped names, a crab, a hand, an
upper body without legs or a three-point VR capture (head and two hands) must be refused in one
line that says what was found, before the role finder's "missing roles" (which asks for a roles
file: no roles file makes a crab walk). Two tests, each on what gravity saw:

1. **Limbs reaching the floor** (:func:`floor_limbs`). Per frame of the clip (or the rest pose
   alone), the leaves of the hierarchy whose height above that frame's lowest point is under
   :data:`FLOOR_BAND` of the body's size, in at least :data:`FLOOR_SHARE` of the frames. Leaves
   are grouped into limbs by the joint :data:`LIMB_REACH` of the body's size above them (a
   foot's toe, heel and ball are one limb). A walking human has two; a quadruped four, a crab
   eight. Three or more in the clip and in the rest pose (or a rest pose that says nothing: bones
   along local axes, lying flat) is not a biped. A human who crawls for the whole clip has four
   too: its T-pose rest still has two.
2. **A trunk above the legs** (:func:`trunk_problem`), when legs were found: over the clip, the
   pelvis-to-head (or -clavicles) direction points away from the legs' hip-to-ankle direction
   (within :data:`TRUNK_DEG` of opposite, on the median frame). A hand whose fingers were taken
   for legs has its "trunk" along them.

3. **An upright trunk** (:func:`upright_problem`): in a rest pose whose legs hang down (within
   :data:`LEGS_DOWN_DEG` of down), the trunk stands within :data:`UPRIGHT_DEG` of up; a rest
   pose that is no standing figure (bones along local axes) leaves it to the clip, whose median
   frame must have it within :data:`CLIP_UPRIGHT_DEG`. A bird, a dinosaur or a quadruped on its
   hind legs carries its trunk level; a human is upright at rest however it moves in the clip.

Legs missing altogether (no knee names, no mirror pair of limb chains) is said as "not a
humanoid: no legs" by the caller.
"""

from __future__ import annotations

import numpy as np

from mjchar.bvh.io.skeleton import Skeleton

#: a leaf this close to the frame's lowest point (fraction of the body's size) is on the floor
FLOOR_BAND = 0.05
#: a limb reaches the floor when one of its leaves is on it in at least this share of frames
FLOOR_SHARE = 0.3
#: leaves under the same joint this far above them (fraction of the body's size) are one limb
LIMB_REACH = 0.2
#: a rest pose whose vertical extent is under this fraction of its largest extent says nothing
#: about the floor (bones along local axes, a figure lying flat)
FLAT_REST = 0.35
#: degrees: the trunk (pelvis to head) points within this of the legs' opposite
TRUNK_DEG = 110.0
#: degrees: a rest pose whose hips-to-ankles direction is this close to down is a standing one
LEGS_DOWN_DEG = 45.0
#: degrees: the trunk of a standing rest pose is within this of up
UPRIGHT_DEG = 45.0
#: degrees: without a standing rest pose, the trunk of the clip's median frame is within this
CLIP_UPRIGHT_DEG = 60.0


def _points(sk: Skeleton, positions: np.ndarray | None) -> np.ndarray:
    """``(F, J, 3)``: the clip's joint positions, or the rest pose as one frame."""
    return positions if positions is not None else sk.rest_positions()[None]


def floor_limbs(sk: Skeleton, up: np.ndarray, positions: np.ndarray | None = None) -> int:
    """How many limbs reach the floor (module docstring, test 1) in ``positions`` ``(F, J, 3)``
    (file units and axes; ``None``: the rest pose). ``up`` ``(3,)``: the file's up vector.
    Returns ``-1`` for a rest pose that says nothing (lying flat along the floor)."""
    P = _points(sk, positions)
    h = P @ np.asarray(up, dtype=float)                                     # (F, J)
    size = float(np.median(np.ptp(P, axis=1).max(axis=1)))
    if size <= 0:
        return 0
    if positions is None and float(np.ptp(h)) < FLAT_REST * size:
        return -1
    leaves = [j for j in range(sk.n_joints) if not sk.children(j)]
    near = (h - h.min(axis=1, keepdims=True)) < FLOOR_BAND * size           # (F, J)
    down = [j for j in leaves if near[:, j].mean() >= FLOOR_SHARE]
    lengths = sk.bone_lengths()
    keys: set[int] = set()
    for j in down:
        k, reach = j, 0.0
        while sk.parents[k] >= 0 and reach < LIMB_REACH * size:
            reach += lengths[k]
            k = int(sk.parents[k])
        keys.add(k)
    # a key below another key's joint is the same limb (a toe and the foot's other leaves)
    return len({k for k in keys if not any(o != k and o in sk.chain(k) for o in keys)})


def trunk_problem(P: np.ndarray, legs: list[tuple[int, int, int]], pelvis: int,
                  tops: list[int]) -> str | None:
    """Why the trunk does not stand above the legs (module docstring, test 2), or ``None``.

    ``P`` ``(F, J, 3)`` joint positions; ``legs`` ``[(hip, knee, ankle), ...]``; ``tops``: the
    head and the clavicles or shoulders (whichever exist)."""
    if not tops:
        return None
    leg = np.mean([P[:, a] - P[:, h] for h, _, a in legs], axis=0)          # (F, 3)
    trunk = P[:, tops].mean(axis=1) - P[:, pelvis]                           # (F, 3)
    n = np.linalg.norm(leg, axis=1) * np.linalg.norm(trunk, axis=1)
    ok = n > 1e-12
    if not ok.any():
        return None
    cos = np.sum(leg[ok] * trunk[ok], axis=1) / n[ok]
    angle = float(np.degrees(np.arccos(np.clip(np.median(cos), -1.0, 1.0))))
    if angle >= 180.0 - TRUNK_DEG:
        return None
    return (f"the trunk does not stand above the legs (pelvis to head {angle:.0f} deg from the "
            f"legs' direction, a biped's is near 180)")


def _angle(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Degrees between the vectors ``a`` and ``b`` ``(..., 3)``."""
    n = np.linalg.norm(a, axis=-1) * np.linalg.norm(b, axis=-1)
    cos = np.sum(a * b, axis=-1) / np.maximum(n, 1e-300)
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def upright_problem(rest: np.ndarray, positions: np.ndarray | None,
                    legs: list[tuple[int, int, int]], pelvis: int, tops: list[int],
                    up: np.ndarray) -> str | None:
    """Why the trunk is not upright (module docstring, test 3), or ``None``.

    ``rest`` ``(J, 3)`` the rest pose's joint positions; ``positions`` ``(F, J, 3)`` the clip's
    (or ``None``); ``legs`` ``[(hip, knee, ankle), ...]``; ``tops``: head and clavicles or
    shoulders; ``up`` ``(3,)``."""
    if not tops:
        return None
    up = np.asarray(up, dtype=float)
    leg = np.mean([rest[a] - rest[h] for h, _, a in legs], axis=0)
    if np.linalg.norm(leg) > 0 and _angle(leg, -up) <= LEGS_DOWN_DEG:
        tilt = float(_angle(rest[tops].mean(axis=0) - rest[pelvis], up))
        if tilt > UPRIGHT_DEG:
            return (f"its trunk lies {tilt:.0f} deg from upright in the rest pose, where its "
                    "legs stand (a bird, a dinosaur or a quadruped on its hind legs)")
        return None
    if positions is None:
        return None
    tilt = float(np.median(_angle(positions[:, tops].mean(axis=1) - positions[:, pelvis], up)))
    if tilt > CLIP_UPRIGHT_DEG:
        return f"its trunk lies {tilt:.0f} deg from upright over the clip"
    return None
