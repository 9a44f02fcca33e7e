"""mjchar's kinematic layer (``mjchar.bvh``): BVH files, skeletons and motions, no simulation.

Public API (stable)::

    from mjchar import bvh

    motion = bvh.load("walk.bvh")            # -> Motion
    motion.skeleton.names                    # joints in file order (end sites apart)
    motion.frame_time                        # seconds per frame
    fk = bvh.forward_kinematics(motion)      # fk.positions (F, J, 3), fk.orientations (F, J, 4)
    bvh.save(motion, "out.bvh")

Subpackages, by concern (each imports only from those listed before it):

- :mod:`~mjchar.bvh.io`: file I/O and skeletons (reader, writer, :class:`Skeleton`,
  :class:`Motion`).
- :mod:`~mjchar.bvh.kinematics`: forward kinematics, a model's qpos algebra,
  inverse kinematics (:mod:`~mjchar.bvh.kinematics.ik`).
- :mod:`~mjchar.bvh.rigs`: rigs and roles: units and up axis, joint roles from names and shape,
  exact re-expressions of a rig.
- :mod:`~mjchar.bvh.editing`: editing and interpolation (mirror, retarget, concatenate, splines,
  resampling).
- :mod:`~mjchar.bvh.mjcf`: the BVH -> MJCF converter.
- :mod:`~mjchar.bvh.reference`: reference motions (a clip in a converted model's coordinates,
  the joint map, foot points, hinge projection) and export back to BVH.
- :mod:`~mjchar.bvh.gait`: gait analysis of simulated runs and clips.
- :mod:`~mjchar.bvh.bundled`: the project's own material: the bundled humanoid's skeleton and
  motions, where the bundled files are, and the rig zoo made from known clips.

:mod:`~mjchar.bvh.errors` and :mod:`~mjchar.bvh.rotations` sit at the top level, under every
subpackage: the project's exceptions (shared by every layer) and the quaternion helpers every
concern uses.
Quaternions are (w, x, y, z). Malformed input raises :class:`BVHError` with the line.
"""

from mjchar.bvh import editing, io, kinematics, rigs, rotations  # noqa: F401  (as attributes)
from mjchar.bvh.errors import BVHError, MjcharError, SkeletonError
from mjchar.bvh.io import Motion, Skeleton, dumps, load, loads, read_channels, save
from mjchar.bvh.kinematics import FKResult, end_site_positions, forward_kinematics

__all__ = [
    "BVHError", "MjcharError", "SkeletonError", "Skeleton", "Motion", "FKResult",
    "load", "loads", "save", "dumps", "read_channels", "forward_kinematics", "end_site_positions",
    "editing", "io", "kinematics", "rigs", "rotations",
]
