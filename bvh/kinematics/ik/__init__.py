"""Inverse kinematics on one skeleton pose or every frame of a motion.

- :mod:`~mjchar.bvh.kinematics.ik.solve`: the entry points (:func:`solve`, :func:`solve_frames`).
- :mod:`~mjchar.bvh.kinematics.ik.pose`: one pose and its forward kinematics over joints.
- :mod:`~mjchar.bvh.kinematics.ik.problem`: the problem every solver shares.
- :mod:`~mjchar.bvh.kinematics.ik.solvers`: the three update rules.
"""

from mjchar.bvh.kinematics.ik.solve import (
    METHODS,
    Effector,
    FramesResult,
    IKError,
    IKProblem,
    IKResult,
    IKState,
    Pose,
    solve,
    solve_ccd,
    solve_dls,
    solve_frames,
    solve_jacobian_transpose,
)

__all__ = [
    "IKError", "Pose", "Effector", "IKProblem", "IKState", "IKResult", "FramesResult",
    "solve", "solve_ccd", "solve_jacobian_transpose", "solve_dls", "solve_frames", "METHODS",
]
