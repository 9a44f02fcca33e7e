"""Real exports of three more rig families (../shared/data/real, skipped when absent), never
used to tune the converter: an Xsens MVN walk in millimetres, a CMU clip with Daz/MakeHuman
names and a face, an Emilya walk in inches with a non-zero root offset.

Each converts at the defaults to a body 1.2-2.1 m tall in its own unit and replays within 1 mm
in the ``full`` model; the role maps are the ones their names mean (no finger for an elbow),
and the same roles are found from geometry when the names are taken away; the same skeleton
from two different stretches of its clip gives the same segments.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import real_export, run_command, run_json, shared_clip

from mjchar import bvh
from mjchar.bvh.bundled.zoo_layouts import anonymise
from mjchar.bvh.mjcf import convert
from mjchar.bvh.reference.reference_motion import replay_errors
from mjchar.bvh.rigs.naming import Clip, recognise
from mjchar.bvh.rigs.words import is_finger

#: file -> its unit
REAL = {"xsens_mvn_walk.bvh": "mm", "cmu_daz_02_03.bvh": "cm", "emilya_walk.bvh": "in"}
LIMB_ROLES = tuple(f"{s}_{r}" for s in ("left", "right")
                   for r in ("hip", "knee", "ankle", "shoulder", "elbow", "wrist"))

_MOTIONS: dict[str, bvh.Motion] = {}


def _motion(name: str) -> bvh.Motion:
    path = real_export(name)
    if name not in _MOTIONS:
        _MOTIONS[name] = bvh.load(path)
    return _MOTIONS[name]


@pytest.mark.parametrize("name", list(REAL))
def test_real_export_converts_at_the_defaults(name):
    m = _motion(name)
    c = convert(m)
    assert 1.2 <= c.summary["height_m"] <= 2.1, c.summary["height_m"]
    assert c.summary["unit_name"] == REAL[name]
    assert c.summary["height_warning"] is None
    full = convert(m, joint_model="full")
    e = replay_errors(full, m)
    assert e["max_mm"] < 1.0, e["max_joint"]
    # the hinge model replays its end effectors within a centimetre
    assert replay_errors(c, m)["end_effector_max_mm"] < 10.0


def test_cli_verify_on_a_real_export(tmp_path, capsys):
    path = real_export("emilya_walk.bvh")
    out = tmp_path / "emilya.xml"
    res = run_json(["convert", str(path), "-o", str(out), "--joint-model", "full", "--verify",
                    "--json"], capsys)
    assert res["worst_error_mm"] < 1.0 and res["unit"] == "in"
    assert 1.2 <= res["height_m"] <= 2.1


def test_daz_names_no_finger_for_an_elbow():
    rec = convert(_motion("cmu_daz_02_03.bvh")).prepared.rec
    r = rec.roles
    assert (r["pelvis"], r["head"]) == ("hip", "head")
    assert (r["left_hip"], r["left_knee"], r["left_ankle"]) == ("lhip", "lknee", "lfoot")
    assert (r["right_clavicle"], r["right_shoulder"], r["right_elbow"], r["right_wrist"]) == \
        ("rcollar", "rshoulder", "relbow", "rhand")
    assert r["spine"] == ["abdomen", "chest"] and r["neck"] == ["neck", "neck1"]
    assert not any(is_finger(v) for v in r.values() if isinstance(v, str))
    assert rec.by_structure == []
    # the face and the toes' phalanges are details, dropped with the fingers
    assert rec.joint_roles["tongue02"] == "face" and rec.joint_roles["eye.l"] == "face"
    assert rec.joint_roles["toe3-2.r"] == "toes" and rec.joint_roles["finger2-2.r"] == "hand"


def test_daz_model_is_a_humanoid_not_a_face():
    c = convert(_motion("cmu_daz_02_03.bvh"))
    assert c.summary["n_bodies"] < 30
    assert set(c.summary["fused"]) == {"lbuttock", "rbuttock"}
    assert not any(c.info.joints[n].role == "unknown" for n in c.info.joints)


def test_xsens_names():
    r = convert(_motion("xsens_mvn_walk.bvh")).prepared.rec.roles
    # MVN's RightShoulder is the upper arm, RightCollar the clavicle
    assert (r["right_clavicle"], r["right_shoulder"], r["right_elbow"], r["right_wrist"]) == \
        ("RightCollar", "RightShoulder", "RightElbow", "RightWrist")
    assert (r["left_hip"], r["left_knee"], r["left_ankle"], r["left_toe"]) == \
        ("LeftHip", "LeftKnee", "LeftAnkle", "LeftToe")
    assert r["spine"] == ["Chest", "Chest2", "Chest3", "Chest4"] and r["neck"] == ["Neck"]


def test_emilya_names():
    c = convert(_motion("emilya_walk.bvh"))
    r = c.prepared.rec.roles
    assert (r["left_clavicle"], r["left_shoulder"], r["left_elbow"], r["left_wrist"]) == \
        ("LeftShoulder", "LeftArm", "LeftForeArm", "LeftHand")
    assert r["spine"] == ["Spine"] and r["head"] == "Head"
    assert {"LeftHand_End", "RightHand_End"} <= set(c.info.dropped)


@pytest.mark.parametrize("name", list(REAL))
def test_roles_from_geometry_match_the_names(name):
    """The names taken away (``Joint0``...), the geometry and the clip find the same limbs,
    sides, pelvis and head."""
    m = _motion(name)
    named = recognise(m.skeleton, clip=Clip.of(m))
    anon, mapping = anonymise(m)
    shaped = recognise(anon.skeleton, clip=Clip.of(anon))
    for role in LIMB_ROLES + ("pelvis", "head"):
        assert shaped.roles.get(role) == mapping[named.roles[role]], role
    assert shaped.problem is None


def _segments(c) -> dict[str, float]:
    """Body -> its distance from its parent body (m), from the compiled model."""
    model = c.compile()
    return {model.body(i).name: float(np.linalg.norm(model.body_pos[i]))
            for i in range(2, model.nbody)}


def test_same_skeleton_from_two_stretches_of_a_real_clip():
    """Two halves of the Xsens walk (the first starts on its zero pose, the second mid-stride)
    give the same body: every segment and the height within 1 mm."""
    m = _motion("xsens_mvn_walk.bvh")
    half = m.n_frames // 2
    a, b = convert(m[:half]), convert(m[half:])
    sa, sb = _segments(a), _segments(b)
    assert sa.keys() == sb.keys()
    assert max(abs(sa[k] - sb[k]) for k in sa) < 1e-3
    assert abs(a.summary["height_m"] - b.summary["height_m"]) < 1e-3
    np.testing.assert_allclose(a.compile().body_pos, b.compile().body_pos, atol=1e-6)


@pytest.mark.parametrize("clip", ["walk_and_turn_right.bvh", "idle.bvh"])
def test_same_skeleton_from_two_clips(clip):
    """Each structure rig of the zoo made from walk60 and from another clip of the same
    skeleton: the segments agree within 1 mm (bones along local axes included: their rest is
    built from the skeleton, not taken from a frame of the clip)."""
    from mjchar.bvh.bundled.zoo import structure_rigs

    a = structure_rigs(bvh.load(shared_clip("walk60.bvh")), "walk60")
    b = structure_rigs(bvh.load(shared_clip(clip)), clip)
    for ra, rb in zip(a, b, strict=True):
        ca, cb = convert(bvh.loads(bvh.dumps(ra.motion))), convert(bvh.loads(bvh.dumps(rb.motion)))
        # by the source joint each body stands for (anonymous names follow each file's order)
        ga, gb = ({v: k for k, v in r.names.items()} for r in (ra, rb))
        sa = {ga.get(k, k): v for k, v in _segments(ca).items()}
        sb = {gb.get(k, k): v for k, v in _segments(cb).items()}
        assert sa.keys() == sb.keys(), ra.name
        worst = max(abs(sa[k] - sb[k]) for k in sa)
        assert worst < 1e-3, (ra.name, worst)
        assert abs(ca.summary["height_m"] - cb.summary["height_m"]) < 0.01, ra.name


def test_info_shows_the_role_map_the_unit_and_the_height(capsys):
    path = real_export("cmu_daz_02_03.bvh")
    assert run_command(["info", str(path)]) == 0
    out = capsys.readouterr().out
    assert "unit: cm (0.01 m per file unit" in out
    height = float(out.split("the body it would build: ")[1].split(" m tall")[0])
    assert 1.2 <= height <= 2.1
    assert "left elbow      lelbow (name)" in out and "pelvis          hip (name)" in out
    assert "dropped by default: face" in out


def test_a_leaning_clip_gives_the_same_body():
    """A game-studio rig (static root, bones along local axes, 6 channels) from the course walk
    and from the same walk leaning 35 degrees forward with its arms raised: the same body (the
    rest was a frame of the clip: 1.594 m and 1.475 m tall)."""
    from mjchar.bvh.bundled.zoo import (
        CONVENTIONS,
        add_static_root,
        all_channels,
        bone_local_axes,
        rename,
    )
    from mjchar.bvh.rotations import quat_from_rotvec, quat_mul

    walk = bvh.load(shared_clip("walk60.bvh"))
    lean = walk.copy()
    sk = lean.skeleton
    for name, deg, axis in (("lowerback_torso", 35.0, 0), ("lShoulder", -60.0, 2),
                            ("rShoulder", 60.0, 2)):
        j = sk.index(name)
        lean.rotations[:, j] = quat_mul(quat_from_rotvec(np.radians(deg) * np.eye(3)[axis]),
                                        lean.rotations[:, j])

    def gamestudio(m):
        r = bone_local_axes(rename(m, CONVENTIONS["gamestudio"]), twist_deg=-31.0)
        r = add_static_root(all_channels(r, "ZXY", six=True), "joint_Root")
        return convert(bvh.loads(bvh.dumps(r)))

    a, b = gamestudio(walk), gamestudio(lean)
    assert abs(a.summary["height_m"] - b.summary["height_m"]) < 1e-3
    np.testing.assert_allclose(a.compile().body_pos, b.compile().body_pos, atol=1e-3)
