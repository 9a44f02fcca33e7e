"""Quaternion helpers that scipy's ``Rotation`` does not provide.

Conventions: quaternions are ``(w, x, y, z)`` arrays with the scalar first, as MuJoCo uses them.
Convert to and from scipy explicitly with :func:`to_rotation` / :func:`from_rotation`.
All functions broadcast over leading dimensions: ``q`` has shape ``(..., 4)``.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

AXES = {"x": 0, "y": 1, "z": 2}


def to_rotation(q: np.ndarray) -> Rotation:
    """scipy ``Rotation`` from ``(..., 4)`` wxyz quaternions (flattened to ``(N,)`` rotations)."""
    q = np.asarray(q, dtype=float)
    return Rotation.from_quat(q.reshape(-1, 4), scalar_first=True)


def from_rotation(r: Rotation, shape: tuple[int, ...] | None = None) -> np.ndarray:
    """wxyz quaternions ``(..., 4)`` from a scipy ``Rotation``; ``shape`` is the leading shape."""
    q = r.as_quat(scalar_first=True)
    return q.reshape((*shape, 4)) if shape is not None else q


def quat_identity(shape: tuple[int, ...] = ()) -> np.ndarray:
    """Identity quaternions of leading shape ``shape``: ``(*shape, 4)``."""
    q = np.zeros((*shape, 4))
    q[..., 0] = 1.0
    return q


def quat_normalize(q: np.ndarray) -> np.ndarray:
    """Unit quaternions ``(..., 4)``."""
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def quat_conj(q: np.ndarray) -> np.ndarray:
    """Conjugate (the inverse of a unit quaternion), ``(..., 4)``."""
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product ``a * b`` (rotation ``b`` first, then ``a``), broadcasting ``(..., 4)``."""
    aw, ax, ay, az = np.moveaxis(np.asarray(a, dtype=float), -1, 0)
    bw, bx, by, bz = np.moveaxis(np.asarray(b, dtype=float), -1, 0)
    return np.stack(
        [
            aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
        ],
        axis=-1,
    )


def quat_rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate vectors ``v`` ``(..., 3)`` by unit quaternions ``q`` ``(..., 4)``."""
    q = np.asarray(q, dtype=float)
    v = np.asarray(v, dtype=float)
    w = q[..., :1]
    u = q[..., 1:]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def quat_fix_continuity(q: np.ndarray, axis: int = 0) -> np.ndarray:
    """Flip quaternion signs along ``axis`` (frames) so consecutive ones have a non-negative dot.

    ``q`` and ``-q`` are the same rotation; interpolation and finite differences need the sign
    that keeps the curve continuous. Returns a new array of the same shape ``(..., 4)``.
    """
    q = np.moveaxis(np.asarray(q, dtype=float), axis, 0).copy()
    if len(q) > 1:
        dots = np.sum(q[1:] * q[:-1], axis=-1)
        flips = np.cumsum(dots < 0, axis=0) % 2  # flip parity accumulated along the frames
        q[1:] *= np.where(flips[..., None] == 1, -1.0, 1.0)
    return np.moveaxis(q, 0, axis)


def quat_slerp(q0: np.ndarray, q1: np.ndarray, t: np.ndarray | float) -> np.ndarray:
    """Spherical linear interpolation, element-wise over broadcast ``(..., 4)`` inputs.

    ``t`` broadcasts against the leading dimensions (``(...)``); takes the short path.
    Returns unit quaternions ``(..., 4)``.
    """
    q0 = quat_normalize(np.asarray(q0, dtype=float))
    q1 = quat_normalize(np.asarray(q1, dtype=float))
    t = np.asarray(t, dtype=float)[..., None]
    dot = np.sum(q0 * q1, axis=-1, keepdims=True)
    q1 = np.where(dot < 0, -q1, q1)
    dot = np.abs(dot)
    theta = np.arccos(np.clip(dot, -1.0, 1.0))
    sin_theta = np.sin(theta)
    small = sin_theta < 1e-8
    safe = np.where(small, 1.0, sin_theta)
    w0 = np.where(small, 1.0 - t, np.sin((1.0 - t) * theta) / safe)
    w1 = np.where(small, t, np.sin(t * theta) / safe)
    return quat_normalize(w0 * q0 + w1 * q1)


def quat_to_rotvec(q: np.ndarray) -> np.ndarray:
    """Rotation vectors ``(..., 3)`` (axis * angle, radians, angle in [0, pi]) of ``q`` ``(..., 4)``."""
    q = np.asarray(q, dtype=float)
    q = np.where(q[..., :1] < 0, -q, q)
    v = q[..., 1:]
    s = np.linalg.norm(v, axis=-1, keepdims=True)
    angle = 2.0 * np.arctan2(s, q[..., :1])
    scale = np.where(s > 1e-12, angle / np.where(s > 1e-12, s, 1.0), 2.0)
    return v * scale


def quat_from_rotvec(r: np.ndarray) -> np.ndarray:
    """Unit quaternions ``(..., 4)`` from rotation vectors ``(..., 3)`` (radians)."""
    r = np.asarray(r, dtype=float)
    angle = np.linalg.norm(r, axis=-1, keepdims=True)
    half = 0.5 * angle
    k = np.where(angle > 1e-12, np.sin(half) / np.where(angle > 1e-12, angle, 1.0), 0.5)
    return np.concatenate([np.cos(half), r * k], axis=-1)


def decompose_facing(q: np.ndarray, up: str = "y") -> tuple[np.ndarray, np.ndarray]:
    """Split rotations into a heading part about ``up`` and the rest: ``R = R_up * R_tilt``.

    The heading ``R_up`` is the rotation about the up axis (``"x"``, ``"y"`` or ``"z"``) that
    brings the projection of the rotated forward axis onto the ground plane to where it points;
    ``R_tilt`` (``R_xz`` for Y-up) is what remains. This is the swing-twist decomposition with
    twist about the up axis. ``q``: ``(..., 4)`` wxyz. Returns ``(q_heading, q_tilt)``, both
    ``(..., 4)``, with ``quat_mul(q_heading, q_tilt) == q``.
    """
    q = quat_normalize(np.asarray(q, dtype=float))
    i = AXES[up]
    twist = np.zeros_like(q)
    twist[..., 0] = q[..., 0]
    twist[..., 1 + i] = q[..., 1 + i]
    norm = np.linalg.norm(twist, axis=-1, keepdims=True)
    # a 180 degree tilt has no defined heading: pick identity
    twist = np.where(norm > 1e-9, twist / np.where(norm > 1e-9, norm, 1.0), quat_identity(q.shape[:-1]))
    tilt = quat_mul(quat_conj(twist), q)
    return twist, tilt


def heading_angle(q: np.ndarray, up: str = "y") -> np.ndarray:
    """Heading angle (radians) about ``up`` of rotations ``q`` ``(..., 4)``; shape ``(...)``."""
    twist, _ = decompose_facing(q, up)
    i = AXES[up]
    return 2.0 * np.arctan2(twist[..., 1 + i], twist[..., 0])
