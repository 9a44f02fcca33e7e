"""More exact re-expressions for the rig zoo: the structures of real skeletons.

Each keeps every joint of the source where it was in every frame (forward kinematics unchanged,
to rounding), like those of :mod:`mjchar.bvh.bundled.zoo`:

- :func:`spread_legs`: a rest with the legs turned outward (a CMU ASF rest, legs apart);
- :func:`turn_rest`: the whole rest turned (a Z-up armature written into a Y-up file without a
  node above it: the root's channels carry the turn, near gimbal lock for some orders);
- :func:`insert_joint`: a helper joint between a joint and some of its children (Daz's
  ``pelvis`` between ``hip`` and the thighs);
- :func:`add_chain`: new joints that never move (fingers, a face: jaw, tongue, eyes);
- :func:`strip_end_sites`, :func:`anonymise`: no End Sites (LAFAN1), names ``Joint0``...
"""

from __future__ import annotations

import numpy as np

from mjchar.bvh.io.motion import Motion
from mjchar.bvh.io.skeleton import Skeleton
from mjchar.bvh.rigs.layouts import rerest
from mjchar.bvh.rotations import quat_from_rotvec, quat_identity

__all__ = ["spread_legs", "turn_rest", "insert_joint", "add_chain", "strip_end_sites",
           "anonymise"]

_ROT = ("Zrotation", "Xrotation", "Yrotation")


def spread_legs(motion: Motion, hips: tuple[str, str], angle_deg: float = 20.0,
                forward=(0.0, 0.0, 1.0), up=(0.0, 1.0, 0.0)) -> Motion:
    """Rest with each leg (the joint ``hips[i]`` and everything below it) turned outward by
    ``angle_deg`` about ``forward``: the legs of a CMU ASF rest pose, apart like an A."""
    sk = motion.skeleton
    rest = sk.rest_positions()
    forward, up = np.asarray(forward, dtype=float), np.asarray(up, dtype=float)
    left = np.cross(up, forward)
    r = quat_identity((sk.n_joints,))
    for h in hips:
        i = sk.index(h)
        side = 1.0 if float((rest[i] - rest[0]) @ left) > 0 else -1.0
        q = quat_from_rotvec(side * np.radians(angle_deg) * forward)
        for j in range(sk.n_joints):
            if i in sk.chain(j):
                r[j] = q
    return rerest(motion, r)


def turn_rest(motion: Motion, rotation: np.ndarray) -> Motion:
    """The whole rest turned by ``rotation`` (wxyz): the zero pose lies as the rotation says
    and the root's rotation per frame carries its inverse."""
    q = np.asarray(rotation, dtype=float)
    return rerest(motion, np.tile(q, (motion.skeleton.n_joints, 1)))


def _insert(sk: Skeleton, at: int, name: str, parent: int, offset, channels) -> tuple:
    """Skeleton arrays with a joint inserted at index ``at`` (old indices >= at shift by one)."""
    n = sk.n_joints
    idx = np.arange(n) + (np.arange(n) >= at)
    names = list(sk.names[:at]) + [name] + list(sk.names[at:])
    parents = np.empty(n + 1, dtype=int)
    parents[idx] = [idx[p] if p >= 0 else -1 for p in sk.parents]
    parents[at] = idx[parent] if parent >= 0 else -1
    offsets = np.zeros((n + 1, 3))
    offsets[idx] = sk.offsets
    offsets[at] = offset
    chans = list(sk.channels[:at]) + [tuple(channels)] + list(sk.channels[at:])
    return idx, names, parents, offsets, chans


def insert_joint(motion: Motion, children: list[str], name: str, offset,
                 channels: tuple[str, ...] = _ROT) -> Motion:
    """A joint ``name`` at ``offset`` (file units, the children's parent's frame) between the
    ``children`` (siblings) and their parent; it never rotates, so the children keep their
    places (their offsets and translations become relative to it)."""
    sk = motion.skeleton
    kids = [sk.index(c) for c in children]
    parent = int(sk.parents[kids[0]])
    if any(int(sk.parents[k]) != parent for k in kids):
        raise ValueError("insert_joint: the children must share a parent")
    at = min(kids)
    offset = np.asarray(offset, dtype=float)
    idx, names, parents, offsets, chans = _insert(sk, at, name, parent, offset, channels)
    for k in kids:
        parents[idx[k]] = at
        offsets[idx[k]] = sk.offsets[k] - offset
    es = idx[sk.end_site_parents] if sk.n_end_sites else sk.end_site_parents
    new = Skeleton(names, parents, offsets, chans, es, sk.end_site_offsets.copy(),
                   list(sk.end_site_names))
    n_f = motion.n_frames
    lp = np.zeros((n_f, sk.n_joints + 1, 3))
    lp[:, idx] = motion.local_positions
    lp[:, at] = offset
    for k in kids:
        lp[:, idx[k]] = motion.local_positions[:, k] - offset
    rot = np.tile(quat_identity(), (n_f, sk.n_joints + 1, 1))
    rot[:, idx] = motion.rotations
    m = Motion(new, motion.frame_time, lp, rot)
    return Motion.from_channels(new, motion.frame_time, m.to_channels())


def add_chain(motion: Motion, parent: str, joints: list[tuple[str, tuple[float, float, float]]],
              end: tuple[float, float, float] | None = None,
              channels: tuple[str, ...] = _ROT) -> Motion:
    """New joints below ``parent``, each the child of the one before (``(name, offset)``,
    file units, zero pose axes), with an End Site at ``end`` after the last; they never
    rotate (a face's or a hand's joints the clip does not animate)."""
    sk = motion.skeleton
    p = sk.index(parent)
    names = list(sk.names)
    parents = list(sk.parents)
    offsets = list(sk.offsets)
    chans = list(sk.channels)
    for name, off in joints:
        names.append(name)
        parents.append(p)
        offsets.append(np.asarray(off, dtype=float))
        chans.append(tuple(channels))
        p = len(names) - 1
    es_p, es_o, es_n = list(sk.end_site_parents), list(sk.end_site_offsets), \
        list(sk.end_site_names)
    if end is not None:
        es_p.append(p)
        es_o.append(np.asarray(end, dtype=float))
        es_n.append(f"{names[p]}_end")
    new = Skeleton(names, np.asarray(parents), np.asarray(offsets), chans,
                   np.asarray(es_p, dtype=int), np.asarray(es_o, dtype=float).reshape(-1, 3),
                   es_n)
    n_f, k = motion.n_frames, len(joints)
    lp = np.concatenate([motion.local_positions,
                         np.broadcast_to(new.offsets[sk.n_joints:], (n_f, k, 3))], axis=1)
    rot = np.concatenate([motion.rotations, np.tile(quat_identity(), (n_f, k, 1))], axis=1)
    m = Motion(new, motion.frame_time, lp, rot)
    return Motion.from_channels(new, motion.frame_time, m.to_channels())


def strip_end_sites(motion: Motion) -> Motion:
    """The motion without End Sites (LAFAN1 files end their chains with a joint)."""
    sk = motion.skeleton
    new = Skeleton(list(sk.names), sk.parents.copy(), sk.offsets.copy(), list(sk.channels))
    return Motion(new, motion.frame_time, motion.local_positions, motion.rotations,
                  motion.source_channels)


def anonymise(motion: Motion, prefix: str = "Joint") -> tuple[Motion, dict[str, str]]:
    """``(motion, mapping)``: joints renamed ``Joint0``, ``Joint1``... in file order (a names
    file that says nothing, as LAFAN1 clips shared without their skeleton's names)."""
    sk = motion.skeleton
    mapping = {n: f"{prefix}{i}" for i, n in enumerate(sk.names)}
    names = [mapping[n] for n in sk.names]
    new = Skeleton(names, sk.parents.copy(), sk.offsets.copy(), list(sk.channels),
                   sk.end_site_parents.copy(), sk.end_site_offsets.copy(),
                   [f"{names[p]}_end" for p in sk.end_site_parents])
    return Motion(new, motion.frame_time, motion.local_positions, motion.rotations,
                  motion.source_channels), mapping
