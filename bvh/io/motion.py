"""The :class:`Motion`: a skeleton animated over frames, and its BVH channel encoding."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from mjchar.bvh.errors import SkeletonError
from mjchar.bvh.io.skeleton import POSITION_CHANNELS, ROTATION_CHANNELS, Skeleton
from mjchar.bvh.rotations import (
    _fix_continuity_inplace,
    quat_from_euler,
    quat_identity,
    quat_normalize,
    quat_to_euler,
)

_AXIS_INDEX = {"X": 0, "Y": 1, "Z": 2}
#: frames converted at a time from Euler angles to quaternions
_FRAME_BLOCK = 4096


class FrameTimes:
    """The times of ``n_frames`` frames ``frame_time`` seconds apart, for a clip that has both
    (:class:`Motion`, :class:`~mjchar.bvh.reference.reference_motion.ReferenceMotion`)."""

    n_frames: int
    frame_time: float

    @property
    def duration(self) -> float:
        """Seconds from the first to the last frame: ``(F - 1) * frame_time`` (the loop period of
        a cyclic clip)."""
        return (self.n_frames - 1) * self.frame_time

    @property
    def times(self) -> np.ndarray:
        """``(F,)`` time of each frame in seconds."""
        return np.arange(self.n_frames) * self.frame_time


@dataclass
class Motion(FrameTimes):
    """Frames of local joint transforms.

    Attributes:
        skeleton: the :class:`Skeleton` animated.
        frame_time: seconds per frame.
        local_positions: ``(F, J, 3)`` translation of each joint in its parent's frame, in file
            units. It equals the rest offset except for joints with position channels (the root,
            and 6-channel joints), whose channels *replace* the offset (the common reading of
            BVH, as Blender and most tools do).
        rotations: ``(F, J, 4)`` local joint rotations as unit wxyz quaternions.
        source_channels: optional ``(F, C)`` BVH channel values this motion was decoded from
            (set by :meth:`from_channels`, so by :func:`bvh.load`), or ``None``. Only a hint for
            :meth:`to_channels`: joints whose rotations still equal the decoded ones are written
            with these exact Euler angles, so an unedited file round-trips channel for channel
            (even angles outside the principal ranges). Ignored (set to ``None``) when its shape
            does not match the motion.
    """

    skeleton: Skeleton
    frame_time: float
    local_positions: np.ndarray
    rotations: np.ndarray
    source_channels: np.ndarray | None = field(default=None, repr=False, compare=False)

    def __post_init__(self) -> None:
        self.local_positions = np.asarray(self.local_positions, dtype=float)
        self.rotations = np.asarray(self.rotations, dtype=float)
        j = self.skeleton.n_joints
        if self.local_positions.ndim != 3 or self.local_positions.shape[1:] != (j, 3):
            raise SkeletonError(
                f"local_positions must be (F, {j}, 3), got {self.local_positions.shape}")
        if self.rotations.shape != (*self.local_positions.shape[:2], 4):
            raise SkeletonError(
                f"rotations must be ({len(self.local_positions)}, {j}, 4), "
                f"got {self.rotations.shape}"
            )
        if not (np.isfinite(self.frame_time) and self.frame_time > 0):
            raise SkeletonError(
                f"frame_time must be a positive number of seconds, got {self.frame_time}")
        self.frame_time = float(self.frame_time)
        if self.source_channels is not None:
            src = np.asarray(self.source_channels, dtype=float)
            ok = src.shape == (self.n_frames, self.skeleton.n_channels)
            self.source_channels = src if ok else None

    # -- sizes and time ----------------------------------------------------------------------
    @property
    def n_frames(self) -> int:
        return int(self.local_positions.shape[0])

    @property
    def fps(self) -> float:
        return 1.0 / self.frame_time

    @property
    def root_positions(self) -> np.ndarray:
        """``(F, 3)`` root translation per frame."""
        return self.local_positions[:, 0]

    def copy(self) -> Motion:
        src = None if self.source_channels is None else self.source_channels.copy()
        return Motion(self.skeleton.copy(), self.frame_time, self.local_positions.copy(),
                      self.rotations.copy(), src)

    def __getitem__(self, frames: slice | np.ndarray | list[int]) -> Motion:
        """A new Motion with the selected frames (a slice or an index array)."""
        if isinstance(frames, (int, np.integer)):
            frames = [int(frames)]
        src = None if self.source_channels is None else self.source_channels[frames]
        return Motion(self.skeleton, self.frame_time, self.local_positions[frames],
                      self.rotations[frames], src)

    @classmethod
    def rest(cls, skeleton: Skeleton, n_frames: int = 1, frame_time: float = 1 / 30) -> Motion:
        """``n_frames`` frames of the rest pose (offsets, identity rotations)."""
        pos = np.broadcast_to(skeleton.offsets, (n_frames, skeleton.n_joints, 3)).copy()
        return cls(skeleton, frame_time, pos, quat_identity((n_frames, skeleton.n_joints)))

    # -- BVH channel encoding ------------------------------------------------------------------
    @classmethod
    def from_channels(cls, skeleton: Skeleton, frame_time: float, values: np.ndarray, *,
                      copy: bool = True) -> Motion:
        """Decode a ``(F, C)`` array of BVH channel values (degrees for rotations).

        Rotation channels listed as ``A B C`` mean ``R = R_A R_B R_C`` (intrinsic order);
        position channels replace the matching components of the joint's offset. The values
        are kept as :attr:`source_channels` (a copy, unless ``copy=False`` hands the array
        over). Vectorised: one Euler conversion per distinct rotation order.
        """
        values = np.asarray(values, dtype=float)
        if values.ndim != 2 or values.shape[1] != skeleton.n_channels:
            raise SkeletonError(
                f"expected (F, {skeleton.n_channels}) channel values, got {values.shape}")
        n_f = values.shape[0]
        pos = np.broadcast_to(skeleton.offsets, (n_f, skeleton.n_joints, 3)).copy()
        # column layout: position channels (joint, axis, column), rotation columns by order
        pj: list[int] = []
        pa: list[int] = []
        pc: list[int] = []
        groups: dict[str, tuple[list[int], list[list[int]]]] = {}
        col = 0
        for j, chans in enumerate(skeleton.channels):
            order = ""
            rot_cols = []
            for c in chans:
                if c in POSITION_CHANNELS:
                    pj.append(j)
                    pa.append(_AXIS_INDEX[c[0]])
                    pc.append(col)
                else:
                    order += c[0]
                    rot_cols.append(col)
                col += 1
            if rot_cols:
                js, cols = groups.setdefault(order, ([], []))
                js.append(j)
                cols.append(rot_cols)
        if pj:
            pos[:, pj, pa] = values[:, pc]
        # in blocks of frames: the conversion's work arrays stay small for long clips
        rot = quat_identity((n_f, skeleton.n_joints))
        everywhere = (len(groups) == 1
                      and len(next(iter(groups.values()))[0]) == skeleton.n_joints)
        for a in range(0, n_f, _FRAME_BLOCK):
            block = values[a:a + _FRAME_BLOCK]
            for order, (js, cols) in groups.items():
                q = quat_from_euler(block[:, np.array(cols)], order)
                if everywhere:  # the usual file: one order on every joint
                    rot[a:a + _FRAME_BLOCK] = q
                else:
                    rot[a:a + _FRAME_BLOCK, js] = q
        _fix_continuity_inplace(rot)
        return cls(skeleton, frame_time, pos, rot, values.copy() if copy else values)

    def to_channels(self) -> np.ndarray:
        """Encode as a ``(F, C)`` array of BVH channel values (degrees), continuous over frames.

        Joints whose rotations equal those decoded from :attr:`source_channels` (unedited) get
        those exact angles back. Otherwise Euler angles are chosen frame by frame as the
        solution nearest the previous frame (both Euler branches and multiples of 360 degrees
        are considered), starting from the principal solution, so curves do not jump at
        +-180 degrees or at gimbal crossings.
        A joint with fewer than three rotation channels can only express rotations about those
        axes; the other components are dropped (the Euler branch that leaves them smallest is
        used, so a rotation the joint can express is encoded exactly).
        """
        sk = self.skeleton
        out = np.zeros((self.n_frames, sk.n_channels))
        src = self.source_channels
        for j, (chans, start) in enumerate(zip(sk.channels, sk.channel_starts(), strict=True)):
            rot_cols = [start + k for k, c in enumerate(chans) if c in ROTATION_CHANNELS]
            for k, c in enumerate(chans):
                if c in POSITION_CHANNELS:
                    out[:, start + k] = self.local_positions[:, j, POSITION_CHANNELS.index(c)]
            if rot_cols and self.n_frames:
                order = sk.rotation_order(j)
                q = quat_normalize(self.rotations[:, j])
                if src is not None:
                    hint = src[:, rot_cols]
                    qh = quat_from_euler(hint, order)
                    diff = np.minimum(np.abs(qh - q).max(axis=1), np.abs(qh + q).max(axis=1))
                    if np.all(diff < 1e-9):
                        out[:, rot_cols] = hint
                        continue
                out[:, rot_cols] = _continuous_euler(q, order)
        return out


def _wrap180(a: np.ndarray) -> np.ndarray:
    """Angles (degrees) wrapped to [-180, 180)."""
    return (a + 180.0) % 360.0 - 180.0


def _other_branch(a: np.ndarray, order: str) -> np.ndarray:
    """The second Euler solution ``(F, 3)`` (degrees) of the same rotations as ``a``.

    Tait-Bryan ``ABC``: ``R_A(a+180) R_B(180-b) R_C(c+180) = R_A(a) R_B(b) R_C(c)``, because a
    half turn about A flips the B axis and two half turns about perpendicular axes A, C make a
    half turn about B. Proper Euler ``ABA``: ``(a+180, -b, c+180)``.
    """
    b = np.stack([a[:, 0] + 180.0, 180.0 - a[:, 1], a[:, 2] + 180.0], axis=1)
    if order[0] == order[2]:
        b[:, 1] = -a[:, 1]
    return b


def _continuous_euler(q: np.ndarray, order: str) -> np.ndarray:
    """``(F, n)`` intrinsic Euler angles in degrees for ``(F, 4)`` quaternions, continuous in F.

    ``order`` has ``n`` = 1-3 axis letters (3 may be Tait-Bryan or proper Euler).
    """
    n = len(order)
    full = order if n == 3 else order + "".join(x for x in "XYZ" if x not in order)
    a = quat_to_euler(q, full)  # principal solution, exact also next to gimbal lock
    if n < 3:
        # one or two axes: of the two solutions, the one whose dropped angles are nearest zero
        # (exactly zero when the joint can express the rotation)
        b = _other_branch(a, full)
        use_b = np.abs(_wrap180(b[:, n:])).sum(axis=1) < np.abs(_wrap180(a[:, n:])).sum(axis=1)
        kept = np.where(use_b[:, None], b, a)[:, :n]
        return np.rad2deg(np.unwrap(np.deg2rad(_wrap180(kept)), axis=0))
    unwrapped = np.rad2deg(np.unwrap(np.deg2rad(a), axis=0))
    if len(a) < 2 or np.max(np.abs(np.diff(unwrapped, axis=0))) < 90.0:
        return unwrapped  # the common case: no branch switch needed
    b = _other_branch(a, order)
    out = np.empty_like(a)
    prev = a[0]
    for f in range(len(a)):  # greedy: branch and 360-degree shift nearest the previous frame
        cands = np.stack([a[f], b[f]])
        cands = cands + 360.0 * np.round((prev - cands) / 360.0)
        prev = out[f] = cands[np.argmin(np.sum((cands - prev) ** 2, axis=1))]
    return out
