"""World-frame helpers of the walking controllers: elementary rotations, the rotation vector of
a rotation matrix, the shortest arc between two directions and the world torque of a set of
hinges (the Jacobian transpose read backwards). Vectors are ``(3,)`` numpy arrays in the world
frame, angles in rad."""

from __future__ import annotations

import math

import mujoco
import numpy as np


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


def cross3(a: list[float], b: list[float]) -> list[float]:
    """Cross product of two 3-vectors given as Python floats (the same IEEE operations as
    numpy's element-wise ones, without numpy's per-element overhead)."""
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``(3,)`` cross product of two ``(3,)`` vectors (:func:`cross3`'s operations)."""
    return np.array(cross3(a.tolist(), b.tolist()))


def cross_rows(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``np.cross(a, b)`` of ``(k, 3)`` rows and one ``(3,)`` vector, the same element-wise
    operations (``np.cross`` costs ~10x more at this size)."""
    out = np.empty_like(a)
    b0, b1, b2 = b.tolist()
    out[:, 0] = a[:, 1] * b2 - a[:, 2] * b1
    out[:, 1] = a[:, 2] * b0 - a[:, 0] * b2
    out[:, 2] = a[:, 0] * b1 - a[:, 1] * b0
    return out


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
