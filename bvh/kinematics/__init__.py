"""Kinematics and IK: forward kinematics over frames, a MuJoCo model's qpos
algebra, and inverse kinematics.

- :mod:`~mjchar.bvh.kinematics.fk`: :func:`forward_kinematics`, :func:`end_site_positions`.
- :mod:`~mjchar.bvh.rotations`: quaternion helpers scipy's ``Rotation`` lacks.
- :mod:`~mjchar.bvh.kinematics.qpos_algebra`: vectorised ``mj_differentiatePos`` /
  ``mj_integratePos`` of one model.
- :mod:`~mjchar.bvh.kinematics.ik`: CCD, Jacobian transpose and damped least squares.
"""

from mjchar.bvh.kinematics import ik  # noqa: F401  (a subpackage as an attribute)
from mjchar.bvh.kinematics.fk import FKResult, end_site_positions, forward_kinematics

__all__ = ["FKResult", "end_site_positions", "forward_kinematics", "ik"]
