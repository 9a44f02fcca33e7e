"""The :class:`Motion`: a skeleton animated over frames, and its BVH channel encoding."""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from .errors import SkeletonError
from .rotations import from_rotation, quat_fix_continuity, quat_identity, quat_normalize, to_rotation
from .skeleton import POSITION_CHANNELS, ROTATION_CHANNELS, Skeleton


@dataclass
class Motion:
    """Frames of local joint transforms.

    Attributes:
        skeleton: the :class:`Skeleton` animated.
        frame_time: seconds per frame.
        local_positions: ``(F, J, 3)`` translation of each joint in its parent's frame, in file
            units. It equals the rest offset except for joints with position channels (the root,
            and 6-channel joints), whose channels *replace* the offset (the common reading of
            BVH, as Blender and most tools do).
        rotations: ``(F, J, 4)`` local joint rotations as unit wxyz quaternions.
    """

    skeleton: Skeleton
    frame_time: float
    local_positions: np.ndarray
    rotations: np.ndarray

    def __post_init__(self) -> None:
        self.local_positions = np.asarray(self.local_positions, dtype=float)
        self.rotations = np.asarray(self.rotations, dtype=float)
        j = self.skeleton.n_joints
        if self.local_positions.ndim != 3 or self.local_positions.shape[1:] != (j, 3):
            raise SkeletonError(f"local_positions must be (F, {j}, 3), got {self.local_positions.shape}")
        if self.rotations.shape != (*self.local_positions.shape[:2], 4):
            raise SkeletonError(
                f"rotations must be ({len(self.local_positions)}, {j}, 4), got {self.rotations.shape}"
            )
        if not (np.isfinite(self.frame_time) and self.frame_time > 0):
            raise SkeletonError(f"frame_time must be a positive number of seconds, got {self.frame_time}")
        self.frame_time = float(self.frame_time)

    # -- sizes and time ----------------------------------------------------------------------
    @property
    def n_frames(self) -> int:
        return int(self.local_positions.shape[0])

    @property
    def fps(self) -> float:
        return 1.0 / self.frame_time

    @property
    def duration(self) -> float:
        """Seconds from the first to the last frame: ``(F - 1) * frame_time``."""
        return (self.n_frames - 1) * self.frame_time

    @property
    def times(self) -> np.ndarray:
        """``(F,)`` time of each frame in seconds."""
        return np.arange(self.n_frames) * self.frame_time

    @property
    def root_positions(self) -> np.ndarray:
        """``(F, 3)`` root translation per frame."""
        return self.local_positions[:, 0]

    def copy(self) -> Motion:
        return Motion(self.skeleton.copy(), self.frame_time, self.local_positions.copy(),
                      self.rotations.copy())

    def __getitem__(self, frames: slice | np.ndarray | list[int]) -> Motion:
        """A new Motion with the selected frames (a slice or an index array)."""
        if isinstance(frames, (int, np.integer)):
            frames = [int(frames)]
        return Motion(self.skeleton, self.frame_time, self.local_positions[frames],
                      self.rotations[frames])

    @classmethod
    def rest(cls, skeleton: Skeleton, n_frames: int = 1, frame_time: float = 1 / 30) -> Motion:
        """``n_frames`` frames of the rest pose (offsets, identity rotations)."""
        pos = np.broadcast_to(skeleton.offsets, (n_frames, skeleton.n_joints, 3)).copy()
        return cls(skeleton, frame_time, pos, quat_identity((n_frames, skeleton.n_joints)))

    # -- BVH channel encoding ------------------------------------------------------------------
    @classmethod
    def from_channels(cls, skeleton: Skeleton, frame_time: float, values: np.ndarray) -> Motion:
        """Decode a ``(F, C)`` array of BVH channel values (degrees for rotations).

        Rotation channels listed as ``A B C`` mean ``R = R_A R_B R_C`` (intrinsic order).
        """
        values = np.asarray(values, dtype=float)
        n_f = values.shape[0]
        if values.ndim != 2 or values.shape[1] != skeleton.n_channels:
            raise SkeletonError(f"expected (F, {skeleton.n_channels}) channel values, got {values.shape}")
        pos = np.broadcast_to(skeleton.offsets, (n_f, skeleton.n_joints, 3)).copy()
        rot = quat_identity((n_f, skeleton.n_joints))
        for j, (chans, start) in enumerate(zip(skeleton.channels, skeleton.channel_starts(), strict=True)):
            rot_cols = []
            for k, c in enumerate(chans):
                if c in POSITION_CHANNELS:
                    pos[:, j, POSITION_CHANNELS.index(c)] = values[:, start + k]
                else:
                    rot_cols.append(start + k)
            if rot_cols and n_f:
                order = skeleton.rotation_order(j)
                r = Rotation.from_euler(order, values[:, rot_cols], degrees=True)
                rot[:, j] = from_rotation(r)
        return cls(skeleton, frame_time, pos, quat_fix_continuity(rot, axis=0))

    def to_channels(self) -> np.ndarray:
        """Encode as a ``(F, C)`` array of BVH channel values (degrees), continuous over frames.

        Euler angles are chosen frame by frame as the solution nearest the previous frame (both
        Euler branches and multiples of 360 degrees are considered), starting from the principal
        solution, so curves do not jump at +-180 degrees or at gimbal crossings.
        A joint with fewer than three rotation channels can only express rotations about those
        axes; the other components are dropped.
        """
        sk = self.skeleton
        out = np.zeros((self.n_frames, sk.n_channels))
        for j, (chans, start) in enumerate(zip(sk.channels, sk.channel_starts(), strict=True)):
            rot_idx = [k for k, c in enumerate(chans) if c in ROTATION_CHANNELS]
            for k, c in enumerate(chans):
                if c in POSITION_CHANNELS:
                    out[:, start + k] = self.local_positions[:, j, POSITION_CHANNELS.index(c)]
            if rot_idx and self.n_frames:
                order = sk.rotation_order(j)
                q = quat_normalize(self.rotations[:, j])
                out[:, [start + k for k in rot_idx]] = _continuous_euler(q, order)
        return out


def _continuous_euler(q: np.ndarray, order: str) -> np.ndarray:
    """``(F, n)`` intrinsic Euler angles in degrees for ``(F, 4)`` quaternions, continuous in F."""
    r = to_rotation(q)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # gimbal-lock warnings: the angles are still valid
        if len(order) < 3:
            # one or two axes: the angles that express r about those axes (exact when possible)
            full = order + "".join(a for a in "XYZ" if a not in order)
            a = r.as_euler(full, degrees=True)[:, : len(order)]
            return np.rad2deg(np.unwrap(np.deg2rad(a), axis=0))
        a = r.as_euler(order, degrees=True)
    unwrapped = np.rad2deg(np.unwrap(np.deg2rad(a), axis=0))
    if len(a) < 2 or np.max(np.abs(np.diff(unwrapped, axis=0))) < 90.0:
        return unwrapped  # the common case: no branch switch needed
    # the other Euler branch: (a + 180, 180 - b, c + 180) for Tait-Bryan orders,
    # (a + 180, -b, c + 180) for proper Euler orders (e.g. ZXZ)
    b = np.stack([a[:, 0] + 180.0, 180.0 - a[:, 1], a[:, 2] + 180.0], axis=1)
    if order[0] == order[2]:
        b[:, 1] = -a[:, 1]
    out = np.empty_like(a)
    prev = a[0]
    for f in range(len(a)):  # greedy: branch and 360-degree shift nearest the previous frame
        cands = np.stack([a[f], b[f]])
        cands = cands + 360.0 * np.round((prev - cands) / 360.0)
        prev = out[f] = cands[np.argmin(np.sum((cands - prev) ** 2, axis=1))]
    return out
