"""BVH -> MJCF conversion (mjchar.bvh.mjcf) and the `mjchar convert` command."""

from __future__ import annotations

import json

import mujoco
import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from test_naming import anonymous_skeleton, cmu_skeleton, mixamo_skeleton, zup_skeleton

from mjchar import bvh
from mjchar.bvh.bundled.humanoid_skeleton import humanoid_skeleton
from mjchar.bvh.io.skeleton import Skeleton
from mjchar.bvh.kinematics.fk import forward_kinematics
from mjchar.bvh.mjcf import ConversionError, ConvertedModel, ModelInfo, convert
from mjchar.bvh.rigs.layouts import apply_record
from mjchar.bvh.rigs.units import transform_motion
from mjchar.bvh.rotations import from_rotation, quat_conj, quat_mul, to_rotation
from mjchar.cli import main as cli_main


# ------------------------------------------------------------------------------------------------
# helpers
# ------------------------------------------------------------------------------------------------
def random_motion(sk: Skeleton, n_frames: int = 12, scale_deg: float = 60.0, seed: int = 0):
    """Frames of random local rotations (up to ``scale_deg`` per Euler angle)."""
    rng = np.random.default_rng(seed)
    m = bvh.Motion.rest(sk, n_frames)
    angles = rng.uniform(-scale_deg, scale_deg, (n_frames, sk.n_joints, 3))
    m.rotations[:] = from_rotation(Rotation.from_euler("ZYX", angles.reshape(-1, 3),
                                                       degrees=True)).reshape(n_frames, -1, 4)
    m.local_positions[:, 0] = rng.normal(0, 1.0, (n_frames, 3)) * sk.bone_lengths().max()
    return m


def kinematic_qpos(model: mujoco.MjModel, info: ModelInfo, motion) -> tuple[np.ndarray, np.ndarray]:
    """(qpos (F, nq), expected body positions (F, K, 3)) from the contract alone: the clip
    through the model's ``rig`` record (its canonical rest), in MuJoCo axes,
    ``L_j = G_parent^-1 G_j`` and the recorded hinge orders (no projection)."""
    motion = apply_record(motion, info.extra.get("rig"))
    mm = transform_motion(motion, info.unit_scale, info.basis)
    fk = forward_kinematics(mm)
    sk = motion.skeleton
    kept = list(info.joints)
    qpos = np.tile(model.qpos0, (motion.n_frames, 1))
    expected = np.zeros((motion.n_frames, len(kept), 3))
    for k, name in enumerate(kept):
        j = sk.index(name)
        ji = info.joints[name]
        expected[:, k] = fk.positions[:, j] + info.offset
        if ji.order == "free":
            adr = model.jnt_qposadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, "root")]
            qpos[:, adr:adr + 3] = fk.positions[:, j] + info.offset
            qpos[:, adr + 3:adr + 7] = fk.orientations[:, j]
            continue
        a = j  # the kept BVH joint owning the model parent body
        parent_body = model.body_parentid[model.body(ji.body).id]
        pname = model.body(parent_body).name
        a = sk.index(pname)
        local = quat_mul(quat_conj(fk.orientations[:, a]), fk.orientations[:, j])
        if ji.order == "ball":
            adr = model.jnt_qposadr[model.joint(ji.mj_joints[0]).id]
            qpos[:, adr:adr + 4] = local
        elif len(ji.order) == 3:
            ang = to_rotation(local).as_euler(ji.order.upper())
            for i, jn in enumerate(ji.mj_joints):
                qpos[:, model.jnt_qposadr[model.joint(jn).id]] = ang[:, i]
        elif len(ji.order) == 1:  # swing-twist projection on the hinge axis
            ax = "xyz".index(ji.order)
            tw = 2 * np.arctan2(local[:, 1 + ax], local[:, 0])
            qpos[:, model.jnt_qposadr[model.joint(ji.mj_joints[0]).id]] = \
                np.arctan2(np.sin(tw), np.cos(tw))
    return qpos, expected


def body_positions(model, qpos, bodies) -> np.ndarray:
    d = mujoco.MjData(model)
    ids = [model.body(b).id for b in bodies]
    out = np.zeros((len(qpos), len(ids), 3))
    for f, q in enumerate(qpos):
        d.qpos[:] = q
        mujoco.mj_kinematics(model, d)
        out[f] = d.xpos[ids]
    return out


def passive(model: mujoco.MjModel) -> mujoco.MjModel:
    """Actuators off: every position actuator becomes a zero-gain, zero-bias actuator."""
    model.actuator_gainprm[:] = 0
    model.actuator_biasprm[:] = 0
    return model


@pytest.fixture(scope="module")
def humanoid() -> ConvertedModel:
    return convert(humanoid_skeleton())


# ------------------------------------------------------------------------------------------------
# structure and metadata
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("joint_model,n_dofs", [("hinge", 55), ("full", 63), ("ball", 55)])
def test_compiles_with_exact_mass(joint_model, n_dofs):
    for mass in (70.0, 45.5):
        c = convert(humanoid_skeleton(), total_mass=mass, joint_model=joint_model)
        m = c.compile()
        assert m.nv == n_dofs and c.summary["n_dofs"] == n_dofs
        assert m.nbody == 21
        assert abs(m.body_mass.sum() - mass) < 1e-3 * mass
        assert m.opt.integrator == mujoco.mjtIntegrator.mjINT_IMPLICITFAST


def test_contract_layout(humanoid):
    m = humanoid.compile()
    info = ModelInfo.from_model(m)
    # free root named root on the root body, world-aligned bodies at the joints
    root = m.joint("root")
    assert m.jnt_type[root.id] == mujoco.mjtJoint.mjJNT_FREE
    assert m.body(int(m.jnt_bodyid[root.id])).name == "RootJoint"
    np.testing.assert_allclose(m.body_quat[1:], np.tile([1, 0, 0, 0], (m.nbody - 1, 1)))
    # x forward, y left, z up
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)
    assert d.xpos[m.body("lHip").id][1] > 0.05 > -0.05 > d.xpos[m.body("rHip").id][1]
    assert d.xpos[m.body("lToeJoint").id][0] > d.xpos[m.body("lAnkle").id][0] + 0.1
    assert d.xpos[m.body("torso_head").id][2] > 1.3
    # knees and elbows: one hinge; the rest triplets in the recorded order
    assert info.joints["lKnee"].mj_joints == ("lKnee_y",) and info.joints["lKnee"].order == "y"
    assert info.joints["lElbow"].mj_joints == ("lElbow_z",)
    assert info.joints["lHip"].mj_joints == ("lHip_y", "lHip_x", "lHip_z")
    assert info.joints["lShoulder"].order == "zyx"
    assert m.joint("lKnee_y").range[1] > 2.5  # knee flexion is positive
    assert m.joint("lElbow_z").range[0] < -2.5 and m.joint("rElbow_z").range[1] > 2.5
    # every hinge: armature, a position actuator of the same name with kp, kv, forcerange
    for j in range(1, m.njnt):
        assert m.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE
        assert m.dof_armature[m.jnt_dofadr[j]] >= 0.01
        a = m.actuator(m.joint(j).name).id
        assert m.actuator_trntype[a] == mujoco.mjtTrn.mjTRN_JOINT and m.actuator_trnid[a, 0] == j
        kp, kv = m.actuator_gainprm[a, 0], -m.actuator_biasprm[a, 2]
        assert kp > 0 and kv > 0 and m.actuator_biasprm[a, 1] == -kp
        assert m.actuator_forcelimited[a] and m.actuator_forcerange[a, 1] > 0
    assert m.nu == m.nv - 6
    # sites, floor, weld
    for s in ("head", "left_hand", "right_hand", "left_foot", "right_foot", "left_toe",
              "right_toe"):
        assert mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, s) >= 0, s
    assert m.geom("floor").type == mujoco.mjtGeom.mjGEOM_PLANE
    assert m.geom("floor").friction[0] == pytest.approx(1.0)
    w = m.equality("root_weld").id
    assert m.eq_type[w] == mujoco.mjtEq.mjEQ_WELD and not m.eq_active0[w]
    assert m.eq_obj1id[w] == m.body("RootJoint").id and m.eq_obj2id[w] == 0
    # metadata
    assert info.joint_model == "hinge" and info.up_axis == "y" and info.unit_scale == 1.0
    np.testing.assert_allclose(info.basis, [0.5, 0.5, 0.5, 0.5])
    assert info.roles["left_knee"] == "lKnee" and info.roles["spine"] == [
        "pelvis_lowerback", "lowerback_torso"]
    assert list(info.joints) == humanoid_skeleton().names
    assert info.to_dict() == humanoid.info.to_dict()


def test_feet_on_floor_and_sites(humanoid):
    m = humanoid.compile()
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    # the lowest geom point touches z = 0 in the reference pose; root about 0.93 m high
    low = min(d.geom_xpos[g][2] - (m.geom_size[g][2] if m.geom_type[g] == 6 else
                                   m.geom_size[g][0] + m.geom_size[g][1])
              for g in range(1, m.ngeom) if m.geom_type[g] in (3, 6))
    assert low > -1e-4
    assert d.site("left_foot").xpos[2] == pytest.approx(0.0, abs=1e-5)
    assert d.site("left_toe").xpos[2] == pytest.approx(0.0, abs=1e-5)
    assert 0.9 < d.xpos[1][2] < 0.96
    for g in humanoid.info.extra["foot_geoms"]["left"]:
        assert m.geom(g).type == mujoco.mjtGeom.mjGEOM_BOX
    others = set(range(1, m.ngeom)) - {m.geom(g).id for s in ("left", "right")
                                       for g in humanoid.info.extra["foot_geoms"][s]}
    assert all(m.geom_type[g] == mujoco.mjtGeom.mjGEOM_CAPSULE for g in others)
    # contacts: floor against everything, no body against body
    assert all(m.geom_contype[g] & 1 == 0 and m.geom_conaffinity[g] & 1 for g in others)


def test_mass_distribution_is_human_like(humanoid):
    m = humanoid.compile()
    frac = {b: m.body(b).mass[0] / 70.0 for b in humanoid.summary["bodies"]}
    assert frac["lHip"] == pytest.approx(0.1416, rel=0.02)  # de Leva thigh
    assert frac["lKnee"] == pytest.approx(0.0433, rel=0.02)  # shank
    assert frac["lShoulder"] == pytest.approx(0.0271, rel=0.02)  # upper arm
    assert frac["torso_head"] == pytest.approx(0.0694, rel=0.02)
    assert frac["RootJoint"] == pytest.approx(0.1117, rel=0.02)
    # inertias follow the geoms: a thigh is a long thin rod about the z axis
    ix, iy, iz = m.body("lHip").inertia
    assert iz < 0.2 * min(ix, iy)


def test_deterministic_output():
    a = convert(humanoid_skeleton()).xml
    b = convert(humanoid_skeleton()).xml
    assert a == b


# ------------------------------------------------------------------------------------------------
# replay exactness (the contract's kinematics, checked without
# mjchar.bvh.reference.reference_motion)
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("make", [humanoid_skeleton, cmu_skeleton, mixamo_skeleton, zup_skeleton,
                                  anonymous_skeleton])
def test_full_model_replays_random_poses_exactly(make):
    sk = make()
    motion = random_motion(sk, scale_deg=70.0)
    c = convert(motion, joint_model="full")
    m = c.compile()
    qpos, expected = kinematic_qpos(m, c.info, motion)
    got = body_positions(m, qpos, [c.info.joints[n].body for n in c.info.joints])
    assert np.abs(got - expected).max() < 1e-6  # metres


def test_fused_helpers_replay_exactly_while_still():
    """CMU's zero-length LHipJoint/RHipJoint are fused in the hinge model; when they do not
    rotate (as in CMU data) the hip-down chain still lands exactly."""
    sk = cmu_skeleton()
    motion = random_motion(sk, scale_deg=30.0)
    for h in ("LHipJoint", "RHipJoint"):
        motion.rotations[:, sk.index(h)] = [1, 0, 0, 0]
    c = convert(motion, joint_model="full", fuse=["LHipJoint", "RHipJoint"])
    assert any("exact only while" in w for w in c.warnings)
    m = c.compile()
    assert c.info.fused_into["LHipJoint"] == "Hips"
    qpos, expected = kinematic_qpos(m, c.info, motion)
    got = body_positions(m, qpos, list(c.info.joints))
    assert np.abs(got - expected).max() < 1e-6


def test_hinge_limits_contain_the_shared_clips(shared_clip_path):
    """Every pose of the shared clips (hinge angles by the recorded orders, knee/elbow twist)
    lies inside the hinge model's anatomical ranges."""
    motion = bvh.load(shared_clip_path)
    c = convert(motion, joint_model="hinge")
    m = c.compile()
    qpos, _ = kinematic_qpos(m, c.info, motion)
    for j in range(1, m.njnt):
        q = qpos[:, m.jnt_qposadr[j]]
        lo, hi = m.jnt_range[j]
        assert lo <= q.min() and q.max() <= hi, (m.joint(j).name, np.degrees([q.min(), q.max()]))


def test_euler_orders_keep_the_middle_angle_small(shared_clip_path):
    """With the recorded hinge orders the middle angle of every triplet stays far from the
    +-90 degree gimbal over the shared clips (measured worst: 26 degrees, shoulders)."""
    motion = bvh.load(shared_clip_path)
    c = convert(motion, joint_model="full")
    m = c.compile()
    qpos, _ = kinematic_qpos(m, c.info, motion)
    for name, ji in c.info.joints.items():
        if len(ji.order) == 3:
            mid = qpos[:, m.jnt_qposadr[m.joint(ji.mj_joints[1]).id]]
            assert np.degrees(np.abs(mid)).max() < 35.0, name


def test_full_model_has_no_limits(walk60):
    m = convert(walk60, joint_model="full").compile()
    assert not m.jnt_limited[1:].any()


def test_replay_errors_via_reference(walk60):
    reference = pytest.importorskip("mjchar.bvh.reference.reference_motion")
    full = convert(walk60, joint_model="full")
    e = reference.replay_errors(full, full.motion)
    assert e["max_mm"] < 1e-3 and e["end_effector_max_mm"] < 1e-3
    hinge = convert(walk60)
    e = reference.replay_errors(hinge, hinge.motion)
    # the bar for the projection onto 1-DoF knees/elbows: joints 3 cm, end effectors 1 cm
    assert e["max_mm"] < 30.0 and e["end_effector_max_mm"] < 10.0


# ------------------------------------------------------------------------------------------------
# other rigs
# ------------------------------------------------------------------------------------------------
def test_cmu_defaults():
    c = convert(cmu_skeleton())
    info = c.info
    assert info.unit_scale == pytest.approx(0.0254)
    assert set(info.extra["fused"]) == {"LHipJoint", "RHipJoint"}
    for f in ("LeftFingerBase", "LeftHandIndex1", "LThumb", "RThumb"):
        assert f in info.dropped
    assert info.fused_into["LThumb"] == "LeftHand" and info.fused_into["LHipJoint"] == "Hips"
    m = c.compile()
    assert m.nbody - 1 == 31 - 8
    assert m.body("LeftUpLeg").parentid[0] == m.body("Hips").id
    assert info.roles["left_clavicle"] == "LeftShoulder"
    # nothing is fused in the full model: zero-length joints keep their own dofs
    full = convert(cmu_skeleton(), joint_model="full")
    assert full.info.extra["fused"] == [] and "LHipJoint" in full.info.joints
    assert any("LHipJoint" in w for w in full.warnings)  # unrecognised, named
    assert full.compile().body("LHipJoint").mass[0] > 0


def test_mixamo_defaults():
    c = convert(mixamo_skeleton(), total_mass=80.0)
    m = c.compile()
    assert c.info.unit_scale == pytest.approx(0.01)
    assert abs(m.body_mass.sum() - 80.0) < 0.08
    assert all("Hand" not in b or b.endswith("Hand") for b in c.summary["bodies"])
    assert "mixamorig:HeadTop_End" in c.info.dropped
    assert c.warnings == []
    # the head reaches the dropped head-top marker
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    assert d.site("head").xpos[2] > 1.6


def test_zup_file_gives_the_same_model():
    y = convert(humanoid_skeleton()).compile()
    zc = convert(zup_skeleton())
    z = zc.compile()
    assert zc.info.up_axis == "z"
    np.testing.assert_allclose(z.body_pos, y.body_pos, atol=1e-6)
    np.testing.assert_allclose(z.body_mass, y.body_mass, rtol=1e-5)


def test_overrides_unit_and_up():
    sk = humanoid_skeleton()
    cm = Skeleton(sk.names, sk.parents, sk.offsets * 100, sk.channels, sk.end_site_parents,
                  sk.end_site_offsets * 100)
    a = convert(cm).compile()
    b = convert(cm, unit="cm", up_axis="y").compile()
    c = convert(cm, unit=0.01).compile()
    np.testing.assert_allclose(a.body_pos, b.body_pos, atol=1e-6)
    np.testing.assert_allclose(a.body_pos, c.body_pos, atol=1e-6)


def test_unrecognised_names_get_wide_limits_and_a_warning():
    sk = anonymous_skeleton()  # arms and legs found by shape; a gadget on the chest is not
    sk = Skeleton(sk.names + ["gadget"], np.append(sk.parents, 2),
                  np.vstack([sk.offsets, [0.0, 0.05, 0.1]]), sk.channels + [sk.channels[1]],
                  sk.end_site_parents, sk.end_site_offsets)
    c = convert(sk)
    assert any("unrecognised" in w and "gadget" in w for w in c.warnings)
    m = c.compile()
    gadget = [n for n in c.info.joints["gadget"].mj_joints]
    assert len(gadget) == 3
    assert all(m.joint(n).range[1] >= np.radians(160) for n in gadget)


def test_gains_override(tmp_path):
    path = tmp_path / "gains.json"
    path.write_text(json.dumps({"knee": {"kp": 123.0, "kd": 4.5}, "lHip": {"torque": 77.0},
                                "default": {"armature": 0.04}}))
    m = convert(humanoid_skeleton(), gains=str(path)).compile()
    assert m.actuator("lKnee_y").gainprm[0] == pytest.approx(123.0)
    assert -m.actuator("rKnee_y").biasprm[2] == pytest.approx(4.5)
    assert m.actuator("lHip_x").forcerange[1] == pytest.approx(77.0)
    assert m.actuator("rHip_x").forcerange[1] != pytest.approx(77.0)
    assert np.allclose(m.dof_armature[6:], 0.04)


# ------------------------------------------------------------------------------------------------
# dynamics
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("tilt", [(0.0, 0.0), (0.0, 1.0), (1.0, 0.0), (0.0, -1.0)])
def test_passive_ragdoll_settles(humanoid, tilt):
    """Actuators off, dropped from 5 cm above the T-pose (tilted 10 degrees): after 5 s it lies
    still, no NaN, no contact deeper than 2 cm, total energy never above the start."""
    m = passive(humanoid.compile())
    m.opt.enableflags |= mujoco.mjtEnableBit.mjENBL_ENERGY
    d = mujoco.MjData(m)
    if any(tilt):
        ang = np.radians(10.0)
        d.qpos[3:7] = [np.cos(ang / 2), tilt[0] * np.sin(ang / 2), tilt[1] * np.sin(ang / 2), 0]
    d.qpos[2] += 0.05
    mujoco.mj_forward(m, d)
    e0 = d.energy.sum()
    e_max, deepest = e0, 0.0
    for _ in range(int(5.0 / m.opt.timestep)):
        mujoco.mj_step(m, d)
        if d.ncon:
            deepest = min(deepest, d.contact.dist[:d.ncon].min())
        e_max = max(e_max, d.energy.sum())
    assert np.isfinite(d.qpos).all() and np.isfinite(d.qvel).all()
    assert deepest > -0.02
    assert e_max <= e0 + 1e-6
    assert d.energy[1] < 0.05  # kinetic energy, J: at rest
    assert np.linalg.norm(d.qvel[:3]) < 0.05
    assert d.qpos[2] < 0.5  # it fell


def test_native_pd_holds_the_rest_pose(humanoid):
    """Root welded, floor contacts off, every joint 0.2 rad off: after 3 s every joint is within
    2 degrees of its rest target (gravity droop included)."""
    m = humanoid.compile()
    m.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
    d = mujoco.MjData(m)
    d.eq_active[m.equality("root_weld").id] = 1
    d.qpos[7:] += np.random.default_rng(1).normal(0.0, 0.2, m.nq - 7)
    d.ctrl[:] = 0.0
    for _ in range(int(3.0 / m.opt.timestep)):
        mujoco.mj_step(m, d)
    assert np.isfinite(d.qpos).all()
    assert np.degrees(np.abs(d.qpos[7:])).max() < 2.0


# ------------------------------------------------------------------------------------------------
# bad input
# ------------------------------------------------------------------------------------------------
def _single_joint() -> Skeleton:
    return Skeleton(["Hips"], np.array([-1]), np.zeros((1, 3)),
                    [("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation",
                      "Yrotation")])


def _no_legs() -> Skeleton:
    sk = humanoid_skeleton()
    legs = ("Hip", "Knee", "Ankle", "ToeJoint")
    keep = [i for i, n in enumerate(sk.names) if not n.endswith(legs)]
    return Skeleton([sk.names[i] for i in keep], np.array([keep.index(p) if p >= 0 else -1
                                                          for p in sk.parents[keep]]),
                    sk.offsets[keep], [sk.channels[i] for i in keep])


@pytest.mark.parametrize("kwargs,match", [
    ({"joint_model": "nope"}, "unknown joint model"),
    ({"drop": ["RootJoint"]}, "cannot drop the root"),
    ({"fuse": ["RootJoint"]}, "cannot fuse the root"),
    ({"drop": ["lKnee"]}, "cannot drop the legs"),
    ({"drop": ["lWrist"], "fuse": ["lWrist"]}, "both dropped and fused"),
    ({"drop": ["NoSuchJoint"]}, "unknown joint 'NoSuchJoint'"),
    ({"total_mass": -3.0}, "positive"),
    ({"unit": "furlong"}, "unknown unit"),
    ({"up_axis": "w"}, "up axis"),
    ({"gains": {"kneee": {"kp": 1.0}}}, "match no kept joint"),
    ({"gains": {"knee": {"kp": -1.0}}}, "number >= 0"),
    ({"gains": {"knee": {"stiffness": 1.0}}}, "unknown fields"),
])
def test_bad_options(kwargs, match):
    with pytest.raises(ConversionError, match=match):
        convert(humanoid_skeleton(), **kwargs)


def test_bad_skeletons():
    with pytest.raises(ConversionError, match="1 joint"):
        convert(_single_joint())
    with pytest.raises(ConversionError, match="no legs"):
        convert(_no_legs())
    with pytest.raises(ConversionError, match="cannot convert a int"):
        convert(3)
    with pytest.raises(bvh.BVHError):
        convert("/nonexistent/file.bvh")


def test_model_without_metadata():
    m = mujoco.MjModel.from_xml_string("<mujoco><worldbody/></mujoco>")
    with pytest.raises(ConversionError, match="no <custom>"):
        ModelInfo.from_model(m)


# ------------------------------------------------------------------------------------------------
# CLI
# ------------------------------------------------------------------------------------------------
def test_cli_convert_shared_clip(walk60, tmp_path, capsys):
    out = tmp_path / "walk.xml"
    assert cli_main(["convert", str(walk60), "-o", str(out), "--mass", "75"]) == 0
    text = capsys.readouterr().out
    assert "20 bodies" in text and "55 dofs" in text and "75.000 kg" in text
    m = mujoco.MjModel.from_xml_path(str(out))
    assert abs(m.body_mass.sum() - 75.0) < 0.075
    assert ModelInfo.from_xml_path(out).roles["head"] == "torso_head"


def test_cli_json_verify(walk60, tmp_path, capsys):
    pytest.importorskip("mjchar.bvh.reference.reference_motion")
    out = tmp_path / "walk.xml"
    assert cli_main(["convert", str(walk60), "-o", str(out), "--joint-model", "full",
                     "--verify", "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    for k in ("worst_error_mm", "worst_end_effector_error_mm", "total_mass_kg", "n_bodies",
              "n_dofs", "dropped_joints"):
        assert k in res
    assert res["worst_error_mm"] < 1e-3 and res["n_dofs"] == 63 and res["n_bodies"] == 20
    assert res["dropped_joints"] == [] and res["total_mass_kg"] == pytest.approx(70.0, rel=1e-3)


def test_cli_cmu_file_drops_and_fuses(tmp_path, capsys):
    src = tmp_path / "cmu.bvh"
    bvh.save(random_motion(cmu_skeleton(), n_frames=3, scale_deg=10.0), src)
    assert cli_main(["convert", str(src), "--drop", "default,LeftToeBase", "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert "LeftToeBase" in res["dropped_joints"] and "LThumb" in res["dropped_joints"]
    assert (tmp_path / "cmu.xml").is_file()


def test_cli_errors_are_one_line(tmp_path, capsys):
    assert cli_main(["convert", "/nonexistent.bvh", "-o", str(tmp_path / "x.xml")]) == 2
    assert "error" in capsys.readouterr().err
    src = tmp_path / "one.bvh"
    bvh.save(bvh.Motion.rest(_single_joint()), src)
    assert cli_main(["convert", str(src), "--joint-model", "ball"]) == 2
    assert "1 joint" in capsys.readouterr().err


def test_cli_prints_the_unit_and_height_and_warns_outside_the_human_range(tmp_path, capsys):
    sk = humanoid_skeleton()
    src = tmp_path / "odd.bvh"  # 8.5 units tall: no known unit makes it a human
    k = 8.5 / 1.633
    bvh.save(bvh.Motion.rest(Skeleton(sk.names, sk.parents, sk.offsets * k, sk.channels,
                                      sk.end_site_parents, sk.end_site_offsets * k), 2), src)
    assert cli_main(["convert", str(src), "-o", str(tmp_path / "a.xml")]) == 0
    cap = capsys.readouterr()
    assert "unit: 0.2" in cap.out and "no known unit fits" in cap.out
    height = float(cap.out.split("; height ")[1].split(" m")[0])
    assert 1.6 < height < 1.9 and cap.err == ""
    assert cli_main(["convert", str(src), "-o", str(tmp_path / "b.xml"), "--unit", "in"]) == 0
    cap = capsys.readouterr()
    assert "unit: 0.0254 m per file unit (in, given); height 0.2" in cap.out
    err = cap.err.strip().splitlines()
    assert len(err) == 1 and "outside 1.0-2.3 m" in err[0] and "--unit" in err[0]
    assert "outside" not in cap.out  # said once, on stderr
    assert cli_main(["convert", str(src), "-o", str(tmp_path / "c.xml"), "--unit", "cmu",
                     "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["unit"] == "cmu" and res["unit_scale"] == pytest.approx(0.0254 / 0.45)
