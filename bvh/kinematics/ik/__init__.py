"""Inverse kinematics on one skeleton pose or every frame of a motion.

- :mod:`~mjchar.bvh.kinematics.ik.solve`: the entry points (:func:`solve`, :func:`solve_frames`).
- :mod:`~mjchar.bvh.kinematics.ik.pose`: one pose and its forward kinematics over joints.
- :mod:`~mjchar.bvh.kinematics.ik.problem`: the problem every solver shares.
- :mod:`~mjchar.bvh.kinematics.ik.solvers`: the three update rules.
"""

# the public names are those of ``solve``'s ``__all__`` (one list, kept there)
from mjchar.bvh.kinematics.ik.solve import *  # noqa: F403
from mjchar.bvh.kinematics.ik.solve import __all__  # noqa: F401
