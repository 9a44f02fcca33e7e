"""The ``mjchar`` command line.

Each subcommand lives in the module that owns the work and registers itself here through a
``add_parser(subparsers)`` function; this module only dispatches and turns project errors into
one-line messages with a non-zero exit status.
"""

from __future__ import annotations

import argparse
import sys

from bvh.errors import MjcharError


def _info(args: argparse.Namespace) -> int:
    import numpy as np

    import bvh

    motion = bvh.load(args.file)
    sk = motion.skeleton
    fk = bvh.forward_kinematics(motion)
    lo = fk.positions.reshape(-1, 3).min(axis=0)
    hi = fk.positions.reshape(-1, 3).max(axis=0)
    print(f"{args.file}: {sk.n_joints} joints, {sk.n_end_sites} end sites, "
          f"{motion.n_frames} frames at {motion.fps:.2f} fps ({motion.duration:.2f} s)")
    print(f"  up axis (guessed): {bvh.units.guess_up_axis(sk)}, "
          f"metres per unit (guessed): {bvh.units.guess_unit_scale(sk):g}")
    print(f"  bounding box: {np.round(lo, 3)} .. {np.round(hi, 3)}")
    print("  joints: " + ", ".join(sk.names))
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="mjchar", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    p = sub.add_parser("info", help="summarise a BVH file (joints, frames, units, axes)")
    p.add_argument("file", help="BVH file")
    p.set_defaults(func=_info)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except MjcharError as e:
        print(f"mjchar {args.command}: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
