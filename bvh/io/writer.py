"""BVH writing: a :class:`~mjchar.bvh.io.motion.Motion` as BVH text.

What :func:`dumps` writes, :func:`~mjchar.bvh.io.reader.loads` reads back within ``10**-precision``
on every channel (a round trip).
"""

from __future__ import annotations

import os

import numpy as np

from mjchar.bvh.io.files import write_text
from mjchar.bvh.io.motion import Motion

__all__ = ["dumps", "save"]


def dumps(motion: Motion, precision: int = 6) -> str:
    """BVH text for ``motion`` (``\\n`` line ends, tab indentation).

    Rotations become Euler angles in degrees in each joint's channel order (see
    :meth:`Motion.to_channels`); ``precision`` is the number of decimals of every value.
    Joints are written depth-first in index order (a file can hold no other order, so a
    skeleton whose joints are not depth-first comes back renumbered depth-first); each End Site
    is written before the first child holding a later-numbered End Site, so the end-site order
    of anything read from a file survives a round trip.
    """
    sk = motion.skeleton
    n_j = sk.n_joints
    children: list[list[int]] = [[] for _ in range(n_j)]
    for j in range(1, n_j):
        children[sk.parents[j]].append(j)
    sites: list[list[int]] = [[] for _ in range(n_j)]
    for e, p in enumerate(sk.end_site_parents):
        sites[p].append(e)
    first_site = [min(s, default=len(sk.end_site_parents)) for s in sites]
    for j in range(n_j - 1, 0, -1):  # smallest end-site index in each subtree
        first_site[sk.parents[j]] = min(first_site[sk.parents[j]], first_site[j])
    items: list[list[tuple[bool, int]]] = []  # per joint: (is_joint, index) in writing order
    for j in range(n_j):
        pending, row = list(sites[j]), []
        for c in children[j]:
            while pending and pending[0] < first_site[c]:
                row.append((False, pending.pop(0)))
            row.append((True, c))
        row.extend((False, e) for e in pending)
        items.append(row)
    fmt = f"{{:.{precision}f}}"

    def vec(v: np.ndarray) -> str:
        return " ".join(fmt.format(float(x)) for x in v)

    out = ["HIERARCHY"]
    written: list[int] = []  # joints in the order the file holds them (its channel order)

    def open_joint(j: int, ind: str) -> None:
        written.append(j)
        out.append(f"{ind}{'ROOT' if j == 0 else 'JOINT'} {sk.names[j]}")
        out.append(f"{ind}{{")
        out.append(f"{ind}\tOFFSET {vec(sk.offsets[j])}")
        chans = "".join(f" {c}" for c in sk.channels[j])
        out.append(f"{ind}\tCHANNELS {len(sk.channels[j])}{chans}")

    # iterative depth-first walk (no recursion limit on deep skeletons)
    open_joint(0, "")
    stack = [iter(items[0])]
    while stack:
        ind = "\t" * len(stack)
        nxt = next(stack[-1], None)
        if nxt is None:
            stack.pop()
            out.append(f"{ind[1:]}}}")
        elif nxt[0]:
            open_joint(nxt[1], ind)
            stack.append(iter(items[nxt[1]]))
        else:
            out.append(f"{ind}End Site")
            out.append(f"{ind}{{")
            out.append(f"{ind}\tOFFSET {vec(sk.end_site_offsets[nxt[1]])}")
            out.append(f"{ind}}}")
    out.append("MOTION")
    out.append(f"Frames: {motion.n_frames}")
    out.append(f"Frame Time: {motion.frame_time:.{max(precision, 8)}g}")
    values = motion.to_channels()
    if written != list(range(n_j)):  # a skeleton not numbered depth-first: the file's order
        starts = sk.channel_starts()
        cols = [starts[j] + k for j in written for k in range(len(sk.channels[j]))]
        values = values[:, cols]
    if values.shape[1]:
        row = " ".join([f"%.{precision}f"] * values.shape[1])
        out.extend(row % tuple(r) for r in values.tolist())
    else:
        out.extend("" for _ in range(motion.n_frames))
    return "\n".join(out) + "\n"


def save(motion: Motion, path: str | os.PathLike, precision: int = 6) -> None:
    """Write ``motion`` to ``path`` as BVH (see :func:`dumps`), atomically (a failed write leaves
    what was there)."""
    write_text(path, dumps(motion, precision))
