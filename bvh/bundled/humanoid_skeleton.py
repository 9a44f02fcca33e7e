"""The project's own 20-joint humanoid skeleton, from which the bundled model is converted.

Authored here as numbers (not copied from any file): the joint names of the GAMES-105 clips
(``RootJoint``, ``lHip``, ``lKnee``, ... ``torso_head``) so that those clips and the bundled
motions drive it directly, and proportions of a 1.64 m adult: metres, Y up, the character faces
+Z (its left is +X), T-pose with palms down. Every joint has three rotation channels
(``Xrotation Yrotation Zrotation``), the root also three position channels.

Heights in the T-pose with the feet on the floor as the converter places them (the sole 2.3 cm
below the toe joint, 7.3 cm below the ankle): root (pelvis centre) 0.933 m, shoulders 1.313 m,
neck 1.423 m, top of the head 1.633 m.
"""

from __future__ import annotations

import numpy as np

from mjchar.bvh.io.skeleton import Skeleton

_ROT = ("Xrotation", "Yrotation", "Zrotation")
_ROOT = ("Xposition", "Yposition", "Zposition", *_ROT)

#: (name, parent name, offset from the parent in metres, x = left, y = up, z = forward)
_JOINTS = (
    ("RootJoint", None, (0.0, 0.0, 0.0)),
    ("pelvis_lowerback", "RootJoint", (0.0, 0.10, 0.0)),
    ("lowerback_torso", "pelvis_lowerback", (0.0, 0.12, 0.0)),
    ("torso_head", "lowerback_torso", (0.0, 0.27, 0.0)),
    ("lTorso_Clavicle", "lowerback_torso", (0.02, 0.16, 0.0)),
    ("lShoulder", "lTorso_Clavicle", (0.13, 0.0, 0.0)),
    ("lElbow", "lShoulder", (0.27, 0.0, 0.0)),
    ("lWrist", "lElbow", (0.26, 0.0, 0.0)),
    ("rTorso_Clavicle", "lowerback_torso", (-0.02, 0.16, 0.0)),
    ("rShoulder", "rTorso_Clavicle", (-0.13, 0.0, 0.0)),
    ("rElbow", "rShoulder", (-0.27, 0.0, 0.0)),
    ("rWrist", "rElbow", (-0.26, 0.0, 0.0)),
    ("lHip", "RootJoint", (0.095, -0.055, 0.0)),
    ("lKnee", "lHip", (0.0, -0.41, 0.0)),
    ("lAnkle", "lKnee", (0.0, -0.395, 0.0)),
    ("lToeJoint", "lAnkle", (0.0, -0.05, 0.13)),
    ("rHip", "RootJoint", (-0.095, -0.055, 0.0)),
    ("rKnee", "rHip", (0.0, -0.41, 0.0)),
    ("rAnkle", "rKnee", (0.0, -0.395, 0.0)),
    ("rToeJoint", "rAnkle", (0.0, -0.05, 0.13)),
)

#: (parent name, offset): head top, hand tips (middle finger) and toe tips
_END_SITES = (
    ("torso_head", (0.0, 0.21, 0.0)),
    ("lWrist", (0.17, 0.0, 0.0)),
    ("rWrist", (-0.17, 0.0, 0.0)),
    ("lToeJoint", (0.0, 0.0, 0.05)),
    ("rToeJoint", (0.0, 0.0, 0.05)),
)

#: height of the root above the floor in the T-pose (m): root to ankle plus the ankle height
#: (the converter's sole level: 2.5 cm x height / 1.75 m under the toe joint)
ROOT_HEIGHT = 0.933


def humanoid_skeleton() -> Skeleton:
    """The project's default 20-joint skeleton (metres, Y up, faces +Z), rest pose = T-pose.

    Returns:
        A :class:`~mjchar.bvh.io.skeleton.Skeleton` with 20 joints and 5 end sites.
    """
    names = [j[0] for j in _JOINTS]
    parents = [-1 if p is None else names.index(p) for _, p, _ in _JOINTS]
    offsets = np.array([o for _, _, o in _JOINTS], dtype=float)
    channels = [_ROOT if p is None else _ROT for _, p, _ in _JOINTS]
    return Skeleton(
        names=names,
        parents=np.array(parents),
        offsets=offsets,
        channels=channels,
        end_site_parents=np.array([names.index(p) for p, _ in _END_SITES]),
        end_site_offsets=np.array([o for _, o in _END_SITES], dtype=float),
    )


def humanoid_rest_motion(n_frames: int = 1, frame_time: float = 1 / 60):
    """The T-pose as a :class:`~mjchar.bvh.io.motion.Motion` with the root at
    :data:`ROOT_HEIGHT`."""
    from mjchar.bvh.io.motion import Motion

    m = Motion.rest(humanoid_skeleton(), n_frames, frame_time)
    m.local_positions[:, 0] = [0.0, ROOT_HEIGHT, 0.0]
    return m
