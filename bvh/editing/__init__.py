"""Editing and interpolation of motions.

- :mod:`~mjchar.bvh.editing.clips`: mirror, retarget between rest poses, align, concatenate,
  cyclic cuts.
- :mod:`~mjchar.bvh.editing.interpolation`: position and quaternion splines, keyframes,
  resampling.
"""

from mjchar.bvh.editing import clips, interpolation  # noqa: F401  (modules as attributes)

__all__ = ["clips", "interpolation"]
