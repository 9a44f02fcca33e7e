"""Interpolation of keyframes and motions: position splines, quaternion splines, resampling.

Curves through keys ``(t_k, p_k)``, ``k = 0 .. K-1``, with ``t_k`` strictly increasing seconds:

- positions: piecewise :func:`linear`, cubic :func:`hermite` (tangents given, or the three-point
  finite difference ``m_k = ((p_{k+1}-p_k)/(t_{k+1}-t_k) + (p_k-p_{k-1})/(t_k-t_{k-1})) / 2``) and
  :func:`catmull_rom` (Hermite with ``m_k = (p_{k+1}-p_{k-1}) / (t_{k+1}-t_{k-1})``). Both cubic
  curves pass through the keys and are C1 (same tangent left and right of each key).
- rotations: :func:`slerp_keys` (piecewise great-arc, C0) and :func:`quat_spline`, a C1 cubic
  quaternion curve in the *cumulative* form of Kim, Kim and Shin (SIGGRAPH 1995, "A general
  construction scheme for unit quaternion curves with simple high order derivatives"). On the
  segment ``[t_a, t_b]`` (``h = t_b - t_a``, ``u = (t - t_a)/h``) with body angular velocities
  ``w_a``, ``w_b`` (rad/s) at its keys::

      q(u) = q_a exp(W1 B1(u)) exp(W2 B2(u)) exp(W3 B3(u))
      B1 = 1-(1-u)^3,  B2 = 3u^2-2u^3,  B3 = u^3            (cumulative cubic Bernstein basis)
      W1 = h w_a / 3,  W3 = h w_b / 3,  W2 = log(exp(-W1) q_a^-1 q_b exp(-W3))

  ``exp``/``log`` map rotation vectors (axis * angle) to quaternions and back. ``q(0) = q_a``,
  ``q(1) = q_b``, and the body angular velocity is ``w_a`` at ``t_a`` and ``w_b`` at ``t_b``, so
  adjacent segments that share a key's ``w_k`` join with continuous angular velocity (C1). The key
  velocities follow the same rules as the position tangents, applied to the body-frame log
  differences ``log(q_k^-1 q_{k+1}) / (t_{k+1} - t_k)``; unit norm holds by construction.

Motions (:class:`~mjchar.bvh.io.motion.Motion`) are sampled at any times with :func:`sample` and
brought to another frame rate with :func:`resample`; :func:`keyframes_to_motion` turns key poses
into a motion. Everything is vectorised over times, joints and frames.

Out-of-range times are clamped to the first/last key (the pose is held), never extrapolated.
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import CubicSpline

from mjchar.bvh.errors import SkeletonError
from mjchar.bvh.io.motion import Motion
from mjchar.bvh.io.skeleton import Skeleton
from mjchar.bvh.rotations import (
    quat_conj,
    quat_fix_continuity,
    quat_from_rotvec,
    quat_mul,
    quat_normalize,
    quat_rotate,
    quat_slerp,
    quat_to_rotvec,
)

__all__ = [
    "InterpolationError",
    "linear",
    "hermite",
    "catmull_rom",
    "finite_difference_tangents",
    "catmull_rom_tangents",
    "slerp_keys",
    "quat_spline",
    "quat_key_velocities",
    "sample",
    "resample",
    "keyframes_to_motion",
    "POSITION_METHODS",
    "ROTATION_METHODS",
    "KEYFRAME_METHODS",
]

POSITION_METHODS = ("linear", "cubic")
ROTATION_METHODS = ("slerp", "spline")
KEYFRAME_METHODS = ("linear", "hermite", "catmull_rom")
_TANGENT_RULES = ("finite_difference", "catmull_rom")


class InterpolationError(SkeletonError):
    """Keys, times or options an interpolation cannot work with (e.g. times not increasing)."""


# -- validation and segment lookup ----------------------------------------------------------------
def _check_times(key_times: np.ndarray, n_keys: int | None = None) -> np.ndarray:
    times = np.asarray(key_times, dtype=float)
    if times.ndim != 1 or len(times) < 2:
        raise InterpolationError(
            f"key_times must be a (K,) array with K >= 2, got shape {times.shape}")
    if n_keys is not None and len(times) != n_keys:
        raise InterpolationError(f"{len(times)} key times for {n_keys} keys")
    if not np.all(np.isfinite(times)):
        raise InterpolationError("key_times contain NaN or infinity")
    if np.any(np.diff(times) <= 0):
        bad = int(np.flatnonzero(np.diff(times) <= 0)[0])
        raise InterpolationError(
            f"key_times must be strictly increasing; key {bad + 1} ({times[bad + 1]} s) does not "
            f"come after key {bad} ({times[bad]} s)")
    return times


def _check_pair(times: np.ndarray, values: np.ndarray) -> None:
    if len(values) != len(times):
        raise InterpolationError(f"{len(times)} key times for {len(values)} keys")


def _check_values(values: np.ndarray, name: str, last: int | None = None) -> np.ndarray:
    values = np.asarray(values, dtype=float)
    if values.ndim < 1 or (last is not None and (values.ndim < 2 or values.shape[-1] != last)):
        want = f"(K, ..., {last})" if last else "(K, ...)"
        raise InterpolationError(f"{name} must have shape {want}, got {values.shape}")
    if not np.all(np.isfinite(values)):
        raise InterpolationError(f"{name} contain NaN or infinity")
    return values


def _segments(times: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Segment index, local parameter ``u`` in [0, 1] and segment length, each ``(N,)``."""
    t = np.clip(t, times[0], times[-1])
    idx = np.clip(np.searchsorted(times, t, side="right") - 1, 0, len(times) - 2)
    h = times[idx + 1] - times[idx]
    u = np.clip((t - times[idx]) / h, 0.0, 1.0)
    return idx, u, h


def _as_query(t: np.ndarray | float) -> tuple[np.ndarray, bool]:
    arr = np.asarray(t, dtype=float)
    if arr.ndim > 1:
        raise InterpolationError(
            f"query times must be a scalar or a (N,) array, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InterpolationError("query times contain NaN or infinity")
    return np.atleast_1d(arr), arr.ndim == 0


def _bcast(x: np.ndarray, like: np.ndarray) -> np.ndarray:
    """Reshape ``(N,)`` to ``(N, 1, ..., 1)`` to broadcast against ``like`` ``(N, ...)``."""
    return x.reshape(x.shape + (1,) * (like.ndim - 1))


# -- tangents --------------------------------------------------------------------------------------
def _neighbour_differences(times: np.ndarray, diffs: np.ndarray, cyclic: bool
                           ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Differences into and out of each key and the time spans they cover.

    ``diffs`` ``(K-1, ...)`` are the segment increments. Returns ``(d_in, d_out, h_in, h_out)``
    of shapes ``(K, ...)`` / ``(K,)``. Without ``cyclic`` the missing end neighbours copy the
    one-sided difference (so end tangents are the end segment's slope).
    """
    h = np.diff(times)
    if cyclic:
        d_in = np.concatenate([diffs[-1:], diffs])
        d_out = np.concatenate([diffs, diffs[:1]])
        h_in = np.concatenate([h[-1:], h])
        h_out = np.concatenate([h, h[:1]])
    else:
        d_in = np.concatenate([diffs[:1], diffs])
        d_out = np.concatenate([diffs, diffs[-1:]])
        h_in = np.concatenate([h[:1], h])
        h_out = np.concatenate([h, h[-1:]])
    return d_in, d_out, h_in, h_out


def _tangents_from_differences(times: np.ndarray, diffs: np.ndarray, rule: str,
                               cyclic: bool) -> np.ndarray:
    if rule not in _TANGENT_RULES:
        raise InterpolationError(f"unknown tangent rule {rule!r}; expected one of {_TANGENT_RULES}")
    d_in, d_out, h_in, h_out = _neighbour_differences(times, diffs, cyclic)
    if rule == "catmull_rom":
        return (d_in + d_out) / _bcast(h_in + h_out, d_in)
    return 0.5 * (d_in / _bcast(h_in, d_in) + d_out / _bcast(h_out, d_out))


def _check_cyclic(values: np.ndarray, cyclic: bool) -> None:
    if cyclic and len(values) < 3:
        raise InterpolationError(
            "a cyclic curve needs at least 3 keys (the last repeats the first)")


def finite_difference_tangents(key_times: np.ndarray, key_values: np.ndarray,
                               cyclic: bool = False) -> np.ndarray:
    """Three-point finite-difference tangents ``(K, ...)`` (units of value per second).

    ``m_k`` is the mean of the slopes of the two segments meeting at key ``k``; end keys use
    their one segment's slope. ``cyclic``: the keys are a loop whose last key equals the first
    (the caller guarantees it), and the end keys use the slopes on both sides of the seam.
    """
    times = _check_times(key_times)
    values = _check_values(key_values, "key_values")
    _check_pair(times, values)
    _check_cyclic(values, cyclic)
    return _tangents_from_differences(times, np.diff(values, axis=0), "finite_difference", cyclic)


def catmull_rom_tangents(key_times: np.ndarray, key_values: np.ndarray,
                         cyclic: bool = False) -> np.ndarray:
    """Catmull-Rom tangents ``(K, ...)``: ``m_k = (p_{k+1} - p_{k-1}) / (t_{k+1} - t_{k-1})``.

    End keys use their one segment's slope unless ``cyclic`` (see
    :func:`finite_difference_tangents`). Equal to the finite-difference rule for uniform keys.
    """
    times = _check_times(key_times)
    values = _check_values(key_values, "key_values")
    _check_pair(times, values)
    _check_cyclic(values, cyclic)
    return _tangents_from_differences(times, np.diff(values, axis=0), "catmull_rom", cyclic)


# -- position curves -------------------------------------------------------------------------------
def linear(key_times: np.ndarray, key_values: np.ndarray, t: np.ndarray | float) -> np.ndarray:
    """Piecewise-linear interpolation of ``key_values`` ``(K, ...)`` at times ``t``.

    ``t``: scalar or ``(N,)`` seconds. Returns ``(...)`` or ``(N, ...)``.
    """
    times = _check_times(key_times)
    values = _check_values(key_values, "key_values")
    _check_pair(times, values)
    tq, scalar = _as_query(t)
    idx, u, _ = _segments(times, tq)
    a, b = values[idx], values[idx + 1]
    out = a + _bcast(u, a) * (b - a)
    return out[0] if scalar else out


def hermite(key_times: np.ndarray, key_values: np.ndarray, t: np.ndarray | float,
            tangents: np.ndarray | None = None, cyclic: bool = False,
            derivative: bool = False) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """Cubic Hermite spline through ``key_values`` ``(K, ...)`` evaluated at ``t``.

    Args:
        key_times: ``(K,)`` strictly increasing seconds.
        key_values: ``(K, ...)`` values at the keys (any units).
        t: scalar or ``(N,)`` seconds (clamped to the key range).
        tangents: ``(K, ...)`` derivatives at the keys (value units per second); ``None`` uses
            :func:`finite_difference_tangents`.
        cyclic: with ``tangents=None``, treat the keys as a loop (last key equals first).
        derivative: also return the time derivative.

    Returns ``(...)``/``(N, ...)`` values, and with ``derivative`` a tuple ``(values, d/dt)``.
    """
    times = _check_times(key_times)
    values = _check_values(key_values, "key_values")
    _check_pair(times, values)
    if tangents is None:
        tangents = finite_difference_tangents(times, values, cyclic)
    tangents = _check_values(tangents, "tangents")
    if tangents.shape != values.shape:
        raise InterpolationError(
            f"tangents must match key_values {values.shape}, got {tangents.shape}")
    tq, scalar = _as_query(t)
    idx, u, h = _segments(times, tq)
    p0, p1 = values[idx], values[idx + 1]
    m0, m1 = tangents[idx] * _bcast(h, p0), tangents[idx + 1] * _bcast(h, p0)
    u = _bcast(u, p0)
    u2, u3 = u * u, u * u * u
    out = ((2 * u3 - 3 * u2 + 1) * p0 + (u3 - 2 * u2 + u) * m0
           + (-2 * u3 + 3 * u2) * p1 + (u3 - u2) * m1)
    if not derivative:
        return out[0] if scalar else out
    d = ((6 * u2 - 6 * u) * p0 + (3 * u2 - 4 * u + 1) * m0
         + (-6 * u2 + 6 * u) * p1 + (3 * u2 - 2 * u) * m1) / _bcast(h, p0)
    return (out[0], d[0]) if scalar else (out, d)


def catmull_rom(key_times: np.ndarray, key_values: np.ndarray, t: np.ndarray | float,
                cyclic: bool = False, derivative: bool = False
                ) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """Catmull-Rom spline (cubic Hermite with :func:`catmull_rom_tangents`); see :func:`hermite`."""
    tangents = catmull_rom_tangents(key_times, key_values, cyclic)
    return hermite(key_times, key_values, t, tangents=tangents, derivative=derivative)


# -- rotation curves -------------------------------------------------------------------------------
def _check_quats(key_quats: np.ndarray, name: str = "key_quats") -> np.ndarray:
    q = _check_values(key_quats, name, last=4)
    norms = np.linalg.norm(q, axis=-1)
    if np.any(norms < 1e-9):
        raise InterpolationError(f"{name} contain zero-length quaternions")
    return quat_fix_continuity(q / norms[..., None], axis=0)


def _qlog_rel(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Rotation vector of ``a^-1 b`` (shortest path), ``(..., 3)`` radians."""
    return quat_to_rotvec(quat_mul(quat_conj(a), b))


def slerp_keys(key_times: np.ndarray, key_quats: np.ndarray, t: np.ndarray | float) -> np.ndarray:
    """Piecewise slerp through unit wxyz quaternions ``key_quats`` ``(K, ..., 4)`` at ``t``.

    ``t``: scalar or ``(N,)`` seconds. Returns unit quaternions ``(..., 4)`` or ``(N, ..., 4)``.
    """
    times = _check_times(key_times)
    q = _check_quats(key_quats)
    _check_pair(times, q)
    tq, scalar = _as_query(t)
    idx, u, _ = _segments(times, tq)
    out = quat_slerp(q[idx], q[idx + 1], u.reshape(u.shape + (1,) * (q.ndim - 2)))
    return out[0] if scalar else out


def quat_key_velocities(key_times: np.ndarray, key_quats: np.ndarray,
                        rule: str = "catmull_rom", cyclic: bool = False) -> np.ndarray:
    """Body-frame angular velocities ``(K, ..., 3)`` (rad/s) at the keys of a quaternion spline.

    ``rule``: ``"catmull_rom"`` or ``"finite_difference"``, applied to the body-frame log
    differences ``log(q_k^-1 q_{k+1}) / (t_{k+1} - t_k)`` as for positions (a rotation's axis is
    the same in the frames of both its ends, so both neighbouring differences are expressed in key
    ``k``'s frame). ``cyclic``: the last key equals the first (up to sign).
    """
    times = _check_times(key_times)
    q = _check_quats(key_quats)
    _check_pair(times, q)
    _check_cyclic(q, cyclic)
    diffs = _qlog_rel(q[:-1], q[1:])  # (K-1, ..., 3) radians
    return _tangents_from_differences(times, diffs, rule, cyclic)


def quat_spline(key_times: np.ndarray, key_quats: np.ndarray, t: np.ndarray | float,
                angular_velocities: np.ndarray | None = None, rule: str = "catmull_rom",
                cyclic: bool = False, derivative: bool = False
                ) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """C1 cubic quaternion spline (Kim-Kim-Shin cumulative Hermite form; see the module doc).

    Args:
        key_times: ``(K,)`` strictly increasing seconds.
        key_quats: ``(K, ..., 4)`` wxyz key rotations (normalised; signs made continuous).
        t: scalar or ``(N,)`` seconds (clamped to the key range).
        angular_velocities: ``(K, ..., 3)`` body-frame angular velocity at each key (rad/s), or
            ``None`` to use :func:`quat_key_velocities` with ``rule`` and ``cyclic``.
        derivative: also return the body-frame angular velocity ``(N, ..., 3)`` rad/s
            (``q^-1 dq/dt = (0, w/2)``).

    Returns unit quaternions ``(..., 4)``/``(N, ..., 4)`` (and angular velocities).
    """
    times = _check_times(key_times)
    q = _check_quats(key_quats)
    _check_pair(times, q)
    if angular_velocities is None:
        w = quat_key_velocities(times, q, rule, cyclic)
    else:
        w = _check_values(angular_velocities, "angular_velocities", last=3)
        if w.shape != q.shape[:-1] + (3,):
            raise InterpolationError(
                f"angular_velocities must be {q.shape[:-1] + (3,)}, got {w.shape}")
    # per-segment Bezier-like control rotation vectors (K-1, ..., 3)
    hseg = np.diff(times).reshape((-1,) + (1,) * (q.ndim - 1))
    w1 = hseg * w[:-1] / 3.0
    w3 = hseg * w[1:] / 3.0
    mid = quat_mul(quat_mul(quat_from_rotvec(-w1), quat_mul(quat_conj(q[:-1]), q[1:])),
                   quat_from_rotvec(-w3))
    w2 = quat_to_rotvec(mid)

    tq, scalar = _as_query(t)
    idx, u, h = _segments(times, tq)
    uu = u.reshape(u.shape + (1,) * (q.ndim - 1))
    b1 = 1.0 - (1.0 - uu) ** 3
    b2 = 3.0 * uu**2 - 2.0 * uu**3
    b3 = uu**3
    e1 = quat_from_rotvec(w1[idx] * b1)
    e2 = quat_from_rotvec(w2[idx] * b2)
    e3 = quat_from_rotvec(w3[idx] * b3)
    out = quat_normalize(quat_mul(quat_mul(quat_mul(q[idx], e1), e2), e3))
    if not derivative:
        return out[0] if scalar else out
    # body velocity of q_a E1 E2 E3: Ad(E3^-1 E2^-1) W1 B1' + Ad(E3^-1) W2 B2' + W3 B3', per second
    db1, db2, db3 = 3.0 * (1.0 - uu) ** 2, 6.0 * uu * (1.0 - uu), 3.0 * uu**2
    e23 = quat_conj(quat_mul(e2, e3))
    vel = (quat_rotate(e23, w1[idx] * db1) + quat_rotate(quat_conj(e3), w2[idx] * db2)
           + w3[idx] * db3) / h.reshape(h.shape + (1,) * (q.ndim - 1))
    return (out[0], vel[0]) if scalar else (out, vel)


# -- motions ---------------------------------------------------------------------------------------
def _check_method(value: str, allowed: tuple[str, ...], what: str) -> None:
    if value not in allowed:
        raise InterpolationError(f"unknown {what} {value!r}; expected one of {allowed}")


def sample(motion: Motion, t: np.ndarray | float, position_method: str = "linear",
           rotation_method: str = "slerp") -> tuple[np.ndarray, np.ndarray]:
    """The pose of ``motion`` at time(s) ``t`` (seconds from its first frame, clamped to the clip).

    Args:
        motion: the :class:`Motion`.
        t: scalar or ``(N,)`` seconds.
        position_method: ``"linear"`` or ``"cubic"`` (scipy ``CubicSpline``, not-a-knot ends)
            for the local positions.
        rotation_method: ``"slerp"`` (between neighbouring frames) or ``"spline"`` (the C1
            :func:`quat_spline` through the frames with Catmull-Rom velocities).

    Returns ``(local_positions, rotations)``: ``(J, 3)`` and ``(J, 4)`` for a scalar ``t``,
    ``(N, J, 3)`` and ``(N, J, 4)`` for an array; positions in file units, unit wxyz rotations.
    """
    _check_method(position_method, POSITION_METHODS, "position_method")
    _check_method(rotation_method, ROTATION_METHODS, "rotation_method")
    tq, scalar = _as_query(t)
    if motion.n_frames == 0:
        raise InterpolationError("cannot sample a motion with no frames")
    if motion.n_frames == 1:
        pos = np.repeat(motion.local_positions, len(tq), axis=0)
        rot = np.repeat(quat_normalize(motion.rotations), len(tq), axis=0)
    else:
        times = motion.times
        tq = np.clip(tq, times[0], times[-1])
        if position_method == "linear":
            pos = linear(times, motion.local_positions, tq)
        else:
            pos = CubicSpline(times, motion.local_positions, axis=0)(tq)
        if rotation_method == "slerp":
            rot = slerp_keys(times, motion.rotations, tq)
        else:
            rot = quat_spline(times, motion.rotations, tq, rule="catmull_rom")
    return (pos[0], rot[0]) if scalar else (pos, rot)


def _new_frame_time(fps: float | None, frame_time: float | None) -> float:
    if (fps is None) == (frame_time is None):
        raise InterpolationError("give exactly one of fps or frame_time")
    value = (1.0 / fps) if fps is not None else frame_time
    if fps is not None and not (np.isfinite(fps) and fps > 0):
        raise InterpolationError(f"fps must be a positive number, got {fps}")
    if not (np.isfinite(value) and value > 0):
        raise InterpolationError(
            f"frame_time must be a positive number of seconds, got {frame_time}")
    return float(value)


def _frame_count(duration: float, frame_time: float) -> int:
    """Frames at ``0, dt, 2 dt, ...`` up to ``duration`` (a last time within 1e-6 dt counts)."""
    return int(np.floor(duration / frame_time + 1e-6)) + 1


def resample(motion: Motion, fps: float | None = None, frame_time: float | None = None,
             position_method: str = "linear", rotation_method: str = "slerp") -> Motion:
    """The motion at another frame rate.

    New frames are at ``n * frame_time`` for every ``n`` with ``n * frame_time <= duration``, so
    the new clip starts with the old first frame and ends at or before the old last frame (the
    end is kept when the duration is a multiple of the new frame time). Give ``fps`` (frames per
    second) or ``frame_time`` (seconds). Rotations use slerp (default) or the C1 quaternion spline
    (``rotation_method="spline"``), positions linear or cubic interpolation; see :func:`sample`.
    Returns a new :class:`Motion` on the same skeleton.
    """
    ft = _new_frame_time(fps, frame_time)
    n = _frame_count(motion.duration, ft) if motion.n_frames > 0 else 0
    if n == 0:
        raise InterpolationError("cannot resample a motion with no frames")
    pos, rot = sample(motion, np.arange(n) * ft, position_method, rotation_method)
    return Motion(motion.skeleton, ft, pos, quat_fix_continuity(rot, axis=0))


def keyframes_to_motion(skeleton: Skeleton, key_times: np.ndarray, key_rotations: np.ndarray,
                        key_root_positions: np.ndarray, frame_time: float,
                        method: str = "catmull_rom", cyclic: bool = False, *,
                        key_local_positions: np.ndarray | None = None) -> Motion:
    """A :class:`Motion` sampled every ``frame_time`` from key poses.

    Args:
        skeleton: the :class:`Skeleton` animated (``J`` joints).
        key_times: ``(K,)`` strictly increasing seconds; frame 0 is at ``key_times[0]``.
        key_rotations: ``(K, J, 4)`` wxyz local joint rotations (normalised here).
        key_root_positions: ``(K, 3)`` root translations, file units.
        frame_time: seconds per output frame. Frames are at ``key_times[0] + n * frame_time`` for
            every ``n`` up to ``key_times[-1]`` (the last key is a frame when the key span is a
            multiple of ``frame_time``; for ``cyclic`` keys the last frame then repeats the first
            pose, displaced by one cycle).
        method: ``"linear"`` (linear positions, slerp rotations), ``"hermite"`` (cubic Hermite
            positions with finite-difference tangents, quaternion spline with finite-difference
            angular velocities) or ``"catmull_rom"`` (Catmull-Rom positions and velocities).
        cyclic: the keys form a loop whose last key repeats the first; the curves are C1 through
            the seam. The root may move by a constant displacement ``D = p_{K-1} - p_0`` per cycle:
            the displacement-free part ``p_k - D (t_k - t_0) / T`` (``T`` the period) is
            interpolated as a loop and the drift ``D (t - t_0) / T`` added back. Rotations of the
            last key must equal the first (within 1e-3 rad).
        key_local_positions: optional ``(K, J, 3)``: local translations for joints that have
            BVH position channels (other than the root); otherwise such joints, like all
            non-root joints, keep their skeleton offsets.

    Raises :class:`InterpolationError` for inconsistent shapes, times or methods.
    """
    _check_method(method, KEYFRAME_METHODS, "method")
    if not (np.isfinite(frame_time) and frame_time > 0):
        raise InterpolationError(
            f"frame_time must be a positive number of seconds, got {frame_time}")
    times, rot, root, klp = _checked_keys(skeleton, key_times, key_rotations, key_root_positions,
                                          key_local_positions)
    if cyclic:
        rot = _closed_loop(skeleton, rot)
    n_j = skeleton.n_joints
    extra = skeleton.has_position_channels()
    extra[0] = False
    n = _frame_count(times[-1] - times[0], frame_time)
    t = times[0] + np.arange(n) * frame_time
    rule = "finite_difference" if method == "hermite" else "catmull_rom"
    pos = np.broadcast_to(skeleton.offsets, (n, n_j, 3)).copy()
    pos[:, 0] = _key_positions(times, root, t, method, rule, cyclic, drift=True)
    if klp is not None and np.any(extra):
        pos[:, extra] = _key_positions(times, klp[:, extra], t, method, rule, cyclic, drift=False)
    if method == "linear":
        rots = slerp_keys(times, rot, t)
    else:
        rots = quat_spline(times, rot, t, rule=rule, cyclic=cyclic)
    return Motion(skeleton, float(frame_time), pos, quat_fix_continuity(rots, axis=0))


def _checked_keys(skeleton: Skeleton, key_times: np.ndarray, key_rotations: np.ndarray,
                  key_root_positions: np.ndarray, key_local_positions: np.ndarray | None
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray | None]:
    """The keys of :func:`keyframes_to_motion` checked against each other and ``skeleton``:
    ``(times, rotations (normalised), root positions, local positions or None)``."""
    times = _check_times(key_times)
    n_k, n_j = len(times), skeleton.n_joints
    rot = _check_values(key_rotations, "key_rotations")
    if rot.shape != (n_k, n_j, 4):
        raise InterpolationError(f"key_rotations must be ({n_k}, {n_j}, 4), got {rot.shape}")
    rot = _check_quats(rot, "key_rotations")
    root = _check_values(key_root_positions, "key_root_positions")
    if root.shape != (n_k, 3):
        raise InterpolationError(f"key_root_positions must be ({n_k}, 3), got {root.shape}")
    if key_local_positions is not None:
        klp = _check_values(key_local_positions, "key_local_positions")
        if klp.shape != (n_k, n_j, 3):
            raise InterpolationError(
                f"key_local_positions must be ({n_k}, {n_j}, 3), got {klp.shape}")
    else:
        klp = None
    return times, rot, root, klp


def _closed_loop(skeleton: Skeleton, rot: np.ndarray) -> np.ndarray:
    """Cyclic key rotations ``(K, J, 4)`` whose last key must repeat the first (within 1e-3
    rad); a copy with the last key set to the first in the same hemisphere."""
    _check_cyclic(rot, True)
    seam = np.linalg.norm(quat_to_rotvec(quat_mul(quat_conj(rot[-1]), rot[0])), axis=-1)
    if np.any(seam > 1e-3):
        j = int(np.argmax(seam))
        raise InterpolationError(
            f"cyclic keys: the last key's rotation of joint {skeleton.names[j]!r} differs "
            f"from the first by {np.degrees(seam[j]):.3g} degrees; a loop must end where it "
            f"starts")
    rot = rot.copy()
    rot[-1] = rot[0] * np.sign(np.sum(rot[-1] * rot[0], axis=-1, keepdims=True) + 1e-300)
    return rot


def _key_positions(times: np.ndarray, values: np.ndarray, t: np.ndarray, method: str, rule: str,
                   cyclic: bool, drift: bool) -> np.ndarray:
    """Key ``values`` ``(K, ...)`` at the frame times ``t``: linear, or Hermite with ``rule``
    tangents; cyclic keys loop C1 through the seam, with the per-cycle displacement taken out
    and added back (``drift``) or the last key set to the first."""
    if method == "linear":
        return linear(times, values, t)
    if not cyclic:
        tang = _tangents_from_differences(times, np.diff(values, axis=0), rule, False)
        return hermite(times, values, t, tangents=tang)
    period = times[-1] - times[0]
    disp = values[-1] - values[0]
    phase_k = ((times - times[0]) / period).reshape((-1,) + (1,) * (values.ndim - 1))
    phase_t = ((t - times[0]) / period).reshape((-1,) + (1,) * (values.ndim - 1))
    periodic = values - phase_k * disp if drift else values.copy()
    if not drift:
        periodic[-1] = periodic[0]
    tang = _tangents_from_differences(times, np.diff(periodic, axis=0), rule, True)
    out = hermite(times, periodic, t, tangents=tang)
    return out + phase_t * disp if drift else out
