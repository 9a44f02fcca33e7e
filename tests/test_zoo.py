"""The rig zoo (mjchar.bvh.bundled.zoo): real-world layouts of the shared clips, converted and
replayed.

Per rig: the file text round-trips, the converter guesses its unit and up axis, finds the
essential roles, gives the requested mass, replays the clip within 1 mm in the ``full`` model
and keeps end effectors within 10 mm and joints within 30 mm in the default ``hinge`` model.
Rigs made from the shared clips skip when ../shared/data is absent.
"""

from __future__ import annotations

import re

import numpy as np
import pytest
from conftest import SHARED_BVH, shared_clip

from mjchar import bvh
from mjchar.bvh.bundled.assets import motion_path
from mjchar.bvh.bundled.zoo import CONVENTIONS, stature, zoo_rigs
from mjchar.bvh.mjcf import convert
from mjchar.bvh.reference.reference_motion import replay_errors
from mjchar.bvh.rigs.units import up_axis_rotation
from mjchar.bvh.rotations import quat_rotate

SHARED_RIGS = {  # rig -> the shared clip it is made from
    "cmu-in-yup": "walk60", "unreal-cm-zup": "walk60", "gamestudio-cm-yup": "walk60",
    "blender-m-yup-rotated-root": "walk60", "mixamo-cm-yup": "walk_forward",
    "lafan1-cm-yup-apose": "walk_forward", "smpl-m-zup-child": "walk_forward",
    "xsens-mm-yup-tall": "walk_forward",
}
BUNDLED_RIGS = ("humanoid-150-m-zup", "humanoid-195-in-yup")
#: the structures of real exports (zoo_rigs(..., structures=True)), made from walk60
STRUCTURE_RIGS = ("cmu-asf-yup", "daz-cm-yup-face", "lafan1-anon-cm-yup",
                  "mixamo7-cm-yup-gimbal")
ESSENTIAL = ("pelvis", "left_hip", "right_hip", "left_knee", "right_knee", "left_ankle",
             "right_ankle", "left_shoulder", "right_shoulder", "left_elbow", "right_elbow",
             "head")
MASS = 63.0

_RIGS: dict = {}


def _rig(name: str):
    if name in SHARED_RIGS:
        shared_clip(f"{SHARED_RIGS[name]}.bvh")
    if name in STRUCTURE_RIGS:
        shared_clip("walk60.bvh")
    if not _RIGS:
        _RIGS.update({r.name: r for r in zoo_rigs(SHARED_BVH if SHARED_BVH.is_dir() else None,
                                                  structures=True)})
    return _RIGS[name]


def _file_motion(rig) -> bvh.Motion:
    """The rig as its BVH file reads back (6-decimal text)."""
    return bvh.loads(bvh.dumps(rig.motion))


def test_zoo_covers_the_conventions():
    shared_clip("walk60.bvh")
    shared_clip("walk_forward.bvh")
    rigs = zoo_rigs(SHARED_BVH)
    assert [r.name for r in rigs] == list(SHARED_RIGS) + list(BUNDLED_RIGS)
    assert len(rigs) >= 8
    assert len({r.convention for r in rigs}) >= 5
    assert {"m", "cm", "in"} <= {r.unit for r in rigs}
    assert {"y", "z"} <= {r.up for r in rigs}
    assert all(set(r.names) == set(CONVENTIONS["games"]) for r in rigs)
    more = zoo_rigs(SHARED_BVH, humanoid=False, structures=True)
    assert [r.name for r in more] == list(SHARED_RIGS) + list(STRUCTURE_RIGS)
    assert all(set(r.names) == set(CONVENTIONS["games"]) for r in more)


ALL_RIGS = list(SHARED_RIGS) + list(BUNDLED_RIGS) + list(STRUCTURE_RIGS)


@pytest.mark.parametrize("name", ALL_RIGS)
def test_zoo_rig_is_the_clip(name):
    """Forward kinematics of the rig's file = the source clip, scaled and re-axed."""
    rig = _rig(name)
    src = bvh.load(motion_path("walk")) if rig.source == "bundled walk" else \
        bvh.load(SHARED_BVH / f"{rig.source}.bvh")
    m = _file_motion(rig)
    step = int(round(m.frame_time / src.frame_time))
    f0 = bvh.forward_kinematics(src).positions[::step]
    scale = rig.height_m / stature(src.skeleton) / rig.unit_scale
    expected = scale * quat_rotate(up_axis_rotation("y", rig.up), f0)
    idx = [m.skeleton.index(rig.names[n]) for n in src.skeleton.names]
    got = bvh.forward_kinematics(m).positions[:, idx]
    assert np.max(np.abs(got - expected)) * rig.unit_scale < 1e-5  # metres


@pytest.mark.parametrize("name", ALL_RIGS)
def test_zoo_rig_converts(name):
    rig = _rig(name)
    m = _file_motion(rig)
    full = convert(m, joint_model="full", total_mass=MASS)
    e_full = replay_errors(full, m)
    assert e_full["max_mm"] < 1.0, e_full["max_joint"]
    hinge = convert(m, total_mass=MASS)
    e = replay_errors(hinge, m)
    assert e["end_effector_max_mm"] < 10.0, e["end_effector"]
    assert e["max_mm"] < 30.0, e["max_joint"]
    info = hinge.info
    assert info.unit_scale == pytest.approx(rig.unit_scale)
    assert info.up_axis == rig.up
    assert float(hinge.compile().body_mass.sum()) == pytest.approx(MASS, rel=1e-3)
    missing = [r for r in ESSENTIAL if r not in info.roles]
    assert not missing
    assert len(info.roles["spine"]) >= 1
    for g, n in rig.names.items():  # every role is the joint the convention means
        if g in ("lKnee", "rKnee", "lElbow", "rElbow", "lHip", "rAnkle"):
            role = {"Knee": "knee", "Elbow": "elbow", "Hip": "hip", "Ankle": "ankle"}[g[1:]]
            assert info.roles[f"{'left' if g[0] == 'l' else 'right'}_{role}"] == n
    assert info.extra["height"] == pytest.approx(rig.height_m, rel=0.05)


def test_static_root_folds_and_the_reference_motion_follows():
    """A game-studio rig (static joint_Root whose child Hips carries the translation): Hips is
    the free root; the file's clip replays through the recorded folding; a clip already on the
    model's skeleton (e.g. exported) is used as is."""
    rig = _rig("gamestudio-cm-yup")
    m = _file_motion(rig)
    c = convert(m, joint_model="full")
    assert "joint_Root" not in c.info.joints and c.info.joints["Hips"].mj_joints == ("root",)
    assert c.info.extra["rig"]["fold"] == ["joint_Root"]
    assert any("folded" in w and "joint_Root" in w for w in c.warnings)
    assert any("not a standing figure" in w for w in c.warnings)
    normalised = c.prepared.motion
    assert replay_errors(c, normalised)["max_mm"] < 1.0


def test_varying_translation_channels_warn_in_mm():
    rig = _rig("humanoid-150-m-zup")
    m = rig.motion.copy()
    j = m.skeleton.index("lElbow")
    sk = m.skeleton
    sk.channels[j] = ("Xposition", "Yposition", "Zposition") + sk.channels[j]
    stretch = 0.004 * np.sin(np.arange(m.n_frames) / 4.0)  # +-4 mm along the forearm bone
    m.local_positions[:, j] = sk.offsets[j] * (1.0 + stretch[:, None] / np.linalg.norm(
        sk.offsets[j]))
    m = bvh.Motion(sk, m.frame_time, m.local_positions, m.rotations)
    c = convert(m, joint_model="full")
    w = [x for x in c.warnings if "translation channels vary" in x]
    assert len(w) == 1
    got = float(re.search(r"lElbow by ([\d.]+) mm", w[0]).group(1))
    assert 3.5 < got < 5.0
    e = replay_errors(c, m)
    assert 2.0 < e["max_mm"] <= got + 0.1  # the bone is the mean: the variation is what is left


def _twisted_arms(motion: bvh.Motion, shoulders: tuple[str, str], deg: float) -> bvh.Motion:
    """The rest with each arm turned ``deg`` about its own upper-arm bone (joint positions
    kept): a T-pose whose elbows do not bend about a world axis."""
    from mjchar.bvh.rigs.layouts import rerest
    from mjchar.bvh.rotations import quat_from_rotvec, quat_identity

    sk = motion.skeleton
    rest = sk.rest_positions()
    r = quat_identity((sk.n_joints,))
    for sh in shoulders:
        s = sk.index(sh)
        arm = rest[sk.children(s)[0]] - rest[s]
        q = quat_from_rotvec(np.radians(deg) * arm / np.linalg.norm(arm))
        for j in range(sk.n_joints):
            if s in sk.chain(j):
                r[j] = q
    return rerest(motion, r)


def test_flexion_axes_come_from_the_clip():
    """Elbows whose rest is twisted about the upper arm bend about an axis off the world axes:
    the hinge turns about it. The canonical rest keeps a human rest's twist (it only swings
    bones), so the axis is the clip's."""
    rig = _rig("lafan1-cm-yup-apose")
    m = _twisted_arms(_file_motion(rig), ("LeftArm", "RightArm"), 45.0)
    c = convert(m)
    model = c.compile()
    ax = model.joint(c.info.joints["LeftForeArm"].mj_joints[0]).axis
    assert np.count_nonzero(np.abs(ax) > 0.2) >= 2  # not snapped to a world axis
    knee = model.joint(c.info.joints["LeftLeg"].mj_joints[0]).axis
    np.testing.assert_allclose(np.abs(knee), [0, 1, 0], atol=1e-9)  # lateral, as it bends
    e = replay_errors(c, m)
    assert e["end_effector_max_mm"] < 10.0


def test_a_cmu_asf_file_is_read_in_its_unit(tmp_path, capsys):
    """The CMU file as most people download it (zero-length hip helpers, legs apart and arms
    hanging at rest, lengths in 1/0.45 inch): at the defaults a 1.6 m body in the ASF unit,
    standing straight with its arms out; no warning on stderr."""
    from conftest import run_command

    rig = _rig("cmu-asf-yup")
    path = tmp_path / "cmu.bvh"
    bvh.save(rig.motion, path)
    assert run_command(["convert", str(path), "-o", str(tmp_path / "cmu.xml")]) == 0
    cap = capsys.readouterr()
    assert "unit: cmu (0.0564444 m per file unit, from the body's size)" in cap.out
    assert cap.err == ""
    c = convert(bvh.load(path))
    assert 1.5 < c.summary["height_m"] < 1.7
    assert set(c.summary["fused"]) == {"LHipJoint", "RHipJoint"}
    m = c.compile()
    pos = {n: m.body(n).pos for n in ("LeftUpLeg", "LeftLeg", "LeftFoot", "LeftForeArm")}
    np.testing.assert_allclose(pos["LeftLeg"][:2], 0.0, atol=1e-9)  # thigh straight down
    np.testing.assert_allclose(pos["LeftFoot"][:2], 0.0, atol=1e-9)  # shank straight down
    assert pos["LeftForeArm"][1] > 0.2 and abs(pos["LeftForeArm"][2]) < 1e-9  # arm out, level
    assert any("arms put in a T-pose (up to 90 deg)" in w for w in c.warnings)
