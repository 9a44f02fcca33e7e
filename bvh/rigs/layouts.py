"""Exact re-expressions of a rig: the same motion on a different skeleton layout.

Real exports differ from a tidy world-axis T-pose in ways that change no joint position: a
static node above the pelvis (``Reference``, ``root``, ``joint_Root``), translation channels that
carry the bones, rest poses whose offsets lie along each bone's local X axis or whose arms hang in
an A-pose. The functions here move between such layouts **without moving any joint** (forward
kinematics of the result equals the input's, to rounding), so the converter can normalise a rig
and a reference motion can apply the same normalisation to the file's clip:

- :func:`rerest`: new rest orientations ``R_j`` (``(J, 4)`` wxyz, world frame of the old rest);
  global orientations become ``G_j R_j^-1``, offsets ``R_parent o_j``, local rotations
  ``R_parent L_j R_j^-1``. With ``R_j`` = a pose's global orientations the rest *becomes* that
  pose.
- :func:`fold_root`: drop the single-child chain of joints above joint ``k``; ``k`` becomes the
  root and carries its global transform per frame.
- :func:`bones_from_channels`: translation channels of non-root joints: the mean is the bone.
- :func:`apply_record`: the converter's use of the three, replayed from the record kept in a
  model's metadata; :func:`undo_record` takes a motion on the normalised skeleton back to the
  file's own layout (what :mod:`mjchar.bvh.reference.export` writes).
"""

from __future__ import annotations

import numpy as np

from mjchar.bvh.io.motion import Motion
from mjchar.bvh.io.skeleton import POSITION_CHANNELS, Skeleton
from mjchar.bvh.kinematics.fk import forward_kinematics
from mjchar.bvh.rotations import (
    quat_conj,
    quat_fix_continuity,
    quat_identity,
    quat_mul,
    quat_normalize,
    quat_rotate,
    quat_to_rotvec,
)

__all__ = ["rerest", "fold_root", "unfold_root", "bones_from_channels", "static_chain_above",
           "apply_record", "undo_record"]


def rerest(motion: Motion, rest: np.ndarray) -> Motion:
    """The same motion with new rest orientations ``rest`` ``(J, 4)`` (wxyz, one per joint).

    Offsets and end sites turn with their joint's parent (``o' = R_p o``, end sites ``R_j e``),
    translations likewise, local rotations become ``R_p L_j R_j^-1`` (``R_p`` = identity for the
    root). Joint positions are unchanged in every frame; global orientations become
    ``G_j R_j^-1``, so with ``rest = G(f)`` the new rest pose is frame ``f``'s pose.
    """
    sk = motion.skeleton
    rest = quat_normalize(np.asarray(rest, dtype=float).reshape(sk.n_joints, 4))
    rp = np.where((sk.parents >= 0)[:, None], rest[np.maximum(sk.parents, 0)],
                  quat_identity((sk.n_joints,)))
    new = sk.copy()
    new.offsets = quat_rotate(rp, sk.offsets)
    if sk.n_end_sites:
        new.end_site_offsets = quat_rotate(rest[sk.end_site_parents], sk.end_site_offsets)
    pos = quat_rotate(rp[None], motion.local_positions)
    rot = quat_mul(quat_mul(rp[None], motion.rotations), quat_conj(rest)[None])
    rot = quat_fix_continuity(quat_normalize(rot), axis=0)
    return Motion(new, motion.frame_time, pos, rot)


def static_chain_above(sk: Skeleton, k: int) -> bool:
    """True when every joint above ``k`` has exactly one child joint (a chain root -> k)."""
    j = int(sk.parents[k])
    while j >= 0:
        if len(sk.children(j)) != 1:
            return False
        j = int(sk.parents[j])
    return k > 0


def fold_root(motion: Motion, k: int) -> Motion:
    """Drop joints ``0..k-1`` (a single-child chain above ``k``); ``k`` becomes the root.

    The new root's translation and rotation per frame are its global ones (the chain's
    transforms folded in); its rest offset is its rest position; it gets position channels if it
    had none. End sites of the dropped joints are dropped. Joint positions are unchanged.
    """
    sk = motion.skeleton
    if not static_chain_above(sk, k):
        raise ValueError(f"joints above {sk.names[k]!r} are not a single-child chain")
    fk = forward_kinematics(motion)
    keep = np.arange(k, sk.n_joints)
    parents = np.where(sk.parents[keep] >= k, sk.parents[keep] - k, -1)
    chans = [tuple(c) for c in sk.channels[k:]]
    if not any(c in POSITION_CHANNELS for c in chans[0]):
        chans[0] = POSITION_CHANNELS + chans[0]
    es = sk.end_site_parents >= k
    offsets = sk.offsets[keep].copy()
    offsets[0] = sk.rest_positions()[k]
    new = Skeleton([sk.names[j] for j in keep], parents, offsets, chans,
                   sk.end_site_parents[es] - k, sk.end_site_offsets[es],
                   [n for n, e in zip(sk.end_site_names, es, strict=True) if e])
    pos = motion.local_positions[:, keep].copy()
    rot = motion.rotations[:, keep].copy()
    pos[:, 0] = fk.positions[:, k]
    rot[:, 0] = fk.orientations[:, k]
    return Motion(new, motion.frame_time, pos, rot)


def unfold_root(motion: Motion, original: Skeleton, chain_pose: dict) -> Motion:
    """The inverse of :func:`fold_root`: ``motion`` (root = the original's joint ``k``) on the
    ``original`` skeleton, whose joints ``0..k-1`` form a single-child chain above it, held at
    ``chain_pose`` (name -> ``{"position": (3,), "rotation": (4,) wxyz}``, their local channel
    values). Joint ``k`` carries the motion when it has position channels, else the top joint
    does (the chain below it held). Joint positions are unchanged."""
    k = original.index(motion.skeleton.names[0])
    if original.names[k:] != motion.skeleton.names:
        raise ValueError("the motion's joints are not the original's below the folded chain")
    n_f = motion.n_frames
    pos = np.broadcast_to(original.offsets, (n_f, original.n_joints, 3)).copy()
    rot = np.broadcast_to(quat_identity(), (n_f, original.n_joints, 4)).copy()
    pos[:, k:] = motion.local_positions
    rot[:, k:] = motion.rotations
    for j in range(k):
        p = chain_pose[original.names[j]]
        pos[:, j] = p["position"]
        rot[:, j] = p["rotation"]
    # the chain's constant transform from joint 0's frame to joint k's parent's frame
    cq, cp = quat_identity(), np.zeros(3)
    for j in range(1, k):
        cp = cp + quat_rotate(cq, pos[0, j])
        cq = quat_mul(cq, rot[0, j])
    g_q, g_p = motion.rotations[:, 0], motion.local_positions[:, 0]  # joint k, world
    if any(c in POSITION_CHANNELS for c in original.channels[k]):
        top_q, top_p = rot[:, 0], pos[:, 0]  # held: joint k carries the motion
        par_q = quat_mul(top_q, cq[None])
        par_p = top_p + quat_rotate(top_q, np.broadcast_to(cp, (n_f, 3)))
        rot[:, k] = quat_mul(quat_conj(par_q), g_q)
        pos[:, k] = quat_rotate(quat_conj(par_q), g_p - par_p)
    else:  # joint k has its offset only: the top joint carries the motion, joint k is at rest
        rot[:, k] = quat_identity()
        rot[:, 0] = quat_mul(g_q, quat_conj(cq)[None])
        par_p = g_p - quat_rotate(g_q, np.broadcast_to(original.offsets[k], (n_f, 3)))
        pos[:, 0] = par_p - quat_rotate(rot[:, 0], np.broadcast_to(cp, (n_f, 3)))
    return Motion(original, motion.frame_time, pos, quat_normalize(rot))


def bones_from_channels(motion: Motion) -> tuple[Motion, dict[str, float]]:
    """Offsets of non-root joints with translation channels set to the mean translation.

    Returns ``(motion, variation)``: the motion (same frames; only rest offsets change, so
    forward kinematics is unchanged) and, per such joint, the largest distance of its
    translation from the mean over the clip (file units)."""
    sk = motion.skeleton
    has = sk.has_position_channels()
    new = sk.copy()
    variation = {}
    for j in np.flatnonzero(has):
        if j == 0:
            continue
        lp = motion.local_positions[:, j]
        mean = lp.mean(axis=0)
        new.offsets[j] = mean
        variation[sk.names[j]] = float(np.max(np.linalg.norm(lp - mean, axis=1)))
    return Motion(new, motion.frame_time, motion.local_positions, motion.rotations,
                  motion.source_channels), variation


# ------------------------------------------------------------------------------------------------
# the converter's normalisation, recorded so that a reference motion can repeat it
# ------------------------------------------------------------------------------------------------
#: degrees: the chain above the pelvis counts as statically rotated when its global rotation
#: stays this close to its first frame's (its rotation is then folded into the rest pose)
STATIC_ROTATION_DEG = 2.0


def fold_record(motion: Motion, k: int) -> dict:
    """What :func:`apply_record` needs to fold the chain above joint ``k`` of ``motion``:
    ``{"fold": [names above k], "fold_rotation": wxyz or None}``. The rotation is the chain's
    global rotation when it is static (within :data:`STATIC_ROTATION_DEG`) and not identity, so
    that the folded rest pose stays in the file's world axes."""
    sk = motion.skeleton
    rec = {"fold": list(sk.names[:k]), "fold_rotation": None}
    if motion.n_frames:
        g = forward_kinematics(motion).orientations[:, k - 1]
        dev = np.linalg.norm(quat_to_rotvec(quat_mul(quat_conj(g[:1]), g)), axis=-1)
        ang0 = np.linalg.norm(quat_to_rotvec(g[0]))
        if np.degrees(dev.max()) < STATIC_ROTATION_DEG and np.degrees(ang0) > 0.01:
            rec["fold_rotation"] = [float(x) for x in quat_normalize(g[0])]
    return rec


def undo_record(motion: Motion, record: dict | None, original: Skeleton | None) -> Motion:
    """The inverse of :func:`apply_record`: a motion on the normalised skeleton (e.g. exported
    from a model) on the file's ``original`` skeleton (its static chain above the pelvis, its
    translation-channel bones, its rest pose). Forward kinematics is unchanged. Without a
    record (or without the original) the motion is returned as it is."""
    if not record or original is None:
        return motion
    if record.get("rest"):
        motion = rerest(motion, quat_conj(_rest_array(motion.skeleton, record["rest"])))
    if record.get("fold"):
        if record.get("fold_rotation") is not None:
            q = quat_conj(np.asarray(record["fold_rotation"], dtype=float))
            motion = rerest(motion, np.tile(q, (motion.skeleton.n_joints, 1)))
        motion = unfold_root(motion, original, record.get("fold_pose") or {})
    sk = original.copy()
    pos = motion.local_positions.copy()
    has = sk.has_position_channels()
    keep = ~has  # joints without translation channels sit at the original's offsets
    keep[0] = False
    pos[:, keep] = sk.offsets[keep]
    return Motion(sk, motion.frame_time, pos, motion.rotations)


def apply_record(motion: Motion, record: dict | None,
                 normalised: Skeleton | None = None) -> Motion:
    """Apply a normalisation record (kept in a model's metadata as ``rig``) to a clip of the
    original skeleton. A clip already normalised (the folded joints absent, e.g. one exported
    from the model) is returned unchanged. Keys: ``fold`` (names above the new root),
    ``fold_rotation`` (wxyz or ``None``), ``bones`` (joints whose offsets come from their
    translation channels), ``rest`` (joint -> wxyz rest orientation). ``normalised``: the
    skeleton the record produces (the model's source skeleton); a clip already on it is
    returned unchanged."""
    if not record:
        return motion
    sk = motion.skeleton
    if normalised is not None and sk.names == normalised.names:
        tol = 1e-6 * max(float(np.abs(normalised.offsets).max()), 1e-12)
        if np.allclose(sk.offsets[1:], normalised.offsets[1:], atol=tol):
            return motion
    fold = record.get("fold") or []
    if fold and fold[0] not in sk.names:
        return motion  # already normalised
    if fold:
        motion = fold_root(motion, len(fold))
        if record.get("fold_rotation") is not None:
            q = np.asarray(record["fold_rotation"], dtype=float)
            motion = rerest(motion, np.tile(q, (motion.skeleton.n_joints, 1)))
    if record.get("bones"):
        motion, _ = bones_from_channels(motion)
    if record.get("rest"):
        motion = rerest(motion, _rest_array(motion.skeleton, record["rest"]))
    return motion


def _rest_array(sk: Skeleton, rest: dict) -> np.ndarray:
    """``(J, 4)`` rest orientations from a record's ``{joint: wxyz}`` (identity elsewhere)."""
    r = quat_identity((sk.n_joints,))
    for name, q in rest.items():
        r[sk.index(name)] = q
    return r
