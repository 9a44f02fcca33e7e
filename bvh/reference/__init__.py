"""Reference motions: a BVH clip in a converted model's coordinates, and back.

- :mod:`~mjchar.bvh.reference.reference_motion`: :class:`ReferenceMotion` (qpos, qvel and body
  positions at any time, cyclic clips looped).
- :mod:`~mjchar.bvh.reference.joint_map`: which model body and joints carry each BVH joint.
- :mod:`~mjchar.bvh.reference.foot_points`: where a reference motion looks for its feet.
- :mod:`~mjchar.bvh.reference.projection`: clip rotations on models with fewer dofs (hinges).
- :mod:`~mjchar.bvh.reference.export`: a simulated motion as BVH on the source skeleton.
"""

from mjchar.bvh.reference.reference_motion import (
    FLOOR_MODES,
    ReferenceMotion,
    ReferenceMotionError,
    replay_errors,
)

__all__ = ["FLOOR_MODES", "ReferenceMotion", "ReferenceMotionError", "replay_errors"]
