"""Rigs and roles: what a skeleton is, whatever its file calls it.

- :mod:`~mjchar.bvh.rigs.units`: units and up axis, detected from the skeleton, and conversion.
- :mod:`~mjchar.bvh.rigs.naming`: joint roles (pelvis, left knee, a finger...) from names and
  shape.
- :mod:`~mjchar.bvh.rigs.layouts`: exact re-expressions of a rig (new rest orientations, a
  folded static root, bones along local axes).
"""
