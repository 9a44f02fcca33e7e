"""File I/O and skeletons: the BVH reader and writer, :class:`Skeleton` and :class:`Motion`.

- :mod:`~mjchar.bvh.io.skeleton`: joint hierarchy, rest offsets, channel layout, end sites.
- :mod:`~mjchar.bvh.io.motion`: a skeleton animated over frames, and its channel encoding.
- :mod:`~mjchar.bvh.io.reader`: :func:`load`, :func:`loads`, :func:`read_channels`.
- :mod:`~mjchar.bvh.io.writer`: :func:`save`, :func:`dumps`.
"""

from mjchar.bvh.io.motion import Motion
from mjchar.bvh.io.reader import load, loads, read_channels
from mjchar.bvh.io.skeleton import Skeleton
from mjchar.bvh.io.writer import dumps, save

__all__ = ["Motion", "Skeleton", "load", "loads", "read_channels", "save", "dumps"]
