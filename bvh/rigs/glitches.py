"""Glitch frames: where a capture jumps further than a body can move between two frames.

Optical and inertial captures lose a marker or a sensor for a few frames and write the root
metres away, or a joint turned half a turn, then come back. Such frames are found from
physical limits, not from the clip's statistics:

1. a **transition** between two consecutive frames is impossible when the body (the centroid
   of its joints) moves faster than :data:`ROOT_SPEED_LIMIT`, or a joint moves relative to
   it faster than :data:`JOINT_SPEED_LIMIT` (a limb turned half a turn; a finger or a
   zero-length helper that flips moves nothing far, so it is no glitch);
2. the impossible transitions cut the clip into segments; the longest is taken as good, and
   each other segment is good when it continues the last good frame before it (root and
   joints within the same limits over the elapsed time), else its frames are glitch frames.

The converter and ``mjchar info`` flag them; the clip conditioning before tracking
(:mod:`mjchar.bvh.reference.conditioning`) repairs short runs by interpolation and refuses
long ones.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from mjchar.bvh.io.motion import Motion
from mjchar.bvh.kinematics.fk import forward_kinematics

#: m/s: no body's root moves faster (a sprinter peaks near 12 m/s)
ROOT_SPEED_LIMIT = 20.0
#: m/s: no joint moves faster relative to the body's centroid (a pitcher's hand peaks near
#: 20 m/s)
JOINT_SPEED_LIMIT = 40.0


@dataclass
class Glitches:
    """Glitch frames of a clip.

    Attributes:
        frames: ``(F,)`` bool, True for a glitch frame.
        runs: ``[(start, stop), ...]`` frame ranges (``stop`` exclusive) of consecutive glitch
            frames.
        root_jump_m: the largest distance (m) the body's centroid moves between two
            consecutive frames.
        frame_time: seconds per frame.
    """

    frames: np.ndarray
    runs: list[tuple[int, int]] = field(default_factory=list)
    root_jump_m: float = 0.0
    frame_time: float = 1.0

    def __bool__(self) -> bool:
        return bool(self.runs)

    def describe(self) -> str:
        """One phrase: ``"5 frames in 1 run (frames 120-124; the body jumps up to 1460 m
        between frames)"``."""
        n = int(self.frames.sum())
        spans = ", ".join(f"{a}-{b - 1}" if b - a > 1 else f"{a}" for a, b in self.runs[:4])
        more = ", ..." if len(self.runs) > 4 else ""
        return (f"{n} frame{'s' if n != 1 else ''} in {len(self.runs)} "
                f"run{'s' if len(self.runs) != 1 else ''} (frames {spans}{more}; the body jumps "
                f"up to {self.root_jump_m:.3g} m between frames)")


def find_glitches(motion: Motion, scale: float = 1.0) -> Glitches:
    """The glitch frames of ``motion`` (module docstring); ``scale``: metres per file unit."""
    F, dt = motion.n_frames, float(motion.frame_time)
    if F < 3 or dt <= 0:
        return Glitches(np.zeros(F, dtype=bool), [], 0.0, dt)
    # the body's centroid: a static node above the pelvis (joint_Root) never moves itself
    P = forward_kinematics(motion).positions * float(scale)               # (F, J, 3) m
    p = P.mean(axis=1)                                                    # (F, 3)
    r = P - p[:, None]                                                    # (F, J, 3)
    step = np.linalg.norm(np.diff(p, axis=0), axis=1)                     # (F-1,) m
    turn = np.linalg.norm(np.diff(r, axis=0), axis=2).max(axis=1)         # (F-1,) m
    bad = (step > ROOT_SPEED_LIMIT * dt) | (turn > JOINT_SPEED_LIMIT * dt)
    frames = np.zeros(F, dtype=bool)
    if bad.any():
        cuts = np.flatnonzero(bad) + 1
        segs = list(zip(np.r_[0, cuts], np.r_[cuts, F], strict=True))
        best = max(range(len(segs)), key=lambda i: segs[i][1] - segs[i][0])

        def continues(a: int, b: int) -> bool:
            gap = abs(b - a) * dt
            return bool(np.linalg.norm(p[b] - p[a]) <= ROOT_SPEED_LIMIT * gap
                        and np.linalg.norm(r[b] - r[a], axis=1).max() <= JOINT_SPEED_LIMIT * gap)

        last = segs[best][1] - 1
        for a, b in segs[best + 1:]:
            if continues(last, a):
                last = b - 1
            else:
                frames[a:b] = True
        first = segs[best][0]
        for a, b in reversed(segs[:best]):
            if continues(first, b - 1):
                first = a
            else:
                frames[a:b] = True
    runs = []
    edges = np.diff(np.r_[0, frames.astype(int), 0])
    for a, b in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1), strict=True):
        runs.append((int(a), int(b)))
    return Glitches(frames, runs, float(step.max()), dt)
