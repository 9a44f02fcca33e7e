"""Geometry shared by the controllers, the scenarios and the environments: a body's heading,
small cross products (cheaper than ``np.cross`` at these sizes, with the same IEEE operations),
and the support polygon (the convex hull of the feet's floor contacts and the signed distance of
a point, the centre of mass or capture point, from its edges)."""

from __future__ import annotations

import math

import numpy as np


def heading_yaw(R: np.ndarray) -> float:
    """Heading (rad) of a body orientation: the yaw of its x axis (its facing direction)
    projected on the floor. ``R``: a ``(3, 3)`` rotation matrix or MuJoCo's row-major ``(9,)``
    ``xmat`` row."""
    m = R.ravel() if isinstance(R, np.ndarray) else np.asarray(R).reshape(-1)
    return math.atan2(m[3], m[0])


def cross3(a: list[float], b: list[float]) -> list[float]:
    """Cross product of two 3-vectors given as Python floats (the same IEEE operations as
    numpy's element-wise ones, without numpy's per-element overhead)."""
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``(3,)`` cross product of two ``(3,)`` vectors (:func:`cross3`'s operations)."""
    return np.array(cross3(a.tolist(), b.tolist()))


_NEXT, _PREV = np.array([1, 2, 0]), np.array([2, 0, 1])


def cross_rows(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise ``np.cross(a, b)`` of ``(k, 3)`` rows ``a`` and ``(k, 3)`` rows or one ``(3,)``
    vector ``b``: column ``i`` is ``a_{i+1} b_{i+2} - a_{i+2} b_{i+1}``, in three whole-array
    products (``np.cross`` costs ~10x more at this size)."""
    return a[:, _NEXT] * b[..., _PREV] - a[:, _PREV] * b[..., _NEXT]


def smoothstep(x: float) -> float:
    """``3 x^2 - 2 x^3`` of ``x`` clipped to [0, 1]: 0 at 0, 1 at 1, zero slope at both ends."""
    x = min(max(x, 0.0), 1.0)
    return x * x * (3.0 - 2.0 * x)


def convex_hull_2d(points: np.ndarray) -> np.ndarray:
    """Counter-clockwise convex hull ``(K, 2)`` of ``(N, 2)`` points (Andrew's monotone chain).

    Duplicate and collinear points are dropped; returns ``(0, 2)`` for no points, one row for a
    single point and two for a segment.
    """
    p = np.unique(np.round(np.asarray(points, dtype=float).reshape(-1, 2), 9), axis=0)
    if len(p) <= 2:
        return p

    def cross(o, a, b) -> float:
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower: list = []
    for q in p:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], q) <= 1e-12:
            lower.pop()
        lower.append(q)
    upper: list = []
    for q in p[::-1]:
        while len(upper) >= 2 and cross(upper[-2], upper[-1], q) <= 1e-12:
            upper.pop()
        upper.append(q)
    hull = np.array(lower[:-1] + upper[:-1])
    return hull


def point_in_polygon_margin(point: np.ndarray, polygon: np.ndarray) -> float:
    """Signed distance (m) of a 2D ``point`` inside a CCW convex ``polygon`` ``(K, 2)``.

    Positive inside (distance to the nearest edge), negative outside; ``-inf`` for an empty
    polygon. Points and segments count as zero-area polygons (the distance to them, negated).
    """
    poly = np.asarray(polygon, dtype=float)
    x = np.asarray(point, dtype=float)[:2]
    if len(poly) == 0:
        return -math.inf
    if len(poly) == 1:
        return -float(np.linalg.norm(x - poly[0]))
    if len(poly) == 2:
        a, b = poly
        t = np.clip(np.dot(x - a, b - a) / max(np.dot(b - a, b - a), 1e-18), 0, 1)
        return -float(np.linalg.norm(x - (a + t * (b - a))))
    a = poly
    b = np.roll(poly, -1, axis=0)
    e = b - a
    n = np.stack([e[:, 1], -e[:, 0]], axis=1) / np.linalg.norm(e, axis=1, keepdims=True)  # outward
    s = np.einsum("ij,ij->i", x - a, n)  # signed distance to each edge line, + outside
    if np.all(s <= 0):
        return float(-s.max())
    # outside: distance to the polygon boundary
    d = []
    for ai, ei in zip(a, e, strict=True):
        t = np.clip(np.dot(x - ai, ei) / np.dot(ei, ei), 0, 1)
        d.append(np.linalg.norm(x - (ai + t * ei)))
    return -float(min(d))
