"""Clip conditioning: what a captured clip needs before a physics tracker follows it.

Video-lifted and consumer captures float above the floor, sink into it, slide their standing
feet and carry glitch frames; a physical body cannot follow any of that. As physics-based
trackers of video motion do (PhysCap, Shimada et al. 2020; SimPoE, Yuan et al. 2021), the clip is
conditioned kinematically first, in the file's own units and axes (the model's ``unit_scale`` and
``up_axis`` say which), moving only the root:

1. **Glitch frames** (:func:`mjchar.bvh.rigs.glitches.find_glitches`): runs of at most
   :data:`MAX_REPAIR_S` are replaced by interpolation between the good frames around them (root
   position linear, every joint's rotation slerped; at a clip end the nearest good frame is
   held); a longer run is refused in one line (:class:`ConditioningError`).
2. **Contact labels** per frame and foot: the foot's lowest joint (ankle or toe) within
   :data:`CONTACT_HEIGHT_M` of the clip's floor, neither rising nor dropping faster than
   :data:`CONTACT_RISE_MPS`, and either slower than :data:`CONTACT_SPEED_MPS` horizontally
   (its slowest joint), or the only foot that low, or the slower of two (a clip that walks in
   place slides its standing foot back at the walking speed); one-frame flickers cleared. The
   floor is the median height of the lowest foot joint over the frames where a foot is slow.
3. **Feet on the floor**: the whole clip is shifted so the floor is at height 0 (the height
   offset), and each frame with a foot in contact by what puts that foot's lowest point on the
   floor (penetration and float), frames without contact interpolated between them; left as
   it is when that is under :data:`FLOAT_MIN_M` on average.
4. **Foot skating**: a pivot of a foot in contact (its ankle or its toe) stands while it is at
   its own standing height (within :data:`PIVOT_BAND_M`): the heel while the foot lands, both
   when it is flat, the toe while it pushes off, so a rolling foot is no skating. The root is
   shifted horizontally so that every standing pivot stays where it began to stand (several:
   the mean of their corrections); between contacts the shift is held, so the body travels by
   its steps (a new anchor is taken where the shift stands, so the shift has no steps). Left
   as it is when the standing pivots slide slower than :data:`SKATE_MIN_MPS` (median: capture
   noise; clean captures are not touched).

The model's own grounding (:class:`~mjchar.bvh.reference.reference_motion.ReferenceMotion`,
``floor="contact"``) still puts the model's foot boxes on the floor afterwards. Trackers take
the conditioned clip (:func:`mjchar.controllers.core.builder.load_reference`) and report their
error against it and against the raw clip.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from mjchar.bvh.errors import ReferenceMotionError
from mjchar.bvh.io.motion import Motion
from mjchar.bvh.kinematics.fk import forward_kinematics
from mjchar.bvh.rigs.glitches import Glitches, find_glitches
from mjchar.bvh.rigs.units import AXIS_VECTORS
from mjchar.bvh.rotations import quat_slerp

#: s: the longest run of glitch frames repaired by interpolation
MAX_REPAIR_S = 0.25
#: m: a foot this close to the floor (and slow) is in contact
CONTACT_HEIGHT_M = 0.05
#: m/s: a foot slower than this horizontally (and low) is in contact
CONTACT_SPEED_MPS = 0.3
#: m/s: a foot rising or dropping faster than this (lifting off, landing) is not in contact
CONTACT_RISE_MPS = 0.25
#: frames: the float correction is smoothed over this many frames (the skate correction is
#: continuous by construction)
SMOOTH_FRAMES = 5
#: m: a pivot of a foot in contact (ankle or toe) stands within this of its standing height
PIVOT_BAND_M = 0.02
#: m/s: standing pivots sliding slower than this (median) are left as they are: optical and
#: inertial captures show 0.003-0.1 m/s (the shared and real clips); cmu_daz_02_03, whose
#: header frame time is 3x too long, 0.17; a clip that walks in place slides at its speed
SKATE_MIN_MPS = 0.25
#: m: contact feet floating or sinking less than this on average are left as they are (the
#: shared and real clips: 0-17 mm); the model's grounding handles the rest
FLOAT_MIN_M = 0.02


class ConditioningError(ReferenceMotionError):
    """A clip that conditioning cannot make trackable (a long run of glitch frames)."""


@dataclass
class Conditioned:
    """A conditioned clip and what was done.

    Attributes:
        motion: the conditioned clip (file units and axes, same skeleton).
        glitches: the glitch frames found (:class:`~mjchar.bvh.rigs.glitches.Glitches`).
        repaired: ``[(start, stop), ...]`` frame runs replaced by interpolation.
        contacts: ``(F, 2)`` bool contact labels, columns (left, right).
        height_offset_m: metres the whole clip was moved up (floor to height 0).
        float_m: mean |per-frame vertical correction| (m) over contact frames.
        skate_mps: mean horizontal speed (m/s) of feet in contact, before and after.
    """

    motion: Motion
    glitches: Glitches
    repaired: list[tuple[int, int]] = field(default_factory=list)
    contacts: np.ndarray | None = None
    height_offset_m: float = 0.0
    float_m: float = 0.0
    skate_mps: tuple[float, float] = (0.0, 0.0)

    @property
    def changed(self) -> bool:
        """Whether the clip differs from the raw one in more than its height (which the
        model's grounding sets anyway)."""
        return bool(self.repaired) or self.float_m > 0.0 or self.skate_mps[0] != self.skate_mps[1]

    def summary(self) -> str:
        """One line: what conditioning did."""
        parts = []
        if self.repaired:
            parts.append(f"{sum(b - a for a, b in self.repaired)} glitch frames interpolated")
        parts.append(f"floor offset {self.height_offset_m:+.3f} m, float/penetration "
                     f"{1000 * self.float_m:.0f} mm")
        parts.append(f"stance-foot skating {self.skate_mps[0]:.3f} -> {self.skate_mps[1]:.3f} "
                     "m/s")
        return "clip conditioned: " + ", ".join(parts)


def _repair(motion: Motion, glitches: Glitches, name: str) -> tuple[Motion, list]:
    """Glitch runs interpolated (step 1); a run longer than :data:`MAX_REPAIR_S` refused."""
    F, dt = motion.n_frames, float(motion.frame_time)
    m = motion.copy()
    for a, b in glitches.runs:
        if (b - a) * dt > MAX_REPAIR_S:
            raise ConditioningError(
                f"{name}: {b - a} glitch frames in a row (frames {a}-{b - 1}, {(b - a) * dt:.2f} "
                f"s; the body jumps up to {glitches.root_jump_m:.3g} m between frames): too long "
                f"to repair (at most {MAX_REPAIR_S:g} s); cut them out of the clip")
        lo, hi = a - 1, b
        for t in range(a, b):
            if lo < 0 and hi >= F:
                break
            src = [hi, hi] if lo < 0 else ([lo, lo] if hi >= F else [lo, hi])
            w = 0.0 if src[0] == src[1] else (t - lo) / (hi - lo)
            m.local_positions[t] = ((1 - w) * motion.local_positions[src[0]]
                                    + w * motion.local_positions[src[1]])
            m.rotations[t] = quat_slerp(motion.rotations[src[0]], motion.rotations[src[1]], w)
    return m, list(glitches.runs)


def _foot_joints(motion: Motion, roles: dict) -> list[list[int]]:
    """Per side (left, right): the joints of the foot (ankle and toe), by the model's roles."""
    names = motion.skeleton.names
    out = []
    for s in ("left", "right"):
        js = [names.index(v) for r in ("ankle", "toe")
              if isinstance(v := roles.get(f"{s}_{r}"), str) and v in names]
        out.append(js)
    return out


def _smooth(x: np.ndarray, n: int) -> np.ndarray:
    """``x`` ``(F, ...)`` averaged over a centred window of ``n`` frames (edges held)."""
    if n <= 1 or len(x) < n:
        return x
    pad = np.concatenate([np.repeat(x[:1], n // 2, axis=0), x,
                          np.repeat(x[-1:], n - 1 - n // 2, axis=0)])
    c = np.cumsum(np.concatenate([np.zeros_like(x[:1]), pad]), axis=0)
    return (c[n:] - c[:-n]) / n


def condition(motion: Motion, info, name: str = "the clip") -> Conditioned:
    """Condition ``motion`` (file units and axes) for tracking in the model of ``info`` (its
    ``ModelInfo``: ``unit_scale``, ``up_axis``, ``roles``); see the module docstring."""
    scale = float(info.unit_scale)
    glitches = find_glitches(motion, scale)
    m, repaired = _repair(motion, glitches, name)
    feet = _foot_joints(m, info.roles)
    if m.n_frames < 3 or not all(feet):
        return Conditioned(m, glitches, repaired)
    up = AXIS_VECTORS[str(info.up_axis)]
    dt = float(m.frame_time)
    fk = forward_kinematics(m)
    P = fk.positions * scale                                              # (F, J, 3) m
    heights = np.stack([(P[:, js] @ up).min(axis=1) for js in feet], axis=1)    # (F, 2)
    piv, piv_h, piv_v = _pivots(P, feet, up, dt)
    # 2. contact labels and the clip's floor
    contacts, floor = _contacts(heights, piv_h, piv_v, dt)
    # 3. feet on the floor: the height offset, then each contact frame's float or penetration
    offset = -floor
    dz, float_m = _float_correction(contacts, heights, floor)
    # 4. foot skating: the root follows the pivots that stand
    standing = _standing_pivots(piv_h, contacts)
    d, before_mps, slid = _skate_shift(piv, piv_v, standing)
    shift = (d + (offset + dz)[:, None] * up) / scale                    # (F, 3) file units
    m.local_positions[:, 0] += shift
    after = [np.linalg.norm(np.gradient(x + d, dt, axis=0), axis=1)[standing[s][k]]
             for s in range(2) for k, x in enumerate(piv[s])]
    after_mps = float(np.median(np.concatenate(after))) if slid else 0.0
    return Conditioned(m, glitches, repaired, contacts, float(offset), float_m,
                       (before_mps, after_mps))


def _pivots(P: np.ndarray, feet: list[list[int]], up: np.ndarray,
            dt: float) -> tuple[list, list, list]:
    """Each foot's pivots (ankle, toe) from the joint positions ``P`` ``(F, J, 3)`` (m):
    ``(F, 3)`` horizontal positions, ``(F,)`` heights and ``(F,)`` horizontal speeds, per side
    and pivot."""
    horiz = np.eye(3) - np.outer(up, up)
    piv = [[P[:, j] @ horiz for j in js] for js in feet]
    piv_h = [[P[:, j] @ up for j in js] for js in feet]
    piv_v = [[np.linalg.norm(np.gradient(x, dt, axis=0), axis=1) for x in side] for side in piv]
    return piv, piv_h, piv_v


def _contacts(heights: np.ndarray, piv_h: list, piv_v: list,
              dt: float) -> tuple[np.ndarray, float]:
    """Step 2: ``(contacts (F, 2) bool, floor height m)`` from the feet's lowest heights
    ``(F, 2)`` and their pivots' heights and speeds (:func:`_pivots`)."""
    # a foot is as slow as its slowest pivot (the heel while it lands, the toe while it pushes)
    speed = np.stack([np.min(side, axis=0) for side in piv_v], axis=1)           # (F, 2)
    slow = speed < CONTACT_SPEED_MPS
    low = heights.min(axis=1)
    floor = float(np.median(heights[slow])) if slow.any() else float(low.min())
    floor = min(floor, float(np.percentile(low, 50)))
    near = heights - floor < CONTACT_HEIGHT_M                                     # (F, 2)
    # a low foot stands when it is slow, or the only low one, or the slower of two low ones
    # (a clip that walks in place slides its standing foot back at the walking speed)
    # and a foot that rises or drops (lifting off, landing) is not standing
    rise = np.stack([np.abs(np.gradient(np.min(side, axis=0), dt)) for side in piv_h], axis=1)
    other_near, other_speed = near[:, ::-1], speed[:, ::-1]
    contacts = near & (rise < CONTACT_RISE_MPS) & (slow | ~other_near | (speed < other_speed))
    # one-frame flickers removed: a label is the majority of its frame and its neighbours
    c = contacts.astype(int)
    pad = np.concatenate([c[:1], c, c[-1:]])
    contacts = (pad[:-2] + pad[1:-1] + pad[2:]) >= 2
    return contacts, floor


def _float_correction(contacts: np.ndarray, heights: np.ndarray,
                      floor: float) -> tuple[np.ndarray, float]:
    """Step 3: ``(dz (F,), float_m)``, the per-frame vertical correction putting the lowest
    contact foot on the floor (interpolated between contacts, smoothed; zero under
    :data:`FLOAT_MIN_M` on average) and its mean magnitude over the contact frames."""
    n_frames = len(heights)
    dz = np.full(n_frames, np.nan)
    have = contacts.any(axis=1)
    if have.any():
        lowest = np.where(contacts, heights, np.inf).min(axis=1)
        dz[have] = floor - lowest[have]
        t = np.arange(n_frames)
        dz = np.interp(t, t[have], dz[have])
        dz = _smooth(dz, SMOOTH_FRAMES)
    else:
        dz = np.zeros(n_frames)
    float_m = float(np.abs(dz[have]).mean()) if have.any() else 0.0
    if float_m < FLOAT_MIN_M:
        dz, float_m = np.zeros(n_frames), 0.0
    return dz, float_m


def _standing_pivots(piv_h: list, contacts: np.ndarray) -> list[list[np.ndarray]]:
    """Per side and pivot, ``(F,)`` bool: the pivot of a foot in contact stands while it is at
    its own standing height (within :data:`PIVOT_BAND_M` of its median over the contact
    frames): the heel while the foot lands, both when it is flat, the toe while it pushes
    off; a rolling foot is no skating."""
    standing = []
    for s in range(2):
        rows = []
        for h in piv_h[s]:
            base = float(np.median(h[contacts[:, s]])) if contacts[:, s].any() else float(h.min())
            rows.append(contacts[:, s] & (h - base < PIVOT_BAND_M))
        standing.append(rows)
    return standing


def _skate_shift(piv: list, piv_v: list,
                 standing: list[list[np.ndarray]]) -> tuple[np.ndarray, float, bool]:
    """Step 4: ``(d (F, 3), before_mps, slid)``: the horizontal root shift (m) keeping every
    standing pivot where it began to stand (the mean of their corrections; held between
    contacts), zero when the standing pivots slide slower than :data:`SKATE_MIN_MPS`
    (median, ``before_mps``); ``slid``: some pivot stands at all."""
    slide = [v for s in range(2) for k, v in enumerate(piv_v[s]) if standing[s][k].any()
             for v in v[standing[s][k]]]
    before_mps = float(np.median(slide)) if slide else 0.0
    n_frames = len(piv[0][0])
    d = np.zeros((n_frames, 3))
    anchors: dict[tuple[int, int], np.ndarray] = {}
    for t in range(n_frames):
        prev = d[t - 1] if t else np.zeros(3)
        targets = []
        for s in range(2):
            for k, x in enumerate(piv[s]):
                if not standing[s][k][t]:
                    anchors.pop((s, k), None)
                    continue
                if (s, k) not in anchors:
                    anchors[(s, k)] = x[t] + prev
                targets.append(anchors[(s, k)] - x[t])
        d[t] = np.mean(targets, axis=0) if targets else prev
    if before_mps < SKATE_MIN_MPS:
        d = np.zeros_like(d)
    return d, before_mps, bool(slide)
