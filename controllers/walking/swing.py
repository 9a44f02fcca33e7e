"""Swing-leg helpers for IPM stepping: the swing-foot trajectory and analytic two-link leg IK.

Coros, Beaudoin and van de Panne, "Generalized Biped Walking Control" (SIGGRAPH 2010), steer the
swing foot along a trajectory defined relative to the centre of mass in the heading frame:

- **height** of the sole over the ground: a quadratic spline through three heights (the paper's
  ``0.04 -> 0.15 -> 0.05`` m) at phases ``0, 0.5, 1``; after phase 1 the target keeps sinking at
  ``descent_speed`` m/s until the foot touches the ground, which ends the step;
- **horizontal** position: blended from the offset the foot had at lift-off to the inverted
  pendulum step location ``d``, with the lift-off weight ``t = (1 - phase)^2`` (the paper's) or
  ``t = 1 - smoothstep(phase)`` (``blend="smooth"``: the target starts at rest, so a fast swing
  overshoots less)::

      p(phase) = t * p_liftoff + (1 - t) * d

Hip and knee angles then come from two-link IK (:func:`two_link_ik`): thigh length ``l1``, shank
length ``l2``, a hip position and an ankle target give the knee flexion by the law of cosines and
the thigh direction in the plane that contains the hip-ankle line and the "pole" (forward)
direction, so the knee points forward. A knee whose hinge axis is not across both bones (an
axis fitted to a capture) is solved about that axis instead (:func:`hinge_leg_ik`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..core.base import ControllerError
from ..core.geometry import cross, cross3, smoothstep


class SwingError(ControllerError):
    """A swing trajectory or leg IK was given impossible numbers (non-finite, non-positive)."""


def _unit(v: np.ndarray) -> np.ndarray:
    n = math.sqrt(float(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]))
    return v / n if n > 1e-12 else v * 0.0


def _unit3(v: list[float]) -> list[float]:
    """:func:`_unit` of a 3-vector of Python floats (the same IEEE operations)."""
    n = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    return [x / n for x in v] if n > 1e-12 else [x * 0.0 for x in v]


def rotation_about(axis: np.ndarray, angle: float) -> np.ndarray:
    """``(3, 3)`` rotation matrix about unit ``axis`` ``(3,)`` by ``angle`` rad (Rodrigues)."""
    x, y, z = axis
    c, s = math.cos(angle), math.sin(angle)
    C = 1.0 - c
    return np.array([[c + x * x * C, x * y * C - z * s, x * z * C + y * s],
                     [y * x * C + z * s, c + y * y * C, y * z * C - x * s],
                     [z * x * C - y * s, z * y * C + x * s, c + z * z * C]])


def rotation_z(angle: float) -> np.ndarray:
    """``(3, 3)`` rotation about the world z axis by ``angle`` rad (a heading)."""
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


@dataclass(frozen=True)
class SwingTrajectory:
    """Swing-foot sole height and horizontal blend over the step phase (0 at lift-off, 1 nominal
    landing).

    Attributes:
        heights: ``(3,)`` sole heights (m over the ground) at phases 0, 0.5 and 1.
        descent_speed: m/s the height target keeps sinking after phase 1 (the step ends on
            contact, not on time).
        floor: lowest height target (m; negative presses the foot into the ground).
        blend: ``"quadratic"`` (lift-off weight ``(1 - phase)^2``) or ``"smooth"``.
    """

    heights: tuple[float, float, float] = (0.04, 0.15, 0.05)
    descent_speed: float = 1.0
    floor: float = -0.05
    blend: str = "quadratic"

    def __post_init__(self):
        h = np.asarray(self.heights, dtype=float)
        if h.shape != (3,) or not np.all(np.isfinite(h)):
            raise SwingError(f"swing heights must be 3 finite numbers (m), got {self.heights!r}")
        if not (math.isfinite(self.descent_speed) and self.descent_speed >= 0):
            raise SwingError(f"descent_speed must be >= 0 m/s, got {self.descent_speed}")
        if self.blend not in ("quadratic", "smooth"):
            raise SwingError(f"blend must be 'quadratic' or 'smooth', got {self.blend!r}")

    def height(self, phase: float, step_time: float) -> float:
        """Sole height target (m) at ``phase``; ``step_time`` (s) converts the overrun after
        phase 1 into a descent."""
        h0, h1, h2 = self.heights
        if phase <= 0.0:
            return h0
        if phase <= 1.0:
            # quadratic Lagrange spline through (0, h0), (0.5, h1), (1, h2)
            p = phase
            return (h0 * 2 * (p - 0.5) * (p - 1.0) - h1 * 4 * p * (p - 1.0)
                    + h2 * 2 * p * (p - 0.5))
        return max(h2 - self.descent_speed * (phase - 1.0) * step_time, self.floor)

    def liftoff_weight(self, phase: float) -> float:
        """Weight of the lift-off offset (0 from phase 1 on): ``t = (1 - phase)^2`` (the paper's
        blend) or, with ``blend="smooth"``, ``1 - smoothstep(phase)`` (the target starts and ends
        at rest)."""
        if self.blend == "smooth":
            return 1.0 - smoothstep(phase)
        return (1.0 - min(max(phase, 0.0), 1.0)) ** 2

    def horizontal(self, phase: float, liftoff: np.ndarray, target: np.ndarray) -> np.ndarray:
        """``(2,)`` horizontal foot offset: ``t * liftoff + (1 - t) * target``, both ``(2,)`` m
        (relative to the centre of mass, heading frame)."""
        t = self.liftoff_weight(phase)
        return t * np.asarray(liftoff, float) + (1.0 - t) * np.asarray(target, float)


def two_link_ik(hip: np.ndarray, target: np.ndarray, l1: float, l2: float, pole: np.ndarray,
                *, min_reach: float = 0.05, max_extension: float = 0.999
                ) -> tuple[np.ndarray, np.ndarray, float]:
    """Analytic IK of a hip-knee-ankle chain with a hinge knee.

    Args:
        hip: ``(3,)`` hip joint position (m, world).
        target: ``(3,)`` ankle target (m, world); moved onto the reachable shell when too near or
            too far (``min_reach`` m, ``max_extension`` x ``(l1 + l2)``).
        l1, l2: thigh and shank lengths (m).
        pole: ``(3,)`` direction the knee should point to (e.g. the desired heading).
    Returns:
        ``(thigh, axis, flexion)``: ``thigh`` ``(3,)`` unit direction hip -> knee, ``axis``
        ``(3,)`` unit knee hinge axis (positive flexion about it swings the shank away from the
        pole, i.e. backwards), ``flexion`` the knee flexion angle (rad, 0 = straight leg).
    """
    thigh, axis, flexion = two_link_ik3(np.asarray(hip, dtype=float).tolist(),
                                        np.asarray(target, dtype=float).tolist(), l1, l2,
                                        np.asarray(pole, dtype=float).tolist(),
                                        min_reach=min_reach, max_extension=max_extension)
    return np.array(thigh), np.array(axis), flexion


def two_link_ik3(hip: list[float], target: list[float], l1: float, l2: float,
                 pole: list[float], *, min_reach: float = 0.05, max_extension: float = 0.999
                 ) -> tuple[list[float], list[float], float]:
    """:func:`two_link_ik` on 3-vectors given as Python floats (``(thigh, axis, flexion)``
    with ``thigh`` and ``axis`` as lists): the arithmetic of a controller's every physics step,
    without numpy's per-call overhead."""
    if not (l1 > 0 and l2 > 0):
        raise SwingError(f"leg lengths must be positive, got {l1}, {l2}")
    r = [target[0] - hip[0], target[1] - hip[1], target[2] - hip[2]]
    D = math.sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2])
    if not math.isfinite(D):
        raise SwingError("two_link_ik: non-finite hip or target")
    lo = max(min_reach, abs(l1 - l2) + 1e-6)
    hi = max_extension * (l1 + l2)
    rh = [x / D for x in r] if D > 1e-9 else [0.0, 0.0, -1.0]
    D = min(max(D, lo), hi)
    axis = _unit3(cross3(pole, rh))
    if not any(axis):  # pole parallel to the leg: any perpendicular will do
        axis = _unit3(cross3([0.0, 0.0, 1.0] if abs(rh[2]) < 0.9 else [1.0, 0.0, 0.0], rh))
    cos_knee = (l1 * l1 + l2 * l2 - D * D) / (2 * l1 * l2)
    flexion = math.pi - math.acos(min(max(cos_knee, -1.0), 1.0))
    cos_hip = (l1 * l1 + D * D - l2 * l2) / (2 * l1 * D)
    alpha = math.acos(min(max(cos_hip, -1.0), 1.0))
    # r_hat turned by -alpha about the (unit) axis, Rodrigues: r c + (k x r) s + k (k . r)(1 - c)
    c, s = math.cos(-alpha), math.sin(-alpha)
    kr = axis[0] * rh[0] + axis[1] * rh[1] + axis[2] * rh[2]
    kxr = cross3(axis, rh)
    thigh = [rh[i] * c + kxr[i] * s + axis[i] * kr * (1.0 - c) for i in range(3)]
    return thigh, axis, flexion


def frame_from_axes3(primary: list[float], secondary: list[float]) -> list[list[float]]:
    """:func:`frame_from_axes` on 3-vectors given as Python floats, the frame as rows."""
    a = _unit3(primary)
    k = a[0] * secondary[0] + a[1] * secondary[1] + a[2] * secondary[2]
    b = _unit3([si - ai * k for si, ai in zip(secondary, a, strict=True)])
    c = cross3(a, b)
    return [[a[0], b[0], c[0]], [a[1], b[1], c[1]], [a[2], b[2], c[2]]]


def frame_from_axes(primary: np.ndarray, secondary: np.ndarray) -> np.ndarray:
    """``(3, 3)`` orthonormal frame (columns) with first column along ``primary`` and second the
    part of ``secondary`` orthogonal to it."""
    a = _unit(np.asarray(primary, dtype=float))
    k = float(np.dot(a, secondary))
    al = a.tolist()
    b = _unit3([si - ai * k for si, ai in zip(np.asarray(secondary, dtype=float).tolist(), al,
                                              strict=True)])
    c = cross3(al, b)
    return np.array([[al[0], b[0], c[0]], [al[1], b[1], c[1]], [al[2], b[2], c[2]]])


__all__ = ["SwingTrajectory", "SwingError", "two_link_ik", "two_link_ik3", "frame_from_axes",
           "frame_from_axes3", "rotation_about", "rotation_z", "cross"]


def hinge_leg_ik(hip: np.ndarray, target: np.ndarray, bone1: np.ndarray, bone2: np.ndarray,
                 axis: np.ndarray, pole: np.ndarray, flexion_sign: float = 1.0, *,
                 min_reach: float = 0.05, max_extension: float = 0.999
                 ) -> tuple[np.ndarray, float]:
    """Analytic IK of a hip-knee-ankle chain whose hinge knee turns about any axis.

    :func:`two_link_ik` assumes the knee axis is perpendicular to both bones and the shank in
    line with the thigh at zero flexion; a knee axis fitted to a real capture need not be (the
    shank then sweeps a cone, not a plane). Here the ankle relative to the hip, in the thigh's
    frame, is ``p(q) = bone1 + R(axis, q) bone2``, and ``|p(q)|`` equals the hip-ankle distance
    ``D`` where ``A cos q + B sin q = (D^2 - |bone1|^2 - |bone2|^2) / 2 - C`` (Rodrigues:
    ``A = bone1 . bone2 - (a . bone1)(a . bone2)``, ``B = bone1 . (a x bone2)``,
    ``C = (a . bone1)(a . bone2)``); of its two roots the one on the flexion side is taken. The
    thigh is then turned so that ``p(q)`` points at the target and the knee (``bone1``, off the
    hip-ankle line) lies towards ``pole``.

    Args:
        hip: ``(3,)`` hip joint position (m, world).
        target: ``(3,)`` ankle target (m, world); moved onto the reachable shell when too near
            or too far (``min_reach`` m, ``max_extension`` x the longest reach).
        bone1: ``(3,)`` knee joint position in the thigh's frame (m).
        bone2: ``(3,)`` ankle joint position relative to the knee at zero flexion, in the
            thigh's frame (m).
        axis: ``(3,)`` unit knee hinge axis in the thigh's frame.
        pole: ``(3,)`` world direction the knee should point to (e.g. the desired heading).
        flexion_sign: +1 when the knee flexes to positive angles, -1 otherwise.
    Returns:
        ``(R_thigh, q)``: the thigh's world orientation ``(3, 3)`` and the knee angle (rad).
    """
    hip = np.asarray(hip, dtype=float)
    b1 = np.asarray(bone1, dtype=float)
    b2 = np.asarray(bone2, dtype=float)
    a = _unit(np.asarray(axis, dtype=float))
    r = np.asarray(target, dtype=float) - hip
    D = math.sqrt(float(r @ r))
    if not math.isfinite(D):
        raise SwingError("hinge_leg_ik: non-finite hip or target")
    ab1, ab2 = float(a @ b1), float(a @ b2)
    A = float(b1 @ b2) - ab1 * ab2
    B = float(b1 @ cross(a, b2))
    C = ab1 * ab2
    R0 = math.hypot(A, B)
    base = float(b1 @ b1 + b2 @ b2) + 2.0 * C
    lo = max(min_reach, math.sqrt(max(base - 2.0 * R0, 0.0)) + 1e-6)
    hi = max_extension * math.sqrt(max(base + 2.0 * R0, 0.0))
    r_hat = r / D if D > 1e-9 else np.array([0.0, 0.0, -1.0])
    D = min(max(D, lo), hi)
    phi = math.atan2(B, A)
    c = (0.5 * (D * D - base)) / R0 if R0 > 1e-12 else 1.0
    q = phi + flexion_sign * math.acos(min(max(c, -1.0), 1.0))
    p = b1 + rotation_about(a, q) @ b2                       # hip -> ankle, thigh frame
    side = np.asarray(pole, dtype=float)
    if abs(float(_unit(side) @ r_hat)) > 0.999:  # pole along the leg: any perpendicular will do
        side = np.array([1.0, 0.0, 0.0]) if abs(r_hat[0]) < 0.9 else np.array([0.0, 0.0, 1.0])
    R_thigh = frame_from_axes(r_hat, side) @ frame_from_axes(p, b1).T
    return R_thigh, q
