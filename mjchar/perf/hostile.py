"""Cost of pathological but valid input: ``python -m mjchar.perf.hostile``.

Makes, in a temporary folder, a 5,000-joint chain, the bundled walk with a 2,000-joint tail
hanging from its head (a body the converter builds, dropping the tail) and a 50 MB clip of
repeated frames (the bundled walk's frames over and over), runs ``mjchar info`` and ``mjchar
convert`` on each in a process of its own, and prints a table of each process's CPU seconds
and peak resident memory (``getrusage`` of the process itself), beside the same for the bundled
walk (the baseline: what importing mjchar and MuJoCo costs) and the file's size. ``--joints``,
``--tail`` and ``--megabytes`` change the sizes.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

from mjchar.bvh.bundled.assets import motion_path

from .report import entry_parser

#: the child: runs one mjchar command, then reports its own CPU time and peak memory
_CHILD = r"""
import json, os, resource, sys
from mjchar.cli import main
devnull = os.open(os.devnull, os.O_WRONLY)
os.dup2(devnull, 1)
os.dup2(devnull, 2)
rc = main(sys.argv[2:])
u = resource.getrusage(resource.RUSAGE_SELF)
with open(sys.argv[1], "w") as fh:
    json.dump({"rc": rc, "cpu_s": u.ru_utime + u.ru_stime, "peak_mb": u.ru_maxrss / 1024}, fh)
"""


def chain(n_joints: int) -> str:
    """A BVH chain of ``n_joints`` joints, each 10 units above its parent, two frames."""
    parts = ["HIERARCHY", "ROOT j0", "{", "OFFSET 0 0 0",
             "CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation"]
    for k in range(1, n_joints):
        parts += [f"JOINT j{k}", "{", "OFFSET 0 10 0", "CHANNELS 3 Zrotation Xrotation Yrotation"]
    parts += ["End Site", "{", "OFFSET 0 10 0", "}"] + ["}"] * n_joints
    n_ch = 6 + 3 * (n_joints - 1)
    parts += ["MOTION", "Frames: 2", "Frame Time: 0.0333333"] + [" ".join(["0"] * n_ch)] * 2
    return "\n".join(parts) + "\n"


def with_tail(n_joints: int) -> str:
    """The bundled walk with a chain of ``n_joints`` joints (1 mm apart, no rotation) below its
    head joint."""
    import numpy as np

    from mjchar import bvh

    m = bvh.load(motion_path("walk"))
    sk = m.skeleton
    head = next(j for j, n in enumerate(sk.names) if "head" in n.lower())
    n = sk.n_joints
    names = sk.names + [f"tail{k}" for k in range(n_joints)]
    parents = np.concatenate([sk.parents, [head], np.arange(n, n + n_joints - 1)])
    offsets = np.concatenate([sk.offsets, np.tile([0.0, 0.001, 0.0], (n_joints, 1))])
    channels = sk.channels + [("Zrotation", "Xrotation", "Yrotation")] * n_joints
    tail_sk = bvh.Skeleton(names, parents, offsets, channels, sk.end_site_parents,
                           sk.end_site_offsets)
    f = m.n_frames
    pos = np.concatenate([m.local_positions, np.broadcast_to(offsets[n:], (f, n_joints, 3))],
                         axis=1)
    rot = np.concatenate([m.rotations, np.tile([1.0, 0, 0, 0], (f, n_joints, 1))], axis=1)
    return bvh.dumps(bvh.Motion(tail_sk, m.frame_time, pos, rot))


def repeated(megabytes: float) -> str:
    """The bundled walk with its frames repeated to about ``megabytes`` MB."""
    head, _, rest = motion_path("walk").read_text().partition("MOTION")
    lines = rest.strip().splitlines()
    frames = "\n".join(lines[2:]) + "\n"
    reps = int(megabytes * 2**20 / len(frames)) + 1
    return (head + f"MOTION\nFrames: {reps * (len(lines) - 2)}\n{lines[1]}\n" + frames * reps)


def measure(argv: list[str], folder: Path) -> dict:
    """``{"rc", "cpu_s", "peak_mb"}`` of ``mjchar ARGV`` in a process of its own."""
    out = folder / "usage.json"
    subprocess.run([sys.executable, "-c", _CHILD, str(out), *argv], cwd=folder, check=False)
    return json.loads(out.read_text())


def main(argv: list[str] | None = None) -> int:
    p = entry_parser("hostile", __doc__)
    p.add_argument("--joints", type=int, default=5000, help="joints of the chain (5000)")
    p.add_argument("--tail", type=int, default=2000, help="joints of the walk's tail (2000)")
    p.add_argument("--megabytes", type=float, default=50.0, help="size of the long clip (50)")
    args = p.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        files = {"bundled walk": motion_path("walk"),
                 f"{args.joints}-joint chain": d / "chain.bvh",
                 f"bundled walk with a {args.tail}-joint tail": d / "tail.bvh",
                 f"{args.megabytes:g} MB of repeated frames": d / "long.bvh"}
        files[f"{args.joints}-joint chain"].write_text(chain(args.joints))
        files[f"bundled walk with a {args.tail}-joint tail"].write_text(with_tail(args.tail))
        files[f"{args.megabytes:g} MB of repeated frames"].write_text(repeated(args.megabytes))
        print("| file | size MB | command | exit | CPU s | peak memory MB |")
        print("|---|---|---|---|---|---|")
        for label, path in files.items():
            size = os.path.getsize(path) / 2**20
            for cmd in (["info", str(path)], ["convert", str(path), "-o", str(d / "o.xml")]):
                r = measure(cmd, d)
                print(f"| {label} | {size:.1f} | mjchar {cmd[0]} | {r['rc']} | {r['cpu_s']:.1f} "
                      f"| {r['peak_mb']:.0f} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
