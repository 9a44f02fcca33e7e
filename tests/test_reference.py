"""Reference motions in a converted model's coordinates (mjchar.bvh.reference.reference_motion).

Measured figures (worst errors per clip) are printed with ``pytest -s``; the assertions hold the
limits: exact replay within 1 mm on the ``full`` model, and on the default ``hinge`` model end
effectors within 1 cm and every joint within 3 cm after the projection IK.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from conftest import SHARED_CLIPS, shared_clip

from mjchar import bvh
from mjchar.bvh.bundled.humanoid_skeleton import humanoid_rest_motion, humanoid_skeleton
from mjchar.bvh.io.motion import Motion
from mjchar.bvh.io.skeleton import Skeleton
from mjchar.bvh.mjcf import convert
from mjchar.bvh.reference.reference_motion import (
    ReferenceMotion,
    ReferenceMotionError,
    _geom_local_points,
    _QposAlgebra,
    replay_errors,
)
from mjchar.bvh.rigs.units import transform_motion, up_axis_rotation
from mjchar.bvh.rotations import heading_angle, quat_from_rotvec, quat_mul

EXACT_MM = 1.0
EE_LIMIT_MM = 10.0
JOINT_LIMIT_MM = 30.0

_MODELS: dict = {}


def _model(source, joint_model: str, key: str):
    """Compiled conversion of ``source`` (cached per key and joint model)."""
    k = (key, joint_model)
    if k not in _MODELS:
        _MODELS[k] = convert(source, joint_model=joint_model).compile()
    return _MODELS[k]


# ------------------------------------------------------------------------------------------------
# project-made skeletons: CMU-like, Mixamo-like, Z-up
# ------------------------------------------------------------------------------------------------
_ZYX = ("Zrotation", "Yrotation", "Xrotation")
_ZXY = ("Zrotation", "Xrotation", "Yrotation")
_POS = ("Xposition", "Yposition", "Zposition")


def _build(spec, root_channels, channels, scale, end_sites=()) -> Skeleton:
    names = [s[0] for s in spec]
    parents = [-1 if s[1] is None else names.index(s[1]) for s in spec]
    return Skeleton(
        names, parents, np.array([s[2] for s in spec], float) * scale,
        [root_channels if p < 0 else channels for p in parents],
        [names.index(p) for p, _ in end_sites],
        np.array([o for _, o in end_sites], float).reshape(-1, 3) * scale)


def cmu_skeleton() -> Skeleton:
    """31 joints with zero-length helper bones (LHipJoint, LowerBack, FingerBase, Thumb), ZYX
    channel order, inches; Y up, faces +Z."""
    spec = [("Hips", None, (0, 0, 0))]
    for s, side in ((1.0, "Left"), (-1.0, "Right")):
        spec += [(f"{side[0]}HipJoint", "Hips", (0, 0, 0)),
                 (f"{side}UpLeg", f"{side[0]}HipJoint", (s * 0.09, -0.06, 0.0)),
                 (f"{side}Leg", f"{side}UpLeg", (0, -0.42, 0)),
                 (f"{side}Foot", f"{side}Leg", (0, -0.40, 0)),
                 (f"{side}ToeBase", f"{side}Foot", (0, -0.05, 0.13))]
    spec += [("LowerBack", "Hips", (0, 0, 0)), ("Spine", "LowerBack", (0, 0.11, 0)),
             ("Spine1", "Spine", (0, 0.12, 0)), ("Neck", "Spine1", (0, 0.22, 0)),
             ("Neck1", "Neck", (0, 0.05, 0)), ("Head", "Neck1", (0, 0.06, 0))]
    for s, side in ((1.0, "Left"), (-1.0, "Right")):
        spec += [(f"{side}Shoulder", "Spine1", (s * 0.02, 0.17, 0)),
                 (f"{side}Arm", f"{side}Shoulder", (s * 0.14, 0, 0)),
                 (f"{side}ForeArm", f"{side}Arm", (s * 0.27, 0, 0)),
                 (f"{side}Hand", f"{side}ForeArm", (s * 0.25, 0, 0)),
                 (f"{side}FingerBase", f"{side}Hand", (0, 0, 0)),
                 (f"{side}HandIndex1", f"{side}FingerBase", (s * 0.07, 0, 0)),
                 (f"{side[0]}Thumb", f"{side}Hand", (0, 0, 0))]
    ends = [("LeftToeBase", (0, 0, 0.05)), ("RightToeBase", (0, 0, 0.05)), ("Head", (0, 0.18, 0)),
            ("LeftHandIndex1", (0.04, 0, 0)), ("RightHandIndex1", (-0.04, 0, 0)),
            ("LThumb", (0.03, 0, 0.03)), ("RThumb", (-0.03, 0, 0.03))]
    return _build(spec, _POS + _ZYX, _ZYX, 1 / 0.0254, ends)


def mixamo_skeleton() -> Skeleton:
    """``mixamorig:`` names, centimetres, three-joint fingers, 6 channels on every joint (ZXY)."""
    m = "mixamorig:"
    spec = [(m + "Hips", None, (0, 0, 0)), (m + "Spine", m + "Hips", (0, 0.1, 0)),
            (m + "Spine1", m + "Spine", (0, 0.12, 0)), (m + "Spine2", m + "Spine1", (0, 0.13, 0)),
            (m + "Neck", m + "Spine2", (0, 0.15, 0)), (m + "Head", m + "Neck", (0, 0.1, 0)),
            (m + "HeadTop_End", m + "Head", (0, 0.18, 0))]
    for s, side in ((1.0, "Left"), (-1.0, "Right")):
        spec += [(m + f"{side}Shoulder", m + "Spine2", (s * 0.06, 0.1, 0)),
                 (m + f"{side}Arm", m + f"{side}Shoulder", (s * 0.12, 0, 0)),
                 (m + f"{side}ForeArm", m + f"{side}Arm", (s * 0.27, 0, 0)),
                 (m + f"{side}Hand", m + f"{side}ForeArm", (s * 0.25, 0, 0))]
        for f in ("Index", "Middle", "Thumb"):
            prev = m + f"{side}Hand"
            for k in (1, 2, 3):
                spec.append((m + f"{side}Hand{f}{k}", prev,
                             (s * 0.03, 0, 0.02 if f == "Thumb" else 0)))
                prev = m + f"{side}Hand{f}{k}"
        spec += [(m + f"{side}UpLeg", m + "Hips", (s * 0.09, -0.07, 0)),
                 (m + f"{side}Leg", m + f"{side}UpLeg", (0, -0.42, 0)),
                 (m + f"{side}Foot", m + f"{side}Leg", (0, -0.41, 0)),
                 (m + f"{side}ToeBase", m + f"{side}Foot", (0, -0.06, 0.12)),
                 (m + f"{side}Toe_End", m + f"{side}ToeBase", (0, 0, 0.06))]
    return _build(spec, _POS + _ZXY, _POS + _ZXY, 100.0)


def smooth_motion(sk: Skeleton, unit: float, n_frames: int = 40, frame_time: float = 1 / 30,
                  max_deg: float = 30.0, seed: int = 0) -> Motion:
    """Smooth pseudo-random rotations on every joint (sums of sines, up to ``max_deg``), the root
    walking forward (+Z) at 1 m/s; ``unit`` = metres per file unit; Y-up file."""
    rng = np.random.default_rng(seed)
    t = np.arange(n_frames) * frame_time
    n_j = sk.n_joints
    amp = np.radians(max_deg) * rng.uniform(0.3, 1.0, (n_j, 3))
    freq = rng.uniform(0.3, 1.5, (n_j, 3))
    phase = rng.uniform(0, 2 * np.pi, (n_j, 3))
    rot = quat_from_rotvec(amp * np.sin(2 * np.pi * freq * t[:, None, None] + phase))
    pos = np.broadcast_to(sk.offsets, (n_frames, n_j, 3)).copy()
    pts = np.concatenate([sk.rest_positions(), sk.rest_end_sites()]) if sk.n_end_sites \
        else sk.rest_positions()
    height = sk.rest_positions()[0, 1] - pts[:, 1].min()
    pos[:, 0] = np.stack([0 * t, height + 0 * t, t / unit], axis=1)
    return Motion(sk, frame_time, pos, rot)


def zup_motion() -> Motion:
    """The default skeleton moving, written in a Z-up file in millimetres (faces -Y)."""
    m = smooth_motion(humanoid_skeleton(), 1.0, seed=1)
    return transform_motion(m, 1000.0, up_axis_rotation("y", "z"))


VARIANTS = {
    "cmu": lambda: smooth_motion(cmu_skeleton(), 0.0254, seed=2),
    "mixamo": lambda: smooth_motion(mixamo_skeleton(), 0.01, seed=3),
    "zup_mm": zup_motion,
}


def _report(tag: str, e: dict) -> None:
    print(f"\n{tag}: worst joint {e['max_mm']:.4f} mm ({e['max_joint']}, frame "
          f"{e['worst_frame']}), worst end effector {e['end_effector_max_mm']:.4f} mm "
          f"({e['end_effector']}), mean {e['mean_mm']:.4f} mm")


# ------------------------------------------------------------------------------------------------
# exact replay (full model) and projection (hinge model)
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", SHARED_CLIPS)
def test_shared_clip_full_replay_is_exact(name):
    path = shared_clip(name)
    motion = bvh.load(path)
    model = _model(motion, "full", name)
    ref = ReferenceMotion(model, motion)
    e = ref.replay_errors()
    _report(f"{name} full", e)
    assert e["n_frames"] == motion.n_frames
    assert len(e["joints_mm"]) == motion.skeleton.n_joints  # nothing dropped on this rig
    assert e["max_mm"] < EXACT_MM
    assert e["end_effector_max_mm"] < EXACT_MM
    assert len(e["end_effectors_mm"]) >= 5  # head, hands, toes (joints and end sites)


@pytest.mark.parametrize("name", SHARED_CLIPS)
def test_shared_clip_hinge_projection_within_limits(name):
    path = shared_clip(name)
    motion = bvh.load(path)
    model = _model(motion, "hinge", name)
    plain = ReferenceMotion(model, motion, project=False).replay_errors()
    ref = ReferenceMotion(model, motion)
    e = ref.replay_errors()
    _report(f"{name} hinge, projection only", plain)
    _report(f"{name} hinge, projection + IK", e)
    assert set(ref.projected_joints) == {"lKnee", "rKnee", "lElbow", "rElbow"}
    # the clips' knees and elbows are not hinges: projection alone misses by centimetres
    assert plain["end_effector_max_mm"] > 20.0
    assert e["end_effector_max_mm"] < EE_LIMIT_MM
    assert e["max_mm"] < JOINT_LIMIT_MM
    assert ref.ik_iterations.max() < 40  # converged on every frame


@pytest.mark.parametrize("variant", sorted(VARIANTS))
def test_project_made_skeletons_full_replay_is_exact(variant):
    motion = VARIANTS[variant]()
    converted = convert(motion, joint_model="full")
    e = replay_errors(converted, motion)
    _report(f"{variant} full", e)
    assert e["max_mm"] < EXACT_MM
    assert e["end_effector_max_mm"] < EXACT_MM
    # dropped joints (fingers, *_End markers) are not compared; every kept joint is
    assert set(e["joints_mm"]) == set(converted.info.joints)


def _shared_variants():
    """The motion-level and authored-rig variants of tests/bvh_variants.py (built lazily)."""
    import bvh_variants as bv

    if "variants" not in _MODELS:
        base, label = bv.base_motion()
        _MODELS["variants"] = {v.name: v for v in bv.motion_variants(base, label)
                               + bv.authored_variants()}
    return _MODELS["variants"]


_VARIANT_NAMES = ["base", "base-cm", "base-inch", "base-zup", "base-zup-cm", "base-order-zyx",
                  "base-orders-mixed", "base-six-channels", "base-few-channels",
                  "base-zero-length", "base-inner-end-site", "base-unprincipal-angles", "cmu31",
                  "mixamo", "mixamo-zup", "authored20", "authored20-inch"]


@pytest.mark.parametrize("name", _VARIANT_NAMES)
def test_bvh_variants_full_replay_is_exact(name):
    """Every rigid-bone variant of tests/bvh_variants.py replays exactly (``base`` is walk60 when
    the shared data is present, else a synthetic walk; its "stretch" variant changes a bone's
    length, which no rigid model can follow, and is left out)."""
    variants = _shared_variants()
    key = name if name in variants else name.replace("base", next(iter(variants)).split("-")[0], 1)
    motion = bvh.loads(variants[key].text)
    e = replay_errors(convert(motion, joint_model="full"), motion)
    _report(f"bvh_variants {key} full", e)
    assert e["max_mm"] < EXACT_MM
    assert e["end_effector_max_mm"] < EXACT_MM


def test_mixamo_hinge_projection_with_dropped_fingers():
    # gentle motion: random 30-degree rotations would bend the knees far off their hinge axis
    motion = smooth_motion(mixamo_skeleton(), 0.01, max_deg=8.0, seed=3)
    converted = convert(motion, joint_model="hinge")
    assert any("Index" in n for n in converted.info.dropped)
    e = replay_errors(converted, motion)
    _report("mixamo hinge", e)
    assert e["end_effector_max_mm"] < EE_LIMIT_MM
    assert e["max_mm"] < JOINT_LIMIT_MM


def test_ball_model_replay_is_exact_except_projected_limbs():
    motion = smooth_motion(humanoid_skeleton(), 1.0, n_frames=20, max_deg=10.0, seed=4)
    ref = ReferenceMotion(_model(motion, "ball", "default_smooth"), motion)
    assert set(ref.projected_joints) == {"lKnee", "rKnee", "lElbow", "rElbow"}  # hinges
    e = ref.replay_errors()
    assert e["end_effector_max_mm"] < EE_LIMIT_MM and e["max_mm"] < JOINT_LIMIT_MM
    trunk = ["RootJoint", "pelvis_lowerback", "lowerback_torso", "torso_head", "lTorso_Clavicle",
             "rTorso_Clavicle", "lShoulder", "rShoulder", "lHip", "rHip"]
    assert max(e["joints_mm"][n] for n in trunk) < 1e-6  # ball joints replay exactly


def test_hinge_model_of_other_proportions_follows_the_full_model():
    """The bundled humanoid's bones differ from walk60's: the projection IK aims at the clip's
    pose on the model's own bones, so hinge and full models put ankles and wrists together."""
    motion = bvh.load(shared_clip("walk60.bvh"))
    full = ReferenceMotion(_model(humanoid_skeleton(), "full", "default"), motion)
    hinge = ReferenceMotion(_model(humanoid_skeleton(), "hinge", "default"), motion)
    bf, bh = full.body_positions(full.times), hinge.body_positions(hinge.times)
    bf[..., 2] -= full.z_offset
    bh[..., 2] -= hinge.z_offset
    ids = [mujoco.mj_name2id(full.model, mujoco.mjtObj.mjOBJ_BODY, n)
           for n in ("lAnkle", "rAnkle", "lWrist", "rWrist", "lToeJoint", "rToeJoint")]
    err = np.linalg.norm(bf[:, ids] - bh[:, ids], axis=-1).max()
    print(f"\nwalk60 on the bundled humanoid: hinge vs full end effectors {1000 * err:.3f} mm")
    assert err < 0.002
    # the clip's own joint positions are another skeleton's: replay reports the mismatch
    assert full.replay_errors()["max_mm"] > 10.0


def test_rest_pose_maps_to_qpos0_angles():
    """The T-pose is the model's reference configuration: all joint angles zero."""
    motion = humanoid_rest_motion(n_frames=3)
    model = _model(humanoid_skeleton(), "hinge", "default")
    ref = ReferenceMotion(model, motion)
    np.testing.assert_allclose(ref.frame_qpos[:, 7:], 0.0, atol=1e-12)
    np.testing.assert_allclose(ref.frame_qpos[:, 3:7], [[1, 0, 0, 0]] * 3, atol=1e-12)
    # the model's rest pose has its feet on the floor; so has the placed clip
    assert ref.z_offset == pytest.approx(model.qpos0[2] - motion.root_positions[0, 1], abs=1e-6)


# ------------------------------------------------------------------------------------------------
# qpos algebra and sampling in time
# ------------------------------------------------------------------------------------------------
def test_qpos_algebra_matches_mujoco():
    model = _model(humanoid_skeleton(), "ball", "default")
    alg = _QposAlgebra(model)
    rng = np.random.default_rng(0)
    for _ in range(5):
        q0, q1 = model.qpos0.copy(), model.qpos0.copy()
        for q in (q0, q1):
            q[:] += rng.normal(scale=0.3, size=model.nq)
            for j in range(model.njnt):
                a = model.jnt_qposadr[j]
                if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE:
                    q[a + 3: a + 7] /= np.linalg.norm(q[a + 3: a + 7])
                elif model.jnt_type[j] == mujoco.mjtJoint.mjJNT_BALL:
                    q[a: a + 4] /= np.linalg.norm(q[a: a + 4])
        v_mj = np.zeros(model.nv)
        mujoco.mj_differentiatePos(model, v_mj, 1.0, q0, q1)
        np.testing.assert_allclose(alg.diff(q0, q1), v_mj, atol=1e-9)
        q_mj = q0.copy()
        mujoco.mj_integratePos(model, q_mj, 0.4 * v_mj, 1.0)
        np.testing.assert_allclose(alg.integrate(q0, 0.4 * v_mj), q_mj, atol=1e-9)
        np.testing.assert_allclose(alg.interpolate(q0, q1, 0.4), q_mj, atol=1e-9)


def _walk60_ref(joint_model="hinge"):
    motion = bvh.load(shared_clip("walk60.bvh"))
    return motion, ReferenceMotion(_model(motion, joint_model, "walk60.bvh"), motion)


def test_sampling_shapes_and_frame_times():
    motion, ref = _walk60_ref()
    m = ref.model
    assert ref.duration == pytest.approx((motion.n_frames - 1) * motion.frame_time)
    assert ref.frame_time == motion.frame_time
    assert ref.qpos(0.1).shape == (m.nq,)
    assert ref.qvel(np.zeros((2, 3))).shape == (2, 3, m.nv)
    assert ref.body_positions([0.0, 0.5]).shape == (2, m.nbody, 3)
    assert ref.site_positions(0.2).shape == (m.nsite, 3)
    assert ref.joint_positions([0.1]).shape == (1, len(ref.joint_names), 3)
    assert ref.foot_contacts(np.arange(4.0)).shape == (4, 2)
    np.testing.assert_allclose(ref.qpos(ref.times), ref.frame_qpos, atol=1e-12)
    np.testing.assert_allclose(ref.qvel(ref.times), ref.frame_qvel, atol=1e-12)


def test_interpolation_follows_integrate_pos():
    motion, ref = _walk60_ref()
    m = ref.model
    i, a = 37, 0.3
    t = (i + a) * ref.frame_time
    v = np.zeros(m.nv)
    mujoco.mj_differentiatePos(m, v, 1.0, ref.frame_qpos[i], ref.frame_qpos[i + 1])
    q = ref.frame_qpos[i].copy()
    mujoco.mj_integratePos(m, q, v, a)
    np.testing.assert_allclose(ref.qpos(t), q, atol=1e-9)


def test_qvel_matches_finite_differences_of_qpos():
    motion, ref = _walk60_ref()
    m = ref.model
    h = 1e-4
    for t in (0.31, 1.0, 2.2):
        v = np.zeros(m.nv)
        mujoco.mj_differentiatePos(m, v, 2 * h, ref.qpos(t - h), ref.qpos(t + h))
        # qvel is an interpolated central difference: equal to the qpos slope up to the change
        # of velocity within a frame
        scale = np.abs(ref.frame_qvel).max(axis=0) + 1.0
        assert np.all(np.abs(ref.qvel(t) - v) < 0.25 * scale)
    # past the end of a non-cyclic clip the pose holds and the velocity is zero
    assert not ref.cyclic
    np.testing.assert_allclose(ref.qpos(ref.duration + 1.0), ref.frame_qpos[-1])
    np.testing.assert_allclose(ref.qvel(ref.duration + 1.0), 0.0)
    np.testing.assert_allclose(ref.qpos(-1.0), ref.frame_qpos[0])


def test_hinge_angles_are_continuous():
    motion, ref = _walk60_ref("full")
    hinge_adr = [ref.model.jnt_qposadr[j] for j in range(ref.model.njnt)
                 if ref.model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE]
    jumps = np.abs(np.diff(ref.frame_qpos[:, hinge_adr], axis=0))
    assert jumps.max() < np.radians(20)  # 60 fps mocap: no 2 pi wraps or Euler branch flips
    assert np.all(np.abs(np.median(ref.frame_qpos[:, hinge_adr], axis=0)) <= np.pi)


def test_body_positions_agree_with_joint_positions_between_frames():
    motion, ref = _walk60_ref("full")
    t = np.linspace(0.0, ref.duration, 23)
    bp = ref.body_positions(t)[:, ref.joint_body_ids]
    jp = ref.joint_positions(t)
    err = np.linalg.norm(bp - jp, axis=-1)
    assert err.max() < 0.01  # interpolated pose vs linearly interpolated positions
    on_frames = ref.body_positions(ref.times[::10])[:, ref.joint_body_ids]
    np.testing.assert_allclose(on_frames, ref.joint_positions(ref.times[::10]), atol=1e-6)


# ------------------------------------------------------------------------------------------------
# floor placement and contacts
# ------------------------------------------------------------------------------------------------
def test_box_corner_points_are_centred_on_the_geom():
    model = _model(humanoid_skeleton(), "hinge", "default")
    d = mujoco.MjData(model)
    mujoco.mj_kinematics(model, d)
    boxes = [g for g in range(model.ngeom) if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX]
    assert len(boxes) == 4  # two feet, two toes
    for g in boxes:
        pts = _geom_local_points(model, g)
        assert pts.shape == (8, 3)
        np.testing.assert_allclose(pts.mean(axis=0), 0.0, atol=1e-12)
        np.testing.assert_allclose(np.abs(pts).max(axis=0), model.geom_size[g])


def _lowest_foot_corner_per_frame(model, ref) -> np.ndarray:
    d = mujoco.MjData(model)
    boxes = [g for g in range(model.ngeom) if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX]
    signs = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)], float)
    lowest = []
    for q in ref.frame_qpos:
        d.qpos[:] = q
        mujoco.mj_kinematics(model, d)
        lowest.append(min(
            (d.geom_xpos[g] + (signs * model.geom_size[g]) @ d.geom_xmat[g].reshape(3, 3).T)
            [:, 2].min() for g in boxes))
        # nothing else of the body goes (much) below the floor either
        assert np.all(d.xpos[1:, 2] > 0.0)
    return np.array(lowest)


@pytest.mark.parametrize("name", SHARED_CLIPS)
def test_clip_is_placed_with_lowest_foot_point_on_the_floor(name):
    motion = bvh.load(shared_clip(name))
    model = _model(motion, "hinge", name)
    ref = ReferenceMotion(model, motion, floor="clip")
    assert _lowest_foot_corner_per_frame(model, ref).min() == pytest.approx(0.0, abs=1e-9)
    assert not ref.grounding.any()


def test_frame_floor_puts_a_foot_on_the_floor_in_every_frame(walk60):
    motion = bvh.load(walk60)
    model = _model(motion, "hinge", "walk60.bvh")
    clip = ReferenceMotion(model, motion, floor="clip")
    ref = ReferenceMotion(model, motion, floor="frame")
    np.testing.assert_allclose(_lowest_foot_corner_per_frame(model, ref), 0.0, atol=1e-9)
    # the clip floats by up to ~4 cm mid-stance with the whole-clip placement
    assert _lowest_foot_corner_per_frame(model, clip).max() > 0.02
    assert ref.grounding.max() == 0.0 and ref.grounding.min() < -0.02
    assert ref.z_offset == clip.z_offset
    # joints and end effectors move with their frame
    np.testing.assert_allclose(ref.joint_positions(0.5)[..., 2] - clip.joint_positions(0.5)[..., 2],
                               np.interp(0.5, np.arange(ref.n_frames) * ref.frame_time,
                                         ref.grounding), atol=1e-9)
    with pytest.raises(ReferenceMotionError, match="floor must be"):
        ReferenceMotion(model, motion, floor="lowest")


def _jump(stand_floats: float) -> Motion:
    """The bundled humanoid standing 1 s, floating ``stand_floats`` m in its second half-second
    of stance, with a 0.25 m jump (frames 60-99, a parabola of the root) in between."""
    m = humanoid_rest_motion(n_frames=160)
    t = np.arange(40) / 40
    m.local_positions[60:100, 0, 1] += 4 * 0.25 * t * (1 - t)
    m.local_positions[110:, 0, 1] += stand_floats
    return m


def test_contact_floor_grounds_supported_frames_and_keeps_flight():
    m = _jump(0.03)
    model = _model(humanoid_rest_motion(), "hinge", "humanoid-rest")
    clip = ReferenceMotion(model, m, floor="clip")
    frame = ReferenceMotion(model, m, floor="frame")
    contact = ReferenceMotion(model, m)  # the default
    assert contact.floor == "contact"
    z = model.jnt_qposadr[0] + 2
    # standing frames, before and after the jump, have their feet on the floor
    np.testing.assert_allclose(contact.frame_qpos[[0, 30, 130, 150], z],
                               frame.frame_qpos[[0, 30, 130, 150], z], atol=1e-9)
    assert clip.frame_qpos[130, z] - contact.frame_qpos[130, z] == pytest.approx(0.03, abs=1e-6)
    # the flight keeps its height (interpolated shift: none here), "frame" flattens it
    flight = ~contact.support
    assert flight[75:85].all() and contact.support[:55].all() and contact.support[115:].all()
    assert contact.frame_qpos[80, z] - contact.frame_qpos[0, z] == pytest.approx(
        0.25 * 4 * 0.5 * 0.5, abs=0.01)
    assert frame.frame_qpos[80, z] - frame.frame_qpos[0, z] < 0.01
    # never a foot below the floor
    assert _lowest_foot_corner_per_frame(model, contact).min() > -1e-9


@pytest.mark.parametrize("name", SHARED_CLIPS)
def test_contact_floor_equals_frame_floor_on_walks_and_idle(name):
    motion = bvh.load(shared_clip(name))
    model = _model(motion, "hinge", name)
    ref = ReferenceMotion(model, motion)
    assert ref.support.all()  # a foot supports the body in every frame of these clips
    np.testing.assert_allclose(ref.grounding,
                               ReferenceMotion(model, motion, floor="frame").grounding, atol=1e-12)


def test_walk_contacts_alternate_and_idle_stands():
    motion, ref = _walk60_ref()
    c = ref.frame_contacts()
    assert c.shape == (motion.n_frames, 2)
    single = np.where(c[:, 0] & ~c[:, 1], 0, np.where(c[:, 1] & ~c[:, 0], 1, -1))
    seq = [s for s in single if s >= 0]
    runs = [seq[0]] + [s for a, s in zip(seq[:-1], seq[1:], strict=True) if s != a]
    assert len(runs) >= 5  # 3 s of walking: several steps
    assert all(a != b for a, b in zip(runs[:-1], runs[1:], strict=True))
    assert 0.2 < c[:, 0].mean() < 0.85 and 0.2 < c[:, 1].mean() < 0.85
    idle = bvh.load(shared_clip("idle.bvh"))
    ref_idle = ReferenceMotion(_model(idle, "hinge", "idle.bvh"), idle)
    assert ref_idle.frame_contacts().all()


# ------------------------------------------------------------------------------------------------
# loops
# ------------------------------------------------------------------------------------------------
def _turning_loop(turn_deg: float, n_frames: int = 41) -> Motion:
    """A cyclic clip of the default skeleton: a periodic pose whose root walks an arc turning
    ``turn_deg`` per cycle (last frame = first frame moved by one cycle)."""
    sk = humanoid_skeleton()
    base = smooth_motion(sk, 1.0, n_frames=n_frames, frame_time=1 / 30, max_deg=10.0, seed=5)
    u = np.arange(n_frames) / (n_frames - 1)
    # periodic joint rotations: blended back to the first frame's at both ends
    w = np.sin(np.pi * u)[:, None, None] ** 2
    rot = base.rotations[:1] * (1 - w) + base.rotations * w
    rot /= np.linalg.norm(rot, axis=-1, keepdims=True)
    psi = np.radians(turn_deg) * u
    yaw = np.stack([np.cos(psi / 2), 0 * psi, np.sin(psi / 2), 0 * psi], axis=1)  # about +Y
    rot[:, 0] = quat_mul(yaw, rot[:, 0])
    radius = 2.0
    pos = base.local_positions.copy()
    if abs(turn_deg) > 1e-9:
        pos[:, 0, 0] = radius * (1 - np.cos(psi)) * np.sign(turn_deg)
        pos[:, 0, 2] = radius * np.sin(np.abs(psi))
    else:
        pos[:, 0, 0] = 0.0
        pos[:, 0, 2] = 1.2 * u
    pos[:, 0, 1] = pos[0, 0, 1]
    return Motion(sk, 1 / 30, pos, rot)


def test_cyclic_detection():
    _, ref = _walk60_ref()
    assert not ref.cyclic  # first and last poses differ
    straight = _turning_loop(0.0)
    model = _model(humanoid_skeleton(), "hinge", "default")
    assert ReferenceMotion(model, straight).cyclic
    assert not ReferenceMotion(model, straight, cyclic=False).cyclic
    broken = straight.copy()
    broken.rotations[-1] = broken.rotations[len(broken.rotations) // 2]
    assert not ReferenceMotion(model, broken).cyclic


def test_straight_loop_accumulates_displacement():
    model = _model(humanoid_skeleton(), "hinge", "default")
    ref = ReferenceMotion(model, _turning_loop(0.0))
    assert ref.cyclic and ref.cycle_heading == 0.0
    d = ref.cycle_displacement
    assert np.hypot(*d) == pytest.approx(1.2, abs=1e-6)
    for k in (1, 2, -1):
        for t in (0.1, 0.77):
            q0, qk = ref.qpos(t), ref.qpos(t + k * ref.duration)
            np.testing.assert_allclose(qk[:2], q0[:2] + k * d, atol=1e-9)
            np.testing.assert_allclose(qk[2:], q0[2:], atol=1e-9)
            np.testing.assert_allclose(ref.qvel(t + k * ref.duration), ref.qvel(t), atol=1e-9)
            np.testing.assert_allclose(ref.joint_positions(t + k * ref.duration)[:, :2],
                                       ref.joint_positions(t)[:, :2] + k * d, atol=1e-9)
    # continuous across the seam
    eps = 1e-6
    np.testing.assert_allclose(ref.qpos(ref.duration - eps), ref.qpos(ref.duration + eps),
                               atol=1e-4)


def test_turning_loop_accumulates_heading():
    model = _model(humanoid_skeleton(), "hinge", "default")
    ref = ReferenceMotion(model, _turning_loop(-90.0))
    assert ref.cyclic
    assert np.degrees(ref.cycle_heading) == pytest.approx(-90.0, abs=1e-6)
    h0 = heading_angle(ref.qpos(0.2)[3:7], up="z")
    for k in (1, 2, 3, 4):
        hk = heading_angle(ref.qpos(0.2 + k * ref.duration)[3:7], up="z")
        assert np.degrees(np.angle(np.exp(1j * (hk - h0 + k * np.pi / 2)))) == \
            pytest.approx(0.0, abs=1e-6)
    # four quarter turns close the square: back where it started
    np.testing.assert_allclose(ref.qpos(0.2 + 4 * ref.duration)[:3], ref.qpos(0.2)[:3],
                               atol=1e-9)
    # the root walks on: frame 0 of cycle 1 is the last frame of cycle 0
    np.testing.assert_allclose(ref.qpos(ref.duration + 1e-9)[:3], ref.frame_qpos[-1, :3],
                               atol=1e-6)


# ------------------------------------------------------------------------------------------------
# errors
# ------------------------------------------------------------------------------------------------
def test_bad_inputs_raise_project_errors():
    model = _model(humanoid_skeleton(), "hinge", "default")
    motion = humanoid_rest_motion()
    with pytest.raises(ReferenceMotionError):
        ReferenceMotion("not a model", motion)
    with pytest.raises(ReferenceMotionError):
        ReferenceMotion(model, np.zeros(3))
    other = bvh.loads(
        "HIERARCHY\nROOT Hips\n{\nOFFSET 0 0 0\nCHANNELS 6 Xposition Yposition Zposition "
        "Xrotation Yrotation Zrotation\nEnd Site\n{\nOFFSET 0 1 0\n}\n}\nMOTION\nFrames: 1\n"
        "Frame Time: 0.1\n0 0 0 0 0 0\n")
    with pytest.raises(ReferenceMotionError, match=r"lacks \d+ of the \d+ joints"):
        ReferenceMotion(model, other)
    ref = ReferenceMotion(model, motion)
    with pytest.raises(ReferenceMotionError):
        ref.qpos(np.nan)
    with pytest.raises(ReferenceMotionError):
        replay_errors(3, motion)
    assert issubclass(ReferenceMotionError, bvh.MjcharError)


def test_replay_errors_accepts_paths_and_converted_models(tmp_path):
    motion = smooth_motion(humanoid_skeleton(), 1.0, n_frames=10, seed=6)
    path = tmp_path / "clip.bvh"
    bvh.save(motion, path)
    converted = convert(humanoid_skeleton(), joint_model="full")
    e = replay_errors(converted, path)
    assert e["max_mm"] < EXACT_MM
    assert set(e) >= {"n_frames", "max_mm", "max_joint", "worst_frame", "mean_mm", "joints_mm",
                      "end_effector_max_mm", "end_effector", "end_effectors_mm"}
    e2 = replay_errors(converted.compile(), motion)
    assert e2["max_mm"] < EXACT_MM
