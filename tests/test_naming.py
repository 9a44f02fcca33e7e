"""Joint role recognition (mjchar.bvh.rigs.naming) on the naming styles found in the wild.

The test skeletons below are authored here (numbers made up to look like each rig family):
a CMU-style 31-joint rig in inches with zero-length helper bones and ZYX channels, a
Mixamo-style rig in centimetres with ``mixamorig:`` names, fingers and ``*_End`` joints, a Z-up
copy of the project skeleton, and one with meaningless names.
"""

from __future__ import annotations

import numpy as np
import pytest

from mjchar import bvh
from mjchar.bvh.bundled.humanoid_skeleton import humanoid_skeleton
from mjchar.bvh.io.skeleton import Skeleton
from mjchar.bvh.rigs import units
from mjchar.bvh.rigs.naming import is_end, is_finger, is_twist, recognise, side_of, tokens
from mjchar.bvh.rigs.units import transform_motion, up_axis_rotation
from mjchar.bvh.rotations import quat_rotate

ZYX = ("Zrotation", "Yrotation", "Xrotation")
ZXY = ("Zrotation", "Xrotation", "Yrotation")


def build(joints, end_sites, rot, root_rot=None) -> Skeleton:
    """Skeleton from ``(name, parent, offset)`` rows and ``(parent, offset)`` end sites."""
    names = [j[0] for j in joints]
    parents = [-1 if p is None else names.index(p) for _, p, _ in joints]
    root_ch = ("Xposition", "Yposition", "Zposition", *(root_rot or rot))
    return Skeleton(
        names, np.array(parents), np.array([o for _, _, o in joints], dtype=float),
        [root_ch if p is None else rot for _, p, _ in joints],
        np.array([names.index(p) for p, _ in end_sites], dtype=int),
        np.array([o for _, o in end_sites], dtype=float).reshape(-1, 3),
    )


def cmu_skeleton() -> Skeleton:
    """CMU-style: 31 joints, inches, Y up, faces +Z, zero-length LHipJoint/LowerBack/Neck/
    LeftShoulder/LThumb bones, ZYX channels."""
    j = [("Hips", None, (0, 0, 0))]
    for s, x in (("L", 1.0), ("R", -1.0)):
        side = "Left" if s == "L" else "Right"
        j += [(f"{s}HipJoint", "Hips", (0, 0, 0)),
              (f"{side}UpLeg", f"{s}HipJoint", (3.6 * x, -3.8, 1.0)),
              (f"{side}Leg", f"{side}UpLeg", (0, -17.5, 0)),
              (f"{side}Foot", f"{side}Leg", (0, -17.0, 0)),
              (f"{side}ToeBase", f"{side}Foot", (0, -1.8, 4.8))]
    j += [("LowerBack", "Hips", (0, 0, 0)), ("Spine", "LowerBack", (0, 4.2, -0.2)),
          ("Spine1", "Spine", (0, 4.2, 0)), ("Neck", "Spine1", (0, 0, 0)),
          ("Neck1", "Neck", (0, 1.8, 0)), ("Head", "Neck1", (0, 1.8, 0))]
    for s, x in (("L", 1.0), ("R", -1.0)):
        side = "Left" if s == "L" else "Right"
        j += [(f"{side}Shoulder", "Spine1", (0, 0, 0)),
              (f"{side}Arm", f"{side}Shoulder", (6.0 * x, 1.0, 0)),
              (f"{side}ForeArm", f"{side}Arm", (11.0 * x, 0, 0)),
              (f"{side}Hand", f"{side}ForeArm", (9.5 * x, 0, 0)),
              (f"{side}FingerBase", f"{side}Hand", (1.5 * x, 0, 0)),
              (f"{side}HandIndex1", f"{side}FingerBase", (1.6 * x, 0, 0)),
              (f"{s}Thumb", f"{side}Hand", (0, 0, 0))]
    ends = [("LeftToeBase", (0, 0, 2.0)), ("RightToeBase", (0, 0, 2.0)), ("Head", (0, 7.0, 0)),
            ("LeftHandIndex1", (1.2, 0, 0)), ("RightHandIndex1", (-1.2, 0, 0)),
            ("LThumb", (1.2, 0, 1.2)), ("RThumb", (-1.2, 0, 1.2))]
    return build(j, ends, ZYX)


def mixamo_skeleton() -> Skeleton:
    """Mixamo-style: ``mixamorig:`` names, centimetres, Y up, faces +Z, fingers, *_End joints."""
    p = "mixamorig:"
    j = [(p + "Hips", None, (0, 0, 0)), (p + "Spine", p + "Hips", (0, 9.9, 1.2)),
         (p + "Spine1", p + "Spine", (0, 11.6, 0)), (p + "Spine2", p + "Spine1", (0, 13.2, 0)),
         (p + "Neck", p + "Spine2", (0, 14.9, 0.7)), (p + "Head", p + "Neck", (0, 10.3, 3.0)),
         (p + "HeadTop_End", p + "Head", (0, 18.4, 5.3))]
    for side, x in (("Left", 1.0), ("Right", -1.0)):
        j += [(f"{p}{side}Shoulder", p + "Spine2", (6.1 * x, 9.1, 0.7)),
              (f"{p}{side}Arm", f"{p}{side}Shoulder", (12.9 * x, 0, 0)),
              (f"{p}{side}ForeArm", f"{p}{side}Arm", (27.4 * x, 0, 0)),
              (f"{p}{side}Hand", f"{p}{side}ForeArm", (27.7 * x, 0, 0))]
        for finger, off in (("Thumb", (2.9, -1.0, 3.0)), ("Index", (9.5, 0, 2.6)),
                            ("Middle", (9.6, 0, 0.5))):
            prev = f"{p}{side}Hand"
            for k in range(1, 5):
                o = (off[0] * x, off[1], off[2]) if k == 1 else (3.0 * x, 0, 0)
                name = f"{p}{side}Hand{finger}{k}"
                j.append((name, prev, o))
                prev = name
        j += [(f"{p}{side}UpLeg", p + "Hips", (9.1 * x, -6.6, -0.4)),
              (f"{p}{side}Leg", f"{p}{side}UpLeg", (0, -40.6, 0.3)),
              (f"{p}{side}Foot", f"{p}{side}Leg", (0, -42.1, -1.2)),
              (f"{p}{side}ToeBase", f"{p}{side}Foot", (0, -10.5, 10.8)),
              (f"{p}{side}Toe_End", f"{p}{side}ToeBase", (0, 0, 8.4))]
    ends = [(name, (0, 1.0, 0)) for name, _, _ in j if name.endswith(("End", "4"))]
    return build(j, ends, ZXY, root_rot=ZXY)


def zup_skeleton() -> Skeleton:
    """The project skeleton turned Z up (Y -> Z): it then faces -Y with its left at +X."""
    m = transform_motion(bvh.Motion.rest(humanoid_skeleton()), 1.0, up_axis_rotation("y", "z"))
    return m.skeleton


def anonymous_skeleton() -> Skeleton:
    """The project skeleton with meaningless joint names (j0, j1, ...)."""
    sk = humanoid_skeleton()
    return Skeleton([f"j{i}" for i in range(sk.n_joints)], sk.parents, sk.offsets, sk.channels,
                    sk.end_site_parents, sk.end_site_offsets)


# ------------------------------------------------------------------------------------------------
def test_tokens_and_sides():
    assert tokens("mixamorig:LeftUpLeg") == ["left", "up", "leg"]
    assert tokens("lTorso_Clavicle") == ["l", "torso", "clavicle"]
    assert tokens("RHipJoint") == ["r", "hip", "joint"]
    assert tokens("LThumb") == ["l", "thumb"]
    for name, side in [("lKnee", "left"), ("rElbow", "right"), ("LeftLeg", "left"),
                       ("mixamorig:RightForeArm", "right"), ("knee.L", "left"),
                       ("Bip01 R Calf", "right"), ("L_Hip", "left"), ("Spine1", None),
                       ("pelvis_lowerback", None), ("Head", None)]:
        assert side_of(name) == side, name
    assert is_finger("LeftHandIndex1") and is_finger("LThumb") and is_finger("lFinger2")
    assert not is_finger("LeftHand") and not is_finger("LeftForeArm")
    assert is_end("mixamorig:HeadTop_End") and is_end("LeftToe_End") and not is_end("Head")


def test_games_naming(walk60):
    rec = recognise(bvh.load(walk60).skeleton)
    expected = {"pelvis": "RootJoint", "left_hip": "lHip", "left_knee": "lKnee",
                "left_ankle": "lAnkle", "left_toe": "lToeJoint", "right_toe": "rToeJoint",
                "left_clavicle": "lTorso_Clavicle", "left_shoulder": "lShoulder",
                "left_elbow": "lElbow", "left_wrist": "lWrist", "right_wrist": "rWrist",
                "head": "torso_head", "spine": ["pelvis_lowerback", "lowerback_torso"]}
    for role, name in expected.items():
        assert rec.roles[role] == name, role
    assert rec.unrecognised == [] and rec.by_structure == []
    np.testing.assert_allclose(rec.left_axis, [1, 0, 0], atol=1e-9)


def test_project_skeleton_naming():
    rec = recognise(humanoid_skeleton())
    assert rec.unrecognised == []
    assert len([r for r in rec.joint_roles.values() if r != "unknown"]) == 20


def test_cmu_naming():
    sk = cmu_skeleton()
    assert sk.n_joints == 31
    rec = recognise(sk)
    r = rec.roles
    assert (r["left_hip"], r["left_knee"], r["left_ankle"], r["left_toe"]) == \
        ("LeftUpLeg", "LeftLeg", "LeftFoot", "LeftToeBase")
    # CMU's LeftShoulder is the clavicle, LeftArm the shoulder joint
    assert (r["left_clavicle"], r["left_shoulder"], r["left_elbow"], r["left_wrist"]) == \
        ("LeftShoulder", "LeftArm", "LeftForeArm", "LeftHand")
    assert r["right_clavicle"] == "RightShoulder" and r["right_wrist"] == "RightHand"
    assert r["head"] == "Head" and r["pelvis"] == "Hips"
    assert r["spine"] == ["LowerBack", "Spine", "Spine1"] and r["neck"] == ["Neck", "Neck1"]
    for finger in ("LeftFingerBase", "LeftHandIndex1", "LThumb", "RThumb"):
        assert rec.joint_roles[finger] == "hand"
    # the zero-length helpers are not the hips
    assert rec.unrecognised == ["LHipJoint", "RHipJoint"]


def test_mixamo_naming():
    rec = recognise(mixamo_skeleton())
    p = "mixamorig:"
    r = rec.roles
    assert r["pelvis"] == p + "Hips" and r["head"] == p + "Head"
    assert r["left_knee"] == p + "LeftLeg" and r["right_hip"] == p + "RightUpLeg"
    assert r["left_toe"] == p + "LeftToeBase" and r["right_ankle"] == p + "RightFoot"
    assert r["left_clavicle"] == p + "LeftShoulder" and r["left_shoulder"] == p + "LeftArm"
    assert r["right_elbow"] == p + "RightForeArm" and r["right_wrist"] == p + "RightHand"
    assert r["spine"] == [p + "Spine", p + "Spine1", p + "Spine2"] and r["neck"] == [p + "Neck"]
    assert rec.joint_roles[p + "LeftHandThumb3"] == "hand"
    assert rec.joint_roles[p + "HeadTop_End"] == "end"
    assert rec.joint_roles[p + "LeftToe_End"] == "end"
    assert rec.unrecognised == []


def test_zup_naming():
    sk = zup_skeleton()
    assert units.guess_up_axis(sk) == "z"
    rec = recognise(sk)
    assert rec.roles["left_knee"] == "lKnee" and rec.roles["head"] == "torso_head"
    np.testing.assert_allclose(rec.left_axis, [1, 0, 0], atol=1e-9)


def test_legs_by_shape_when_names_say_nothing():
    sk = anonymous_skeleton()
    rec = recognise(sk)
    names = humanoid_skeleton().names
    j = {n: f"j{i}" for i, n in enumerate(names)}
    assert rec.roles["left_knee"] == j["lKnee"] and rec.roles["right_knee"] == j["rKnee"]
    assert rec.roles["left_hip"] == j["lHip"] and rec.roles["left_ankle"] == j["lAnkle"]
    assert rec.roles["head"] == j["torso_head"]
    assert j["lKnee"] in rec.by_structure
    # arms by shape: the chains branching sideways from the upper spine
    assert rec.roles["left_elbow"] == j["lElbow"] and rec.roles["right_elbow"] == j["rElbow"]
    assert rec.roles["left_shoulder"] == j["lShoulder"]
    assert rec.roles["left_clavicle"] == j["lTorso_Clavicle"]
    assert rec.roles["right_wrist"] == j["rWrist"]
    assert j["lElbow"] in rec.by_structure and rec.unrecognised == []


@pytest.mark.parametrize("name", ["lKnee", "LeftLeg", "mixamorig:LeftLeg", "L_Knee",
                                  "LeftLowerLeg", "LeftShin", "knee_l"])
def test_knee_spellings(name):
    sk = humanoid_skeleton()
    names = [name if n == "lKnee" else n for n in sk.names]
    rec = recognise(Skeleton(names, sk.parents, sk.offsets, sk.channels,
                             sk.end_site_parents, sk.end_site_offsets))
    assert rec.roles["left_knee"] == name and rec.by_structure == []


def test_namespaces_glued_sides_and_details():
    assert tokens("mixamorig7:LeftUpLeg") == ["left", "up", "leg"]
    assert tokens("Armature|LeftLeg") == ["left", "leg"]
    assert tokens("rknee") == ["r", "knee"] and tokens("lShldr") == ["l", "shldr"]
    assert tokens("finger2-2.r") == ["finger", "2", "2", "r"]
    for word in ("leg", "lower", "left", "right", "ring", "root", "lowerback"):
        assert tokens(word) == [word]  # not a side letter glued to a word
    for name, side in [("rcollar", "right"), ("lbuttock", "left"), ("finger2-2.r", "right"),
                       ("ltibia", "left"), ("Armature|RightForeArm", "right"),
                       ("abdomen", None), ("neck1", None)]:
        assert side_of(name) == side, name
    assert is_finger("metacarpal3.l") and is_finger("RightInHandIndex")
    assert is_finger("__rthumb") and not is_finger("rhand")
    assert is_twist("lForearmTwist") and is_twist("upperarm_twist_01_l")
    assert not is_twist("lForeArm")


def test_sides_from_the_knees_bend_in_any_pose():
    """Anonymous names on the bundled walk turned to lie face down (its toes point down and
    back along the ground, so where the feet point would swap the sides): the trunk x the
    knees' bend still tells the left leg and arm from the right ones."""
    from mjchar.bvh.bundled.assets import motion_path
    from mjchar.bvh.bundled.zoo_layouts import anonymise
    from mjchar.bvh.rigs.naming import Clip
    from mjchar.bvh.rotations import quat_from_rotvec, quat_mul

    m = bvh.load(motion_path("walk"))
    lying = m.copy()
    turn = quat_from_rotvec(np.radians(90.0) * np.eye(3)[0])  # face +Z -> face -Y (the floor)
    lying.rotations[:, 0] = quat_mul(turn, lying.rotations[:, 0])
    lying.local_positions[:, 0] = quat_rotate(turn, lying.local_positions[:, 0])
    anon, names = anonymise(lying)
    rec = recognise(anon.skeleton, np.eye(3)[1], clip=Clip.of(anon))
    for g, role in (("lKnee", "left_knee"), ("rHip", "right_hip"), ("lElbow", "left_elbow"),
                    ("rShoulder", "right_shoulder")):
        assert rec.roles[role] == names[g], role


def test_up_is_where_the_body_keeps_a_floor():
    """A crawl along +Z (made up: hips 0.45 m above the ankles and 0.7 m ahead of them, the
    lowest point always on the floor): the legs point more along Z than up, the floor says Y."""
    from mjchar.bvh.rigs import structure
    from mjchar.bvh.rigs.naming import Clip

    sk = humanoid_skeleton()
    n_f = 60
    rng = np.random.default_rng(3)
    z = np.linspace(0.0, 3.0, n_f)[:, None]
    P = np.zeros((n_f, sk.n_joints, 3))
    P[:, :, 1] = rng.uniform(0.05, 0.6, (n_f, sk.n_joints))  # everything between floor and hips
    P[:, :, 2] = z + rng.uniform(-0.8, 0.4, (n_f, sk.n_joints))
    P[:, :, 0] = rng.uniform(-0.3, 0.3, (n_f, sk.n_joints))
    legs = [(sk.index(f"{s}Hip"), sk.index(f"{s}Knee"), sk.index(f"{s}Ankle")) for s in "lr"]
    for h, k, a in legs:
        P[:, h] = np.c_[np.zeros(n_f), np.full(n_f, 0.5), z[:, 0]]
        P[:, k] = np.c_[np.zeros(n_f), np.full(n_f, 0.03), z[:, 0] - 0.3]
        P[:, a] = np.c_[np.zeros(n_f), np.full(n_f, 0.05), z[:, 0] - 0.7]
    P[:, sk.index("lToeJoint"), 1] = 0.0  # the floor
    clip = Clip(P, np.zeros(sk.n_joints, bool))
    assert structure.up_axis(sk, legs, clip) == "y"
