"""``mjchar info FILE.bvh``: summarise a BVH file."""

from __future__ import annotations

import argparse


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("info", help="summarise a BVH file (joints, frames, units, axes)")
    p.add_argument("file", help="BVH file")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    import numpy as np

    from mjchar import bvh

    motion = bvh.load(args.file)
    sk = motion.skeleton
    if motion.n_frames:
        points = bvh.forward_kinematics(motion).positions.reshape(-1, 3)
        frames = (f"{motion.n_frames} frames at {motion.fps:.2f} fps "
                  f"({motion.duration:.2f} s)")
    else:  # a skeleton without motion (the converter takes it): its rest pose
        points = sk.rest_positions()
        frames = "no frames (a skeleton without motion; the bounding box is the rest pose's)"
    lo, hi = points.min(axis=0), points.max(axis=0)
    print(f"{args.file}: {sk.n_joints} joints, {sk.n_end_sites} end sites, {frames}")
    from mjchar.bvh.mjcf import ConversionError
    from mjchar.bvh.mjcf.prepare import prepare
    from mjchar.bvh.rigs import units

    try:  # the converter's guesses (anatomy, after folding a static root and re-resting)
        prep = prepare(motion, sk)
        up, scale = prep.up, prep.scale
        notes = prep.warnings
    except ConversionError as e:
        up, scale = units.guess_up_axis(sk), units.guess_unit_scale(sk)
        notes = [f"not convertible as is: {e}"]
    print(f"  up axis (guessed): {up}, metres per unit (guessed): {scale:g}")
    for n in notes:
        print(f"  note: {n}")
    print(f"  bounding box: {np.round(lo, 3)} .. {np.round(hi, 3)}")
    print("  joints: " + ", ".join(sk.names))
    return 0
