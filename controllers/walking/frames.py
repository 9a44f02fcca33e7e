"""World-frame helpers of the walking controllers: elementary rotations, the rotation vector of
a rotation matrix, the shortest arc between two directions and the world torque of a set of
hinges (the Jacobian transpose read backwards). Vectors are ``(3,)`` numpy arrays in the world
frame, angles in rad."""

from __future__ import annotations

import math

import mujoco
import numpy as np

from ..core.geometry import cross, cross3


def rot_x(a: float) -> np.ndarray:
    """``(3, 3)`` rotation by ``a`` rad about the x axis."""
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def rot_y(a: float) -> np.ndarray:
    """``(3, 3)`` rotation by ``a`` rad about the y axis."""
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def rot_z(a: float) -> np.ndarray:
    """``(3, 3)`` rotation by ``a`` rad about the z axis."""
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def log(R: np.ndarray) -> np.ndarray:
    """``(3,)`` rotation vector (rad) of a rotation matrix ``(3, 3)``."""
    q = np.empty(4)
    mujoco.mju_mat2Quat(q, R.reshape(9))
    if q[0] < 0:
        q = -q
    v = np.empty(3)
    mujoco.mju_quat2Vel(v, q, 1.0)
    return v


def angle_between(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``(3,)`` rotation vector turning unit vector ``u`` onto unit vector ``v`` (shortest arc)."""
    ax = cross(u, v)
    s = math.sqrt(ax @ ax)
    if s < 1e-12:
        return np.zeros(3)
    return ax * (math.atan2(s, float(u @ v)) / s)


def world_torque(axes: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """``(3,)`` world torque that hinges with world ``axes`` ``(k, 3)`` apply to their child body
    when their generalised forces are ``tau`` ``(k,)`` (``axes @ T = tau``; least squares for
    fewer than three hinges)."""
    if len(tau) == 3:  # Cramer's rule: T = sum_i tau_i (a_j x a_k) / det
        a1, a2, a3 = axes.tolist()
        c23, c31, c12 = cross3(a2, a3), cross3(a3, a1), cross3(a1, a2)
        det = float(axes[0] @ np.array(c23))
        if abs(det) > 1e-9:
            t0, t1, t2 = tau.tolist()
            return np.array([(t0 * c23[k] + t1 * c31[k] + t2 * c12[k]) / det for k in range(3)])
    return np.linalg.lstsq(axes, tau, rcond=None)[0]
