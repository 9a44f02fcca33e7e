"""The converter on the capture families users bring: up axes that point down, decimetres,
knees that twist while they bend (generated files; the real exports are tests/test_real_exports.py).
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from mjchar import bvh
from mjchar.bvh.bundled.assets import motion_path
from mjchar.bvh.mjcf import convert
from mjchar.bvh.rigs.units import transform_motion
from mjchar.bvh.rotations import quat_from_rotvec, quat_mul
from tests.conftest import run_command


@pytest.fixture(scope="module")
def walk() -> bvh.Motion:
    """The bundled walk: metres, Y-up, facing +Z."""
    return bvh.load(motion_path("walk"))


def _knee_axis(model: mujoco.MjModel, side: str) -> np.ndarray:
    for j in range(model.njnt):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j)
        if name.startswith(f"{side}Knee"):
            return model.jnt_axis[j].copy()
    raise AssertionError(f"no {side}Knee hinge")


def test_up_axis_pointing_down_is_detected(walk, tmp_path, capsys):
    """The walk written with +Y pointing down (an Azure Kinect export's camera frame): read as
    -y, the same body stands up, and the replay is as exact as the original's."""
    down = transform_motion(walk, 1.0, quat_from_rotvec([0.0, 0.0, np.pi]))  # y -> -y
    ref, c = convert(walk), convert(down)
    assert ref.info.up_axis == "y" and c.info.up_axis == "-y"
    assert c.summary["height_m"] == pytest.approx(ref.summary["height_m"], abs=1e-3)
    assert c.summary["n_dofs"] == ref.summary["n_dofs"]
    assert not any("stood upright" in w for w in c.warnings)
    given = convert(down, up_axis="-y")
    assert given.summary["height_m"] == pytest.approx(c.summary["height_m"], abs=1e-9)
    from mjchar.bvh.reference.reference_motion import replay_errors

    assert replay_errors(c.compile(), c.motion)["max_mm"] < 20.0
    path = tmp_path / "down.bvh"
    bvh.save(down, path)
    capsys.readouterr()
    assert run_command(["convert", str(path), "-o", str(tmp_path / "d.xml"), "--up", "-y"]) == 0
    assert "up axis -y" in capsys.readouterr().out


def test_up_axis_option_refuses_nonsense(walk):
    with pytest.raises(bvh.MjcharError, match="-x, -y or -z"):
        convert(walk, up_axis="+w")


def test_decimetres_from_the_body(walk):
    """A Blender scene in decimetres (Z-up), a 1.55 m body: read in dm, not at a fitted
    scale, and said in the unit line."""
    zup = transform_motion(walk, 10.0 * 1.55 / convert(walk).summary["height_m"],
                           quat_from_rotvec([np.pi / 2, 0.0, 0.0]))
    c = convert(zup)
    assert c.info.up_axis == "z"
    assert c.summary["unit_name"] == "dm" and c.summary["unit_scale"] == 0.1
    assert c.summary["height_m"] == pytest.approx(1.55, abs=0.01)


def test_fitted_scale_said_in_one_line(walk, tmp_path, capsys):
    """No known unit fits (a body 8.5 units tall): the fitted scale is used and said."""
    odd = transform_motion(walk, 8.5 / convert(walk).summary["height_m"])
    path = tmp_path / "odd.bvh"
    bvh.save(odd, path)
    capsys.readouterr()
    assert run_command(["convert", str(path), "-o", str(tmp_path / "o.xml")]) == 0
    line = [ln for ln in capsys.readouterr().out.splitlines() if "unit:" in ln]
    assert len(line) == 1 and "no known unit fits" in line[0]


def _twisting_knees(walk: bvh.Motion, ratio: float) -> bvh.Motion:
    """The walk with each knee twisting about its shank by ``ratio`` times its flexion (the
    ankles stay where they were: only the feet turn)."""
    m = walk.copy()
    sk = m.skeleton
    for s in "lr":
        k, a = sk.index(f"{s}Knee"), sk.index(f"{s}Ankle")
        e = sk.offsets[a] / np.linalg.norm(sk.offsets[a])
        q = m.rotations[:, k]
        angle = 2.0 * np.arccos(np.clip(np.abs(q[:, 0]), 0.0, 1.0))
        twist = quat_from_rotvec(ratio * angle[:, None] * e)
        m.rotations[:, k] = quat_mul(q, twist)
    return m


def test_knee_hinge_fitted_on_the_flexion_not_the_twist(walk):
    """Knees that twist while they flex (0.8 x the flexion: up to ~50 deg): the hinge is still
    the lateral axis (MuJoCo y), as for the untwisted clip; the whole rotation's principal
    axis, the old fit, is far off it."""
    from mjchar.bvh.mjcf.dynamics import _flexion_from_clip
    from mjchar.bvh.rotations import quat_to_rotvec

    twisted = _twisting_knees(walk, 0.8)
    model = convert(twisted).compile()
    for s in "lr":
        axis = _knee_axis(model, s)
        assert abs(axis[1]) > np.cos(np.radians(5.0)), (s, axis)
    # the same clip fitted on the whole rotation vectors
    sk = twisted.skeleton
    k = sk.index("lKnee")
    rv = quat_to_rotvec(twisted.rotations[:, k])
    naive = _flexion_from_clip(None, rv)
    assert naive is not None
    lateral = np.array([1.0, 0.0, 0.0])  # the file's left-right axis (Y-up, facing +Z)
    assert abs(float(naive[2] @ lateral)) < np.cos(np.radians(25.0)), naive


# -- not a two-legged humanoid ----------------------------------------------------------------
SIX = ("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation")
THREE = ("Zrotation", "Xrotation", "Yrotation")


def _rig(joints: list[tuple[str, str | None, tuple]], ends: dict[str, tuple]) -> bvh.Skeleton:
    """A skeleton from ``(name, parent, offset)`` rows (the root first) and end sites."""
    names = [n for n, _, _ in joints]
    parents = [-1 if p is None else names.index(p) for _, p, _ in joints]
    offsets = np.array([o for _, _, o in joints], dtype=float)
    channels = [SIX if p is None else THREE for _, p, _ in joints]
    ep = [names.index(n) for n in ends]
    eo = np.array(list(ends.values()), dtype=float).reshape(-1, 3)
    return bvh.Skeleton(names, parents, offsets, channels, ep, eo)


def _moving(sk: bvh.Skeleton, swing: list[str], n_frames: int = 40) -> bvh.Motion:
    """The rest pose walking forward along +Z at 0.5 units per frame, the ``swing`` joints
    turning +-10 degrees about X, alternately."""
    m = bvh.Motion.rest(sk, n_frames)
    t = np.arange(n_frames)
    m.local_positions[:, 0, 2] += 0.5 * t
    for i, name in enumerate(swing):
        a = np.radians(10.0) * np.sin(2 * np.pi * t / 20 + np.pi * (i % 2))
        m.rotations[:, sk.index(name)] = quat_from_rotvec(a[:, None] * np.array([1.0, 0, 0]))
    return m


def quadruped_biped_names() -> bvh.Motion:
    """A dog rigged with 3ds Max Biped names (cm, Y-up, facing +Z): hind legs under the pelvis,
    front legs hanging from the chest as 'arms', all four feet on the floor."""
    rows = [("Bip01", None, (0, 60, 0)), ("Bip01 Spine", "Bip01", (0, 2, 15)),
            ("Bip01 Spine1", "Bip01 Spine", (0, 0, 25)), ("Bip01 Neck", "Bip01 Spine1", (0, 5, 20)),
            ("Bip01 Head", "Bip01 Neck", (0, 10, 15))]
    for s, x in (("L", 8.0), ("R", -8.0)):
        rows += [(f"Bip01 {s} Thigh", "Bip01", (x, -5, 0)),
                 (f"Bip01 {s} Calf", f"Bip01 {s} Thigh", (0, -25, 0)),
                 (f"Bip01 {s} Foot", f"Bip01 {s} Calf", (0, -25, -3)),
                 (f"Bip01 {s} Toe0", f"Bip01 {s} Foot", (0, -5, 5)),
                 (f"Bip01 {s} Clavicle", "Bip01 Spine1", (x / 2, 0, 0)),
                 (f"Bip01 {s} UpperArm", f"Bip01 {s} Clavicle", (x / 2, -5, 0)),
                 (f"Bip01 {s} Forearm", f"Bip01 {s} UpperArm", (0, -27, 0)),
                 (f"Bip01 {s} Hand", f"Bip01 {s} Forearm", (0, -25, 0)),
                 (f"Bip01 {s} Finger0", f"Bip01 {s} Hand", (0, -5, 4))]
    ends = {"Bip01 Head": (0, 0, 10)} | {f"Bip01 {s} {p}": (0, 0, 4)
                                        for s in "LR" for p in ("Toe0", "Finger0")}
    sk = _rig(rows, ends)
    return _moving(sk, [f"Bip01 {s} {p}" for p in ("Thigh", "UpperArm") for s in "LR"])


def crab() -> bvh.Motion:
    """Eight three-segment legs around a flat body, a pair of claws (m, Y-up)."""
    rows = [("carapace", None, (0, 0.1, 0))]
    for k in range(4):
        for s, x in (("a", 1.0), ("b", -1.0)):
            n = f"walker{k}{s}"
            rows += [(f"{n}_coxa", "carapace", (0.05 * x, 0, 0.04 * (k - 1.5))),
                     (f"{n}_merus", f"{n}_coxa", (0.08 * x, 0.03, 0)),
                     (f"{n}_carpus", f"{n}_merus", (0.07 * x, -0.06, 0)),
                     (f"{n}_dactyl", f"{n}_carpus", (0.03 * x, -0.07, 0))]
    for s, x in (("a", 1.0), ("b", -1.0)):
        rows += [(f"cheliped_{s}", "carapace", (0.03 * x, 0.01, 0.06)),
                 (f"claw_{s}", f"cheliped_{s}", (0.02 * x, 0.0, 0.05))]
    sk = _rig(rows, {f"walker{k}{s}_dactyl": (0, -0.005, 0) for k in range(4) for s in "ab"})
    return _moving(sk, [f"walker{k}{s}_merus" for k in range(4) for s in "ab"])


def hand() -> bvh.Motion:
    """A right hand capture: the wrist and five fingers curling (cm, Y-up)."""
    rows = [("RightHand", None, (0, 100, 0))]
    for f, x in (("Thumb", -3.0), ("Index", -2.0), ("Middle", 0.0), ("Ring", 2.0),
                 ("Pinky", 3.5)):
        prev = "RightHand"
        for k, length in enumerate((5.0, 4.0, 2.5, 2.0)[(1 if f == "Thumb" else 0):]):
            n = f"RightHand{f}{k + 1}"
            rows.append((n, prev, (x if k == 0 else 0.0, 0, length)))
            prev = n
    sk = _rig(rows, {n: (0, 0, 1.5) for n, _, _ in rows if n[-1] in "34" and
                     not any(r[1] == n for r in rows)})
    return _moving(sk, [n for n, _, _ in rows if n.endswith("2")])


def upper_body() -> bvh.Motion:
    """Hips, spine, head and two arms: a capture with no legs (cm, Y-up)."""
    rows = [("Hips", None, (0, 100, 0)), ("Spine", "Hips", (0, 10, 0)),
            ("Spine1", "Spine", (0, 15, 0)), ("Neck", "Spine1", (0, 20, 0)),
            ("Head", "Neck", (0, 10, 0))]
    for s, x in (("Left", 1.0), ("Right", -1.0)):
        rows += [(f"{s}Shoulder", "Spine1", (5 * x, 15, 0)),
                 (f"{s}Arm", f"{s}Shoulder", (12 * x, 0, 0)),
                 (f"{s}ForeArm", f"{s}Arm", (28 * x, 0, 0)),
                 (f"{s}Hand", f"{s}ForeArm", (25 * x, 0, 0))]
    sk = _rig(rows, {"Head": (0, 18, 0), "LeftHand": (8, 0, 0), "RightHand": (-8, 0, 0)})
    return _moving(sk, ["LeftArm", "RightArm"])


def three_point_vr() -> bvh.Motion:
    """A three-point VR capture: head and two hand trackers under a floor origin (m)."""
    sk = _rig([("origin", None, (0, 0, 0)), ("hmd", "origin", (0, 1.65, 0)),
               ("controller_left", "origin", (0.25, 1.0, 0.2)),
               ("controller_right", "origin", (-0.25, 1.0, 0.2))],
              {"hmd": (0, 0.1, 0), "controller_left": (0, 0, 0.1),
               "controller_right": (0, 0, 0.1)})
    return _moving(sk, ["controller_left", "controller_right"])


NOT_HUMANOIDS = {"quadruped": (quadruped_biped_names, "4 limbs reaching the floor"),
                 "crab": (crab, "8 limbs reaching the floor"),
                 "hand": (hand, "not a humanoid"),
                 "upper_body": (upper_body, "no legs"),
                 "three_point_vr": (three_point_vr, "no legs")}


@pytest.mark.parametrize("name", sorted(NOT_HUMANOIDS))
def test_not_a_humanoid_is_refused_in_one_line(name, tmp_path, capsys):
    from mjchar.cli import main as cli_main

    make, said = NOT_HUMANOIDS[name]
    path = tmp_path / f"{name}.bvh"
    bvh.save(make(), path)
    assert cli_main(["convert", str(path), "-o", str(tmp_path / "x.xml")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "not a humanoid" in err[0] and said in err[0], err
    assert not (tmp_path / "x.xml").exists()


def test_quadruped_rest_pose_alone_is_refused():
    """The quadruped's skeleton without a clip: its rest pose stands on four feet."""
    sk = quadruped_biped_names().skeleton
    with pytest.raises(bvh.MjcharError, match="4 limbs reaching the floor in the rest pose"):
        convert(sk)


# -- glitch frames ----------------------------------------------------------------------------
def glitched(walk: bvh.Motion, start: int, n: int, jump_m: float = 1460.0) -> bvh.Motion:
    """The walk with its root thrown ``jump_m`` sideways for ``n`` frames from ``start``."""
    m = walk.copy()
    m.local_positions[start:start + n, 0, 0] += jump_m
    return m


def test_glitch_frames_found_from_physical_limits(walk):
    from mjchar.bvh.rigs.glitches import find_glitches

    assert not find_glitches(walk)
    g = find_glitches(glitched(walk, 20, 5))
    assert g.runs == [(20, 25)] and int(g.frames.sum()) == 5
    assert g.root_jump_m == pytest.approx(1460.0, rel=1e-3)
    m = walk.copy()  # a leg turned half a turn for two frames
    k = m.skeleton.index("lHip")
    m.rotations[30:32, k] = quat_mul(m.rotations[30:32, k],
                                     quat_from_rotvec([3.0, 0.0, 0.0]))
    assert find_glitches(m).runs == [(30, 32)]


def test_glitch_frames_flagged_by_the_converter(walk, tmp_path, capsys):
    c = convert(glitched(walk, 20, 5))
    said = [w for w in c.warnings if w.startswith("glitch frames")]
    assert len(said) == 1 and "frames 20-24" in said[0] and "body jumps up to" in said[0]
    assert not any(w.startswith("glitch") for w in convert(walk).warnings)


# -- clip conditioning ------------------------------------------------------------------------
@pytest.fixture(scope="module")
def walk_info(walk):
    return convert(walk).info


def test_conditioning_repairs_short_glitch_runs(walk, walk_info):
    from mjchar.bvh.reference.conditioning import condition
    from mjchar.bvh.rigs.glitches import find_glitches

    c = condition(glitched(walk, 20, 5), walk_info)
    assert c.repaired == [(20, 25)] and not find_glitches(c.motion)
    raw = condition(walk, walk_info).motion  # the clean clip through the same steps
    gap = np.linalg.norm(c.motion.local_positions[20:25, 0] - raw.local_positions[20:25, 0],
                         axis=1)
    assert gap.max() < 0.05  # metres: the interpolated root is where the clip went


def test_conditioning_refuses_long_glitch_runs(walk, walk_info):
    from mjchar.bvh.reference.conditioning import ConditioningError, condition

    with pytest.raises(ConditioningError, match="too long to repair") as e:
        condition(glitched(walk, 10, 20), walk_info, "walk.bvh")  # 0.33 s
    assert "\n" not in str(e.value) and "frames 10-29" in str(e.value)


def test_conditioning_puts_floating_sliding_feet_on_the_floor(walk, walk_info):
    """The walk lifted 0.15 m and made to walk in place (its feet slide back in stance, as a
    clip lifted from video does): conditioning labels the contacts, puts the standing feet on
    the floor and removes most of the skating."""
    from mjchar.bvh.kinematics.fk import forward_kinematics
    from mjchar.bvh.reference.conditioning import condition

    m = walk.copy()
    m.local_positions[:, 0, 1] += 0.15
    m.local_positions[:, 0, 2] = m.local_positions[0, 0, 2]  # no forward travel
    c = condition(m, walk_info)
    assert c.contacts.any(axis=1).mean() > 0.6
    assert c.skate_mps[0] > 0.5 and c.skate_mps[1] < 0.2 * c.skate_mps[0]
    assert c.height_offset_m < -0.1
    feet = [m.skeleton.index(n) for n in ("lAnkle", "lToeJoint", "rAnkle", "rToeJoint")]
    P = forward_kinematics(c.motion).positions[:, feet, 1]
    lowest = np.minimum(P[:, :2].min(axis=1), P[:, 2:].min(axis=1))
    on = c.contacts.any(axis=1)
    assert np.abs(lowest[on]).max() < 0.045 and np.median(np.abs(lowest[on])) < 0.01
    # the clean walk is hardly touched
    clean = condition(walk, walk_info)
    assert clean.skate_mps[1] <= clean.skate_mps[0] + 1e-9


def test_trackers_take_the_conditioned_clip_and_report_both_errors(walk, tmp_path):
    """Hand-of-god on the floating clip that walks in place: the run follows the conditioned
    clip and reports its error against the raw one too."""
    from mjchar.controllers.core.builder import run

    m = walk.copy()
    m.local_positions[:, 0, 1] += 0.15
    m.local_positions[:, 0, 2] = m.local_positions[0, 0, 2]
    path = tmp_path / "inplace.bvh"
    bvh.save(m, path)
    r = run("hand_of_god", "track", motion=str(path), duration=0.3)
    assert r.extra["tracking_error_raw_m"] > r.tracking_error_m
    assert "clip conditioned" in r.extra["conditioning"]
    assert "against the raw clip" in r.summary()


# -- the families' joint names ----------------------------------------------------------------
_TRUNK = ("RootJoint", "pelvis_lowerback", "lowerback_torso", "torso_head")
_LIMB = ("Hip", "Knee", "Ankle", "ToeJoint", "Torso_Clavicle", "Shoulder", "Elbow", "Wrist")


def _family(trunk, limb, left, right) -> dict[str, str]:
    out = dict(zip(_TRUNK, trunk, strict=True))
    for p, pat in zip(_LIMB, limb, strict=True):
        out[f"l{p}"], out[f"r{p}"] = pat.format(s=left), pat.format(s=right)
    return out


#: joint names as the families write them (the bundled walk's joints renamed), with the unit
#: (metres per unit) and the up axis their exports use
FAMILIES = {
    "azure_kinect": (_family(("PELVIS", "SPINE_NAVAL", "SPINE_CHEST", "HEAD"),
                             ("HIP_{s}", "KNEE_{s}", "ANKLE_{s}", "FOOT_{s}", "CLAVICLE_{s}",
                              "SHOULDER_{s}", "ELBOW_{s}", "WRIST_{s}"), "LEFT", "RIGHT"),
                     0.001, "-y"),
    "perception_neuron": (_family(("Hips", "Spine", "Spine2", "Head"),
                                  ("{s}UpLeg", "{s}Leg", "{s}Foot", "{s}ToeBase", "{s}Shoulder",
                                   "{s}Arm", "{s}ForeArm", "{s}Hand"), "Left", "Right"),
                          0.01, "y"),
    "rokoko": (_family(("Hips", "Spine1", "Spine4", "Head"),
                       ("{s}Thigh", "{s}Shin", "{s}Foot", "{s}Toe", "{s}Shoulder", "{s}Arm",
                        "{s}ForeArm", "{s}Hand"), "Left", "Right"), 0.01, "y"),
    "unity_humanoid": (_family(("Hips", "Spine", "Chest", "Head"),
                               ("{s}UpperLeg", "{s}LowerLeg", "{s}Foot", "{s}Toes",
                                "{s}Shoulder", "{s}UpperArm", "{s}LowerArm", "{s}Hand"),
                               "Left", "Right"), 1.0, "y"),
    "smplx": (_family(("pelvis", "spine1", "spine3", "head"),
                      ("{s}_hip", "{s}_knee", "{s}_ankle", "{s}_foot", "{s}_collar",
                       "{s}_shoulder", "{s}_elbow", "{s}_wrist"), "left", "right"), 1.0, "y"),
    "smpl": (_family(("Pelvis", "Spine1", "Spine3", "Head"),
                     ("{s}_Hip", "{s}_Knee", "{s}_Ankle", "{s}_Foot", "{s}_Collar",
                      "{s}_Shoulder", "{s}_Elbow", "{s}_Wrist"), "L", "R"), 1.0, "y"),
    "sfu_vicon": (_family(("Hips", "Spine", "Spine1", "Head"),
                          ("{s}UpLeg", "{s}Leg", "{s}Foot", "{s}ToeBase", "{s}Shoulder",
                           "{s}Arm", "{s}ForeArm", "{s}Hand"), "Left", "Right"), 0.01, "y"),
    "makehuman_default": (_family(("root", "spine04", "spine02", "head"),
                                  ("upperleg01.{s}", "lowerleg01.{s}", "foot.{s}", "toe1-1.{s}",
                                   "clavicle.{s}", "upperarm01.{s}", "lowerarm01.{s}",
                                   "wrist.{s}"), "L", "R"), 0.1, "z"),
    "max_biped": (_family(("Bip01", "Bip01 Spine", "Bip01 Spine1", "Bip01 Head"),
                          ("Bip01 {s} Thigh", "Bip01 {s} Calf", "Bip01 {s} Foot",
                           "Bip01 {s} Toe0", "Bip01 {s} Clavicle", "Bip01 {s} UpperArm",
                           "Bip01 {s} Forearm", "Bip01 {s} Hand"), "L", "R"), 0.0254, "z"),
    "blender_rigify": (_family(("pelvis", "spine", "chest", "head"),
                               ("thigh.{s}", "shin.{s}", "foot.{s}", "toe.{s}", "shoulder.{s}",
                                "upper_arm.{s}", "forearm.{s}", "hand.{s}"), "L", "R"),
                       1.0, "z"),
}
_TURN = {"y": None, "-y": [0.0, 0.0, np.pi], "z": [np.pi / 2, 0.0, 0.0]}


@pytest.mark.parametrize("family", sorted(FAMILIES))
def test_capture_families_convert_with_their_names_units_and_axes(family, walk):
    from mjchar.bvh.bundled.zoo import rename

    names, unit, up = FAMILIES[family]
    turn = _TURN[up]
    m = transform_motion(rename(walk, names), 1.0 / unit,
                         None if turn is None else quat_from_rotvec(turn))
    ref, c = convert(walk), convert(m)
    assert c.info.up_axis == up and c.summary["unit_scale"] == pytest.approx(unit)
    assert c.summary["height_m"] == pytest.approx(ref.summary["height_m"], abs=2e-3)
    for g, role in (("lHip", "left_hip"), ("rKnee", "right_knee"), ("lAnkle", "left_ankle"),
                    ("rToeJoint", "right_toe"), ("lShoulder", "left_shoulder"),
                    ("rElbow", "right_elbow"), ("lWrist", "left_wrist"),
                    ("rTorso_Clavicle", "right_clavicle"), ("torso_head", "head"),
                    ("RootJoint", "pelvis")):
        assert c.info.roles[role] == names[g], (family, role)


def azure_kinect() -> bvh.Motion:
    """The Azure Kinect body-tracking hierarchy (32 joints: face points, hand tips and thumbs
    included) in its camera frame: mm, +Y pointing down, walking towards the camera (-Z)."""
    rows = [("PELVIS", None, (0, 0, 0)), ("SPINE_NAVAL", "PELVIS", (0, -180, 0)),
            ("SPINE_CHEST", "SPINE_NAVAL", (0, -150, 0)), ("NECK", "SPINE_CHEST", (0, -200, 0)),
            ("HEAD", "NECK", (0, -80, 0)), ("NOSE", "HEAD", (0, 0, -100)),
            ("EYE_LEFT", "HEAD", (30, -30, -80)), ("EAR_LEFT", "HEAD", (70, -20, 0)),
            ("EYE_RIGHT", "HEAD", (-30, -30, -80)), ("EAR_RIGHT", "HEAD", (-70, -20, 0))]
    for s, x in (("LEFT", 1), ("RIGHT", -1)):
        rows += [(f"CLAVICLE_{s}", "SPINE_CHEST", (30 * x, -150, 0)),
                 (f"SHOULDER_{s}", f"CLAVICLE_{s}", (140 * x, 0, 0)),
                 (f"ELBOW_{s}", f"SHOULDER_{s}", (280 * x, 0, 0)),
                 (f"WRIST_{s}", f"ELBOW_{s}", (250 * x, 0, 0)),
                 (f"HAND_{s}", f"WRIST_{s}", (80 * x, 0, 0)),
                 (f"HANDTIP_{s}", f"HAND_{s}", (60 * x, 0, 0)),
                 (f"THUMB_{s}", f"WRIST_{s}", (40 * x, 0, -50)),
                 (f"HIP_{s}", "PELVIS", (90 * x, 0, 0)), (f"KNEE_{s}", f"HIP_{s}", (0, 420, 0)),
                 (f"ANKLE_{s}", f"KNEE_{s}", (0, 400, 0)),
                 (f"FOOT_{s}", f"ANKLE_{s}", (0, 60, -140))]
    sk = _rig(rows, {})
    m = bvh.Motion.rest(sk, 60)
    t = np.arange(60)
    m.local_positions[:, 0] = [0.0, -900.0, 2500.0]
    m.local_positions[:, 0, 2] -= 10.0 * t
    for i, s in enumerate(("LEFT", "RIGHT")):
        hip = 0.3 * np.sin(2 * np.pi * t / 30 + np.pi * i)
        knee = 0.4 * (1 + np.sin(2 * np.pi * t / 30 + np.pi * i))
        m.rotations[:, sk.index(f"HIP_{s}")] = quat_from_rotvec(hip[:, None] * [1.0, 0, 0])
        m.rotations[:, sk.index(f"KNEE_{s}")] = quat_from_rotvec(knee[:, None] * [1.0, 0, 0])
    return m


def test_azure_kinect_export_stands_up(tmp_path):
    """The whole Azure Kinect skeleton in its camera frame (+Y down, mm): up is -y, the unit mm,
    every role by name (face points under the head, hand tips and thumbs under the wrists),
    a 1.69 m body standing on the floor."""
    path = tmp_path / "kinect.bvh"
    bvh.save(azure_kinect(), path)
    c = convert(str(path))
    assert c.info.up_axis == "-y" and c.summary["unit_name"] == "mm"
    assert c.summary["height_m"] == pytest.approx(1.685, abs=0.01)
    roles = c.info.roles
    assert roles["left_knee"] == "KNEE_LEFT" and roles["right_elbow"] == "ELBOW_RIGHT"
    assert roles["left_toe"] == "FOOT_LEFT" and roles["head"] == "HEAD"
    assert roles["left_shoulder"] == "SHOULDER_LEFT" and roles["pelvis"] == "PELVIS"
    assert not c.warnings
    model = c.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    head = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "HEAD")
    assert data.xpos[head, 2] > 1.3  # standing, head up


def dinosaur() -> bvh.Motion:
    """A two-legged dinosaur with Biped names (cm, Y-up, facing +Z): legs under the pelvis, a
    level trunk and neck ahead, a tail behind, small arms."""
    rows = [("Bip01", None, (0, 100, 0)), ("Bip01 Spine", "Bip01", (0, 5, 30)),
            ("Bip01 Spine1", "Bip01 Spine", (0, 5, 30)),
            ("Bip01 Neck", "Bip01 Spine1", (0, 15, 25)), ("Bip01 Head", "Bip01 Neck", (0, 10, 25)),
            ("Bip01 Tail", "Bip01", (0, 0, -40)), ("Bip01 Tail1", "Bip01 Tail", (0, -5, -40))]
    for s, x in (("L", 1.0), ("R", -1.0)):
        rows += [(f"Bip01 {s} Thigh", "Bip01", (12 * x, -5, 0)),
                 (f"Bip01 {s} Calf", f"Bip01 {s} Thigh", (0, -45, 5)),
                 (f"Bip01 {s} Foot", f"Bip01 {s} Calf", (0, -45, -5)),
                 (f"Bip01 {s} Toe0", f"Bip01 {s} Foot", (0, -5, 12)),
                 (f"Bip01 {s} Clavicle", "Bip01 Spine1", (8 * x, 0, 5)),
                 (f"Bip01 {s} UpperArm", f"Bip01 {s} Clavicle", (4 * x, -8, 3)),
                 (f"Bip01 {s} Forearm", f"Bip01 {s} UpperArm", (0, -10, 4)),
                 (f"Bip01 {s} Hand", f"Bip01 {s} Forearm", (0, -5, 3))]
    sk = _rig(rows, {"Bip01 Head": (0, 0, 20), "Bip01 Tail1": (0, 0, -30)}
              | {f"Bip01 {s} Toe0": (0, 0, 5) for s in "LR"})
    return _moving(sk, ["Bip01 L Thigh", "Bip01 R Thigh"])


def test_a_two_legged_animal_is_not_a_humanoid(tmp_path, capsys):
    from mjchar.cli import main as cli_main

    path = tmp_path / "dino.bvh"
    bvh.save(dinosaur(), path)
    assert cli_main(["convert", str(path), "-o", str(tmp_path / "x.xml")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "not a humanoid" in err[0] and "from upright" in err[0], err


def test_a_wrong_up_axis_given_is_named_in_the_refusal():
    with pytest.raises(bvh.MjcharError, match="with --up -z: if that is not the file's up"):
        convert(azure_kinect(), up_axis="-z")
