"""The :class:`Skeleton`: joint hierarchy, rest offsets, BVH channel layout and end sites."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from mjchar.bvh.errors import SkeletonError, name_list

POSITION_CHANNELS = ("Xposition", "Yposition", "Zposition")
ROTATION_CHANNELS = ("Xrotation", "Yrotation", "Zrotation")
VALID_CHANNELS = POSITION_CHANNELS + ROTATION_CHANNELS
_VALID_SET = frozenset(VALID_CHANNELS)


@dataclass
class Skeleton:
    """A joint hierarchy in file order (parents always precede children).

    Attributes:
        names: joint names, ``(J,)``, in file order; end sites are kept apart.
        parents: parent index per joint, ``(J,)`` int, ``-1`` for the root.
        offsets: rest offset of each joint from its parent, ``(J, 3)``, in file units.
        channels: per joint, the tuple of its BVH channel names in file order, e.g.
            ``("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation")``.
        end_site_parents: joint index each end site hangs from, ``(E,)`` int.
        end_site_offsets: end site offsets from their joint, ``(E, 3)``.
        end_site_names: a name per end site (``"<parent>_end"`` unless given).
    """

    names: list[str]
    parents: np.ndarray
    offsets: np.ndarray
    channels: list[tuple[str, ...]]
    end_site_parents: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))
    end_site_offsets: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    end_site_names: list[str] | None = None

    def __post_init__(self) -> None:
        self.names = list(self.names)
        self.parents = np.asarray(self.parents, dtype=int).reshape(-1)
        self.offsets = np.asarray(self.offsets, dtype=float).reshape(-1, 3)
        self.channels = [tuple(c) for c in self.channels]
        self.end_site_parents = np.asarray(self.end_site_parents, dtype=int).reshape(-1)
        self.end_site_offsets = np.asarray(self.end_site_offsets, dtype=float).reshape(-1, 3)
        if self.end_site_names is None:
            self.end_site_names = [f"{self.names[p]}_end" for p in self.end_site_parents]
        n = len(self.names)
        if not (len(self.parents) == len(self.offsets) == len(self.channels) == n):
            raise SkeletonError(
                f"skeleton arrays disagree: {n} names, {len(self.parents)} parents, "
                f"{len(self.offsets)} offsets, {len(self.channels)} channel lists"
            )
        if len(set(self.names)) != n:
            dup = sorted({x for x in self.names if self.names.count(x) > 1})
            raise SkeletonError(f"duplicate joint names: {dup}")
        if n and (self.parents[0] != -1 or np.any(self.parents[1:] < 0)
                  or np.any(self.parents[1:] >= np.arange(1, n))):
            raise SkeletonError("joints must be in topological order with a single root at index 0")
        for name, chans in zip(self.names, self.channels, strict=True):
            if not _VALID_SET.issuperset(chans) or len(set(chans)) != len(chans):
                raise SkeletonError(f"joint {name!r}: invalid channels {chans}")

    # -- structure -------------------------------------------------------------------------
    @property
    def n_joints(self) -> int:
        return len(self.names)

    @property
    def n_end_sites(self) -> int:
        return len(self.end_site_parents)

    @property
    def n_channels(self) -> int:
        """Total number of channels per frame."""
        return sum(len(c) for c in self.channels)

    def index(self, name: str) -> int:
        """Index of joint ``name``; raises :class:`SkeletonError` naming close matches."""
        try:
            return self.names.index(name)
        except ValueError:
            raise SkeletonError(
                f"unknown joint {name!r}; joints are: {name_list(self.names)}"
            ) from None

    def children(self, j: int) -> list[int]:
        """Indices of the direct children of joint ``j``."""
        return [int(c) for c in np.flatnonzero(self.parents == j)]

    def chain(self, j: int) -> list[int]:
        """Joint indices from the root down to ``j`` (inclusive)."""
        out = []
        while j >= 0:
            out.append(int(j))
            j = int(self.parents[j])
        return out[::-1]

    def in_subtree(self, j: int) -> np.ndarray:
        """``(J,)`` bool: joint ``j`` and every joint below it (one pass over the parents)."""
        inside = np.zeros(self.n_joints, dtype=bool)
        inside[j] = True
        parents = self.parents.tolist()
        for k in range(j + 1, self.n_joints):
            inside[k] = inside[parents[k]]
        return inside

    def has_position_channels(self) -> np.ndarray:
        """``(J,)`` bool: which joints carry position channels."""
        return np.array([any(c in POSITION_CHANNELS for c in ch) for ch in self.channels])

    def channel_starts(self) -> np.ndarray:
        """``(J,)`` column index of each joint's first channel in a frame row."""
        lengths = np.array([len(c) for c in self.channels], dtype=int)
        return np.concatenate([[0], np.cumsum(lengths)[:-1]]).astype(int)

    def rotation_order(self, j: int) -> str:
        """Intrinsic Euler order of joint ``j``'s rotation channels, e.g. ``"ZXY"`` ('' if none)."""
        return "".join(c[0] for c in self.channels[j] if c in ROTATION_CHANNELS)

    # -- geometry --------------------------------------------------------------------------
    def rest_positions(self) -> np.ndarray:
        """Global joint positions ``(J, 3)`` of the rest pose (all rotations identity)."""
        pos = np.zeros((self.n_joints, 3))
        for j in range(self.n_joints):
            p = self.parents[j]
            pos[j] = self.offsets[j] + (pos[p] if p >= 0 else 0.0)
        return pos

    def rest_end_sites(self) -> np.ndarray:
        """Global end site positions ``(E, 3)`` of the rest pose."""
        return self.rest_positions()[self.end_site_parents] + self.end_site_offsets

    def bone_lengths(self) -> np.ndarray:
        """``(J,)`` length of the offset from each joint's parent (0 for the root)."""
        lengths = np.linalg.norm(self.offsets, axis=1)
        lengths[0] = 0.0
        return lengths

    def copy(self) -> Skeleton:
        return Skeleton(
            list(self.names), self.parents.copy(), self.offsets.copy(), list(self.channels),
            self.end_site_parents.copy(), self.end_site_offsets.copy(), list(self.end_site_names),
        )
