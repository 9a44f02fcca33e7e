"""Quaternion helpers that scipy's ``Rotation`` does not provide.

Conventions: quaternions are ``(w, x, y, z)`` arrays with the scalar first, as MuJoCo uses them.
Convert to and from scipy explicitly with :func:`to_rotation` / :func:`from_rotation`.
All functions broadcast over leading dimensions: ``q`` has shape ``(..., 4)``.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from mjchar.bvh.errors import SkeletonError

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


def quat_from_euler(angles: np.ndarray, order: str, degrees: bool = True) -> np.ndarray:
    """Unit wxyz quaternions ``(..., 4)`` of intrinsic Euler angles ``(..., len(order))``.

    ``order`` is a string of 1-3 axis letters (``"ZXY"``, ``"XY"``, ``"zyx"``...), read as the
    product ``R_order[0] R_order[1] ...`` (intrinsic rotations, the BVH convention); ``degrees``
    says the unit of ``angles``. An empty ``order`` gives identities. Equivalent to scipy's
    ``Rotation.from_euler(order.upper(), ...)`` but vectorised over any leading shape.
    """
    angles = np.asarray(angles, dtype=float)
    if angles.shape[-1:] != (len(order),):
        raise SkeletonError(
            f"expected angles (..., {len(order)}) for order {order!r}, got {angles.shape}")
    shape = angles.shape[:-1]
    if not order:
        return quat_identity(shape)
    # cos and sin of the half angles from t = tan(angle / 4) (numpy's vectorised tan is several
    # times faster than its sin and cos here; exact to an ulp or two, also at +-180 degrees)
    t = np.moveaxis(angles, -1, 0) * (np.pi / 720.0 if degrees else 0.25)
    np.tan(t, out=t)
    one_plus_t2 = t * t
    c = np.subtract(1.0, one_plus_t2)
    one_plus_t2 += 1.0
    c /= one_plus_t2  # cos(half) = (1 - t^2) / (1 + t^2)
    t *= 2.0
    t /= one_plus_t2
    s = t  # sin(half) = 2 t / (1 + t^2)
    # components as arrays, None meaning exactly zero (saves work on the first products)
    k0 = AXES[order[0].lower()]
    w: np.ndarray = c[0]
    v: list[np.ndarray | None] = [None, None, None]
    v[k0] = s[0]
    for n in range(1, len(order)):
        k = AXES[order[n].lower()]
        i, j = (k + 1) % 3, (k + 2) % 3
        ck, sk = c[n], s[n]
        # (w, v) * (ck, sk e_k) = (w ck - sk v_k, w sk e_k + ck v + sk v x e_k)
        vk, vi, vj = v[k], v[i], v[j]
        w, v[k] = ((w * ck if vk is None else w * ck - vk * sk),
                   (w * sk if vk is None else vk * ck + w * sk))
        v[i] = _lin(vi, ck, vj, sk)
        v[j] = _lin(vj, ck, vi, -sk)
    zero = np.zeros(shape)
    return np.stack([w, *(zero if x is None else x for x in v)], axis=-1)


def quat_to_euler(q: np.ndarray, order: str, degrees: bool = True) -> np.ndarray:
    """Intrinsic Euler angles ``(..., 3)`` of unit wxyz quaternions ``(..., 4)``.

    ``order`` is three axis letters, Tait-Bryan (``"ZXY"``) or proper Euler (``"ZXZ"``), read
    as ``R = R_order[0] R_order[1] R_order[2]`` (the inverse of :func:`quat_from_euler`).
    Principal ranges: outer angles in [-180, 180], the middle one in [-90, 90] (Tait-Bryan) or
    [0, 180] (proper). Uses the direct quaternion formulas of Bernardes & Viollet (2022)
    without a gimbal-lock threshold, so rotations within 1e-9 degrees of gimbal lock still
    come back to machine precision (scipy's ``as_euler`` snaps those to exact lock, losing
    ~1e-9 rad); at exact lock the free angle is split evenly.
    """
    q = np.asarray(q, dtype=float)
    if len(order) != 3 or order[1].lower() in (order[0].lower(), order[2].lower()):
        raise SkeletonError(f"expected an Euler order of 3 axes like 'ZXY' or 'ZXZ', got {order!r}")
    # intrinsic ABC is extrinsic CBA with the angles reversed
    i, j, k = (AXES[a] for a in order.lower()[::-1])
    proper = i == k
    if proper:
        k = 3 - i - j
    sign = (i - j) * (j - k) * (k - i) // 2
    w, v = q[..., 0], [q[..., 1], q[..., 2], q[..., 3]]
    if proper:
        a, b, c, d = w, v[i], v[j], v[k] * sign
    else:
        a, b, c, d = w - v[j], v[i] + v[k] * sign, v[j] + w, v[k] * sign - v[i]
    middle = 2.0 * np.arctan2(np.hypot(c, d), np.hypot(a, b))
    half_sum, half_diff = np.arctan2(b, a), np.arctan2(d, c)
    first, third = half_sum - half_diff, half_sum + half_diff  # extrinsic 1st and 3rd
    if not proper:
        third = third * sign
        middle = middle - np.pi / 2
    out = np.stack([third, middle, first], axis=-1)  # back to the intrinsic order
    out = (out + np.pi) % (2 * np.pi) - np.pi
    return np.rad2deg(out) if degrees else out


def _lin(a: np.ndarray | None, ca: np.ndarray, b: np.ndarray | None,
         cb: np.ndarray) -> np.ndarray | None:
    """``a * ca + b * cb`` with ``None`` standing for zero."""
    if a is None:
        return None if b is None else b * cb
    return a * ca if b is None else a * ca + b * cb


def quat_fix_continuity(q: np.ndarray, axis: int = 0) -> np.ndarray:
    """Flip quaternion signs along ``axis`` (frames) so consecutive ones have a non-negative dot.

    ``q`` and ``-q`` are the same rotation; interpolation and finite differences need the sign
    that keeps the curve continuous. Returns a new array of the same shape ``(..., 4)``.
    """
    q = np.moveaxis(np.array(q, dtype=float), axis, 0)  # a copy
    _fix_continuity_inplace(q)
    return np.moveaxis(q, 0, axis)


def _fix_continuity_inplace(q: np.ndarray) -> None:
    """:func:`quat_fix_continuity` along axis 0, modifying the float array ``q`` in place."""
    if len(q) > 1:
        flip = np.einsum("...i,...i->...", q[1:], q[:-1]) < 0
        if flip.any():
            np.logical_xor.accumulate(flip, axis=0, out=flip)  # flip parity along the frames
            q[1:][flip] *= -1.0


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
    """Rotation vectors ``(..., 3)`` (axis * angle, radians, angle in [0, pi]) of ``q``
    ``(..., 4)``."""
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
    i = _axis_index(up)
    twist = np.zeros_like(q)
    twist[..., 0] = q[..., 0]
    twist[..., 1 + i] = q[..., 1 + i]
    norm = np.linalg.norm(twist, axis=-1, keepdims=True)
    # a 180 degree tilt has no defined heading: pick identity
    twist = np.where(norm > 1e-9, twist / np.where(norm > 1e-9, norm, 1.0),
                     quat_identity(q.shape[:-1]))
    tilt = quat_mul(quat_conj(twist), q)
    return twist, tilt


def heading_angle(q: np.ndarray, up: str = "y") -> np.ndarray:
    """Heading angle (radians) about ``up`` of rotations ``q`` ``(..., 4)``; shape ``(...)``."""
    twist, _ = decompose_facing(q, up)
    i = _axis_index(up)
    # q and -q are the same rotation: take the twist with w >= 0 so the angle is in (-pi, pi]
    sign = np.where(twist[..., 0] < 0, -1.0, 1.0)
    return 2.0 * np.arctan2(sign * twist[..., 1 + i], sign * twist[..., 0])


def _axis_index(up: str) -> int:
    """Index 0/1/2 of axis name ``up`` (``"x"``, ``"y"``, ``"z"``, any case)."""
    try:
        return AXES[str(up).lower()]
    except KeyError:
        raise SkeletonError(f"unknown up axis {up!r}; expected 'x', 'y' or 'z'") from None
