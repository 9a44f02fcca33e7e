"""Joint roles for many naming conventions, by shape, and from a user roles file; bad rigs fail
with one line and exit status 2 from ``mjchar convert``."""

from __future__ import annotations

import numpy as np
import pytest

from mjchar import bvh
from mjchar.bvh.bundled.humanoid_skeleton import humanoid_rest_motion, humanoid_skeleton
from mjchar.bvh.bundled.zoo import _UPLEG_LIMB, CONVENTIONS, _names, rename
from mjchar.bvh.io.skeleton import Skeleton
from mjchar.bvh.mjcf import ConversionError, ModelInfo, convert
from mjchar.bvh.mjcf.roles import load_roles
from mjchar.bvh.rigs.naming import recognise
from mjchar.cli import main as cli_main


def _renamed(mapping: dict[str, str]) -> Skeleton:
    return rename(humanoid_rest_motion(), mapping).skeleton


#: naming conventions of real exports beside the rig zoo's (:data:`CONVENTIONS`, Daz/Poser's
#: among them): MakeHuman's CMU-MB (lower case, side letters glued on), Xsens MVN as its BVH
#: export writes it, Perception Neuron, CMU's ASF names, Mixamo under a numbered namespace and
#: under a Blender armature
REAL_CONVENTIONS = {
    "makehuman": _names(("hip", "abdomen", "chest", "head"),
                        ("{s}hip", "{s}knee", "{s}foot", "{s}toe", "{s}collar",
                         "{s}shoulder", "{s}elbow", "{s}hand"), "l", "r"),
    "xsens-bvh": _names(("Hips", "Chest", "Chest4", "Head"),
                        ("{s}Hip", "{s}Knee", "{s}Ankle", "{s}Toe", "{s}Collar",
                         "{s}Shoulder", "{s}Elbow", "{s}Wrist"), "Left", "Right"),
    "neuron": _names(("Hips", "Spine", "Spine3", "Head"), _UPLEG_LIMB, "Left", "Right"),
    "asf": _names(("root", "lowerback", "thorax", "head"),
                  ("{s}femur", "{s}tibia", "{s}foot", "{s}toes", "{s}clavicle",
                   "{s}humerus", "{s}radius", "{s}wrist"), "l", "r"),
    "mixamo7": _names(("Hips", "Spine", "Spine2", "Head"), _UPLEG_LIMB, "Left", "Right",
                      prefix="mixamorig7:"),
    "armature": {g: f"Armature|{n}" for g, n in CONVENTIONS["gamestudio"].items()},
}


#: every convention tested: the zoo's under their names, the real exports' as ``real-NAME``
ALL_CONVENTIONS = CONVENTIONS | {f"real-{k}": v for k, v in REAL_CONVENTIONS.items()}


@pytest.mark.parametrize("convention", sorted(ALL_CONVENTIONS))
def test_conventions_are_recognised(convention):
    mapping = ALL_CONVENTIONS[convention]
    rec = recognise(_renamed(mapping))
    for g, role in (("lHip", "left_hip"), ("rKnee", "right_knee"), ("lAnkle", "left_ankle"),
                    ("rToeJoint", "right_toe"), ("lShoulder", "left_shoulder"),
                    ("rElbow", "right_elbow"), ("lWrist", "left_wrist"),
                    ("rTorso_Clavicle", "right_clavicle"), ("torso_head", "head"),
                    ("RootJoint", "pelvis")):
        assert rec.roles[role] == mapping[g], (convention, role)
    assert rec.by_structure == [] and rec.unrecognised == []


@pytest.mark.parametrize("left,right", [("LegUpper_L", "LegUpper_R"),
                                        ("Left_UpperLeg", "Right_UpperLeg")])
def test_upper_leg_names_are_not_knees(left, right):
    mapping = {"lHip": left, "rHip": right, "lKnee": left.replace("Upper", "Lower"),
               "rKnee": right.replace("Upper", "Lower")}
    rec = recognise(_renamed(mapping))
    assert rec.roles["left_hip"] == left and rec.roles["right_knee"] == mapping["rKnee"]


def _save(tmp_path, motion_or_skeleton, name="rig.bvh"):
    m = motion_or_skeleton
    if isinstance(m, Skeleton):
        m = bvh.Motion.rest(m, 2)
    path = tmp_path / name
    bvh.save(m, path)
    return path


def _skeleton_without(names: tuple[str, ...]) -> Skeleton:
    sk = humanoid_skeleton()
    keep = [i for i, n in enumerate(sk.names) if not n.endswith(names)]
    es = [e for e, p in enumerate(sk.end_site_parents) if p in keep]
    return Skeleton([sk.names[i] for i in keep],
                    np.array([keep.index(p) if p >= 0 else -1 for p in sk.parents[keep]]),
                    sk.offsets[keep], [sk.channels[i] for i in keep],
                    [keep.index(sk.end_site_parents[e]) for e in es], sk.end_site_offsets[es])


def _legs_together() -> Skeleton:
    """Meaningless names and both hips at the pelvis centre, legs side by side at x = 0."""
    sk = humanoid_skeleton()
    off = sk.offsets.copy()
    for n in ("lHip", "rHip"):
        off[sk.index(n), 0] = 0.0
    return Skeleton([f"j{i}" for i in range(sk.n_joints)], sk.parents, off, sk.channels,
                    sk.end_site_parents, sk.end_site_offsets)


def _cli(argv, capsys) -> tuple[int, str]:
    code = cli_main(argv)
    err = capsys.readouterr().err.strip()
    return code, err


@pytest.mark.parametrize("rig,match", [
    (lambda: _skeleton_without(("Hip", "Knee", "Ankle", "ToeJoint")), "no legs"),
    (lambda: _skeleton_without(("rHip", "rKnee", "rAnkle", "rToeJoint")), "one leg only"),
    (_legs_together, "left and right cannot be told apart"),
])
def test_bad_rigs_fail_in_one_line(tmp_path, capsys, rig, match):
    path = _save(tmp_path, rig())
    code, err = _cli(["convert", str(path), "-o", str(tmp_path / "x.xml")], capsys)
    assert code == 2 and len(err.splitlines()) == 1
    assert match in err and "missing essential roles" in err and "--roles" in err


def test_roles_file_rescues_a_rig(tmp_path, capsys):
    path = _save(tmp_path, _legs_together())
    roles = tmp_path / "roles.toml"
    roles.write_text('# which leg is which\n[roles]\nleft_knee = "j13"\nright_knee = "j17"\n'
                     'spine = ["j1", "j2"]\n')
    code, err = _cli(["convert", str(path), "-o", str(tmp_path / "x.xml"), "--roles",
                      str(roles)], capsys)
    assert code == 0, err
    info = ModelInfo.from_xml_path(tmp_path / "x.xml")
    assert info.roles["left_knee"] == "j13" and info.roles["left_hip"] == "j12"
    assert info.roles["right_ankle"] == "j18" and info.roles["spine"] == ["j1", "j2"]


@pytest.mark.parametrize("text,match", [
    ('left_knee = "NoSuchJoint"\n', "names joints the skeleton does not have: "
                                    "left_knee = 'NoSuchJoint'"),
    ("left_knee = \n", "is not valid TOML"),
    ('[roles\nleft_knee = "lKnee"\n', "is not valid TOML"),
    ('left_kneecap = "lKnee"\n', "unknown role 'left_kneecap'"),
    ("left_knee = 3\n", "must be a joint name"),
])
def test_bad_roles_files_fail_in_one_line(tmp_path, capsys, text, match):
    path = _save(tmp_path, humanoid_skeleton())
    roles = tmp_path / "roles.toml"
    roles.write_text(text)
    code, err = _cli(["convert", str(path), "-o", str(tmp_path / "x.xml"), "--roles",
                      str(roles)], capsys)
    assert code == 2 and len(err.splitlines()) == 1 and match in err, err


def test_roles_mapping_overrides_names():
    sk = humanoid_skeleton()
    c = convert(sk, roles={"head": "lowerback_torso"})  # a perverse but valid choice
    assert c.info.roles["head"] == "lowerback_torso"
    assert load_roles({"roles": {"pelvis": "RootJoint"}}) == {"pelvis": "RootJoint"}
    with pytest.raises(ConversionError, match="spine must be"):
        load_roles({"spine": 3})


def test_info_says_where_each_role_came_from(tmp_path, capsys):
    """``mjchar info``: the role map with each joint's provenance (its name, or the skeleton's
    shape), the unit and the height of the body the converter would build."""
    from mjchar.bvh.bundled.assets import motion_path

    named = motion_path("walk")
    assert cli_main(["info", str(named)]) == 0
    out = capsys.readouterr().out
    assert "left knee       lKnee (name)" in out and "unit: m (1 m per file unit" in out
    assert "the body it would build: 1.6" in out
    anon = _save(tmp_path, _renamed({n: f"j{i}" for i, n in
                                     enumerate(humanoid_skeleton().names)}), "anon.bvh")
    assert cli_main(["info", str(anon)]) == 0
    out = capsys.readouterr().out
    assert "left knee       j13 (shape)" in out and "right elbow     j10 (shape)" in out
    assert "pelvis          j0 (shape)" in out and "head            j3 (shape)" in out
    assert "spine           j1, j2 (shape)" in out
    roles = tmp_path / "roles.toml"
    roles.write_text('left_knee = "j13"\nright_knee = "j17"\n')
    assert cli_main(["info", str(anon), "--roles", str(roles)]) == 0
    assert "left knee       j13 (given)" in capsys.readouterr().out
