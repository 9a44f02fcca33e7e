"""BVH reading and writing: round trips, formatting variants, the Euler encoding, error lines.

Round trips run on every shared clip (skipped with a message when ../shared/data is absent) and
on every file generated in tests/bvh_variants.py (units, axes, channel orders, zero-length
bones, 6-channel joints, 0-2 rotation channels, End Sites, tabs, CRLF/CR, scientific notation,
extra whitespace, CMU-style and Mixamo-style rigs).
"""

from __future__ import annotations

import numpy as np
import pytest
from bvh_variants import TAIT_BRYAN, Variant, all_variants, rot_channels
from scipy.spatial.transform import Rotation

from mjchar import bvh
from mjchar.bvh.io import reader as bvh_io
from mjchar.bvh.io.motion import _continuous_euler
from mjchar.bvh.io.skeleton import Skeleton
from mjchar.bvh.rotations import quat_from_euler, quat_from_rotvec, to_rotation

VARIANTS = all_variants()


def _by_name(name: str) -> Variant:
    return next(v for v in VARIANTS if v.name == name)


def _write(tmp_path, text: str, name: str = "clip.bvh"):
    path = tmp_path / name
    path.write_bytes(text.encode("utf-8"))
    return path


def _assert_same_skeleton(a: Skeleton, b: Skeleton, atol: float = 1e-6) -> None:
    assert a.names == b.names
    np.testing.assert_array_equal(a.parents, b.parents)
    np.testing.assert_allclose(a.offsets, b.offsets, atol=atol, rtol=0)
    assert a.channels == b.channels
    np.testing.assert_array_equal(a.end_site_parents, b.end_site_parents)
    np.testing.assert_allclose(a.end_site_offsets, b.end_site_offsets, atol=atol, rtol=0)


def _assert_round_trip(path) -> None:
    """parse -> write -> re-parse agree within 1e-6 on every channel value and FK position."""
    sk, frame_time, values = bvh.read_channels(path)
    motion = bvh.load(path)
    np.testing.assert_array_equal(motion.source_channels, values)
    again_path = path.with_name(path.stem + "-again.bvh")
    bvh.save(motion, again_path)
    sk2, frame_time2, values2 = bvh.read_channels(again_path)
    _assert_same_skeleton(sk, sk2)
    assert abs(frame_time2 - frame_time) <= 1e-9 * frame_time
    assert values2.shape == values.shape
    np.testing.assert_allclose(values2, values, atol=1e-6, rtol=0)
    fk = bvh.forward_kinematics(motion).positions
    fk2 = bvh.forward_kinematics(bvh.load(again_path)).positions
    np.testing.assert_allclose(fk2, fk, atol=1e-6, rtol=0)


# -- round trips ---------------------------------------------------------------------------------
def test_round_trip_shared_clip(shared_clip_path, tmp_path):
    clip = tmp_path / shared_clip_path.name
    clip.write_bytes(shared_clip_path.read_bytes())
    _assert_round_trip(clip)


@pytest.mark.parametrize("variant", VARIANTS, ids=lambda v: v.name)
def test_round_trip_generated(variant, tmp_path):
    _assert_round_trip(_write(tmp_path, variant.text))


@pytest.mark.parametrize("variant", VARIANTS, ids=lambda v: v.name)
def test_generated_file_reads_as_made(variant, tmp_path):
    """The reader gives back the values and positions the file was generated from."""
    motion = bvh.loads(variant.text)
    if variant.channels is not None:
        np.testing.assert_allclose(motion.source_channels, variant.channels, atol=1e-6, rtol=0)
    fk = bvh.forward_kinematics(motion)
    extent = float(np.ptp(variant.positions.reshape(-1, 3), axis=0).max())
    tol = 1e-6 * max(extent, 1.0)  # 6 printed decimals of angles, lever arms of `extent`
    np.testing.assert_allclose(fk.positions, variant.positions, atol=tol, rtol=0)
    np.testing.assert_allclose(bvh.end_site_positions(motion, fk), variant.end_sites, atol=tol,
                               rtol=0)


@pytest.mark.parametrize("variant", [v for v in VARIANTS if v.format_of],
                         ids=lambda v: v.name)
def test_text_formats_parse_identically(variant):
    """Tabs, CRLF, CR, scientific notation, whitespace, inline braces: the same doubles."""
    ref = bvh.loads(_by_name(variant.format_of).text)
    got = bvh.loads(variant.text)
    _assert_same_skeleton(got.skeleton, ref.skeleton, atol=0)
    assert got.frame_time == ref.frame_time
    np.testing.assert_array_equal(got.source_channels, ref.source_channels)


def test_variants_cover_the_brief():
    """The generated set holds every layout the brief lists (guards against silent drift)."""
    motions = {v.name: bvh.loads(v.text) for v in VARIANTS}
    sks = [m.skeleton for m in motions.values()]
    orders = {sk.rotation_order(j) for sk in sks for j in range(sk.n_joints)}
    assert set(TAIT_BRYAN) <= orders and "" in orders
    assert any(len(o) == 1 for o in orders) and any(len(o) == 2 for o in orders)
    assert any(sk.has_position_channels()[1:].any() for sk in sks)  # 6-channel non-root joints
    assert any((sk.bone_lengths()[1:] == 0).any() for sk in sks)  # zero-length bones
    assert any((np.linalg.norm(sk.end_site_offsets, axis=1) == 0).any() for sk in sks)
    assert any(sk.n_joints == 31 and sk.rotation_order(1) == "ZYX" for sk in sks)  # CMU-style
    assert any(all(n.startswith("mixamorig:") for n in sk.names) for sk in sks)
    texts = {v.name.rsplit("-", 1)[-1] for v in VARIANTS if v.format_of}
    assert {"crlf", "cr", "tabs", "scientific", "whitespace"} <= texts
    assert {v.unit_scale for v in VARIANTS} >= {1.0, 0.01, 0.0254}
    assert {v.up for v in VARIANTS} >= {"y", "z"}


def test_reencoding_rotations_alone_reproduces_channels(shared_clip_path):
    """Without the source-channel hint, the continuous Euler encoder finds the file's own
    angles again (they are principal and continuous in real clips)."""
    motion = bvh.load(shared_clip_path)
    values = motion.source_channels
    motion.source_channels = None
    np.testing.assert_allclose(motion.to_channels(), values, atol=1e-9, rtol=0)


@pytest.mark.parametrize("variant", [v for v in VARIANTS if not v.format_of],
                         ids=lambda v: v.name)
def test_reencoding_generated_without_hint(variant):
    motion = bvh.loads(variant.text)
    values = motion.source_channels
    motion.source_channels = None
    again = motion.to_channels()
    if "unprincipal" in variant.name:  # other Euler branch / beyond 180: same rotations only
        np.testing.assert_allclose(
            np.abs(np.sum(bvh.Motion.from_channels(motion.skeleton, 1.0, again).rotations
                          * motion.rotations, axis=-1)), 1.0, atol=1e-12)
        assert np.abs(again - values).max() > 90.0
    else:
        np.testing.assert_allclose(again, values, atol=1e-9, rtol=0)


def test_edited_joint_is_reencoded_others_keep_file_angles():
    motion = bvh.loads(_by_name(VARIANTS[0].name.split("-")[0] + "-unprincipal-angles").text)
    values = motion.source_channels.copy()
    motion.rotations[:, 3] = motion.rotations[::-1, 3]  # edit one joint
    out = motion.to_channels()
    starts = motion.skeleton.channel_starts()
    cols3 = np.arange(starts[3], starts[3] + len(motion.skeleton.channels[3]))
    others = np.setdiff1d(np.arange(values.shape[1]), cols3)
    np.testing.assert_array_equal(out[:, others], values[:, others])
    re = bvh.Motion.from_channels(motion.skeleton, 1.0, out)
    np.testing.assert_allclose(np.abs(np.sum(re.rotations[:, 3] * motion.rotations[:, 3], -1)),
                               1.0, atol=1e-12)


def test_fast_and_general_paths_agree_bit_for_bit(monkeypatch):
    """The vectorised frame parser and the one-statement-per-line hierarchy parser give exactly
    what the general token-by-token parser (Python float()) gives."""
    texts = [v.text for v in VARIANTS]
    fast = [bvh_io._parse(t, None) for t in texts]
    monkeypatch.setattr(bvh_io, "_fast_frames", lambda *a: None)
    monkeypatch.setattr(bvh_io, "_hierarchy_fast", lambda *a: None)
    for t, (sk, ft, values) in zip(texts, fast, strict=True):
        sk2, ft2, values2 = bvh_io._parse(t, None)
        _assert_same_skeleton(sk, sk2, atol=0)
        assert ft == ft2
        np.testing.assert_array_equal(values, values2)


@pytest.mark.parametrize("name", ["left  arm", "a\tb", "a\x0bb", "a\xa0b", "mixamorig:Hips"])
def test_joint_names_are_words_joined_by_one_space(name, monkeypatch):
    text = (f"HIERARCHY\nROOT {name}\n{{\nOFFSET 0 0 0\nCHANNELS 1 Xrotation\n}}\n"
            "MOTION\nFrames: 1\nFrame Time: 0.1\n5\n")
    want = " ".join(name.split())
    assert bvh.loads(text).skeleton.names == [want]
    monkeypatch.setattr(bvh_io, "_hierarchy_fast", lambda *a: None)
    assert bvh.loads(text).skeleton.names == [want]


@pytest.mark.parametrize("token", ["0", "-0", "+7", "5.", ".5", "-.5", "123456789012345",
                                   "1234567890123456", "-0.000000000000001", "99999999.9999999",
                                   "1234567890.123456789", "0.1", "-2.675", "1e3", "1E-3",
                                   "+1.5e+2", "0000000000000000001.5",
                                   "0.12345678901234567890123", "1234567890123456789012345678.5",
                                   "-98765432109876543210987654321", "1." + "0" * 40])
def test_frame_numbers_equal_python_float(token):
    """Every accepted number form converts exactly like float(), fast path or not; a file whose
    positions no body could reach is refused (naming the line) after the conversion."""
    body = f"1 {token} 3\n{token} 2 {token}\n"
    f = float(token)
    np.testing.assert_array_equal(bvh_io._parse_frames(body, 11, 2, 9, 3, None),
                                  [[1, f, 3], [f, 2, f]])
    text = ("HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 3 Xposition Yposition Zposition\n}\n"
            f"MOTION\nFrames: 2\nFrame Time: 0.1\n{body}")
    if abs(f) <= bvh_io.MAX_POSITION:
        np.testing.assert_array_equal(bvh.loads(text).source_channels, [[1, f, 3], [f, 2, f]])
    else:
        with pytest.raises(bvh.BVHError, match=r"line 10: value 2 of frame 1 .*cannot describe"):
            bvh.loads(text)


def test_end_site_order_survives_round_trip():
    """An End Site written before a child joint stays first (end sites keep their numbers)."""
    text = ("HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n"
            "End Site\n{\nOFFSET 1 0 0\n}\nJOINT b\n{\nOFFSET 0 1 0\nCHANNELS 1 Xrotation\n"
            "End Site\n{\nOFFSET 0 2 0\n}\n}\nEnd Site\n{\nOFFSET 0 0 3\n}\n}\n"
            "MOTION\nFrames: 1\nFrame Time: 0.1\n10 20 30 40\n")
    m = bvh.loads(text)
    np.testing.assert_array_equal(m.skeleton.end_site_parents, [0, 1, 0])
    m2 = bvh.loads(bvh.dumps(m))
    _assert_same_skeleton(m2.skeleton, m.skeleton, atol=0)


def test_non_depth_first_skeleton_comes_back_depth_first():
    sk = Skeleton(["root", "a", "b", "a2"], [-1, 0, 0, 1], np.eye(4, 3),
                  [("Xrotation",), ("Yrotation",), ("Zrotation",), ("Xrotation",)])
    m = bvh.Motion.from_channels(sk, 0.1, np.array([[10.0, 20.0, 30.0, 40.0]]))
    m2 = bvh.loads(bvh.dumps(m))
    assert m2.skeleton.names == ["root", "a", "a2", "b"]
    fk, fk2 = bvh.forward_kinematics(m).positions, bvh.forward_kinematics(m2).positions
    np.testing.assert_allclose(fk2[:, [0, 1, 3, 2]], fk, atol=1e-6)


def test_read_channels_and_load_agree(tmp_path):
    v = VARIANTS[0]
    path = _write(tmp_path, v.text)
    sk, ft, values = bvh.read_channels(path)
    m = bvh.load(path)
    _assert_same_skeleton(sk, m.skeleton, atol=0)
    assert ft == m.frame_time
    np.testing.assert_array_equal(values, m.source_channels)
    assert values.shape == (m.n_frames, sk.n_channels)


def test_utf8_bom_and_latin1_names(tmp_path):
    text = ("HIERARCHY\nROOT Hüfte\n{\nOFFSET 0 0 0\nCHANNELS 1 Yrotation\n}\n"
            "MOTION\nFrames: 1\nFrame Time: 0.5\n12.5\n")
    p1 = tmp_path / "bom.bvh"
    p1.write_bytes(b"\xef\xbb\xbf" + text.encode("utf-8"))
    p2 = tmp_path / "latin1.bvh"
    p2.write_bytes(text.encode("latin-1"))
    for p in (p1, p2):
        m = bvh.load(p)
        assert m.skeleton.names == ["Hüfte"]
        assert m.source_channels[0, 0] == 12.5


def test_zero_frames_and_zero_channels():
    m = bvh.loads("HIERARCHY\nROOT a\n{\nOFFSET 1 2 3\nCHANNELS 0\n}\nMOTION\nFrames: 0\n"
                  "Frame Time: 0.1\n")
    assert m.n_frames == 0 and m.skeleton.n_channels == 0
    m = bvh.loads("HIERARCHY\nROOT a\n{\nOFFSET 1 2 3\nCHANNELS 0\n}\nMOTION\nFrames: 3\n"
                  "Frame Time: 0.1\n\n\n\n")
    assert m.n_frames == 3
    np.testing.assert_array_equal(bvh.forward_kinematics(m).positions[:, 0], [[1, 2, 3]] * 3)
    assert bvh.loads(bvh.dumps(m)).n_frames == 3
    with pytest.raises(bvh.BVHError, match="line 9: expected 1000000000000 .empty. frame lines"):
        bvh.loads("HIERARCHY\nROOT a\n{\nOFFSET 1 2 3\nCHANNELS 0\n}\nMOTION\n"
                  "Frames: 1000000000000\nFrame Time: 0.1\n")


def test_deep_skeleton_has_no_recursion_limit():
    depth = 3000
    text = "HIERARCHY\nROOT j0\n{\nOFFSET 0 0 0\nCHANNELS 1 Zrotation\n"
    for j in range(1, depth):
        text += f"JOINT j{j}\n{{\nOFFSET 0 1 0\nCHANNELS 1 Zrotation\n"
    text += "}\n" * depth + "MOTION\nFrames: 1\nFrame Time: 0.1\n" + " ".join(["0.1"] * depth)
    m = bvh.loads(text)
    assert m.skeleton.n_joints == depth
    assert bvh.loads(bvh.dumps(m)).skeleton.n_joints == depth


# -- the Euler encoding (Motion.to_channels / _continuous_euler) --------------------------------
def _one_joint_motion(order: str, q: np.ndarray) -> bvh.Motion:
    sk = Skeleton(["j"], [-1], [[0, 0, 0]], [rot_channels(order)])
    return bvh.Motion(sk, 1 / 30, np.zeros((len(q), 1, 3)), q[:, None, :])


def _rotation_error(q1: np.ndarray, q2: np.ndarray) -> float:
    """Largest angle (radians) between corresponding rotations."""
    return float(np.max((to_rotation(q1).inv() * to_rotation(q2)).magnitude()))


def _near_gimbal_quats(order: str, rng: np.random.Generator) -> np.ndarray:
    """Rotations with the middle angle at and within 1e-9..1 degree of +-90 (Tait-Bryan)."""
    n = 400
    delta = rng.choice([0.0, 1e-9, 1e-7, 1e-5, 1e-3, 0.1, 1.0], n) * rng.choice([-1, 1], n)
    mid = rng.choice([-90.0, 90.0], n) + delta
    angles = np.stack([rng.uniform(-180, 180, n), mid, rng.uniform(-180, 180, n)], axis=1)
    return quat_from_euler(angles, order)


@pytest.mark.parametrize("order", TAIT_BRYAN)
def test_random_rotations_survive_encode_decode(order):
    rng = np.random.default_rng(sum(map(ord, order)))
    q = np.concatenate([Rotation.random(1000, rng=rng).as_quat(scalar_first=True),
                        _near_gimbal_quats(order, rng)])
    m = _one_joint_motion(order, q)
    values = m.to_channels()
    back = bvh.Motion.from_channels(m.skeleton, m.frame_time, values).rotations[:, 0]
    assert _rotation_error(back, q) < 1e-9
    # through text: 6 decimals of a degree per angle
    text_back = bvh.loads(bvh.dumps(m)).rotations[:, 0]
    assert _rotation_error(text_back, q) < 5e-8


@pytest.mark.parametrize("order", ["ZXZ", "XYX", "YZY", "ZYZ", "XZX", "YXY"])
def test_proper_euler_orders_in_continuous_encoder(order):
    """The encoder also handles proper Euler orders (other branch (a+180, -b, c+180))."""
    rng = np.random.default_rng(5)
    q = Rotation.random(300, rng=rng).as_quat(scalar_first=True)
    q = np.concatenate([q, quat_from_euler(np.stack([rng.uniform(-180, 180, 100),
                                                     rng.choice([0.0, 180.0, 1e-7], 100),
                                                     rng.uniform(-180, 180, 100)], 1), order)])
    angles = _continuous_euler(q, order)
    assert _rotation_error(quat_from_euler(angles, order), q) < 1e-9
    # a smooth path whose principal angles jump (middle angle crossing 0): stays continuous
    t = np.linspace(0, 1, 200)
    path = np.stack([40 + 30 * t, 30 - 60 * t, -20 + 50 * t], axis=1)
    enc = _continuous_euler(quat_from_euler(path, order), order)
    assert np.max(np.abs(np.diff(enc, axis=0))) < 5.0
    assert _rotation_error(quat_from_euler(enc, order), quat_from_euler(path, order)) < 1e-9


@pytest.mark.parametrize("order", TAIT_BRYAN)
def test_encoder_is_continuous_through_gimbal_lock_and_180(order):
    """A smooth Euler path through the gimbal-lock middle angle (+90) and past +-180 on the
    outer angles is recovered exactly (no branch or 360-degree jumps)."""
    t = np.linspace(0, 1, 301)
    path = np.stack([150 + 80 * t, 60 + 60.3 * t, -170 - 40 * t], axis=1)  # b: 60 -> 120.3
    q = quat_from_euler(path, order)
    enc = _continuous_euler(q, order)
    np.testing.assert_allclose(enc, path, atol=1e-6)
    assert np.max(np.abs(np.diff(enc, axis=0))) < 1.0


@pytest.mark.parametrize("order", ["X", "Y", "Z", "XY", "ZX", "YZ", "XZ", "ZY", "YX"])
def test_one_and_two_axis_joints_encode_what_they_can_express(order):
    """Rotations a 1- or 2-channel joint can express come back exactly, including a second
    angle beyond +-90 (where the principal 3-axis solution puts 180 on the dropped axis)."""
    t = np.linspace(0, 1, 121)
    path = np.stack([-170 + 400 * t, 20 + 130 * t][: len(order)], axis=1)  # past 180, past 90
    q = quat_from_euler(path, order)
    enc = _continuous_euler(q, order)
    assert _rotation_error(quat_from_euler(enc, order), q) < 1e-9
    np.testing.assert_allclose(enc, path, atol=1e-6)


# -- error messages name the offending line ------------------------------------------------------
CLEAN = """HIERARCHY
ROOT Hips
{
\tOFFSET 0 0 0
\tCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
\tJOINT Chest
\t{
\t\tOFFSET 0 10 0
\t\tCHANNELS 3 Zrotation Xrotation Yrotation
\t\tEnd Site
\t\t{
\t\t\tOFFSET 0 5 0
\t\t}
\t}
}
MOTION
Frames: 2
Frame Time: 0.033333
0 90 0 0 0 0 1 2 3
0 91 0 0 0 0 1 2 3
"""


def _edit(replace: dict[int, str | None] | None = None, insert: dict[int, str] | None = None,
          keep: int | None = None) -> str:
    """CLEAN with 1-based line ``n`` replaced (``None`` deletes), lines inserted *after* line
    ``n``, or only the first ``keep`` lines kept."""
    lines = CLEAN.splitlines()
    out = []
    for n, ln in enumerate(lines, start=1):
        if replace and n in replace:
            if replace[n] is not None:
                out.append(replace[n])
        else:
            out.append(ln)
        if insert and n in insert:
            out.append(insert[n])
    if keep is not None:
        out = out[:keep]
    return "\n".join(out) + "\n"


ERROR_CASES = [
    # (id, text, line, fragment of the message)
    ("bad-channel-name", _edit({9: "CHANNELS 3 Zrotation Xrotaton Yrotation"}), 9, "'Xrotaton'"),
    ("channel-count-7", _edit({9: "CHANNELS 7 Zrotation Xrotation Yrotation"}), 9, "0 and 6"),
    ("channel-count-word", _edit({9: "CHANNELS three Zrotation"}), 9, "'three'"),
    ("channel-count-negative", _edit({9: "CHANNELS -3 Zrotation"}), 9, "'-3'"),
    ("channels-fewer-than-count", _edit({9: "CHANNELS 4 Zrotation Xrotation Yrotation"}), 9,
     "declares 4"),
    ("channel-repeated", _edit({9: "CHANNELS 3 Zrotation Zrotation Yrotation"}), 9, "repeated"),
    ("channels-missing", _edit({9: None}), 9, "'CHANNELS'"),
    ("offset-two-numbers", _edit({8: "OFFSET 0 10"}), 8, "needs 3 numbers"),
    ("offset-word", _edit({8: "OFFSET 0 ten 0"}), 8, "'ten'"),
    ("offset-nan", _edit({8: "OFFSET 0 nan 0"}), 8, "'nan'"),
    ("offset-inf", _edit({8: "OFFSET 0 0 -inf"}), 8, "'-inf'"),
    ("offset-overflow", _edit({12: "OFFSET 0 1e999 0"}), 12, "finite"),
    ("offset-missing", _edit({8: None}), 8, "'OFFSET'"),
    ("open-brace-missing", _edit({7: None}), 7, "'{'"),
    ("close-brace-missing", _edit({14: None}), 15, "'MOTION' line"),
    ("close-brace-extra", _edit(insert={15: "}"}), 16, "after the ROOT"),
    ("end-site-misspelt", _edit({10: "End Sight"}), 10, "'Sight'"),
    ("end-site-unclosed", _edit({13: "JOINT Foot"}), 13, "closing the End Site"),
    ("junk-in-joint", _edit({10: "Endpoint"}), 10, "'Endpoint'"),
    ("duplicate-name", _edit({6: "JOINT Hips"}), 6, "duplicate joint name"),
    ("joint-without-name", _edit({6: "JOINT"}), 6, "joint name"),
    ("no-hierarchy", _edit({1: "HIERARCHIE"}), 1, "'HIERARCHY'"),
    ("no-root", _edit({2: "JOINT Hips"}), 2, "'ROOT'"),
    ("second-root", _edit(insert={15: "ROOT Other"}), 16, "second ROOT"),
    ("motion-misspelt", _edit({16: "MOTIONS"}), 16, "'MOTIONS'"),
    ("no-motion", _edit(keep=15), 15, "'MOTION'"),
    ("ends-inside-hierarchy", _edit(keep=8), 8, "end of the file"),
    ("ends-after-motion", _edit(keep=16), 16, "'Frames: N'"),
    ("ends-after-frames", _edit(keep=17), 17, "'Frame Time"),
    ("frames-negative", _edit({17: "Frames: -2"}), 17, "Frames"),
    ("frames-word", _edit({17: "Frames: two"}), 17, "Frames"),
    ("frames-misspelt", _edit({17: "Frame: 2"}), 17, "Frames"),
    ("frame-time-zero", _edit({18: "Frame Time: 0"}), 18, "positive"),
    ("frame-time-negative", _edit({18: "Frame Time: -0.03"}), 18, "positive"),
    ("frame-time-nan", _edit({18: "Frame Time: nan"}), 18, "positive"),
    ("frame-time-word", _edit({18: "Frame Time: fast"}), 18, "positive"),
    ("too-few-frames", _edit({20: None}), 19, "expected 2 frames"),
    ("too-many-frames", _edit(insert={20: "0 92 0 0 0 0 1 2 3"}), 21, "more frame lines"),
    ("too-few-values", _edit({20: "0 91 0 0 0 0 1 2"}), 20, "found 8"),
    ("too-many-values", _edit({19: "0 91 0 0 0 0 1 2 3 4"}), 19, "found 10"),
    ("value-word", _edit({20: "0 91 0 0 zero 0 1 2 3"}), 20, "'zero'"),
    ("value-nan", _edit({20: "0 91 0 0 0 nan 1 2 3"}), 20, "'nan'"),
    ("value-inf", _edit({19: "0 91 inf 0 0 0 1 2 3"}), 19, "'inf'"),
    ("value-overflow", _edit({20: "0 91 0 0 0 0 1 2 1e999"}), 20, "'1e999'"),
    ("value-two-dots", _edit({20: "0 91 0 0 0 0 1.2.3 2 3"}), 20, "'1.2.3'"),
    ("value-double-sign", _edit({20: "0 91 0 0 0 0 --1 2 3"}), 20, "'--1'"),
    ("value-underscore", _edit({20: "0 91 0 0 0 0 1_0 2 3"}), 20, "'1_0'"),
    ("value-comma", _edit({20: "0 91 0 0 0 0 1,5 2 3"}), 20, "'1,5'"),
    ("blank-lines-counted", _edit({19: "", 20: "0 91 0 0 0 x 1 2 3"}, insert={19: "   "}), 21,
     "'x'"),
    ("empty-text", "", 1, "HIERARCHY"),
]


@pytest.mark.parametrize("text,line,fragment", [c[1:] for c in ERROR_CASES],
                         ids=[c[0] for c in ERROR_CASES])
def test_error_names_the_offending_line(text, line, fragment):
    with pytest.raises(bvh.BVHError) as e:
        bvh.loads(text)
    assert e.value.line == line, str(e.value)
    assert f"line {line}:" in str(e.value)
    assert fragment in e.value.reason


@pytest.mark.parametrize("convert", [lambda t: t.replace("\n", "\r\n"),
                                     lambda t: t.replace("\n", "\r")], ids=["crlf", "cr"])
@pytest.mark.parametrize("case", ["bad-channel-name", "value-word", "too-few-frames",
                                  "close-brace-missing"])
def test_error_lines_with_crlf_and_cr(convert, case):
    _, text, line, _ = next(c for c in ERROR_CASES if c[0] == case)
    with pytest.raises(bvh.BVHError) as e:
        bvh.loads(convert(text))
    assert e.value.line == line


def test_error_names_the_file(tmp_path):
    path = _write(tmp_path, _edit({9: "CHANNELS 3 Zrotation Xrotaton Yrotation"}))
    with pytest.raises(bvh.BVHError) as e:
        bvh.load(path)
    assert str(e.value).startswith(f"{path}, line 9: ")
    with pytest.raises(bvh.BVHError) as e:
        bvh.read_channels(path)
    assert e.value.path == str(path)


def test_missing_file_is_a_bvh_error(tmp_path):
    with pytest.raises(bvh.BVHError) as e:
        bvh.load(tmp_path / "nope.bvh")
    assert e.value.line is None and "nope.bvh" in str(e.value)


def test_bvh_error_is_a_project_error():
    assert issubclass(bvh.BVHError, bvh.MjcharError)
    e = bvh.BVHError("bad", line=3, path="x.bvh")
    assert (e.reason, e.line, e.path, str(e)) == ("bad", 3, "x.bvh", "x.bvh, line 3: bad")


def test_a_skeleton_numbered_out_of_depth_first_order_round_trips():
    """Joints appended after their subtree was written (a chain added under the head later)
    come back renumbered depth-first with their own channel values."""
    from mjchar.bvh.bundled.humanoid_skeleton import humanoid_skeleton
    from mjchar.bvh.bundled.zoo_layouts import add_chain

    m = bvh.Motion.rest(humanoid_skeleton(), 3)
    m.rotations[:] = quat_from_rotvec(
        np.random.default_rng(1).normal(0, 0.3, (3, m.skeleton.n_joints, 3)))
    m = add_chain(m, "torso_head", [("extra", (0.0, 0.05, 0.1))], end=(0.0, 0.0, 0.05))
    back = bvh.loads(bvh.dumps(m))
    assert back.skeleton.names != m.skeleton.names  # renumbered
    fk, fk2 = bvh.forward_kinematics(m).positions, bvh.forward_kinematics(back).positions
    idx = [back.skeleton.index(n) for n in m.skeleton.names]
    np.testing.assert_allclose(fk2[:, idx], fk, atol=1e-6)
