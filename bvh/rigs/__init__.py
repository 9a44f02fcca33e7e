"""Rigs and roles: what a skeleton is, whatever its file calls it.

- :mod:`~mjchar.bvh.rigs.units`: units and up axis, detected from the skeleton, and conversion.
- :mod:`~mjchar.bvh.rigs.words`: the words of a joint name (namespace, side, body part).
- :mod:`~mjchar.bvh.rigs.structure`: limbs, sides and the head from the skeleton's geometry and
  the clip's motion, where names fail.
- :mod:`~mjchar.bvh.rigs.naming`: joint roles (pelvis, left knee, a finger...) from names, and
  from the geometry where they fail.
- :mod:`~mjchar.bvh.rigs.canonical`: the canonical rest (standing, legs straight, arms in a
  T-pose) built from a skeleton and its roles.
- :mod:`~mjchar.bvh.rigs.layouts`: exact re-expressions of a rig (new rest orientations, a
  folded static root, bones along local axes).
"""
