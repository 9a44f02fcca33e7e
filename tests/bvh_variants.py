"""Generators of BVH test files whose content is known independently of the reader.

Every variant is *made* from a motion whose forward kinematics is known (a real shared clip, or
a skeleton authored here with a synthetic walk when ``../shared`` is absent), then transformed
(units, up axis, channel orders, extra joints, fewer channels...) and encoded with
:func:`bvh.dumps`; text-level variants (tabs, CRLF, CR, scientific notation, extra whitespace,
braces sharing lines) re-format that text without changing a value. Each :class:`Variant` carries
the channel values its text encodes and the global joint positions it must produce.

Nothing here reads a file except :func:`base_motion` (the shared clip, when present).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mjchar import bvh
from mjchar.bvh.bundled.zoo import (
    CONVENTIONS,
    all_channels,
    insert_zero_length_joint,
    rename,
    with_channels,
)
from mjchar.bvh.io.skeleton import Skeleton
from mjchar.bvh.rigs.units import transform_motion, up_axis_rotation
from mjchar.bvh.rotations import quat_from_euler, quat_rotate

SHARED_BVH = Path(__file__).resolve().parents[2] / "shared" / "data" / "bvh"
XYZ_POS = ("Xposition", "Yposition", "Zposition")
TAIT_BRYAN = ("XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX")


def rot_channels(order: str) -> tuple[str, ...]:
    """``"ZYX"`` -> ``("Zrotation", "Yrotation", "Xrotation")``."""
    return tuple(f"{a}rotation" for a in order)


@dataclass
class Variant:
    """A generated BVH text and what reading it must give.

    Attributes:
        name: short id (used as the pytest id).
        text: the BVH text.
        channels: ``(F, C)`` channel values the text encodes (before printing with 6 decimals),
            or ``None`` when only the positions are known.
        positions: ``(F, J, 3)`` global joint positions, file units, in the text's joint order.
        end_sites: ``(F, E, 3)`` global end site positions, file units.
        unit_scale: metres per file unit (truth), or ``None``.
        up: the up axis (``"y"``/``"z"``), or ``None``.
        format_of: for text-level variants, the name of the variant whose values it repeats.
    """

    name: str
    text: str
    channels: np.ndarray | None
    positions: np.ndarray
    end_sites: np.ndarray
    unit_scale: float | None = None
    up: str | None = None
    format_of: str | None = None
    notes: list[str] = field(default_factory=list)


# -- authored skeletons --------------------------------------------------------------------------
def _build(spec: list[tuple], root_channels: tuple[str, ...]) -> Skeleton:
    """Skeleton from ``(name, parent_name, offset, channels, end_site_offset_or_None)`` rows,
    listed depth-first (the only joint order a BVH file can have)."""
    names = [r[0] for r in spec]
    parents = [-1 if r[1] is None else names.index(r[1]) for r in spec]
    for j in range(1, len(parents)):  # depth-first: each parent is on the path to the previous
        assert parents[j] in _ancestors_and_self(parents, j - 1), f"{names[j]} breaks DFS order"
    offsets = [r[2] for r in spec]
    channels = [root_channels if r[1] is None else r[3] for r in spec]
    es = [(i, r[4]) for i, r in enumerate(spec) if r[4] is not None]
    return Skeleton(names, parents, offsets, channels, [e[0] for e in es],
                    np.array([e[1] for e in es], dtype=float).reshape(-1, 3))


def _ancestors_and_self(parents: list[int], j: int) -> list[int]:
    out = []
    while j >= 0:
        out.append(j)
        j = parents[j]
    return out


def games_like_skeleton() -> Skeleton:
    """20 joints like the course clips: metres, Y-up, faces +Z, XYZ channels, 5 end sites."""
    c = rot_channels("XYZ")
    spec = [("RootJoint", None, (0, 0, 0), c, None)]
    for s, x in (("l", 1.0), ("r", -1.0)):
        spec += [
            (f"{s}Hip", "RootJoint", (0.1 * x, -0.051395, 0), c, None),
            (f"{s}Knee", f"{s}Hip", (0, -0.41, 0), c, None),
            (f"{s}Ankle", f"{s}Knee", (0, -0.39, 0), c, None),
            (f"{s}ToeJoint", f"{s}Ankle", (0, -0.05, 0.13), c, (0.01 * x, 0.002, 0.06)),
        ]
    spec += [("pelvis_lowerback", "RootJoint", (0, 0.093605, 0), c, None),
             ("lowerback_torso", "pelvis_lowerback", (0, 0.1, 0), c, None),
             ("torso_head", "lowerback_torso", (0, 0.3, 0), c, (0, 0.2, 0.02))]
    for s, x in (("l", 1.0), ("r", -1.0)):
        spec += [
            (f"{s}Torso_Clavicle", "lowerback_torso", (0.001 * x, 0.1575, 0), c, None),
            (f"{s}Shoulder", f"{s}Torso_Clavicle", (0.17 * x, 0.03, 0), c, None),
            (f"{s}Elbow", f"{s}Shoulder", (0.28 * x, 0, 0), c, None),
            (f"{s}Wrist", f"{s}Elbow", (0.25 * x, 0, 0), c, (0.1 * x, 0, 0)),
        ]
    return _build(spec, XYZ_POS + c)


def cmu_like_skeleton() -> Skeleton:
    """31 joints with the CMU mocap names and topology, ``Zrotation Yrotation Xrotation``
    channels, zero-length LHipJoint/RHipJoint-style bones; in inches, Y-up, faces +Z."""
    c = rot_channels("ZYX")
    inch = 1 / 0.0254
    spec = [("Hips", None, (0, 0, 0), c, None)]
    for s, x in (("L", 1.0), ("R", -1.0)):
        side = "Left" if s == "L" else "Right"
        spec += [
            (f"{s}HipJoint", "Hips", (0, 0, 0), c, None),  # zero length, as in the CMU files
            (f"{side}UpLeg", f"{s}HipJoint", (0.09 * x, -0.08, 0.03), c, None),
            (f"{side}Leg", f"{side}UpLeg", (0, -0.42, 0), c, None),
            (f"{side}Foot", f"{side}Leg", (0, -0.41, 0), c, None),
            (f"{side}ToeBase", f"{side}Foot", (0, -0.06, 0.12), c, (0, 0, 0.05)),
        ]
    spec += [("LowerBack", "Hips", (0, 0, 0), c, None),
             ("Spine", "LowerBack", (0, 0.12, 0), c, None),
             ("Spine1", "Spine", (0, 0.12, 0), c, None),
             ("Neck", "Spine1", (0, 0.2, 0), c, None),
             ("Neck1", "Neck", (0, 0.05, 0), c, None),
             ("Head", "Neck1", (0, 0.06, 0), c, (0, 0.18, 0))]
    for s, x in (("L", 1.0), ("R", -1.0)):
        side = "Left" if s == "L" else "Right"
        spec += [
            (f"{side}Shoulder", "Spine1", (0.03 * x, 0.17, 0), c, None),
            (f"{side}Arm", f"{side}Shoulder", (0.15 * x, 0, 0), c, None),
            (f"{side}ForeArm", f"{side}Arm", (0.28 * x, 0, 0), c, None),
            (f"{side}Hand", f"{side}ForeArm", (0.24 * x, 0, 0), c, None),
            (f"{side}FingerBase", f"{side}Hand", (0.03 * x, 0, 0), c, None),
            (f"{side}HandIndex1", f"{side}FingerBase", (0.04 * x, 0, 0), c, (0.03 * x, 0, 0)),
            (f"{s}Thumb", f"{side}Hand", (0.02 * x, 0, 0.02), c, (0.03 * x, 0, 0.02)),
        ]
    sk = _build(spec, XYZ_POS + c)
    sk.offsets *= inch
    sk.end_site_offsets *= inch
    return sk


def mixamo_like_skeleton() -> Skeleton:
    """A Mixamo-style rig: ``mixamorig:`` names, centimetres, Y-up, faces +Z, 6 channels on
    every joint (``Xposition Yposition Zposition Zrotation Xrotation Yrotation``)."""
    c = XYZ_POS + rot_channels("ZXY")
    p = "mixamorig:"
    spec = [(f"{p}Hips", None, (0, 0, 0), c, None),
            (f"{p}Spine", f"{p}Hips", (0, 9.9, -1.2), c, None),
            (f"{p}Spine1", f"{p}Spine", (0, 11.6, 0), c, None),
            (f"{p}Spine2", f"{p}Spine1", (0, 13.3, 0), c, None),
            (f"{p}Neck", f"{p}Spine2", (0, 15.0, 0), c, None),
            (f"{p}Head", f"{p}Neck", (0, 10.3, 3.1), c, (0, 18.5, 6.5))]
    for side, x in (("Left", 1.0), ("Right", -1.0)):
        spec += [
            (f"{p}{side}Shoulder", f"{p}Spine2", (6.1 * x, 12.9, 0), c, None),
            (f"{p}{side}Arm", f"{p}{side}Shoulder", (12.9 * x, 0, 0), c, None),
            (f"{p}{side}ForeArm", f"{p}{side}Arm", (27.4 * x, 0, 0), c, None),
            (f"{p}{side}Hand", f"{p}{side}ForeArm", (27.6 * x, 0, 0), c, (9.0 * x, 0, 0)),
        ]
    for side, x in (("Left", 1.0), ("Right", -1.0)):
        spec += [
            (f"{p}{side}UpLeg", f"{p}Hips", (9.1 * x, -6.6, -0.1), c, None),
            (f"{p}{side}Leg", f"{p}{side}UpLeg", (0, -44.0, 0.3), c, None),
            (f"{p}{side}Foot", f"{p}{side}Leg", (0, -42.1, -2.6), c, None),
            (f"{p}{side}ToeBase", f"{p}{side}Foot", (0, -9.5, 10.4), c, (0, 0, 8.5)),
        ]
    return _build(spec, c)


def synthetic_motion(sk: Skeleton, n_frames: int = 90, fps: float = 30.0, unit: float = 1.0,
                     seed: int = 0, root_height: float = 0.95) -> bvh.Motion:
    """A plausible walk-like motion for a Y-up skeleton facing +Z.

    ``unit`` is metres per file unit. Rotation channels are smooth sinusoids (5-35 degrees,
    1 Hz, random phase and bias, seeded), inside the principal Euler ranges; the root walks
    along +Z at 1.2 m/s with a small bob; non-root position channels carry the offset.
    """
    rng = np.random.default_rng(seed)
    t = np.arange(n_frames) / fps
    values = np.zeros((n_frames, sk.n_channels))
    col = 0
    for j, chans in enumerate(sk.channels):
        for c in chans:
            if c in XYZ_POS:
                axis = XYZ_POS.index(c)
                if j == 0:
                    values[:, col] = [0.02 * np.sin(2 * np.pi * 0.5 * t),
                                      root_height + 0.02 * np.sin(2 * np.pi * 2 * t),
                                      1.2 * t][axis] / unit
                else:
                    values[:, col] = sk.offsets[j, axis]
            else:
                amp, phase = rng.uniform(5, 35), rng.uniform(0, 2 * np.pi)
                bias = rng.uniform(-10, 10)
                values[:, col] = bias + amp * np.sin(2 * np.pi * 1.0 * t + phase)
            col += 1
    return bvh.Motion.from_channels(sk, 1.0 / fps, values)


def base_motion(prefer_shared: bool = True) -> tuple[bvh.Motion, str]:
    """``(motion, label)``: the shared walk60 clip when present, else the authored 20-joint
    skeleton with a synthetic walk (metres, Y-up)."""
    path = SHARED_BVH / "walk60.bvh"
    if prefer_shared and path.is_file():
        return bvh.load(path), "walk60"
    return synthetic_motion(games_like_skeleton(), n_frames=120, fps=60.0), "authored"


# -- motion-level edits (the truth stays known) -------------------------------------------------
def add_end_site(motion: bvh.Motion, joint: str, offset: tuple[float, float, float]) -> bvh.Motion:
    """Same motion with one more End Site under ``joint`` (also allowed on inner joints)."""
    sk = motion.skeleton.copy()
    sk.end_site_parents = np.append(sk.end_site_parents, sk.index(joint))
    sk.end_site_offsets = np.vstack([sk.end_site_offsets, offset])
    sk.end_site_names = None
    sk.__post_init__()
    return bvh.Motion(sk, motion.frame_time, motion.local_positions, motion.rotations,
                      motion.source_channels)


# -- text-level re-formatting (values untouched) --------------------------------------------------
def _map_lines(text: str, fn) -> str:
    lines = text.split("\n")
    motion = next(i for i, ln in enumerate(lines) if ln.strip() == "MOTION")
    return "\n".join(fn(i, ln, i > motion + 2, motion) for i, ln in enumerate(lines))


def to_crlf(text: str) -> str:
    return text.replace("\n", "\r\n")


def to_cr(text: str) -> str:
    return text.replace("\n", "\r")


def to_tabs(text: str) -> str:
    """Tabs between every token (the writer already indents with tabs)."""
    return _map_lines(text, lambda i, ln, frame, m: re.sub(r"(?<=\S) +(?=\S)", "\t", ln))


def to_space_indent(text: str) -> str:
    """Two-space indentation and runs of spaces between numbers, as many exporters write."""
    def fn(i, ln, frame, m):
        ln = re.sub(r"^\t+", lambda g: "  " * len(g.group()), ln)
        return re.sub(r"(?<=\S) (?=[-\d])", "   ", ln)
    return _map_lines(text, fn)


def to_scientific(text: str) -> str:
    """Every OFFSET, frame value and the frame time in ``%.12e`` notation (same doubles)."""
    def sci(tok: str) -> str:
        return f"{float(tok):.12e}"

    def fn(i, ln, frame, m):
        s = ln.strip()
        if frame or s.upper().startswith("OFFSET"):
            return re.sub(r"(?<!\S)[-+]?\d+\.\d*(?!\S)", lambda g: sci(g.group()), ln)
        if s.startswith("Frame Time"):
            return re.sub(r"\S+$", lambda g: sci(g.group()), ln)
        return ln
    return _map_lines(text, fn)


def with_extra_whitespace(text: str) -> str:
    """Blank lines everywhere, trailing blanks, leading blanks on frame lines, blank lines
    between and after the frames."""
    def fn(i, ln, frame, m):
        if frame:
            return ("   " + ln.replace(" ", "  \t ") + " \t\n") if ln else ln
        if i < m:
            return ln + "  \t" + ("\n\n" if i % 3 == 0 else "")
        return ln + ("\n   \n" if i in (m, m + 1) else "")
    return _map_lines(text, fn) + "\n\n  \n"


def with_inline_braces(text: str) -> str:
    """``JOINT name {`` and ``{ OFFSET ...`` sharing lines, End Sites on one line: valid BVH
    token-wise, but not one statement per line (exercises the general hierarchy parser)."""
    head, sep, tail = text.partition("MOTION")
    head = re.sub(r"\n\s*\{", " {", head)
    head = re.sub(r"(End Site) \{\s*(OFFSET[^\n]*)\n\s*\}", r"\1 { \2 }", head)
    return head + sep + tail


FORMATTERS = {"crlf": to_crlf, "cr": to_cr, "tabs": to_tabs, "space_indent": to_space_indent,
              "scientific": to_scientific, "whitespace": with_extra_whitespace,
              "inline_braces": with_inline_braces}


# -- the variants -----------------------------------------------------------------------------
def file_order_end_sites(sk: Skeleton) -> np.ndarray:
    """Indices of ``sk``'s end sites in the order a depth-first file lists them: within a
    joint, an End Site comes before any child whose subtree holds a later-numbered one."""
    children = [[c for c in range(sk.n_joints) if sk.parents[c] == j] for j in range(sk.n_joints)]
    own = [[e for e, p in enumerate(sk.end_site_parents) if p == j] for j in range(sk.n_joints)]

    def first_site(j: int) -> float:
        sites = own[j] + [first_site(c) for c in children[j]]
        return min(sites, default=np.inf)

    order: list[int] = []

    def walk(j: int) -> None:
        pending = list(own[j])
        for c in children[j]:
            while pending and pending[0] < first_site(c):
                order.append(pending.pop(0))
            walk(c)
        order.extend(pending)

    walk(0)
    return np.array(order, dtype=int)


def _variant(name: str, motion: bvh.Motion, positions: np.ndarray | None = None,
             unit_scale: float | None = None, up: str | None = None) -> Variant:
    fk = bvh.forward_kinematics(motion)
    sites = bvh.end_site_positions(motion, fk)[:, file_order_end_sites(motion.skeleton)]
    return Variant(name, bvh.dumps(motion), motion.to_channels(),
                   fk.positions if positions is None else positions, sites, unit_scale, up)


def _transformed(name: str, base: bvh.Motion, scale: float, rotation: np.ndarray | None,
                 unit_scale: float, up: str) -> Variant:
    """Units/axes variant; its expected positions come from the *base* motion's FK."""
    fk = bvh.forward_kinematics(base)
    q = np.array([1.0, 0, 0, 0]) if rotation is None else rotation
    expected = scale * quat_rotate(q, fk.positions)
    expected_sites = scale * quat_rotate(q, bvh.end_site_positions(base, fk))
    m = transform_motion(base, scale, rotation)
    return Variant(name, bvh.dumps(m), m.to_channels(), expected, expected_sites, unit_scale, up)


def motion_variants(base: bvh.Motion, label: str = "base") -> list[Variant]:
    """Units, axes, channel layouts and skeleton-structure variants of a Y-up metre ``base``."""
    sk = base.skeleton
    out = [_variant(f"{label}", base, unit_scale=1.0, up="y"),
           _transformed(f"{label}-cm", base, 100.0, None, 0.01, "y"),
           _transformed(f"{label}-inch", base, 1 / 0.0254, None, 0.0254, "y"),
           _transformed(f"{label}-zup", base, 1.0, up_axis_rotation("y", "z"), 1.0, "z"),
           _transformed(f"{label}-zup-cm", base, 100.0, up_axis_rotation("y", "z"), 0.01, "z")]
    fk = bvh.forward_kinematics(base).positions
    # channel orders: ZYX everywhere; then every Tait-Bryan order and shuffled position channels
    zyx = {n: (XYZ_POS if j == 0 else ()) + rot_channels("ZYX") for j, n in enumerate(sk.names)}
    out.append(_variant(f"{label}-order-zyx", with_channels(base, zyx), fk, 1.0, "y"))
    mixed = {n: rot_channels(TAIT_BRYAN[j % 6]) for j, n in enumerate(sk.names)}
    mixed[sk.names[0]] = rot_channels("YZX")[:2] + ("Zposition", "Xposition", "Yposition",
                                                    "Xrotation")  # interleaved on the root
    out.append(_variant(f"{label}-orders-mixed", with_channels(base, mixed), fk, 1.0, "y"))
    # six channels on non-root joints (translation = offset, so FK is unchanged)
    six = {n: XYZ_POS + rot_channels("ZXY") for n in sk.names[1::3]}
    out.append(_variant(f"{label}-six-channels", with_channels(base, six), fk, 1.0, "y"))
    # six channels with a stretching bone: positions from the new motion (checked by test_fk)
    m = with_channels(base, {sk.names[2]: XYZ_POS + rot_channels("XYZ")})
    m.local_positions[:, 2] *= (1 + 0.2 * np.sin(np.arange(m.n_frames) / 5.0))[:, None]
    out.append(_variant(f"{label}-stretch", bvh.Motion(m.skeleton, m.frame_time,
                                                       m.local_positions, m.rotations)))
    # 0, 1 and 2 rotation channels on some joints (what they can express is kept)
    few = {}
    for j, n in enumerate(sk.names[1:], start=1):
        few[n] = [(), rot_channels("X"), rot_channels("ZX"), rot_channels("Y"),
                  rot_channels("YZ")][j % 5] if j % 2 else sk.channels[j]
    out.append(_variant(f"{label}-few-channels", with_channels(base, few), unit_scale=1.0, up="y"))
    # zero-length bones: with a constant rotation (children re-expressed), and one with none
    q = quat_from_euler(np.array([30.0, -20.0, 45.0]), "XYZ")
    children = [sk.names[j] for j in range(1, sk.n_joints) if sk.parents[j] == 0]
    m = insert_zero_length_joint(base, children[0], "zero_a", rot_channels("ZYX"), q)
    m = insert_zero_length_joint(m, children[1], "zero_b", (), np.array([1.0, 0, 0, 0]))
    m = add_end_site(m, "zero_b", (0.0, 0.0, 0.0))  # a zero-length End Site
    keep = [m.skeleton.index(n) for n in sk.names]
    mfk = bvh.forward_kinematics(m).positions
    mfk[:, keep] = fk  # original joints: positions of the base motion
    mfk[:, m.skeleton.index("zero_a")] = fk[:, sk.parents[sk.index(children[0])]]
    mfk[:, m.skeleton.index("zero_b")] = fk[:, sk.parents[sk.index(children[1])]]
    out.append(_variant(f"{label}-zero-length", m, mfk, 1.0, "y"))
    # an End Site on an inner joint (besides the leaves')
    out.append(_variant(f"{label}-inner-end-site", add_end_site(base, sk.names[1], (0.0, 0.1, 0.0)),
                        fk, 1.0, "y"))
    # angles outside the principal Euler ranges: the file's own angles must survive
    vals = base.to_channels().copy()
    starts = sk.channel_starts()
    for j in (0, 1, 3):
        rot_cols = [starts[j] + k for k, c in enumerate(sk.channels[j]) if c.endswith("rotation")]
        if len(rot_cols) == 3:
            vals[:, rot_cols[0]] += 360.0  # first angle beyond +-180
            a = vals[:, rot_cols]
            # other Euler branch: (a + 180, 180 - b, c + 180) -- same rotation, middle > 90
            vals[:, rot_cols] = np.stack([a[:, 0] + 180.0, 180.0 - a[:, 1], a[:, 2] - 180.0],
                                         axis=1)
    m = bvh.Motion.from_channels(sk, base.frame_time, vals)
    out.append(_variant(f"{label}-unprincipal-angles", m, fk, 1.0, "y"))
    return out


def format_variants(v: Variant) -> list[Variant]:
    """Text-level re-formattings of ``v`` (same values, same expected positions)."""
    return [Variant(f"{v.name}-{k}", fn(v.text), v.channels, v.positions, v.end_sites,
                    v.unit_scale, v.up, format_of=v.name) for k, fn in FORMATTERS.items()]


def authored_variants() -> list[Variant]:
    """The CMU-style (31 joints, inches, ZYX) and Mixamo-style (cm, 6 channels) rigs."""
    cmu = synthetic_motion(cmu_like_skeleton(), n_frames=60, fps=120.0, unit=0.0254, seed=1)
    mix = synthetic_motion(mixamo_like_skeleton(), n_frames=60, fps=30.0, unit=0.01, seed=2)
    games = synthetic_motion(games_like_skeleton(), n_frames=60, fps=60.0, seed=3)
    return [_variant("cmu31", cmu, unit_scale=0.0254, up="y"),
            _variant("mixamo", mix, unit_scale=0.01, up="y"),
            _transformed("mixamo-zup", mix, 1.0, up_axis_rotation("y", "z"), 0.01, "z"),
            _variant("authored20", games, unit_scale=1.0, up="y"),
            _transformed("authored20-inch", games, 1 / 0.0254, None, 0.0254, "y")]


_CACHE: dict[str, list[Variant]] = {}


def all_variants() -> list[Variant]:
    """Every generated variant (motion-level on the base, text-level on two of them, the
    authored rigs); built once per process."""
    if "all" not in _CACHE:
        base, label = base_motion()
        motion_level = motion_variants(base, label)
        authored = authored_variants()
        text_level = format_variants(motion_level[0]) + format_variants(authored[0])
        _CACHE["all"] = motion_level + authored + text_level
    return _CACHE["all"]


#: the GAMES-105 clips' joint names -> CMU names (the rig zoo's convention)
CMU_NAMES = CONVENTIONS["cmu"]


def cmu_style(motion: bvh.Motion) -> bvh.Motion:
    """A GAMES-105 clip re-expressed as a CMU-style export: CMU joint names, ``Zrotation
    Yrotation Xrotation`` on every joint (root ``X/Y/Zposition`` first), inches, Y-up.
    Forward kinematics is the original's, scaled to inches."""
    return all_channels(rename(transform_motion(motion, scale=1.0 / 0.0254), CMU_NAMES), "ZYX")
