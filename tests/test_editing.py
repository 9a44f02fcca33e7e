"""Tests of mjchar.bvh.editing.clips: mirror, retarget between rest poses, align, concatenate."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import shared_clip

from mjchar import bvh
from mjchar.bvh.editing.clips import (
    EditingError,
    align,
    concatenate,
    derive_rest_rotations,
    guess_lateral_axis,
    match_joint_order,
    mirror,
    mirror_name,
    mirror_pairs,
    retarget,
)
from mjchar.bvh.errors import MjcharError
from mjchar.bvh.rotations import (
    heading_angle,
    quat_conj,
    quat_from_rotvec,
    quat_identity,
    quat_mul,
    quat_rotate,
    quat_to_rotvec,
)

ROT3 = ("Zrotation", "Xrotation", "Yrotation")
POS_ROT = ("Xposition", "Yposition", "Zposition") + ROT3


# -- synthetic data --------------------------------------------------------------------------------
def _mixamo_skeleton(asymmetric: bool = False) -> bvh.Skeleton:
    """A Z-up humanoid facing +X with its left on +Y, named like Mixamo rigs."""
    p = "mixamorig:"
    joints = [  # name, parent, offset
        ("Hips", None, [0, 0, 0]),
        ("Spine", "Hips", [0, 0, 0.2]),
        ("Head", "Spine", [0, 0, 0.35]),
        ("LeftUpLeg", "Hips", [0, 0.1, -0.05]),
        ("LeftLeg", "LeftUpLeg", [0, 0, -0.42]),
        ("LeftFoot", "LeftLeg", [0, 0, -0.4]),
        ("RightUpLeg", "Hips", [0, -0.1, -0.05]),
        ("RightLeg", "RightUpLeg", [0, 0, -0.42]),
        ("RightFoot", "RightLeg", [0, 0, -0.4]),
        ("LeftShoulder", "Spine", [0, 0.04, 0.28]),
        ("LeftArm", "LeftShoulder", [0, 0.13, 0]),
        ("LeftForeArm", "LeftArm", [0, 0.26, 0]),
        ("RightShoulder", "Spine", [0, -0.04, 0.28]),
        ("RightArm", "RightShoulder", [0, -0.13, 0]),
        ("RightForeArm", "RightArm", [0, -0.26, 0]),
    ]
    names = [p + n for n, _, _ in joints]
    parents = [-1 if par is None else names.index(p + par) for _, par, _ in joints]
    offsets = np.array([o for _, _, o in joints], dtype=float)
    if asymmetric:
        offsets[names.index(p + "LeftLeg")] = [0.02, 0.01, -0.45]
    chans = [POS_ROT] + [ROT3] * (len(names) - 1)
    ends = [names.index(p + n) for n in ("Head", "LeftFoot", "RightFoot", "LeftForeArm",
                                         "RightForeArm")]
    end_off = [[0, 0, 0.15], [0.15, 0, -0.05], [0.15, 0, -0.05], [0, 0.25, 0], [0, -0.25, 0]]
    return bvh.Skeleton(names, parents, offsets, chans, ends, end_off)


def _random_motion(sk: bvh.Skeleton, n: int = 40, seed: int = 0, frame_time: float = 1 / 30,
                   heading0: float = 0.0, turn: float = 0.0) -> bvh.Motion:
    """Smooth random joint rotations; the root walks forward (+X of its heading, Z up)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * frame_time
    amp = rng.uniform(0.1, 0.6, size=(sk.n_joints, 3))
    ph = rng.uniform(0, 2 * np.pi, size=(sk.n_joints, 3))
    rot = quat_from_rotvec(amp * np.sin(2 * np.pi * t[:, None, None] + ph))
    heading = heading0 + turn * t
    tilt = quat_from_rotvec(0.05 * np.stack([np.sin(3 * t), np.cos(2 * t), 0 * t], axis=1))
    rot[:, 0] = quat_mul(quat_from_rotvec(np.stack([0 * t, 0 * t, heading], axis=1)), tilt)
    speed = 1.2
    step = speed * frame_time * np.stack([np.cos(heading), np.sin(heading), 0 * t], axis=1)
    pos = np.broadcast_to(sk.offsets, (n, sk.n_joints, 3)).copy()
    pos[:, 0] = np.cumsum(step, axis=0) + np.array([rng.normal(), rng.normal(), 0.9])
    pos[:, 0, 2] += 0.02 * np.sin(4 * np.pi * t)
    return bvh.Motion(sk, frame_time, pos, rot)


def _reflect(v: np.ndarray, axis: int) -> np.ndarray:
    out = np.array(v, dtype=float, copy=True)
    out[..., axis] *= -1.0
    return out


def _angle(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.linalg.norm(quat_to_rotvec(quat_mul(quat_conj(a), b)), axis=-1)


# -- names -----------------------------------------------------------------------------------------
@pytest.mark.parametrize("name, expected", [
    ("lHip", "rHip"), ("rToeJoint", "lToeJoint"), ("LHip", "RHip"), ("L_Hip", "R_Hip"),
    ("l_hip", "r_hip"), ("LeftArm", "RightArm"), ("leftArm", "rightArm"),
    ("left_arm", "right_arm"), ("LEFT_ARM", "RIGHT_ARM"), ("hip_left", "hip_right"),
    ("ArmRight", "ArmLeft"), ("Hip.L", "Hip.R"), ("hip_r", "hip_l"), ("HipL", "HipR"),
    ("mixamorig:LeftHand", "mixamorig:RightHand"),
    ("mixamorig1:RightUpLeg", "mixamorig1:LeftUpLeg"),
    ("Bip01 L Thigh", "Bip01 R Thigh"), ("Bip01_Left_Arm", "Bip01_Right_Arm"),
    ("lTorso_Clavicle", "rTorso_Clavicle"),
    ("Hips", None), ("RootJoint", None), ("Spine1", None), ("mixamorig:Head", None),
    ("Leg", None), ("Root", None), ("pelvis_lowerback", None),
])
def test_mirror_name(name, expected):
    assert mirror_name(name) == expected


def test_mirror_name_only_returns_existing_partners():
    names = ["LOWERBACK", "LHip", "RHip"]
    assert mirror_name("LOWERBACK") == "ROWERBACK"  # looks sided on its own...
    assert mirror_name("LOWERBACK", names) is None  # ...but has no partner: a centre joint
    assert mirror_name("LHip", names) == "RHip"


def test_mirror_pairs_and_lateral_axis(walk60):
    sk = bvh.load(walk60).skeleton
    partner = mirror_pairs(sk)
    for j, name in enumerate(sk.names):
        other = sk.names[partner[j]]
        if name[0] in "lr" and name[1].isupper():
            assert other == ("r" if name[0] == "l" else "l") + name[1:]
        else:
            assert other == name
    assert guess_lateral_axis(sk) == "x"
    assert guess_lateral_axis(_mixamo_skeleton()) == "y"


def test_mirror_pairs_errors():
    sk = _mixamo_skeleton()
    lonely = sk.copy()
    lonely.names[sk.index("mixamorig:RightForeArm")] = "mixamorig:Forearm2"
    with pytest.raises(EditingError, match="no mirrored joint"):
        mirror_pairs(lonely)
    # explicit pairs fix it
    partner = mirror_pairs(lonely, pairs={"mixamorig:LeftForeArm": "mixamorig:Forearm2"})
    assert lonely.names[partner[lonely.index("mixamorig:Forearm2")]] == "mixamorig:LeftForeArm"
    with pytest.raises(EditingError, match="unknown joint"):
        mirror_pairs(sk, pairs={"nope": "mixamorig:Head"})
    centre_only = bvh.Skeleton(["a", "b"], [-1, 0], [[0, 0, 0], [0, 1, 0]], [POS_ROT, ROT3])
    with pytest.raises(EditingError, match="lateral axis"):
        mirror(bvh.Motion.rest(centre_only, 2))
    with pytest.raises(MjcharError):
        mirror(_random_motion(sk, 3), axis="w")


# -- mirror ----------------------------------------------------------------------------------------
def _check_mirror(m: bvh.Motion) -> None:
    mm = mirror(mirror(m))
    np.testing.assert_allclose(mm.rotations, m.rotations, atol=1e-9)
    np.testing.assert_allclose(mm.local_positions, m.local_positions, atol=1e-9)


def test_mirror_twice_is_identity_walk60(walk60):
    _check_mirror(bvh.load(walk60))


@pytest.mark.parametrize("asymmetric", [False, True])
def test_mirror_twice_is_identity_synthetic(asymmetric):
    _check_mirror(_random_motion(_mixamo_skeleton(asymmetric), seed=1))


def _check_swapped(m: bvh.Motion, axis: int, atol: float) -> None:
    sk = m.skeleton
    partner = mirror_pairs(sk)
    mir = mirror(m)
    fk, fk_m = bvh.forward_kinematics(m), bvh.forward_kinematics(mir)
    # every joint of the mirror is the reflected partner of the original (feet included)
    np.testing.assert_allclose(fk_m.positions, _reflect(fk.positions[:, partner], axis), atol=atol)
    # end sites too (the two feet's toes)
    es, es_m = bvh.end_site_positions(m, fk), bvh.end_site_positions(mir, fk_m)
    end_partner = [sk.end_site_names.index(mirror_name(n, sk.end_site_names) or n)
                   for n in sk.end_site_names]
    np.testing.assert_allclose(es_m, _reflect(es[:, end_partner], axis), atol=atol)


def test_mirror_swaps_left_and_right_feet_walk60(walk60):
    m = bvh.load(walk60)
    sk = m.skeleton
    _check_swapped(m, 0, 1e-9)
    mir = mirror(m)
    left_of_mirror = bvh.forward_kinematics(mir).positions[:, sk.index("lAnkle")]
    right_of_original = bvh.forward_kinematics(m).positions[:, sk.index("rAnkle")]
    np.testing.assert_allclose(left_of_mirror, _reflect(right_of_original, 0), atol=1e-9)
    # and the clip really moved: the feet are not trivially symmetric
    assert np.abs(left_of_mirror - right_of_original).max() > 0.1


def test_mirror_swaps_sides_synthetic():
    _check_swapped(_random_motion(_mixamo_skeleton(), seed=2), 1, 1e-9)


def test_mirror_about_explicit_axis_vector():
    m = _random_motion(_mixamo_skeleton(), seed=3)
    a = mirror(m, axis="y")
    b = mirror(m, axis=np.array([0.0, -2.0, 0.0]))
    np.testing.assert_allclose(a.rotations, b.rotations, atol=1e-12)
    np.testing.assert_allclose(a.local_positions, b.local_positions, atol=1e-12)


# -- joint order -----------------------------------------------------------------------------------
def test_match_joint_order_keeps_global_positions():
    a = bvh.load(shared_clip("walk60.bvh"))
    b = bvh.load(shared_clip("walk_and_turn_right.bvh"))
    assert a.skeleton.names != b.skeleton.names  # same joints, another file order
    r = match_joint_order(b, a.skeleton)
    assert r.skeleton.names == a.skeleton.names
    np.testing.assert_array_equal(r.skeleton.parents, a.skeleton.parents)
    order = [b.skeleton.names.index(n) for n in a.skeleton.names]
    np.testing.assert_allclose(bvh.forward_kinematics(r).positions,
                               bvh.forward_kinematics(b).positions[:, order], atol=1e-12)
    np.testing.assert_allclose(bvh.end_site_positions(r), bvh.end_site_positions(b), atol=1e-12)
    other = bvh.Skeleton(["x", "y"], [-1, 0], [[0, 0, 0], [0, 1, 0]], [POS_ROT, ROT3])
    with pytest.raises(EditingError, match="different joints"):
        match_joint_order(b, other)


# -- retarget --------------------------------------------------------------------------------------
def _repose(m: bvh.Motion, R: np.ndarray) -> bvh.Motion:
    """The same global motion on a skeleton whose rest pose differs by global rest rotations.

    With ``R_j`` the rotation that retargeting must apply, the new skeleton's bones are
    ``R_p^-1 o_c`` and the compensating local rotations ``R_p^-1 r_j R_j``.
    """
    sk = m.skeleton
    par = sk.parents
    R_par = np.where((par >= 0)[:, None], R[np.maximum(par, 0)], quat_identity((sk.n_joints,)))
    src = sk.copy()
    src.offsets = quat_rotate(quat_conj(R_par), sk.offsets)
    src.end_site_offsets = quat_rotate(quat_conj(R[sk.end_site_parents]), sk.end_site_offsets)
    pos = np.broadcast_to(src.offsets, m.local_positions.shape).copy()
    pos[:, 0] = m.local_positions[:, 0]
    rot = quat_mul(quat_mul(quat_conj(R_par), m.rotations), R)
    return bvh.Motion(src, m.frame_time, pos, rot)


def _a_pose_rotations(sk: bvh.Skeleton, down_axis: np.ndarray, degrees: float = 45.0) -> np.ndarray:
    """Rest rotations that bring the arms of an A-pose (arms ``degrees`` down) to a T-pose."""
    R = quat_identity((sk.n_joints,))
    a = np.radians(degrees)
    for j, name in enumerate(sk.names):
        low = name.lower()
        if any(k in low for k in ("shoulder", "elbow", "wrist")) and "clavicle" not in low:
            side = 1.0 if mirror_name(name, sk.names) and (low.startswith("l")) else -1.0
            R[j] = quat_from_rotvec(side * a * down_axis)
    return R


def _max_position_error(a: bvh.Motion, b: bvh.Motion) -> float:
    fa, fb = bvh.forward_kinematics(a), bvh.forward_kinematics(b)
    return max(np.abs(fa.positions - fb.positions).max(),
               np.abs(bvh.end_site_positions(a, fa) - bvh.end_site_positions(b, fb)).max())


def test_retarget_a_pose_onto_t_pose_walk60(walk60):
    m = bvh.load(walk60)
    sk = m.skeleton
    # walk60 is Y-up and faces +Z with its left on +X: arms point along +-X, so "down" is a
    # rotation about the forward axis Z; left arm: R = +45 degrees about Z takes the A-pose arm
    # (rotated -45 degrees, pointing down-left) back up to +X
    R = _a_pose_rotations(sk, np.array([0.0, 0.0, 1.0]))
    assert np.count_nonzero(np.abs(R[:, 0] - 1) > 1e-9) == 6
    a_pose = _repose(m, R)
    elbow = a_pose.skeleton.offsets[sk.index("lElbow")]
    assert np.degrees(np.arctan2(-elbow[1], elbow[0])) == pytest.approx(45.0)  # arms down 45
    assert _max_position_error(a_pose, m) < 1e-12  # the A-pose clip is the same motion
    assert np.abs(a_pose.rotations - m.rotations).max() > 0.3  # with other local rotations
    out = retarget(a_pose, sk)
    assert out.skeleton is sk
    assert _max_position_error(out, m) < 1e-6
    np.testing.assert_allclose(derive_rest_rotations(a_pose.skeleton, sk), R, atol=1e-12)
    assert _angle(out.rotations, m.rotations).max() < 1e-6


def test_retarget_random_rest_change_synthetic():
    sk = _mixamo_skeleton()
    m = _random_motion(sk, seed=4)
    rng = np.random.default_rng(5)
    R = quat_from_rotvec(rng.normal(scale=0.5, size=(sk.n_joints, 3)))
    # rest changes at joints with several children must be rigid (one R per joint): they are
    src = _repose(m, R)
    assert _max_position_error(src, m) < 1e-12
    # derived rest rotations: directions only (twist about single bones is not observable)
    out = retarget(src, sk)
    assert _max_position_error(out, m) < 1e-6
    # given rest rotations: also the local rotations come back
    out = retarget(src, sk, rest_rotations=R)
    assert _max_position_error(out, m) < 1e-9
    assert _angle(out.rotations, m.rotations).max() < 1e-9


def test_retarget_identity_and_joint_order():
    a = bvh.load(shared_clip("walk60.bvh"))
    target = bvh.load(shared_clip("walk_and_turn_right.bvh")).skeleton  # same rest, other order
    out = retarget(a, target)
    assert out.skeleton.names == target.names
    order = [a.skeleton.names.index(n) for n in target.names]
    np.testing.assert_allclose(bvh.forward_kinematics(out).positions,
                               bvh.forward_kinematics(a).positions[:, order], atol=1e-12)
    with pytest.raises(EditingError):
        retarget(a, target, rest_rotations=np.ones((3, 4)))


# -- align and concatenate -------------------------------------------------------------------------
def test_align_matches_heading_and_horizontal_position():
    sk = _mixamo_skeleton()
    m = _random_motion(sk, seed=6, heading0=1.0, turn=0.3)
    target_q = quat_from_rotvec([0.0, 0.0, -2.0])
    target_p = np.array([5.0, -3.0, 7.0])
    out = align(m, target_q, target_p, frame=5, up="z")
    assert heading_angle(out.rotations[5, 0], "z") == pytest.approx(-2.0)
    np.testing.assert_allclose(out.root_positions[5, :2], target_p[:2], atol=1e-12)
    np.testing.assert_allclose(out.root_positions[:, 2], m.root_positions[:, 2], atol=1e-12)
    # rigid in the ground plane: step lengths and joint rotations unchanged
    np.testing.assert_allclose(np.linalg.norm(np.diff(out.root_positions, axis=0), axis=1),
                               np.linalg.norm(np.diff(m.root_positions, axis=0), axis=1))
    np.testing.assert_allclose(out.rotations[:, 1:], m.rotations[:, 1:])
    with pytest.raises(EditingError):
        align(m, target_q, target_p, frame=100, up="z")


def _steps(m: bvh.Motion) -> np.ndarray:
    return np.linalg.norm(np.diff(m.root_positions, axis=0), axis=1)


def _heading_steps(m: bvh.Motion, up: str) -> np.ndarray:
    d = np.diff(heading_angle(m.rotations[:, 0], up))
    return np.abs((d + np.pi) % (2 * np.pi) - np.pi)


def _check_concatenation(a: bvh.Motion, b: bvh.Motion, up: str, blend: int) -> bvh.Motion:
    c = concatenate(a, b, blend_frames=blend)
    n_a = a.n_frames
    assert c.frame_time == a.frame_time
    np.testing.assert_allclose(c.local_positions[:n_a], a.local_positions)
    np.testing.assert_allclose(c.rotations[:n_a], a.rotations)
    # no root jump: the seam step is no larger than the clips' own largest step
    own = max(_steps(a).max(), _steps(b).max())
    seam = _steps(c)[n_a - 2: n_a + 1]
    assert seam.max() <= own + 1e-9
    # heading continuous: the seam's heading change is no larger than the clips' own
    own_h = max(_heading_steps(a, up).max(), _heading_steps(b, up).max())
    assert _heading_steps(c, up)[n_a - 2: n_a + 1].max() <= own_h + 1e-9
    return c


@pytest.mark.parametrize("blend", [0, 10])
def test_concatenate_walk60_and_walk_and_turn(blend):
    a = bvh.load(shared_clip("walk60.bvh"))
    b = bvh.load(shared_clip("walk_and_turn_right.bvh"))
    c = _check_concatenation(a, b, "y", blend)
    assert c.n_frames == a.n_frames + b.n_frames - 1
    assert c.skeleton.names == a.skeleton.names
    # b's own motion is kept after the transition: its root path, turned and shifted rigidly
    n_a = a.n_frames
    bb = match_joint_order(b, a.skeleton)
    np.testing.assert_allclose(_steps(c)[n_a + blend:], _steps(bb)[blend + 1:], atol=1e-9)
    np.testing.assert_allclose(c.rotations[n_a + blend:, 1:], bb.rotations[blend + 1:, 1:],
                               atol=1e-9)
    # the clip ends after turning right by b's own turn
    turn_b = heading_angle(b.rotations[-1, 0]) - heading_angle(b.rotations[0, 0])
    turn_c = heading_angle(c.rotations[-1, 0]) - heading_angle(a.rotations[-1, 0])
    assert np.cos(turn_c - turn_b) == pytest.approx(1.0)


def test_concatenate_blending_removes_the_pose_jump():
    a = bvh.load(shared_clip("walk60.bvh"))
    b = bvh.load(shared_clip("walk_and_turn_right.bvh"))
    n_a = a.n_frames

    def joint_steps(m):
        p = bvh.forward_kinematics(m).positions
        return np.linalg.norm(np.diff(p, axis=0), axis=-1).max(axis=1)

    own = max(joint_steps(a).max(), joint_steps(b).max())
    hard = joint_steps(concatenate(a, b, blend_frames=0))[n_a - 1]
    smooth = joint_steps(concatenate(a, b, blend_frames=10))[n_a - 2: n_a + 11]
    assert hard > own  # a hard cut jumps (measured 0.149 m vs the clips' own 0.076 m)
    assert smooth.max() <= own  # the blended transition does not (measured 0.053 m)


def test_concatenate_synthetic_with_other_frame_time():
    sk = _mixamo_skeleton()
    a = _random_motion(sk, n=60, seed=7, frame_time=1 / 60, heading0=0.3, turn=0.5)
    b = _random_motion(sk, n=31, seed=8, frame_time=1 / 30, heading0=-2.5, turn=-0.4)
    c = _check_concatenation(a, b, "z", 6)
    assert c.n_frames == a.n_frames + 61 - 1  # b resampled to 1/60 s: 61 frames
    # after the transition b keeps its own turning rate (-0.4 rad/s) in its new direction
    h = np.unwrap(heading_angle(c.rotations[a.n_frames + 10:, 0], "z"))
    np.testing.assert_allclose(np.diff(h) / c.frame_time, -0.4, atol=0.05)
    with pytest.raises(EditingError):
        concatenate(a, b, blend_frames=-1)
