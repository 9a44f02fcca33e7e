"""``mjchar info FILE.bvh``: summarise a BVH file and what the converter would build from it."""

from __future__ import annotations

import argparse

from . import command_parser
from .dropped import dropped_lines

#: the order roles are listed in
ROLE_ORDER = ("pelvis", "spine", "neck", "head") + tuple(
    f"{s}_{r}" for r in ("hip", "knee", "ankle", "toe", "clavicle", "shoulder", "elbow", "wrist")
    for s in ("left", "right"))


def register(sub: argparse._SubParsersAction) -> None:
    p = command_parser(sub, "info")
    p.add_argument("file", help="BVH file")
    p.add_argument("--unit", help="file unit, as for mjchar convert (default: guessed)")
    p.add_argument("--up", choices=["x", "y", "z", "-x", "-y", "-z"],
                   help="up axis of the file, -y when +Y points down (default: guessed)")
    p.add_argument("--roles", metavar="FILE.toml", help="role map, as for mjchar convert")
    p.set_defaults(func=main)


def _role_lines(rec) -> list[str]:
    """``role  joint (name|shape|given)`` lines, in :data:`ROLE_ORDER`."""
    out = []
    for role in ROLE_ORDER:
        v = rec.roles.get(role)
        if v is None:
            continue
        joints = [v] if isinstance(v, str) else list(v)
        how = [rec.source(j) for j in joints]
        if len(set(how)) == 1:
            text = f"{', '.join(joints)} ({how[0]})"
        else:
            text = ", ".join(f"{j} ({h})" for j, h in zip(joints, how, strict=True))
        out.append(f"    {role.replace('_', ' '):16s}{text}")
    return out


def _bounds(motion, block: int = 2048):
    """``(lo, hi)``, the ``(3,)`` corners of the box holding every joint in every frame, in file
    units; forward kinematics a block of frames at a time (long clips need no more memory)."""
    import numpy as np

    from mjchar import bvh

    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    for a in range(0, motion.n_frames, block):
        points = bvh.forward_kinematics(motion[a:a + block]).positions.reshape(-1, 3)
        lo, hi = np.minimum(lo, points.min(axis=0)), np.maximum(hi, points.max(axis=0))
    return lo, hi


def main(args: argparse.Namespace) -> int:

    import numpy as np

    from mjchar import bvh
    from mjchar.bvh.mjcf import ConversionError, convert
    from mjchar.bvh.mjcf.roles import load_roles
    from mjchar.bvh.rigs import units

    motion = bvh.load(args.file)
    load_roles(args.roles)  # a roles file that cannot be read is an error, not a note
    sk = motion.skeleton
    if motion.n_frames:
        lo, hi = _bounds(motion)
        frames = (f"{motion.n_frames} frames at {motion.fps:.2f} fps "
                  f"({motion.duration:.2f} s)")
    else:  # a skeleton without motion (the converter takes it): its rest pose
        points = sk.rest_positions()
        lo, hi = points.min(axis=0), points.max(axis=0)
        frames = "no frames (a skeleton without motion; the bounding box is the rest pose's)"
    print(f"{args.file}: {sk.n_joints} joints, {sk.n_end_sites} end sites, {frames}")
    try:  # what the converter would build at these options
        c = convert(motion, unit=args.unit, up_axis=args.up, roles=args.roles)
    except ConversionError as e:
        up, scale = units.guess_up_axis(sk), units.guess_unit_scale(sk)
        print(f"  up axis (guessed): {up}, metres per unit (guessed): {scale:g}")
        print(f"  note: not convertible as is: {e}")
    else:
        s, rec = c.summary, c.prepared.rec
        print(f"  up axis: {c.info.up_axis}; unit: {s['unit']}")
        print(f"  the body it would build: {s['height_m']:.3f} m tall, {s['n_bodies']} bodies, "
              f"{s['n_dofs']} dofs (mjchar convert, joint model hinge)")
        if s["height_warning"]:
            print(f"  warning: {s['height_warning']}")
        print("  roles (name: from the joint's name or the limb around a named knee or elbow; "
              "shape: from the skeleton's geometry and the clip's motion; given: the roles "
              "file):")
        for line in _role_lines(rec):
            print(line)
        for line in dropped_lines(c, " by default"):
            print(f"  {line}")
        for w in c.warnings:
            if w != s["height_warning"]:
                print(f"  note: {w}")
    print(f"  bounding box: {np.round(lo, 3)} .. {np.round(hi, 3)}")
    print("  joints: " + ", ".join(sk.names))
    return 0
