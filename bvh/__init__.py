"""mjchar's kinematic core: BVH I/O, skeletons and motions, kinematics, interpolation, editing.

Public API (stable)::

    motion = bvh.load("walk.bvh")            # -> Motion
    motion.skeleton.names                    # joints in file order (end sites apart)
    motion.frame_time                        # seconds per frame
    fk = bvh.forward_kinematics(motion)      # fk.positions (F, J, 3), fk.orientations (F, J, 4)
    bvh.save(motion, "out.bvh")

Submodules: ``bvh.units`` (units and up axis), ``bvh.rotations`` (quaternion helpers),
``bvh.interpolation`` (resampling, splines, keyframes), ``bvh.editing`` (retarget, mirror,
concatenate), ``bvh.ik`` (CCD, Jacobian transpose, damped least squares), ``bvh.mjcf`` (BVH ->
MJCF), ``bvh.reference`` (motions in a converted model's coordinates).

Quaternions are (w, x, y, z). Malformed input raises :class:`bvh.BVHError` with the line.
"""

from . import editing, ik, interpolation, rotations, units  # noqa: F401  (submodules as attributes)
from .errors import BVHError, MjcharError, SkeletonError
from .io import dumps, load, loads, read_channels, save
from .kinematics import FKResult, end_site_positions, forward_kinematics
from .motion import Motion
from .skeleton import Skeleton

__all__ = [
    "BVHError", "MjcharError", "SkeletonError", "Skeleton", "Motion", "FKResult",
    "load", "loads", "save", "dumps", "read_channels", "forward_kinematics", "end_site_positions",
    "editing", "ik", "interpolation", "rotations", "units",
]
