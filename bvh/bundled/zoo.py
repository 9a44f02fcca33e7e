"""The rig zoo: real-world BVH layouts generated from known clips (pure kinematics).

Each :class:`ZooRig` is a shared clip (``walk60.bvh``, ``walk_forward.bvh``, GAMES-105 names,
metres, Y-up, facing +Z) or the bundled humanoid's walk, re-expressed the way exporters write
files: renamed to a naming convention, re-rooted under a static node, re-oriented so each bone
lies along its joint's local X axis or so the arms hang in an A-pose, rescaled, re-unitted,
re-axed, channel-reordered, with zero-length helper bones and 6-channel joints. Every step is
exact (:mod:`mjchar.bvh.rigs.layouts`): forward kinematics of a zoo rig is the source clip's, scaled
and rotated. A rig carries what it is (``convention``, ``unit``, ``up``, ``height_m``), so tests can
check the converter's guesses::

    from mjchar.bvh.bundled.zoo import zoo_rigs
    for rig in zoo_rigs("/path/to/shared/data/bvh"):
        rig.name, rig.convention, rig.unit, rig.up, rig.height_m
        bvh.save(rig.motion, f"{rig.name}.bvh")

``python -m mjchar.bvh.bundled.zoo SHARED_BVH_DIR OUT_DIR`` writes them all as BVH files.
"""

from __future__ import annotations

import os
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mjchar.bvh.io import load
from mjchar.bvh.io.motion import Motion
from mjchar.bvh.io.skeleton import POSITION_CHANNELS, Skeleton
from mjchar.bvh.rigs.layouts import rerest
from mjchar.bvh.rigs.units import UNIT_SCALES, transform_motion, up_axis_rotation
from mjchar.bvh.rotations import quat_conj, quat_from_rotvec, quat_identity, quat_mul, quat_rotate

__all__ = ["ZooRig", "zoo_rigs", "structure_rigs", "CONVENTIONS", "rename", "with_channels",
           "add_static_root", "insert_zero_length_joint", "bone_local_axes", "a_pose", "stature"]

_G = ("RootJoint", "pelvis_lowerback", "lowerback_torso", "torso_head")
_LIMB = ("Hip", "Knee", "Ankle", "ToeJoint", "Torso_Clavicle", "Shoulder", "Elbow", "Wrist")


#: the limb names of Mixamo, CMU and Perception Neuron exports (``_names``'s ``limb``)
_UPLEG_LIMB = ("{s}UpLeg", "{s}Leg", "{s}Foot", "{s}ToeBase", "{s}Shoulder", "{s}Arm",
               "{s}ForeArm", "{s}Hand")


def _names(trunk: tuple[str, str, str, str], limb, left: str, right: str,
           prefix: str = "") -> dict[str, str]:
    """GAMES-105 name -> convention name; ``limb`` has 8 patterns with ``{s}`` for the side;
    every name after ``prefix`` (an exporter's namespace, ``mixamorig:``)."""
    out = dict(zip(_G, trunk, strict=True))
    for g, pat in zip(_LIMB, limb, strict=True):
        out[f"l{g}"] = pat.format(s=left)
        out[f"r{g}"] = pat.format(s=right)
    return {g: prefix + n for g, n in out.items()}


#: naming conventions: GAMES-105 joint name -> the convention's name
CONVENTIONS: dict[str, dict[str, str]] = {
    "games": {n: n for n in _G} | {f"{s}{g}": f"{s}{g}" for s in "lr" for g in _LIMB},
    "cmu": _names(("Hips", "LowerBack", "Spine1", "Head"), _UPLEG_LIMB, "Left", "Right"),
    "mixamo": _names(("Hips", "Spine", "Spine1", "Head"), _UPLEG_LIMB, "Left", "Right",
                     prefix="mixamorig:"),
    "lafan1": _names(("Hips", "Spine", "Spine1", "Head"),
                     ("{s}UpLeg", "{s}Leg", "{s}Foot", "{s}Toe", "{s}Shoulder", "{s}Arm",
                      "{s}ForeArm", "{s}Hand"), "Left", "Right"),
    "unreal": _names(("pelvis", "spine_01", "spine_02", "head"),
                     ("thigh_{s}", "calf_{s}", "foot_{s}", "ball_{s}", "clavicle_{s}",
                      "upperarm_{s}", "lowerarm_{s}", "hand_{s}"), "l", "r"),
    "gamestudio": _names(("Hips", "Spine", "Chest", "Head"),
                         ("UpperLeg_{s}", "LowerLeg_{s}", "Foot_{s}", "Toes_{s}", "Shoulder_{s}",
                          "UpperArm_{s}", "LowerArm_{s}", "Hand_{s}"), "L", "R"),
    "smpl": _names(("Pelvis", "Spine1", "Spine2", "Head"),
                   ("{s}_Hip", "{s}_Knee", "{s}_Ankle", "{s}_Foot", "{s}_Collar", "{s}_Shoulder",
                    "{s}_Elbow", "{s}_Wrist"), "L", "R"),
    "blender": _names(("hips", "spine", "chest", "head"),
                      ("thigh.{s}", "shin.{s}", "foot.{s}", "toe.{s}", "shoulder.{s}",
                       "upper_arm.{s}", "forearm.{s}", "hand.{s}"), "L", "R"),
    "daz": _names(("hip", "abdomen", "chest", "head"),
                  ("{s}Thigh", "{s}Shin", "{s}Foot", "{s}Toe", "{s}Collar", "{s}Shldr",
                   "{s}ForeArm", "{s}Hand"), "l", "r"),
    "mixamo7": _names(("Hips", "Spine", "Spine1", "Head"), _UPLEG_LIMB, "Left", "Right",
                      prefix="mixamorig7:"),
    "xsens": _names(("Pelvis", "L5", "T8", "Head"),
                    ("{s}UpperLeg", "{s}LowerLeg", "{s}Foot", "{s}Toe", "{s}Shoulder",
                     "{s}UpperArm", "{s}ForeArm", "{s}Hand"), "Left", "Right"),
}


@dataclass
class ZooRig:
    """A generated rig and the truth about it.

    Attributes:
        name: short id, e.g. ``"unreal-cm-zup"``.
        motion: the clip on the rig (file units and axes), as a BVH file would hold it.
        convention: naming convention (a key of :data:`CONVENTIONS`).
        unit: the file unit (``"m"``, ``"cm"``, ``"mm"``, ``"in"``); ``unit_scale`` metres per unit.
        up: the file's world up axis (``"y"`` or ``"z"``).
        height_m: standing height of the figure (T-pose vertical extent of joints and end sites).
        source: the clip it was made from; ``features``: what was done to it.
        names: GAMES-105 joint name -> this rig's name (the essential joints).
        mass_kg: the total mass to convert it with (70 kg, the converter's default, for the
            clip rigs; the scaled humanoids are 1.5 m / 50 kg and 1.95 m / 100 kg).
    """

    name: str
    motion: Motion
    convention: str
    unit: str
    up: str
    height_m: float
    source: str
    features: list[str] = field(default_factory=list)
    names: dict[str, str] = field(default_factory=dict)
    mass_kg: float = 70.0

    @property
    def unit_scale(self) -> float:
        return UNIT_SCALES[self.unit]


# ------------------------------------------------------------------------------------------------
# re-expressions (each keeps every joint where it was)
# ------------------------------------------------------------------------------------------------
def rename(motion: Motion, mapping: dict[str, str]) -> Motion:
    """Joints renamed by ``mapping`` (others keep their names); end sites ``<joint>_end``."""
    sk = motion.skeleton.copy()
    sk.names = [mapping.get(n, n) for n in sk.names]
    sk.end_site_names = [f"{sk.names[p]}_end" for p in sk.end_site_parents]
    return Motion(Skeleton(sk.names, sk.parents, sk.offsets, sk.channels, sk.end_site_parents,
                           sk.end_site_offsets, sk.end_site_names),
                  motion.frame_time, motion.local_positions, motion.rotations)


def with_channels(motion: Motion, new: dict[str, tuple[str, ...]]) -> Motion:
    """Other channel lists for some joints, re-decoded from the channels they produce (so the
    motion is exactly what the file says). Added position channels carry the joint's local
    translation; reordered rotation channels keep every rotation."""
    sk = motion.skeleton.copy()
    for name, chans in new.items():
        sk.channels[sk.index(name)] = tuple(chans)
    m = Motion(sk, motion.frame_time, motion.local_positions.copy(), motion.rotations.copy())
    return Motion.from_channels(sk, motion.frame_time, m.to_channels())


def _rot(order: str) -> tuple[str, ...]:
    return tuple(f"{a}rotation" for a in order)


def all_channels(motion: Motion, order: str, six: bool = False) -> Motion:
    """Every joint's rotation channels in ``order`` (e.g. ``"ZXY"``); ``six``: every joint also
    gets ``X/Y/Zposition`` (the root always has them)."""
    sk = motion.skeleton
    return with_channels(motion, {
        n: (POSITION_CHANNELS if (j == 0 or six) else ()) + _rot(order)
        for j, n in enumerate(sk.names)})


def add_static_root(motion: Motion, name: str, rotation: np.ndarray | None = None,
                    six: bool = True) -> Motion:
    """A new root joint ``name`` at the origin holding a constant ``rotation`` (wxyz; identity
    by default); the old root becomes its child with its translation and rotation unchanged,
    so the whole figure turns by ``rotation`` (a rig authored in other axes than the file's
    world, e.g. a Z-up armature exported to a Y-up world). ``six``: the new root has 6 channels
    (else 3 rotation channels)."""
    sk = motion.skeleton
    q = np.array([1.0, 0, 0, 0]) if rotation is None else np.asarray(rotation, dtype=float)
    order = sk.rotation_order(0) or "ZXY"
    chans = (POSITION_CHANNELS if six else ()) + _rot(order)
    new = Skeleton([name] + list(sk.names), np.concatenate([[-1], sk.parents + 1]),
                   np.vstack([np.zeros(3), sk.offsets]),
                   [chans] + list(sk.channels), sk.end_site_parents + 1, sk.end_site_offsets,
                   list(sk.end_site_names))
    n_f = motion.n_frames
    pos = np.concatenate([np.zeros((n_f, 1, 3)), motion.local_positions], axis=1)
    rot = np.concatenate([np.tile(q, (n_f, 1, 1)), motion.rotations], axis=1)
    return Motion.from_channels(new, motion.frame_time,
                                Motion(new, motion.frame_time, pos, rot).to_channels())


def insert_zero_length_joint(motion: Motion, child: str, new_name: str,
                             channels: tuple[str, ...] = _rot("ZYX"),
                             rest_rotation: np.ndarray | None = None) -> Motion:
    """Insert ``new_name`` with a zero offset between ``child`` and its parent (a CMU-style
    ``LHipJoint`` helper). It holds the constant rotation ``rest_rotation`` (wxyz; default
    none); the child's offset, translation and rotation are expressed in the new joint's frame,
    so every original joint keeps its global position and orientation."""
    sk = motion.skeleton
    c = sk.index(child)
    idx = np.arange(sk.n_joints) + (np.arange(sk.n_joints) >= c)
    names = list(sk.names[:c]) + [new_name] + list(sk.names[c:])
    parents = np.empty(sk.n_joints + 1, dtype=int)
    parents[idx] = [idx[p] if p >= 0 else -1 for p in sk.parents]
    parents[c] = idx[sk.parents[c]]
    parents[c + 1] = c
    q = quat_identity() if rest_rotation is None else np.asarray(rest_rotation, dtype=float)
    qi = quat_conj(q)
    offsets = np.zeros((sk.n_joints + 1, 3))
    offsets[idx] = sk.offsets
    offsets[c + 1] = quat_rotate(qi, sk.offsets[c])
    chans = list(sk.channels[:c]) + [tuple(channels)] + list(sk.channels[c:])
    new = Skeleton(names, parents, offsets, chans, idx[sk.end_site_parents],
                   sk.end_site_offsets.copy(), list(sk.end_site_names))
    n_f = motion.n_frames
    lp = np.zeros((n_f, sk.n_joints + 1, 3))
    lp[:, idx] = motion.local_positions
    lp[:, c + 1] = quat_rotate(qi, motion.local_positions[:, c])
    rot = np.tile(q, (n_f, sk.n_joints + 1, 1))
    rot[:, idx] = motion.rotations
    rot[:, c + 1] = quat_mul(qi, motion.rotations[:, c])
    m = Motion(new, motion.frame_time, lp, rot)
    return Motion.from_channels(new, motion.frame_time, m.to_channels())


def _main_child_direction(sk: Skeleton, j: int, rest: np.ndarray) -> np.ndarray | None:
    kids = sk.children(j)
    vecs = [rest[c] - rest[j] for c in kids]
    vecs += [sk.end_site_offsets[e] for e in range(sk.n_end_sites) if sk.end_site_parents[e] == j]
    vecs = [v for v in vecs if np.linalg.norm(v) > 1e-9]
    if not vecs:
        return None
    if kids:  # the child whose subtree is largest continues the chain (spine over a clavicle)
        sizes = [sum(1 for k in range(sk.n_joints) if c in sk.chain(k)) for c in kids]
        v = rest[kids[int(np.argmax(sizes))]] - rest[j]
        if np.linalg.norm(v) > 1e-9:
            return v / np.linalg.norm(v)
    v = max(vecs, key=np.linalg.norm)
    return v / np.linalg.norm(v)


def bone_local_axes(motion: Motion, twist_deg: float = 23.0) -> Motion:
    """Rest re-oriented so each joint's bone (to its main child, or end site) lies along its
    local +X axis, with a twist about it of ``twist_deg * (j mod 3)`` degrees (real rigs'
    joint orients are arbitrary about the bone). The rest pose (all channels zero) is then no
    longer a T-pose, as in many game-engine exports; joint positions in every frame are kept."""
    sk = motion.skeleton
    rest = sk.rest_positions()  # world axes: the source rig's rest has identity orientations
    q = quat_identity((sk.n_joints,))
    for j in range(sk.n_joints):
        x = _main_child_direction(sk, j, rest)
        if x is None:
            q[j] = q[sk.parents[j]] if j else q[j]
            continue
        ref = np.array([0.0, 0.0, 1.0]) if abs(x[2]) < 0.9 else np.array([0.0, 1.0, 0.0])
        y = ref - (ref @ x) * x
        y /= np.linalg.norm(y)
        m = np.stack([x, y, np.cross(x, y)], axis=1)  # columns: the joint's axes in the world
        from scipy.spatial.transform import Rotation

        r = Rotation.from_matrix(m) * Rotation.from_rotvec(
            np.radians(twist_deg * (j % 3)) * np.array([1.0, 0, 0]))
        w = r.as_quat()
        q[j] = np.array([w[3], w[0], w[1], w[2]])
    return rerest(motion, quat_conj(q))


def a_pose(motion: Motion, shoulders: tuple[str, str], angle_deg: float = 40.0,
           forward: tuple[float, float, float] = (0.0, 0.0, 1.0)) -> Motion:
    """Rest with the arms lowered by ``angle_deg`` (an A-pose): every joint from each shoulder
    (the upper-arm joint) down gets the rest rotation about ``forward`` that turns its arm down.
    ``shoulders``: (left, right) joint names. Joint positions in every frame are kept."""
    sk = motion.skeleton
    rest = sk.rest_positions()
    r = quat_identity((sk.n_joints,))
    up = np.array([0.0, 1.0, 0.0])
    forward = np.asarray(forward, dtype=float)
    for sh in shoulders:
        s = sk.index(sh)
        arm = _main_child_direction(sk, s, rest)
        sign = -np.sign(np.cross(forward, arm) @ up) or 1.0
        q = quat_from_rotvec(sign * np.radians(angle_deg) * forward)
        for j in range(sk.n_joints):
            if s in sk.chain(j):
                r[j] = q
    return rerest(motion, r)


def stature(sk: Skeleton, up_index: int = 1) -> float:
    """Rest-pose vertical extent (joints and end sites) along axis ``up_index``, file units."""
    pts = sk.rest_positions()
    if sk.n_end_sites:
        pts = np.concatenate([pts, sk.rest_end_sites()])
    return float(pts[:, up_index].max() - pts[:, up_index].min())


def _units_axes(motion: Motion, scale_m: float, unit: str, up: str) -> Motion:
    rot = None if up == "y" else up_axis_rotation("y", up)
    return transform_motion(motion, scale_m / UNIT_SCALES[unit], rot)


def _half_rate(motion: Motion) -> Motion:
    return Motion(motion.skeleton, 2 * motion.frame_time, motion.local_positions[::2],
                  motion.rotations[::2])


# ------------------------------------------------------------------------------------------------
# the zoo
# ------------------------------------------------------------------------------------------------
def _rig(name, motion, convention, unit, up, height_m, source, features,
         mass_kg: float = 70.0, names: dict[str, str] | None = None) -> ZooRig:
    return ZooRig(name, motion, convention, unit, up, float(height_m), source, features,
                  dict(CONVENTIONS[convention]) if names is None else names, float(mass_kg))


def zoo_rigs(shared_bvh: str | os.PathLike | None = None, *, humanoid: bool = True,
             structures: bool = False) -> list[ZooRig]:
    """The zoo: rigs made from ``walk60.bvh`` and ``walk_forward.bvh`` in ``shared_bvh`` (skipped
    when the folder or a file is absent) and, with ``humanoid``, the bundled humanoid's walk on
    its skeleton scaled to 1.5 m and 1.95 m. With ``structures``, also the rigs of
    :func:`structure_rigs` (the structures of real exports: a CMU ASF rest, Daz names with a
    face and fingers, anonymous names on local-axis bones, namespaced names on a root near
    gimbal lock), made from ``walk60.bvh``."""
    out: list[ZooRig] = []
    clips = {}
    if shared_bvh is not None:
        for c in ("walk60", "walk_forward"):
            p = Path(shared_bvh) / f"{c}.bvh"
            if p.is_file():
                clips[c] = load(p)
    if "walk60" in clips:
        out += _from_clip(clips["walk60"], "walk60", even=True)
    if "walk_forward" in clips:
        out += _from_clip(clips["walk_forward"], "walk_forward", even=False)
    if humanoid:
        out += _humanoids()
    if structures and "walk60" in clips:
        out += structure_rigs(clips["walk60"], "walk60")
    return out


def _from_clip(m: Motion, src: str, even: bool) -> list[ZooRig]:
    h0 = stature(m.skeleton)  # metres, Y-up
    out = []
    conv = CONVENTIONS
    if even:
        # CMU: ZYX everywhere, inches, zero-length LHipJoint/RHipJoint helpers, Y-up
        r = rename(m, conv["cmu"])
        for s in ("Left", "Right"):
            r = insert_zero_length_joint(r, f"{s}UpLeg", f"{s[0]}HipJoint")
        r = all_channels(_units_axes(r, 1.0, "in", "y"), "ZYX")
        out.append(_rig("cmu-in-yup", r, "cmu", "in", "y", h0, src,
                        ["zero-length bones", "ZYX", "inches"]))
        # Unreal mannequin: static `root` above `pelvis`, local-X bones, cm, Z-up, scaled 1.80 m
        s = 1.80 / h0
        r = bone_local_axes(rename(m, conv["unreal"]))
        r = all_channels(_units_axes(r, s, "cm", "z"), "XYZ")
        r = add_static_root(r, "root")
        out.append(_rig("unreal-cm-zup", r, "unreal", "cm", "z", 1.80, src,
                        ["static root", "local-X bones", "rescaled"]))
        # game studio: static joint_Root, 6 channels everywhere, local-X bones, ZXY, cm, 30 fps
        r = bone_local_axes(rename(_half_rate(m), conv["gamestudio"]), twist_deg=-31.0)
        r = all_channels(_units_axes(r, 1.0, "cm", "y"), "ZXY", six=True)
        r = add_static_root(r, "joint_Root")
        out.append(_rig("gamestudio-cm-yup", r, "gamestudio", "cm", "y", h0, src,
                        ["static root", "6 channels on every joint", "local-X bones", "ZXY",
                         "30 fps"]))
        # Blender: .L/.R, a Z-up-authored armature under a static node turned to Y-up, metres
        r = rename(m, conv["blender"])
        zup = all_channels(_units_axes(r, 1.0, "m", "z"), "XYZ")
        r = add_static_root(zup, "Armature", rotation=up_axis_rotation("z", "y"), six=False)
        out.append(_rig("blender-m-yup-rotated-root", r, "blender", "m", "y", h0, src,
                        ["static root with a constant rotation", "Z-up rest under a Y-up world"]))
    else:
        # Mixamo: 6 channels on every joint, ZXY, cm, Y-up, scaled to 1.85 m
        s = 1.85 / h0
        r = all_channels(_units_axes(rename(m, conv["mixamo"]), s, "cm", "y"), "ZXY", six=True)
        out.append(_rig("mixamo-cm-yup", r, "mixamo", "cm", "y", 1.85, src,
                        ["6 channels on every joint", "ZXY", "rescaled"]))
        # LAFAN1: A-pose, ZYX, cm, Y-up
        r = a_pose(rename(m, conv["lafan1"]), ("LeftArm", "RightArm"), 40.0)
        r = all_channels(_units_axes(r, 1.0, "cm", "y"), "ZYX")
        out.append(_rig("lafan1-cm-yup-apose", r, "lafan1", "cm", "y", h0, src,
                        ["A-pose (arms 40 degrees down)", "ZYX"]))
        # SMPL: metres, Z-up, child-sized (1.25 m), A-pose
        s = 1.25 / h0
        r = a_pose(rename(m, conv["smpl"]), ("L_Shoulder", "R_Shoulder"), 30.0)
        r = all_channels(_units_axes(r, s, "m", "z"), "XYZ")
        out.append(_rig("smpl-m-zup-child", r, "smpl", "m", "z", 1.25, src,
                        ["A-pose (30 degrees)", "rescaled to 1.25 m"]))
        # Xsens: mm, Y-up, YXZ, a static Reference node, 2.05 m
        s = 2.05 / h0
        r = all_channels(_units_axes(rename(m, conv["xsens"]), s, "mm", "y"), "YXZ")
        r = add_static_root(r, "Reference")
        out.append(_rig("xsens-mm-yup-tall", r, "xsens", "mm", "y", 2.05, src,
                        ["static Reference node", "YXZ", "millimetres", "rescaled to 2.05 m"]))
    return out


def structure_rigs(m: Motion, src: str) -> list[ZooRig]:
    """The structures of real exports, made from one shared clip ``m`` (GAMES-105 skeleton,
    metres, Y-up, facing +Z) named ``src``; any clip of that skeleton gives the same skeletons:

    - ``cmu-asf-yup``: a CMU file as most people download it: CMU names, zero-length
      ``LHipJoint``/``RHipJoint``, the legs 20 degrees apart and the arms hanging in the rest,
      lengths in the ASF unit (1/0.45 inch), ZYX;
    - ``daz-cm-yup-face``: Daz/Poser names (``hip``, ``abdomen``, ``lThigh``, ``lShin``,
      ``lShldr``), a ``pelvis`` helper between ``hip`` and the thighs, five three-joint fingers
      per hand and a face (jaw, tongue, eyes, brows, ears) that never moves, cm, root ZYX,
      others ZXY;
    - ``lafan1-anon-cm-yup``: LAFAN1's layout with anonymous names (``Joint0``...), bones along
      local axes, no End Sites, cm, ZYX;
    - ``mixamo7-cm-yup-gimbal``: ``mixamorig7:`` names, 6 channels on every joint, ZXY, cm,
      a Z-up rest written into a Y-up file with no node above it: the root's middle Euler angle
      sits near -90 degrees (gimbal lock).
    """
    from mjchar.bvh.bundled.zoo_layouts import (
        add_chain,
        anonymise,
        insert_joint,
        spread_legs,
        strip_end_sites,
        turn_rest,
    )
    from mjchar.bvh.rotations import quat_from_rotvec

    h0 = stature(m.skeleton)
    conv = CONVENTIONS
    out = []
    # CMU ASF: zero-length hip helpers, legs apart, arms hanging, 1/0.45 inch, ZYX
    r = rename(m, conv["cmu"])
    for s in ("Left", "Right"):
        r = insert_joint(r, [f"{s}UpLeg"], f"{s[0]}HipJoint", (0.0, 0.0, 0.0))
    r = spread_legs(r, ("LeftUpLeg", "RightUpLeg"), 20.0)
    r = a_pose(r, ("LeftArm", "RightArm"), 90.0)
    r = all_channels(_units_axes(r, 1.0, "cmu", "y"), "ZYX")
    out.append(_rig("cmu-asf-yup", r, "cmu", "cmu", "y", h0, src,
                    ["zero-length hip joints", "legs 20 degrees apart", "arms hanging",
                     "CMU ASF unit", "ZYX"]))
    # Daz/Poser: hip above a pelvis helper, fingers, a face, cm
    r = rename(m, conv["daz"])
    r = insert_joint(r, ["lThigh", "rThigh"], "pelvis", (0.0, -0.03, 0.0))
    for s, x in (("l", 1.0), ("r", -1.0)):
        for finger, base, spread in (("Thumb", (0.02, -0.01, 0.03), 0.7),
                                     ("Index", (0.09, 0, 0.02), 0), ("Mid", (0.095, 0, 0), 0),
                                     ("Ring", (0.09, 0, -0.015), 0),
                                     ("Pinky", (0.08, 0, -0.03), 0)):
            step = (0.03 * x * (1 - 0.3 * spread), 0.0, 0.03 * spread)
            r = add_chain(r, f"{s}Hand", [(f"{s}{finger}1", (base[0] * x, base[1], base[2])),
                                          (f"{s}{finger}2", step), (f"{s}{finger}3", step)],
                          end=step)
    r = add_chain(r, "head", [("lowerJaw", (0.0, 0.02, 0.03)), ("tongueBase", (0.0, 0.0, 0.03)),
                              ("tongue01", (0.0, 0.0, 0.015)), ("tongue02", (0.0, 0.0, 0.015))],
                  end=(0.0, 0.0, 0.01))
    for s, x in (("l", 1.0), ("r", -1.0)):
        r = add_chain(r, "head", [(f"{s}Eye", (0.032 * x, 0.09, 0.08))], end=(0.0, 0.0, 0.02))
        r = add_chain(r, "head", [(f"{s}Ear", (0.075 * x, 0.07, 0.0))], end=(0.01 * x, 0.0, 0.0))
        r = add_chain(r, "head", [(f"{s}BrowInner", (0.015 * x, 0.12, 0.09))],
                      end=(0.01 * x, 0.0, 0.0))
    r = all_channels(_units_axes(r, 1.0, "cm", "y"), "ZXY")
    r = with_channels(r, {"hip": POSITION_CHANNELS + _rot("ZYX")})
    out.append(_rig("daz-cm-yup-face", r, "daz", "cm", "y", h0, src,
                    ["Daz names", "pelvis helper", "fingers", "face joints", "root ZYX, ZXY"]))
    # LAFAN1, anonymous: local-axis bones, no End Sites, cm, ZYX
    r = bone_local_axes(rename(m, conv["lafan1"]), twist_deg=17.0)
    r = all_channels(_units_axes(strip_end_sites(r), 1.0, "cm", "y"), "ZYX")
    r, anon = anonymise(r)
    out.append(_rig("lafan1-anon-cm-yup", r, "lafan1", "cm", "y", h0, src,
                    ["anonymous names", "local-X bones", "no End Sites", "ZYX"],
                    names={g: anon[n] for g, n in conv["lafan1"].items()}))
    # Mixamo, namespaced: a Z-up rest in a Y-up file (the root near gimbal lock), 6 channels
    r = turn_rest(rename(m, conv["mixamo7"]), quat_from_rotvec(np.radians(90.0) * np.eye(3)[0]))
    r = all_channels(_units_axes(r, 1.0, "cm", "y"), "ZXY", six=True)
    out.append(_rig("mixamo7-cm-yup-gimbal", r, "mixamo7", "cm", "y", h0, src,
                    ["namespaced names (mixamorig7:)", "6 channels on every joint",
                     "root near gimbal lock (a Z-up rest in a Y-up file)", "ZXY"]))
    return out


def _humanoids() -> list[ZooRig]:
    from mjchar.bvh.bundled.assets import motion_path

    m = load(motion_path("walk"))
    h0 = stature(m.skeleton)
    out = []
    for height, mass, unit, up in ((1.5, 50.0, "m", "z"), (1.95, 100.0, "in", "y")):
        r = all_channels(_units_axes(m, height / h0, unit, up), "XYZ")
        out.append(_rig(f"humanoid-{int(round(height * 100))}-{unit}-{up}up", r, "games", unit,
                        up, height, "bundled walk",
                        [f"bundled skeleton scaled to {height} m / {mass:g} kg"], mass))
    return out


def main(argv: list[str] | None = None) -> int:
    """``python -m mjchar.bvh.bundled.zoo SHARED_BVH_DIR OUT_DIR``: write every zoo rig as
    ``OUT_DIR/NAME.bvh``."""
    from mjchar.bvh.io import save

    argv = sys.argv[1:] if argv is None else argv
    if len(argv) != 2:
        print("usage: python -m mjchar.bvh.bundled.zoo SHARED_BVH_DIR OUT_DIR", file=sys.stderr)
        return 2
    os.makedirs(argv[1], exist_ok=True)
    for rig in zoo_rigs(argv[0], structures=True):
        save(rig.motion, os.path.join(argv[1], f"{rig.name}.bvh"))
        print(f"{rig.name}: {rig.convention}, {rig.unit}, {rig.up}-up, {rig.height_m:.2f} m, "
              f"{rig.mass_kg:g} kg, "
              f"{rig.motion.skeleton.n_joints} joints, {rig.motion.n_frames} frames")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

